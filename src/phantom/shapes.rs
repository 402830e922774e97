//! The fixed analytic shapes (sphere, torus, double torus, Y-shaped vessel, two touching
//! tubes, a tube whose contrast fades), rendered with partial-volume voxels, optional Gaussian
//! blur and Gaussian noise, on any spacing and direction.
//!
//! Each shape is an exact signed distance function in world millimetres (negative inside,
//! after Quilez's primitives), so Dice, surface distance and genus of a segmentation can be
//! measured against the truth rather than against another algorithm. Noise comes from our own
//! seeded generator (`random`) so that a phantom is bit-identical across versions, platforms
//! and thread counts.

use glam::{DMat3, DVec3};
use rayon::prelude::*;

use super::grid::covering;
use super::imaging::{add_noise, gaussian_blur};
use super::sdf::segment_distance;
use crate::error::{Error, Result};
use crate::geometry::Geometry;
use crate::volume::{Image, VoxelBuffer};

/// The analytic shapes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    /// Radius 10 mm: genus 0.
    Sphere,
    /// Major radius 12 mm, tube radius 4 mm: genus 1.
    Torus,
    /// Two tori of the same size fused side by side, like an 8: genus 2.
    DoubleTorus,
    /// A trunk (radius 5 mm) that bifurcates into two branches (radius 3.5 mm): genus 0.
    YVessel,
    /// Two parallel tubes (radius 4 mm) whose walls touch along a line; the seed goes in the
    /// first. The case where region growing leaks.
    TouchingTubes,
    /// A tube (radius 5 mm, 60 mm long, along y) whose contrast fades from full at y = 0 to
    /// 30% at y = 20 mm and stays there to its end, like a contrast bolus fading along a
    /// vessel: genus 0. Where it fades, noise decides voxel by voxel which side of the border
    /// it is on.
    FadingTube,
}

impl Shape {
    pub const ALL: [Shape; 6] = [
        Shape::Sphere,
        Shape::Torus,
        Shape::DoubleTorus,
        Shape::YVessel,
        Shape::TouchingTubes,
        Shape::FadingTube,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Shape::Sphere => "sphere",
            Shape::Torus => "torus",
            Shape::DoubleTorus => "double-torus",
            Shape::YVessel => "y-vessel",
            Shape::TouchingTubes => "touching-tubes",
            Shape::FadingTube => "fading-tube",
        }
    }

    pub fn from_name(name: &str) -> Result<Shape> {
        super::named(&Shape::ALL, Shape::name, name, "phantom")
    }

    /// Genus of the shape's surface (of the seeded object for the touching tubes).
    pub fn genus(self) -> u32 {
        match self {
            Shape::Torus => 1,
            Shape::DoubleTorus => 2,
            _ => 0,
        }
    }

    /// Signed distance (mm) from `p` to the surface of the whole shape, negative inside.
    pub fn signed_distance(self, p: DVec3) -> f64 {
        match self {
            Shape::Sphere => p.length() - SPHERE_RADIUS,
            Shape::Torus => torus(p),
            Shape::DoubleTorus => {
                let shift = DVec3::new(TORUS_MAJOR, 0.0, 0.0);
                torus(p - shift).min(torus(p + shift))
            }
            Shape::YVessel => y_vessel(p),
            Shape::TouchingTubes => self.seeded_distance(p).min(second_tube(p)),
            Shape::FadingTube => capsule(p, -FADING_END, FADING_END, FADING_RADIUS),
        }
    }

    /// The share of the full contrast the shape has at `p` (1 but where it fades).
    pub fn contrast(self, p: DVec3) -> f64 {
        match self {
            Shape::FadingTube => {
                let faded = (p.y / FADE_LENGTH).clamp(0.0, 1.0);
                1.0 - (1.0 - FADED_CONTRAST) * faded
            }
            _ => 1.0,
        }
    }

    /// Signed distance to the object the seed is in: the whole shape, except for the touching
    /// tubes where it is the first tube only.
    pub fn seeded_distance(self, p: DVec3) -> f64 {
        match self {
            Shape::TouchingTubes => tube(p + TUBE_OFFSET),
            other => other.signed_distance(p),
        }
    }

    /// Signed distance to the object the seed is not in (the second of the touching tubes), if
    /// the shape has one.
    pub fn unseeded_distance(self, p: DVec3) -> Option<f64> {
        (self == Shape::TouchingTubes).then(|| second_tube(p))
    }

    /// A point deep inside the seeded object (world mm, before the phantom's placement).
    pub fn seed(self) -> DVec3 {
        match self {
            Shape::Sphere => DVec3::ZERO,
            // On the centre line of the tube (of the +x torus for the double torus).
            Shape::Torus => DVec3::new(0.0, TORUS_MAJOR, 0.0),
            Shape::DoubleTorus => DVec3::new(TORUS_MAJOR, TORUS_MAJOR, 0.0),
            Shape::YVessel => DVec3::new(0.0, 0.0, -10.0),
            Shape::TouchingTubes => -TUBE_OFFSET,
            Shape::FadingTube => DVec3::new(0.0, -20.0, 0.0),
        }
    }

    /// A box (lo, hi) that contains the shape.
    pub fn bounds(self) -> (DVec3, DVec3) {
        (-self.half_extent(), self.half_extent())
    }

    /// Half-extent of a box that contains the shape, centred at the origin.
    fn half_extent(self) -> DVec3 {
        match self {
            Shape::Sphere => DVec3::splat(SPHERE_RADIUS),
            Shape::Torus => DVec3::new(16.0, 16.0, 4.0),
            Shape::DoubleTorus => DVec3::new(28.0, 16.0, 4.0),
            Shape::YVessel => DVec3::new(16.0, 6.0, 21.0),
            Shape::TouchingTubes => DVec3::new(8.0, 4.0, 22.0),
            Shape::FadingTube => FADING_END + FADING_RADIUS,
        }
    }
}

