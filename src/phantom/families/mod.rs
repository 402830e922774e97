//! Families of synthetic scenes, each drawn at random from a variant number: the scans the
//! balloon was never tuned on. A variant is bit-identical for the same number on any machine
//! (with the same libm) and any thread count: every number comes from one SplitMix64 stream
//! seeded by the family and the variant number, drawn in a fixed order.
//!
//! Every variant first draws what all families share — a grid direction uniform on SO(3) (the
//! solids stay in world mm; the grid turns), in-plane spacing s ∈ U[0.6, 1.0] mm for x and y,
//! slices z ∈ U[s, 2.0] mm, a Gaussian PSF σ ∈ U[0, 0.6] mm before noise, and Gaussian noise
//! σ ∈ U[0.05, 0.15] × the family's contrast (the seeded object's intensity minus the tissue
//! right around it) — then its family's scene (`ct_scene`, `thin_wall`, `touching_pair`,
//! `thin_vessels`, `stent`, `vessel_chamber`). The grid covers what matters with a margin of at least 6 mm and
//! holds at most `VOXEL_BUDGET` voxels; context around it (more of a neighbouring organ) is
//! shown when the budget allows.
//!
//! The truth is what the scene paints as the seeded object (its layer minus the layers above,
//! inside the voxels), so the rendering cannot disagree with it.

mod ct_scene;
mod placement;
mod stent;
mod thin_vessels;
mod thin_wall;
mod touching_pair;
mod vessel_chamber;

#[cfg(test)]
mod tests;

use glam::{DMat3, DVec3};

use super::grid::{Ball, Grid};
use super::imaging::{BiasField, Imaging};
use super::random::SplitMix64;
use super::scene::Scene;
use super::sdf::Sdf;
use crate::error::{Error, Result};
use crate::volume::{Image, ScalarType};

/// The families of scenes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Family {
    /// A CT-like thorax around a contrast vessel: body, fat, lung, vertebra, a second vessel
    /// alongside, calcifications; int16 HU. Genus 0.
    CtScene,
    /// Two bright rounded boxes separated by a wall of background 0.6–1.5 voxels thick.
    /// Genus 0.
    ThinWall,
    /// Two capsules that touch along a line, a point or a patch. Genus 0.
    TouchingPair,
    /// An MR-like ring of thin tortuous vessels with branches and a feeding trunk, a contrast
    /// that drifts along them and a bias field; float32. Genus 1.
    ThinVessels,
    /// A contrast lumen lined by a stent's wire lattice, blooming under blur; int16 HU.
    /// Genus 0.
    Stent,
    /// A vessel opening into a chamber as bright as it, with no wall between them: a family
    /// for several objects, where one balloon fills both (`Family::needs_competitor`). Genus 0.
    VesselChamber,
}

/// Voxels a variant may have at most (the tests run several).
pub const VOXEL_BUDGET: usize = 3_000_000;

/// Margin around what matters, mm.
const MARGIN: f64 = 6.0;

/// The lattice (mm) on which `Variant::other_seed` looks for the other object's deepest point.
const OTHER_SEED_STEP: f64 = 0.5;

impl Family {
    pub const ALL: [Family; 6] = [
        Family::CtScene,
        Family::ThinWall,
        Family::TouchingPair,
        Family::ThinVessels,
        Family::Stent,
        Family::VesselChamber,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Family::CtScene => "ct-scene",
            Family::ThinWall => "thin-wall",
            Family::TouchingPair => "touching-pair",
            Family::ThinVessels => "thin-vessels",
            Family::Stent => "stent",
            Family::VesselChamber => "vessel-chamber",
        }
    }

    /// Whether the seeded object can only be told from the other one by seeding that too (as a
    /// competitor or an object of its own): nothing in the image separates them.
    pub fn needs_competitor(self) -> bool {
        self == Family::VesselChamber
    }

    pub fn from_name(name: &str) -> Result<Family> {
        crate::phantom::named(&Family::ALL, Family::name, name, "phantom family")
    }

    /// Variant `number` of the family, rendered.
    pub fn variant(self, number: u64) -> Result<Variant> {
        let design = Design::new(self, number)?;
        let image = design.scene.render(&design.grid, &design.imaging)?;
        Ok(Variant { design, image })
    }

    /// The range of the PSF's σ (mm): a stent's struts always bloom.
    fn blur_range(self) -> (f64, f64) {
        match self {
            Family::Stent => (0.4, 0.6),
            _ => (0.0, 0.6),
        }
    }

    /// Where the family's stream starts: FNV-1a of its name, so that variant n of two
    /// families draws different numbers.
    fn salt(self) -> u64 {
        self.name().bytes().fold(0xCBF2_9CE4_8422_2325, |h, b| {
            (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01B3)
        })
    }

    fn compose(self, rng: &mut SplitMix64, scan: &Acquisition) -> Result<Composition> {
        match self {
            Family::CtScene => ct_scene::compose(rng),
            Family::ThinWall => Ok(thin_wall::compose(rng, scan)),
            Family::TouchingPair => Ok(touching_pair::compose(rng)),
            Family::ThinVessels => thin_vessels::compose(rng, scan),
            Family::Stent => stent::compose(rng),
            Family::VesselChamber => Ok(vessel_chamber::compose(rng)),
        }
    }
}

