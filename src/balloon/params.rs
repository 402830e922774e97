//! The balloon's parameters, defined once. [`PARAMETERS`] gives each one's name, kind, range,
//! meaning when unset and documentation, and reads and writes it in a [`BalloonParams`]; the
//! defaults are [`BalloonParams::default`]'s. Validation, access by name, the C ABI's
//! `balloon_param_info`, the command line's flags and the table in docs/interfaces.md all come
//! from it, so a new parameter is a field, its default and one entry here. How the defaults are
//! chosen: docs/method.md.

use std::ops::Bound::{self, Excluded, Included, Unbounded};

use crate::balloon::inflation::forces::ForceWeights;
use crate::error::{Error, Result};

/// Parameters of [`super::Segmenter`]; each field's meaning and range is its entry in
/// [`PARAMETERS`]. `None` means "estimate" (reference, tolerance) or "from the volume" (edge
/// length: the mean voxel spacing).
#[derive(Debug, Clone, PartialEq)]
pub struct BalloonParams {
    pub reference: Option<f64>,
    pub tolerance: Option<f64>,
    pub edge_length: Option<f64>,
    pub weights: ForceWeights,
    /// Default 0.75: a step lands inside any dip of the trilinear intensity below the border
    /// that is wider than it, and a dark wall one voxel thick dips below a border half-way to
    /// the structure for a whole voxel.
    pub step_fraction: f64,
    pub max_iterations: u32,
    pub self_intersection_interval: u32,
    pub refinement_iterations: u32,
    pub max_reparametrizations: u32,
    pub max_vertices: usize,
    pub threads: usize,
    /// 0 (the default) returns the balloon as it is; see [`BalloonParams::simplification`].
    pub simplify_error_mm: f64,
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
            simplify_error_mm: 0.0,
        }
    }
}

/// Whether a parameter is a real number or a whole number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParamKind {
    Real,
    Integer,
}

/// One parameter: what the bindings need to offer it, document it and check it. Values pass as
/// `f64`, exact for every whole number up to 2^53; NaN stands for "unset".
#[derive(Debug)]
pub struct Parameter {
    /// The name in C (a field of `BalloonParams`) and Python (a keyword); the VTK filters'
    /// `Set`/`Get` add it in CamelCase.
    pub name: &'static str,
    /// The command line's flag, without the leading `--`.
    pub flag: &'static str,
    pub kind: ParamKind,
    pub min: Bound<f64>,
    pub max: Bound<f64>,
    /// For a parameter that may be left unset: what is used then.
    pub unset: Option<&'static str>,
    /// What it does.
    pub doc: &'static str,
    get: fn(&BalloonParams) -> Option<f64>,
    set: fn(&mut BalloonParams, f64),
}

/// More workers than this is a mistake (each is an OS thread with its own stack), not a request
/// to honour: it would exhaust memory before it sped anything up.
const MAX_THREADS: usize = 1024;

const U32_MAX: Bound<f64> = Included(u32::MAX as f64);

