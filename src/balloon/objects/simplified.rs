//! The segmentation's optional last step, the paper's "error preserving mesh simplification":
//! the objects' meshes reduced by `simplification::simplify`, all in one mesh so that no two
//! objects' simplified surfaces cross (the self-intersection check sees them all), then split
//! back into objects with their vertex states carried over.

use crate::balloon::surface::VertexState;
use crate::error::Result;
use crate::mesh::TriMesh;
use crate::simplification::{simplify, NO_VERTEX};

use super::SegmentedObject;

/// How settled a state is: a vertex merged from several takes the least settled one, so that a
/// region still moving (not converged, or leaking) stays visible after simplification.
fn settledness(state: VertexState) -> u8 {
    match state {
        VertexState::Moving => 0,
        VertexState::FrozenBySelfIntersection => 1,
        VertexState::FrozenAtBorder => 2,
    }
}

/// Replaces every object's mesh by its simplification within `max_error_mm` (both ways), with
/// its vertex states merged as `settledness` says. Errors as `simplify`; the objects are left
/// as they were then.
pub fn simplify_objects(objects: &mut [SegmentedObject], max_error_mm: f64) -> Result<()> {
    let Some(first) = objects.first() else {
        return Ok(());
    };
    let mut all = first.mesh.clone();
    for object in &objects[1..] {
        all.append(&object.mesh)?;
    }
    let simplified = simplify(&all, max_error_mm)?;
    let count = simplified.mesh.points().len();
    let mut owner = vec![usize::MAX; count];
    let mut state: Vec<Option<VertexState>> = vec![None; count];
    let mut offset = 0;
    for (k, object) in objects.iter().enumerate() {
        for (i, &s) in object.states.iter().enumerate() {
            let v = simplified.vertex_map[offset + i];
            if v == NO_VERTEX {
                continue;
            }
            owner[v as usize] = k;
            let slot = &mut state[v as usize];
            match slot {
                Some(old) if settledness(*old) <= settledness(s) => {}
                _ => *slot = Some(s),
            }
        }
        offset += object.mesh.points().len();
    }
    let (points, triangles) = (simplified.mesh.points(), simplified.mesh.triangles());
    let mut split = Vec::with_capacity(objects.len());
    for k in 0..objects.len() {
        let mut local = vec![NO_VERTEX; count];
        let (mut mine, mut states, mut corners) = (Vec::new(), Vec::new(), Vec::new());
        for t in triangles.iter().filter(|t| owner[t[0] as usize] == k) {
            corners.push(t.map(|v| {
                if local[v as usize] == NO_VERTEX {
                    local[v as usize] = mine.len() as u32;
                    mine.push(points[v as usize]);
                    states.push(state[v as usize].unwrap_or_default());
                }
                local[v as usize]
            }));
        }
        split.push((TriMesh::new(mine, corners)?, states));
    }
    for (object, (mesh, states)) in objects.iter_mut().zip(split) {
        object.mesh = mesh;
        object.states = states;
    }
    Ok(())
}
