//! A Gaussian-smoothed view of a volume, computed lazily in bricks: the image as the balloon
//! sees it, at the scale of its own triangles rather than of single noisy voxels.
//!
//! The smoothing is separable (a sampled, normalised Gaussian per axis, σ given in mm and
//! converted per axis, so anisotropic voxels are smoothed by the same physical amount; the
//! volume's faces are extended by their last voxel). It is computed only for the bricks of
//! `BRICK`³ voxels that are sampled, each once, when first needed: a balloon visits a thin shell
//! of a large scan, and a smoothed copy of the whole of it would cost more than the
//! segmentation. Bricks are computed the same way whichever thread asks first, so results do
//! not depend on the thread count.
//!
//! Samples are trilinear on the smoothed grid, like [`Volume::sample_index`]. Non-finite voxels
//! stay unknown (NaN) and are left out of their neighbours' averages (normalised convolution),
//! so that unknown data neither spreads over the kernel's reach nor disappears.

use std::sync::OnceLock;

use glam::DVec3;

use crate::geometry::Geometry;
use crate::volume::{Cell, Scalar, TypedVolume, Volume, VoxelVisitor};

/// Voxels per brick side; every brick is stored whole (the last ones padded), so that a voxel's
/// place in its brick is bit arithmetic.
const BRICK: usize = 16;
const BRICK_BITS: u32 = BRICK.trailing_zeros();
const BRICK_VOXELS: usize = BRICK * BRICK * BRICK;
/// The kernel reaches this many σ each way.
const KERNEL_REACH: f64 = 3.0;

/// A lazily smoothed view of a volume.
pub struct SmoothedVolume<'v> {
    volume: Volume<'v>,
    sigma_mm: f64,
    dims: [usize; 3],
    bricks_per_axis: [usize; 3],
    /// One sampled Gaussian per axis, `kernel[a][r + t]` for offsets `t` in `-r..=r`.
    kernels: [Vec<f32>; 3],
    bricks: Vec<OnceLock<Box<[f32; BRICK_VOXELS]>>>,
}

impl<'v> SmoothedVolume<'v> {
    /// `volume` smoothed by a Gaussian of `sigma_mm` (0 or less: not smoothed at all).
    pub fn new(volume: Volume<'v>, sigma_mm: f64) -> Self {
        let dims = volume.dims();
        let spacing = volume.geometry().spacing();
        let kernels = [0, 1, 2].map(|a| gaussian_kernel(sigma_mm / spacing[a]));
        let bricks_per_axis = dims.map(|d| d.div_ceil(BRICK));
        let count = bricks_per_axis.iter().product();
        SmoothedVolume {
            volume,
            sigma_mm,
            dims,
            bricks_per_axis,
            kernels,
            bricks: (0..count).map(|_| OnceLock::new()).collect(),
        }
    }

    pub fn geometry(&self) -> &Geometry {
        self.volume.geometry()
    }

