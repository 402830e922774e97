//! Step 1 of the paper (section 2), inflation: the balloon's steps (`stepper`: the forces of
//! `forces` integrated, each vertex stopping where `image_model::border` says), remeshing as it
//! grows (`surface::remesh`), the leak guard, and equilibrium. Refinement after a
//! re-parametrisation (the paper's section 3) is the same inflation again.

pub mod forces;
pub(in crate::balloon) mod stepper;

use crate::balloon::progress::Phase;
use crate::balloon::reparametrization::AfterReparametrization;
use crate::balloon::segmenter::Segmenter;
use crate::balloon::surface::Surface;
use crate::error::{Error, Result};
use stepper::{StepReport, Stepper};

/// Edges longer than this many target lengths are split, shorter than `COLLAPSE_BELOW`
/// collapsed: a split leaves halves (0.75 L) above the collapse length, so work is not undone.
const SPLIT_ABOVE: f64 = 1.5;
const COLLAPSE_BELOW: f64 = 0.6;
/// Vertices of the balloon when `inflate` first looks for structures entered through a neck.
pub(super) const FIRST_LEAK_CHECK: usize = 4096;
/// Steps between two remeshings: at three quarters of a voxel per step (the default step
/// fraction) an edge of the growing balloon stretches by well under half its length in between.
const REMESH_INTERVAL: u32 = 2;
/// Equilibrium when no vertex moved more than this fraction of the step size.
const STILL: f64 = 1e-3;
/// Steps over which the enclosed volume must grow by a voxel for the balloon to count as
/// growing: a front advancing at most a voxel per step sweeps a dozen voxels or more in that
/// time. An even count, so that vertices flipping between two positions every step are seen
/// in the same one, not as a balloon that keeps growing.
const STALL_STEPS: u32 = 24;

/// Splits the edges longer than `split`, collapses those shorter than `collapse` and flips for
/// valence (`remesh`), on the moving front.
fn remesh_surface(surface: &mut Surface, split: f64, collapse: f64) -> Result<()> {
    surface.split_long_edges(split)?;
    surface.collapse_short_edges(collapse, split)?;
    surface.flip_edges_for_valence();
    Ok(())
}

impl Segmenter<'_, '_> {
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

    pub(super) fn at_equilibrium(&self, report: &StepReport) -> bool {
        let max_step = self.params.step_fraction * self.volume.geometry().min_spacing();
        report.moving == 0 || report.largest_move < STILL * max_step
    }

    pub(super) fn one_step(&mut self, phase: Phase) -> Result<StepReport> {
        let mut report = self.timed(phase, |s| -> Result<StepReport> {
            let stepper = Stepper {
                image: &s.image,
                border: s.border,
                weights: s.params.weights,
                edge_length: s.edge_length,
                max_step: s.params.step_fraction * s.volume.geometry().min_spacing(),
            };
            s.stats.iterations += 1;
            // One hand-over to the pool per step: remeshing goes with the step when it is due.
            let remesh = (s.stats.iterations % REMESH_INTERVAL == 0).then(|| s.remesh_lengths());
            let (surface, scratch) = (&mut s.surface, &mut s.scratch);
            let report = s.pool.install(|| -> Result<StepReport> {
                let report = stepper.step(surface, scratch);
                if let Some((split, collapse)) = remesh {
                    remesh_surface(surface, split, collapse)?;
                }
                Ok(report)
            })?;
            if remesh.is_some() {
                s.after_remeshing()?;
            }
            Ok(report)
        })?;
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

    pub(super) fn moving_vertices(&self) -> usize {
        self.surface.moving_vertices().count()
    }

    /// The lengths (mm) above which edges are split and below which they are collapsed.
    pub(super) fn remesh_lengths(&self) -> (f64, f64) {
        (
            SPLIT_ABOVE * self.edge_length,
            COLLAPSE_BELOW * self.edge_length,
        )
    }

    pub(super) fn remesh(&mut self) -> Result<()> {
        let (split, collapse) = self.remesh_lengths();
        let surface = &mut self.surface;
        self.pool
            .install(|| remesh_surface(surface, split, collapse))?;
        self.after_remeshing()
    }

    /// The leak guard, and compaction when deleted slots outnumber live ones.
    pub(super) fn after_remeshing(&mut self) -> Result<()> {
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

    /// Up to `limit` steps, until equilibrium: no vertex moving measurably, or the enclosed
    /// volume not growing by a voxel over `STALL_STEPS` steps (vertices that only jitter in
    /// place, between forces that balance, would otherwise keep the balloon going). Returns
    /// the steps taken.
    pub(super) fn inflate(&mut self, phase: Phase, limit: u32) -> Result<u32> {
        let mut run = self.start_inflation(phase, limit);
        while !self.continue_inflation(&mut run)? {}
        Ok(run.steps)
    }

    /// An inflation to be run a step at a time (`continue_inflation`), beside other balloons.
    pub(in crate::balloon) fn start_inflation(&self, phase: Phase, limit: u32) -> Inflation {
        Inflation {
            phase,
            limit,
            steps: 0,
            volume: self.surface.signed_volume(),
        }
    }

    /// The next step of `run`; whether the inflation is over.
    pub(in crate::balloon) fn continue_inflation(&mut self, run: &mut Inflation) -> Result<bool> {
        if run.steps >= run.limit {
            return Ok(true);
        }
        run.steps += 1;
        let report = self.one_step(run.phase)?;
        if self.at_equilibrium(&report) {
            return Ok(true);
        }
        if self.surface.vertex_count() >= self.next_leak_check {
            self.next_leak_check = 2 * self.surface.vertex_count();
            self.cut_touching(AfterReparametrization::Refinement)?;
        }
        if run.steps % STALL_STEPS == 0 {
            let voxel_volume: f64 = self.volume.geometry().spacing().iter().product();
            let now = self.surface.signed_volume();
            if (now - run.volume).abs() < voxel_volume {
                return Ok(true);
            }
            run.volume = now;
        }
        if run.steps >= run.limit {
            self.stats.out_of_steps = true;
            return Ok(true);
        }
        Ok(false)
    }
}

/// Where an inflation stands.
pub(in crate::balloon) struct Inflation {
    phase: Phase,
    limit: u32,
    /// Steps taken.
    pub steps: u32,
    /// The enclosed volume at the last check for a stall.
    volume: f64,
}
