//! Where the balloon can meet itself (paper, section 3): the triangles that a triangle of the
//! moving front may intersect, found without visiting the frozen rest of the balloon.
//!
//! Frozen triangles (no moving corner) keep their shape until remeshing rewrites them, which
//! the surface records (`Surface::record_rewrites`). So they are put in a uniform grid once,
//! when they freeze or are rewritten frozen, and a search only reads the grid cells the front
//! reaches. Entries are never removed: a slot that was rewritten, moved back into the front or
//! died keeps stale entries, which a search skips by checking the triangle as it is now.

use std::collections::{HashMap, HashSet};

use glam::{DVec3, I64Vec3};

use crate::balloon::fast_hash::FastHash;
use crate::balloon::surface::front::Front;
use crate::balloon::surface::Surface;
use crate::error::Result;
use crate::mesh::TriMesh;

/// The frozen triangles of a surface by grid cell.
#[derive(Debug, Default)]
pub(crate) struct FrozenTriangles {
    cell: f64,
    cells: HashMap<I64Vec3, Vec<u32>, FastHash>,
    /// The front's triangles at the last search: those of them frozen since must be entered.
    last_front: Vec<u32>,
}

impl FrozenTriangles {
    /// An index with cells of `cell` mm for a surface whose every triangle is entered now
    /// (after the surface was built or compacted); `surface` must record its rewrites from
    /// here on.
    pub fn new(surface: &Surface, cell: f64) -> FrozenTriangles {
        let mut index = FrozenTriangles {
            cell,
            ..FrozenTriangles::default()
        };
        let all: Vec<u32> = surface.triangles().map(|(t, _)| t).collect();
        index.enter(surface, all);
        index
    }

    /// The live triangles (slots, ascending) whose bounding boxes reach a grid cell that the
    /// box of one of the `front`'s triangles reaches: every triangle a front triangle can
    /// intersect, since two intersecting triangles' boxes overlap in some cell both reach.
    /// Brings the index up to date with the surface's rewrites first.
    pub fn near(&mut self, surface: &mut Surface, front: &Front) -> Vec<u32> {
        let mut changed = surface.take_rewritten();
        changed.append(&mut self.last_front);
        self.enter(surface, changed);
        self.last_front.clone_from(&front.triangles);

        let mut marked: HashSet<I64Vec3, FastHash> = HashSet::default();
        for &t in &front.triangles {
            let (lo, hi) = self.cell_range(surface, t);
            for_each_cell(lo, hi, |c| {
                marked.insert(c);
            });
        }
        let reaches_marked = |t: u32| {
            let (lo, hi) = self.cell_range(surface, t);
            let mut any = false;
            for_each_cell(lo, hi, |c| any = any || marked.contains(&c));
            any
        };
        let mut near = front.triangles.clone();
        for c in &marked {
            for &t in self.cells.get(c).into_iter().flatten() {
                if is_frozen(surface, t) && reaches_marked(t) {
                    near.push(t);
                }
            }
        }
        near.sort_unstable();
        near.dedup();
        near
    }

    /// Enters those of `triangles` that are live and frozen, in the cells of their boxes now.
    fn enter(&mut self, surface: &Surface, mut triangles: Vec<u32>) {
        triangles.sort_unstable();
        triangles.dedup();
        for t in triangles {
            if is_frozen(surface, t) {
                let (lo, hi) = self.cell_range(surface, t);
                for_each_cell(lo, hi, |c| self.cells.entry(c).or_default().push(t));
            }
        }
    }

    /// The grid cells, lowest and highest, that the box of the live triangle `t` reaches.
    fn cell_range(&self, surface: &Surface, t: u32) -> (I64Vec3, I64Vec3) {
        let [a, b, c] = surface.triangle_corners(t).expect("live triangle");
        let cell = |p: DVec3| (p / self.cell).floor().as_i64vec3();
        (cell(a.min(b).min(c)), cell(a.max(b).max(c)))
    }
}

/// Whether `t` is a live triangle without a moving corner.
fn is_frozen(surface: &Surface, t: u32) -> bool {
    surface.triangle(t).is_some_and(|tri| {
        tri.iter()
            .all(|&v| surface.states()[v as usize].is_frozen())
    })
}

fn for_each_cell(lo: I64Vec3, hi: I64Vec3, mut f: impl FnMut(I64Vec3)) {
    for z in lo.z..=hi.z {
        for y in lo.y..=hi.y {
            for x in lo.x..=hi.x {
                f(I64Vec3::new(x, y, z));
            }
        }
    }
}

/// The triangles `slots` of the surface as a mesh of their own, corners renumbered in order of
/// first use (so the same surface always gives the same mesh).
pub(crate) fn local_mesh(surface: &Surface, slots: &[u32]) -> Result<TriMesh> {
    let mut index: HashMap<u32, u32, FastHash> = HashMap::default();
    let mut points = Vec::new();
    let triangles = slots
        .iter()
        .map(|&t| {
            surface.triangle(t).expect("live triangle").map(|v| {
                *index.entry(v).or_insert_with(|| {
                    points.push(surface.positions()[v as usize]);
                    points.len() as u32 - 1
                })
            })
        })
        .collect();
    TriMesh::new(points, triangles)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::balloon::surface::VertexState;

    /// The triangles near the front by brute force: every live triangle whose box shares a
    /// grid cell with a front triangle's box.
    fn brute_force(surface: &Surface, front: &Front, cell: f64) -> Vec<u32> {
        let index = FrozenTriangles {
            cell,
            ..FrozenTriangles::default()
        };
        let cells = |t: u32| {
            let (lo, hi) = index.cell_range(surface, t);
            let mut all = Vec::new();
            for_each_cell(lo, hi, |c| all.push(c));
            all
        };
        let marked: Vec<I64Vec3> = front.triangles.iter().flat_map(|&t| cells(t)).collect();
        surface
            .triangles()
            .map(|(t, _)| t)
            .filter(|&t| cells(t).iter().any(|c| marked.contains(c)))
            .collect()
    }

    #[test]
    fn index_follows_freezing_and_remeshing_and_finds_what_brute_force_finds() {
        let mut s = Surface::icosphere(DVec3::ZERO, 4.0, 3).unwrap();
        for v in 0..s.vertex_slots() {
            if s.positions()[v].z < 2.0 {
                s.states_mut()[v] = VertexState::FrozenAtBorder;
            }
        }
        s.record_rewrites();
        let cell = 1.0;
        let mut index = FrozenTriangles::new(&s, cell);
        for round in 0..6 {
            let front = Front::of(&s);
            assert_eq!(
                index.near(&mut s, &front),
                brute_force(&s, &front, cell),
                "round {round}"
            );
            // Freeze a band of the front, then grow and remesh the rest.
            for v in 0..s.vertex_slots() {
                if s.positions()[v].z < 2.4 + 0.3 * round as f64 {
                    s.states_mut()[v] = VertexState::FrozenAtBorder;
                }
            }
            for v in Front::of(&s).vertices {
                s.positions_mut()[v as usize] *= 1.05;
            }
            s.split_long_edges(0.9).unwrap();
            s.collapse_short_edges(0.3, 0.9).unwrap();
            s.flip_edges_for_valence();
        }
    }
}
