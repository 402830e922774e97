//! The structure's intensity model from the seed alone, so that a user only clicks: its level,
//! the window `[lower, upper]` the balloon may inflate in, and the strength of its edge, which
//! tells the border rule (`border`) an edge from a dip inside the structure.
//!
//! The window's ends come from the tissue right outside the structure, found along rays from
//! the seed — never from global percentiles, which in CT are air or lung, far below the fat and
//! muscle that touch a vessel:
//! - **Reference**: the image at the seed as the balloon sees it (smoothed over half a voxel:
//!   a thin vessel is two or three voxels wide, so a block of voxels would mix in its
//!   surroundings). **Noise**: σ of the voxels from the median absolute first difference in a
//!   box around the seed (Immerkær-style: edges only touch the tails).
//! - **Rays**: 162 rays (the vertices of a twice-subdivided icosahedron) leave the seed in world
//!   space, sampled every half of the smallest spacing up to 80 mm or the volume's edge, each
//!   profile smoothed by a Gaussian of one voxel (voxels measured along the ray).
//! - **A ray's edge** is the first place where its profile leaves the band `reference ± 3σ`
//!   (at least 2% of the rays' spread of intensities, for a noiseless image) and steps to a
//!   level beyond that band on the other side of its steepest point (Canny's criterion): the
//!   mean of the profile two to three voxels beyond it. Smaller excursions are
//!   noise or the structure's own texture; the ray then goes on from where it comes back. A
//!   step up counts only if it is also at least half of the structure's median contrast
//!   to its darker surroundings: contrast mixing inside a lumen varies by a tenth of that.
//! - **The ray's border** is the half maximum of its edge: half-way between the profile two to
//!   three voxels inside and two to three voxels outside the steepest point (FWHM).
//! - **The window** comes from the rays that meet an edge within 1.5 times the rays' median
//!   distance to theirs: along a vessel, a ray meets the vessel's own slow drift long before it
//!   leaves it. Its lower end is the median of the borders of those rays that step down —
//!   each ray's first edge is the tissue right outside the structure, so muscle next to a
//!   vessel bounds it and not the fat or lung beyond — and its upper end the median of the
//!   borders of the rays that step up, if at least [`MIN_SIDE_RAYS`] do (bone, calcium,
//!   stent struts, denser contrast); otherwise that side is open. Either end stays at least
//!   2.5σ from the reference, so that the window holds the seed's own neighbourhood.
//! - **In a CT** the Hounsfield scale adds what the rays may not see: the lower end of a
//!   structure brighter than soft tissue is at least half-way to the soft tissue around the
//!   seed, the upper end at most half-way to dense calcium (`hounsfield`).
//! - **Edge strength**: the steepest slope (intensity per mm) at the rays' edges on the profile
//!   smoothed at the scale the border rule reads gradients at (`edge_scale_mm`), so that the
//!   rule compares like with like.
//!
//! With the window given, the rays cross at its ends and only the edge strength is measured.

use glam::DVec3;

use crate::allocation;
use crate::balloon::image_model::border::{ImageScales, IntensityWindow};
use crate::balloon::image_model::hounsfield;
use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use crate::smoothed_volume::{gaussian_weights, SmoothedVolume};
use crate::volume::Volume;

/// The tissue the rays met on one side of the structure (darker or brighter).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Neighbours {
    /// Rays whose first edge steps to this side.
    pub rays: usize,
    /// Median level of the tissue two to three voxels beyond those edges.
    pub level: f64,
    /// The window's end this side gives (±∞ with fewer than [`MIN_SIDE_RAYS`] rays).
    pub border: f64,
    /// Median steepest slope at those edges (intensity per mm, at the edge scale).
    pub edge_strength: f64,
}

