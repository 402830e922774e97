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

use rayon::prelude::*;

/// Closes `mask` (i fastest, `dims`, spacing in mm) with a ball of `radius_mm`; returns the
/// indices of the voxels it adds, ascending. The set must stay one ball's width away from the
/// grid's faces (voxels beyond them count as outside), or it is closed against those faces.
pub fn close(mask: &mut [bool], dims: [usize; 3], spacing: [f64; 3], radius_mm: f64) -> Vec<usize> {
    let closed = erode(
        &dilate(mask, dims, spacing, radius_mm),
        dims,
        spacing,
        radius_mm,
    );
    let mut added = Vec::new();
    for (n, inside) in mask.iter_mut().enumerate() {
        if !*inside && closed[n] {
            *inside = true;
            added.push(n);
        }
    }
    added
}

/// The voxels within `radius_mm` of a voxel of `mask` (i fastest, `dims`, spacing in mm).
pub fn dilate(mask: &[bool], dims: [usize; 3], spacing: [f64; 3], radius_mm: f64) -> Vec<bool> {
    let ball = Ball::new(spacing, radius_mm);
    let grid = Grid(dims);
    let mut dilated = mask.to_vec();
    for n in (0..mask.len()).filter(|&n| mask[n]) {
        if grid.neighbours(n).any(|m| !mask[m]) || grid.on_face(n) {
            ball.mark(&mut dilated, grid, n);
        }
    }
    dilated
}

/// The voxels of `mask` farther than `radius_mm` from every voxel of the grid outside it
/// (those beyond the grid's faces do not count).
pub fn erode(mask: &[bool], dims: [usize; 3], spacing: [f64; 3], radius_mm: f64) -> Vec<bool> {
    let ball = Ball::new(spacing, radius_mm);
    let grid = Grid(dims);
    let mut near_outside = vec![false; mask.len()];
    let mut source = vec![false; mask.len()];
    for n in (0..mask.len()).filter(|&n| mask[n]) {
        for m in grid.neighbours(n) {
            if !mask[m] && !source[m] {
                source[m] = true;
                ball.mark(&mut near_outside, grid, m);
            }
        }
    }
    mask.iter()
        .zip(&near_outside)
        .map(|(&m, &o)| m && !o)
        .collect()
}

/// For each voxel of `mask`, its Euclidean distance (mm) to the nearest voxel outside it (0
/// outside; a mask without outside voxels is as far as the grid is long). Exact, by
/// Felzenszwalb and Huttenlocher's lower envelope of parabolas ("Distance transforms of sampled
/// functions", 2012), one axis after the other with that axis's spacing; the lines of an axis
/// are independent, so they run in parallel with the same result for any thread count.
pub fn distance_to_outside(mask: &[bool], dims: [usize; 3], spacing: [f64; 3]) -> Vec<f64> {
    let far = dims
        .iter()
        .zip(spacing)
        .map(|(&n, s)| n as f64 * s)
        .sum::<f64>()
        .powi(2);
    let [nx, ny, nz] = dims;
    let mut squared: Vec<f64> = mask
        .par_iter()
        .map(|&m| if m { far } else { 0.0 })
        .collect();
    if squared.is_empty() {
        return squared;
    }
    // Each line is transformed on its own, so any order gives the same values.
    // Along x the lines are the rows.
    squared.par_chunks_mut(nx).for_each_init(
        || LowerEnvelope::with_capacity(nx),
        |envelope, row| envelope.transform(row, spacing[0]),
    );
    // Along y, slab by slab: the lines of a slab are gathered row by row.
    squared.par_chunks_mut(nx * ny).for_each_init(
        || (LowerEnvelope::with_capacity(ny), vec![0.0; nx * ny]),
        |(envelope, lines), slab| {
            transform_strided_lines(envelope, slab, lines, nx, ny, spacing[1]);
        },
    );
    // Along z, a row of lines at a time (all i for one j), gathered from every slab into a
    // buffer, and scattered back slab by slab.
    let columns: Vec<Vec<f64>> = (0..ny)
        .into_par_iter()
        .map_init(
            || LowerEnvelope::with_capacity(nz),
            |envelope, j| {
                let mut lines = vec![0.0; nx * nz];
                for k in 0..nz {
                    let row = &squared[(k * ny + j) * nx..][..nx];
                    for (i, &v) in row.iter().enumerate() {
                        lines[i * nz + k] = v;
                    }
                }
                for line in lines.chunks_mut(nz) {
                    envelope.transform(line, spacing[2]);
                }
                lines
            },
        )
        .collect();
    squared
        .par_chunks_mut(nx * ny)
        .enumerate()
        .for_each(|(k, slab)| {
            for (j, lines) in columns.iter().enumerate() {
                for (i, v) in slab[j * nx..][..nx].iter_mut().enumerate() {
                    *v = lines[i * nz + k];
                }
            }
        });
    squared.into_par_iter().map(f64::sqrt).collect()
}