    /// The volume before smoothing.
    pub fn volume(&self) -> &Volume<'v> {
        &self.volume
    }

    /// The Gaussian's σ (mm).
    pub fn sigma_mm(&self) -> f64 {
        self.sigma_mm
    }

    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// The variance (mm², per world axis of the grid) by which sampling this volume blurs the
    /// scan: the discrete Gaussian's, plus trilinear interpolation's, which on average over a
    /// cell blurs like a variance of h²/6 along an axis of spacing h (the interpolant of a
    /// parabola lies h²/12 of its second derivative above it on average).
    pub fn blur_variances(&self) -> [f64; 3] {
        let spacing = self.geometry().spacing();
        [0, 1, 2].map(|a| {
            let kernel = &self.kernels[a];
            let reach = (kernel.len() / 2) as f64;
            let taps: f64 = kernel
                .iter()
                .enumerate()
                .map(|(n, &w)| f64::from(w) * (n as f64 - reach).powi(2))
                .sum();
            (taps + 1.0 / 6.0) * spacing[a] * spacing[a]
        })
    }

    /// The smoothed voxel at (i, j, k).
    pub fn voxel(&self, i: usize, j: usize, k: usize) -> f64 {
        let brick = self.brick([i, j, k].map(|v| v >> BRICK_BITS));
        brick[local(i, j, k)] as f64
    }

    /// Trilinear interpolation at a continuous index; `None` outside `[-0.5, dims-0.5]`.
    pub fn sample_index(&self, p: DVec3) -> Option<f64> {
        let cell = Cell::around(p, self.dims)?;
        Some(cell.interpolate(self.corners(&cell)))
    }

    pub fn sample_world(&self, world: DVec3) -> Option<f64> {
        self.sample_index(self.geometry().world_to_index(world))
    }

    /// The trilinear interpolant's value and gradient (intensity per mm, world axes) at
    /// `world`; `None` outside the volume. One cell's eight voxels give both; the gradient
    /// jumps a little across cell faces, too little on a smoothed image to matter.
    pub fn sample_with_gradient_world(&self, world: DVec3) -> Option<(f64, DVec3)> {
        let geometry = self.geometry();
        let cell = Cell::around(geometry.world_to_index(world), self.dims)?;
        let (c, t) = (self.corners(&cell), cell.t);
        let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
        // Along x on the cell's four x edges (y0z0, y1z0, y0z1, y1z1), then across them.
        let [e00, e10, e01, e11] = [0, 2, 4, 6].map(|n| lerp(c[n], c[n + 1], t.x));
        let (near, far) = (lerp(e00, e10, t.y), lerp(e01, e11, t.y));
        let value = lerp(near, far, t.z);
        let dx = lerp(
            lerp(c[1] - c[0], c[3] - c[2], t.y),
            lerp(c[5] - c[4], c[7] - c[6], t.y),
            t.z,
        );
        let dy = lerp(e10 - e00, e11 - e01, t.z);
        let dz = far - near;
        let per_index = DVec3::new(dx, dy, dz);
        // index = W·(world − origin), so ∂I/∂world = Wᵀ·∂I/∂index.
        Some((
            value,
            geometry.world_to_index_matrix().transpose() * per_index,
        ))
    }

    /// The smoothed voxels at a cell's corners; most cells lie in one brick.
    fn corners(&self, cell: &Cell) -> [f64; 8] {
        let (lo, hi) = (cell.lo, cell.hi);
        if (0..3).all(|a| lo[a] >> BRICK_BITS == hi[a] >> BRICK_BITS) {
            let brick = self.brick(lo.map(|v| v >> BRICK_BITS));
            cell.corners().map(|[i, j, k]| brick[local(i, j, k)] as f64)
        } else {
            cell.corners().map(|[i, j, k]| self.voxel(i, j, k))
        }
    }

    /// Voxels of brick `b` per axis inside the volume (the last bricks are cut by its faces).
    fn brick_extent(&self, b: [usize; 3]) -> [usize; 3] {
        [0, 1, 2].map(|a| BRICK.min(self.dims[a] - b[a] * BRICK))
    }

    fn brick(&self, b: [usize; 3]) -> &[f32; BRICK_VOXELS] {
        let n = b[0] + self.bricks_per_axis[0] * (b[1] + self.bricks_per_axis[1] * b[2]);
        self.bricks[n].get_or_init(|| self.smooth_brick(b))
    }

    /// The smoothed voxels of brick `b` (at `local` places): the raw voxels around it (the
    /// kernels' reach beyond it, faces extended) smoothed along i, then j, then k.
    fn smooth_brick(&self, b: [usize; 3]) -> Box<[f32; BRICK_VOXELS]> {
        let extent = self.brick_extent(b);
        let start = b.map(|v| v * BRICK);
        let reach = self.kernels.clone().map(|k| k.len() / 2);
        // Each pass keeps the reach of the axes still to be smoothed.
        let mut ranges = [0, 1, 2].map(|a| {
            (
                start[a] as isize - reach[a] as isize,
                start[a] as isize + (extent[a] + reach[a]) as isize,
            )
        });
        let size = |r: &[(isize, isize); 3]| r.map(|(lo, hi)| (hi - lo) as usize);
        let mut values = self.volume.dispatch(ReadBox {
            ranges,
            dims: self.dims,
        });
        let unknown = values.iter().any(|v| !v.is_finite());
        for axis in 0..3 {
            let before = size(&ranges);
            let mut after_ranges = ranges;
            after_ranges[axis] = (start[axis] as isize, (start[axis] + extent[axis]) as isize);
            let after = size(&after_ranges);
            let kernel = &self.kernels[axis];
            values = if unknown {
                convolve_axis_with_unknowns(&values, before, after, axis, kernel)
            } else {
                convolve_axis(&values, before, after, axis, kernel)
            };
            ranges = after_ranges;
        }
        let mut brick = Box::new([f32::NAN; BRICK_VOXELS]);
        let mut smoothed = values.into_iter();
        for k in 0..extent[2] {
            for j in 0..extent[1] {
                for i in 0..extent[0] {
                    brick[local(i, j, k)] = smoothed.next().expect("one value per voxel");
                }
            }
        }
        brick
    }
}

