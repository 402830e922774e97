//! Default reference intensity and tolerance from the seed alone, so that a user only clicks.
//!
//! - **Reference**: the median of the voxels within 2 voxels (in mm, by the largest spacing) of
//!   the seed, with their median absolute deviation (MAD) as the local noise level.
//! - **Border**: 42 rays (the vertices of a once-subdivided icosahedron) leave the seed in
//!   world space, sampled every half of the smallest spacing. A ray *exits* the structure at
//!   the first of two consecutive samples further than `max(3 · 1.4826 · MAD, 1% of |reference|)`
//!   from the reference. Around the exit the profile is smoothed by a Gaussian of one voxel
//!   (σ), and the edge is where the smoothed profile is steepest, between two voxels before and
//!   three after the exit (Canny's criterion: the maximum of the derivative of a Gaussian-smoothed
//!   profile, which noise moves less than it moves the steepest raw difference); the ray's
//!   border intensity is the smoothed profile's value there. Voxels are measured along the ray
//!   (a voxel's extent in that direction), so on an anisotropic grid the in-plane rays look at
//!   the tissue next to the structure. Rays that reach the volume's edge or 80 mm without
//!   exiting are ignored; at least 8 must exit.
//! - **Tolerance**: |reference − median border|, so the balloon stops where the structure's
//!   edge is steepest — on a blurred step, half-way between the structure and its surroundings
//!   (on the noisy phantoms 573–591 between 1100 and 100); on the vmtk aorta 1182, where vmtk's
//!   reference surface sits at 1195 between a lumen of 1946 and surroundings of 341.
//!
//! A tolerance derived from the spread around the seed alone would stop the balloon far
//! inside the wall (the aorta's MAD is 73 against a contrast of 1600), hence the rays.

use glam::DVec3;

use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use crate::volume::Volume;

/// What was estimated, for reports and for the user to override.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SeedStatistics {
    pub reference: f64,
    /// Median absolute deviation around the seed (not scaled).
    pub spread: f64,
    /// Median intensity at the structure's edge along the rays that left it.
    pub border: f64,
    pub tolerance: f64,
    /// Rays that found the structure's edge, of [`RAYS`].
    pub rays_exited: usize,
}

pub const RAYS: usize = 42;
const MIN_EXITED_RAYS: usize = 8;
const MAX_RAY_MM: f64 = 80.0;

/// Estimates the statistics around `seed` (world mm).
pub fn estimate(volume: &Volume<'_>, seed: DVec3) -> Result<SeedStatistics> {
    let geometry = volume.geometry();
    let index = geometry.world_to_index(seed);
    let dims = volume.dims();
    let inside = (0..3).all(|a| index[a] >= 0.0 && index[a] <= (dims[a] - 1) as f64);
    if !inside {
        return Err(Error::invalid_argument(format!(
            "the seed {seed} mm is at voxel index {index}, outside the volume (dims {dims:?}); \
             give the seed in world millimetres (or as a voxel index with --index)"
        )));
    }
    let (reference, spread) = neighbourhood(volume, index)?;
    let threshold = (3.0 * 1.4826 * spread)
        .max(0.01 * reference.abs())
        .max(f64::EPSILON);
    let step = 0.5 * geometry.min_spacing();
    let to_index = geometry.world_to_index_matrix();

    let mut borders: Vec<f64> = ray_directions()
        .into_iter()
        .filter_map(|direction| {
            // A voxel's length along this ray (mm): anisotropic grids are finer along some
            // rays than along others, and the edge is as sharp as the grid along the ray.
            let voxel = 1.0 / (to_index * direction).length();
            let sample = |t: f64| volume.sample_world(seed + direction * t);
            let far = |v: f64| (v - reference).abs() > threshold;
            let mut t = step;
            while t < MAX_RAY_MM {
                if far(sample(t)?) && far(sample(t + step)?) {
                    return edge_intensity(&sample, t, step, voxel);
                }
                t += step;
            }
            None
        })
        .collect();
    if borders.len() < MIN_EXITED_RAYS {
        return Err(Error::invalid_argument(format!(
            "cannot estimate the tolerance: only {} of {RAYS} rays from the seed found an edge \
             within {MAX_RAY_MM} mm (intensity around the seed {reference:.4}, noise {spread:.4}); \
             the seed may be in a uniform region or background — move it into the structure or \
             give the reference intensity and tolerance explicitly",
            borders.len()
        )));
    }
    let border = median(&mut borders);
    Ok(SeedStatistics {
        reference,
        spread,
        border,
        tolerance: (reference - border).abs(),
        rays_exited: borders.len(),
    })
}