/// Transforms the `count` lines of `slab` that run across its rows of `width` voxels (the
/// lines of a slab along y), gathered into `lines` (line after line) and scattered back.
fn transform_strided_lines(
    envelope: &mut LowerEnvelope,
    slab: &mut [f64],
    lines: &mut [f64],
    width: usize,
    count: usize,
    spacing: f64,
) {
    for (t, row) in slab.chunks(width).enumerate() {
        for (i, &v) in row.iter().enumerate() {
            lines[i * count + t] = v;
        }
    }
    for line in lines.chunks_mut(count) {
        envelope.transform(line, spacing);
    }
    for (t, row) in slab.chunks_mut(width).enumerate() {
        for (i, v) in row.iter_mut().enumerate() {
            *v = lines[i * count + t];
        }
    }
}

/// The lower envelope of the parabolas `(x − q)² s² + f(q)` of one line (F&H's 1D pass).
struct LowerEnvelope {
    vertices: Vec<usize>,
    bounds: Vec<f64>,
    /// The line before the transform: its values at the envelope's vertices are read while
    /// the line is overwritten.
    original: Vec<f64>,
}

impl LowerEnvelope {
    fn with_capacity(n: usize) -> Self {
        LowerEnvelope {
            vertices: Vec::with_capacity(n),
            bounds: Vec::with_capacity(n + 1),
            original: Vec::with_capacity(n),
        }
    }

    /// Replaces `f` by `min_q (x − q)² s² + f(q)` for samples `spacing` apart.
    fn transform(&mut self, f: &mut [f64], spacing: f64) {
        // A line wholly outside stays so: most lines of a box around a vessel.
        if f.iter().all(|&x| x == 0.0) {
            return;
        }
        let s2 = spacing * spacing;
        let (v, z, original) = (&mut self.vertices, &mut self.bounds, &mut self.original);
        v.clear();
        z.clear();
        let meet = |q: usize, p: usize, f: &[f64]| {
            ((f[q] + s2 * (q * q) as f64) - (f[p] + s2 * (p * p) as f64))
                / (2.0 * s2 * (q as f64 - p as f64))
        };
        v.push(0);
        z.push(f64::NEG_INFINITY);
        z.push(f64::INFINITY);
        for q in 1..f.len() {
            let mut s = meet(q, v[v.len() - 1], f);
            while s <= z[v.len() - 1] {
                v.pop();
                z.pop();
                s = meet(q, v[v.len() - 1], f);
            }
            z.pop();
            v.push(q);
            z.push(s);
            z.push(f64::INFINITY);
        }
        original.clear();
        original.extend_from_slice(f);
        let mut k = 0;
        for (x, out) in f.iter_mut().enumerate() {
            while z[k + 1] < x as f64 {
                k += 1;
            }
            let d = x as f64 - v[k] as f64;
            *out = s2 * d * d + original[v[k]];
        }
    }
}

