//! Broad phase for self-intersection: every pair of overlapping axis-aligned boxes, by the
//! spatial hashing of Teschner et al., "Optimized Spatial Hashing for Collision Detection of
//! Deformable Objects" (VMV 2003).
//!
//! Space is cut into cubic cells whose size is about the mean box extent (the paper's finding:
//! cells about the size of the objects work best; see `CELL_SIZE_PER_EXTENT`). Only occupied
//! cells are stored: every box is entered into each cell its extent overlaps, and boxes meeting
//! in a cell are candidate pairs.
//!
//! Where Teschner et al. hash the cell coordinates into a table modulo its size, the table here
//! is the list of (cell key, box) entries sorted by key, the key being the cell's Morton
//! (Z-order) code: a hash without collisions whose order follows space. Each cell is a run of
//! the sorted list, and runs are visited in Morton order, so consecutive cells hold nearby boxes
//! and the search streams through memory; with a modulo hash, cells come in random order and
//! box tests miss the cache (measured several times slower on 0.3M–1.3M triangle meshes).
//! `spatial_order` lets callers store their boxes along the same curve.
//!
//! Boxes are kept in single precision, rounded outwards (`Aabb`): half the memory to stream
//! through, for a few more candidate pairs among boxes that nearly touch, which the caller's
//! exact test rejects as it would any other.
//!
//! Two boxes that overlap share several cells; the pair is examined only in the cell holding
//! the lower corner of their overlap, which both boxes cover. So each pair is tested exactly
//! once without a global set of visited pairs, and runs are processed in parallel. The result
//! is sorted, hence independent of the number of threads.
//!
//! A box much larger than the cells would enter a huge number of them. Boxes covering up to
//! `SMALL_BOX_CELLS` cells always enter the table; larger ones enter it too, smallest first, as
//! long as the table holds no more than `ENTRIES_PER_BOX` entries per box on average (a few long
//! slivers are cheaper to enter than to handle apart). The remaining boxes are deferred to a
//! coarser level whose cell size is their mean extent; there only pairs involving a deferred box
//! are examined (the boxes already handled are looked up in the coarser table, not entered into
//! it). Every deferred box spans more than two cells along some axis, so each level's cells are
//! more than twice as large as the previous level's: there are fewer levels than
//! log2(largest / smallest extent), and the table size stays proportional to the box count.

use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};

use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// A closed axis-aligned box in single precision, rounded outwards from the double-precision
/// box it stands for: it contains that box, so boxes that overlap in double precision overlap
/// here too (some that only touch or nearly touch may overlap only here). Half the size of a
/// double-precision box, which halves the memory the broad phase streams through; callers
/// decide candidate pairs exactly anyway.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    pub lo: Vec3,
    pub hi: Vec3,
}

impl Aabb {
    /// A single-precision box containing the box from `lo` to `hi`, a few ulps larger.
    ///
    /// Rounding to nearest moves a value by at most 2^-24 of its magnitude, or 2^-150 below
    /// the normal range; pushing it outwards by more than that first, in double precision,
    /// makes the rounded bound land outside. Values beyond the single-precision range become
    /// infinite, and are clamped on the side where that would cut the box.
    #[inline]
    pub fn new(lo: DVec3, hi: DVec3) -> Aabb {
        const RELATIVE: f64 = 1.0 / (1u64 << 23) as f64;
        // 2^-148, twice the smallest subnormal.
        const ABSOLUTE: f64 = 1.0 / (1u128 << 127) as f64 / (1u64 << 21) as f64;
        let lo = (lo - (lo.abs() * RELATIVE + ABSOLUTE)).as_vec3();
        let hi = (hi + (hi.abs() * RELATIVE + ABSOLUTE)).as_vec3();
        Aabb {
            lo: lo.min(Vec3::splat(f32::MAX)),
            hi: hi.max(Vec3::splat(f32::MIN)),
        }
    }

    pub fn of_triangle(corners: [DVec3; 3]) -> Aabb {
        let [a, b, c] = corners;
        Aabb::new(a.min(b).min(c), a.max(b).max(c))
    }

    /// Whether the closed boxes share a point (touching counts).
    #[inline]
    pub fn overlaps(&self, other: &Aabb) -> bool {
        self.lo.cmple(other.hi).all() && other.lo.cmple(self.hi).all()
    }

    fn max_extent(&self) -> f64 {
        (self.hi.as_dvec3() - self.lo.as_dvec3()).max_element()
    }
}

/// The cell size in mean box extents. Teschner et al. found one extent best when the table is
/// reused across time steps; here it is built for every query, and cells of two extents halve
/// the number of entries for only a few more candidate pairs per cell (measured about 10%
/// faster overall on 0.3M–1.3M triangle spheres).
const CELL_SIZE_PER_EXTENT: f64 = 2.0;

/// A box covering no more than 3 cells along each axis always stays at the current level.
const SMALL_BOX_CELLS: i64 = 27;
/// Larger boxes stay while the level's table holds at most this many entries per box.
const ENTRIES_PER_BOX: i64 = 8;