/// One drawn parameter: its name and value (one number, or a vector's components).
#[derive(Debug, Clone, PartialEq)]
pub struct Parameter {
    pub name: &'static str,
    pub values: Vec<f64>,
}

impl Parameter {
    fn new(name: &'static str, values: impl Into<Vec<f64>>) -> Parameter {
        Parameter {
            name,
            values: values.into(),
        }
    }
}

/// Two bright objects on a background (the thin wall's boxes, the touching pair's capsules):
/// background U[50, 150], the first object U[800, 1200], the second's contrast within ±20% of
/// the first's. Half of the variants map these numbers through a random affine change of units
/// (scale 10^U[−2, 2], offset U[−1000, 1000]), so that nothing may assume fixed units.
struct BrightPair {
    background: f64,
    first: f64,
    second: f64,
    scale: f64,
    offset: f64,
}

impl BrightPair {
    fn draw(rng: &mut SplitMix64) -> BrightPair {
        let background = rng.uniform(50.0, 150.0);
        let first = rng.uniform(800.0, 1200.0);
        let second = background + (first - background) * rng.uniform(0.8, 1.2);
        let (scale, offset) = if rng.chance(0.5) {
            (
                10f64.powf(rng.uniform(-2.0, 2.0)),
                rng.uniform(-1000.0, 1000.0),
            )
        } else {
            (1.0, 0.0)
        };
        let units = |v: f64| scale * v + offset;
        BrightPair {
            background: units(background),
            first: units(first),
            second: units(second),
            scale,
            offset,
        }
    }

    fn contrast(&self) -> f64 {
        self.first - self.background
    }

    fn parameters(&self) -> Vec<Parameter> {
        vec![
            Parameter::new("background", [self.background]),
            Parameter::new("first_intensity", [self.first]),
            Parameter::new("second_intensity", [self.second]),
            Parameter::new("units_scale_offset", [self.scale, self.offset]),
        ]
    }
}

/// The grid and imaging every variant draws first.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Acquisition {
    /// Columns: the grid's axes in world space.
    direction: DMat3,
    spacing: [f64; 3],
    blur_mm: f64,
    /// Noise σ as a fraction of the contrast.
    noise: f64,
    noise_seed: u64,
}

impl Acquisition {
    fn draw(rng: &mut SplitMix64, blur: (f64, f64)) -> Acquisition {
        let direction = rng.rotation();
        let s = rng.uniform(0.6, 1.0);
        let z = rng.uniform(s, 2.0);
        Acquisition {
            direction,
            spacing: [s, s, z],
            blur_mm: rng.uniform(blur.0, blur.1),
            noise: rng.uniform(0.05, 0.15),
            noise_seed: rng.next(),
        }
    }

    fn mean_spacing(&self) -> f64 {
        self.spacing.iter().sum::<f64>() / 3.0
    }

    /// The extent of a voxel along the unit `normal`: the distance between the planes with
    /// this normal through neighbouring voxel centres, 1 / |diag(1/s) · Dᵀ n|.
    fn voxel_extent_along(&self, normal: DVec3) -> f64 {
        let index = self.direction.transpose() * normal / DVec3::from(self.spacing);
        1.0 / index.length()
    }

    fn parameters(&self) -> Vec<Parameter> {
        vec![
            Parameter::new("direction", self.direction.transpose().to_cols_array()),
            Parameter::new("spacing_mm", self.spacing),
            Parameter::new("blur_mm", [self.blur_mm]),
            Parameter::new("noise_fraction", [self.noise]),
        ]
    }
}

/// What a family's scene is, before it meets a grid.
struct Composition {
    scene: Scene,
    /// The layer of the seeded object.
    truth_layer: usize,
    /// The layer of the object the seeded one must be told from, if any.
    other_layer: Option<usize>,
    seed: DVec3,
    genus: u32,
    contrast: f64,
    output: ScalarType,
    bias: Option<BiasField>,
    /// What the grid must show (balls with their margin).
    essential: Vec<Ball>,
    /// What it shows too when the voxel budget allows.
    context: Vec<Ball>,
    /// Balls that enclose the truth, and the other object.
    truth_hull: Vec<Ball>,
    other_hull: Vec<Ball>,
    parameters: Vec<Parameter>,
}

/// A variant before rendering: its scene, grid and imaging.
struct Design {
    family: Family,
    number: u64,
    scene: Scene,
    grid: Grid,
    imaging: Imaging,
    truth_layer: usize,
    other_layer: Option<usize>,
    seed: DVec3,
    genus: u32,
    contrast: f64,
    truth_bounds: (DVec3, DVec3),
    other_bounds: (DVec3, DVec3),
    parameters: Vec<Parameter>,
}

