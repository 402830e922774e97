//! A uniform grid of triangles' bounding boxes that triangles can enter and leave: the local
//! queries of the simplifier (which triangles lie near a collapse) while the mesh changes.
//!
//! Only occupied cells are stored, in a hash map. A box that would enter more than
//! `MAX_CELLS_PER_BOX` cells (a large tilted triangle late in a simplification, or a sliver
//! from another tool's mesh) is kept in a short list of oversized boxes that every query scans
//! instead, so that no triangle's size makes the grid's memory or a query's time explode.

use std::collections::HashMap;

use glam::DVec3;

use crate::allocation;
use crate::balloon::fast_hash::FastHash;
use crate::error::Result;

/// The most cells one box enters; larger boxes go to the oversized list.
const MAX_CELLS_PER_BOX: i64 = 512;

pub(super) struct TriangleGrid {
    inverse_cell: f64,
    cells: HashMap<[i32; 3], Vec<u32>, FastHash>,
    oversized: Vec<u32>,
}

/// An axis-aligned box in f64.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Bounds {
    pub lo: DVec3,
    pub hi: DVec3,
}

impl Bounds {
    pub(super) fn of(corners: [DVec3; 3]) -> Bounds {
        let [a, b, c] = corners;
        Bounds {
            lo: a.min(b).min(c),
            hi: a.max(b).max(c),
        }
    }

    pub(super) fn grown(self, margin: f64) -> Bounds {
        Bounds {
            lo: self.lo - DVec3::splat(margin),
            hi: self.hi + DVec3::splat(margin),
        }
    }

    pub(super) fn overlaps(&self, o: &Bounds) -> bool {
        self.lo.cmple(o.hi).all() && o.lo.cmple(self.hi).all()
    }
}

impl TriangleGrid {
    /// A grid of cubic cells `cell` mm wide (positive and finite).
    pub(super) fn new(cell: f64) -> TriangleGrid {
        TriangleGrid {
            inverse_cell: 1.0 / cell,
            cells: HashMap::default(),
            oversized: Vec::new(),
        }
    }

    /// The cells a box covers, or `None` when there are more than `MAX_CELLS_PER_BOX`.
    fn cell_range(&self, b: &Bounds) -> Option<([i32; 3], [i32; 3])> {
        let to_cell = |x: f64| (x * self.inverse_cell).floor().clamp(-1e9, 1e9) as i32;
        let lo = b.lo.to_array().map(to_cell);
        let hi = b.hi.to_array().map(to_cell);
        // Up to 2·10⁹ cells a side: the product can exceed i64, hence checked.
        let count = (0..3).try_fold(1i64, |n, k| {
            n.checked_mul(i64::from(hi[k]) - i64::from(lo[k]) + 1)
        });
        count
            .is_some_and(|n| n <= MAX_CELLS_PER_BOX)
            .then_some((lo, hi))
    }

    fn for_cells(lo: [i32; 3], hi: [i32; 3], mut f: impl FnMut([i32; 3])) {
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    f([x, y, z]);
                }
            }
        }
    }

    pub(super) fn insert(&mut self, id: u32, b: &Bounds) {
        match self.cell_range(b) {
            Some((lo, hi)) => Self::for_cells(lo, hi, |key| {
                self.cells.entry(key).or_default().push(id);
            }),
            None => self.oversized.push(id),
        }
    }

    /// `insert`, with the room for new cells allocated fallibly: for building a grid, whose
    /// cells grow with the mesh. (Once built, a collapse takes out as many cells as it adds.)
    pub(super) fn try_insert(&mut self, id: u32, b: &Bounds) -> Result<()> {
        let cells = self.cell_range(b).map_or(0, |(lo, hi)| {
            (0..3).map(|k| (hi[k] - lo[k] + 1) as usize).product()
        });
        allocation::reserved::<([i32; 3], Vec<u32>)>(
            self.cells.try_reserve(cells),
            self.cells.len() + cells,
            "a grid's cells",
        )?;
        self.insert(id, b);
        Ok(())
    }

    /// Removes a triangle entered with the same bounds.
    pub(super) fn remove(&mut self, id: u32, b: &Bounds) {
        let take = |list: &mut Vec<u32>| {
            if let Some(k) = list.iter().position(|&x| x == id) {
                list.swap_remove(k);
            }
        };
        match self.cell_range(b) {
            Some((lo, hi)) => Self::for_cells(lo, hi, |key| {
                if let Some(list) = self.cells.get_mut(&key) {
                    take(list);
                    if list.is_empty() {
                        self.cells.remove(&key);
                    }
                }
            }),
            None => take(&mut self.oversized),
        }
    }

    /// The triangles whose cells meet the box (a superset of those whose boxes overlap it),
    /// sorted and without repeats, in `out`.
    pub(super) fn query(&self, b: &Bounds, out: &mut Vec<u32>) {
        out.clear();
        out.extend_from_slice(&self.oversized);
        match self.cell_range(b) {
            Some((lo, hi)) => Self::for_cells(lo, hi, |key| {
                if let Some(list) = self.cells.get(&key) {
                    out.extend_from_slice(list);
                }
            }),
            None => self
                .cells
                .values()
                .for_each(|list| out.extend_from_slice(list)),
        }
        out.sort_unstable();
        out.dedup();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_box_at(x: f64) -> Bounds {
        Bounds {
            lo: DVec3::splat(x),
            hi: DVec3::splat(x + 1.0),
        }
    }

    #[test]
    fn queries_find_what_was_entered_and_not_what_left() {
        let mut grid = TriangleGrid::new(1.0);
        grid.insert(7, &unit_box_at(0.5));
        grid.insert(9, &unit_box_at(10.0));
        let mut found = Vec::new();
        grid.query(&unit_box_at(1.2), &mut found);
        assert_eq!(found, vec![7]);
        grid.remove(7, &unit_box_at(0.5));
        grid.query(&unit_box_at(1.2), &mut found);
        assert!(found.is_empty());
        assert!(grid.cells.values().all(|list| !list.contains(&7)));
    }

    #[test]
    fn a_box_spanning_the_whole_coordinate_range_counts_its_cells_without_overflow() {
        let mut grid = TriangleGrid::new(1e-3);
        let everything = Bounds {
            lo: DVec3::splat(-1e300),
            hi: DVec3::splat(1e300),
        };
        grid.insert(1, &everything);
        let mut found = Vec::new();
        grid.query(&everything, &mut found);
        assert_eq!(found, vec![1]);
    }

    #[test]
    fn a_box_over_many_cells_is_kept_apart_and_found_by_every_query() {
        let mut grid = TriangleGrid::new(0.01);
        let huge = Bounds {
            lo: DVec3::ZERO,
            hi: DVec3::splat(100.0),
        };
        grid.insert(3, &huge);
        assert!(grid.cells.is_empty());
        let mut found = Vec::new();
        grid.query(&unit_box_at(-50.0), &mut found);
        assert_eq!(found, vec![3]);
        grid.remove(3, &huge);
        grid.query(&unit_box_at(-50.0), &mut found);
        assert!(found.is_empty());
    }
}