/// What was estimated, for reports and for the user to override.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SeedStatistics {
    pub reference: f64,
    /// σ of the voxels' noise around the seed.
    pub noise: f64,
    /// σ of the image smoothed at the scale of local steps (`ImageScales::mid`) inside the
    /// structure (noise and the structure's own texture, such as contrast mixing in a lumen), on the rays between a voxel from the seed and
    /// [`TEXTURE_REACH`] of the way to their edges.
    pub texture: f64,
    /// The same on the fine image (`ImageScales::fine`), where the crests of thin bright layers
    /// are read (`thin_layer`).
    pub fine_texture: f64,
    pub darker: Neighbours,
    pub brighter: Neighbours,
    /// In a CT, the level of the soft tissue around the seed (`hounsfield`).
    pub soft_tissue: Option<f64>,
    /// The estimated window: `[darker.border, brighter.border]`, each end at least 2.5σ from
    /// the reference.
    pub window: IntensityWindow,
    /// Median steepest slope over every ray's edge (intensity per mm, at the edge scale).
    pub edge_strength: f64,
}

impl SeedStatistics {
    /// Rays that met the structure's edge, of [`RAYS`].
    pub fn rays_exited(&self) -> usize {
        self.darker.rays + self.brighter.rays
    }

    /// The structure's contrast to its surroundings: to the darker tissue the rays met, or to
    /// the brighter one if none is darker.
    pub fn contrast(&self) -> f64 {
        if self.darker.rays > 0 {
            self.reference - self.darker.level
        } else {
            self.brighter.level - self.reference
        }
    }
}

pub const RAYS: usize = 162;
const MIN_EXITED_RAYS: usize = 8;
/// Rays that must step up before the window gets an upper end (3% of them).
pub const MIN_SIDE_RAYS: usize = 5;
const MAX_RAY_MM: f64 = 80.0;
/// A ray leaves the structure where its profile leaves `reference ± BAND_SIGMAS σ`, and steps
/// to a level at least as far.
const BAND_SIGMAS: f64 = 3.0;
/// The band is at least this share of the spread of the rays' samples (1st to 99th
/// percentile), so that on a noiseless image rounding is not an edge.
const BAND_FLOOR: f64 = 0.02;
/// A step up is an edge only if at least this share of the structure's contrast to its darker
/// surroundings.
const BRIGHTER_SHARE: f64 = 0.5;
/// The percentile of the darker borders taken as the lower end (and its complement for the
/// brighter ones): the median, robust to the few rays whose first edge is a farther tissue.
const NEAREST_PERCENTILE: f64 = 0.5;
/// Only the edges within this many times the rays' median distance to their edge shape the
/// window: along a vessel, a ray meets the vessel's own slow drift long before it leaves it.
const NEAR_RAYS: f64 = 1.5;
/// In a CT, the soft tissue bounds the window only below a structure brighter than it by this
/// many σ of the structure's texture on the fine image, the image the balloon reads (in σ of
/// the raw noise, 24 HU on the portal-venous CT, its portal vein 71 HU above the liver fell
/// 1 HU short, and the window took in the liver).
const CT_MARGIN_SIGMAS: f64 = 3.0;
/// The window's ends stay at least this many σ from the reference.
const MIN_HALF_WIDTH_SIGMAS: f64 = 2.5;
/// How far along the rays towards their edges the structure's texture is sampled.
const TEXTURE_REACH: f64 = 0.6;
/// Half-width (voxels) of the box whose first differences give the noise.
const NOISE_BOX: usize = 16;

