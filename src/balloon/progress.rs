//! Progress and timing: the phases a run goes through, the callback that sees them (and may
//! cancel), and the seconds spent in each.

use std::time::Instant;

use crate::balloon::segmenter::Segmenter;
use crate::error::{Error, Result};

/// The phase a segmenter is in, as progress callbacks see it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    Inflation,
    SelfIntersection,
    Reparametrization,
    Refinement,
    Validation,
    /// Only with `simplify_error_mm` set: the final mesh simplified within it.
    Simplification,
}

impl Phase {
    pub fn name(self) -> &'static str {
        match self {
            Phase::Inflation => "inflation",
            Phase::SelfIntersection => "self-intersection",
            Phase::Reparametrization => "reparametrization",
            Phase::Refinement => "refinement",
            Phase::Validation => "validation",
            Phase::Simplification => "simplification",
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
    pub simplification: f64,
}

impl PhaseSeconds {
    pub fn total(&self) -> f64 {
        self.inflation
            + self.self_intersection
            + self.reparametrization
            + self.refinement
            + self.validation
            + self.simplification
    }

    pub(super) fn add(&mut self, phase: Phase, seconds: f64) {
        *match phase {
            Phase::Inflation => &mut self.inflation,
            Phase::SelfIntersection => &mut self.self_intersection,
            Phase::Reparametrization => &mut self.reparametrization,
            Phase::Refinement => &mut self.refinement,
            Phase::Validation => &mut self.validation,
            Phase::Simplification => &mut self.simplification,
        } += seconds;
    }
}

/// The fraction of the whole run that `fraction` of the method (or, in its phase, of the
/// simplification) stands for. With a simplification to follow (`simplifying`), the method
/// takes the first half of the run and the simplification the second: on the scans it takes
/// about as long as the method, or longer.
pub(in crate::balloon) fn of_the_run(fraction: f64, phase: Phase, simplifying: bool) -> f64 {
    match (phase, simplifying) {
        (_, false) => fraction,
        (Phase::Simplification, true) => 0.5 + 0.5 * fraction,
        (_, true) => 0.5 * fraction,
    }
}

impl<'p> Segmenter<'_, 'p> {
    /// Reports progress to the callback, if any; cancels when it says so.
    pub fn set_progress(&mut self, callback: Option<ProgressCallback<'p>>) {
        self.progress = callback;
    }

    /// `fraction` is of the method for every phase but the simplification, of the
    /// simplification for it ([`of_the_run`]).
    pub(super) fn report(&mut self, fraction: f64, phase: Phase) -> Result<()> {
        let fraction = of_the_run(fraction, phase, self.params.simplification().is_some());
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

    /// Runs `work` on the segmenter and adds its seconds to `phase`'s, whether it succeeds or
    /// not.
    pub(super) fn timed<T>(&mut self, phase: Phase, work: impl FnOnce(&mut Self) -> T) -> T {
        let start = Instant::now();
        let result = work(self);
        self.stats.seconds.add(phase, start.elapsed().as_secs_f64());
        result
    }
}
