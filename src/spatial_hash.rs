//! Broad phase for self-intersection: every pair of overlapping axis-aligned boxes, found by the
//! spatial hashing of Teschner et al., "Optimized Spatial Hashing for Collision Detection of
//! Deformable Objects" (VMV 2003).
//!
//! Space is cut into cubic cells whose size is the mean box extent (the paper's finding: cells
//! about the size of the objects work best). Only occupied cells are stored: every box is
//! entered into each cell its extent overlaps, and a cell's integer coordinates are hashed into a
//! table with about one bucket per entry. The table is filled by a counting sort, so a bucket is
//! a contiguous slice and the construction allocates nothing per cell.
//!
//! Two boxes that overlap share several cells; the pair is examined only in the cell holding
//! the lower corner of their overlap, which both boxes cover. So each pair is tested exactly
//! once without a global set of visited pairs, and buckets are processed in parallel. The result
//! is sorted, hence independent of the number of threads.
//!
//! A box much larger than the cells would enter a huge number of them. Boxes covering more than
//! `MAX_CELLS_PER_BOX` cells are deferred to a coarser level whose cell size is the deferred
//! boxes' mean extent; there only pairs involving a deferred box are examined (the boxes already
//! handled are looked up in the coarser table, not entered into it). Every deferred box spans
//! more than two cells along some axis, so each level's cells are more than twice as large as the
//! previous level's: the number of levels is below log2(largest / smallest extent) and the table
//! never holds more than `MAX_CELLS_PER_BOX` entries per box.

use glam::DVec3;
use rayon::prelude::*;

/// A closed axis-aligned box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    pub lo: DVec3,
    pub hi: DVec3,
}

impl Aabb {
    pub fn of_triangle(corners: [DVec3; 3]) -> Aabb {
        let [a, b, c] = corners;
        Aabb {
            lo: a.min(b).min(c),
            hi: a.max(b).max(c),
        }
    }

    /// Whether the closed boxes share a point (touching counts).
    #[inline]
    pub fn overlaps(&self, other: &Aabb) -> bool {
        self.lo.cmple(other.hi).all() && other.lo.cmple(self.hi).all()
    }

    fn max_extent(&self) -> f64 {
        (self.hi - self.lo).max_element()
    }
}

/// A box covering no more than 3 cells along each axis stays at the current level.
const MAX_CELLS_PER_BOX: i64 = 27;

/// Every pair (a, b) with a < b of ids whose boxes overlap and for which `accept(a, b)` holds,
/// sorted. `accept` is called exactly once for each overlapping pair, from several threads.
/// Ids are the first element of each item and must be distinct.
pub fn overlapping_pairs<F>(items: &[(u32, Aabb)], accept: F) -> Vec<(u32, u32)>
where
    F: Fn(u32, u32) -> bool + Sync,
{
    let Some(origin) = items.iter().map(|(_, b)| b.lo).reduce(DVec3::min) else {
        return Vec::new();
    };
    let level = |cell_size: f64, primary: &[u32], settled: &[u32]| {
        Level::new(items, Grid::new(origin, cell_size), primary).pairs(settled, &accept)
    };
    // Positions in `items`: boxes still to place, and those placed at a finer level.
    let mut pending: Vec<u32> = (0..items.len() as u32).collect();
    let mut settled: Vec<u32> = Vec::new();
    let mut pairs = Vec::new();
    while !pending.is_empty() {
        let cell_size = mean_extent(items, &pending);
        let grid = Grid::new(origin, cell_size);
        let (fits, deferred): (Vec<u32>, Vec<u32>) = pending
            .par_iter()
            .partition(|&&i| grid.cell_count(&items[i as usize].1) <= MAX_CELLS_PER_BOX);
        if fits.is_empty() {
            // Only when extents or coordinates are too extreme for a grid (infinite mean
            // extent, cell coordinates beyond i32): one cell holding everything.
            pairs.extend(level(f64::INFINITY, &pending, &settled));
            break;
        }
        pairs.extend(level(cell_size, &fits, &settled));
        settled.extend(fits);
        pending = deferred;
    }
    pairs.par_sort_unstable();
    pairs
}

/// The mean of the boxes' largest side, or infinity when that is not a usable cell size.
fn mean_extent(items: &[(u32, Aabb)], positions: &[u32]) -> f64 {
    let n = positions.len() as f64;
    let mean: f64 = positions
        .par_iter()
        .map(|&i| items[i as usize].1.max_extent() / n)
        .sum();
    if mean.is_finite() && mean > 0.0 {
        mean
    } else {
        f64::INFINITY
    }
}

/// Integer cell coordinates of points for one cell size.
#[derive(Clone, Copy)]
struct Grid {
    origin: DVec3,
    inverse_size: f64,
}

type Cell = [i32; 3];

impl Grid {
    fn new(origin: DVec3, cell_size: f64) -> Grid {
        Grid {
            origin,
            inverse_size: 1.0 / cell_size,
        }
    }