/// Estimates the statistics around `seed` (world mm) in `image` (`image.coarse` sets the scale
/// of the edge strength). `reference` replaces the estimated level when given.
pub(crate) fn estimate(
    image: &ImageScales<'_>,
    seed: DVec3,
    reference: Option<f64>,
) -> Result<SeedStatistics> {
    let volume = image.fine.volume();
    let index = seed_index(volume, seed)?;
    let reference = match reference {
        Some(r) => r,
        None => seed_level(image, seed)?,
    };
    let noise = noise_sigma(volume, index)?;
    let rays = Rays::cast(volume, seed, image.coarse.sigma_mm());
    // At least a rounding error of the reference, so that a uniform region has no edge.
    let band = (BAND_SIGMAS * noise)
        .max(BAND_FLOOR * rays.spread())
        .max(1e-6 * reference.abs().max(1.0));
    let down = rays.edges(reference, band, |e| e.outside < reference);
    let contrast = median(
        &mut down
            .iter()
            .map(|e| reference - e.outside)
            .collect::<Vec<_>>(),
    );
    // Without darker surroundings (a dark structure) every step up counts.
    let step_up = if contrast.is_nan() {
        0.0
    } else {
        BRIGHTER_SHARE * contrast
    };
    let edges = rays.edges(reference, band, |e| {
        e.outside < reference || e.outside - reference >= step_up
    });
    let nearest = NEAR_RAYS * median(&mut edges.iter().map(|e| e.distance).collect::<Vec<_>>());
    let (darker, brighter): (Vec<RayEdge>, Vec<RayEdge>) = edges
        .into_iter()
        .filter(|e| e.distance <= nearest)
        .partition(|e| e.outside < reference);
    if darker.len() + brighter.len() < MIN_EXITED_RAYS {
        return Err(no_edge(darker.len() + brighter.len(), reference, noise));
    }
    let margin = MIN_HALF_WIDTH_SIGMAS * noise;
    let darker_side = side(&darker, NEAREST_PERCENTILE, f64::NEG_INFINITY);
    let brighter_side = side(&brighter, 1.0 - NEAREST_PERCENTILE, f64::INFINITY);
    let texture_on = |scale| texture(scale, seed, darker.iter().chain(&brighter));
    let (texture, fine_texture) = (texture_on(&image.mid), texture_on(&image.fine));
    let ct = hounsfield::is_ct(volume);
    let soft_tissue = ct
        .then(|| hounsfield::soft_tissue_level(volume, seed))
        .flatten();
    let (ct_lower, ct_upper) = if ct {
        let seen = if fine_texture > 0.0 {
            fine_texture
        } else {
            noise
        };
        hounsfield::window_bounds(reference, soft_tissue, CT_MARGIN_SIGMAS * seen)
    } else {
        (f64::NEG_INFINITY, f64::INFINITY)
    };
    // The soft tissue's bound is the half-way between two calibrated tissues, where the
    // balloon's image tells them apart best; widened by the noise, it would sink into the soft
    // tissue (the portal vein's window reached 112 HU, the liver being at 101).
    let window = IntensityWindow::new(
        reference,
        darker_side.border.min(reference - margin).max(ct_lower),
        brighter_side.border.min(ct_upper).max(reference + margin),
    );
    let mut slopes: Vec<f64> = darker.iter().chain(&brighter).map(|e| e.slope).collect();
    Ok(SeedStatistics {
        reference,
        noise,
        texture,
        fine_texture,
        soft_tissue,
        darker: darker_side,
        brighter: brighter_side,
        window,
        edge_strength: median(&mut slopes),
    })
}

/// What the edges on one side say, with `open` as the window's end when too few rays met one.
fn side(edges: &[RayEdge], percentile: f64, open: f64) -> Neighbours {
    if edges.is_empty() {
        return Neighbours {
            rays: 0,
            level: f64::NAN,
            border: open,
            edge_strength: f64::NAN,
        };
    }
    let mut borders: Vec<f64> = edges.iter().map(|e| e.half_maximum).collect();
    borders.sort_unstable_by(f64::total_cmp);
    Neighbours {
        rays: edges.len(),
        level: median(&mut edges.iter().map(|e| e.outside).collect::<Vec<_>>()),
        border: if edges.len() >= MIN_SIDE_RAYS {
            percentile_of_sorted(&borders, percentile)
        } else {
            open
        },
        edge_strength: median(&mut edges.iter().map(|e| e.slope).collect::<Vec<_>>()),
    }
}

/// The structure's edge strength at the scale `edge_scale_mm` (intensity per mm, the median
/// over the rays) when its window is given: the rays meet the edge where they leave the window
/// (each ray's first exit, below or above).
pub(crate) fn edge_strength(
    image: &ImageScales<'_>,
    seed: DVec3,
    window: &IntensityWindow,
) -> Result<f64> {
    let volume = image.fine.volume();
    seed_index(volume, seed)?;
    let rays = Rays::cast(volume, seed, image.coarse.sigma_mm());
    let edges: Vec<RayEdge> = rays
        .profiles
        .iter()
        .filter_map(|p| p.window_exit(window))
        .collect();
    if edges.len() < MIN_EXITED_RAYS {
        return Err(Error::invalid_argument(format!(
            "only {} of {RAYS} rays from the seed leave the window {window} within {MAX_RAY_MM} \
             mm: the seed is not inside a structure that this window bounds; move the seed or \
             change the window",
            edges.len()
        )));
    }
    Ok(median(
        &mut edges.iter().map(|e| e.slope).collect::<Vec<_>>(),
    ))
}