/// Every pair (i, j) with i < j of positions in `boxes` whose boxes overlap and for which
/// `accept(i, j)` holds, sorted; or `None` when there are more than `limit` such pairs. `accept`
/// is called at most once for each overlapping pair (exactly once when the result is `Some`),
/// from several threads.
///
/// The search stops soon after the pair beyond the limit is accepted, and never holds more
/// than `limit` pairs: boxes piled into one place have a pair for almost every two of them,
/// quadratically many. Whether the result is `None` depends only on the boxes and `accept`,
/// not on the threads: a search is cut short only once more than `limit` pairs are accepted.
///
/// Boxes are visited in Morton order: stored in `spatial_order`, they (and whatever data
/// `accept` reads by position) are accessed almost sequentially.
pub fn overlapping_pairs<F>(boxes: &[Aabb], limit: usize, accept: F) -> Option<Vec<(u32, u32)>>
where
    F: Fn(u32, u32) -> bool + Sync,
{
    let Some(all) = Summary::of(boxes.par_iter()) else {
        return Some(Vec::new());
    };
    let accepted = Accepted {
        accept,
        count: AtomicUsize::new(0),
        limit,
    };
    let grid = |cell_size: f64| Grid::over(&all, boxes.len(), cell_size);
    let level = |cell_size: f64, primary: &[u32], settled: &[u32], highest: DVec3| {
        Level::new(boxes, grid(cell_size), primary, highest).pairs(settled, &accepted)
    };
    // Positions of the boxes still to place, and of those placed at a finer level.
    let mut pending: Vec<u32> = (0..boxes.len() as u32).collect();
    let mut settled: Vec<u32> = Vec::new();
    let mut pairs = Vec::new();
    let mut summary = Some(all);
    while let Some(pending_summary) = summary {
        let cell_size = CELL_SIZE_PER_EXTENT * pending_summary.mean_extent;
        let grid = grid(cell_size);
        // A box at most 1.5 cells wide (rounding included) covers at most 3 cells along each
        // axis, hence at most `SMALL_BOX_CELLS`: on a mesh of even triangles, all of them.
        let (fits, deferred) = if pending_summary.max_extent <= 1.5 * cell_size {
            (std::mem::take(&mut pending), Vec::new())
        } else {
            split_by_size(boxes, &pending, &grid)
        };
        if fits.is_empty() {
            // Only when extents are too extreme for a grid (an infinite mean extent): one cell
            // holding everything.
            pairs.extend(level(f64::INFINITY, &pending, &settled, pending_summary.hi));
            break;
        }
        pairs.extend(level(cell_size, &fits, &settled, pending_summary.hi));
        settled.extend(fits);
        pending = deferred;
        summary = Summary::of(pending.par_iter().map(|&i| &boxes[i as usize]));
    }
    if accepted.exceeded() {
        return None;
    }
    pairs.par_sort_unstable();
    Some(pairs)
}

/// The caller's test of a pair, and the count of the pairs it accepted, shared by the threads
/// of one search, against the search's limit.
struct Accepted<F> {
    accept: F,
    count: AtomicUsize,
    limit: usize,
}

impl<F: Fn(u32, u32) -> bool> Accepted<F> {
    /// Whether the caller accepts the pair and it is within the limit, to be kept.
    #[inline]
    fn keep(&self, a: u32, b: u32) -> bool {
        (self.accept)(a, b) && self.count.fetch_add(1, Ordering::Relaxed) < self.limit
    }

    /// Whether more pairs than the limit were accepted: the search can stop.
    #[inline]
    fn exceeded(&self) -> bool {
        self.count.load(Ordering::Relaxed) > self.limit
    }
}

/// The positions of `boxes` ordered along the Morton (Z-order) curve through their lower
/// corners, on the first grid of `overlapping_pairs` refined 4 times: the order in which that
/// search visits them. (The alignment matters: ordered on an unrelated grid, the same boxes
/// were searched about half as fast.)
pub fn spatial_order(boxes: &[Aabb]) -> Vec<u32> {
    let Some(all) = Summary::of(boxes.par_iter()) else {
        return Vec::new();
    };
    let grid = Grid::over(
        &all,
        boxes.len(),
        CELL_SIZE_PER_EXTENT * all.mean_extent / 4.0,
    );
    let corners = LowerCorners { boxes, grid };
    sorted_entries(grid.last_entry(all.hi), &corners)
        .into_iter()
        .map(|e| grid.packing.item(e))
        .collect()
}

/// What the grids need to know of a set of boxes, gathered in one pass over them.
#[derive(Clone, Copy)]
struct Summary {
    /// The lowest and highest corner of all boxes.
    lo: DVec3,
    hi: DVec3,
    /// The mean of the boxes' largest side, or infinity when that is not a usable cell size.
    mean_extent: f64,
    /// The largest side of all boxes.
    max_extent: f64,
}

