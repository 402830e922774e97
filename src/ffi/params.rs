//! `BalloonParams`, the C layout of [`balloon::BalloonParams`] (whose table, `PARAMETERS`,
//! documents each field): NaN stands for "not given" in the optional values, and `struct_size`
//! lets the library reject a caller compiled against another layout instead of misreading it.

use std::mem::size_of;

use super::boundary::{require, run, Failure};
use super::status::BalloonStatus;
use crate::balloon::{self, ForceWeights};
use crate::error::Error;

/// The balloon's parameters. Fill with `balloon_params_default`, then change what you need,
/// directly or by name with `balloon_params_set`. Each field's meaning, default and range is
/// in `balloon_param_info` (and docs/interfaces.md); NaN leaves reference_intensity, tolerance
/// and edge_length_mm unset, to be estimated around the first seed or taken from the volume.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BalloonParams {
    /// sizeof(BalloonParams); set by balloon_params_default, checked by balloon_init.
    pub struct_size: usize,
    pub reference_intensity: f64,
    pub tolerance: f64,
    /// From half the volume's shortest spacing to ten times its longest, or NaN for the mean
    /// spacing; outside that, segmentation is BALLOON_INVALID_ARGUMENT.
    pub edge_length_mm: f64,
    pub elastic_weight: f64,
    pub bending_weight: f64,
    pub inflation_weight: f64,
    pub step_fraction: f64,
    pub max_iterations: u32,
    pub self_intersection_interval: u32,
    pub refinement_iterations: u32,
    pub max_reparametrizations: u32,
    /// Growing past it fails with BALLOON_LEAK.
    pub max_vertices: u64,
    /// 0 = all cores; the segmenter's own pool.
    pub threads: u32,
    /// 0 (the default) returns the balloon as it is. A positive distance (mm) simplifies the
    /// result of balloon_segment and balloon_segment_objects so that every
    /// point of the result within this distance of the balloon's surface and every point of
    /// that surface within it of the result (two-sided Hausdorff), still closed, 2-manifold,
    /// outward, free of self-intersections (also between objects), with the same genus and
    /// components. Several objects are simplified together, so they cannot cross, and each keeps
    /// the bound to its own balloon. A merged vertex takes the least settled vertex_state (moving before frozen
    /// by a self-intersection before frozen at the border). NaN, negative or infinite values
    /// are BALLOON_INVALID_ARGUMENT. Added last: a caller compiled against an older header
    /// has a smaller struct_size and is refused with BALLOON_PARAMS_SIZE_MISMATCH.
    pub simplify_error_mm: f64,
}

fn optional(value: f64) -> Option<f64> {
    (!value.is_nan()).then_some(value)
}

impl From<&balloon::BalloonParams> for BalloonParams {
    fn from(p: &balloon::BalloonParams) -> Self {
        let balloon::BalloonParams {
            reference,
            tolerance,
            edge_length,
            weights,
            step_fraction,
            max_iterations,
            self_intersection_interval,
            refinement_iterations,
            max_reparametrizations,
            max_vertices,
            threads,
            simplify_error_mm,
        } = p.clone();
        BalloonParams {
            struct_size: size_of::<BalloonParams>(),
            reference_intensity: reference.unwrap_or(f64::NAN),
            tolerance: tolerance.unwrap_or(f64::NAN),
            edge_length_mm: edge_length.unwrap_or(f64::NAN),
            elastic_weight: weights.elastic,
            bending_weight: weights.bending,
            inflation_weight: weights.inflation,
            step_fraction,
            max_iterations,
            self_intersection_interval,
            refinement_iterations,
            max_reparametrizations,
            max_vertices: max_vertices as u64,
            threads: u32::try_from(threads).unwrap_or(u32::MAX),
            simplify_error_mm,
        }
    }
}

impl BalloonParams {
    /// The Rust parameters; their validation is `Segmenter::new`'s.
    pub(crate) fn to_rust(self) -> Result<balloon::BalloonParams, Failure> {
        let max_vertices = usize::try_from(self.max_vertices).map_err(|_| {
            Error::invalid_argument(format!(
                "max_vertices is {}, more than this platform can address",
                self.max_vertices
            ))
        })?;
        Ok(balloon::BalloonParams {
            reference: optional(self.reference_intensity),
            tolerance: optional(self.tolerance),
            edge_length: optional(self.edge_length_mm),
            weights: ForceWeights {
                elastic: self.elastic_weight,
                bending: self.bending_weight,
                inflation: self.inflation_weight,
            },
            step_fraction: self.step_fraction,
            max_iterations: self.max_iterations,
            self_intersection_interval: self.self_intersection_interval,
            refinement_iterations: self.refinement_iterations,
            max_reparametrizations: self.max_reparametrizations,
            max_vertices,
            threads: self.threads as usize,
            simplify_error_mm: self.simplify_error_mm,
        })
    }
}

