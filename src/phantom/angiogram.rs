//! The CT angiogram at the size scans come in: an abdomen of 512×512×600 int16 voxels
//! 0.6–0.8 mm apart (any size the caller asks for), with an abdominal aorta that gives off two
//! renal arteries and divides into the common iliac arteries, drawn from a variant number like
//! the families (`families`) but on an axis-aligned grid of the caller's size, as a scanner
//! writes it, and without their voxel budget. It is what the clinical-size benchmarks run on
//! (`balloonseg phantom angiogram`, `scripts/fullsize_run.py`), and the test of the whole tree
//! at a reduced size.
//!
//! World axes as DICOM's patient axes (LPS): x towards the patient's left, y posterior, z
//! superior; the grid is centred on the origin. Bottom to top, each layer painted over the ones
//! below:
//! - air (−1000 HU) outside a body, an elliptic cylinder along z (semi-axes 140–170 and
//!   100–125 mm; a small field of view shows only its inside), with subcutaneous fat
//!   (−100 HU, 10–30 mm) around soft tissue (30–50 HU);
//! - the spine: a cylinder along z (radius 15–20 mm) behind the aorta, its wall 3–6 mm of
//!   soft tissue from the aorta's, a cortex of 1–2 mm at 700–1100 HU around marrow at
//!   150–300 HU (as bright as some lumens: the cortex and the gap are what keep it out);
//! - retroperitoneal fat (−100 HU, 1–4 mm) around the front half of every vessel, so that the
//!   back half touches soft tissue;
//! - the vessel tree, 250–450 HU: the aorta (radius 9–13 mm, tapering by 10–20% towards the
//!   bifurcation, winding up to 6 mm sideways) from above the grid down to its bifurcation at
//!   30–45% of the height, two renal arteries (radius 2.5–3.5 mm tapering by 20%, up to 45 mm
//!   long, ending in the tissue as they would at the kidneys, which are not drawn) leaving it
//!   laterally and 0–20° backwards at 55–70% of the height between the bifurcation and the
//!   top, and the common iliacs (0.55–0.65 of the aorta's radius) leaving the bifurcation at
//!   18–30° from the vertical, then bending to half that, out through the bottom of the grid.
//!
//! A draw where a renal artery or an iliac comes within 2 mm of the spine, or where the field of
//! view leaves a renal artery less than 10 mm, is drawn again. The truth is the tree as the
//! volume shows it (cut by the grid's extent), genus 0; the seed is on the aorta's centre line
//! half-way between the renal arteries and the top of the grid.

use std::sync::Arc;

use glam::{DMat3, DVec2, DVec3};

use super::families::Parameter;
use super::grid::Grid;
use super::imaging::Imaging;
use super::random::SplitMix64;
use super::scene::{Intensity, Layer, Scene};
use super::sdf::{EllipticCylinder, HalfSpace, Intersection, Offset, RoundedCylinder, Sdf, Solid};
use super::tube::{Path, Tubes};
use crate::error::{Error, Result};
use crate::evaluation::{overlap_with_shape, Overlap};
use crate::geometry::Geometry;
use crate::mesh::TriMesh;
use crate::volume::{Image, ScalarType};

const AIR: f64 = -1000.0;
const FAT: f64 = -100.0;
/// Distance between the points of the aorta's centre line, mm.
const STEP: f64 = 2.0;
/// What every vessel keeps from the spine, and the room left between the grid's side and a
/// renal artery's end, mm.
const CLEARANCE: f64 = 2.0;
const SIDE_MARGIN: f64 = 6.0;
/// The shortest renal artery a field of view may leave, mm.
const SHORTEST_RENAL: f64 = 10.0;
const ATTEMPTS: usize = 100;
/// The smallest grid (voxels per axis) that holds the tree.
const SMALLEST: [usize; 3] = [96, 96, 96];
const LARGEST: usize = 4096;