/// The seed's continuous index, if the seed is inside the volume on a known intensity (the
/// rays start there).
fn seed_index(volume: &Volume<'_>, seed: DVec3) -> Result<DVec3> {
    let index = volume.geometry().world_to_index(seed);
    let dims = volume.dims();
    match volume.sample_index(index) {
        None => Err(Error::invalid_argument(format!(
            "the seed {seed} mm is at voxel index {index}, outside the volume (dims {dims:?}); \
             give the seed in world millimetres (or as a voxel index with --index)"
        ))),
        Some(v) if !v.is_finite() => Err(Error::invalid_volume(format!(
            "the intensity at the seed {seed} mm is {v}: the voxels there are NaN or infinite, \
             the intensity unknown — move the seed or repair the volume"
        ))),
        Some(_) => Ok(index),
    }
}

fn no_edge(found: usize, reference: f64, noise: f64) -> Error {
    Error::invalid_argument(format!(
        "cannot estimate the intensity window: only {found} of {RAYS} rays from the seed found \
         an edge within {MAX_RAY_MM} mm (intensity around the seed {reference:.4}, noise σ \
         {noise:.4}); the seed may be in a uniform region or background — move it into the \
         structure or give the reference intensity and tolerance explicitly"
    ))
}

/// The smoothed intensity profiles along the rays from a seed.
struct Rays {
    profiles: Vec<Profile>,
}

/// One ray's profile, sampled every `step` mm: smoothed by a Gaussian of one voxel, and at the
/// edge scale.
struct Profile {
    smoothed: Vec<f64>,
    edge_scale: Vec<f64>,
    direction: DVec3,
    /// A voxel's length along the ray, in samples.
    voxel: f64,
    step: f64,
}

/// Where a ray meets the structure's edge.
#[derive(Debug, Clone, Copy)]
struct RayEdge {
    direction: DVec3,
    /// From the seed to the steepest point, mm.
    distance: f64,
    /// The profile two to three voxels beyond the steepest point.
    outside: f64,
    half_maximum: f64,
    slope: f64,
}

impl Rays {
    fn cast(volume: &Volume<'_>, seed: DVec3, edge_scale_mm: f64) -> Rays {
        let geometry = volume.geometry();
        let step = 0.5 * geometry.min_spacing();
        let to_index = geometry.world_to_index_matrix();
        let samples = (MAX_RAY_MM / step).ceil() as usize;
        let profiles = ray_directions()
            .into_iter()
            .map(|direction| {
                let raw: Vec<f64> = (0..samples)
                    .map_while(|n| {
                        volume
                            .sample_world(seed + direction * (n as f64 * step))
                            .filter(|v| v.is_finite())
                    })
                    .collect();
                let voxel = 1.0 / (to_index * direction).length() / step;
                Profile {
                    direction,
                    smoothed: gaussian_smoothed(&raw, voxel.max(1.0)),
                    edge_scale: gaussian_smoothed(&raw, edge_scale_mm / step),
                    voxel,
                    step,
                }
            })
            .collect();
        Rays { profiles }
    }

    /// The spread of every ray's smoothed samples, from the 1st to the 99th percentile.
    fn spread(&self) -> f64 {
        let mut all: Vec<f64> = self
            .profiles
            .iter()
            .flat_map(|p| p.smoothed.iter().copied())
            .collect();
        if all.is_empty() {
            return 0.0;
        }
        all.sort_unstable_by(f64::total_cmp);
        percentile_of_sorted(&all, 0.99) - percentile_of_sorted(&all, 0.01)
    }

    /// Each ray's first edge out of `reference ± band` that `accept` takes.
    fn edges(&self, reference: f64, band: f64, accept: impl Fn(&RayEdge) -> bool) -> Vec<RayEdge> {
        self.profiles
            .iter()
            .filter_map(|p| p.first_edge(reference, band, &accept))
            .collect()
    }
}

