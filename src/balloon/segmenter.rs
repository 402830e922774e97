//! The whole method of the paper (docs/method.md), as a segmenter that can be driven step by step
//! (the C ABI's `balloon_step`, `balloon_freeze_self_intersections`, `balloon_reparametrize`)
//! or run to completion (`segment`). This module holds the segmenter, its construction from the
//! seeds and the order of the steps; each step's work is in the module named after it
//! (`inflation`, `contacts`, `reparametrization`, `finishing`), as `impl Segmenter` blocks.
//!
//! `segment` inflates the seed spheres until equilibrium — every vertex frozen at the border or
//! by a self-intersection, or no vertex moving measurably — remeshing as the balloon grows and
//! searching for self-intersections every few steps; those a few rings apart on the surface
//! are folds of the mesh and are relaxed (`untangle`). If the balloon met itself, it is
//! re-parametrised (signed distance + marching cubes) and refined by a few more steps; that
//! repeats while refinement makes new contacts. The result is checked — closed, 2-manifold,
//! outward, free of self-intersections — before it is returned; when refinement cannot keep
//! it free of contacts, the last marching-cubes surface is returned instead.
//!
//! Each segmenter has its own thread pool of the requested size, and every result is the
//! same for any size.

use std::sync::Arc;

use glam::DVec3;

use crate::balloon::contacts::search::FrozenTriangles;
use crate::balloon::image_model::border::{Border, ImageScales, IntensityWindow};
use crate::balloon::image_model::hounsfield;
use crate::balloon::image_model::region::Region;
use crate::balloon::image_model::seed_statistics::{self, SeedStatistics};
use crate::balloon::image_model::thin_layer;
use crate::balloon::inflation::stepper::Scratch;
use crate::balloon::inflation::{Inflation, FIRST_LEAK_CHECK};
use crate::balloon::objects::obstacle::Obstacle;
use crate::balloon::objects::simplify_with_states;
use crate::balloon::params::BalloonParams;
use crate::balloon::progress::{Phase, PhaseSeconds, ProgressCallback};
use crate::balloon::reparametrization::AfterReparametrization;
use crate::balloon::surface::{Surface, VertexState};
use crate::error::{Error, Result};
use crate::geometry::Geometry;
use crate::mesh::TriMesh;
use crate::thread_pool::ThreadPool;
use crate::volume::Volume;

/// The largest ratio of the longest voxel spacing to the shortest. The balloon's grids (its
/// re-parametrisation, the touching cut, the objects' repartition) have the shortest spacing
/// over the balloon's box, so their size grows with the square of the ratio; scans stay within
/// about 20 (0.3 mm pixels on 6 mm slices).
pub const MAX_ANISOTROPY: f64 = 100.0;

/// The edge length's range, in voxel spacings: at least this share of the shortest spacing, at
/// most this many of the longest. Below, the balloon needs the square of the ratio more
/// vertices and steps to fill the same structure; above, its triangles span structures it
/// cannot see.
pub const EDGE_LENGTH_SPACINGS: (f64, f64) = (0.5, 10.0);

/// How far from 1 the length of a direction column may be (float32 headers round to 1e-7).
const UNIT_DIRECTION: f64 = 1e-3;

/// The least volume the unit voxel axes may span, against a cube's: below, a world box maps to
/// an index box that many times longer, and so do the balloon's grids. A gantry tilted by 30°
/// spans 0.87.
const MIN_AXES_SINE: f64 = 0.1;

/// The smallest local step that is an edge, as a share of the structure's contrast and in σ
/// of the image inside the structure at the scale of local steps (its texture).
const LOCAL_STEP_SHARE: f64 = 0.25;
const LOCAL_STEP_TEXTURE: f64 = 5.0;
/// The smallest dip of a thin dark wall, as a share of a local step and in σ of the texture.
const VALLEY_STEP_SHARE: f64 = 0.5;
const VALLEY_TEXTURE: f64 = 8.0;