    /// The cell holding `p`. Monotone in each coordinate (rounding and the saturating cast
    /// included), which is all the pair deduplication needs: the cell of the lower corner of two
    /// boxes' overlap is then covered by both boxes.
    #[inline]
    fn cell(&self, p: DVec3) -> Cell {
        let c = ((p - self.origin) * self.inverse_size).floor();
        [c.x as i32, c.y as i32, c.z as i32]
    }

    fn cell_count(&self, b: &Aabb) -> i64 {
        let (lo, hi) = (self.cell(b.lo), self.cell(b.hi));
        (0..3).map(|k| hi[k] as i64 - lo[k] as i64 + 1).product()
    }

    fn cells(&self, b: &Aabb) -> impl Iterator<Item = Cell> {
        let (lo, hi) = (self.cell(b.lo), self.cell(b.hi));
        (lo[2]..=hi[2]).flat_map(move |k| {
            (lo[1]..=hi[1]).flat_map(move |j| (lo[0]..=hi[0]).map(move |i| [i, j, k]))
        })
    }
}

/// Teschner et al.'s hash of a cell (large primes, xor), spread over the table size by a
/// multiplicative (Fibonacci) mix and a multiply-shift range reduction.
#[inline]
fn bucket(cell: Cell, buckets: usize) -> usize {
    let [i, j, k] = cell.map(|c| c as i64 as u64);
    let h = i.wrapping_mul(73_856_093) ^ j.wrapping_mul(19_349_663) ^ k.wrapping_mul(83_492_791);
    let mixed = h.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    ((mixed as u128 * buckets as u128) >> 64) as usize
}

#[derive(Clone, Copy, Default)]
struct Entry {
    cell: Cell,
    /// Position of the box in `items`.
    item: u32,
}

/// The hash table of one level, holding its primary boxes.
struct Level<'a> {
    items: &'a [(u32, Aabb)],
    grid: Grid,
    /// `table[starts[b]..starts[b + 1]]` is bucket b.
    starts: Vec<usize>,
    table: Vec<Entry>,
}