/// Every parameter, in the order of the C struct's fields.
pub const PARAMETERS: &[Parameter] = &[
    Parameter {
        name: "reference_intensity",
        flag: "reference",
        kind: ParamKind::Real,
        min: Unbounded,
        max: Unbounded,
        unset: Some("the median intensity around the first seed"),
        doc: "Intensity of the structure, in the volume's units (HU for CT).",
        get: |p| p.reference,
        set: |p, v| p.reference = given(v),
    },
    Parameter {
        name: "tolerance",
        flag: "tolerance",
        kind: ParamKind::Real,
        min: Excluded(0.0),
        max: Unbounded,
        unset: Some(
            "the distance from the reference to the structure's steepest edge along rays from \
             the first seed",
        ),
        doc: "Half-width of the intensity window around the reference.",
        get: |p| p.tolerance,
        set: |p, v| p.tolerance = given(v),
    },
    Parameter {
        name: "edge_length_mm",
        flag: "edge-length",
        kind: ParamKind::Real,
        min: Excluded(0.0),
        max: Unbounded,
        unset: Some("the mean voxel spacing"),
        doc: "Target length of the balloon's edges, in mm: from half the shortest voxel \
              spacing to ten times the longest.",
        get: |p| p.edge_length,
        set: |p, v| p.edge_length = given(v),
    },
    Parameter {
        name: "elastic_weight",
        flag: "elastic",
        kind: ParamKind::Real,
        min: Included(0.0),
        max: Unbounded,
        unset: None,
        doc: "Weight of the elastic (spring) force, which spreads the vertices evenly.",
        get: |p| Some(p.weights.elastic),
        set: |p, v| p.weights.elastic = v,
    },
    Parameter {
        name: "bending_weight",
        flag: "bending",
        kind: ParamKind::Real,
        min: Included(0.0),
        max: Unbounded,
        unset: None,
        doc: "Weight of the bending force, which flattens dents and spikes.",
        get: |p| Some(p.weights.bending),
        set: |p, v| p.weights.bending = v,
    },
    Parameter {
        name: "inflation_weight",
        flag: "inflation",
        kind: ParamKind::Real,
        min: Excluded(0.0),
        max: Unbounded,
        unset: None,
        doc: "Weight of the inflation force, which pushes the surface out inside the intensity \
              window and back beyond it.",
        get: |p| Some(p.weights.inflation),
        set: |p, v| p.weights.inflation = v,
    },
    Parameter {
        name: "step_fraction",
        flag: "step-fraction",
        kind: ParamKind::Real,
        min: Excluded(0.0),
        max: Included(1.0),
        unset: None,
        doc: "Largest move of a vertex in one step, as a fraction of the smallest voxel spacing, \
              so that the balloon cannot jump through a thin wall.",
        get: |p| Some(p.step_fraction),
        set: |p, v| p.step_fraction = v,
    },
    Parameter {
        name: "max_iterations",
        flag: "max-iterations",
        kind: ParamKind::Integer,
        min: Included(1.0),
        max: U32_MAX,
        unset: None,
        doc: "Steps of inflation before the balloon is taken as it is (equilibrium usually \
              comes first).",
        get: |p| Some(p.max_iterations.into()),
        set: |p, v| p.max_iterations = v as u32,
    },
    Parameter {
        name: "self_intersection_interval",
        flag: "self-intersection-interval",
        kind: ParamKind::Integer,
        min: Included(1.0),
        max: U32_MAX,
        unset: None,
        doc: "Steps between two searches for self-intersections.",
        get: |p| Some(p.self_intersection_interval.into()),
        set: |p, v| p.self_intersection_interval = v as u32,
    },
    Parameter {
        name: "refinement_iterations",
        flag: "refinement-iterations",
        kind: ParamKind::Integer,
        min: Included(0.0),
        max: U32_MAX,
        unset: None,
        doc: "Steps of deformation after each re-parametrisation.",
        get: |p| Some(p.refinement_iterations.into()),
        set: |p, v| p.refinement_iterations = v as u32,
    },
    Parameter {
        name: "max_reparametrizations",
        flag: "max-reparametrizations",
        kind: ParamKind::Integer,
        min: Included(0.0),
        max: U32_MAX,
        unset: None,
        doc: "Re-parametrisations before the marching-cubes surface is returned as it is.",
        get: |p| Some(p.max_reparametrizations.into()),
        set: |p, v| p.max_reparametrizations = v as u32,
    },
    Parameter {
        name: "max_vertices",
        flag: "max-vertices",
        kind: ParamKind::Integer,
        min: Included(64.0),
        max: Unbounded,
        unset: None,
        doc: "Leak guard: growing past this many vertices is an error (the balloon has most \
              likely leaked out of the structure).",
        get: |p| Some(p.max_vertices as f64),
        set: |p, v| p.max_vertices = v as usize,
    },
    Parameter {
        name: "threads",
        flag: "threads",
        kind: ParamKind::Integer,
        min: Included(0.0),
        max: Included(MAX_THREADS as f64),
        unset: None,
        doc: "Worker threads, 0 for all cores. The result does not depend on it.",
        get: |p| Some(p.threads as f64),
        set: |p, v| p.threads = v as usize,
    },
    Parameter {
        name: "simplify_error_mm",
        flag: "simplify",
        kind: ParamKind::Real,
        min: Included(0.0),
        max: Unbounded,
        unset: None,
        doc: "Simplify the result within this distance (mm) of the balloon's surface, both ways \
              (the two-sided Hausdorff distance), keeping every guarantee of the output; a \
              merged vertex takes the least settled vertex_state; several objects are \
              simplified together, so that they cannot cross, each within the bound of its \
              own balloon. 0 returns the balloon as it is.",
        get: |p| Some(p.simplify_error_mm),
        set: |p, v| p.simplify_error_mm = v,
    },
];

/// NaN, the unset value by name, as `None`.
fn given(value: f64) -> Option<f64> {
    (!value.is_nan()).then_some(value)
}

impl Parameter {
    /// Its value in `params`; NaN when unset.
    pub fn get(&self, params: &BalloonParams) -> f64 {
        (self.get)(params).unwrap_or(f64::NAN)
    }