const SPHERE_RADIUS: f64 = 10.0;
const TORUS_MAJOR: f64 = 12.0;
const TORUS_MINOR: f64 = 4.0;
const TUBE_RADIUS: f64 = 4.0;
/// Each tube's centre line is this far from the contact line: the walls touch along x = 0.
const TUBE_OFFSET: DVec3 = DVec3::new(TUBE_RADIUS, 0.0, 0.0);
const FADING_RADIUS: f64 = 5.0;
/// The fading tube's centre line runs from −FADING_END to FADING_END.
const FADING_END: DVec3 = DVec3::new(0.0, 30.0, 0.0);
const FADE_LENGTH: f64 = 20.0;
const FADED_CONTRAST: f64 = 0.3;

fn torus(p: DVec3) -> f64 {
    let ring = (p.x * p.x + p.y * p.y).sqrt() - TORUS_MAJOR;
    (ring * ring + p.z * p.z).sqrt() - TORUS_MINOR
}

/// Distance to the segment a–b minus the radius: a cylinder with hemispherical caps.
fn capsule(p: DVec3, a: DVec3, b: DVec3, radius: f64) -> f64 {
    segment_distance(p, a, b) - radius
}

/// A tube along z with rounded ends, centred at the origin.
fn tube(p: DVec3) -> f64 {
    let end = DVec3::new(0.0, 0.0, 18.0);
    capsule(p, -end, end, TUBE_RADIUS)
}

fn second_tube(p: DVec3) -> f64 {
    tube(p - TUBE_OFFSET)
}

fn y_vessel(p: DVec3) -> f64 {
    let fork = DVec3::new(0.0, 0.0, 2.0);
    let trunk = capsule(p, DVec3::new(0.0, 0.0, -16.0), fork, 5.0);
    let left = capsule(p, fork, DVec3::new(-10.0, 0.0, 16.0), 3.5);
    let right = capsule(p, fork, DVec3::new(10.0, 0.0, 16.0), 3.5);
    trunk.min(left).min(right)
}

/// How to render a phantom.
#[derive(Debug, Clone, PartialEq)]
pub struct PhantomOptions {
    pub spacing: [f64; 3],
    /// Row-major direction matrix of the grid.
    pub direction: [f64; 9],
    /// Intensity outside the object.
    pub background: f64,
    /// Intensity inside the object.
    pub foreground: f64,
    /// Gaussian noise σ as a fraction of |foreground − background|.
    pub noise: f64,
    /// Gaussian blur σ in mm (0 = none), applied before the noise like a scanner's PSF.
    pub blur_mm: f64,
    /// Empty margin around the shape, in mm.
    pub margin_mm: f64,
    pub noise_seed: u64,
}

impl Default for PhantomOptions {
    fn default() -> Self {
        PhantomOptions {
            spacing: [1.0; 3],
            direction: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            background: 100.0,
            foreground: 1100.0,
            noise: 0.0,
            blur_mm: 0.0,
            margin_mm: 6.0,
            noise_seed: 1,
        }
    }
}