impl Summary {
    /// `None` for no boxes. Summed in fixed chunks, so that the mean does not depend on the
    /// thread count.
    fn of<'b>(boxes: impl IndexedParallelIterator<Item = &'b Aabb>) -> Option<Summary> {
        let n = boxes.len() as f64;
        let parts: Vec<Summary> = boxes
            .chunks(4096)
            .map(|chunk| {
                let mut part = Summary {
                    lo: DVec3::INFINITY,
                    hi: DVec3::NEG_INFINITY,
                    mean_extent: 0.0,
                    max_extent: 0.0,
                };
                for b in chunk {
                    part.lo = part.lo.min(b.lo.as_dvec3());
                    part.hi = part.hi.max(b.hi.as_dvec3());
                    let extent = b.max_extent();
                    part.mean_extent += extent / n;
                    part.max_extent = part.max_extent.max(extent);
                }
                part
            })
            .collect();
        let mut all = *parts.first()?;
        for part in &parts[1..] {
            all.lo = all.lo.min(part.lo);
            all.hi = all.hi.max(part.hi);
            all.mean_extent += part.mean_extent;
            all.max_extent = all.max_extent.max(part.max_extent);
        }
        if !(all.mean_extent.is_finite() && all.mean_extent > 0.0) {
            all.mean_extent = f64::INFINITY;
        }
        Some(all)
    }
}

/// The boxes that enter the level's table, and those deferred to a coarser level.
fn split_by_size(boxes: &[Aabb], pending: &[u32], grid: &Grid) -> (Vec<u32>, Vec<u32>) {
    let counts: Vec<i64> = pending
        .par_iter()
        .map(|&i| grid.cell_count(&boxes[i as usize]))
        .collect();
    let mut fits = Vec::with_capacity(pending.len());
    let mut large = Vec::new();
    let mut entries = 0;
    for (&i, &count) in pending.iter().zip(&counts) {
        if count <= SMALL_BOX_CELLS {
            fits.push(i);
            entries += count;
        } else {
            large.push((count, i));
        }
    }
    large.sort_unstable();
    let budget = ENTRIES_PER_BOX.saturating_mul(pending.len() as i64);
    let admitted = large
        .iter()
        .take_while(|&&(count, _)| {
            entries = entries.saturating_add(count);
            entries <= budget
        })
        .count();
    fits.extend(large[..admitted].iter().map(|&(_, i)| i));
    let deferred = large[admitted..].iter().map(|&(_, i)| i).collect();
    (fits, deferred)
}

/// Integer cell coordinates of points for one cell size, and the layout of the entries that
/// name the cells.
#[derive(Clone, Copy)]
struct Grid {
    origin: DVec3,
    inverse_size: f64,
    packing: Packing,
    /// `packing.axis_max()`, kept for `cell`, the innermost call of the table's making.
    axis_max: u32,
}

type Cell = [u32; 3];

/// A Morton key of 64 bits holds three coordinates of this many bits.
const MORTON_AXIS_BITS: u32 = 21;

impl Grid {
    /// Cells of `cell_size` from `origin`, for points up to `span` beyond it along each axis,
    /// named by entries laid out as `packing` says. Where that would be more cells along an
    /// axis than the entries can name, the cells are made larger instead (correct either way,
    /// but coordinates clamped at the last cell would pile its slab of boxes into it).
    fn new(origin: DVec3, cell_size: f64, span: f64, packing: Packing) -> Grid {
        let axis_max = packing.axis_max();
        Grid {
            origin,
            inverse_size: (1.0 / cell_size).min(f64::from(axis_max) / span),
            packing,
            axis_max,
        }
    }

    /// The cell holding `p`, which must not be below the origin. Monotone in each coordinate
    /// (rounding, the saturating cast and the clamp included), which is all the pair
    /// deduplication needs: the cell of the lower corner of two boxes' overlap is then covered
    /// by both boxes.
    #[inline]
    fn cell(&self, p: DVec3) -> Cell {
        // Non-negative, so truncation is the floor; NaN (infinite size and distance) gives 0.
        let c = (p - self.origin) * self.inverse_size;
        [c.x, c.y, c.z].map(|x| (x as u32).min(self.axis_max))
    }

    /// The Morton code of a cell: the bits of its three coordinates interleaved.
    #[inline]
    fn key(cell: Cell) -> u64 {
        spread(cell[0]) | spread(cell[1]) << 1 | spread(cell[2]) << 2
    }

    /// Cells of `cell_size` from the lowest corner of the `count` boxes that `all` summarises.
    fn over(all: &Summary, count: usize, cell_size: f64) -> Grid {
        let span = (all.hi - all.lo).max_element();
        Grid::new(all.lo, cell_size, span, Packing::for_boxes(count))
    }

    /// An entry at least as large as that of any box in any cell up to the cell of `p`.
    fn last_entry(&self, p: DVec3) -> Entry {
        self.packing.entry(
            Grid::key(self.cell(p)),
            0b111,
            u32::MAX >> (32 - self.packing.item_bits),
        )
    }

    fn cell_count(&self, b: &Aabb) -> i64 {
        let (lo, hi) = (self.cell(b.lo.as_dvec3()), self.cell(b.hi.as_dvec3()));
        (0..3)
            .map(|k| i64::from(hi[k]) - i64::from(lo[k]) + 1)
            .fold(1, i64::saturating_mul)
    }