    /// Sets it in `params` (NaN unsets it) once `value` has passed [`Parameter::check`].
    /// Whole numbers beyond the field's type saturate (only `max_vertices` has no upper bound).
    pub fn set(&self, params: &mut BalloonParams, value: f64) -> Result<()> {
        self.check(value)?;
        (self.set)(params, value);
        Ok(())
    }

    /// The default, NaN for "unset".
    pub fn default_value(&self) -> f64 {
        self.get(&BalloonParams::default())
    }

    /// Fails unless `value` (NaN = unset) is allowed; the message names the parameter and the
    /// values to give.
    pub fn check(&self, value: f64) -> Result<()> {
        self.check_value(given(value))
    }

    fn check_value(&self, value: Option<f64>) -> Result<()> {
        let allowed = match value {
            None => self.unset.is_some(),
            Some(v) => {
                let whole = match self.kind {
                    ParamKind::Real => v.is_finite(),
                    ParamKind::Integer => v.fract() == 0.0,
                };
                whole && above(self.min, v) && below(self.max, v)
            }
        };
        if allowed {
            return Ok(());
        }
        Err(Error::invalid_argument(format!(
            "{} is {}; give {}",
            self.name,
            value.unwrap_or(f64::NAN),
            self.allowed()
        )))
    }

    /// The values it takes, in words: "a finite number in (0, 1]", "a whole number of at
    /// least 64, or leave it unset (NaN) for ...".
    pub fn allowed(&self) -> String {
        match self.unset {
            Some(unset) => format!("{}, or leave it unset (NaN) for {unset}", self.range_text()),
            None => self.range_text(),
        }
    }

    /// The kind and range in words, without the unset case: "a finite number in (0, 1]".
    pub fn range_text(&self) -> String {
        let noun = match self.kind {
            ParamKind::Real => "a finite number",
            ParamKind::Integer => "a whole number",
        };
        let range = match (self.min, self.max) {
            (Unbounded, Unbounded) => String::new(),
            (Included(a), Unbounded) => format!(" of at least {a}"),
            (Excluded(a), Unbounded) => format!(" greater than {a}"),
            (Unbounded, Included(b)) => format!(" of at most {b}"),
            (Unbounded, Excluded(b)) => format!(" less than {b}"),
            (Included(a), Included(b)) if self.kind == ParamKind::Integer => {
                format!(" from {a} to {b}")
            }
            (lo, hi) => format!(
                " in {}{}, {}{}",
                open(lo, '[', '('),
                end(lo),
                end(hi),
                open(hi, ']', ')')
            ),
        };
        format!("{noun}{range}")
    }
}

fn above(min: Bound<f64>, v: f64) -> bool {
    match min {
        Unbounded => true,
        Included(a) => v >= a,
        Excluded(a) => v > a,
    }
}

fn below(max: Bound<f64>, v: f64) -> bool {
    match max {
        Unbounded => true,
        Included(b) => v <= b,
        Excluded(b) => v < b,
    }
}

fn open(bound: Bound<f64>, included: char, excluded: char) -> char {
    match bound {
        Included(_) => included,
        _ => excluded,
    }
}

fn end(bound: Bound<f64>) -> f64 {
    match bound {
        Included(v) | Excluded(v) => v,
        Unbounded => f64::INFINITY,
    }
}

/// The parameter called `name`, or an error that lists them all.
pub fn parameter(name: &str) -> Result<&'static Parameter> {
    PARAMETERS.iter().find(|p| p.name == name).ok_or_else(|| {
        let names: Vec<&str> = PARAMETERS.iter().map(|p| p.name).collect();
        Error::invalid_argument(format!(
            "there is no parameter {name:?}; the parameters are {}",
            names.join(", ")
        ))
    })
}

impl BalloonParams {
    /// Checks every value; the error names the parameter and the values it takes.
    pub fn validate(&self) -> Result<()> {
        PARAMETERS
            .iter()
            .try_for_each(|p| p.check_value((p.get)(self)))
    }

    /// The parameter called `name` (see [`PARAMETERS`]); NaN when unset.
    pub fn get(&self, name: &str) -> Result<f64> {
        Ok(parameter(name)?.get(self))
    }

    /// Sets the parameter called `name` after checking the value; NaN unsets it.
    pub fn set(&mut self, name: &str, value: f64) -> Result<()> {
        parameter(name)?.set(self, value)
    }

    /// The bound of the simplification the result goes through, `None` when it is returned as
    /// the balloon left it (`simplify_error_mm` is 0).
    pub fn simplification(&self) -> Option<f64> {
        (self.simplify_error_mm > 0.0).then_some(self.simplify_error_mm)
    }
}

