//! The segmentation's optional last step, the paper's "error preserving mesh simplification":
//! the objects' meshes reduced by `simplification::simplify`, all in one mesh so that no two
//! objects' simplified surfaces cross (the self-intersection check sees them all), then split
//! back into objects with their vertex states carried over. One balloon's result
//! (`Segmenter::segment`) goes through the same [`simplify_with_states`].

use crate::balloon::surface::VertexState;
use crate::error::Result;
use crate::mesh::TriMesh;
use crate::simplification::{simplify_with_progress, Simplified, NO_VERTEX};

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

/// `mesh` simplified within `max_error_mm` (both ways), with the state of each of its
/// vertices: the least settled (`settledness`) of the input vertices merged into it, given one
/// state per input point in `states`. Progress and errors as `simplify_with_progress`.
pub(in crate::balloon) fn simplify_with_states(
    mesh: &TriMesh,
    states: &[VertexState],
    max_error_mm: f64,
    progress: impl FnMut(f64) -> bool,
) -> Result<(Simplified, Vec<VertexState>)> {
    let simplified = simplify_with_progress(mesh, max_error_mm, progress)?;
    let mut merged: Vec<Option<VertexState>> = vec![None; simplified.mesh.points().len()];
    for (&v, &s) in simplified.vertex_map.iter().zip(states) {
        if v == NO_VERTEX {
            continue;
        }
        let slot = &mut merged[v as usize];
        match slot {
            Some(old) if settledness(*old) <= settledness(s) => {}
            _ => *slot = Some(s),
        }
    }
    let merged = merged.into_iter().map(Option::unwrap_or_default).collect();
    Ok((simplified, merged))
}

/// Replaces every object's mesh by its simplification within `max_error_mm` (both ways), with
/// its vertex states merged as `settledness` says. Progress and errors as
/// `simplify_with_progress`; on an error (a cancel too) the objects are left as they were.
///
/// Simplified in one mesh, the objects cannot cross; the kernel keeps the bound per component,
/// so each object's result is within `max_error_mm` of its own balloon even where two objects
/// are closer than that.
pub fn simplify_objects(
    objects: &mut [SegmentedObject],
    max_error_mm: f64,
    progress: impl FnMut(f64) -> bool,
) -> Result<()> {
    let Some(first) = objects.first() else {
        return Ok(());
    };
    let mut all = first.mesh.clone();
    let mut states = first.states.clone();
    for object in &objects[1..] {
        all.append(&object.mesh)?;
        states.extend_from_slice(&object.states);
    }
    let (simplified, state) = simplify_with_states(&all, &states, max_error_mm, progress)?;
    let count = simplified.mesh.points().len();
    // A collapse never joins two components, so the input vertices merged into one output
    // vertex all belong to one object.
    let mut owner = vec![usize::MAX; count];
    let mut offset = 0;
    for (k, object) in objects.iter().enumerate() {
        let points = object.mesh.points().len();
        for &v in &simplified.vertex_map[offset..offset + points] {
            if v != NO_VERTEX {
                owner[v as usize] = k;
            }
        }
        offset += points;
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
                    states.push(state[v as usize]);
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