/// The smallest local step that is an edge (`Border::step`): a share of the structure's
/// contrast to its surroundings (twice the tolerance for a window given without an estimate),
/// and well above the variation of the image inside the structure (noise and texture).
fn local_step(window: &IntensityWindow, estimate: Option<&SeedStatistics>) -> f64 {
    let contrast = estimate
        .map(|s| s.contrast())
        .filter(|c| c.is_finite())
        .unwrap_or(2.0 * window.tolerance());
    let texture = estimate.map_or(0.0, |s| s.texture);
    (LOCAL_STEP_SHARE * contrast).max(LOCAL_STEP_TEXTURE * texture)
}

/// The smallest dip of a thin dark wall (`Border::valley`): half a local step, and far above
/// the image's variation inside the structure (on the phantom families a thin tortuous
/// vessel's undulations along its length reach 6 σ of it; a wall of 0.64 voxel under 0.5 mm of
/// blur dips by about 12 σ). A window given without an estimate comes with no texture to tell
/// a wall's dip from the structure's own: then no dip is an edge.
fn smallest_valley(step: f64, estimate: Option<&SeedStatistics>) -> f64 {
    estimate.map_or(0.0, |s| {
        (VALLEY_STEP_SHARE * step).max(VALLEY_TEXTURE * s.texture)
    })
}

fn outside_region(seed: DVec3, region: Region) -> Error {
    Error::invalid_argument(format!(
        "the seed {seed} mm is outside the region of interest {} – {} mm; move the seed or \
         widen the region",
        region.lo(),
        region.hi()
    ))
}

/// What a run did, besides the mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentationStats {
    pub reference_intensity: f64,
    /// The window's half-width towards the darker side ([`IntensityWindow::tolerance`]).
    pub tolerance: f64,
    /// The intensities the balloon inflates in.
    pub window: IntensityWindow,
    /// The estimate behind the defaults, when reference or tolerance were not given.
    pub seed_statistics: Option<SeedStatistics>,
    /// The structure's edge strength (intensity per mm) that the border rule compares
    /// gradients with; 0 when no ray from the seed crosses a given window's border (the window
    /// is then taken literally).
    pub edge_strength: f64,
    pub edge_length: f64,
    pub iterations: u32,
    pub reparametrizations: u32,
    /// Whether an inflation or refinement ran out of `max_iterations` while the balloon was
    /// still growing: the result is where the balloon stood then, most likely a leak into
    /// the surroundings (or a structure longer than the steps allow).
    pub out_of_steps: bool,
    pub seconds: PhaseSeconds,
}

/// Refuses a volume whose spacing, or an edge length whose size, would make the balloon's work
/// unbounded (see [`MAX_ANISOTROPY`] and [`EDGE_LENGTH_SPACINGS`]).
fn check_scales(geometry: &Geometry, edge_length: f64) -> Result<()> {
    // The balloon reads the voxel size from the spacing: a direction column of another length
    // would scale the grid behind its back.
    let m = geometry.index_to_world_matrix();
    let steps = [m.x_axis, m.y_axis, m.z_axis].map(|c| c.length());
    let spacing = geometry.spacing();
    if let Some(a) = (0..3).find(|&a| (steps[a] / spacing[a] - 1.0).abs() > UNIT_DIRECTION) {
        return Err(Error::invalid_volume(format!(
            "column {a} of the direction matrix {:?} has length {}; the columns must be unit \
             vectors, with the voxel size in the spacing",
            geometry.direction(),
            steps[a] / spacing[a]
        )));
    }
    let sine = m.determinant().abs() / steps.iter().product::<f64>();
    if sine < MIN_AXES_SINE {
        return Err(Error::invalid_volume(format!(
            "the voxel axes of the direction matrix {:?} are nearly coplanar (the volume they \
             span is {sine:.2e} of a cube's); the balloon needs them at least {MIN_AXES_SINE} \
             apart: check the direction, or resample the volume",
            geometry.direction()
        )));
    }
    let (shortest, longest) = (geometry.min_spacing(), geometry.max_spacing());
    if longest > MAX_ANISOTROPY * shortest {
        return Err(Error::invalid_volume(format!(
            "the voxel spacing {:?} mm is {:.3e} times longer along one axis than along \
             another; the balloon handles at most {MAX_ANISOTROPY}: check the header's \
             spacing, or resample the volume",
            geometry.spacing(),
            longest / shortest
        )));
    }
    let (least, most) = (
        EDGE_LENGTH_SPACINGS.0 * shortest,
        EDGE_LENGTH_SPACINGS.1 * longest,
    );
    if !(least..=most).contains(&edge_length) {
        return Err(Error::invalid_argument(format!(
            "edge_length_mm is {edge_length}, outside {least}..{most} mm for voxels of \
             {shortest} to {longest} mm ({} of the shortest spacing to {} of the longest); \
             give a length in that range, or leave it unset for the mean spacing",
            EDGE_LENGTH_SPACINGS.0, EDGE_LENGTH_SPACINGS.1
        )));
    }
    Ok(())
}