impl Profile {
    /// The first edge out of `reference ± band` to a level beyond the band that `accept` takes;
    /// after an excursion that is not one, the search goes on from where the profile comes back
    /// into the band.
    fn first_edge(
        &self,
        reference: f64,
        band: f64,
        accept: &impl Fn(&RayEdge) -> bool,
    ) -> Option<RayEdge> {
        let s = &self.smoothed;
        let outside = |v: f64| (v - reference).abs() > band;
        let mut from = 0;
        loop {
            let exit = from + s[from..].iter().position(|&v| outside(v))?;
            let falling = s[exit] < reference;
            if let Some(edge) = self.edge_near(exit, falling) {
                if (edge.outside - reference).abs() > band && accept(&edge) {
                    return Some(edge);
                }
            }
            from = exit + s[exit..].iter().position(|&v| !outside(v))?;
        }
    }

    /// The ray's first exit from `window` as an edge.
    fn window_exit(&self, window: &IntensityWindow) -> Option<RayEdge> {
        let exit = self.smoothed.iter().position(|&v| !window.contains(v))?;
        self.edge_near(exit, self.smoothed[exit] < window.reference)
    }

    /// The edge at the steepest point within two voxels of sample `at`, falling or rising.
    fn edge_near(&self, at: usize, falling: bool) -> Option<RayEdge> {
        let s = &self.smoothed;
        let sign = if falling { -1.0 } else { 1.0 };
        let slope = |s: &[f64], n: usize| sign * (s[n + 1] - s[n - 1]);
        let reach = (2.0 * self.voxel).ceil() as usize;
        let last = s.len().checked_sub(2)?;
        let lo = at.saturating_sub(reach).max(1);
        let hi = (at + reach).min(last);
        if lo > hi {
            return None;
        }
        let steepest_in =
            |s: &[f64]| (lo..=hi).max_by(|&a, &b| slope(s, a).total_cmp(&slope(s, b)));
        let steepest = steepest_in(s)?;
        let scaled = &self.edge_scale;
        let strength = slope(scaled, steepest_in(scaled)?);
        let (near, far) = (
            (2.0 * self.voxel).round() as usize,
            (3.0 * self.voxel).round() as usize,
        );
        let outside = mean(s.get(steepest + near..=steepest + far)?);
        let inside = mean(&s[steepest.saturating_sub(far)..=steepest.saturating_sub(near)]);
        Some(RayEdge {
            direction: self.direction,
            distance: steepest as f64 * self.step,
            outside,
            half_maximum: 0.5 * (inside + outside),
            slope: strength / (2.0 * self.step),
        })
    }
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// `values` smoothed by a Gaussian of `sigma` samples, the ends extended by their last values
/// (a copy for σ = 0).
fn gaussian_smoothed(values: &[f64], sigma: f64) -> Vec<f64> {
    if sigma.is_nan() || sigma <= 0.0 {
        return values.to_vec();
    }
    let kernel = gaussian_weights(sigma);
    let reach = (kernel.len() / 2) as isize;
    let norm: f64 = kernel.iter().sum();
    let last = values.len() as isize - 1;
    (0..values.len() as isize)
        .map(|n| {
            kernel
                .iter()
                .zip(-reach..=reach)
                .map(|(w, i)| w * values[(n + i).clamp(0, last) as usize])
                .sum::<f64>()
                / norm
        })
        .collect()
}

/// The structure's level: the image as the balloon sees it at the seed (smoothed over half a
/// voxel). A thin vessel is two or three voxels wide, so any block of voxels around the seed
/// would mix in its surroundings.
fn seed_level(image: &ImageScales<'_>, seed: DVec3) -> Result<f64> {
    match image.fine.sample_world(seed) {
        Some(v) if v.is_finite() => Ok(v),
        _ => Err(Error::invalid_volume(format!(
            "the voxels around the seed {seed} mm are NaN or infinite; the intensity there is \
             unknown — move the seed or repair the volume"
        ))),
    }
}

/// σ (1.4826 MAD) of the image at `scale` on the rays of `edges` from `seed`, between a voxel
/// from the seed and [`TEXTURE_REACH`] of the way to each ray's edge; 0 where the structure is
/// too small for any sample.
fn texture<'e>(
    scale: &SmoothedVolume<'_>,
    seed: DVec3,
    edges: impl Iterator<Item = &'e RayEdge>,
) -> f64 {
    let geometry = scale.geometry();
    let step = 0.5 * geometry.min_spacing();
    let start = geometry.max_spacing();
    let mut samples: Vec<f64> = edges
        .flat_map(|e| {
            let end = TEXTURE_REACH * e.distance;
            (0..)
                .map(move |n| start + n as f64 * step)
                .take_while(move |&s| s <= end)
                .filter_map(move |s| scale.sample_world(seed + s * e.direction))
        })
        .filter(|v| v.is_finite())
        .collect();
    if samples.is_empty() {
        return 0.0;
    }
    let centre = median(&mut samples);
    1.4826
        * median(
            &mut samples
                .iter()
                .map(|v| (v - centre).abs())
                .collect::<Vec<_>>(),
        )
}