/// The intensity at the edge a ray crosses near `exit` (mm along the ray, sampled every
/// `step`): the value of the profile smoothed by a Gaussian of one `voxel` where it is
/// steepest, within two voxels before and three after the exit. `None` if the smoothing
/// window leaves the volume or holds a non-finite sample.
fn edge_intensity(
    profile: &impl Fn(f64) -> Option<f64>,
    exit: f64,
    step: f64,
    voxel: f64,
) -> Option<f64> {
    let sigma = (voxel / step).max(1.0);
    let reach = (3.0 * sigma).ceil() as isize;
    let kernel: Vec<f64> = (-reach..=reach)
        .map(|i| (-0.5 * (i as f64 / sigma).powi(2)).exp())
        .collect();
    let norm: f64 = kernel.iter().sum();
    let before = (2.0 * voxel / step).ceil() as isize;
    let after = (3.0 * voxel / step).ceil() as isize;
    // Samples far enough either side for the kernel and the differences; the ray starts at
    // the seed, so those before it are the seed's.
    let first = -before - reach - 1;
    let raw: Vec<f64> = (first..=after + reach + 1)
        .map(|i| profile((exit + i as f64 * step).max(0.0)).filter(|v| v.is_finite()))
        .collect::<Option<_>>()?;
    let smoothed = |i: isize| -> f64 {
        let start = (i - first - reach) as usize;
        kernel
            .iter()
            .zip(&raw[start..])
            .map(|(w, v)| w * v)
            .sum::<f64>()
            / norm
    };
    let slope = |i: isize| (smoothed(i + 1) - smoothed(i - 1)).abs();
    // One sample in from the window's ends, for the parabola below.
    let steepest = (1 - before..after)
        .max_by(|&a, &b| slope(a).total_cmp(&slope(b)))
        .expect("a non-empty window");
    // Between samples: the vertex of the parabola through the slopes around the steepest
    // sample, so that the border does not depend on where the samples fall on the edge (on a
    // staircase edge that moved it by a tenth of the contrast between ray directions).
    let (left, centre, right) = (slope(steepest - 1), slope(steepest), slope(steepest + 1));
    let curvature = left - 2.0 * centre + right;
    let offset = if curvature < 0.0 {
        (0.5 * (left - right) / curvature).clamp(-0.5, 0.5)
    } else {
        0.0
    };
    let (here, next) = if offset >= 0.0 {
        (smoothed(steepest), smoothed(steepest + 1))
    } else {
        (smoothed(steepest), smoothed(steepest - 1))
    };
    Some(here + offset.abs() * (next - here))
}

/// Median and MAD of the voxels within 2 voxels of the continuous index `centre`.
fn neighbourhood(volume: &Volume<'_>, centre: DVec3) -> Result<(f64, f64)> {
    let geometry = volume.geometry();
    let spacing = DVec3::from(geometry.spacing());
    let radius_mm = 2.0 * geometry.max_spacing();
    let reach = (DVec3::splat(radius_mm) / spacing).ceil();
    let dims = volume.dims();
    let mut values = Vec::new();
    let lo = (centre - reach).max(DVec3::ZERO).ceil();
    let hi = (centre + reach).floor();
    for k in lo.z as usize..=(hi.z as usize).min(dims[2] - 1) {
        for j in lo.y as usize..=(hi.y as usize).min(dims[1] - 1) {
            for i in lo.x as usize..=(hi.x as usize).min(dims[0] - 1) {
                let offset = DVec3::new(i as f64, j as f64, k as f64) - centre;
                if (offset * spacing).length() <= radius_mm {
                    values.push(volume.get_f64(i, j, k));
                }
            }
        }
    }
    let nan = values.iter().filter(|v| !v.is_finite()).count();
    if nan * 2 > values.len() || values.is_empty() {
        return Err(Error::invalid_volume(format!(
            "{nan} of the {} voxels around the seed are NaN or infinite; the intensity there is \
             unknown — move the seed or repair the volume",
            values.len()
        )));
    }
    values.retain(|v| v.is_finite());
    let reference = median(&mut values);
    let mut deviations: Vec<f64> = values.iter().map(|v| (v - reference).abs()).collect();
    Ok((reference, median(&mut deviations)))
}

fn median(values: &mut [f64]) -> f64 {
    values.sort_unstable_by(f64::total_cmp);
    let n = values.len();
    if n % 2 == 1 {
        values[n / 2]
    } else {
        0.5 * (values[n / 2 - 1] + values[n / 2])
    }
}

