//! Binary morphology of voxel masks on an anisotropic grid (Serra, "Image analysis and
//! mathematical morphology", 1982): dilation, erosion and closing by a ball given in
//! millimetres (the set of voxel offsets within the radius), and 6-connected components.
//!
//! Both operations work from boundary voxels only. The voxel of a set nearest to a voxel
//! outside it always has a 6-neighbour outside the set (a step along any axis towards the
//! outside voxel is shorter), so dilating a set by a ball is the same as marking the ball
//! around each of its boundary voxels; erosion is the complement of the dilation of the
//! complement. The cost is the surface's voxel count times the ball's, not the grid's.
//! Marking is idempotent, so the result does not depend on the order of the work.

use crate::allocation;
use crate::error::Result;

/// Closes `mask` (i fastest, `dims`, spacing in mm) with a ball of `radius_mm`; returns the
/// indices of the voxels it adds, ascending. The set must stay one ball's width away from the
/// grid's faces (voxels beyond them count as outside), or it is closed against those faces.
pub fn close(
    mask: &mut [bool],
    dims: [usize; 3],
    spacing: [f64; 3],
    radius_mm: f64,
) -> Result<Vec<usize>> {
    let closed = erode(
        &dilate(mask, dims, spacing, radius_mm)?,
        dims,
        spacing,
        radius_mm,
    )?;
    let mut added = Vec::new();
    for (n, inside) in mask.iter_mut().enumerate() {
        if !*inside && closed[n] {
            *inside = true;
            added.push(n);
        }
    }
    Ok(added)
}

/// The voxels within `radius_mm` of a voxel of `mask` (i fastest, `dims`, spacing in mm).
pub fn dilate(
    mask: &[bool],
    dims: [usize; 3],
    spacing: [f64; 3],
    radius_mm: f64,
) -> Result<Vec<bool>> {
    let ball = Ball::new(spacing, radius_mm);
    let grid = Grid(dims);
    let mut dilated = allocation::collect(mask.iter().copied(), "a dilated mask")?;
    for n in (0..mask.len()).filter(|&n| mask[n]) {
        if grid.neighbours(n).any(|m| !mask[m]) || grid.on_face(n) {
            ball.mark(&mut dilated, grid, n);
        }
    }
    Ok(dilated)
}

/// The voxels of `mask` farther than `radius_mm` from every voxel of the grid outside it
/// (those beyond the grid's faces do not count).
pub fn erode(
    mask: &[bool],
    dims: [usize; 3],
    spacing: [f64; 3],
    radius_mm: f64,
) -> Result<Vec<bool>> {
    let ball = Ball::new(spacing, radius_mm);
    let grid = Grid(dims);
    let mut eroded = allocation::zeroed(mask.len(), "an eroded mask")?;
    for n in (0..mask.len()).filter(|&n| mask[n]) {
        for m in grid.neighbours(n) {
            // Each outside voxel's ball once: from the first of its neighbours inside.
            if !mask[m] && grid.neighbours(m).find(|&p| mask[p]) == Some(n) {
                ball.mark(&mut eroded, grid, m);
            }
        }
    }
    // What is marked is near the outside; the rest of the mask is the erosion.
    for (e, &inside) in eroded.iter_mut().zip(mask) {
        *e = inside && !*e;
    }
    Ok(eroded)
}

/// The 6-connected components of `mask`: a label per voxel (`u32::MAX` outside the mask),
/// numbered in the order of their first voxel, and how many there are.
pub fn components(mask: &[bool], dims: [usize; 3]) -> Result<(Vec<u32>, u32)> {
    let grid = Grid(dims);
    label_components(mask.len(), |n| mask[n], |n| grid.neighbours(n))
}