/// Reads the voxels of a box of index ranges (any of them may reach beyond the volume, whose
/// faces are then extended), i fastest, as f32.
struct ReadBox {
    ranges: [(isize, isize); 3],
    dims: [usize; 3],
}

impl VoxelVisitor for ReadBox {
    type Output = Vec<f32>;

    fn visit<T: Scalar>(self, volume: &TypedVolume<'_, T>) -> Vec<f32> {
        let clamp = |v: isize, a: usize| v.clamp(0, self.dims[a] as isize - 1) as usize;
        let [(i0, i1), (j0, j1), (k0, k1)] = self.ranges;
        let mut values = Vec::with_capacity(((i1 - i0) * (j1 - j0) * (k1 - k0)) as usize);
        // The part of each row inside the volume, and how far its ends are extended.
        let (inner0, inner1) = (clamp(i0, 0), clamp(i1 - 1, 0) + 1);
        let (before, after) = (
            (inner0 as isize - i0) as usize,
            (i1 - inner1 as isize) as usize,
        );
        for k in k0..k1 {
            for j in j0..j1 {
                let (j, k) = (clamp(j, 1), clamp(k, 2));
                let first = volume.get(inner0, j, k).to_f64() as f32;
                let last = volume.get(inner1 - 1, j, k).to_f64() as f32;
                values.extend(std::iter::repeat(first).take(before));
                match volume.row(j, k) {
                    Some(row) => {
                        values.extend(row[inner0..inner1].iter().map(|v| v.to_f64() as f32))
                    }
                    None => {
                        values.extend((inner0..inner1).map(|i| volume.get(i, j, k).to_f64() as f32))
                    }
                }
                values.extend(std::iter::repeat(last).take(after));
            }
        }
        values
    }
}

/// A voxel's place in its brick.
fn local(i: usize, j: usize, k: usize) -> usize {
    let m = BRICK - 1;
    (i & m) | (j & m) << BRICK_BITS | (k & m) << (2 * BRICK_BITS)
}

/// A sampled Gaussian of `sigma` voxels, normalised; `[1.0]` (no smoothing) for σ = 0.
fn gaussian_kernel(sigma: f64) -> Vec<f32> {
    if !(sigma.is_finite() && sigma > 0.0) {
        return vec![1.0];
    }
    let weights = gaussian_weights(sigma);
    let sum: f64 = weights.iter().sum();
    weights.into_iter().map(|w| (w / sum) as f32).collect()
}

/// `exp(−½ (t/σ)²)` for the offsets `t` within the kernel's reach (`KERNEL_REACH` σ, rounded
/// up) either way, not normalised; σ must be positive.
pub(crate) fn gaussian_weights(sigma: f64) -> Vec<f64> {
    let reach = (KERNEL_REACH * sigma).ceil() as isize;
    (-reach..=reach)
        .map(|t| (-0.5 * (t as f64 / sigma).powi(2)).exp())
        .collect()
}