    /// Calls `f` with the key of each cell the box overlaps, and the axes (bits 0, 1, 2 for
    /// x, y, z) along which that cell is the box's first.
    #[inline]
    fn for_each_cell(&self, b: &Aabb, mut f: impl FnMut(u64, u8)) {
        let (lo, hi) = (self.cell(b.lo.as_dvec3()), self.cell(b.hi.as_dvec3()));
        // The keys of successive cells by adding one in the bits of one axis, rather than
        // spreading every coordinate anew. (Exclusive ranges: `hi` is at most `axis_max`, and
        // inclusive ones compile to slower loops.)
        let (x0, y0) = (spread(lo[0]), spread(lo[1]) << 1);
        let mut z = spread(lo[2]) << 2;
        for k in lo[2]..hi[2] + 1 {
            let z_first = u8::from(k == lo[2]) << 2;
            let mut y = y0;
            for j in lo[1]..hi[1] + 1 {
                let yz_first = z_first | u8::from(j == lo[1]) << 1;
                let mut x = x0;
                for i in lo[0]..hi[0] + 1 {
                    f(x | y | z, yz_first | u8::from(i == lo[0]));
                    x = next_on_axis(x, AXIS_BITS);
                }
                y = next_on_axis(y, AXIS_BITS << 1);
            }
            z = next_on_axis(z, AXIS_BITS << 2);
        }
    }
}

/// The bits of the x coordinate in a Morton key.
const AXIS_BITS: u64 = 0x1249_2492_4924_9249;

/// The bits `axis` of a Morton key plus one, as a coordinate: filling the other bits with ones
/// carries the addition across them.
#[inline]
fn next_on_axis(bits: u64, axis: u64) -> u64 {
    (bits | !axis).wrapping_add(1) & axis
}

/// The 21 low bits of `v` moved to every third bit: one axis of a Morton code.
#[inline]
fn spread(v: u32) -> u64 {
    let mut x = u64::from(v) & 0x1f_ffff;
    x = (x | x << 32) & 0x001f_0000_0000_ffff;
    x = (x | x << 16) & 0x001f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    (x | x << 2) & 0x1249_2492_4924_9249
}

/// A box entered in a cell, packed in one word (`Packing`): the cell's Morton key in the high
/// bits, then the axes along which the cell is the box's first (see `Level::test`), then the
/// box's position. Sorting the words sorts the entries by cell; within a cell the order is
/// immaterial, because the pairs are sorted at the end.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord)]
struct Entry(u64);

/// The layout of an [`Entry`] for a number of boxes: as many bits as their positions need,
/// three for the axes, and the rest for the key, which bounds the cells per axis
/// (`axis_max`). Half the size of an entry with a separate 64-bit key, hence half the table
/// and its copy to write and sort (measured 10–15% faster on 0.3M–1.3M triangle spheres).
#[derive(Clone, Copy, Debug)]
struct Packing {
    item_bits: u32,
}

impl Packing {
    fn for_boxes(count: usize) -> Packing {
        Packing {
            item_bits: (usize::BITS - count.saturating_sub(1).leading_zeros()).max(1),
        }
    }

    /// The largest cell coordinate along an axis: three of them fill the key's bits.
    fn axis_max(self) -> u32 {
        let axis_bits = ((u64::BITS - 3 - self.item_bits) / 3).min(MORTON_AXIS_BITS);
        (1 << axis_bits) - 1
    }

    #[inline]
    fn entry(self, key: u64, first: u8, item: u32) -> Entry {
        Entry(key << (self.item_bits + 3) | u64::from(first) << self.item_bits | u64::from(item))
    }

    #[inline]
    fn key(self, e: Entry) -> u64 {
        e.0 >> (self.item_bits + 3)
    }

    #[inline]
    fn first(self, e: Entry) -> u8 {
        (e.0 >> self.item_bits) as u8 & 0b111
    }

    #[inline]
    fn item(self, e: Entry) -> u32 {
        (e.0 & ((1 << self.item_bits) - 1)) as u32
    }
}

/// A list of entries, produced in parts from numbered sources (see `sorted_entries`), without
/// being stored.
trait EntryList: Sync {
    fn sources(&self) -> usize;
    fn for_each(&self, sources: Range<usize>, f: impl FnMut(Entry));
}

/// One entry per box: the cell of its lower corner.
struct LowerCorners<'b> {
    boxes: &'b [Aabb],
    grid: Grid,
}

impl EntryList for LowerCorners<'_> {
    fn sources(&self) -> usize {
        self.boxes.len()
    }

    fn for_each(&self, sources: Range<usize>, mut f: impl FnMut(Entry)) {
        for (item, b) in (sources.start as u32..).zip(&self.boxes[sources]) {
            let key = Grid::key(self.grid.cell(b.lo.as_dvec3()));
            f(self.grid.packing.entry(key, 0b111, item));
        }
    }
}

/// One entry per cell overlapped by each of the boxes at `items`.
struct OverlappedCells<'b> {
    boxes: &'b [Aabb],
    items: &'b [u32],
    grid: Grid,
}

impl EntryList for OverlappedCells<'_> {
    fn sources(&self) -> usize {
        self.items.len()
    }

    fn for_each(&self, sources: Range<usize>, mut f: impl FnMut(Entry)) {
        for &item in &self.items[sources] {
            self.grid
                .for_each_cell(&self.boxes[item as usize], |key, first| {
                    f(self.grid.packing.entry(key, first, item))
                });
        }
    }
}

