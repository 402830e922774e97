//! The balloon's parameters (docs/interfaces.md; how the defaults are chosen: docs/method.md):
//! every one optional, with defaults that work on the shared scans from a seed alone, and a
//! validation that says which value to change.

use super::forces::ForceWeights;
use crate::error::{Error, Result};

/// Parameters of [`super::Segmenter`]. `None` means "estimate" (reference, tolerance) or "from
/// the volume" (edge length: the mean voxel spacing).
#[derive(Debug, Clone, PartialEq)]
pub struct BalloonParams {
    /// Intensity of the structure; default: the median around the first seed.
    pub reference: Option<f64>,
    /// Half-width of the intensity window around the reference; default: the distance from
    /// the reference to the structure's steepest edge around the seed (see `seed_statistics`).
    pub tolerance: Option<f64>,
    /// Target edge length in mm; default: the mean voxel spacing.
    pub edge_length: Option<f64>,
    pub weights: ForceWeights,
    /// Largest displacement of a vertex in one step, as a fraction of the smallest spacing, so
    /// that the balloon cannot jump through a thin wall: a step lands inside any dip of the
    /// trilinear intensity below the border that is wider than it. A dark wall one voxel thick
    /// dips below a border half-way to the structure for a whole voxel. Default 0.75.
    pub step_fraction: f64,
    /// Steps of inflation before the balloon is taken as it is (equilibrium usually comes first).
    pub max_iterations: u32,
    /// Steps between two self-intersection searches.
    pub self_intersection_interval: u32,
    /// Steps of deformation after each re-parametrisation.
    pub refinement_iterations: u32,
    /// Re-parametrisations before the marching-cubes surface is returned as it is.
    pub max_reparametrizations: u32,
    /// Leak guard: growing past this many vertices is an error.
    pub max_vertices: usize,
    /// Worker threads (0 = all cores). The result does not depend on it.
    pub threads: usize,
}

impl Default for BalloonParams {
    fn default() -> Self {
        BalloonParams {
            reference: None,
            tolerance: None,
            edge_length: None,
            weights: ForceWeights::default(),
            step_fraction: 0.75,
            max_iterations: 4000,
            self_intersection_interval: 5,
            refinement_iterations: 40,
            max_reparametrizations: 4,
            max_vertices: 1_000_000,
            threads: 0,
        }
    }
}

/// More workers than this is a mistake (each is an OS thread with its own stack), not a request
/// to honour: it would exhaust memory before it sped anything up.
const MAX_THREADS: usize = 1024;

fn finite_positive(name: &str, value: f64, hint: &str) -> Result<()> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(Error::invalid_argument(format!(
            "{name} is {value}; it must be a finite positive number ({hint})"
        )))
    }
}

impl BalloonParams {
    /// Checks every value; the error names the parameter and a sensible range.
    pub fn validate(&self) -> Result<()> {
        if let Some(r) = self.reference {
            if !r.is_finite() {
                return Err(Error::invalid_argument(format!(
                    "the reference intensity is {r}; give a finite intensity or leave it unset to \
                     estimate it around the seed"
                )));
            }
        }
        if let Some(t) = self.tolerance {
            finite_positive(
                "the tolerance",
                t,
                "leave it unset to estimate it from the seed",
            )?;
        }
        if let Some(l) = self.edge_length {
            finite_positive("the edge length", l, "in mm, e.g. the voxel spacing")?;
        }
        let w = &self.weights;
        for (name, value) in [
            ("the elastic weight", w.elastic),
            ("the bending weight", w.bending),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(Error::invalid_argument(format!(
                    "{name} is {value}; it must be finite and not negative"
                )));
            }
        }
        finite_positive("the inflation weight", w.inflation, "1 by default")?;
        if !(self.step_fraction > 0.0 && self.step_fraction <= 1.0) {
            return Err(Error::invalid_argument(format!(
                "the step fraction is {}; it must be in (0, 1] of the smallest voxel spacing",
                self.step_fraction
            )));
        }
        if self.max_iterations == 0 {
            return Err(Error::invalid_argument(
                "max_iterations is 0: the balloon would not inflate at all; give at least 1",
            ));
        }
        if self.self_intersection_interval == 0 {
            return Err(Error::invalid_argument(
                "the self-intersection interval is 0; give the number of steps between searches \
                 (5 by default)",
            ));
        }
        if self.max_vertices < 64 {
            return Err(Error::invalid_argument(format!(
                "max_vertices is {}; the balloon needs at least 64 vertices to grow",
                self.max_vertices
            )));
        }
        check_threads(self.threads)
    }
}

/// A worker-thread count for a pool of its own (0 = all cores): more than `MAX_THREADS` is a
/// mistake, refused before any thread starts.
pub fn check_threads(threads: usize) -> Result<()> {
    if threads > MAX_THREADS {
        return Err(Error::invalid_argument(format!(
            "threads is {threads}; give 0 for all cores or at most {MAX_THREADS} worker threads"
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_nonsense_is_named() {
        BalloonParams::default().validate().unwrap();
        let bad = |p: BalloonParams| p.validate().unwrap_err().message().to_string();
        let d = BalloonParams::default;
        assert!(bad(BalloonParams {
            max_iterations: 0,
            ..d()
        })
        .contains("max_iterations"));
        assert!(bad(BalloonParams {
            tolerance: Some(-1.0),
            ..d()
        })
        .contains("tolerance"));
        assert!(bad(BalloonParams {
            reference: Some(f64::NAN),
            ..d()
        })
        .contains("reference"));
        assert!(bad(BalloonParams {
            edge_length: Some(0.0),
            ..d()
        })
        .contains("edge length"));
        assert!(bad(BalloonParams {
            step_fraction: 2.0,
            ..d()
        })
        .contains("step fraction"));
        assert!(bad(BalloonParams {
            max_vertices: 3,
            ..d()
        })
        .contains("max_vertices"));
        assert!(bad(BalloonParams {
            threads: 1_000_000,
            ..d()
        })
        .contains("threads"));
        let weights = ForceWeights {
            bending: f64::INFINITY,
            ..ForceWeights::default()
        };
        assert!(bad(BalloonParams { weights, ..d() }).contains("bending"));
    }
}
