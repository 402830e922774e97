//! Distance transforms of voxel grids, exact, by Felzenszwalb and Huttenlocher's lower envelope
//! of parabolas ("Distance transforms of sampled functions", Theory of Computing 2012): the
//! transform `min_q |p − q|² + f(q)` of a sampled function, one axis after the other with that
//! axis's spacing. The lines of an axis are independent, so they run in parallel with the same
//! result for any thread count.
//!
//! Two uses: each voxel's distance to the outside of a mask (`f` is 0 outside and far inside),
//! and the power diagram of labelled balls (`f` is minus each ball's squared radius), whose
//! label travels with the parabola that wins.

use rayon::prelude::*;

use crate::allocation;
use crate::error::Result;
use crate::kernels::mask_voxels::MaskVoxels;

/// A sample of a line: the value the envelope minimises, and what goes with the sample whose
/// parabola is lowest at a point (nothing, or a label).
trait Sample: Copy + Default + Send + Sync {
    fn value(self) -> f64;
    /// This sample, as the lowest parabola where it takes `value`.
    fn with_value(self, value: f64) -> Self;
}

impl Sample for f64 {
    fn value(self) -> f64 {
        self
    }

    fn with_value(self, value: f64) -> Self {
        value
    }
}

impl Sample for (f64, u32) {
    fn value(self) -> f64 {
        self.0
    }

    fn with_value(self, value: f64) -> Self {
        (value, self.1)
    }
}

/// For each voxel of `mask`, its Euclidean distance (mm) to the nearest voxel outside it (0
/// outside; a mask without outside voxels is as far as the grid is long).
pub fn distance_to_outside(mask: &[bool], dims: [usize; 3], spacing: [f64; 3]) -> Result<Vec<f64>> {
    let voxels = MaskVoxels::new(mask, dims)?;
    let depth = depth_in_mask(&voxels, spacing)?;
    voxels.scatter(depth, 0.0, "a distance map")
}

/// [`distance_to_outside`] at the mask's voxels only, in the mask's order. Outside the mask
/// every pass leaves 0 (each outside voxel is its own nearest), so only the mask's voxels are
/// kept between passes, and a pass gathers its lines into a slab's or a row's worth of
/// buffer: the memory is the mask's, not the grid's.
pub(crate) fn depth_in_mask(mask: &MaskVoxels, spacing: [f64; 3]) -> Result<Vec<f64>> {
    let dims = mask.dims();
    let [nx, ny, nz] = dims;
    let far = far(dims, spacing);
    let mut squared = allocation::filled(mask.len(), far, "a distance map")?;
    // Along x and y, slab by slab in a buffer of the slab.
    mask.split_by_slab(&mut squared)
        .into_par_iter()
        .enumerate()
        .filter(|(_, values)| !values.is_empty())
        .for_each_init(
            || {
                (
                    LowerEnvelope::with_capacity(nx.max(ny)),
                    vec![0.0; nx * ny],
                    vec![0.0; nx * ny],
                )
            },
            |(envelope, plane, lines), (k, values)| {
                let first = mask.slab(k).start;
                let at = |c: usize| mask.voxel(c) - k * nx * ny;
                plane.fill(0.0);
                for (c, &v) in (first..).zip(values.iter()) {
                    plane[at(c)] = v;
                }
                for row in plane.chunks_mut(nx) {
                    envelope.transform(row, spacing[0]);
                }
                transform_strided_lines(envelope, plane, lines, nx, ny, spacing[1]);
                for (c, v) in (first..).zip(values.iter_mut()) {
                    *v = plane[at(c)];
                }
            },
        );
    // Along z, a row of lines at a time (all i for one j), gathered from every slab, a few
    // rows at once, and scattered back slab by slab.
    let batch = 2 * rayon::current_num_threads();
    for first in (0..ny).step_by(batch) {
        let rows = first..(first + batch).min(ny);
        let columns: Vec<Vec<f64>> = rows
            .clone()
            .into_par_iter()
            .map_init(
                || LowerEnvelope::with_capacity(nz),
                |envelope, j| {
                    if (0..nz).all(|k| mask.row(j, k).is_empty()) {
                        return Vec::new();
                    }
                    let mut lines = vec![0.0; nx * nz];
                    for k in 0..nz {
                        for c in mask.row(j, k) {
                            lines[(mask.voxel(c) % nx) * nz + k] = squared[c];
                        }
                    }
                    for line in lines.chunks_mut(nz) {
                        envelope.transform(line, spacing[2]);
                    }
                    lines
                },
            )
            .collect();
        mask.split_by_slab(&mut squared)
            .into_par_iter()
            .enumerate()
            .for_each(|(k, values)| {
                let start = mask.slab(k).start;
                for (j, lines) in rows.clone().zip(&columns) {
                    for c in mask.row(j, k) {
                        values[c - start] = lines[(mask.voxel(c) % nx) * nz + k];
                    }
                }
            });
    }
    squared.par_iter_mut().for_each(|d| *d = d.sqrt());
    Ok(squared)
}