/// Convolves `values` (an `input` box, i fastest) along `axis` with `kernel`, keeping the
/// middle `output[axis]` positions of that axis (the kernel's reach is cut off either side).
/// Row by row: each tap adds a weighted row of the input to a row of the output.
fn convolve_axis(
    values: &[f32],
    input: [usize; 3],
    output: [usize; 3],
    axis: usize,
    kernel: &[f32],
) -> Vec<f32> {
    let strides = [1, input[0], input[0] * input[1]];
    let mut out = vec![0.0f32; output[0] * output[1] * output[2]];
    for (row, out_row) in out.chunks_exact_mut(output[0]).enumerate() {
        let (j, k) = (row % output[1], row / output[1]);
        let base = j * strides[1] + k * strides[2];
        for (t, &w) in kernel.iter().enumerate() {
            let first = base + t * strides[axis];
            for (o, v) in out_row.iter_mut().zip(&values[first..first + output[0]]) {
                *o += w * v;
            }
        }
    }
    out
}

/// [`convolve_axis`] where some voxels are unknown (non-finite): they stay unknown, and the
/// others average only their known neighbours (normalised convolution).
fn convolve_axis_with_unknowns(
    values: &[f32],
    input: [usize; 3],
    output: [usize; 3],
    axis: usize,
    kernel: &[f32],
) -> Vec<f32> {
    let strides = [1, input[0], input[0] * input[1]];
    let mut out = Vec::with_capacity(output[0] * output[1] * output[2]);
    for k in 0..output[2] {
        for j in 0..output[1] {
            for i in 0..output[0] {
                let base = i + j * strides[1] + k * strides[2];
                let centre = values[base + kernel.len() / 2 * strides[axis]];
                let (mut sum, mut weight) = (0.0, 0.0);
                for (t, w) in kernel.iter().enumerate() {
                    let v = values[base + t * strides[axis]];
                    if v.is_finite() {
                        sum += w * v;
                        weight += w;
                    }
                }
                out.push(if centre.is_finite() {
                    sum / weight
                } else {
                    f32::NAN
                });
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::{Image, VoxelBuffer};

    fn image(dims: [usize; 3], spacing: [f64; 3], f: impl Fn(usize, usize, usize) -> f64) -> Image {
        let mut values = Vec::new();
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    values.push(f(i, j, k));
                }
            }
        }
        Image::new(
            VoxelBuffer::F64(values),
            dims,
            Geometry::with_spacing(spacing, [0.0; 3]).unwrap(),
        )
        .unwrap()
    }

    #[test]
    fn a_parabola_sampled_anywhere_rises_by_the_blur_variance_on_average() {
        // Smoothing and interpolation raise x² by their variance (times half its second
        // derivative, 2), whatever the spacing and σ.
        for (h, sigma) in [(0.8, 0.4), (1.5, 0.4), (0.7, 1.0)] {
            let centre = 10.0 * h;
            let img = image([21, 4, 4], [h, 1.0, 1.0], |i, _, _| {
                (i as f64 * h - centre).powi(2)
            });
            let s = SmoothedVolume::new(img.view(), sigma);
            let samples = 400;
            let rise = (0..samples)
                .map(|n| {
                    let x = centre - 2.0 * h + 4.0 * h * (n as f64 + 0.5) / samples as f64;
                    s.sample_world(DVec3::new(x, 1.5, 1.5)).unwrap() - (x - centre).powi(2)
                })
                .sum::<f64>()
                / samples as f64;
            let variance = s.blur_variances()[0];
            assert!(
                (rise - variance).abs() < 1e-3,
                "{h} {sigma}: {rise} vs {variance}"
            );
        }
    }

    #[test]
    fn a_linear_ramp_is_unchanged_away_from_the_faces() {
        // A Gaussian is symmetric: it keeps a linear function, across brick boundaries too.
        let img = image([40, 35, 20], [0.8, 0.8, 1.5], |i, j, k| {
            3.0 * i as f64 - 2.0 * j as f64 + 5.0 * k as f64
        });
        let s = SmoothedVolume::new(img.view(), 1.0);
        for (i, j, k) in [(5, 5, 5), (15, 16, 14), (16, 17, 3), (31, 20, 12)] {
            let exact = 3.0 * i as f64 - 2.0 * j as f64 + 5.0 * k as f64;
            assert!((s.voxel(i, j, k) - exact).abs() < 1e-3, "{i} {j} {k}");
        }
        let world = DVec3::new(12.3, 11.9, 14.2);
        let (v, g) = s.sample_with_gradient_world(world).unwrap();
        assert!((v - s.sample_world(world).unwrap()).abs() < 1e-9);
        let exact = DVec3::new(3.0 / 0.8, -2.0 / 0.8, 5.0 / 1.5);
        assert!((g - exact).length() < 1e-3, "{g}");
    }

    #[test]
    fn bricks_agree_with_smoothing_the_whole_volume() {
        let dims = [37, 19, 21];
        let noise =
            |i: usize, j: usize, k: usize| ((i * 7919 + j * 104_729 + k * 1299) % 97) as f64;
        let img = image(dims, [1.0, 0.7, 1.3], noise);
        let s = SmoothedVolume::new(img.view(), 1.2);
        // The same separable convolution on the whole volume, faces extended.
        let kernels = [1.0, 0.7, 1.3].map(|sp| gaussian_kernel(1.2 / sp));
        let mut full: Vec<f64> = (0..dims[0] * dims[1] * dims[2])
            .map(|n| noise(n % dims[0], n / dims[0] % dims[1], n / (dims[0] * dims[1])))
            .collect();
        for axis in 0..3 {
            let r = kernels[axis].len() / 2;
            let mut next = full.clone();
            for (n, smoothed) in next.iter_mut().enumerate() {
                let mut at = [n % dims[0], n / dims[0] % dims[1], n / (dims[0] * dims[1])];
                let centre = at[axis] as isize;
                let mut sum = 0.0;
                for (t, &w) in kernels[axis].iter().enumerate() {
                    at[axis] = (centre + t as isize - r as isize).clamp(0, dims[axis] as isize - 1)
                        as usize;
                    sum += w as f64 * full[at[0] + dims[0] * (at[1] + dims[1] * at[2])];
                }
                *smoothed = sum;
            }
            full = next;
        }
        for (n, &expected) in full.iter().enumerate() {
            let (i, j, k) = (n % dims[0], n / dims[0] % dims[1], n / (dims[0] * dims[1]));
            assert!((s.voxel(i, j, k) - expected).abs() < 1e-4, "{i} {j} {k}");
        }
    }

    #[test]
    fn unknown_voxels_stay_where_they_are() {
        // A plate of NaN at i = 10: its neighbours average their finite neighbours.
        let img = image(
            [20, 12, 12],
            [1.0; 3],
            |i, _, _| if i == 10 { f64::NAN } else { 5.0 },
        );
        let s = SmoothedVolume::new(img.view(), 1.0);
        assert!(s.voxel(10, 6, 6).is_nan());
        assert!((s.voxel(9, 6, 6) - 5.0).abs() < 1e-6);
        assert!((s.voxel(11, 6, 6) - 5.0).abs() < 1e-6);
    }

    #[test]
    fn no_smoothing_samples_like_the_volume() {
        let img = image([9, 8, 7], [1.0; 3], |i, j, k| {
            (i * i + 3 * j + k * k * k) as f64
        });
        let s = SmoothedVolume::new(img.view(), 0.0);
        for p in [
            DVec3::new(1.3, 2.7, 4.1),
            DVec3::new(8.0, 7.0, 6.0),
            DVec3::ZERO,
        ] {
            let a = s.sample_index(p).unwrap();
            let b = img.view().sample_index(p).unwrap();
            assert!((a - b).abs() < 1e-3 * b.abs().max(1.0), "{p}: {a} {b}");
        }
        assert_eq!(
            s.sample_index(DVec3::new(-0.4, 1.0, 1.0)),
            s.sample_index(DVec3::new(0.0, 1.0, 1.0))
        );
        assert!(s.sample_index(DVec3::new(-0.6, 1.0, 1.0)).is_none());
    }
}
