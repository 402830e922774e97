//! Folds of the moving mesh, told apart from the balloon meeting itself.
//!
//! The contact search (paper, section 3) finds every pair of intersecting triangles. Most pairs
//! on a growing vessel are not two parts of the balloon meeting: they lie a few rings apart on
//! the surface, where an explicit step of three quarters of a voxel turned a thin triangle of
//! the front over its neighbours (on the vmtk aorta every contact before this rule lay 0–4
//! rings apart, and each one froze the whole front and cost a re-parametrisation). A fold is
//! a defect of the mesh, not of the topology, so it is relaxed instead of frozen: the patch
//! around the pair (two rings) is smoothed by the umbrella operator, which pulls each vertex
//! towards its neighbours and unfolds the patch while keeping it a disc, and it moves on. Its
//! vertices that the smoothing moved where the balloon may not go freeze at the border. Pairs
//! further apart on the surface than `LOCAL_RINGS` — the balloon meeting itself — are frozen as
//! the paper says.

use std::collections::{BTreeSet, HashSet};

use glam::DVec3;

use crate::balloon::fast_hash::FastHash;
use crate::balloon::surface::{Surface, VertexState};

/// Two intersecting triangles at most this many rings apart on the surface are a fold.
pub(in crate::balloon) const LOCAL_RINGS: usize = 6;
/// Rings around a fold's triangles that are smoothed with it.
const PATCH_RINGS: usize = 2;
/// Umbrella passes over the patch, each moving a vertex half-way to its neighbours' centroid.
const PASSES: usize = 5;

/// Whether the triangles `a` and `b` (corners) are at most [`LOCAL_RINGS`] rings apart.
pub(in crate::balloon) fn is_fold(surface: &Surface, a: [u32; 3], b: [u32; 3]) -> bool {
    let mut seen: HashSet<u32, FastHash> = a.iter().copied().collect();
    let mut ring: Vec<u32> = a.to_vec();
    for _ in 0..=LOCAL_RINGS {
        if b.iter().any(|v| seen.contains(v)) {
            return true;
        }
        ring = ring
            .iter()
            .flat_map(|&v| surface.neighbours(v))
            .filter(|&n| seen.insert(n))
            .collect();
    }
    false
}

/// Smooths the patch around the folds' corners `folded`: every vertex within [`PATCH_RINGS`]
/// rings except those frozen by a self-intersection, the patch's rim held. Afterwards a
/// patch vertex moves on where `passable`, and is frozen at the border elsewhere.
pub(in crate::balloon) fn relax(
    surface: &mut Surface,
    folded: &BTreeSet<u32>,
    passable: impl Fn(DVec3) -> bool,
) {
    let patch: Vec<u32> = surface
        .neighbourhood(folded.iter().copied(), PATCH_RINGS)
        .into_iter()
        .filter(|&v| surface.states()[v as usize] != VertexState::FrozenBySelfIntersection)
        .collect();
    let rings = surface.rings(&patch);
    for _ in 0..PASSES {
        surface.umbrella_pass(&patch, &rings, 0.5);
    }
    for &v in &patch {
        let p = surface.positions()[v as usize];
        surface.states_mut()[v as usize] = if passable(p) {
            VertexState::Moving
        } else {
            VertexState::FrozenAtBorder
        };
        // Frozen triangles around it moved: the contact search must enter them again.
        let fan: Vec<u32> = surface.outgoing_half_edges(v).map(|h| h / 3).collect();
        for t in fan {
            surface.note_rewritten(t);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn neighbours_are_a_fold_and_the_far_side_is_not() {
        let s = Surface::icosphere(DVec3::ZERO, 10.0, 4).unwrap();
        let tri = |t: u32| s.triangle(t).unwrap();
        let first = tri(0);
        let near = s
            .triangles()
            .find(|(_, t)| t.iter().any(|v| first.contains(v)) && *t != first)
            .unwrap()
            .1;
        assert!(is_fold(&s, first, near));
        // The antipodal triangle is half the sphere away.
        let centre = |t: [u32; 3]| t.iter().map(|&v| s.positions()[v as usize]).sum::<DVec3>();
        let far = s
            .triangles()
            .min_by(|a, b| {
                centre(a.1)
                    .dot(centre(first))
                    .total_cmp(&centre(b.1).dot(centre(first)))
            })
            .unwrap()
            .1;
        assert!(!is_fold(&s, first, far));
    }

    #[test]
    fn relaxing_a_turned_over_vertex_unfolds_its_patch() {
        let mut s = Surface::icosphere(DVec3::ZERO, 5.0, 3).unwrap();
        // Push a vertex through the sphere's centre: its fan turns over.
        let v = 0u32;
        let p = s.positions()[v as usize];
        s.positions_mut()[v as usize] = -0.2 * p;
        let folded_before = folded_edges(&s);
        assert!(folded_before > 0);
        relax(&mut s, &BTreeSet::from([v]), |_| true);
        assert_eq!(folded_edges(&s), 0);
        assert!(s.states().iter().all(|&st| st == VertexState::Moving));
        s.check_invariants().unwrap();
    }

    /// Edges whose two triangles face more than 90° apart.
    fn folded_edges(s: &Surface) -> usize {
        let p = s.positions();
        s.edges()
            .filter(|e| {
                let [a, b, c, d] = [e.a, e.b, e.c, e.d].map(|v| p[v as usize]);
                (b - a).cross(c - a).dot((a - b).cross(d - b)) < 0.0
            })
            .count()
    }
}