/// The label of each voxel's cell in the power diagram (Aurenhammer, "Power diagrams", SIAM J.
/// Comput. 1987) of the balls around the labelled voxels (`labels[n] != unlabelled`), each as
/// wide as its `radius` (mm): the label of the ball of least power `|p − c|² − r²`. Where two
/// round structures overlap, the faces between their cells are the planes through the rim of
/// their contact; the nearest voxel, or the deepest, would bend the boundary into the smaller.
/// Every voxel gets a label, when there is one at all.
pub fn power_labels(
    radius: &[f64],
    labels: &[u32],
    unlabelled: u32,
    dims: [usize; 3],
    spacing: [f64; 3],
) -> Result<Vec<u32>> {
    let far = far(dims, spacing);
    let mut samples = allocation::par_collect(
        radius.par_iter().zip(labels).map(|(&r, &l)| {
            if l == unlabelled {
                (far, l)
            } else {
                (-r * r, l)
            }
        }),
        "a power diagram's samples",
    )?;
    transform(&mut samples, dims, spacing);
    allocation::par_collect(samples.into_par_iter().map(|(_, l)| l), "a power diagram")
}

/// More than any squared distance within the grid.
fn far(dims: [usize; 3], spacing: [f64; 3]) -> f64 {
    dims.iter()
        .zip(spacing)
        .map(|(&n, s)| n as f64 * s)
        .sum::<f64>()
        .powi(2)
}

