//! The voxels of a mask, listed in the grid's order (i fastest) and found again by their grid
//! index: a compressed-row layout (one run of entries per row of the grid, as CSR stores a
//! sparse matrix) for work that only the mask's voxels need. A vessel tree fills a few per cent
//! of the box around it, so a value per voxel of the mask (a depth, a label) costs that much
//! rather than a value per voxel of the box.

use std::ops::Range;

use crate::allocation;
use crate::error::Result;
use crate::morphology::{self, Grid};

pub(crate) struct MaskVoxels {
    dims: [usize; 3],
    /// The grid index of each voxel of the mask, ascending.
    voxels: Vec<usize>,
    /// Where the voxels of row `j + ny k` begin in `voxels`; one more entry ends the last.
    row_start: Vec<usize>,
}

impl MaskVoxels {
    /// The voxels where `mask` (i fastest, `dims`) holds.
    pub fn new(mask: &[bool], dims: [usize; 3]) -> Result<Self> {
        debug_assert_eq!(mask.len(), dims.iter().product::<usize>());
        Self::where_true(dims, |n| mask[n])
    }

    /// The voxels `n` of a grid of `dims` for which `holds(n)`.
    pub fn where_true(dims: [usize; 3], holds: impl Fn(usize) -> bool) -> Result<Self> {
        let len = dims.iter().product();
        let voxels =
            allocation::collect_counted((0..len).filter(|&n| holds(n)), "a mask's voxels")?;
        Self::from_sorted(voxels, dims)
    }

    /// The voxels `voxels` (grid indices, ascending, without repeats) of a grid of `dims`.
    pub fn from_sorted(voxels: Vec<usize>, dims: [usize; 3]) -> Result<Self> {
        let [nx, ny, nz] = dims;
        debug_assert!(voxels.windows(2).all(|w| w[0] < w[1]));
        let mut row_start = allocation::filled(ny * nz + 1, 0, "a mask's rows")?;
        for &n in &voxels {
            row_start[n / nx + 1] += 1;
        }
        for r in 0..ny * nz {
            row_start[r + 1] += row_start[r];
        }
        Ok(MaskVoxels {
            dims,
            voxels,
            row_start,
        })
    }

    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    pub fn len(&self) -> usize {
        self.voxels.len()
    }

    /// The grid index of the mask's `c`-th voxel.
    pub fn voxel(&self, c: usize) -> usize {
        self.voxels[c]
    }

    /// The positions (in the mask's order) of the voxels of row `j` of slab `k`.
    pub fn row(&self, j: usize, k: usize) -> Range<usize> {
        let r = j + self.dims[1] * k;
        self.row_start[r]..self.row_start[r + 1]
    }

    /// The positions of the voxels of slab `k`.
    pub fn slab(&self, k: usize) -> Range<usize> {
        let ny = self.dims[1];
        self.row_start[k * ny]..self.row_start[(k + 1) * ny]
    }

    /// The position in the mask's order of the grid's voxel `n`, if the mask holds it.
    pub fn position(&self, n: usize) -> Option<usize> {
        let r = n / self.dims[0];
        let row = self.row_start[r]..self.row_start[r + 1];
        let found = self.voxels[row.clone()].binary_search(&n).ok()?;
        Some(row.start + found)
    }