/// The 6-connected components of `mask`: a label per voxel (`u32::MAX` outside the mask),
/// numbered in the order of their first voxel, and how many there are.
pub fn components(mask: &[bool], dims: [usize; 3]) -> (Vec<u32>, u32) {
    let grid = Grid(dims);
    let mut labels = vec![u32::MAX; mask.len()];
    let mut count = 0;
    let mut stack = Vec::new();
    for start in 0..mask.len() {
        if !mask[start] || labels[start] != u32::MAX {
            continue;
        }
        labels[start] = count;
        stack.push(start);
        while let Some(n) = stack.pop() {
            for m in grid.neighbours(n) {
                if mask[m] && labels[m] == u32::MAX {
                    labels[m] = count;
                    stack.push(m);
                }
            }
        }
        count += 1;
    }
    (labels, count)
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
mod tests {
    use super::*;

    #[test]
    fn distance_to_outside_is_exact_on_an_anisotropic_grid() {
        // A box of 9 × 7 × 5 voxels inside a 13 × 11 × 9 grid, spacing 0.5 × 1 × 2 mm.
        let dims = [13, 11, 9];
        let spacing = [0.5, 1.0, 2.0];
        let inside = |i: usize, j: usize, k: usize| {
            (2..11).contains(&i) && (2..9).contains(&j) && (2..7).contains(&k)
        };
        let mask: Vec<bool> = (0..13 * 11 * 9)
            .map(|n| inside(n % 13, n / 13 % 11, n / 143))
            .collect();
        let d = distance_to_outside(&mask, dims, spacing);
        for (n, exact) in brute_force_distances(&mask, dims, spacing)
            .into_iter()
            .enumerate()
        {
            let (i, j, k) = (n % 13, n / 13 % 11, n / 143);
            assert!(
                (d[n] - exact).abs() < 1e-9,
                "({i},{j},{k}): {} vs {exact}",
                d[n]
            );
        }
    }

    /// Each voxel's distance to the nearest voxel outside `mask`, over every outside voxel.
    fn brute_force_distances(mask: &[bool], dims: [usize; 3], spacing: [f64; 3]) -> Vec<f64> {
        let position = |n: usize| {
            let (i, j, k) = (n % dims[0], n / dims[0] % dims[1], n / (dims[0] * dims[1]));
            [
                i as f64 * spacing[0],
                j as f64 * spacing[1],
                k as f64 * spacing[2],
            ]
        };
        (0..mask.len())
            .map(|n| {
                if !mask[n] {
                    return 0.0;
                }
                let p = position(n);
                (0..mask.len())
                    .filter(|&o| !mask[o])
                    .map(|o| {
                        let q = position(o);
                        ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2))
                            .sqrt()
                    })
                    .fold(f64::INFINITY, f64::min)
            })
            .collect()
    }

    #[test]
    fn distance_to_outside_of_a_scattered_mask_is_exact_and_the_same_on_any_thread_count() {
        // Two overlapping balls and a few scattered voxels, in a grid whose sides differ, so
        // that rows, slabs and columns all have lines inside and wholly outside.
        let dims = [17, 12, 9];
        let spacing = [0.7, 1.0, 1.9];
        let mask = grid(
            dims,
            |[x, y, z]| {
                let ball = |c: [f64; 3], r: f64| {
                    (x - c[0]).powi(2) + (y - c[1]).powi(2) + (z - c[2]).powi(2) < r * r
                };
                ball([4.0, 5.0, 7.0], 3.5) || ball([7.5, 6.0, 8.0], 3.0)
            },
            spacing,
        )
        .into_iter()
        .enumerate()
        .map(|(n, m)| m || n % 97 == 5)
        .collect::<Vec<_>>();
        let in_pool = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| distance_to_outside(&mask, dims, spacing))
        };
        let d = in_pool(1);
        assert_eq!(d, in_pool(2));
        for (n, exact) in brute_force_distances(&mask, dims, spacing)
            .into_iter()
            .enumerate()
        {
            assert!((d[n] - exact).abs() < 1e-9, "{n}: {} vs {exact}", d[n]);
        }
    }

    fn grid(dims: [usize; 3], inside: impl Fn([f64; 3]) -> bool, spacing: [f64; 3]) -> Vec<bool> {
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
        let added = close(&mut closed, dims, spacing, 1.7);
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
        assert_eq!(components(&mask, dims).1, 1);
        let cores = erode(&mask, dims, spacing, 2.0);
        let (labels, count) = components(&cores, dims);
        assert_eq!(count, 2);
        let at = |i: usize| i + 32 * (8 + 16 * 8);
        assert_ne!(labels[at(10)], labels[at(20)]);
        assert!(cores.iter().zip(&mask).all(|(&c, &m)| !c || m));
        // Dilating the cores back gives no more than the balls.
        let back = dilate(&cores, dims, spacing, 2.0);
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
        assert!(close(&mut ball.clone(), dims, spacing, 1.5).is_empty());
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
        let added = close(&mut closed, dims, spacing, 1.5);
        assert_eq!(added.len(), 7, "the hole's seven voxels");
    }
}
