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

use std::collections::BTreeSet;

use glam::DVec3;
use rayon::prelude::*;

use crate::balloon::surface::{Surface, VertexState};

/// Two intersecting triangles at most this many rings apart on the surface are a fold.
pub(in crate::balloon) const LOCAL_RINGS: usize = 6;
/// Rings around a fold's triangles that are smoothed with it.
const PATCH_RINGS: usize = 2;
/// Umbrella passes over the patch, each moving a vertex half-way to its neighbours' centroid.
const PASSES: usize = 5;

/// For each pair of triangles (corners), whether the two are at most [`LOCAL_RINGS`] rings
/// apart: a corner of the second within that many rings of a corner of the first. The pairs
/// of one first triangle share one walk of its rings: a balloon pressed flat against the
/// volume's faces intersects itself in thousands of pairs at once, and a walk per pair took
/// most of the run.
pub(in crate::balloon) fn folds(surface: &Surface, pairs: &[([u32; 3], [u32; 3])]) -> Vec<bool> {
    let mut order: Vec<usize> = (0..pairs.len()).collect();
    order.sort_unstable_by_key(|&i| (pairs[i].0, i));
    let groups: Vec<&[usize]> = order.chunk_by(|&i, &j| pairs[i].0 == pairs[j].0).collect();
    let vertices = surface.positions().len();
    let found: Vec<Vec<(usize, bool)>> = groups
        .par_iter()
        .map_init(
            || RingWalk::new(vertices),
            |walk, group| {
                // Ring by ring, until every second triangle is reached: most pairs are folds
                // a ring or two across.
                let mut answers = Vec::with_capacity(group.len());
                let mut pending = group.to_vec();
                walk.start(pairs[group[0]].0);
                for ring in 0..=LOCAL_RINGS {
                    if ring > 0 {
                        walk.next_ring(surface);
                    }
                    pending.retain(|&i| {
                        let reached = pairs[i].1.iter().any(|&v| walk.is_marked(v));
                        if reached {
                            answers.push((i, true));
                        }
                        !reached
                    });
                    if pending.is_empty() {
                        break;
                    }
                }
                answers.extend(pending.into_iter().map(|i| (i, false)));
                answers
            },
        )
        .collect();
    let mut fold = vec![false; pairs.len()];
    for (i, f) in found.into_iter().flatten() {
        fold[i] = f;
    }
    fold
}

/// The rings around a triangle, walked outwards: the vertices reached are marked with the
/// walk's number, so that the marks need no clearing between walks.
struct RingWalk {
    marks: Vec<u32>,
    walk: u32,
    ring: Vec<u32>,
    next: Vec<u32>,
}

impl RingWalk {
    fn new(vertices: usize) -> Self {
        RingWalk {
            marks: vec![0; vertices],
            walk: 0,
            ring: Vec::new(),
            next: Vec::new(),
        }
    }

    /// A new walk from the triangle `corners`: its corners are marked.
    fn start(&mut self, corners: [u32; 3]) {
        self.walk += 1;
        self.ring.clear();
        for v in corners {
            if !self.is_marked(v) {
                self.marks[v as usize] = self.walk;
                self.ring.push(v);
            }
        }
    }

    /// Marks the next ring.
    fn next_ring(&mut self, surface: &Surface) {
        self.next.clear();
        for &v in &self.ring {
            for n in surface.neighbours(v) {
                if self.marks[n as usize] != self.walk {
                    self.marks[n as usize] = self.walk;
                    self.next.push(n);
                }
            }
        }
        std::mem::swap(&mut self.ring, &mut self.next);
    }

    fn is_marked(&self, v: u32) -> bool {
        self.marks[v as usize] == self.walk
    }
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
        assert_eq!(folds(&s, &[(first, near)]), [true]);
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
        assert_eq!(folds(&s, &[(first, far)]), [false]);
        // Grouped or not, each pair gets its own answer.
        assert_eq!(
            folds(
                &s,
                &[(first, far), (near, first), (first, near), (far, far)]
            ),
            [false, true, true, true]
        );
    }

    #[test]
    fn a_fold_is_at_most_local_rings_apart() {
        // Along a strip of the icosphere: the vertex `LOCAL_RINGS` rings from a triangle's
        // corners makes a fold with it, one ring further does not.
        let s = Surface::icosphere(DVec3::ZERO, 10.0, 5).unwrap();
        let first = s.triangle(0).unwrap();
        let mut distance = vec![usize::MAX; s.positions().len()];
        let mut ring: Vec<u32> = first.to_vec();
        for &v in &ring {
            distance[v as usize] = 0;
        }
        for d in 1..=LOCAL_RINGS + 1 {
            ring = ring
                .iter()
                .flat_map(|&v| s.neighbours(v).collect::<Vec<_>>())
                .filter(|&n| {
                    let new = distance[n as usize] == usize::MAX;
                    if new {
                        distance[n as usize] = d;
                    }
                    new
                })
                .collect();
        }
        let at = |d: usize| {
            let v = (0..distance.len()).find(|&v| distance[v] == d).unwrap() as u32;
            s.triangles()
                .find(|(_, t)| t.contains(&v) && t.iter().all(|&u| distance[u as usize] >= d))
                .unwrap()
                .1
        };
        assert_eq!(
            folds(
                &s,
                &[(first, at(LOCAL_RINGS)), (first, at(LOCAL_RINGS + 1))]
            ),
            [true, false]
        );
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