/// σ of the noise around `centre`: the median absolute difference between neighbouring voxels
/// along each axis, in a box of [`NOISE_BOX`] voxels around it, scaled for a Gaussian
/// (1.4826 / √2). Edges and slow trends only reach the tails of those differences.
fn noise_sigma(volume: &Volume<'_>, centre: DVec3) -> Result<f64> {
    let dims = volume.dims();
    let nearest = centre.round();
    let range = |axis: usize| {
        let c = nearest[axis] as usize;
        c.saturating_sub(NOISE_BOX)..(c + NOISE_BOX).min(dims[axis])
    };
    let voxels = range(0).len() * range(1).len() * range(2).len();
    let mut differences = allocation::with_capacity(3 * voxels, "the noise estimate's samples")?;
    for k in range(2) {
        for j in range(1) {
            for i in range(0) {
                let v = volume.get_f64(i, j, k);
                for (a, b, c) in [(i + 1, j, k), (i, j + 1, k), (i, j, k + 1)] {
                    if a < dims[0] && b < dims[1] && c < dims[2] {
                        let d = volume.get_f64(a, b, c) - v;
                        if d.is_finite() {
                            differences.push(d.abs());
                        }
                    }
                }
            }
        }
    }
    if differences.is_empty() {
        return Ok(0.0);
    }
    Ok(1.4826 / std::f64::consts::SQRT_2 * median(&mut differences))
}

fn median(values: &mut [f64]) -> f64 {
    values.sort_unstable_by(f64::total_cmp);
    let n = values.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        values[n / 2]
    } else {
        0.5 * (values[n / 2 - 1] + values[n / 2])
    }
}

/// The `q` quantile of sorted, non-empty `values` by linear interpolation.
fn percentile_of_sorted(values: &[f64], q: f64) -> f64 {
    let at = (values.len() - 1) as f64 * q;
    let (lo, hi) = (at.floor() as usize, at.ceil() as usize);
    values[lo] + (at - lo as f64) * (values[hi] - values[lo])
}