impl<'a> Level<'a> {
    fn new(items: &'a [(u32, Aabb)], grid: Grid, primary: &[u32]) -> Level<'a> {
        let entries: Vec<Entry> = primary
            .par_iter()
            .flat_map_iter(|&item| {
                grid.cells(&items[item as usize].1)
                    .map(move |cell| Entry { cell, item })
            })
            .collect();
        let buckets = entries.len().max(1);
        let of_entry: Vec<usize> = entries
            .par_iter()
            .map(|e| bucket(e.cell, buckets))
            .collect();
        let mut starts = vec![0usize; buckets + 1];
        for &b in &of_entry {
            starts[b + 1] += 1;
        }
        for b in 0..buckets {
            starts[b + 1] += starts[b];
        }
        let mut next = starts.clone();
        let mut table = vec![Entry::default(); entries.len()];
        for (e, &b) in entries.iter().zip(&of_entry) {
            table[next[b]] = *e;
            next[b] += 1;
        }
        Level {
            items,
            grid,
            starts,
            table,
        }
    }

    fn bucket_entries(&self, b: usize) -> &[Entry] {
        &self.table[self.starts[b]..self.starts[b + 1]]
    }

    /// Accepted overlapping pairs among the primary boxes, and between them and `settled`.
    fn pairs<F>(&self, settled: &[u32], accept: &F) -> Vec<(u32, u32)>
    where
        F: Fn(u32, u32) -> bool + Sync,
    {
        let buckets = self.starts.len() - 1;
        let within =
            (0..buckets)
                .into_par_iter()
                .with_min_len(1024)
                .fold(Vec::new, |mut out, b| {
                    let entries = self.bucket_entries(b);
                    for (x, e) in entries.iter().enumerate() {
                        for f in &entries[x + 1..] {
                            if e.cell == f.cell {
                                self.test(e.item, f.item, e.cell, accept, &mut out);
                            }
                        }
                    }
                    out
                });
        let across = settled
            .par_iter()
            .with_min_len(256)
            .fold(Vec::new, |mut out, &item| {
                for cell in self.grid.cells(&self.items[item as usize].1) {
                    for e in self.bucket_entries(bucket(cell, buckets)) {
                        if e.cell == cell {
                            self.test(item, e.item, cell, accept, &mut out);
                        }
                    }
                }
                out
            });
        within.chain(across).reduce(Vec::new, |mut a, mut b| {
            a.append(&mut b);
            a
        })
    }

    /// Tests the pair of boxes at positions `x` and `y`, met in `cell`, if this is the cell that
    /// owns the pair.
    #[inline]
    fn test<F>(&self, x: u32, y: u32, cell: Cell, accept: &F, out: &mut Vec<(u32, u32)>)
    where
        F: Fn(u32, u32) -> bool,
    {
        let (a, box_a) = self.items[x as usize];
        let (b, box_b) = self.items[y as usize];
        if box_a.overlaps(&box_b) && self.grid.cell(box_a.lo.max(box_b.lo)) == cell {
            let pair = (a.min(b), a.max(b));
            if accept(pair.0, pair.1) {
                out.push(pair);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    fn brute_force(items: &[(u32, Aabb)]) -> Vec<(u32, u32)> {
        let mut pairs = Vec::new();
        for (x, (a, ba)) in items.iter().enumerate() {
            for (b, bb) in &items[x + 1..] {
                if ba.overlaps(bb) {
                    pairs.push((*a.min(b), *a.max(b)));
                }
            }
        }
        pairs.sort_unstable();
        pairs
    }

    /// Random boxes from a xorshift generator; sizes spread over `decades` powers of ten.
    fn random_boxes(n: usize, decades: f64, seed: u64) -> Vec<(u32, Aabb)> {
        let mut state = seed;
        let mut uniform = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n)
            .map(|i| {
                let lo = DVec3::new(uniform(), uniform(), uniform()) * 100.0;
                let size = 10f64.powf(decades * uniform() - decades + 0.5);
                let extent = DVec3::new(uniform(), uniform(), uniform()) * size;
                // Ids deliberately not in item order.
                let id = (i as u32).wrapping_mul(2_654_435_761) % 1_000_003;
                (
                    id,
                    Aabb {
                        lo,
                        hi: lo + extent,
                    },
                )
            })
            .collect()
    }

    fn check_against_brute_force(items: &[(u32, Aabb)]) {
        let calls = AtomicUsize::new(0);
        let pairs = overlapping_pairs(items, |_, _| {
            calls.fetch_add(1, Ordering::Relaxed);
            true
        });
        let expected = brute_force(items);
        assert_eq!(pairs, expected);
        assert_eq!(
            calls.load(Ordering::Relaxed),
            expected.len(),
            "one call per pair"
        );
    }

    #[test]
    fn uniform_boxes_match_brute_force() {
        check_against_brute_force(&random_boxes(2000, 0.3, 1));
    }

    #[test]
    fn boxes_of_very_different_sizes_match_brute_force() {
        // Sizes from 0.003 to 300 across a 100-wide region: several levels.
        check_against_brute_force(&random_boxes(2000, 5.0, 7));
    }

    #[test]
    fn touching_and_identical_boxes_count_as_overlapping() {
        let unit = |lo: DVec3| Aabb {
            lo,
            hi: lo + DVec3::ONE,
        };
        let items = vec![
            (0, unit(DVec3::ZERO)),
            (1, unit(DVec3::X)),
            (2, unit(DVec3::ZERO)),
            (3, unit(DVec3::splat(1f64.next_up()))),
            (4, unit(DVec3::ONE)),
        ];
        let pairs = overlapping_pairs(&items, |_, _| true);
        assert_eq!(pairs, brute_force(&items));
        assert!(pairs.contains(&(0, 4)) && pairs.contains(&(0, 2)));
        assert!(!pairs.contains(&(0, 3)));
    }

    #[test]
    fn a_box_covering_millions_of_cells_is_deferred_to_a_coarser_level() {
        // 10^4 unit boxes on a plane and one box a million times larger, which would cover
        // about 10^8 cells of the fine level.
        let mut items: Vec<(u32, Aabb)> = (0..10_000u32)
            .map(|i| {
                let lo = DVec3::new((i % 100) as f64 * 1.5, (i / 100) as f64 * 1.5, 0.0);
                (
                    i,
                    Aabb {
                        lo,
                        hi: lo + DVec3::ONE,
                    },
                )
            })
            .collect();
        let huge = Aabb {
            lo: DVec3::splat(-1.0e6),
            hi: DVec3::new(1.0e6, 1.0e6, 0.5),
        };
        items.push((10_000, huge));
        let pairs = overlapping_pairs(&items, |_, _| true);
        assert_eq!(pairs.len(), 10_000);
        assert!(pairs.iter().all(|&(_, b)| b == 10_000));
    }

    #[test]
    fn accept_filters_pairs_and_result_is_sorted() {
        let items = random_boxes(500, 0.5, 3);
        let pairs = overlapping_pairs(&items, |a, b| (a + b) % 3 == 0);
        let expected: Vec<_> = brute_force(&items)
            .into_iter()
            .filter(|(a, b)| (a + b) % 3 == 0)
            .collect();
        assert_eq!(pairs, expected);
    }

    #[test]
    fn empty_and_single_inputs() {
        assert!(overlapping_pairs(&[], |_, _| true).is_empty());
        let one = [(5, Aabb::of_triangle([DVec3::ZERO, DVec3::X, DVec3::Y]))];
        assert!(overlapping_pairs(&one, |_, _| true).is_empty());
    }

    #[test]
    fn infinite_extents_fall_back_to_one_cell() {
        let huge = Aabb {
            lo: DVec3::splat(-f64::MAX),
            hi: DVec3::splat(f64::MAX),
        };
        let small = Aabb {
            lo: DVec3::ZERO,
            hi: DVec3::ONE,
        };
        let items = [(0, huge), (1, small), (2, huge)];
        assert_eq!(overlapping_pairs(&items, |_, _| true), brute_force(&items));
    }
}