/// A drawn angiogram: its truth, and its image when rendered (which takes a while at full
/// size, and which the truth does not need).
pub struct Angiogram {
    scene: Scene,
    grid: Grid,
    imaging: Imaging,
    tree_layer: usize,
    seed: DVec3,
    tree_bounds: (DVec3, DVec3),
    parameters: Vec<Parameter>,
}

impl Angiogram {
    /// The size of a clinical CT angiogram, voxels.
    pub const FULL_SIZE: [usize; 3] = [512, 512, 600];

    /// Variant `number` on a grid of `dims` voxels, drawn (not rendered). Errors (invalid argument) when a side is
    /// below 96 or above 4096 voxels.
    pub fn new(number: u64, dims: [usize; 3]) -> Result<Angiogram> {
        if dims
            .iter()
            .zip(SMALLEST)
            .any(|(&d, least)| d < least || d > LARGEST)
        {
            return Err(Error::invalid_argument(format!(
                "an angiogram of {dims:?} voxels: give each side between {} and {LARGEST} \
                 voxels (a clinical scan is {:?})",
                SMALLEST[0],
                Angiogram::FULL_SIZE
            )));
        }
        let mut rng = SplitMix64::new(0x616E_6769_6F67_7261 ^ number);
        let s = rng.uniform(0.6, 0.8);
        let spacing = [s, s, rng.uniform(0.6, 0.8)];
        let size = DVec3::from(dims.map(|d| d as f64)) * DVec3::from(spacing);
        let origin = -0.5 * (size - DVec3::from(spacing));
        let grid = Grid {
            geometry: Geometry::with_spacing(spacing, origin.to_array())?,
            dims,
        };
        let imaging = Imaging {
            blur_mm: rng.uniform(0.3, 0.6),
            bias: None,
            noise_sigma: rng.uniform(8.0, 15.0),
            noise_seed: rng.next(),
            output: ScalarType::I16,
        };
        let half = 0.5 * size;
        for _ in 0..ATTEMPTS {
            if let Some(design) = Design::draw(&mut rng, half)? {
                let mut parameters = vec![
                    Parameter {
                        name: "spacing_mm",
                        values: spacing.to_vec(),
                    },
                    Parameter {
                        name: "blur_mm",
                        values: vec![imaging.blur_mm],
                    },
                    Parameter {
                        name: "noise_sigma",
                        values: vec![imaging.noise_sigma],
                    },
                ];
                parameters.extend(design.parameters);
                let extent = grid.extent();
                let reach = extent.half;
                let (lo, hi) = design.tree_bounds;
                return Ok(Angiogram {
                    scene: design.scene,
                    grid,
                    imaging,
                    tree_layer: design.tree_layer,
                    seed: design.seed,
                    tree_bounds: (lo.max(-reach), hi.min(reach)),
                    parameters,
                });
            }
        }
        Err(Error::invalid_argument(format!(
            "angiogram variant {number}: no tree in {ATTEMPTS} draws fits {dims:?} voxels \
             ({:.0} mm across); give more voxels along x, or another --variant",
            size.x
        )))
    }

    /// The image: int16 HU, blurred and noisy.
    pub fn render(&self) -> Result<Image> {
        self.scene.render(&self.grid, &self.imaging)
    }

    /// The image's geometry (axis-aligned, centred on the origin).
    pub fn geometry(&self) -> &Geometry {
        &self.grid.geometry
    }

    pub fn dims(&self) -> [usize; 3] {
        self.grid.dims
    }

    /// A point on the aorta's centre line (world mm).
    pub fn seed(&self) -> DVec3 {
        self.seed
    }

    /// Genus of the tree's surface.
    pub fn genus(&self) -> u32 {
        0
    }

    /// Signed distance (mm, negative inside; a bound away from the surface with the exact
    /// sign) of the vessel tree as the volume shows it.
    pub fn truth(&self, p: DVec3) -> f64 {
        self.scene
            .visible(self.tree_layer, p)
            .max(self.grid.extent().distance(p))
    }

    /// A world box (lo, hi) that contains the truth.
    pub fn truth_bounds(&self) -> (DVec3, DVec3) {
        self.tree_bounds
    }

