//! Step 2 of the paper (section 3), contacts and freezing: every few steps the triangles of the
//! moving front that intersect the balloon (`search`) freeze their vertices and the rest of
//! their front; pairs a few rings apart on the surface are folds of the mesh, relaxed instead
//! (`untangle`).

pub(in crate::balloon) mod search;
pub(in crate::balloon) mod untangle;

use std::collections::BTreeSet;

use crate::balloon::progress::Phase;
use crate::balloon::segmenter::Segmenter;
use crate::balloon::surface::front::Front;
use crate::balloon::surface::VertexState;
use crate::error::Result;
use crate::self_intersection::self_intersections_among;
use search::{local_mesh, FrozenTriangles};

/// Cell size, in target edge lengths, of the grid that finds the triangles near the moving
/// front for the self-intersection search: about the size of a triangle's box.
const SEARCH_CELLS: f64 = 2.0;

impl Segmenter<'_, '_> {
    /// Starts the index of frozen triangles afresh, after the surface was replaced or
    /// compacted (slots renumbered).
    pub(super) fn index_surface(&mut self) {
        self.surface.record_rewrites();
        self.frozen = FrozenTriangles::new(&self.surface, SEARCH_CELLS * self.edge_length);
    }

    /// Freezes the vertices of every triangle that intersects another (paper, section 3), and
    /// the rest of each moving front that touched the balloon (frozen at the border, so that it
    /// does not grow on inside the balloon's own interior until re-parametrisation merges the
    /// lobes); returns how many vertices were newly frozen. Pairs a few rings apart on the
    /// surface are folds of the mesh, not contacts: their patch is relaxed instead
    /// (`untangle`).
    pub fn freeze_self_intersections(&mut self) -> Result<usize> {
        self.timed(Phase::SelfIntersection, |s| {
            let front = Front::of(&s.surface);
            let near = s.frozen.near(&mut s.surface, &front);
            let local = local_mesh(&s.surface, &near)?;
            let local_active: Vec<bool> = near
                .iter()
                .map(|t| front.triangles.binary_search(t).is_ok())
                .collect();
            let pairs = s
                .pool
                .install(|| self_intersections_among(&local, &local_active))?;
            let corners = |t: u32| {
                s.surface
                    .triangle(near[t as usize])
                    .expect("near triangles are live")
            };
            let corner_pairs: Vec<_> = pairs
                .iter()
                .map(|&(a, b)| (corners(a), corners(b)))
                .collect();
            let surface = &s.surface;
            let fold = s.pool.install(|| untangle::folds(surface, &corner_pairs));
            let (folds, contacts): (Vec<_>, Vec<_>) =
                pairs.iter().zip(fold).partition(|&(_, fold)| fold);
            let folds: Vec<(u32, u32)> = folds.into_iter().map(|(&p, _)| p).collect();
            let contacts: Vec<(u32, u32)> = contacts.into_iter().map(|(&p, _)| p).collect();
            let folded: BTreeSet<u32> = folds
                .iter()
                .flat_map(|&(a, b)| corners(a).into_iter().chain(corners(b)))
                .collect();
            let contacts: Vec<[u32; 3]> = contacts
                .iter()
                .flat_map(|&(a, b)| [corners(a), corners(b)])
                .collect();
            if !folded.is_empty() {
                let (image, border) = (&s.image, s.border);
                let surface = &mut s.surface;
                s.pool
                    .install(|| untangle::relax(surface, &folded, |p| border.passable(image, p)));
            }
            let mut frozen = 0;
            let mut fronts = Vec::new();
            for v in contacts.into_iter().flatten() {
                let state = &mut s.surface.states_mut()[v as usize];
                if *state != VertexState::FrozenBySelfIntersection {
                    *state = VertexState::FrozenBySelfIntersection;
                    frozen += 1;
                    fronts.push(v);
                }
            }
            frozen += s.freeze_fronts(fronts);
            Ok(frozen)
        })
    }

    /// Freezes every moving vertex connected through moving vertices to `seeds` — the rest of
    /// a front that met the balloon — as if at the border, so its triangles still shape the
    /// distance map. Left moving, the part of the front that passed the contact would go on
    /// inflating inside the balloon's own interior, along the whole structure (on the aorta,
    /// doubling the balloon's volume in overlapping lobes and making contacts all along).
    /// Re-parametrisation merges the lobes, and refinement lets the front move on where it is
    /// still inside the window.
    /// Returns how many vertices it froze.
    pub(super) fn freeze_fronts(&mut self, mut seeds: Vec<u32>) -> usize {
        let mut frozen = 0;
        while let Some(v) = seeds.pop() {
            let moving: Vec<u32> = self
                .surface
                .neighbours(v)
                .filter(|&n| self.surface.states()[n as usize] == VertexState::Moving)
                .collect();
            for n in moving {
                self.surface.states_mut()[n as usize] = VertexState::FrozenAtBorder;
                frozen += 1;
                seeds.push(n);
            }
        }
        frozen
    }

    pub(super) fn has_self_intersections(&self) -> bool {
        self.surface
            .states()
            .contains(&VertexState::FrozenBySelfIntersection)
    }
}
