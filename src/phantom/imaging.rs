//! What a scanner does to the ideal intensities of a phantom, in order: a Gaussian point
//! spread function (separable, σ in mm, clamped edges), a smooth multiplicative bias field (MR's
//! intensity drift: one low-frequency sinusoid), Gaussian noise from per-slab SplitMix64 streams
//! (so that it is independent of the thread count), and rounding to the output scalar type.

use glam::DVec3;
use rayon::prelude::*;

use super::random::SplitMix64;
use crate::error::Result;
use crate::geometry::Geometry;
use crate::volume::{Image, ScalarType, VoxelBuffer};

/// A multiplicative drift 1 + amplitude · sin(2π (p − centre) · direction / wavelength + phase).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BiasField {
    pub centre: DVec3,
    pub direction: DVec3,
    pub wavelength: f64,
    pub phase: f64,
    pub amplitude: f64,
}

impl BiasField {
    pub fn factor(&self, p: DVec3) -> f64 {
        let along = (p - self.centre).dot(self.direction) / self.wavelength;
        1.0 + self.amplitude * (std::f64::consts::TAU * along + self.phase).sin()
    }
}

/// How the ideal image is degraded and stored.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Imaging {
    /// Gaussian σ of the point spread function in mm (0 = none).
    pub blur_mm: f64,
    pub bias: Option<BiasField>,
    /// Gaussian noise σ in intensity units.
    pub noise_sigma: f64,
    pub noise_seed: u64,
    /// `I16` (rounded and clamped) or `F32`.
    pub output: ScalarType,
}

impl Imaging {
    /// Blur, bias, noise and rounding of the ideal intensities `voxels` on `geometry`.
    pub fn apply(
        &self,
        mut voxels: Vec<f32>,
        dims: [usize; 3],
        geometry: Geometry,
    ) -> Result<Image> {
        if self.blur_mm > 0.0 {
            gaussian_blur(&mut voxels, dims, &geometry, self.blur_mm);
        }
        if let Some(bias) = &self.bias {
            voxels
                .par_chunks_mut(dims[0] * dims[1])
                .enumerate()
                .for_each(|(k, slab)| {
                    for (n, v) in slab.iter_mut().enumerate() {
                        let index =
                            DVec3::new((n % dims[0]) as f64, (n / dims[0]) as f64, k as f64);
                        *v = (f64::from(*v) * bias.factor(geometry.index_to_world(index))) as f32;
                    }
                });
        }
        if self.noise_sigma > 0.0 {
            add_noise(&mut voxels, dims, self.noise_sigma, self.noise_seed);
        }
        let buffer = match self.output {
            ScalarType::I16 => VoxelBuffer::I16(
                voxels
                    .par_iter()
                    .map(|v| v.round().clamp(f32::from(i16::MIN), f32::from(i16::MAX)) as i16)
                    .collect(),
            ),
            _ => VoxelBuffer::F32(voxels),
        };
        Image::new(buffer, dims, geometry)
    }
}

/// Separable Gaussian blur with σ in mm, per-axis in voxels; edges clamp.
pub fn gaussian_blur(data: &mut [f32], dims: [usize; 3], geometry: &Geometry, sigma_mm: f64) {
    let stride = [1, dims[0], dims[0] * dims[1]];
    for axis in 0..3 {
        let sigma = sigma_mm / geometry.spacing()[axis];
        let radius = (3.0 * sigma).ceil() as isize;
        let weights: Vec<f64> = (-radius..=radius)
            .map(|x| (-0.5 * (x as f64 / sigma).powi(2)).exp())
            .collect();
        let total: f64 = weights.iter().sum();
        let source = data.to_vec();
        let n = dims[axis] as isize;
        data.par_iter_mut().enumerate().for_each(|(idx, out)| {
            let pos = (idx / stride[axis] % dims[axis]) as isize;
            let base = idx as isize - pos * stride[axis] as isize;
            let sum: f64 = weights
                .iter()
                .zip(-radius..=radius)
                .map(|(w, d)| {
                    let p = (pos + d).clamp(0, n - 1);
                    w * source[(base + p * stride[axis] as isize) as usize] as f64
                })
                .sum();
            *out = (sum / total) as f32;
        });
    }
}

/// Adds N(0, σ²) noise; each slab has its own stream so the result is thread-count independent.
pub fn add_noise(data: &mut [f32], dims: [usize; 3], sigma: f64, seed: u64) {
    let slab = dims[0] * dims[1];
    data.par_chunks_mut(slab)
        .enumerate()
        .for_each(|(k, voxels)| {
            let mut rng = SplitMix64::new(seed ^ (k as u64).wrapping_mul(0xD1B5_4A32_D192_ED03));
            for v in voxels {
                *v += (sigma * rng.gaussian()) as f32;
            }
        });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bias_field_stays_within_its_amplitude() {
        let bias = BiasField {
            centre: DVec3::ONE,
            direction: DVec3::new(0.6, 0.8, 0.0),
            wavelength: 80.0,
            phase: 1.0,
            amplitude: 0.2,
        };
        for i in 0..1000 {
            let f = bias.factor(DVec3::new(i as f64 * 0.37, -(i as f64), 3.0));
            assert!((0.8 - 1e-12..=1.2 + 1e-12).contains(&f));
        }
    }

    #[test]
    fn int16_output_rounds_and_clamps() {
        let imaging = Imaging {
            blur_mm: 0.0,
            bias: None,
            noise_sigma: 0.0,
            noise_seed: 0,
            output: ScalarType::I16,
        };
        let image = imaging
            .apply(vec![1.4, -2.6, 1e6, -1e6], [4, 1, 1], Geometry::identity())
            .unwrap();
        assert_eq!(
            image.buffer(),
            &VoxelBuffer::I16(vec![1, -3, 32767, -32768])
        );
    }
}