/// The entries of `list`, sorted; `max` is at least as large as any of them.
///
/// A counting sort on the top bits of the keys distributes the entries into buckets of a few
/// entries each, written straight to their final place; the buckets are then sorted in
/// parallel. Each thread makes the entries of its share of the sources once, counting them per
/// bucket, then copies them into its own sub-slice of every bucket. Entries come nearly in
/// Morton order (boxes are stored along the curve), so the writes are almost sequential and
/// the small sorts find their input nearly sorted: several times faster than sorting the whole
/// list. (Keeping the entries rather than making them once for counting and once for writing
/// takes one more list of entries, and a fifth fewer instructions for the table of a 0.3M
/// triangle sphere.)
fn sorted_entries(max: Entry, list: &impl EntryList) -> Vec<Entry> {
    let sources = list.sources();
    // About 4 sources per bucket, at most 2^20 buckets.
    let top_bits = (usize::BITS - (sources / 4).leading_zeros()).clamp(1, 20);
    let buckets = 1usize << top_bits;
    let shift = (u64::BITS - max.0.leading_zeros()).saturating_sub(top_bits);
    let bucket = |e: &Entry| (e.0 >> shift) as usize;
    let parts = rayon::current_num_threads().clamp(1, sources.max(1));
    let part = |p: usize| p * sources / parts..(p + 1) * sources / parts;
    let (made, counts): (Vec<Vec<Entry>>, Vec<Vec<usize>>) = (0..parts)
        .into_par_iter()
        .map(|p| {
            let mut counts = vec![0usize; buckets];
            // Room for a few entries per source: the address space is only touched as
            // entries are written.
            let mut made = Vec::with_capacity(4 * part(p).len());
            list.for_each(part(p), |e| {
                counts[bucket(&e)] += 1;
                made.push(e);
            });
            (made, counts)
        })
        .unzip();
    let sizes: Vec<usize> = (0..buckets)
        .map(|b| counts.iter().map(|c| c[b]).sum())
        .collect();
    let mut entries: Vec<Entry> = (0..sizes.iter().sum())
        .into_par_iter()
        .map(|_| Entry::default())
        .collect();
    let mut shares: Vec<Vec<&mut [Entry]>> =
        (0..parts).map(|_| Vec::with_capacity(buckets)).collect();
    let mut rest = entries.as_mut_slice();
    for b in 0..buckets {
        for (share, count) in shares.iter_mut().zip(&counts) {
            let (head, tail) = std::mem::take(&mut rest).split_at_mut(count[b]);
            share.push(head);
            rest = tail;
        }
    }
    shares
        .into_par_iter()
        .zip(made)
        .for_each(|(mut share, made)| {
            let mut filled = vec![0usize; buckets];
            for e in made {
                let b = bucket(&e);
                share[b][filled[b]] = e;
                filled[b] += 1;
            }
        });
    let mut slices = Vec::with_capacity(buckets);
    let mut rest = entries.as_mut_slice();
    for size in sizes {
        let (head, tail) = std::mem::take(&mut rest).split_at_mut(size);
        slices.push(head);
        rest = tail;
    }
    slices
        .into_par_iter()
        .with_min_len(256)
        .for_each(|b| b.sort_unstable());
    entries
}

/// The table of one level: the entries of its primary boxes, sorted by cell key.
struct Level<'a> {
    boxes: &'a [Aabb],
    grid: Grid,
    entries: Vec<Entry>,
}

/// Runs of about this many entries are handed to one task.
const ENTRIES_PER_TASK: usize = 4096;

