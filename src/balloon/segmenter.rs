//! The whole method of the paper (docs/method.md), as a segmenter that can be driven step by step
//! (the C ABI's `balloon_step`, `balloon_freeze_self_intersections`, `balloon_reparametrize`)
//! or run to completion (`segment`).
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

use std::collections::BTreeSet;
use std::time::Instant;

use glam::DVec3;

use super::border::{Border, ImageScales, IntensityWindow};
use super::contact_search::{local_mesh, FrozenTriangles};
use super::curvature_offset::offset_by_curvature;
use super::fairing;
use super::front::Front;
use super::hounsfield;
use super::inflation::{Scratch, StepReport, Stepper};
use super::params::BalloonParams;
use super::reparametrize::{inherited_states, reparametrize, voxel_genus, Keep};
use super::seed_statistics::{self, SeedStatistics};
use super::settling;
use super::surface::{Surface, VertexState};
use super::thin_layer;
use super::touching::cut_touching;
use super::untangle;
use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use crate::mesh_checks;
use crate::self_intersection::{self_intersections, self_intersections_among};
use crate::volume::Volume;

/// The smallest local step that is an edge, as a share of the structure's contrast and in σ
/// of the image inside the structure at the scale of local steps (its texture).
const LOCAL_STEP_SHARE: f64 = 0.25;
const LOCAL_STEP_TEXTURE: f64 = 5.0;
/// The smallest dip of a thin dark wall, as a share of a local step and in σ of the texture.
const VALLEY_STEP_SHARE: f64 = 0.5;
const VALLEY_TEXTURE: f64 = 8.0;
/// Edges longer than this many target lengths are split, shorter than `COLLAPSE_BELOW`
/// collapsed: a split leaves halves (0.75 L) above the collapse length, so work is not undone.
const SPLIT_ABOVE: f64 = 1.5;
const COLLAPSE_BELOW: f64 = 0.6;
/// Vertices of the balloon when `inflate` first looks for structures entered through a neck.
const FIRST_LEAK_CHECK: usize = 4096;
/// Steps between two remeshings: at three quarters of a voxel per step (the default step
/// fraction) an edge of the growing balloon stretches by well under half its length in between.
const REMESH_INTERVAL: u32 = 2;
/// Equilibrium when no vertex moved more than this fraction of the step size.
const STILL: f64 = 1e-3;
/// A final surface re-parametrised to close handles narrower than a voxel must keep the
/// balloon's volume to this share: marching cubes on the scan's grid moves the surface of a
/// lumen 20 mm across by well under half a percent of its volume (stents: 0.25–0.46%), but a
/// vessel a voxel or two thick by several percent (thin-vessels 48: 5.5%), and there a
/// handle narrower than a voxel may be the vessel's own loop, which the grid breaks.
const KEPT_VOLUME: f64 = 0.01;
/// Steps over which the enclosed volume must grow by a voxel for the balloon to count as
/// growing: a front advancing at most a voxel per step sweeps a dozen voxels or more in that
/// time. An even count, so that vertices flipping between two positions every step are seen
/// in the same one, not as a balloon that keeps growing.
const STALL_STEPS: u32 = 24;
/// Radius, in target edge lengths, of the ball whose erosion finds the thick parts of the
/// balloon when looking for structures that touch: thinner parts have no core of their own.
/// At 2.5, two tubes of radius 3.2 mm on 1.92 mm slices (a mean spacing of 1.29 mm) had none,
/// and the second was taken in.
const TOUCHING_EDGE_LENGTHS: f64 = 2.0;
/// The largest move of a vertex by its mean curvature (`curvature_offset`), in voxels: on a
/// vessel a voxel and a half in radius, triangles a voxel across and the fine image's blur
/// move it by about 0.15 voxel, so only a structure well under a voxel reaches the cap.
const CURVATURE_OFFSET_VOXELS: f64 = 0.25;
/// Rounds of undoing each finishing step (curvature offset, settling, fairing) around contacts,
/// and the rings around each contact's triangles that each round puts back.
const UNFAIR_ROUNDS: u32 = 3;
const UNFAIR_RINGS: usize = 2;
/// Cell size, in target edge lengths, of the grid that finds the triangles near the moving
/// front for the self-intersection search: about the size of a triangle's box.
const SEARCH_CELLS: f64 = 2.0;

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