    /// The positions of the 6-neighbours of the mask's `c`-th voxel that the mask holds.
    pub fn neighbours(&self, c: usize) -> impl Iterator<Item = usize> + '_ {
        Grid(self.dims)
            .neighbours(self.voxels[c])
            .filter_map(|m| self.position(m))
    }

    /// The 6-connected components of the mask: a label per voxel (in the mask's order),
    /// numbered in the order of their first voxel, and how many there are.
    pub fn components(&self) -> Result<(Vec<u32>, u32)> {
        morphology::label_components(self.len(), |_| true, |c| self.neighbours(c))
    }

    /// `values` (one per voxel of the mask, in its order) cut into the runs of each slab.
    pub fn split_by_slab<'v, T>(&self, mut values: &'v mut [T]) -> Vec<&'v mut [T]> {
        debug_assert_eq!(values.len(), self.len());
        (0..self.dims[2])
            .map(|k| {
                let (slab, rest) = std::mem::take(&mut values).split_at_mut(self.slab(k).len());
                values = rest;
                slab
            })
            .collect()
    }

    /// A grid of `dims`' voxels holding `values` (one per voxel of the mask, in its order) at
    /// the mask's voxels and `background` elsewhere.
    pub fn scatter<T: Clone>(&self, values: Vec<T>, background: T, what: &str) -> Result<Vec<T>> {
        let mut grid = allocation::filled(self.dims.iter().product(), background, what)?;
        for (&n, v) in self.voxels.iter().zip(values) {
            grid[n] = v;
        }
        Ok(grid)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scattered(dims: [usize; 3]) -> Vec<bool> {
        (0..dims.iter().product::<usize>())
            .map(|n| (n * 7919) % 13 < 4)
            .collect()
    }

    #[test]
    fn positions_rows_and_neighbours_agree_with_the_grid() {
        let dims = [7, 5, 4];
        let mask = scattered(dims);
        let voxels = MaskVoxels::new(&mask, dims).unwrap();
        assert_eq!(voxels.len(), mask.iter().filter(|&&m| m).count());
        for (n, &m) in mask.iter().enumerate() {
            let c = voxels.position(n);
            assert_eq!(c.is_some(), m, "voxel {n}");
            if let Some(c) = c {
                assert_eq!(voxels.voxel(c), n);
                let mut expected: Vec<usize> = Grid(dims)
                    .neighbours(n)
                    .filter(|&m| mask[m])
                    .map(|m| voxels.position(m).unwrap())
                    .collect();
                let mut found: Vec<usize> = voxels.neighbours(c).collect();
                expected.sort_unstable();
                found.sort_unstable();
                assert_eq!(found, expected, "voxel {n}");
            }
        }
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                let row: Vec<usize> = voxels.row(j, k).map(|c| voxels.voxel(c)).collect();
                let expected: Vec<usize> = (0..dims[0])
                    .map(|i| i + dims[0] * (j + dims[1] * k))
                    .filter(|&n| mask[n])
                    .collect();
                assert_eq!(row, expected);
            }
        }
        let mut values: Vec<usize> = (0..voxels.len()).collect();
        let slabs = voxels.split_by_slab(&mut values);
        for (k, slab) in slabs.into_iter().enumerate() {
            assert_eq!(
                slab.to_vec(),
                voxels.slab(k).collect::<Vec<_>>(),
                "slab {k}"
            );
        }
        let grid = voxels
            .scatter(vec![true; voxels.len()], false, "a test")
            .unwrap();
        assert_eq!(grid, mask);
        let listed =
            MaskVoxels::from_sorted((0..mask.len()).filter(|&n| mask[n]).collect(), dims).unwrap();
        assert_eq!(listed.row_start, voxels.row_start);
    }

    #[test]
    fn components_are_those_of_the_grid_in_the_same_order() {
        let dims = [9, 8, 7];
        let mask = scattered(dims);
        let voxels = MaskVoxels::new(&mask, dims).unwrap();
        let (labels, count) = voxels.components().unwrap();
        let (expected, expected_count) = morphology::components(&mask, dims).unwrap();
        assert_eq!(count, expected_count);
        assert!(count > 3, "a mask of several pieces: {count}");
        assert_eq!(
            voxels.scatter(labels, u32::MAX, "a test").unwrap(),
            expected
        );
    }

    #[test]
    fn an_empty_mask_and_an_empty_grid_have_no_voxels() {
        let empty = MaskVoxels::new(&[false; 24], [2, 3, 4]).unwrap();
        assert_eq!(empty.len(), 0);
        assert_eq!(empty.slab(3), 0..0);
        assert_eq!(empty.position(23), None);
        let nothing = MaskVoxels::new(&[], [0, 3, 4]).unwrap();
        assert_eq!(nothing.len(), 0);
        assert_eq!(nothing.row(2, 3), 0..0);
    }
}