impl<'a> Level<'a> {
    /// `highest` bounds the upper corners of the primary boxes.
    fn new(boxes: &'a [Aabb], grid: Grid, primary: &[u32], highest: DVec3) -> Level<'a> {
        let cells = OverlappedCells {
            boxes,
            items: primary,
            grid,
        };
        let entries = sorted_entries(grid.last_entry(highest), &cells);
        Level {
            boxes,
            grid,
            entries,
        }
    }

    /// The entries of the cell with this key (empty if none).
    fn cell_entries(&self, key: u64) -> &[Entry] {
        let key_of = |e: &Entry| self.grid.packing.key(*e);
        let start = self.entries.partition_point(|e| key_of(e) < key);
        let len = self.entries[start..].partition_point(|e| key_of(e) == key);
        &self.entries[start..start + len]
    }

    /// Boundaries splitting the entries into slices of whole cells, about
    /// `ENTRIES_PER_TASK` entries each.
    fn task_bounds(&self) -> Vec<usize> {
        let mut bounds = vec![0];
        let mut next = ENTRIES_PER_TASK;
        while next < self.entries.len() {
            let key = self.grid.packing.key(self.entries[next - 1]);
            next += self.entries[next..].partition_point(|&e| self.grid.packing.key(e) == key);
            bounds.push(next);
            next += ENTRIES_PER_TASK;
        }
        if *bounds.last().unwrap_or(&0) < self.entries.len() {
            bounds.push(self.entries.len());
        }
        bounds
    }

    /// Accepted overlapping pairs among the primary boxes, and between them and `settled`, as
    /// many as the limit lets `accepted` keep. The check for the limit comes once per box and
    /// cell, not per pair: a cell of boxes piled into one place is the case it is there for.
    fn pairs<F>(&self, settled: &[u32], accepted: &Accepted<F>) -> Vec<(u32, u32)>
    where
        F: Fn(u32, u32) -> bool + Sync,
    {
        let bounds = self.task_bounds();
        let within = bounds.par_windows(2).fold(Vec::new, |mut out, bounds| {
            let packing = self.grid.packing;
            let same_cell = |e: &Entry, f: &Entry| packing.key(*e) == packing.key(*f);
            for cell in self.entries[bounds[0]..bounds[1]].chunk_by(same_cell) {
                for (x, &e) in cell.iter().enumerate() {
                    if accepted.exceeded() {
                        return out;
                    }
                    let item = packing.item(e);
                    let a = &self.boxes[item as usize];
                    for f in &cell[x + 1..] {
                        self.test(item, a, packing.first(e), f, accepted, &mut out);
                    }
                }
            }
            out
        });
        let across = settled
            .par_iter()
            .with_min_len(256)
            .fold(Vec::new, |mut out, &item| {
                let b = &self.boxes[item as usize];
                self.grid.for_each_cell(b, |key, first| {
                    if accepted.exceeded() {
                        return;
                    }
                    for e in self.cell_entries(key) {
                        self.test(item, b, first, e, accepted, &mut out);
                    }
                });
                out
            });
        within.chain(across).reduce(Vec::new, |mut a, mut b| {
            a.append(&mut b);
            a
        })
    }

    /// Tests the pair of the box `x_box` at position `x` and the box of entry `y`, met in the cell of
    /// `y`, if this is the cell that owns the pair: the cell of the lower corner of their
    /// overlap. Its coordinates are the per-axis maxima of those of the boxes' first cells; as
    /// both boxes cover the cell, it is the owner iff along each axis it is the first cell of
    /// one of them (`x_first`, `y.first`).
    #[inline]
    fn test<F>(
        &self,
        x: u32,
        x_box: &Aabb,
        x_first: u8,
        y: &Entry,
        accepted: &Accepted<F>,
        out: &mut Vec<(u32, u32)>,
    ) where
        F: Fn(u32, u32) -> bool,
    {
        if x_first | self.grid.packing.first(*y) != 0b111 {
            return;
        }
        let y = self.grid.packing.item(*y);
        if x_box.overlaps(&self.boxes[y as usize]) {
            let pair = (x.min(y), x.max(y));
            if accepted.keep(pair.0, pair.1) {
                out.push(pair);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    fn brute_force(boxes: &[Aabb]) -> Vec<(u32, u32)> {
        let mut pairs = Vec::new();
        for (i, a) in boxes.iter().enumerate() {
            for (j, b) in boxes.iter().enumerate().skip(i + 1) {
                if a.overlaps(b) {
                    pairs.push((i as u32, j as u32));
                }
            }
        }
        pairs
    }

    fn unit(lo: DVec3) -> Aabb {
        Aabb::new(lo, lo + DVec3::ONE)
    }

    /// Random boxes from a xorshift generator; sizes spread over `decades` powers of ten.
    fn random_boxes(n: usize, decades: f64, seed: u64) -> Vec<Aabb> {
        let mut state = seed;
        let mut uniform = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| {
                let lo = DVec3::new(uniform(), uniform(), uniform()) * 100.0;
                let size = 10f64.powf(decades * uniform() - decades + 0.5);
                let extent = DVec3::new(uniform(), uniform(), uniform()) * size;
                Aabb::new(lo, lo + extent)
            })
            .collect()
    }

    fn check_against_brute_force(boxes: &[Aabb]) {
        let calls = AtomicUsize::new(0);
        let pairs = overlapping_pairs(boxes, usize::MAX, |_, _| {
            calls.fetch_add(1, Ordering::Relaxed);
            true
        })
        .unwrap();
        let expected = brute_force(boxes);
        assert_eq!(pairs, expected);
        let calls = calls.load(Ordering::Relaxed);
        assert_eq!(calls, expected.len(), "one call per pair");
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
        let boxes = [
            unit(DVec3::ZERO),
            unit(DVec3::X),
            unit(DVec3::ZERO),
            // Eight single-precision ulps beyond the first box.
            unit(DVec3::splat(1.0 + 2f64.powi(-20))),
            unit(DVec3::ONE),
        ];
        let pairs = overlapping_pairs(&boxes, usize::MAX, |_, _| true).unwrap();
        assert_eq!(pairs, brute_force(&boxes));
        assert!(pairs.contains(&(0, 4)) && pairs.contains(&(0, 2)));
        assert!(!pairs.contains(&(0, 3)));
    }

    #[test]
    fn a_box_covering_millions_of_cells_is_deferred_to_a_coarser_level() {
        // 10^4 unit boxes on a plane and one box a million times larger, which would cover
        // about 10^8 cells of the fine level.
        let mut boxes: Vec<Aabb> = (0..10_000u32)
            .map(|i| {
                unit(DVec3::new(
                    (i % 100) as f64 * 1.5,
                    (i / 100) as f64 * 1.5,
                    0.0,
                ))
            })
            .collect();
        boxes.push(Aabb::new(
            DVec3::splat(-1.0e6),
            DVec3::new(1.0e6, 1.0e6, 0.5),
        ));
        let pairs = overlapping_pairs(&boxes, usize::MAX, |_, _| true).unwrap();
        assert_eq!(pairs.len(), 10_000);
        assert!(pairs.iter().all(|&(_, b)| b == 10_000));
    }

    #[test]
    fn single_precision_boxes_contain_the_double_precision_ones_tightly() {
        let values = [
            0.0,
            1.0,
            -1.0,
            0.1,
            -0.1,
            1.0 + 1e-12,
            std::f64::consts::PI * 1e5,
            -123_456.789_012_345,
            1e-30,
            -1e-30,
            1e-44,
            -1e-44,
            1e-300,
            -1e-300,
            3.0e38,
            -3.0e38,
            1e300,
            -1e300,
        ];
        for &x in &values {
            let b = Aabb::new(DVec3::splat(x), DVec3::splat(x));
            let (lo, hi) = (f64::from(b.lo.x), f64::from(b.hi.x));
            assert!(lo <= x && x <= hi, "{x}: [{lo}, {hi}]");
            if x.abs() < 1e38 {
                // A few ulps of single precision (or of its smallest subnormal) at most.
                let slack = 5.0 * (x.abs() * 2f64.powi(-23)).max(2f64.powi(-149));
                assert!(x - lo <= slack && hi - x <= slack, "{x}: [{lo}, {hi}]");
            }
        }
    }

    #[test]
    fn accept_filters_pairs_and_result_is_sorted() {
        let boxes = random_boxes(500, 0.5, 3);
        let pairs = overlapping_pairs(&boxes, usize::MAX, |a, b| (a + b) % 3 == 0).unwrap();
        let expected: Vec<_> = brute_force(&boxes)
            .into_iter()
            .filter(|(a, b)| (a + b) % 3 == 0)
            .collect();
        assert_eq!(pairs, expected);
    }

    #[test]
    fn a_search_gives_up_past_its_limit_whatever_the_threads() {
        // Sizes from 0.003 to 3 in a region 10 wide: several levels, tasks and thousands of
        // pairs.
        let boxes: Vec<Aabb> = random_boxes(20_000, 3.0, 5)
            .iter()
            .map(|b| {
                let lo = b.lo.as_dvec3() * 0.1;
                Aabb::new(lo, lo + (b.hi - b.lo).as_dvec3())
            })
            .collect();
        let accept = |a: u32, b: u32| (a ^ b) % 5 != 0;
        let all = overlapping_pairs(&boxes, usize::MAX, accept).unwrap();
        assert!(all.len() > 10_000, "{}", all.len());
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                assert_eq!(
                    overlapping_pairs(&boxes, all.len(), accept).as_ref(),
                    Some(&all)
                );
                assert_eq!(overlapping_pairs(&boxes, all.len() - 1, accept), None);
                assert_eq!(overlapping_pairs(&boxes, 0, accept), None);
            });
        }
    }