/// Splits the edges longer than `split`, collapses those shorter than `collapse` and flips for
/// valence (`remesh`), on the moving front.
fn remesh_surface(surface: &mut Surface, split: f64, collapse: f64) -> Result<()> {
    surface.split_long_edges(split)?;
    surface.collapse_short_edges(collapse, split)?;
    surface.flip_edges_for_valence();
    Ok(())
}

/// Whether the balloon is refined after a re-parametrisation, or the new surface is final.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum AfterReparametrization {
    Refinement,
    Nothing,
}

/// The phase a segmenter is in, as progress callbacks see it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    Inflation,
    SelfIntersection,
    Reparametrization,
    Refinement,
    Validation,
}

impl Phase {
    pub fn name(self) -> &'static str {
        match self {
            Phase::Inflation => "inflation",
            Phase::SelfIntersection => "self-intersection",
            Phase::Reparametrization => "reparametrization",
            Phase::Refinement => "refinement",
            Phase::Validation => "validation",
        }
    }
}

/// Called with the fraction done (0–1) and the phase; returning `false` cancels.
pub type ProgressCallback<'p> = Box<dyn FnMut(f64, Phase) -> bool + 'p>;

/// Seconds spent per phase.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PhaseSeconds {
    pub inflation: f64,
    pub self_intersection: f64,
    pub reparametrization: f64,
    pub refinement: f64,
    pub validation: f64,
}

impl PhaseSeconds {
    pub fn total(&self) -> f64 {
        self.inflation
            + self.self_intersection
            + self.reparametrization
            + self.refinement
            + self.validation
    }

    fn add(&mut self, phase: Phase, seconds: f64) {
        *match phase {
            Phase::Inflation => &mut self.inflation,
            Phase::SelfIntersection => &mut self.self_intersection,
            Phase::Reparametrization => &mut self.reparametrization,
            Phase::Refinement => &mut self.refinement,
            Phase::Validation => &mut self.validation,
        } += seconds;
    }
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
    pub seconds: PhaseSeconds,
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
    volume: Volume<'v>,
    /// The volume as the balloon sees it.
    image: ImageScales<'v>,
    params: BalloonParams,
    border: Border,
    edge_length: f64,
    surface: Surface,
    /// The surface's frozen triangles, for the contact search; rebuilt with the surface.
    frozen: FrozenTriangles,
    /// The seed points (world mm): the structures touching theirs are cut off at the end.
    seeds: Vec<DVec3>,
    scratch: Scratch,
    /// The vertex count at which `inflate` next looks for structures entered through a neck
    /// (`touching`): each time the balloon has doubled, so that a leak is cut off before it
    /// spreads from the neighbour into everything beyond, at a cost that adds up to a few
    /// times the last look's.
    next_leak_check: usize,
    stats: SegmentationStats,
    pool: rayon::ThreadPool,
    progress: Option<ProgressCallback<'p>>,
}

impl<'v, 'p> Segmenter<'v, 'p> {
    /// A balloon of about one voxel's radius at `seed` (world mm). Reference intensity and
    /// tolerance not given in `params` are estimated around this seed.
    pub fn new(volume: Volume<'v>, params: BalloonParams, seed: DVec3) -> Result<Self> {
        params.validate()?;
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(params.threads)
            .build()
            .map_err(|e| Error::invalid_argument(format!("cannot start the threads: {e}")))?;
        let geometry = *volume.geometry();
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
        let edge_length = params.edge_length.unwrap_or(geometry.mean_spacing());
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
                seconds: PhaseSeconds::default(),
            },
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