/// The connected components of the nodes `0..len` that are `member`s, joined along
/// `neighbours`: a label per node (`u32::MAX` for the others), numbered in the order of their
/// first node, and how many there are.
pub(crate) fn label_components<I: Iterator<Item = usize>>(
    len: usize,
    member: impl Fn(usize) -> bool,
    neighbours: impl Fn(usize) -> I,
) -> Result<(Vec<u32>, u32)> {
    let mut labels = allocation::filled(len, u32::MAX, "the components' labels")?;
    let mut count = 0;
    let mut stack = Vec::new();
    for start in 0..len {
        if !member(start) || labels[start] != u32::MAX {
            continue;
        }
        labels[start] = count;
        stack.push(start);
        while let Some(n) = stack.pop() {
            for m in neighbours(n) {
                if member(m) && labels[m] == u32::MAX {
                    labels[m] = count;
                    // A component as large as the grid stacks a front as large as a slab.
                    allocation::reserved::<usize>(stack.try_reserve(1), len, "the flood's stack")?;
                    stack.push(m);
                }
            }
        }
        count += 1;
    }
    Ok((labels, count))
}

/// The voxel offsets `(di, dj, dk)` within the radius.
struct Ball {
    offsets: Vec<[isize; 3]>,
}

impl Ball {
    fn new(spacing: [f64; 3], radius_mm: f64) -> Ball {
        let reach = spacing.map(|s| (radius_mm / s).floor() as isize);
        let mut offsets = Vec::new();
        for dk in -reach[2]..=reach[2] {
            for dj in -reach[1]..=reach[1] {
                for di in -reach[0]..=reach[0] {
                    let d = [di, dj, dk];
                    let squared: f64 = (0..3).map(|a| (d[a] as f64 * spacing[a]).powi(2)).sum();
                    if squared <= radius_mm * radius_mm {
                        offsets.push(d);
                    }
                }
            }
        }
        Ball { offsets }
    }

    /// Sets `out` at the voxels of the ball around voxel `n`, those inside the grid.
    fn mark(&self, out: &mut [bool], grid: Grid, n: usize) {
        let [ni, nj, nk] = grid.0;
        let (i, j, k) = grid.coordinates(n);
        for d in &self.offsets {
            let (Some(x), Some(y), Some(z)) = (
                i.checked_add_signed(d[0]).filter(|&x| x < ni),
                j.checked_add_signed(d[1]).filter(|&y| y < nj),
                k.checked_add_signed(d[2]).filter(|&z| z < nk),
            ) else {
                continue;
            };
            out[x + ni * (y + nj * z)] = true;
        }
    }
}

/// Voxel indices on a grid of these dimensions, i fastest.
#[derive(Clone, Copy)]
pub(crate) struct Grid(pub [usize; 3]);

impl Grid {
    pub fn coordinates(self, n: usize) -> (usize, usize, usize) {
        let [ni, nj, _] = self.0;
        (n % ni, n / ni % nj, n / (ni * nj))
    }

    /// The 6-neighbours of voxel `n` inside the grid.
    pub fn neighbours(self, n: usize) -> impl Iterator<Item = usize> {
        let [ni, nj, nk] = self.0;
        let (i, j, k) = self.coordinates(n);
        [
            (i > 0).then(|| n - 1),
            (i + 1 < ni).then(|| n + 1),
            (j > 0).then(|| n - ni),
            (j + 1 < nj).then(|| n + ni),
            (k > 0).then(|| n - ni * nj),
            (k + 1 < nk).then(|| n + ni * nj),
        ]
        .into_iter()
        .flatten()
    }