/// 162 well-spread unit directions: a twice-subdivided icosahedron's vertices.
fn ray_directions() -> Vec<DVec3> {
    TriMesh::icosphere(DVec3::ZERO, 1.0, 2).into_parts().0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Geometry;
    use crate::phantom::{self, PhantomOptions, Shape};
    use crate::volume::{Image, VoxelBuffer};

    fn estimated(image: &Image, seed: DVec3) -> Result<SeedStatistics> {
        estimate(&ImageScales::new(image.view()), seed, None)
    }

    #[test]
    fn distinct_ray_directions() {
        let d = ray_directions();
        assert_eq!(d.len(), RAYS);
        for (a, u) in d.iter().enumerate() {
            for v in &d[a + 1..] {
                assert!(u.dot(*v) < 0.99);
            }
        }
    }

    #[test]
    fn noisy_oblique_phantoms_give_the_half_way_lower_end_and_no_upper_one() {
        let options = PhantomOptions {
            spacing: [0.8, 0.8, 1.5],
            direction: phantom::oblique_direction(),
            noise: 0.1,
            ..PhantomOptions::default()
        };
        for shape in Shape::ALL {
            let p = phantom::render(shape, &options).unwrap();
            let s = estimated(&p.image, p.seed_world()).unwrap();
            // Object 1100, background 100, noise σ 100: the edge is half-way; nothing is
            // brighter than the object.
            assert!((s.reference - 1100.0).abs() < 80.0, "{shape:?} {s:?}");
            assert!((s.noise - 100.0).abs() < 25.0, "{shape:?} {s:?}");
            assert!((s.window.lower - 600.0).abs() < 70.0, "{shape:?} {s:?}");
            assert_eq!(s.window.upper, f64::INFINITY, "{shape:?} {s:?}");
            assert_eq!(s.brighter.rays, 0, "{shape:?} {s:?}");
            assert!(s.soft_tissue.is_none());
        }
    }

    #[test]
    fn noiseless_phantom_has_the_edge_half_way() {
        let p = phantom::render(Shape::Sphere, &PhantomOptions::default()).unwrap();
        let s = estimated(&p.image, p.seed_world()).unwrap();
        assert_eq!(s.reference, 1100.0);
        assert_eq!(s.noise, 0.0);
        assert_eq!(s.texture, 0.0);
        // The partial-volume ramp, sampled along the rays at half-voxel steps, is steepest
        // at its middle; curvature and sampling move that by a few percent of the contrast.
        assert!((s.window.lower - 600.0).abs() < 30.0, "{s:?}");
        assert_eq!(s.rays_exited(), RAYS);
        assert_eq!(s.window.tolerance(), 1100.0 - s.window.lower);
    }

    /// A ball of radius 8 at 1000 on 100, cut by a slab at 2000 on one side.
    fn ball_against_bone() -> Image {
        let n = 40;
        let values = (0..n * n * n)
            .map(|i| {
                let p = DVec3::new((i % n) as f64, (i / n % n) as f64, (i / (n * n)) as f64);
                if p.x >= 26.0 {
                    2000.0
                } else if (p - DVec3::new(20.0, 20.0, 20.0)).length() <= 8.0 {
                    1000.0
                } else {
                    100.0
                }
            })
            .collect();
        Image::new(VoxelBuffer::F64(values), [n, n, n], Geometry::identity()).unwrap()
    }

    #[test]
    fn brighter_neighbours_get_an_upper_end_below_them() {
        let s = estimated(&ball_against_bone(), DVec3::splat(20.0)).unwrap();
        assert!(s.brighter.rays >= MIN_SIDE_RAYS, "{s:?}");
        assert!((s.brighter.level - 2000.0).abs() < 150.0, "{s:?}");
        assert!(s.window.upper > 1200.0 && s.window.upper < 1600.0, "{s:?}");
        assert!((s.window.lower - 550.0).abs() < 60.0, "{s:?}");
        assert!(s.window.contains(s.reference));
    }

    /// A CT: a vessel of radius 6 at 170 HU in soft tissue at 100 HU, air above z = 32, and
    /// noise of σ 24 HU (a sum of four hashed uniforms): a portal vein in the liver.
    fn vessel_in_soft_tissue_with_noise() -> Image {
        let n = 40;
        let values = (0..n * n * n)
            .map(|i| {
                let (x, y, z) = ((i % n) as f64, (i / n % n) as f64, (i / (n * n)) as f64);
                let uniform = |k: u64| {
                    let h = (i as u64 * 4 + k + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
                    ((h ^ (h >> 29)).wrapping_mul(0xBF58_476D_1CE4_E5B9) >> 11) as f64
                        / (1u64 << 53) as f64
                };
                // Four uniforms: variance 1/3, so σ 24 needs a factor 24·√3.
                let noise = 24.0 * 3f64.sqrt() * ((0..4).map(uniform).sum::<f64>() - 2.0);
                let level = if z >= 32.0 {
                    -1000.0
                } else if (x - 20.0).hypot(y - 20.0) <= 6.0 {
                    170.0
                } else {
                    100.0
                };
                level + noise
            })
            .collect();
        Image::new(VoxelBuffer::F64(values), [n, n, n], Geometry::identity()).unwrap()
    }

    #[test]
    fn a_ct_vessel_three_noise_sigmas_above_soft_tissue_keeps_the_soft_tissue_out() {
        // 70 HU above the soft tissue, under three σ of the raw noise but far above three of
        // the texture on the fine image: the lower end is the half-way, 135, not widened by
        // the noise to 110, into the soft tissue.
        let s = estimated(
            &vessel_in_soft_tissue_with_noise(),
            DVec3::new(20.0, 20.0, 16.0),
        )
        .unwrap();
        assert!((s.noise - 24.0).abs() < 4.0, "{s:?}");
        assert!(170.0 - 100.0 < CT_MARGIN_SIGMAS * s.noise, "{s:?}");
        assert!((s.soft_tissue.unwrap() - 100.0).abs() < 6.0, "{s:?}");
        assert!((s.window.lower - 135.0).abs() < 6.0, "{s:?}");
    }

    #[test]
    fn seed_outside_or_in_a_uniform_region_is_a_clear_error() {
        let p = phantom::render(Shape::Sphere, &PhantomOptions::default()).unwrap();
        let e = estimated(&p.image, DVec3::splat(500.0)).unwrap_err();
        assert!(e.message().contains("outside the volume"), "{e}");
        let uniform = Image::new(
            VoxelBuffer::U8(vec![7; 20 * 20 * 20]),
            [20, 20, 20],
            Geometry::identity(),
        )
        .unwrap();
        let e = estimated(&uniform, DVec3::splat(10.0)).unwrap_err();
        assert!(e.message().contains("rays"), "{e}");
    }

    #[test]
    fn nan_voxels_around_the_seed_are_reported() {
        let voxels: Vec<f32> = (0..16 * 16 * 16)
            .map(|n| if n % 4 == 0 { 1.0 } else { f32::NAN })
            .collect();
        let image =
            Image::new(VoxelBuffer::F32(voxels), [16, 16, 16], Geometry::identity()).unwrap();
        let e = estimated(&image, DVec3::splat(8.0)).unwrap_err();
        assert!(e.message().contains("NaN"), "{e}");
    }

    #[cfg(feature = "io")]
    #[test]
    fn real_seeds_find_the_lumen_and_the_tissue_around_it() {
        let Some(dir) = balloonseg_testkit::data_dir() else {
            return;
        };
        // ../shared/data/README.md: around the aorta seed the median is 1933; the lumen's
        // median is 1946 and a shell outside it 341, half-way 1143; vmtk's surface sits at a
        // median of 1195.
        let aorta = crate::io::read_image(&dir.join("vmtk-aorta/aorta.mha")).unwrap();
        let geometry = *aorta.view().geometry();
        let seed = DVec3::new(-221.484, -156.445, 22.501);
        let s = estimated(&aorta, seed).unwrap();
        eprintln!("aorta: {s:?}");
        assert!((s.reference - 1933.0).abs() < 80.0, "{s:?}");
        assert!(s.window.lower > 1100.0 && s.window.lower < 1220.0, "{s:?}");
        assert!(s.soft_tissue.is_none(), "not a CT: {s:?}");
        // Regression: one voxel away from the seed the first estimate (the first exit from the
        // noise band) found dips inside the lumen on a third of the rays and gave borders from
        // 1040 to 1340 (the balloon then stopped 4 cm short of the renal arteries).
        for axis in 0..3 {
            for side in [-1.0, 1.0] {
                let mut index = geometry.world_to_index(seed);
                index[axis] += side;
                let near = estimated(&aorta, geometry.index_to_world(index)).unwrap();
                assert!(
                    (near.window.lower - s.window.lower).abs() < 60.0,
                    "{index}: {near:?}"
                );
            }
        }
        // The carotid seed: vessels 257–430 on a background of about 100.
        let carotid = crate::io::read_image(&dir.join("vtk-carotid/carotid.mha")).unwrap();
        let s = estimated(&carotid, DVec3::new(117.0, 103.0, 9.0)).unwrap();
        eprintln!("carotid: {s:?}");
        assert!(s.reference > 257.0 && s.reference < 431.0, "{s:?}");
        assert!(
            s.window.lower > 100.0 && s.window.lower < s.reference,
            "{s:?}"
        );
    }
}