    #[test]
    fn boxes_piled_into_one_place_are_not_all_paired_once_the_limit_is_passed() {
        // 4,000 boxes around one point: about 8 million overlapping pairs, all in one cell.
        let boxes: Vec<Aabb> = (0..4000)
            .map(|i| unit(DVec3::splat(f64::from(i % 7) * 0.01)))
            .collect();
        let calls = AtomicUsize::new(0);
        let limit = 1000;
        let pairs = overlapping_pairs(&boxes, limit, |_, _| {
            calls.fetch_add(1, Ordering::Relaxed);
            true
        });
        assert_eq!(pairs, None);
        // The check comes once per box: each thread may finish the pairs of the box it is on.
        let bound = limit + 1 + rayon::current_num_threads() * boxes.len();
        assert!(calls.into_inner() <= bound);
    }

    #[test]
    fn empty_and_single_inputs() {
        assert_eq!(overlapping_pairs(&[], 0, |_, _| true), Some(Vec::new()));
        assert!(spatial_order(&[]).is_empty());
        let one = [Aabb::of_triangle([DVec3::ZERO, DVec3::X, DVec3::Y])];
        assert_eq!(overlapping_pairs(&one, 0, |_, _| true), Some(Vec::new()));
        assert_eq!(spatial_order(&one), vec![0]);
    }

    #[test]
    fn extreme_extents_and_coordinates_fall_back_to_coarse_cells() {
        let everything = Aabb::new(DVec3::splat(-f64::MAX), DVec3::splat(f64::MAX));
        let boxes = [everything, unit(DVec3::ZERO), everything];
        assert_eq!(
            overlapping_pairs(&boxes, usize::MAX, |_, _| true),
            Some(brute_force(&boxes))
        );
        // Unit boxes 10^9 cells apart: more cells than the entries can name, so the grid gets
        // larger cells.
        let far: Vec<Aabb> = (0..50)
            .map(|i| unit(DVec3::new(i as f64 * 1e9, (i % 3) as f64 * 0.5, 0.0)))
            .chain((0..50).map(|i| unit(DVec3::new(i as f64 * 0.5, 0.0, 0.0))))
            .collect();
        check_against_brute_force(&far);
    }