/// 42 well-spread unit directions: a once-subdivided icosahedron's vertices (its 12 corners
/// and 30 edge midpoints).
fn ray_directions() -> Vec<DVec3> {
    TriMesh::icosphere(DVec3::ZERO, 1.0, 1).into_parts().0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::phantom::{self, PhantomOptions, Shape};

    #[test]
    fn forty_two_distinct_directions() {
        let d = ray_directions();
        assert_eq!(d.len(), RAYS);
        for (a, u) in d.iter().enumerate() {
            for v in &d[a + 1..] {
                assert!(u.dot(*v) < 0.95);
            }
        }
    }

    #[test]
    fn noisy_oblique_phantom_gives_the_half_way_tolerance() {
        let options = PhantomOptions {
            spacing: [0.8, 0.8, 1.5],
            direction: phantom::oblique_direction(),
            noise: 0.1,
            ..PhantomOptions::default()
        };
        for shape in Shape::ALL {
            let p = phantom::render(shape, &options).unwrap();
            let s = estimate(&p.image.view(), p.seed_world()).unwrap();
            // Object 1100, background 100, noise σ 100: the edge is half-way.
            assert!((s.reference - 1100.0).abs() < 60.0, "{shape:?} {s:?}");
            assert!((s.border - 600.0).abs() < 60.0, "{shape:?} {s:?}");
            assert!((s.tolerance - 500.0).abs() < 90.0, "{shape:?} {s:?}");
        }
    }

    #[test]
    fn noiseless_phantom_has_zero_spread_and_the_edge_half_way() {
        let p = phantom::render(Shape::Sphere, &PhantomOptions::default()).unwrap();
        let s = estimate(&p.image.view(), p.seed_world()).unwrap();
        assert_eq!(s.reference, 1100.0);
        assert_eq!(s.spread, 0.0);
        // The partial-volume ramp, sampled along the rays at half-voxel steps, is steepest
        // at its middle; curvature and sampling move that by a few percent of the contrast.
        assert!((s.border - 600.0).abs() < 30.0, "{s:?}");
        assert_eq!(s.tolerance, 1100.0 - s.border);
        assert_eq!(s.rays_exited, RAYS);
    }

    #[test]
    fn seed_outside_or_in_a_uniform_region_is_a_clear_error() {
        let p = phantom::render(Shape::Sphere, &PhantomOptions::default()).unwrap();
        let e = estimate(&p.image.view(), DVec3::splat(500.0)).unwrap_err();
        assert!(e.message().contains("outside the volume"), "{e}");
        let uniform = crate::Image::new(
            crate::VoxelBuffer::U8(vec![7; 20 * 20 * 20]),
            [20, 20, 20],
            crate::Geometry::identity(),
        )
        .unwrap();
        let e = estimate(&uniform.view(), DVec3::splat(10.0)).unwrap_err();
        assert!(e.message().contains("rays"), "{e}");
    }

    #[test]
    fn nan_voxels_around_the_seed_are_reported() {
        let voxels: Vec<f32> = (0..16 * 16 * 16)
            .map(|n| if n % 4 == 0 { 1.0 } else { f32::NAN })
            .collect();
        let image = crate::Image::new(
            crate::VoxelBuffer::F32(voxels),
            [16, 16, 16],
            crate::Geometry::identity(),
        )
        .unwrap();
        let e = estimate(&image.view(), DVec3::splat(8.0)).unwrap_err();
        assert!(e.message().contains("NaN"), "{e}");
    }

    #[cfg(feature = "io")]
    #[test]
    fn real_seeds_find_the_lumen_and_its_edge() {
        let Some(dir) = crate::test_data::data_dir() else {
            return;
        };
        // ../shared/data/README.md: around the aorta seed the median is 1933 (MAD 73); the
        // reference surface sits at 1195, a shell outside the lumen has 341.
        let aorta = crate::io::read_image(&dir.join("vmtk-aorta/aorta.mha")).unwrap();
        let s = estimate(&aorta.view(), DVec3::new(-221.484, -156.445, 22.501)).unwrap();
        eprintln!("aorta: {s:?}");
        assert!((s.reference - 1933.0).abs() < 60.0, "{s:?}");
        assert!((s.border - 1195.0).abs() < 40.0, "{s:?}");
        assert_eq!(s.reference - s.tolerance, s.border);
        // The carotid seed: vessels 257–430 on a background of about 100.
        let carotid = crate::io::read_image(&dir.join("vtk-carotid/carotid.mha")).unwrap();
        let s = estimate(&carotid.view(), DVec3::new(117.0, 103.0, 9.0)).unwrap();
        eprintln!("carotid: {s:?}");
        assert!(s.reference > 257.0 && s.reference < 430.0, "{s:?}");
        assert!(s.border > 100.0 && s.border < s.reference, "{s:?}");
    }
}