    /// The drawn parameters.
    pub fn describe(&self) -> &[Parameter] {
        &self.parameters
    }

    /// How `mesh` overlaps the analytic tree, sampled every smallest spacing of the grid.
    pub fn overlap(&self, mesh: &TriMesh) -> Result<Overlap> {
        let step = self.geometry().min_spacing();
        overlap_with_shape(mesh, |p| self.truth(p), self.truth_bounds(), step)
    }
}

/// A drawn scene that fits its grid.
struct Design {
    scene: Scene,
    tree_layer: usize,
    seed: DVec3,
    tree_bounds: (DVec3, DVec3),
    parameters: Vec<Parameter>,
}

impl Design {
    /// One draw on a grid reaching `half` from the origin, or `None` when the tree does not fit
    /// (see the module documentation).
    fn draw(rng: &mut SplitMix64, half: DVec3) -> Result<Option<Design>> {
        let top = half.z + 10.0;
        let bottom = -half.z - 10.0;
        let bifurcation = -half.z + rng.uniform(0.30, 0.45) * 2.0 * half.z;
        let renal_height = bifurcation + rng.uniform(0.55, 0.70) * (half.z - bifurcation);

        // The aorta, winding sideways along z.
        let aorta_radius = rng.uniform(9.0, 13.0);
        let taper = rng.uniform(0.80, 0.90);
        let (aorta_x, aorta_y) = (rng.uniform(0.0, 15.0), rng.uniform(-15.0, 0.0));
        let (wind, wavelength, phase) = (
            rng.uniform(0.0, 6.0),
            rng.uniform(150.0, 300.0),
            rng.uniform(0.0, std::f64::consts::TAU),
        );
        let centre = |z: f64| {
            let x = aorta_x + wind * (std::f64::consts::TAU * z / wavelength + phase).sin();
            DVec3::new(x, aorta_y, z)
        };
        let steps = ((top - bifurcation) / STEP).ceil() as usize;
        let aorta_points: Vec<DVec3> = (0..=steps)
            .map(|n| centre(top - (top - bifurcation) * n as f64 / steps as f64))
            .collect();
        let aorta_radii: Vec<f64> = (0..=steps)
            .map(|n| aorta_radius * (1.0 - (1.0 - taper) * n as f64 / steps as f64))
            .collect();
        let fork = *aorta_points.last().expect("the aorta has points");

        // The spine behind it.
        let spine_radius = rng.uniform(15.0, 20.0);
        let spine_gap = rng.uniform(3.0, 6.0);
        let spine_y = aorta_y + aorta_radius + spine_gap + spine_radius;
        let cortex = rng.uniform(1.0, 2.0);
        let (cortex_hu, marrow_hu) = (rng.uniform(700.0, 1100.0), rng.uniform(150.0, 300.0));
        let spine_axis = DVec2::new(0.0, spine_y);
        let clear_of_spine = |path: &Path| {
            path.points.windows(2).zip(&path.radii).all(|(w, r)| {
                (0..=8).all(|k| {
                    let p = w[0].lerp(w[1], k as f64 / 8.0);
                    p.truncate().distance(spine_axis) >= spine_radius + r + CLEARANCE
                })
            })
        };

        // The renal arteries, each as long as the field of view lets it be.
        let renal_radius = rng.uniform(2.5, 3.5);
        let renal_origin = centre(renal_height);
        let mut renals = Vec::new();
        let mut renal_parameters = Vec::new();
        for side in [1.0, -1.0] {
            let back = rng.uniform(0.0, 20.0).to_radians();
            let down = rng.uniform(0.0, 15.0).to_radians();
            let direction = DVec3::new(side * back.cos() * down.cos(), back.sin(), -down.sin());
            let room = (half.x - SIDE_MARGIN - renal_radius - side * renal_origin.x)
                / direction.x.abs()
                - aorta_radius;
            let length = rng.uniform(30.0, 45.0).min(room);
            if length < SHORTEST_RENAL {
                return Ok(None);
            }
            let sag = DVec3::new(0.0, 0.0, -rng.uniform(0.0, 8.0));
            let reach = aorta_radius + length;
            let path = Path {
                points: vec![
                    renal_origin,
                    renal_origin + 0.5 * reach * direction,
                    renal_origin + reach * direction + sag,
                ],
                radii: vec![renal_radius, 0.9 * renal_radius, 0.8 * renal_radius],
            };
            if !clear_of_spine(&path) {
                return Ok(None);
            }
            renal_parameters.extend([length, back.to_degrees(), down.to_degrees()]);
            renals.push(path);
        }

        // The common iliacs, out through the bottom.
        let iliac_radius = aorta_radius * taper * rng.uniform(0.55, 0.65);
        let mut iliacs = Vec::new();
        let mut iliac_angles = Vec::new();
        for side in [1.0, -1.0] {
            let angle = rng.uniform(18.0, 30.0).to_radians();
            let forward = rng.uniform(0.0, 10.0).to_radians();
            let heading = |a: f64| {
                DVec3::new(side * a.sin(), -forward.sin(), -a.cos() * forward.cos()).normalize()
            };
            let first = 0.4 * (fork.z - bottom);
            let bend = fork + first / heading(angle).z.abs() * heading(angle);
            let rest = (bend.z - bottom) / heading(0.5 * angle).z.abs();
            let end = bend + rest * heading(0.5 * angle);
            let path = Path {
                points: vec![fork, bend, end],
                radii: vec![iliac_radius, 0.95 * iliac_radius, 0.9 * iliac_radius],
            };
            let inside = path.points[1..]
                .iter()
                .all(|p| p.x.abs() + iliac_radius + SIDE_MARGIN <= half.x);
            if !inside || !clear_of_spine(&path) {
                return Ok(None);
            }
            iliac_angles.push(angle.to_degrees());
            iliacs.push(path);
        }

        let mut paths = vec![Path {
            points: aorta_points,
            radii: aorta_radii,
        }];
        paths.extend(renals);
        paths.extend(iliacs);
        let mut lo = DVec3::INFINITY;
        let mut hi = DVec3::NEG_INFINITY;
        for path in &paths {
            for (p, r) in path.points.iter().zip(&path.radii) {
                lo = lo.min(p - r);
                hi = hi.max(p + r);
            }
        }

        let fat_width = rng.uniform(1.0, 4.0);
        let grown: Vec<Path> = paths
            .iter()
            .map(|p| Path {
                points: p.points.clone(),
                radii: p.radii.iter().map(|r| r + fat_width).collect(),
            })
            .collect();
        let fat = Intersection(vec![
            Arc::new(Tubes::new(&grown)?),
            Arc::new(HalfSpace {
                point: DVec3::new(0.0, aorta_y, 0.0),
                normal: DVec3::Y,
            }),
        ]);

        let body_radii = DVec2::new(rng.uniform(140.0, 170.0), rng.uniform(100.0, 125.0));
        let subcutaneous = rng.uniform(10.0, 30.0);
        let tissue_hu = rng.uniform(30.0, 50.0);
        let lumen_hu = rng.uniform(250.0, 450.0);
        let body = EllipticCylinder {
            centre: DVec3::ZERO,
            axes: DMat3::IDENTITY,
            radii: body_radii,
        };
        let tissue = EllipticCylinder {
            radii: body_radii - subcutaneous,
            ..body
        };
        let spine: Solid = Arc::new(RoundedCylinder {
            centre: DVec3::new(0.0, spine_y, 0.0),
            axis: DVec3::Z,
            radius: spine_radius,
            half_height: half.z + 20.0,
            rounding: 0.0,
        });
        let constant = |solid: Solid, hu: f64| Layer {
            solid,
            intensity: Intensity::Constant(hu),
        };
        let layers = vec![
            constant(Arc::new(body), FAT),
            constant(Arc::new(tissue), tissue_hu),
            constant(spine.clone(), cortex_hu),
            constant(Arc::new(Offset(spine, -cortex)), marrow_hu),
            constant(Arc::new(fat), FAT),
            constant(Arc::new(Tubes::new(&paths)?), lumen_hu),
        ];
        let seed = centre(0.5 * (renal_height + half.z));
        let parameter = |name: &'static str, values: &[f64]| Parameter {
            name,
            values: values.to_vec(),
        };
        Ok(Some(Design {
            tree_layer: layers.len() - 1,
            scene: Scene {
                background: AIR,
                layers,
            },
            seed,
            tree_bounds: (lo, hi),
            parameters: vec![
                parameter("aorta_radius_mm", &[aorta_radius]),
                parameter("aorta_taper", &[taper]),
                parameter("aorta_xy_mm", &[aorta_x, aorta_y]),
                parameter("aorta_wind_mm", &[wind, wavelength]),
                parameter("bifurcation_z_mm", &[bifurcation]),
                parameter("renal_z_mm", &[renal_height]),
                parameter("renal_radius_mm", &[renal_radius]),
                parameter("renal_length_back_down", &renal_parameters),
                parameter("iliac_radius_mm", &[iliac_radius]),
                parameter("iliac_angles_deg", &iliac_angles),
                parameter("lumen_hu", &[lumen_hu]),
                parameter("tissue_hu", &[tissue_hu]),
                parameter("retroperitoneal_fat_mm", &[fat_width]),
                parameter("spine_radius_gap_mm", &[spine_radius, spine_gap]),
                parameter("cortex_mm", &[cortex]),
                parameter("cortex_marrow_hu", &[cortex_hu, marrow_hu]),
                parameter("body_radii_mm", &body_radii.to_array()),
                parameter("subcutaneous_fat_mm", &[subcutaneous]),
            ],
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::marching_cubes::marching_cubes;
    use crate::mesh_checks::check;

    const SMALL: [usize; 3] = [160, 128, 112];

    #[test]
    fn a_variant_is_the_same_bytes_for_one_and_two_threads() {
        let pool = |n| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .unwrap()
        };
        let one = Angiogram::new(2, SMALL).unwrap();
        let image = |n| pool(n).install(|| one.render().unwrap());
        assert!(image(1) == image(2));
        assert_eq!(one.describe(), Angiogram::new(2, SMALL).unwrap().describe());
        assert_ne!(Angiogram::new(3, SMALL).unwrap().describe(), one.describe());
    }

    #[test]
    fn the_truth_is_one_tree_with_its_branches_inside_the_grid() {
        for number in 0..2 {
            let angiogram = Angiogram::new(number, SMALL).unwrap();
            assert!(angiogram.truth(angiogram.seed()) < -8.0);
            // The truth sampled on the grid: one component of genus 0 that reaches the top,
            // the bottom twice (the iliacs) and neither side.
            let geometry = *angiogram.geometry();
            let truth = Image::from_fn(SMALL, geometry, |i, j, k| {
                let p = geometry.index_to_world(DVec3::new(i as f64, j as f64, k as f64));
                angiogram.truth(p) as f32
            })
            .unwrap();
            let surface = marching_cubes(&truth.view(), 0.0).unwrap();
            let report = check(&surface);
            assert_eq!(report.components, 1, "variant {number}");
            let bounds = surface.bounds().unwrap();
            let extent = angiogram.grid.extent().half;
            assert!(bounds.1.z > extent.z - 2.0 && bounds.0.z < -extent.z + 2.0);
            assert!(bounds.0.x > -extent.x + 2.0 && bounds.1.x < extent.x - 2.0);
            let (lo, hi) = angiogram.truth_bounds();
            assert!(bounds.0.cmpge(lo - 1.0).all() && bounds.1.cmple(hi + 1.0).all());
        }
    }

    #[test]
    fn a_grid_too_small_or_too_large_is_an_invalid_argument() {
        for dims in [[64, 512, 600], [512, 512, 5000]] {
            let error = Angiogram::new(0, dims).err().unwrap();
            assert_eq!(error.kind(), crate::ErrorKind::InvalidArgument);
            assert!(error.message().contains("between 96"), "{error}");
        }
    }
}