    #[test]
    fn sorted_entries_orders_keys_of_any_width() {
        struct Listed(Vec<Entry>);
        impl EntryList for Listed {
            fn sources(&self) -> usize {
                self.0.len()
            }
            fn for_each(&self, sources: Range<usize>, f: impl FnMut(Entry)) {
                self.0[sources].iter().copied().for_each(f);
            }
        }
        let packing = Packing::for_boxes(5000);
        let key_bits = 3 * packing.axis_max().count_ones();
        let mut state = 12345u64;
        let input: Vec<Entry> = (0..5000)
            .map(|i| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let wide = state >> (64 - key_bits);
                let key = if i % 2 == 0 { wide } else { wide >> 40 };
                packing.entry(key, (i % 8) as u8, i)
            })
            .collect();
        let max = *input.iter().max().unwrap();
        let entries = sorted_entries(max, &Listed(input.clone()));
        assert!(entries.windows(2).all(|w| w[0] <= w[1]));
        // A permutation of the input, each entry unpacking to what was packed.
        let mut expected = input.clone();
        expected.sort_unstable();
        assert_eq!(entries, expected);
        for (i, &e) in input.iter().enumerate() {
            assert_eq!(packing.item(e), i as u32);
            assert_eq!(packing.first(e), (i % 8) as u8);
        }
        // Keys narrower than the bucket bits, and no entries at all.
        let small: Vec<Entry> = (0..100u32)
            .rev()
            .map(|i| packing.entry(u64::from(i % 7), 0, i))
            .collect();
        let small = sorted_entries(packing.entry(6, 0b111, 4999), &Listed(small));
        assert_eq!(small.len(), 100);
        assert!(small
            .windows(2)
            .all(|w| packing.key(w[0]) <= packing.key(w[1])));
        assert!(sorted_entries(Entry(0), &Listed(Vec::new())).is_empty());
    }

    #[test]
    fn entries_leave_the_key_the_bits_the_positions_do_not_need() {
        for (boxes, item_bits) in [
            (0, 1),
            (1, 1),
            (2, 1),
            (3, 2),
            (1 << 20, 20),
            (1 << 20 | 1, 21),
        ] {
            let packing = Packing::for_boxes(boxes);
            assert_eq!(packing.item_bits, item_bits, "{boxes}");
            let axis_bits = packing.axis_max().count_ones();
            assert!(3 * axis_bits + 3 + item_bits <= 64 && axis_bits <= MORTON_AXIS_BITS);
            let top = packing.axis_max();
            let e = packing.entry(Grid::key([top; 3]), 0b101, (boxes.max(1) - 1) as u32);
            assert_eq!(packing.key(e), Grid::key([top; 3]));
            assert_eq!(packing.first(e), 0b101);
            assert_eq!(packing.item(e), (boxes.max(1) - 1) as u32);
        }
    }

    #[test]
    fn a_grid_wider_than_the_entries_can_name_gets_larger_cells() {
        let packing = Packing::for_boxes(1 << 30);
        let top = packing.axis_max();
        let grid = Grid::new(DVec3::ZERO, 1.0, 1e6, packing);
        assert_eq!(grid.cell(DVec3::splat(1e6)), [top; 3]);
        assert!(grid.cell(DVec3::splat(0.5e6))[0] < top);
        // Narrow enough: unit cells.
        let grid = Grid::new(DVec3::ZERO, 1.0, 10.0, packing);
        assert_eq!(grid.cell(DVec3::new(2.5, 3.5, 9.99)), [2, 3, 9]);
    }

    #[test]
    fn morton_keys_interleave_the_coordinates() {
        assert_eq!(Grid::key([1, 0, 0]), 1);
        assert_eq!(Grid::key([0, 1, 0]), 2);
        assert_eq!(Grid::key([0, 0, 1]), 4);
        assert_eq!(Grid::key([3, 0, 0]), 0b1001);
        assert_eq!(Grid::key([(1 << MORTON_AXIS_BITS) - 1; 3]), (1 << 63) - 1);
    }

    #[test]
    fn cells_of_a_box_know_the_axes_along_which_they_come_first() {
        let grid = Grid::new(DVec3::ZERO, 1.0, 10.0, Packing::for_boxes(1));
        let b = Aabb::new(DVec3::new(0.5, 1.5, 2.5), DVec3::new(1.5, 1.7, 4.5));
        let mut cells = Vec::new();
        grid.for_each_cell(&b, |key, first| cells.push((key, first)));
        let expected: Vec<(u64, u8)> = [
            ([0, 1, 2], 0b111),
            ([1, 1, 2], 0b110),
            ([0, 1, 3], 0b011),
            ([1, 1, 3], 0b010),
            ([0, 1, 4], 0b011),
            ([1, 1, 4], 0b010),
        ]
        .into_iter()
        .map(|(cell, first)| (Grid::key(cell), first))
        .collect();
        assert_eq!(cells, expected);
    }

    #[test]
    fn spatial_order_is_a_permutation_following_the_curve() {
        let boxes = random_boxes(1000, 0.3, 11);
        let order = spatial_order(&boxes);
        let mut sorted = order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..1000).collect::<Vec<u32>>());
        // Consecutive boxes are close: the mean step is far below the mean random distance.
        let step: f64 = order
            .windows(2)
            .map(|w| f64::from(boxes[w[0] as usize].lo.distance(boxes[w[1] as usize].lo)))
            .sum::<f64>()
            / 999.0;
        assert!(step < 20.0, "{step}");
    }
}