/// The oblique direction used by the tests: a rotation of 25° about (1, 2, 3)/√14.
pub fn oblique_direction() -> [f64; 9] {
    let m = DMat3::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 25f64.to_radians());
    m.transpose().to_cols_array()
}

/// A rendered phantom: the float32 volume and the shape it was made from.
#[derive(Debug, Clone)]
pub struct Phantom {
    pub shape: Shape,
    pub image: Image,
}

impl Phantom {
    pub fn seed_world(&self) -> DVec3 {
        self.shape.seed()
    }
}

/// Sub-samples per axis for partial-volume voxels near the surface.
const SUPERSAMPLING: usize = 4;

/// Renders `shape` with partial-volume intensities (the covered fraction of each voxel,
/// estimated with 4×4×4 sub-samples near the surface), then blur, then noise.
pub fn render(shape: Shape, options: &PhantomOptions) -> Result<Phantom> {
    if !(options.noise >= 0.0 && options.noise.is_finite()) {
        return Err(Error::invalid_argument(format!(
            "noise is {}; give σ as a non-negative fraction of the contrast, e.g. 0.1",
            options.noise
        )));
    }
    if !(options.blur_mm >= 0.0 && options.blur_mm.is_finite()) {
        return Err(Error::invalid_argument(format!(
            "blur is {} mm; give a non-negative Gaussian σ in mm",
            options.blur_mm
        )));
    }
    if !(options.margin_mm >= 0.0 && options.margin_mm.is_finite()) {
        return Err(Error::invalid_argument(
            "the margin must be a non-negative number of mm",
        ));
    }
    let axes = Geometry::new(options.spacing, [0.0; 3], options.direction)?;
    let (origin, dims) = grid_around(shape.half_extent() + options.margin_mm, &axes)?;
    let geometry = Geometry::new(options.spacing, origin.to_array(), options.direction)?;

    let voxel_reach = 0.5 * DVec3::from(options.spacing).length();
    let contrast = options.foreground - options.background;
    let mut voxels = vec![0.0f32; dims.iter().product()];
    voxels
        .par_chunks_mut(dims[0] * dims[1])
        .enumerate()
        .for_each(|(k, slab)| {
            for (n, v) in slab.iter_mut().enumerate() {
                let centre = DVec3::new((n % dims[0]) as f64, (n / dims[0]) as f64, k as f64);
                let world = geometry.index_to_world(centre);
                let d = shape.signed_distance(world);
                let covered = if d > voxel_reach {
                    0.0
                } else if d < -voxel_reach {
                    1.0
                } else {
                    coverage(shape, &geometry, centre)
                };
                *v = (options.background + contrast * shape.contrast(world) * covered) as f32;
            }
        });
    if options.blur_mm > 0.0 {
        gaussian_blur(&mut voxels, dims, &geometry, options.blur_mm);
    }
    if options.noise > 0.0 {
        add_noise(
            &mut voxels,
            dims,
            options.noise * contrast.abs(),
            options.noise_seed,
        );
    }
    let image = Image::new(VoxelBuffer::F32(voxels), dims, geometry)?;
    Ok(Phantom { shape, image })
}

/// The fraction of the voxel at `centre` inside the shape, from a regular sub-sample grid.
fn coverage(shape: Shape, geometry: &Geometry, centre: DVec3) -> f64 {
    let n = SUPERSAMPLING;
    let mut inside = 0;
    for a in 0..n {
        for b in 0..n {
            for c in 0..n {
                let offset = (DVec3::new(a as f64, b as f64, c as f64) + 0.5) / n as f64 - 0.5;
                if shape.signed_distance(geometry.index_to_world(centre + offset)) < 0.0 {
                    inside += 1;
                }
            }
        }
    }
    inside as f64 / (n * n * n) as f64
}