    /// Whether voxel `n` lies on a face of the grid (has a 6-neighbour beyond it).
    fn on_face(self, n: usize) -> bool {
        self.neighbours(n).count() < 6
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A mask of the grid points (i fastest) at which `inside` holds, given in mm.
    pub(crate) fn grid(
        dims: [usize; 3],
        inside: impl Fn([f64; 3]) -> bool,
        spacing: [f64; 3],
    ) -> Vec<bool> {
        let mut mask = Vec::new();
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    mask.push(inside([
                        i as f64 * spacing[0],
                        j as f64 * spacing[1],
                        k as f64 * spacing[2],
                    ]));
                }
            }
        }
        mask
    }

    /// Closing by brute force: x is in the closing unless some ball that holds it misses the
    /// set.
    fn brute_force(mask: &[bool], dims: [usize; 3], spacing: [f64; 3], r: f64) -> Vec<bool> {
        let ball = Ball::new(spacing, r);
        let at = |i: isize, j: isize, k: isize| {
            let inside = (0..3).all(|a| [i, j, k][a] >= 0 && ([i, j, k][a] as usize) < dims[a]);
            inside && mask[i as usize + dims[0] * (j as usize + dims[1] * k as usize)]
        };
        let dilated = |i: isize, j: isize, k: isize| {
            ball.offsets
                .iter()
                .any(|d| at(i + d[0], j + d[1], k + d[2]))
        };
        let mut out = Vec::new();
        for k in 0..dims[2] as isize {
            for j in 0..dims[1] as isize {
                for i in 0..dims[0] as isize {
                    out.push(
                        ball.offsets
                            .iter()
                            .all(|d| dilated(i + d[0], j + d[1], k + d[2])),
                    );
                }
            }
        }
        out
    }

    #[test]
    fn closing_equals_brute_force_on_two_nearby_blobs() {
        let dims = [30, 22, 16];
        let spacing = [0.8, 0.8, 1.5];
        let mask = grid(
            dims,
            |[x, y, z]| {
                let a = (x - 7.0).powi(2) + (y - 8.0).powi(2) + (z - 10.0).powi(2) < 16.0;
                let b = (x - 15.0).powi(2) + (y - 8.0).powi(2) + (z - 10.0).powi(2) < 9.0;
                a || b
            },
            spacing,
        );
        let mut closed = mask.clone();
        let added = close(&mut closed, dims, spacing, 1.7).unwrap();
        assert!(!added.is_empty(), "the gap between the blobs must fill");
        let expected = brute_force(&mask, dims, spacing, 1.7);
        let differ = (0..mask.len())
            .filter(|&n| closed[n] != expected[n])
            .count();
        assert_eq!(differ, 0, "voxels that differ from the brute-force closing");
        for n in added {
            assert!(!mask[n] && closed[n]);
        }
    }

    #[test]
    fn erosion_separates_two_touching_balls_into_two_cores() {
        // Two balls of radius 5 whose surfaces touch at x = 15.
        let dims = [32, 16, 16];
        let spacing = [1.0; 3];
        let ball = |p: [f64; 3], c: f64| {
            (p[0] - c).powi(2) + (p[1] - 8.0).powi(2) + (p[2] - 8.0).powi(2) <= 25.0
        };
        let mask = grid(dims, |p| ball(p, 10.0) || ball(p, 20.0), spacing);
        assert_eq!(components(&mask, dims).unwrap().1, 1);
        let cores = erode(&mask, dims, spacing, 2.0).unwrap();
        let (labels, count) = components(&cores, dims).unwrap();
        assert_eq!(count, 2);
        let at = |i: usize| i + 32 * (8 + 16 * 8);
        assert_ne!(labels[at(10)], labels[at(20)]);
        assert!(cores.iter().zip(&mask).all(|(&c, &m)| !c || m));
        // Dilating the cores back gives no more than the balls.
        let back = dilate(&cores, dims, spacing, 2.0).unwrap();
        assert!(back.iter().zip(&mask).all(|(&b, &m)| !b || m));
    }

    #[test]
    fn a_ball_is_closed_already_and_a_thin_tunnel_fills() {
        let dims = [20, 20, 20];
        let spacing = [1.0; 3];
        let ball = grid(
            dims,
            |p| p.iter().map(|c| (c - 9.5).powi(2)).sum::<f64>() < 36.0,
            spacing,
        );
        assert!(close(&mut ball.clone(), dims, spacing, 1.5)
            .unwrap()
            .is_empty());
        // A slab pierced by a hole one voxel wide.
        let pierced = grid(
            dims,
            |[x, y, z]| {
                (6.0..=12.0).contains(&z)
                    && (2.0..18.0).contains(&x)
                    && (2.0..18.0).contains(&y)
                    && !(x == 10.0 && y == 10.0)
            },
            spacing,
        );
        let mut closed = pierced.clone();
        let added = close(&mut closed, dims, spacing, 1.5).unwrap();
        assert_eq!(added.len(), 7, "the hole's seven voxels");
    }
}