/// A worker-thread count for a pool of its own (0 = all cores), checked as the `threads`
/// parameter before any thread starts.
pub fn check_threads(threads: usize) -> Result<()> {
    parameter("threads")?.check(threads as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_nonsense_is_named() {
        BalloonParams::default().validate().unwrap();
        let bad = |p: BalloonParams| p.validate().unwrap_err().message().to_string();
        let d = BalloonParams::default;
        let cases = [
            (
                "max_iterations",
                BalloonParams {
                    max_iterations: 0,
                    ..d()
                },
            ),
            (
                "tolerance",
                BalloonParams {
                    tolerance: Some(-1.0),
                    ..d()
                },
            ),
            (
                "reference_intensity",
                BalloonParams {
                    reference: Some(f64::NAN),
                    ..d()
                },
            ),
            (
                "edge_length_mm",
                BalloonParams {
                    edge_length: Some(0.0),
                    ..d()
                },
            ),
            (
                "step_fraction",
                BalloonParams {
                    step_fraction: 2.0,
                    ..d()
                },
            ),
            (
                "max_vertices",
                BalloonParams {
                    max_vertices: 3,
                    ..d()
                },
            ),
            (
                "threads",
                BalloonParams {
                    threads: 1_000_000,
                    ..d()
                },
            ),
            (
                "simplify_error_mm",
                BalloonParams {
                    simplify_error_mm: f64::NAN,
                    ..d()
                },
            ),
            (
                "bending_weight",
                BalloonParams {
                    weights: ForceWeights {
                        bending: f64::INFINITY,
                        ..ForceWeights::default()
                    },
                    ..d()
                },
            ),
        ];
        for (name, params) in cases {
            let message = bad(params);
            assert!(message.starts_with(&format!("{name} is ")), "{message}");
        }
    }

    #[test]
    fn messages_say_what_to_give() {
        let message = |name: &str, v: f64| {
            parameter(name)
                .unwrap()
                .check(v)
                .unwrap_err()
                .message()
                .to_string()
        };
        assert_eq!(
            message("step_fraction", 0.0),
            "step_fraction is 0; give a finite number in (0, 1]"
        );
        assert_eq!(
            message("max_iterations", 1.5),
            "max_iterations is 1.5; give a whole number from 1 to 4294967295"
        );
        assert_eq!(
            message("max_vertices", 3.0),
            "max_vertices is 3; give a whole number of at least 64"
        );
        assert_eq!(
            message("edge_length_mm", -1.0),
            "edge_length_mm is -1; give a finite number greater than 0, or leave it unset (NaN) \
             for the mean voxel spacing"
        );
        assert_eq!(
            message("simplify_error_mm", -0.1),
            "simplify_error_mm is -0.1; give a finite number of at least 0"
        );
        assert_eq!(
            message("inflation_weight", f64::NAN),
            "inflation_weight is NaN; give a finite number greater than 0"
        );
    }

    #[test]
    fn every_parameter_reads_and_writes_its_own_field() {
        let mut params = BalloonParams::default();
        let fresh = BalloonParams::default();
        let values: Vec<f64> = PARAMETERS
            .iter()
            .enumerate()
            .map(|(i, p)| {
                assert!(
                    p.check(p.default_value()).is_ok(),
                    "{}'s default is refused",
                    p.name
                );
                let low = match p.min {
                    Included(a) | Excluded(a) => a + 1.0,
                    Unbounded => -7.0,
                };
                let high = match p.max {
                    Included(b) => b,
                    _ => f64::INFINITY,
                };
                let fraction = if p.kind == ParamKind::Real {
                    i as f64 / 100.0
                } else {
                    0.0
                };
                (low + fraction).min(high)
            })
            .collect();
        for (p, &value) in PARAMETERS.iter().zip(&values) {
            params.set(p.name, value).unwrap();
        }
        // Read back after all the writes: two entries sharing a field would show here.
        for (p, &value) in PARAMETERS.iter().zip(&values) {
            assert_eq!(params.get(p.name).unwrap(), value, "{}", p.name);
            assert_ne!(
                p.get(&fresh),
                value,
                "{}: pick a test value off the default",
                p.name
            );
        }
        for p in PARAMETERS.iter().filter(|p| p.unset.is_some()) {
            params.set(p.name, f64::NAN).unwrap();
            assert!(params.get(p.name).unwrap().is_nan());
        }
        assert!(params
            .set("nonsense", 1.0)
            .unwrap_err()
            .message()
            .contains("tolerance"));
    }
}