/// Replaces the samples (i fastest, `dims`) by their transform.
fn transform<T: Sample>(samples: &mut [T], dims: [usize; 3], spacing: [f64; 3]) {
    let [nx, ny, nz] = dims;
    if samples.is_empty() {
        return;
    }
    // Each line is transformed on its own, so any order gives the same values.
    // Along x the lines are the rows.
    samples.par_chunks_mut(nx).for_each_init(
        || LowerEnvelope::with_capacity(nx),
        |envelope, row| envelope.transform(row, spacing[0]),
    );
    // Along y, slab by slab: the lines of a slab are gathered row by row.
    samples.par_chunks_mut(nx * ny).for_each_init(
        || {
            (
                LowerEnvelope::with_capacity(ny),
                vec![T::default(); nx * ny],
            )
        },
        |(envelope, lines), slab| {
            transform_strided_lines(envelope, slab, lines, nx, ny, spacing[1]);
        },
    );
    // Along z, a row of lines at a time (all i for one j), gathered from every slab into a
    // buffer, and scattered back slab by slab; a batch of rows at a time, so that the buffers
    // hold a sixteenth of the grid rather than a second copy of it.
    let batch = (ny / 16).max(2 * rayon::current_num_threads()).max(1);
    for first in (0..ny).step_by(batch) {
        let rows = first..(first + batch).min(ny);
        let columns: Vec<Vec<T>> = rows
            .clone()
            .into_par_iter()
            .map_init(
                || LowerEnvelope::with_capacity(nz),
                |envelope, j| {
                    let mut lines = vec![T::default(); nx * nz];
                    for k in 0..nz {
                        let row = &samples[(k * ny + j) * nx..][..nx];
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
        samples
            .par_chunks_mut(nx * ny)
            .enumerate()
            .for_each(|(k, slab)| {
                for (j, lines) in rows.clone().zip(&columns) {
                    for (i, v) in slab[j * nx..][..nx].iter_mut().enumerate() {
                        *v = lines[i * nz + k];
                    }
                }
            });
    }
}

/// Transforms the `count` lines of `slab` that run across its rows of `width` voxels (the
/// lines of a slab along y), gathered into `lines` (line after line) and scattered back.
fn transform_strided_lines<T: Sample>(
    envelope: &mut LowerEnvelope<T>,
    slab: &mut [T],
    lines: &mut [T],
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
struct LowerEnvelope<T> {
    vertices: Vec<usize>,
    bounds: Vec<f64>,
    /// The line before the transform: its values at the envelope's vertices are read while
    /// the line is overwritten.
    original: Vec<T>,
}

impl<T: Sample> LowerEnvelope<T> {
    fn with_capacity(n: usize) -> Self {
        LowerEnvelope {
            vertices: Vec::with_capacity(n),
            bounds: Vec::with_capacity(n + 1),
            original: Vec::with_capacity(n),
        }
    }

    /// Replaces `f` by `min_q (x − q)² s² + f(q)` for samples `spacing` apart.
    fn transform(&mut self, f: &mut [T], spacing: f64) {
        // A line of zeros stays so: a line wholly outside a mask, as most lines of a box
        // around a vessel are.
        if f.iter().all(|x| x.value() == 0.0) {
            return;
        }
        let s2 = spacing * spacing;
        let (v, z, original) = (&mut self.vertices, &mut self.bounds, &mut self.original);
        v.clear();
        z.clear();
        let meet = |q: usize, p: usize, f: &[T]| {
            ((f[q].value() + s2 * (q * q) as f64) - (f[p].value() + s2 * (p * p) as f64))
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
            let lowest = original[v[k]];
            *out = lowest.with_value(s2 * d * d + lowest.value());
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::morphology::tests::grid;

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
        let d = distance_to_outside(&mask, dims, spacing).unwrap();
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
                .install(|| distance_to_outside(&mask, dims, spacing).unwrap())
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

    #[test]
    fn power_labels_give_each_voxel_the_label_of_its_least_power_ball() {
        let dims = [15, 11, 8];
        let spacing = [0.6, 1.0, 1.7];
        // Scattered balls with radii that tie nowhere.
        let count = dims.iter().product::<usize>();
        let labels: Vec<u32> = (0..count)
            .map(|n| {
                if n % 23 == 4 {
                    (n % 3) as u32
                } else {
                    u32::MAX
                }
            })
            .collect();
        let radius: Vec<f64> = (0..count).map(|n| 0.5 + (n % 7) as f64 * 0.37).collect();
        let position = |n: usize| {
            DVec3::new(
                (n % dims[0]) as f64 * spacing[0],
                (n / dims[0] % dims[1]) as f64 * spacing[1],
                (n / (dims[0] * dims[1])) as f64 * spacing[2],
            )
        };
        let power =
            |p: usize, c: usize| (position(p) - position(c)).length_squared() - radius[c].powi(2);
        let got = power_labels(&radius, &labels, u32::MAX, dims, spacing).unwrap();
        for (p, &label) in got.iter().enumerate() {
            let least = |label: u32| {
                (0..count)
                    .filter(|&c| labels[c] == label)
                    .map(|c| power(p, c))
                    .fold(f64::INFINITY, f64::min)
            };
            let best = (0..3).map(least).fold(f64::INFINITY, f64::min);
            assert!((least(label) - best).abs() < 1e-9, "{p}: label {label}");
        }
    }

    #[test]
    fn power_labels_split_two_overlapping_balls_at_the_plane_of_their_rim() {
        // Balls of radius 3 and 1.5 mm whose surfaces cross; labelled by the nearer centre, the
        // larger loses a slab to the smaller, which the power diagram gives back.
        let dims = [30, 16, 16];
        let spacing = [0.5; 3];
        let (a, ra, b, rb) = (
            DVec3::new(5.0, 4.0, 4.0),
            3.0,
            DVec3::new(9.0, 4.0, 4.0),
            1.5,
        );
        let at =
            |n: usize| DVec3::new((n % 30) as f64, (n / 30 % 16) as f64, (n / 480) as f64) * 0.5;
        let inside = |p: DVec3| (p - a).length() < ra || (p - b).length() < rb;
        let mask: Vec<bool> = (0..dims.iter().product()).map(|n| inside(at(n))).collect();
        let depth = distance_to_outside(&mask, dims, spacing).unwrap();
        let labels: Vec<u32> = (0..mask.len())
            .map(|n| match mask[n] {
                false => u32::MAX,
                true if (at(n) - a).length() < (at(n) - b).length() => 0,
                true => 1,
            })
            .collect();
        let got = power_labels(&depth, &labels, u32::MAX, dims, spacing).unwrap();
        // The radical plane: |p − a|² − ra² = |p − b|² − rb².
        let side =
            |p: DVec3| (p - a).length_squared() - ra * ra - (p - b).length_squared() + rb * rb;
        let expected = |n: usize| if side(at(n)) < 0.0 { 0 } else { 1 };
        // Voxel balls only approximate the two balls: within a voxel of the plane either side
        // will do.
        let clear = |n: usize| mask[n] && side(at(n)).abs() > 2.0 * (b - a).length() * 0.5;
        let wrong = |labels: &[u32]| {
            (0..mask.len())
                .filter(|&n| clear(n) && labels[n] != expected(n))
                .count()
        };
        assert_eq!(wrong(&got), 0);
        let slab = wrong(&labels);
        assert!(slab > 20, "the nearer centre misplaces only {slab} voxels");
    }
}