impl SegmentationStats {
    /// The display window (lo, hi) of a picture of the result, from the model of a bright
    /// structure: its intensity window below the reference, and as much again below for the
    /// surroundings.
    pub fn display_window(&self) -> (f64, f64) {
        (
            self.reference_intensity - 2.0 * self.tolerance,
            self.reference_intensity + self.tolerance,
        )
    }
}

/// A balloon in a volume.
pub struct Segmenter<'v, 'p> {
    pub(super) volume: Volume<'v>,
    /// The volume as the balloon sees it.
    pub(super) image: ImageScales<'v>,
    pub(super) params: BalloonParams,
    pub(super) border: Border,
    pub(super) edge_length: f64,
    pub(super) surface: Surface,
    /// The surface's frozen triangles, for the contact search; rebuilt with the surface.
    pub(super) frozen: FrozenTriangles,
    /// The seed points (world mm): the structures touching theirs are cut off at the end.
    pub(super) seeds: Vec<DVec3>,
    pub(super) scratch: Scratch,
    /// The vertex count at which `inflate` next looks for structures entered through a neck
    /// (`touching`): each time the balloon has doubled, so that a leak is cut off before it
    /// spreads from the neighbour into everything beyond, at a cost that adds up to a few
    /// times the last look's.
    pub(super) next_leak_check: usize,
    pub(super) stats: SegmentationStats,
    /// The final surfaces of other objects that this one's final surface must not meet.
    pub(super) apart_from: Vec<Arc<Obstacle>>,
    pub(super) pool: ThreadPool,
    pub(super) progress: Option<ProgressCallback<'p>>,
}

