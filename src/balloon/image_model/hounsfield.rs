//! What the balloon knows of CT: intensities in Hounsfield units are calibrated (air −1000,
//! water 0), so the tissues a contrast-filled structure touches sit at known levels even where
//! the rays from the seed do not meet them.
//!
//! Around the seed, a vessel may lie in fat and lung, and the rays see only those; a few
//! centimetres on, the same vessel runs against enhanced parenchyma, muscle and bowel wall
//! (60–130 HU), with nothing darker in between. A window whose lower end sits half-way to fat
//! takes all of those in. So in CT the lower end of a structure brighter than soft tissue is
//! at least half-way to the soft tissue around it: the brightest mode of the image between 0
//! and 130 HU in a box around the seed (enhanced liver, spleen, muscle). Cortical bone and
//! calcium (from 700 HU) bound the upper end the same way.
//!
//! A volume is taken as CT when a sample of its voxels has air or lung in it (at least 1% at
//! −1100…−500 HU): only a CT has calibrated values that low. A tight crop without air is read
//! as any other image.

use glam::DVec3;

use crate::volume::Volume;

/// Air and lung, in HU: their presence tells a CT.
const AIR: (f64, f64) = (-1100.0, -500.0);
/// The share of the sampled voxels that must be air or lung.
const AIR_SHARE: f64 = 0.01;
/// Voxels sampled to tell a CT, about.
const SAMPLES: usize = 1 << 17;
/// Soft tissue, unenhanced to enhanced (muscle, liver, spleen, pancreas, bowel wall), in HU.
const SOFT_TISSUE: (f64, f64) = (0.0, 130.0);
/// Cortical bone and calcification start here (HU).
const DENSE_CALCIUM: f64 = 700.0;
/// Half-side (mm) of the box around the seed whose soft tissue bounds the window.
const BOX_MM: f64 = 40.0;
/// Width (HU) of the histogram's bins and of the smoothing that finds its mode.
const BIN: f64 = 2.0;
const SMOOTHING_BINS: usize = 3;
/// Soft tissue must make up this share of the box to count.
const MIN_SOFT_SHARE: f64 = 0.05;

/// Whether the volume's intensities are Hounsfield units (see the module's comment).
pub fn is_ct(volume: &Volume<'_>) -> bool {
    let [ni, nj, nk] = volume.dims();
    let total = ni * nj * nk;
    let stride = (total / SAMPLES).max(1);
    let (mut air, mut seen) = (0usize, 0usize);
    for n in (0..total).step_by(stride) {
        let v = volume.get_f64(n % ni, n / ni % nj, n / (ni * nj));
        if v.is_finite() {
            seen += 1;
            air += usize::from((AIR.0..=AIR.1).contains(&v));
        }
    }
    seen > 0 && air as f64 >= AIR_SHARE * seen as f64
}

/// The level (HU) of the soft tissue around `seed`: the mode of the voxels between 0 and
/// 130 HU in a box of ±[`BOX_MM`] around it, if they make up at least [`MIN_SOFT_SHARE`] of it.
pub fn soft_tissue_level(volume: &Volume<'_>, seed: DVec3) -> Option<f64> {
    let geometry = volume.geometry();
    let centre = geometry.world_to_index(seed);
    let spacing = DVec3::from(geometry.spacing());
    let reach = (DVec3::splat(BOX_MM) / spacing).ceil();
    let dims = volume.dims();
    let range = |axis: usize| {
        let lo = (centre[axis] - reach[axis]).max(0.0) as usize;
        let hi = ((centre[axis] + reach[axis]).max(0.0) as usize).min(dims[axis] - 1);
        lo..=hi
    };
    let bins = ((SOFT_TISSUE.1 - SOFT_TISSUE.0) / BIN).ceil() as usize;
    let mut histogram = vec![0usize; bins];
    let mut total = 0usize;
    // Every other voxel along each axis is plenty for a histogram.
    for k in range(2).step_by(2) {
        for j in range(1).step_by(2) {
            for i in range(0).step_by(2) {
                let v = volume.get_f64(i, j, k);
                if !v.is_finite() {
                    continue;
                }
                total += 1;
                if (SOFT_TISSUE.0..SOFT_TISSUE.1).contains(&v) {
                    histogram[((v - SOFT_TISSUE.0) / BIN) as usize] += 1;
                }
            }
        }
    }
    let soft: usize = histogram.iter().sum();
    if total == 0 || (soft as f64) < MIN_SOFT_SHARE * total as f64 {
        return None;
    }
    // A triangular kernel: a flat-topped histogram still has one peak, in its middle.
    let smoothed = |b: usize| -> usize {
        (b.saturating_sub(SMOOTHING_BINS)..(b + SMOOTHING_BINS + 1).min(bins))
            .map(|c| histogram[c] * (SMOOTHING_BINS + 1 - b.abs_diff(c)))
            .sum()
    };
    let mode = (0..bins).max_by_key(|&b| (smoothed(b), b))?;
    Some(SOFT_TISSUE.0 + (mode as f64 + 0.5) * BIN)
}

/// The CT bounds of a window around `reference` (HU): the lower end at least half-way to the
/// soft tissue at `soft` when the structure is brighter than it by more than `margin`, the
/// upper end at most half-way to dense calcium.
pub fn window_bounds(reference: f64, soft: Option<f64>, margin: f64) -> (f64, f64) {
    let lower = match soft {
        Some(s) if reference - s >= margin => 0.5 * (reference + s),
        _ => f64::NEG_INFINITY,
    };
    let upper = if reference < DENSE_CALCIUM {
        0.5 * (reference + DENSE_CALCIUM)
    } else {
        f64::INFINITY
    };
    (lower, upper)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Geometry;
    use crate::volume::{Image, VoxelBuffer};

    /// Air with a block of soft tissue at `soft` HU around a contrast-filled core.
    fn scene(soft: f64, air: bool) -> Image {
        let n = 60;
        let values = (0..n * n * n)
            .map(|i| {
                let (x, y, z) = (i % n, i / n % n, i / (n * n));
                let r = ((x as f64 - 30.0).powi(2) + (y as f64 - 30.0).powi(2)).sqrt();
                if r < 5.0 {
                    250.0
                } else if (10..50).contains(&z) || !air {
                    soft + (i % 7) as f64
                } else {
                    -1000.0
                }
            })
            .collect();
        Image::new(VoxelBuffer::F64(values), [n, n, n], Geometry::identity()).unwrap()
    }

    #[test]
    fn a_ct_is_told_by_its_air_and_its_soft_tissue_bounds_the_window() {
        let ct = scene(60.0, true);
        assert!(is_ct(&ct.view()));
        assert!(!is_ct(&scene(60.0, false).view()));
        let soft = soft_tissue_level(&ct.view(), DVec3::splat(30.0)).unwrap();
        assert!((soft - 63.0).abs() < 4.0, "{soft}");
        let (lower, upper) = window_bounds(250.0, Some(soft), 30.0);
        assert!((lower - 0.5 * (250.0 + soft)).abs() < 1e-9);
        assert_eq!(upper, 475.0);
        // A structure no brighter than soft tissue (the liver itself) keeps its own window.
        assert_eq!(window_bounds(70.0, Some(soft), 30.0).0, f64::NEG_INFINITY);
    }
}