/// Fails unless the `struct_size` that the caller's struct at `ptr` starts with is this
/// library's size of `T`; reads nothing else.
///
/// # Safety
/// `T` is one of the `#[repr(C)]` structs that start with `struct_size: usize`; `ptr` is
/// non-NULL and points to at least that leading size.
pub(crate) unsafe fn check_struct_size<T>(ptr: *const T, name: &str) -> Result<(), Failure> {
    // SAFETY: by the caller's promise, the struct starts with a readable size_t.
    let given = unsafe { ptr.cast::<usize>().read_unaligned() };
    let expected = size_of::<T>();
    if given == expected {
        Ok(())
    } else {
        Err(Failure::new(
            BalloonStatus::BALLOON_PARAMS_SIZE_MISMATCH,
            format!(
                "{name}.struct_size is {given} but this library's {name} has {expected} bytes: \
                 the program was compiled against another balloonseg.h; set struct_size to \
                 sizeof({name}) and rebuild against the header of this library"
            ),
        ))
    }
}

/// The parameters `params` points to, or the defaults when it is NULL.
///
/// # Safety
/// `params` must be NULL or point to readable memory that starts with a `size_t`, and holds a
/// whole `BalloonParams` when that size is this library's.
pub(crate) unsafe fn params_from_c(
    params: *const BalloonParams,
) -> Result<balloon::BalloonParams, Failure> {
    if params.is_null() {
        return Ok(balloon::BalloonParams::default());
    }
    // SAFETY: non-NULL; only the leading size is read before it is known to match.
    unsafe { check_struct_size(params, "BalloonParams")? };
    // SAFETY: the struct has this library's size, so the caller's memory holds all of it.
    unsafe { params.read_unaligned() }.to_rust()
}

/// Writes the default parameters (with struct_size set) to `out`.
///
/// # Safety
/// `out` must be NULL or point to a writable `BalloonParams`.
#[no_mangle]
pub unsafe extern "C" fn balloon_params_default(out: *mut BalloonParams) -> BalloonStatus {
    run(|| {
        require(out, "out")?;
        let defaults = BalloonParams::from(&balloon::BalloonParams::default());
        // SAFETY: non-NULL and writable by the caller's promise.
        unsafe { out.write_unaligned(defaults) };
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_round_trip_and_nan_means_not_given() {
        let mut c = BalloonParams::from(&balloon::BalloonParams::default());
        c.struct_size = 0;
        assert_eq!(
            unsafe { balloon_params_default(&mut c) },
            BalloonStatus::BALLOON_OK
        );
        assert_eq!(c.struct_size, size_of::<BalloonParams>());
        assert!(c.reference_intensity.is_nan() && c.tolerance.is_nan());
        assert_eq!(c.to_rust().unwrap(), balloon::BalloonParams::default());

        let given = balloon::BalloonParams {
            reference: Some(-3.0),
            tolerance: Some(2.0),
            edge_length: Some(0.5),
            weights: ForceWeights {
                elastic: 0.1,
                bending: 0.2,
                inflation: 0.3,
            },
            step_fraction: 0.5,
            max_iterations: 6,
            self_intersection_interval: 7,
            refinement_iterations: 8,
            max_reparametrizations: 9,
            max_vertices: 100,
            threads: 2,
            simplify_error_mm: 0.25,
        };
        assert_eq!(BalloonParams::from(&given).to_rust().unwrap(), given);
    }

    #[test]
    fn a_wrong_struct_size_names_both_sizes() {
        let mut c = BalloonParams::from(&balloon::BalloonParams::default());
        c.struct_size = 8;
        let f = unsafe { params_from_c(&c) }.unwrap_err();
        assert_eq!(f.status, BalloonStatus::BALLOON_PARAMS_SIZE_MISMATCH);
        let expected = size_of::<BalloonParams>().to_string();
        assert!(
            f.message.contains(" 8 ") && f.message.contains(&expected),
            "{}",
            f.message
        );
        assert_eq!(
            unsafe { params_from_c(std::ptr::null()) }.unwrap(),
            balloon::BalloonParams::default()
        );
        assert_eq!(
            unsafe { balloon_params_default(std::ptr::null_mut()) },
            BalloonStatus::BALLOON_NULL_POINTER
        );
    }
}