impl<'v, 'p> Segmenter<'v, 'p> {
    /// A balloon of about one voxel's radius at `seed` (world mm). Reference intensity and
    /// tolerance not given in `params` are estimated around this seed.
    pub fn new(volume: Volume<'v>, params: BalloonParams, seed: DVec3) -> Result<Self> {
        params.validate()?;
        let pool = ThreadPool::new(params.threads)?;
        let geometry = *volume.geometry();
        let edge_length = params.edge_length.unwrap_or(geometry.mean_spacing());
        check_scales(&geometry, edge_length)?;
        let image = ImageScales::new(volume);
        let estimate = match params.tolerance {
            Some(_) if params.reference.is_some() => None,
            _ => Some(pool.install(|| seed_statistics::estimate(&image, seed, params.reference))?),
        };
        let window = match (params.tolerance, estimate) {
            (None, Some(s)) => s.window,
            (Some(tolerance), _) => IntensityWindow::symmetric(
                params
                    .reference
                    .or(estimate.map(|s| s.reference))
                    .expect("estimated when not given"),
                tolerance,
            ),
            (None, None) => unreachable!("estimated when no tolerance is given"),
        };
        let edge_strength = match estimate {
            Some(s) if params.tolerance.is_none() => s.edge_strength,
            _ => pool
                .install(|| seed_statistics::edge_strength(&image, seed, &window))
                .unwrap_or(0.0),
        };
        let step = local_step(&window, estimate.as_ref());
        let in_hounsfield_units = hounsfield::is_ct(&volume);
        let mut segmenter = Segmenter {
            volume,
            image,
            border: Border {
                window,
                edge_strength,
                step,
                crest: thin_layer::smallest_crest(step, estimate.as_ref()),
                valley: smallest_valley(step, estimate.as_ref()),
                voxel: geometry.mean_spacing(),
                hounsfield: in_hounsfield_units,
                surroundings: estimate
                    .as_ref()
                    .filter(|s| !in_hounsfield_units && s.darker.rays > 0)
                    .map(|s| s.darker.level),
            },
            edge_length,
            surface: Surface::icosphere(seed, geometry.mean_spacing(), 1)?,
            frozen: FrozenTriangles::default(),
            seeds: vec![seed],
            scratch: Scratch::default(),
            next_leak_check: FIRST_LEAK_CHECK,
            stats: SegmentationStats {
                reference_intensity: window.reference,
                tolerance: window.tolerance(),
                window,
                seed_statistics: estimate,
                edge_strength,
                edge_length,
                iterations: 0,
                reparametrizations: 0,
                out_of_steps: false,
                seconds: PhaseSeconds::default(),
            },
            apart_from: Vec::new(),
            pool,
            progress: None,
            params,
        };
        segmenter.check_seed(seed)?;
        segmenter.index_surface();
        Ok(segmenter)
    }

    /// Another seed sphere, for a structure the first seed does not reach.
    pub fn add_seed(&mut self, seed: DVec3) -> Result<()> {
        self.check_seed(seed)?;
        let sphere = Surface::icosphere(seed, self.volume.geometry().mean_spacing(), 1)?;
        let (mut mesh, states) = self.mesh();
        mesh.append(&sphere.to_mesh()?)?;
        let mut surface = Surface::from_mesh(&mesh)?;
        surface.states_mut()[..states.len()].copy_from_slice(&states);
        self.replace_surface(surface);
        self.seeds.push(seed);
        Ok(())
    }

    /// Keeps the balloon inside `region` from now on: its faces stop it as the volume's do.
    pub fn restrict_to(&mut self, region: Region) -> Result<()> {
        if let Some(seed) = self.seeds.iter().find(|&&seed| !region.contains(seed)) {
            return Err(outside_region(*seed, region));
        }
        self.image.restrict_to(Some(region));
        Ok(())
    }

    /// The balloon keeps `clearance` (mm) away from `obstacles`, the other objects, instead
    /// of those before.
    pub(super) fn set_obstacles(&mut self, obstacles: Vec<Arc<Obstacle>>, clearance: f64) {
        self.image.set_obstacles(obstacles, clearance);
    }

    /// The final surfaces of other objects that the final surface must not meet.
    pub(super) fn keep_apart_from(&mut self, finished: Vec<Arc<Obstacle>>) {
        self.apart_from = finished;
    }

    /// The balloon as an obstacle to other objects, with exact distances within `reach` mm:
    /// of its triangles within the reach of one of the boxes `near` (lo, hi; world mm), or of
    /// all of them.
    pub(super) fn as_obstacle(&self, reach: f64, near: Option<&[(DVec3, DVec3)]>) -> Obstacle {
        let within = |[a, b, c]: &[DVec3; 3]| {
            let (lo, hi) = (a.min(*b).min(*c), a.max(*b).max(*c));
            near.map_or(true, |boxes| {
                boxes.iter().any(|&(l, h)| {
                    (lo - DVec3::splat(reach)).cmple(h).all()
                        && (hi + DVec3::splat(reach)).cmpge(l).all()
                })
            })
        };
        Obstacle::new(
            self.surface
                .triangles()
                .map(|(t, _)| self.surface.triangle_corners(t).expect("live"))
                .filter(within),
            reach,
        )
    }