/// Origin and dims of the smallest grid with these axes that contains the centred box.
fn grid_around(half: DVec3, axes: &Geometry) -> Result<(DVec3, [usize; 3])> {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for corner in 0..8 {
        let c = DVec3::new(
            if corner & 1 == 0 { -half.x } else { half.x },
            if corner & 2 == 0 { -half.y } else { half.y },
            if corner & 4 == 0 { -half.z } else { half.z },
        );
        let index = axes.world_to_index(c);
        lo = lo.min(index);
        hi = hi.max(index);
    }
    covering(lo, hi, axes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn voxels(p: &Phantom) -> &[f32] {
        match p.image.buffer() {
            VoxelBuffer::F32(v) => v,
            _ => panic!("float32 expected"),
        }
    }

    #[test]
    fn distance_functions_are_negative_at_the_seed_and_zero_on_known_surface_points() {
        for shape in Shape::ALL {
            assert!(shape.seeded_distance(shape.seed()) < -2.0, "{shape:?}");
        }
        assert!(
            Shape::Sphere
                .signed_distance(DVec3::new(0.0, 10.0, 0.0))
                .abs()
                < 1e-12
        );
        assert!(
            Shape::Torus
                .signed_distance(DVec3::new(16.0, 0.0, 0.0))
                .abs()
                < 1e-12
        );
        assert!(
            Shape::Torus.signed_distance(DVec3::ZERO) > 0.0,
            "the hole is outside"
        );
        // The touching tubes share exactly one line of contact at x = 0.
        let contact = DVec3::new(0.0, 1e-9, 5.0);
        assert!(Shape::TouchingTubes.seeded_distance(contact).abs() < 1e-9);
        assert!(second_tube(contact).abs() < 1e-9);
    }

    #[test]
    fn shapes_fit_their_field_of_view() {
        for shape in Shape::ALL {
            let h = shape.half_extent();
            for corner in 0..8 {
                let c = DVec3::new(
                    if corner & 1 == 0 { -h.x } else { h.x },
                    if corner & 2 == 0 { -h.y } else { h.y },
                    if corner & 4 == 0 { -h.z } else { h.z },
                );
                assert!(shape.signed_distance(c * 1.001) > 0.0, "{shape:?} {c}");
            }
        }
    }

    #[test]
    fn partial_volume_rendering_gives_the_analytic_volume() {
        let options = PhantomOptions {
            spacing: [0.8, 0.8, 1.5],
            direction: oblique_direction(),
            ..PhantomOptions::default()
        };
        let p = render(Shape::Sphere, &options).unwrap();
        let voxel = 0.8 * 0.8 * 1.5;
        let volume: f64 = voxels(&p)
            .iter()
            .map(|&v| (v as f64 - 100.0) / 1000.0 * voxel)
            .sum();
        let exact = 4.0 / 3.0 * std::f64::consts::PI * 1000.0;
        assert!(
            (volume - exact).abs() / exact < 0.002,
            "{volume} vs {exact}"
        );
    }

    #[test]
    fn noise_is_reproducible_and_independent_of_thread_count() {
        let options = PhantomOptions {
            noise: 0.1,
            blur_mm: 0.5,
            ..PhantomOptions::default()
        };
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let two = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let a = one.install(|| render(Shape::Torus, &options).unwrap());
        let b = two.install(|| render(Shape::Torus, &options).unwrap());
        assert_eq!(voxels(&a), voxels(&b));
        // σ = 10% of the contrast, measured far from the object.
        let clean = render(
            Shape::Torus,
            &PhantomOptions {
                noise: 0.0,
                ..options
            },
        )
        .unwrap();
        let diffs: Vec<f64> = voxels(&a)
            .iter()
            .zip(voxels(&clean))
            .map(|(x, y)| (x - y) as f64)
            .collect();
        let sd = (diffs.iter().map(|d| d * d).sum::<f64>() / diffs.len() as f64).sqrt();
        assert!((sd - 100.0).abs() < 3.0, "σ = {sd}");
    }

    #[test]
    fn blur_preserves_the_mean_intensity() {
        let sharp = render(Shape::Sphere, &PhantomOptions::default()).unwrap();
        let soft = render(
            Shape::Sphere,
            &PhantomOptions {
                blur_mm: 1.0,
                ..PhantomOptions::default()
            },
        )
        .unwrap();
        let mean = |p: &Phantom| voxels(p).iter().map(|&v| v as f64).sum::<f64>();
        assert!((mean(&sharp) - mean(&soft)).abs() / mean(&sharp) < 1e-4);
    }

    #[test]
    fn bad_options_and_names_are_errors() {
        assert!(Shape::from_name("cube")
            .unwrap_err()
            .message()
            .contains("torus"));
        assert_eq!(
            Shape::from_name("double-torus").unwrap(),
            Shape::DoubleTorus
        );
        let bad = PhantomOptions {
            noise: f64::NAN,
            ..PhantomOptions::default()
        };
        assert!(render(Shape::Sphere, &bad).is_err());
        let bad = PhantomOptions {
            spacing: [0.0, 1.0, 1.0],
            ..PhantomOptions::default()
        };
        assert!(render(Shape::Sphere, &bad).is_err());
        let bad = PhantomOptions {
            spacing: [0.001, 1.0, 1.0],
            ..PhantomOptions::default()
        };
        assert!(render(Shape::Sphere, &bad).is_err());
    }
}