    /// The seed must be where the balloon sees the structure: inside the window on the
    /// smoothed image.
    fn check_seed(&self, seed: DVec3) -> Result<()> {
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

    /// Reports progress to the callback, if any; cancels when it says so.
    pub fn set_progress(&mut self, callback: Option<ProgressCallback<'p>>) {
        self.progress = callback;
    }

    fn report(&mut self, fraction: f64, phase: Phase) -> Result<()> {
        let go_on = match &mut self.progress {
            Some(callback) => callback(fraction.clamp(0.0, 1.0), phase),
            None => true,
        };
        if go_on {
            Ok(())
        } else {
            Err(Error::cancelled(format!(
                "cancelled by the progress callback during {}",
                phase.name()
            )))
        }
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

    /// Up to `iterations` steps of inflation (remeshing and self-intersection searches
    /// included); stops early at equilibrium. Returns the number of vertices still moving.
    pub fn step(&mut self, iterations: u32) -> Result<usize> {
        let mut moving = self.surface.vertex_count();
        for _ in 0..iterations {
            let report = self.one_step(Phase::Inflation)?;
            moving = report.moving;
            if self.at_equilibrium(&report) {
                break;
            }
        }
        Ok(moving)
    }

    fn at_equilibrium(&self, report: &StepReport) -> bool {
        let max_step = self.params.step_fraction * self.volume.geometry().min_spacing();
        report.moving == 0 || report.largest_move < STILL * max_step
    }

    fn one_step(&mut self, phase: Phase) -> Result<StepReport> {
        let start = Instant::now();
        let stepper = Stepper {
            image: &self.image,
            border: self.border,
            weights: self.params.weights,
            edge_length: self.edge_length,
            max_step: self.params.step_fraction * self.volume.geometry().min_spacing(),
        };
        self.stats.iterations += 1;
        // One hand-over to the pool per step: remeshing goes with the step when it is due.
        let remesh = (self.stats.iterations % REMESH_INTERVAL == 0).then(|| self.remesh_lengths());
        let (surface, scratch) = (&mut self.surface, &mut self.scratch);
        let mut report = self.pool.install(|| -> Result<StepReport> {
            let report = stepper.step(surface, scratch);
            if let Some((split, collapse)) = remesh {
                remesh_surface(surface, split, collapse)?;
            }
            Ok(report)
        })?;
        if remesh.is_some() {
            self.after_remeshing()?;
        }
        self.stats.seconds.add(phase, start.elapsed().as_secs_f64());
        if self.stats.iterations % self.params.self_intersection_interval == 0 {
            self.freeze_self_intersections()?;
            report.moving = self.moving_vertices();
        }
        let total = self.surface.vertex_count().max(1);
        let done = 1.0 - report.moving as f64 / total as f64;
        let fraction = match phase {
            Phase::Refinement => 0.8 + 0.15 * done,
            _ => 0.75 * done,
        };
        self.report(fraction, phase)?;
        Ok(report)
    }

    fn moving_vertices(&self) -> usize {
        self.surface.moving_vertices().count()
    }

    /// The lengths (mm) above which edges are split and below which they are collapsed.
    fn remesh_lengths(&self) -> (f64, f64) {
        (
            SPLIT_ABOVE * self.edge_length,
            COLLAPSE_BELOW * self.edge_length,
        )
    }

    fn remesh(&mut self) -> Result<()> {
        let (split, collapse) = self.remesh_lengths();
        let surface = &mut self.surface;
        self.pool
            .install(|| remesh_surface(surface, split, collapse))?;
        self.after_remeshing()
    }

    /// The leak guard, and compaction when deleted slots outnumber live ones.
    fn after_remeshing(&mut self) -> Result<()> {
        if self.surface.vertex_count() > self.params.max_vertices {
            return Err(Error::leak(format!(
                "the balloon grew past {} vertices: it has most likely leaked out of the \
                 structure through a gap in its wall; narrow the window (now {}: give a \
                 smaller tolerance), raise the bending weight, or raise max_vertices if the \
                 structure is really that large",
                self.params.max_vertices, self.border.window
            )));
        }
        if self.surface.vertex_slots() > 2 * self.surface.vertex_count() {
            self.surface.compact();
            self.index_surface();
        }
        Ok(())
    }

    /// Starts the index of frozen triangles afresh, after the surface was replaced or
    /// compacted (slots renumbered).
    fn index_surface(&mut self) {
        self.surface.record_rewrites();
        self.frozen = FrozenTriangles::new(&self.surface, SEARCH_CELLS * self.edge_length);
    }

    /// The balloon from now on: `surface`, with its index of frozen triangles.
    fn replace_surface(&mut self, surface: Surface) {
        self.surface = surface;
        self.index_surface();
    }

    /// Freezes the vertices of every triangle that intersects another (paper, section 3), and
    /// the rest of each moving front that touched the balloon (frozen at the border, so that it
    /// does not grow on inside the balloon's own interior until re-parametrisation merges the
    /// lobes); returns how many vertices were newly frozen. Pairs a few rings apart on the
    /// surface are folds of the mesh, not contacts: their patch is relaxed instead
    /// (`untangle`).
    pub fn freeze_self_intersections(&mut self) -> Result<usize> {
        let start = Instant::now();
        let front = Front::of(&self.surface);
        let near = self.frozen.near(&mut self.surface, &front);
        let local = local_mesh(&self.surface, &near)?;
        let local_active: Vec<bool> = near
            .iter()
            .map(|t| front.triangles.binary_search(t).is_ok())
            .collect();
        let pairs = self
            .pool
            .install(|| self_intersections_among(&local, &local_active))?;
        let corners = |t: u32| {
            self.surface
                .triangle(near[t as usize])
                .expect("near triangles are live")
        };
        let (folds, contacts): (Vec<_>, Vec<_>) = pairs
            .into_iter()
            .partition(|&(a, b)| untangle::is_fold(&self.surface, corners(a), corners(b)));
        let folded: BTreeSet<u32> = folds
            .iter()
            .flat_map(|&(a, b)| corners(a).into_iter().chain(corners(b)))
            .collect();
        let contacts: Vec<[u32; 3]> = contacts
            .iter()
            .flat_map(|&(a, b)| [corners(a), corners(b)])
            .collect();
        if !folded.is_empty() {
            let (image, border) = (&self.image, self.border);
            let surface = &mut self.surface;
            self.pool
                .install(|| untangle::relax(surface, &folded, |p| border.passable(image, p)));
        }
        let mut frozen = 0;
        let mut fronts = Vec::new();
        for v in contacts.into_iter().flatten() {
            let state = &mut self.surface.states_mut()[v as usize];
            if *state != VertexState::FrozenBySelfIntersection {
                *state = VertexState::FrozenBySelfIntersection;
                frozen += 1;
                fronts.push(v);
            }
        }
        frozen += self.freeze_fronts(fronts);
        self.stats
            .seconds
            .add(Phase::SelfIntersection, start.elapsed().as_secs_f64());
        Ok(frozen)
    }

    /// Freezes every moving vertex connected through moving vertices to `seeds` — the rest of
    /// a front that met the balloon — as if at the border, so its triangles still shape the
    /// distance map. Left moving, the part of the front that passed the contact would go on
    /// inflating inside the balloon's own interior, along the whole structure (on the aorta,
    /// doubling the balloon's volume in overlapping lobes and making contacts all along).
    /// Re-parametrisation merges the lobes, and refinement lets the front move on where it is
    /// still inside the window.
    /// Returns how many vertices it froze.
    fn freeze_fronts(&mut self, mut seeds: Vec<u32>) -> usize {
        let mut frozen = 0;
        while let Some(v) = seeds.pop() {
            let moving: Vec<u32> = self
                .surface
                .neighbours(v)
                .filter(|&n| self.surface.states()[n as usize] == VertexState::Moving)
                .collect();
            for n in moving {
                self.surface.states_mut()[n as usize] = VertexState::FrozenAtBorder;
                frozen += 1;
                seeds.push(n);
            }
        }
        frozen
    }

    /// Replaces the balloon by the zero isosurface of its signed distance map, without the
    /// self-intersecting triangles (paper, section 3). Its vertices inside the intensity window
    /// move again afterwards; those outside it stay (`freeze_outside_window`).
    pub fn reparametrize(&mut self) -> Result<()> {
        self.replace_by_isosurface(AfterReparametrization::Refinement)?;
        self.remesh()
    }

    /// [`Self::reparametrize`] without the remeshing, whose splits and collapses could make
    /// new contacts: the marching-cubes surface as it is. Before a refinement the vertices
    /// inside the window move; a final surface keeps the states of the balloon it replaces
    /// (`inherited_states`), so that what was still moving says so.
    fn replace_by_isosurface(&mut self, next: AfterReparametrization) -> Result<()> {
        let start = Instant::now();
        self.report(0.75, Phase::Reparametrization)?;
        let (mesh, states) = self.mesh();
        let geometry = *self.volume.geometry();
        let (image, border) = (&self.image, self.border);
        let keep = Keep {
            seeds: &self.seeds,
            passable: &|p| border.passable(image, p),
        };
        let repaired = self
            .pool
            .install(|| reparametrize(&mesh, &states, &geometry, &keep))?;
        let mut surface = Surface::from_mesh(&repaired)?;
        match next {
            AfterReparametrization::Nothing => {
                let reach = 2.0 * geometry.max_spacing();
                let inherited = inherited_states(&mesh, &states, &repaired, reach);
                surface.states_mut().copy_from_slice(&inherited);
            }
            AfterReparametrization::Refinement => self.freeze_outside_window(&mut surface),
        }
        self.replace_surface(surface);
        self.stats.reparametrizations += 1;
        self.stats
            .seconds
            .add(Phase::Reparametrization, start.elapsed().as_secs_f64());
        Ok(())
    }

    /// Freezes the vertices of a new surface where the balloon may not go (`border`), or where
    /// a vertex coming from a voxel inside would have stopped at a local step
    /// (`Border::step_ahead`): the balloon stopped there at muscle or a thin wall inside the
    /// window, and released, the new surface would walk into it. The others move on to the
    /// border. Where two lumens meet across a saddle below the border (the aorta's renal
    /// arteries), the merged surface bridges the saddle: pulled in, the bridge deflated from
    /// both sides until they passed through each other, and the same contact came back after
    /// every re-parametrisation.
    fn freeze_outside_window(&self, surface: &mut Surface) {
        let normals = surface.vertex_normals();
        let (positions, states) = surface.positions_and_states_mut();
        for ((&p, n), state) in positions.iter().zip(normals).zip(states) {
            if !self.may_move_on(p, n) {
                *state = VertexState::FrozenAtBorder;
            }
        }
    }

    /// Whether a vertex of a new surface at `p` with outward normal `n` may move on: where the
    /// balloon may go, and not past a local step that a vertex coming from a voxel inside
    /// would have stopped at.
    fn may_move_on(&self, p: DVec3, n: DVec3) -> bool {
        self.border.passable(&self.image, p)
            && self
                .border
                .step_ahead(&self.image, p - self.border.voxel * n, p)
                .is_none()
    }

    fn has_self_intersections(&self) -> bool {
        self.surface
            .states()
            .contains(&VertexState::FrozenBySelfIntersection)
    }

    /// The whole method to completion: the final mesh (world mm, outward, closed, 2-manifold,
    /// without self-intersections) and the state of each of its vertices.
    ///
    /// After each re-parametrisation the new surface is refined by the same deformation until
    /// it is at equilibrium again (at least `refinement_iterations` steps, at most what is left
    /// of `max_iterations`): contacts freeze the parts of the front that meet, and the rest of
    /// the front, frozen with them before the re-parametrisation, must go on growing.
    pub fn segment(&mut self) -> Result<(TriMesh, Vec<VertexState>)> {
        let mut budget = self.params.max_iterations;
        budget -= self.inflate(Phase::Inflation, budget)?;
        self.freeze_self_intersections()?;
        while self.has_self_intersections()
            && self.stats.reparametrizations < self.params.max_reparametrizations
        {
            self.reparametrize()?;
            let used = self.inflate(
                Phase::Refinement,
                budget.max(self.params.refinement_iterations),
            )?;
            budget = budget.saturating_sub(used);
            self.freeze_self_intersections()?;
        }
        self.cut_touching(AfterReparametrization::Nothing)?;
        let earlier = self.fair();
        self.validated(earlier)
    }

    /// Fairs the final surface (`fairing`) and settles it onto thin layers' crests and the
    /// local half level where background lies ahead (`settling`), fairing the vertices moved
    /// onto crests and their neighbours once more, then moves the vertices out by the biases
    /// of their triangles and of the fine image on a curved surface (`curvature_offset`),
    /// unless it stopped with contacts (re-parametrised next, in `validated`). Returns the
    /// positions, by slot, before that move, before settling and before fairing, for
    /// `validated` to put back in that order where any made the surface meet itself: a settled
    /// vertex may move two voxels, onto a crest.
    fn fair(&mut self) -> Vec<Vec<DVec3>> {
        if self.has_self_intersections() {
            return Vec::new();
        }
        let start = Instant::now();
        let surface = &mut self.surface;
        let unfaired = self.pool.install(|| fairing::fair(surface));
        let unsettled = self.surface.positions().to_vec();
        let soft_tissue = self
            .stats
            .seed_statistics
            .as_ref()
            .and_then(|s| s.soft_tissue);
        let (surface, image, border) = (&mut self.surface, &self.image, &self.border);
        let settled = self
            .pool
            .install(|| settling::settle(surface, image, border, soft_tissue));
        let around: Vec<u32> = self
            .surface
            .neighbourhood(settled.crested, 1)
            .into_iter()
            .collect();
        let surface = &mut self.surface;
        self.pool
            .install(|| fairing::fair_vertices(surface, &around));
        let variance = self.image.fine.blur_variances().iter().sum::<f64>() / 3.0;
        let on_edge = settled.on_darker_edge;
        let smoothing = |v: u32| if on_edge[v as usize] { variance } else { 0.0 };
        let largest = CURVATURE_OFFSET_VOXELS * self.border.voxel;
        let surface = &mut self.surface;
        let unmoved = self
            .pool
            .install(|| offset_by_curvature(surface, smoothing, largest));
        self.index_surface();
        self.stats
            .seconds
            .add(Phase::Refinement, start.elapsed().as_secs_f64());
        vec![unmoved, unsettled, unfaired]
    }

    /// Puts the corners of the triangles in `pairs` (of `mesh`, the current surface as
    /// [`Self::mesh`] gave it) and [`UNFAIR_RINGS`] rings around them back where they were
    /// `before` (the curvature offset, settling or fairing); every vertex when `pairs` is
    /// empty.
    fn unfair(&mut self, before: &[DVec3], mesh: &TriMesh, pairs: &[(u32, u32)]) {
        if pairs.is_empty() {
            self.surface.positions_mut().copy_from_slice(before);
        } else {
            // The mesh numbers the live slots densely, in slot order.
            let slots: Vec<u32> = self.surface.live_vertices().collect();
            let corners: Vec<u32> = pairs
                .iter()
                .flat_map(|&(a, b)| [a, b])
                .flat_map(|t| mesh.triangles()[t as usize])
                .map(|v| slots[v as usize])
                .collect();
            fairing::restore(&mut self.surface, before, corners, UNFAIR_RINGS);
        }
        self.index_surface();
    }

    /// Cuts off the structures the balloon entered through an elongated contact with the
    /// seeds' structure (`touching`), with cores eroded by `TOUCHING_EDGE_LENGTHS` target edge
    /// lengths: the paper ties the triangle size to the scale of the smallest structure.
    fn cut_touching(&mut self, next: AfterReparametrization) -> Result<()> {
        let start = Instant::now();
        self.report(0.9, Phase::Reparametrization)?;
        let (mesh, _) = self.mesh();
        let geometry = *self.volume.geometry();
        let radius = TOUCHING_EDGE_LENGTHS * self.edge_length;
        let (seeds, earlier) = (&self.seeds, self.image.excluded());
        if let Some(cut) = self
            .pool
            .install(|| cut_touching(&mesh, &geometry, seeds, radius, earlier))?
        {
            self.image.exclude(cut.removed);
            let mut surface = Surface::from_mesh(&cut.mesh)?;
            match next {
                AfterReparametrization::Nothing => {
                    surface.states_mut().fill(VertexState::FrozenAtBorder)
                }
                AfterReparametrization::Refinement => self.freeze_outside_window(&mut surface),
            }
            self.replace_surface(surface);
        }
        self.stats
            .seconds
            .add(Phase::Reparametrization, start.elapsed().as_secs_f64());
        Ok(())
    }

    /// Up to `limit` steps, until equilibrium: no vertex moving measurably, or the enclosed
    /// volume not growing by a voxel over `STALL_STEPS` steps (vertices that only jitter in
    /// place, between forces that balance, would otherwise keep the balloon going). Returns
    /// the steps taken.
    fn inflate(&mut self, phase: Phase, limit: u32) -> Result<u32> {
        let geometry = *self.volume.geometry();
        let voxel_volume: f64 = geometry.spacing().iter().product();
        let mut volume = self.surface.signed_volume();
        for step in 1..=limit {
            let report = self.one_step(phase)?;
            if self.at_equilibrium(&report) {
                return Ok(step);
            }
            if self.surface.vertex_count() >= self.next_leak_check {
                self.next_leak_check = 2 * self.surface.vertex_count();
                self.cut_touching(AfterReparametrization::Refinement)?;
            }
            if step % STALL_STEPS == 0 {
                let now = self.surface.signed_volume();
                if (now - volume).abs() < voxel_volume {
                    return Ok(step);
                }
                volume = now;
            }
        }
        Ok(limit)
    }

    /// The current mesh if it meets the guarantees, without the handles narrower than a voxel
    /// ([`Self::with_fewer_handles`]). Where the curvature offset, settling or fairing
    /// (`earlier`: the positions before each, latest first) made the surface meet itself, each
    /// in turn is undone around the contacts, [`UNFAIR_ROUNDS`] times each, then the latest
    /// everywhere, and so on. Otherwise (or straight away if it stopped with contacts) one more
    /// re-parametrisation, without refinement or remeshing — a marching-cubes surface has no
    /// contacts — checked again.
    fn validated(&mut self, mut earlier: Vec<Vec<DVec3>>) -> Result<(TriMesh, Vec<VertexState>)> {
        let start = Instant::now();
        self.report(0.95, Phase::Validation)?;
        // A balloon that stopped with contacts cannot pass: repair it without measuring it.
        let mut repaired = self.has_self_intersections();
        if repaired {
            self.replace_by_isosurface(AfterReparametrization::Nothing)?;
        }
        let mut unfair_rounds = 0;
        loop {
            let (mesh, states) = self.mesh();
            let report = mesh_checks::check(&mesh);
            let pairs = self.pool.install(|| self_intersections(&mesh));
            if report.is_valid_closed_surface() && pairs.is_empty() {
                let result = match report.genus() {
                    Some(genus) if genus > 0 && !repaired && report.components == 1 => self
                        .with_fewer_handles(&mesh, genus, report.signed_volume)?
                        .unwrap_or((mesh, states)),
                    _ => (mesh, states),
                };
                self.stats
                    .seconds
                    .add(Phase::Validation, start.elapsed().as_secs_f64());
                self.report(1.0, Phase::Validation)?;
                return Ok(result);
            }
            if !earlier.is_empty() {
                // Around the contacts, each step undone in turn, latest first, before the
                // latest is undone everywhere: a contact settling made stays when only the
                // curvature offset is undone around it.
                let stage = (unfair_rounds / UNFAIR_ROUNDS) as usize;
                if stage < earlier.len() && report.is_valid_closed_surface() {
                    self.unfair(&earlier[stage], &mesh, &pairs);
                    unfair_rounds += 1;
                } else {
                    let before = earlier.remove(0);
                    self.unfair(&before, &mesh, &[]);
                    unfair_rounds = 0;
                }
                continue;
            }
            if repaired {
                return Err(Error::internal(format!(
                    "the segmentation failed its own checks (closed {}, manifold {}, outward {}, \
                     {} self-intersecting pairs) even after re-parametrisation",
                    report.closed(),
                    report.manifold(),
                    report.outward(),
                    pairs.len()
                )));
            }
            self.freeze_self_intersections()?;
            self.replace_by_isosurface(AfterReparametrization::Nothing)?;
            repaired = true;
        }
    }

    /// The final surface `mesh` (of genus `genus`, enclosing `volume`) re-parametrised (without
    /// refinement), if its voxels have fewer handles and the new surface is valid with fewer,
    /// not fewer than the voxels, and of the same volume within [`KEPT_VOLUME`]; otherwise the
    /// surface stays as it was. A handle narrower than a voxel is one the image cannot show,
    /// and the paper's re-parametrisation closes it: the stents' lumens wrapped around their
    /// struts (variants 8, 28, 41, 52: genus 1), the slab aorta around something on its wall
    /// (genus 2).
    fn with_fewer_handles(
        &mut self,
        mesh: &TriMesh,
        genus: i64,
        volume: f64,
    ) -> Result<Option<(TriMesh, Vec<VertexState>)>> {
        let geometry = *self.volume.geometry();
        let Some(least) = self.pool.install(|| voxel_genus(mesh, &geometry))? else {
            return Ok(None);
        };
        if least >= genus {
            return Ok(None);
        }
        let before = self.surface.clone();
        self.replace_by_isosurface(AfterReparametrization::Nothing)?;
        let (without_handles, states) = self.mesh();
        let report = mesh_checks::check(&without_handles);
        if report.is_valid_closed_surface()
            && report.genus().is_some_and(|g| g < genus && g >= least)
            && (report.signed_volume - volume).abs() <= KEPT_VOLUME * volume
            && self
                .pool
                .install(|| self_intersections(&without_handles))
                .is_empty()
        {
            return Ok(Some((without_handles, states)));
        }
        self.replace_surface(before);
        Ok(None)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::phantom::{self, PhantomOptions, Shape};

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
        assert!(!self_intersections(&s.mesh().0).is_empty());
        test(&mut s, before);
    }

    #[test]
    fn fairing_that_makes_a_contact_is_undone_there_without_remeshing() {
        with_a_vertex_pushed_through(|s, before| {
            let reparametrizations = s.stats.reparametrizations;
            let (mesh, _) = s.validated(vec![before.clone()]).unwrap();
            assert!(mesh_checks::check(&mesh).is_valid_closed_surface());
            assert!(self_intersections(&mesh).is_empty());
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
            assert!(self_intersections(&mesh).is_empty());
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