impl Design {
    fn new(family: Family, number: u64) -> Result<Design> {
        let mut rng = SplitMix64::new(family.salt() ^ number);
        let scan = Acquisition::draw(&mut rng, family.blur_range());
        let c = family.compose(&mut rng, &scan)?;
        let direction = scan.direction.transpose().to_cols_array();
        let everything: Vec<Ball> = c.essential.iter().chain(&c.context).copied().collect();
        let mut grid = Grid::around(&everything, scan.spacing, direction)?;
        if grid.voxels() > VOXEL_BUDGET {
            grid = Grid::around(&c.essential, scan.spacing, direction)?;
        }
        if grid.voxels() > VOXEL_BUDGET {
            return Err(Error::internal(format!(
                "{} variant {number} needs {} voxels, more than the budget of {VOXEL_BUDGET}",
                family.name(),
                grid.voxels()
            )));
        }
        let noise_sigma = scan.noise * c.contrast.abs();
        let imaging = Imaging {
            blur_mm: scan.blur_mm,
            bias: c.bias,
            noise_sigma,
            noise_seed: scan.noise_seed,
            output: c.output,
        };
        let mut parameters = scan.parameters();
        parameters.push(Parameter::new("noise_sigma", [noise_sigma]));
        parameters.push(Parameter::new("contrast", [c.contrast]));
        parameters.extend(c.parameters);
        Ok(Design {
            family,
            number,
            truth_bounds: bounds_within(&c.truth_hull, &grid),
            other_bounds: bounds_within(&c.other_hull, &grid),
            scene: c.scene,
            grid,
            imaging,
            truth_layer: c.truth_layer,
            other_layer: c.other_layer,
            seed: c.seed,
            genus: c.genus,
            contrast: c.contrast,
            parameters,
        })
    }

    /// Signed distance (bound) of what the volume shows of `layer`.
    fn shown(&self, layer: usize, p: DVec3) -> f64 {
        self.scene
            .visible(layer, p)
            .max(self.grid.extent().distance(p))
    }
}

/// The world box of the balls, cut to the box of the grid's voxels.
fn bounds_within(balls: &[Ball], grid: &Grid) -> (DVec3, DVec3) {
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for b in balls {
        lo = lo.min(b.centre - b.radius);
        hi = hi.max(b.centre + b.radius);
    }
    let extent = grid.extent();
    let reach = extent.axes.abs() * extent.half;
    (lo.max(extent.centre - reach), hi.min(extent.centre + reach))
}

/// A rendered variant of a family, with its truth.
pub struct Variant {
    design: Design,
    pub image: Image,
}

impl Variant {
    pub fn family(&self) -> Family {
        self.design.family
    }

    pub fn number(&self) -> u64 {
        self.design.number
    }

    /// A point deep inside the seeded object (world mm).
    pub fn seed(&self) -> DVec3 {
        self.design.seed
    }

    /// Genus of the seeded object's surface.
    pub fn genus(&self) -> u32 {
        self.design.genus
    }

    /// The seeded object's intensity minus the tissue right around it (before bias and noise).
    pub fn contrast(&self) -> f64 {
        self.design.contrast
    }

    /// Signed distance (mm, negative inside; a bound away from the surface with the exact
    /// sign) of the seeded object as the volume shows it.
    pub fn truth(&self, p: DVec3) -> f64 {
        self.design.shown(self.design.truth_layer, p)
    }

    /// Signed distance of the object the seeded one must be told from, if there is one.
    pub fn other(&self) -> Option<impl Fn(DVec3) -> f64 + Sync + '_> {
        let layer = self.design.other_layer?;
        Some(move |p| self.design.shown(layer, p))
    }

    /// A world box that contains the other object, if there is one.
    pub fn other_bounds(&self) -> Option<(DVec3, DVec3)> {
        self.design.other_layer.map(|_| self.design.other_bounds)
    }

    /// The deepest point of the other object, if there is one (world mm, on a lattice of
    /// half a millimetre): where to seed it as an object of its own.
    pub fn other_seed(&self) -> Option<DVec3> {
        let other = self.other()?;
        let (lo, hi) = self.other_bounds()?;
        let steps = ((hi - lo) / OTHER_SEED_STEP).ceil();
        let mut deepest = (f64::INFINITY, lo);
        for k in 0..=steps.z as usize {
            for j in 0..=steps.y as usize {
                for i in 0..=steps.x as usize {
                    let p = lo + OTHER_SEED_STEP * DVec3::new(i as f64, j as f64, k as f64);
                    let d = other(p);
                    if d < deepest.0 {
                        deepest = (d, p);
                    }
                }
            }
        }
        Some(deepest.1)
    }

    /// A world box (lo, hi) that contains the truth.
    pub fn truth_bounds(&self) -> (DVec3, DVec3) {
        self.design.truth_bounds
    }

    /// The drawn parameters, common ones first.
    pub fn describe(&self) -> &[Parameter] {
        &self.design.parameters
    }
}