    /// The balloon's bounding box (lo, hi; world mm).
    pub(super) fn bounds(&self) -> (DVec3, DVec3) {
        self.surface
            .live_vertices()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), v| {
                let p = self.surface.positions()[v as usize];
                (lo.min(p), hi.max(p))
            })
    }

    pub(super) fn edge_length(&self) -> f64 {
        self.edge_length
    }

    pub(super) fn seeds(&self) -> &[DVec3] {
        &self.seeds
    }

    /// The seed must be where the balloon sees the structure: inside the window on the
    /// smoothed image, and inside the region of interest.
    fn check_seed(&self, seed: DVec3) -> Result<()> {
        if let Some(region) = self.image.region().filter(|r| !r.contains(seed)) {
            return Err(outside_region(seed, region));
        }
        let window = self.border.window;
        match self.image.fine.sample_world(seed) {
            None => Err(Error::invalid_argument(format!(
                "the seed {seed} mm is outside the volume (voxel index {}); give it in world \
                 millimetres inside the image",
                self.volume.geometry().world_to_index(seed)
            ))),
            Some(v) if !window.contains(v) => Err(Error::invalid_argument(format!(
                "the intensity at the seed {seed} mm is {v} (smoothed over half a voxel), \
                 outside the window {window}: the seed is on the background or the window is \
                 too narrow; move the seed into the structure or widen the tolerance"
            ))),
            Some(_) => Ok(()),
        }
    }

    pub fn params(&self) -> &BalloonParams {
        &self.params
    }

    pub(super) fn volume_geometry(&self) -> &Geometry {
        self.volume.geometry()
    }

    pub fn stats(&self) -> &SegmentationStats {
        &self.stats
    }

    /// The current balloon as a compact mesh (world mm) with the state of each vertex.
    pub fn mesh(&self) -> (TriMesh, Vec<VertexState>) {
        let (mesh, map) = self
            .surface
            .to_mesh_with_map()
            .expect("the balloon's positions stay finite");
        let mut states = vec![VertexState::Moving; mesh.points().len()];
        for (old, &new) in map.iter().enumerate() {
            if new != u32::MAX {
                states[new as usize] = self.surface.states()[old];
            }
        }
        (mesh, states)
    }

    /// The balloon from now on: `surface`, with its index of frozen triangles.
    pub(super) fn replace_surface(&mut self, surface: Surface) {
        self.surface = surface;
        self.index_surface();
    }

    /// The whole method to completion: the final mesh (world mm, outward, closed, 2-manifold,
    /// without self-intersections) and the state of each of its vertices.
    ///
    /// After each re-parametrisation the new surface is refined by the same deformation until
    /// it is at equilibrium again (at least `refinement_iterations` steps, at most what is left
    /// of `max_iterations`): contacts freeze the parts of the front that meet, and the rest of
    /// the front, frozen with them before the re-parametrisation, must go on growing.
    ///
    /// With `simplify_error_mm` set, the mesh returned is the final one simplified within that
    /// distance (both ways), with the vertex states merged; the balloon itself (`mesh`) stays
    /// as it was.
    pub fn segment(&mut self) -> Result<(TriMesh, Vec<VertexState>)> {
        let budget = self.params.max_iterations;
        let used = self.inflate(Phase::Inflation, budget)?;
        let (mesh, states) = self.finish(budget - used)?;
        match self.params.simplification() {
            Some(max_error) => {
                let (simplified, states) = self
                    .timed(Phase::Simplification, |s| {
                        simplify_with_states(&mesh, &states, max_error, |fraction| {
                            s.report(fraction, Phase::Simplification).is_ok()
                        })
                    })
                    .map_err(|e| e.context("cannot simplify the segmentation"))?;
                Ok((simplified.mesh, states))
            }
            None => Ok((mesh, states)),
        }
    }

    /// After an inflation, with `budget` steps of `max_iterations` left: the contacts frozen,
    /// and if there are any and re-parametrisations are left, the surface re-parametrised and
    /// the refinement that must follow, to be run a step at a time.
    pub(super) fn next_refinement(&mut self, budget: u32) -> Result<Option<Inflation>> {
        self.freeze_self_intersections()?;
        if !self.has_self_intersections()
            || self.stats.reparametrizations >= self.params.max_reparametrizations
        {
            return Ok(None);
        }
        self.reparametrize()?;
        let limit = budget.max(self.params.refinement_iterations);
        Ok(Some(self.start_inflation(Phase::Refinement, limit)))
    }

    /// What follows the first inflation, with `budget` steps of `max_iterations` left: contacts,
    /// re-parametrisation and refinement, the touching cut, fairing and validation.
    pub(super) fn finish(&mut self, mut budget: u32) -> Result<(TriMesh, Vec<VertexState>)> {
        while let Some(mut run) = self.next_refinement(budget)? {
            while !self.continue_inflation(&mut run)? {}
            budget = budget.saturating_sub(run.steps);
        }
        self.cut_touching(AfterReparametrization::Nothing)?;
        let earlier = self.fair();
        self.validated(earlier)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh_checks;
    use crate::phantom::{self, PhantomOptions, Shape};
    use crate::self_intersection::self_intersections;

    fn run(shape: Shape, options: &PhantomOptions) -> (TriMesh, SegmentationStats) {
        let p = phantom::render(shape, options).unwrap();
        let mut s =
            Segmenter::new(p.image.view(), BalloonParams::default(), p.seed_world()).unwrap();
        let (mesh, _) = s.segment().unwrap();
        (mesh, s.stats().clone())
    }

    #[test]
    fn sphere_phantom_gives_a_valid_sphere_of_the_right_size() {
        let (mesh, stats) = run(Shape::Sphere, &PhantomOptions::default());
        let report = mesh_checks::check(&mesh);
        assert!(report.is_valid_closed_surface(), "{report:?}");
        assert_eq!(report.genus(), Some(0));
        let exact = 4.0 / 3.0 * std::f64::consts::PI * 1000.0;
        assert!(
            (report.signed_volume - exact).abs() / exact < 0.03,
            "volume {} vs {exact}; {stats:?}",
            report.signed_volume
        );
    }

    #[test]
    fn torus_phantom_meets_itself_and_comes_out_with_genus_one() {
        let (mesh, stats) = run(Shape::Torus, &PhantomOptions::default());
        let report = mesh_checks::check(&mesh);
        assert!(report.is_valid_closed_surface(), "{report:?}");
        assert!(stats.reparametrizations >= 1, "{stats:?}");
        assert_eq!(report.genus(), Some(1), "{report:?} {stats:?}");
    }

    #[test]
    fn a_new_surface_moves_only_where_it_is_inside_the_window() {
        // The rule that stops the aorta's renal contacts from coming back: the new surface is
        // not pulled in where it bridges a saddle below the border.
        let p = phantom::render(Shape::Torus, &PhantomOptions::default()).unwrap();
        let mut s =
            Segmenter::new(p.image.view(), BalloonParams::default(), p.seed_world()).unwrap();
        s.step(400).unwrap();
        s.freeze_self_intersections().unwrap();
        assert!(
            s.has_self_intersections(),
            "the torus should have met itself"
        );
        s.replace_by_isosurface(AfterReparametrization::Refinement)
            .unwrap();
        let (mut inside, mut outside) = (0, 0);
        let normals = s.surface.vertex_normals();
        for v in s.surface.live_vertices() {
            let p = s.surface.positions()[v as usize];
            let in_window = s.may_move_on(p, normals[v as usize]);
            let state = s.surface.states()[v as usize];
            if in_window {
                inside += 1;
                assert_eq!(state, VertexState::Moving, "{p}");
            } else {
                outside += 1;
                assert_eq!(state, VertexState::FrozenAtBorder, "{p}");
            }
        }
        assert!(
            inside > 0 && outside > 0,
            "{inside} inside, {outside} outside"
        );
    }

    /// Segments the sphere phantom, then pushes one vertex through the ball and out of its far
    /// side, as if fairing or settling had moved it there (its fan pierces the far wall), and
    /// hands over the segmenter with the positions before the push.
    fn with_a_vertex_pushed_through(test: impl FnOnce(&mut Segmenter<'_, '_>, Vec<DVec3>)) {
        let p = phantom::render(Shape::Sphere, &PhantomOptions::default()).unwrap();
        let mut s =
            Segmenter::new(p.image.view(), BalloonParams::default(), p.seed_world()).unwrap();
        s.segment().unwrap();
        let before = s.surface.positions().to_vec();
        let v = s.surface.live_vertices().next().unwrap();
        let centre = s.seeds[0];
        s.surface.positions_mut()[v as usize] = centre + 1.5 * (centre - before[v as usize]);
        s.index_surface();
        assert!(!self_intersections(&s.mesh().0).unwrap().is_empty());
        test(&mut s, before);
    }

    #[test]
    fn fairing_that_makes_a_contact_is_undone_there_without_remeshing() {
        with_a_vertex_pushed_through(|s, before| {
            let reparametrizations = s.stats.reparametrizations;
            let (mesh, _) = s.validated(vec![before.clone()]).unwrap();
            assert!(mesh_checks::check(&mesh).is_valid_closed_surface());
            assert!(self_intersections(&mesh).unwrap().is_empty());
            assert_eq!(s.surface.positions(), &before[..]);
            assert_eq!(s.stats.reparametrizations, reparametrizations);
        });
    }

    #[test]
    fn a_contact_settling_made_is_undone_before_the_fairing_is() {
        with_a_vertex_pushed_through(|s, unsettled| {
            // Before fairing, as far as the test needs: the same surface a little smaller.
            let centre = s.seeds[0];
            let unfaired: Vec<DVec3> = unsettled
                .iter()
                .map(|&x| centre + 0.97 * (x - centre))
                .collect();
            let (mesh, _) = s.validated(vec![unsettled.clone(), unfaired]).unwrap();
            assert!(self_intersections(&mesh).unwrap().is_empty());
            assert_eq!(s.surface.positions(), &unsettled[..]);
        });
    }

    #[test]
    fn same_mesh_for_one_and_two_threads() {
        let p = phantom::render(
            Shape::YVessel,
            &PhantomOptions {
                noise: 0.1,
                ..PhantomOptions::default()
            },
        )
        .unwrap();
        let run = |threads| {
            let params = BalloonParams {
                threads,
                ..BalloonParams::default()
            };
            Segmenter::new(p.image.view(), params, p.seed_world())
                .unwrap()
                .segment()
                .unwrap()
        };
        assert_eq!(run(1), run(2));
    }

    #[test]
    fn bad_seeds_and_cancel_are_clear_errors() {
        let p = phantom::render(Shape::Sphere, &PhantomOptions::default()).unwrap();
        let outside = Segmenter::new(p.image.view(), BalloonParams::default(), DVec3::splat(1e3));
        assert!(outside.err().unwrap().message().contains("outside"));
        let params = BalloonParams {
            reference: Some(1100.0),
            tolerance: Some(100.0),
            ..BalloonParams::default()
        };
        let corner = p.image.geometry().index_to_world(DVec3::ZERO);
        let background = Segmenter::new(p.image.view(), params, corner);
        assert!(background.err().unwrap().message().contains("background"));

        let mut s =
            Segmenter::new(p.image.view(), BalloonParams::default(), p.seed_world()).unwrap();
        let mut calls = 0;
        s.set_progress(Some(Box::new(move |_, _| {
            calls += 1;
            calls < 5
        })));
        let e = s.segment().unwrap_err();
        assert_eq!(e.kind(), crate::ErrorKind::Cancelled);
        // The balloon is still there, consistent, after the cancel.
        let (mesh, states) = s.mesh();
        assert_eq!(mesh.points().len(), states.len());
        assert!(mesh_checks::check(&mesh).closed());
    }

    #[test]
    fn a_simplification_reports_the_second_half_of_the_run_and_can_be_cancelled() {
        let p = phantom::render(Shape::Sphere, &PhantomOptions::default()).unwrap();
        let params = BalloonParams {
            simplify_error_mm: 0.1,
            ..BalloonParams::default()
        };
        let seen = std::rc::Rc::new(std::cell::RefCell::new(Vec::new()));
        let mut s = Segmenter::new(p.image.view(), params.clone(), p.seed_world()).unwrap();
        let log = std::rc::Rc::clone(&seen);
        s.set_progress(Some(Box::new(move |fraction, phase| {
            log.borrow_mut().push((fraction, phase));
            true
        })));
        s.segment().unwrap();
        assert!(s.stats().seconds.simplification > 0.0, "{:?}", s.stats());
        let seen = seen.borrow();
        let (method, simplification): (Vec<_>, Vec<_>) = seen
            .iter()
            .partition(|(_, phase)| *phase != Phase::Simplification);
        assert!(!simplification.is_empty(), "{seen:?}");
        assert!(method.iter().all(|(f, _)| *f <= 0.5), "{method:?}");
        assert!(simplification.iter().all(|(f, _)| (0.5..=1.0).contains(f)));
        // The simplification comes last.
        assert_eq!(seen.last().unwrap().1, Phase::Simplification);

        let mut s = Segmenter::new(p.image.view(), params, p.seed_world()).unwrap();
        s.set_progress(Some(Box::new(|_, phase| phase != Phase::Simplification)));
        let e = s.segment().unwrap_err();
        assert_eq!(e.kind(), crate::ErrorKind::Cancelled);
        assert!(e.message().contains("simplification"), "{}", e.message());
        assert!(s.stats().seconds.simplification > 0.0);
    }

    #[test]
    fn a_balloon_stopped_by_max_iterations_says_it_ran_out_of_steps() {
        let (_, stats) = run(Shape::Sphere, &PhantomOptions::default());
        assert!(!stats.out_of_steps, "{stats:?}");
        let p = phantom::render(Shape::Sphere, &PhantomOptions::default()).unwrap();
        let params = BalloonParams {
            max_iterations: 10,
            ..BalloonParams::default()
        };
        let mut s = Segmenter::new(p.image.view(), params, p.seed_world()).unwrap();
        let (mesh, _) = s.segment().unwrap();
        assert!(s.stats().out_of_steps, "{:?}", s.stats());
        assert!(mesh_checks::check(&mesh).is_valid_closed_surface());
    }

    #[test]
    fn everything_foreground_hits_the_vertex_limit_as_a_leak() {
        let p = phantom::render(Shape::Sphere, &PhantomOptions::default()).unwrap();
        let params = BalloonParams {
            reference: Some(600.0),
            tolerance: Some(1e6),
            max_vertices: 2000,
            ..BalloonParams::default()
        };
        let mut s = Segmenter::new(p.image.view(), params, p.seed_world()).unwrap();
        let e = s.segment().unwrap_err();
        assert_eq!(e.kind(), crate::ErrorKind::Leak, "{e}");
        assert!(e.message().contains("tolerance"));
    }
}
