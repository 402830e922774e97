//! A hierarchical grid of triangles' bounding boxes that triangles can enter and leave: the
//! local queries of the simplifier (which triangles lie near a collapse) while the mesh
//! changes and its triangles grow from the input's size to many times it.
//!
//! Level `l` has cubic cells `2^l` times the finest; a box enters the finest level whose cells
//! are at least as wide as its longest side, so it meets at most eight cells wherever it is. A
//! query visits, on each level that holds boxes, the cells its box meets, or the level's
//! occupied cells when those are fewer. Only occupied cells are stored, in a hash map per
//! level. A single uniform grid either keeps a late, large triangle in hundreds of cells or
//! in a list that every query copies, and a query wider than its cells visits all of them: on
//! a 1.3M-triangle isosurface, copying and sorting that list took half of the run. Boxes beyond
//! the coarsest level (non-finite or astronomically large coordinates) sit in a list that
//! every query returns.

use std::collections::HashMap;

use glam::DVec3;

use crate::allocation;
use crate::balloon::fast_hash::FastHash;
use crate::error::Result;

/// How many levels: cells from the finest up to 2^40 times it, far beyond any mesh.
const LEVELS: usize = 41;

/// The most cells one box enters; a box wider than the coarsest level's cells goes to the
/// oversized list.
const MAX_CELLS_PER_BOX: i64 = 8;

type Cells = HashMap<[i32; 3], Vec<u32>, FastHash>;

pub(super) struct TriangleGrid {
    finest: f64,
    levels: Vec<Cells>,
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
    /// A grid whose finest cells are `cell` mm wide (positive and finite).
    pub(super) fn new(cell: f64) -> TriangleGrid {
        TriangleGrid {
            finest: cell,
            levels: (0..LEVELS).map(|_| Cells::default()).collect(),
            oversized: Vec::new(),
        }
    }

    /// The level a box enters: the finest whose cells are as wide as the box's longest side.
    fn level_of(&self, b: &Bounds) -> usize {
        let side = (b.hi - b.lo).max_element() / self.finest;
        if side <= 1.0 {
            0
        } else if side.is_finite() {
            (side.log2().ceil() as usize).min(LEVELS - 1)
        } else {
            LEVELS - 1
        }
    }

    /// The cells of `level` a box meets, and how many there are (`None` beyond i64).
    fn cell_range(&self, level: usize, b: &Bounds) -> ([i32; 3], [i32; 3], Option<i64>) {
        let inverse_cell = 1.0 / (self.finest * (1u64 << level) as f64);
        let to_cell = |x: f64| (x * inverse_cell).floor().clamp(-1e9, 1e9) as i32;
        let lo = b.lo.to_array().map(to_cell);
        let hi = b.hi.to_array().map(to_cell);
        // Up to 2·10⁹ cells a side: the product can exceed i64, hence checked.
        let count = (0..3).try_fold(1i64, |n, k| {
            n.checked_mul(i64::from(hi[k]) - i64::from(lo[k]) + 1)
        });
        (lo, hi, count)
    }

    /// Where a box is kept: a level and its cells, or `None` for the oversized list.
    fn place(&self, b: &Bounds) -> Option<(usize, [i32; 3], [i32; 3])> {
        let level = self.level_of(b);
        let (lo, hi, count) = self.cell_range(level, b);
        count
            .is_some_and(|n| n <= MAX_CELLS_PER_BOX)
            .then_some((level, lo, hi))
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
        match self.place(b) {
            Some((level, lo, hi)) => Self::for_cells(lo, hi, |key| {
                self.levels[level].entry(key).or_default().push(id);
            }),
            None => self.oversized.push(id),
        }
    }

    /// `insert`, with the room for new cells allocated fallibly: for building a grid, whose
    /// cells grow with the mesh. (Once built, a collapse takes out about as many cells as it
    /// adds.)
    pub(super) fn try_insert(&mut self, id: u32, b: &Bounds) -> Result<()> {
        if let Some((level, _, _)) = self.place(b) {
            let cells = &mut self.levels[level];
            let room = MAX_CELLS_PER_BOX as usize;
            allocation::reserved::<([i32; 3], Vec<u32>)>(
                cells.try_reserve(room),
                cells.len() + room,
                "a grid's cells",
            )?;
        }
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
        match self.place(b) {
            Some((level, lo, hi)) => {
                let cells = &mut self.levels[level];
                Self::for_cells(lo, hi, |key| {
                    if let Some(list) = cells.get_mut(&key) {
                        take(list);
                        if list.is_empty() {
                            cells.remove(&key);
                        }
                    }
                })
            }
            None => take(&mut self.oversized),
        }
    }

    /// The triangles whose cells meet the box (a superset of those whose boxes overlap it),
    /// sorted and without repeats, in `out`.
    pub(super) fn query(&self, b: &Bounds, out: &mut Vec<u32>) {
        out.clear();
        out.extend_from_slice(&self.oversized);
        for (level, cells) in self.levels.iter().enumerate() {
            if cells.is_empty() {
                continue;
            }
            match self.cell_range(level, b) {
                (lo, hi, Some(count)) if count <= cells.len() as i64 => {
                    Self::for_cells(lo, hi, |key| {
                        if let Some(list) = cells.get(&key) {
                            out.extend_from_slice(list);
                        }
                    })
                }
                _ => cells.values().for_each(|list| out.extend_from_slice(list)),
            }
        }
        out.sort_unstable();
        out.dedup();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

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
        assert!(grid
            .levels
            .iter()
            .all(|cells| cells.values().all(|list| !list.contains(&7))));
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
    fn a_box_many_finest_cells_wide_enters_a_few_coarse_ones_and_only_queries_near_it_find_it() {
        let mut grid = TriangleGrid::new(0.01);
        let huge = Bounds {
            lo: DVec3::ZERO,
            hi: DVec3::splat(100.0),
        };
        grid.insert(3, &huge);
        let entered: usize = grid
            .levels
            .iter()
            .flat_map(|c| c.values())
            .map(Vec::len)
            .sum();
        assert!((1..=8).contains(&entered) && grid.oversized.is_empty());
        let mut found = Vec::new();
        grid.query(&unit_box_at(50.0), &mut found);
        assert_eq!(found, vec![3]);
        grid.query(&unit_box_at(-500.0), &mut found);
        assert!(found.is_empty());
        grid.remove(3, &huge);
        grid.query(&unit_box_at(50.0), &mut found);
        assert!(found.is_empty());
        assert!(grid.levels.iter().all(HashMap::is_empty));
    }

    /// A box somewhere in a 200 mm cube, its sides from a thousandth of a 1 mm cell to a
    /// thousand of them.
    fn any_box() -> impl Strategy<Value = Bounds> {
        (
            prop::array::uniform3(-100.0..100.0f64),
            prop::array::uniform3(0.0..1.0f64),
            -3.0..3.0f64,
        )
            .prop_map(|(centre, half, scale)| {
                let (centre, half) = (DVec3::from(centre), DVec3::from(half) * 10f64.powf(scale));
                Bounds {
                    lo: centre - half,
                    hi: centre + half,
                }
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn queries_return_every_overlapping_box_of_any_size_once_in_order(
            boxes in prop::collection::vec(any_box(), 1..400),
            queries in prop::collection::vec(any_box(), 1..40),
        ) {
            let mut grid = TriangleGrid::new(1.0);
            for (id, b) in boxes.iter().enumerate() {
                grid.try_insert(id as u32, b).unwrap();
            }
            for (id, b) in boxes.iter().enumerate().filter(|(id, _)| id % 3 == 0) {
                grid.remove(id as u32, b);
            }
            let mut found = Vec::new();
            for query in &queries {
                grid.query(query, &mut found);
                prop_assert!(found.windows(2).all(|w| w[0] < w[1]));
                for (id, b) in boxes.iter().enumerate() {
                    let present = found.binary_search(&(id as u32)).is_ok();
                    if id % 3 == 0 {
                        prop_assert!(!present, "{} was removed", id);
                    } else if b.overlaps(query) {
                        prop_assert!(present, "{} overlaps the query but was not found", id);
                    }
                }
            }
        }
    }
}
