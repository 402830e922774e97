//! The parameter table for C (`balloon::params::PARAMETERS`): how many parameters there are,
//! each one's name, kind, default, range and documentation, and a `BalloonParams` read and
//! written by name, so that a binding builds its setters from the library instead of a copy.

use std::ffi::{c_char, CStr, CString};
use std::mem::size_of;
use std::ops::Bound;
use std::sync::OnceLock;

use super::boundary::{require, run, run_infallible, Failure};
use super::params::{check_struct_size, BalloonParams};
use super::status::BalloonStatus;
use crate::balloon::params::{parameter, ParamKind, Parameter, PARAMETERS};
use crate::error::Error;

/// The kind of a parameter's value.
#[repr(C)]
#[allow(non_camel_case_types)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BalloonParamKind {
    /// A real number (a `double` field).
    BALLOON_PARAM_REAL = 0,
    /// A whole number (an unsigned integer field).
    BALLOON_PARAM_INTEGER = 1,
}

/// One parameter, as `balloon_param_info` describes it. The strings are static and
/// NUL-terminated; never free them.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct BalloonParamInfo {
    /// The caller sets it to sizeof(BalloonParamInfo) before calling balloon_param_info.
    pub struct_size: usize,
    /// Its field in BalloonParams, and its name for balloon_params_get/balloon_params_set.
    pub name: *const c_char,
    /// The command line's flag, without the leading "--".
    pub flag: *const c_char,
    pub kind: BalloonParamKind,
    /// 1 when it may be left unset (NaN), meaning what `unset` says.
    pub optional: u8,
    /// The default; NaN when it is unset by default.
    pub default_value: f64,
    /// The smallest value allowed (-INFINITY when there is none); itself allowed when
    /// `minimum_inclusive` is 1.
    pub minimum: f64,
    pub minimum_inclusive: u8,
    /// The largest value allowed (INFINITY when there is none); itself allowed when
    /// `maximum_inclusive` is 1.
    pub maximum: f64,
    pub maximum_inclusive: u8,
    /// What is used when it is unset; "" when it cannot be.
    pub unset: *const c_char,
    /// What it does.
    pub doc: *const c_char,
    /// The values it takes, in words (as in the error for a value outside them).
    pub allowed: *const c_char,
}

/// The table's strings, NUL-terminated once for the life of the process.
struct Strings {
    name: CString,
    flag: CString,
    unset: CString,
    doc: CString,
    allowed: CString,
}

fn strings() -> &'static [Strings] {
    static STRINGS: OnceLock<Vec<Strings>> = OnceLock::new();
    STRINGS.get_or_init(|| {
        // The table's texts are ours and hold no NUL (a test checks); an empty string is the
        // fallback that cannot happen.
        let c = |s: &str| CString::new(s).unwrap_or_default();
        PARAMETERS
            .iter()
            .map(|p| Strings {
                name: c(p.name),
                flag: c(p.flag),
                unset: c(p.unset.unwrap_or("")),
                doc: c(p.doc),
                allowed: c(&p.allowed()),
            })
            .collect()
    })
}

fn bound(bound: Bound<f64>, unbounded: f64) -> (f64, u8) {
    match bound {
        Bound::Included(v) => (v, 1),
        Bound::Excluded(v) => (v, 0),
        Bound::Unbounded => (unbounded, 0),
    }
}

fn info(p: &Parameter, s: &Strings) -> BalloonParamInfo {
    let (minimum, minimum_inclusive) = bound(p.min, f64::NEG_INFINITY);
    let (maximum, maximum_inclusive) = bound(p.max, f64::INFINITY);
    BalloonParamInfo {
        struct_size: size_of::<BalloonParamInfo>(),
        name: s.name.as_ptr(),
        flag: s.flag.as_ptr(),
        kind: match p.kind {
            ParamKind::Real => BalloonParamKind::BALLOON_PARAM_REAL,
            ParamKind::Integer => BalloonParamKind::BALLOON_PARAM_INTEGER,
        },
        optional: p.unset.is_some().into(),
        default_value: p.default_value(),
        minimum,
        minimum_inclusive,
        maximum,
        maximum_inclusive,
        unset: s.unset.as_ptr(),
        doc: s.doc.as_ptr(),
        allowed: s.allowed.as_ptr(),
    }
}

/// The number of parameters: the fields of BalloonParams after struct_size.
#[no_mangle]
pub extern "C" fn balloon_param_count() -> usize {
    run_infallible(0, || PARAMETERS.len())
}

/// Describes parameter `index` (0 to balloon_param_count() - 1, in the order of
/// BalloonParams' fields) in `out`. The caller sets `out->struct_size` to
/// sizeof(BalloonParamInfo).
///
/// # Safety
/// `out` must be NULL or point to a writable `BalloonParamInfo`.
#[no_mangle]
pub unsafe extern "C" fn balloon_param_info(
    index: usize,
    out: *mut BalloonParamInfo,
) -> BalloonStatus {
    run(|| {
        require(out, "out")?;
        // SAFETY: non-NULL; only the leading size is read.
        unsafe { check_struct_size(out, "BalloonParamInfo")? };
        let (p, s) = PARAMETERS.iter().zip(strings()).nth(index).ok_or_else(|| {
            Error::invalid_argument(format!(
                "parameter index {index} is out of range; there are {} parameters \
                     (balloon_param_count)",
                PARAMETERS.len()
            ))
        })?;
        // SAFETY: non-NULL, and the caller's struct has this library's size.
        unsafe { out.write_unaligned(info(p, s)) };
        Ok(())
    })
}

/// The parameter named by the C string `name`.
///
/// # Safety
/// `name` is NULL or a NUL-terminated string.
unsafe fn named(name: *const c_char) -> Result<&'static Parameter, Failure> {
    require(name, "name")?;
    // SAFETY: non-NULL and NUL-terminated by the caller's promise.
    let text = unsafe { CStr::from_ptr(name) }.to_str().map_err(|_| {
        Error::invalid_argument("the parameter name is not UTF-8; give a field of BalloonParams")
    })?;
    Ok(parameter(text)?)
}

/// Reads the parameter called `name` (a field of BalloonParams) from `params` into `value`;
/// NaN when it is unset. Whole numbers come back exactly up to 2^53.
///
/// # Safety
/// `params` must be NULL or point to a readable `BalloonParams`, `name` NULL or a
/// NUL-terminated string, `value` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn balloon_params_get(
    params: *const BalloonParams,
    name: *const c_char,
    value: *mut f64,
) -> BalloonStatus {
    run(|| {
        require(params, "params")?;
        require(value, "value")?;
        // SAFETY: the caller's promises, as documented.
        let p = unsafe { named(name)? };
        unsafe { check_struct_size(params, "BalloonParams")? };
        // SAFETY: non-NULL, of this library's size.
        let rust = unsafe { params.read_unaligned() }.to_rust()?;
        // SAFETY: non-NULL and writable by the caller's promise.
        unsafe { value.write(p.get(&rust)) };
        Ok(())
    })
}

/// Sets the parameter called `name` in `params` to `value` (NaN unsets an optional one),
/// after checking it against the parameter's kind and range; the other fields are left as
/// they are. A value outside the range is BALLOON_INVALID_ARGUMENT, with a message that says
/// what to give, and leaves `params` unchanged.
///
/// # Safety
/// `params` must be NULL or point to a writable `BalloonParams`, `name` NULL or a
/// NUL-terminated string.
#[no_mangle]
pub unsafe extern "C" fn balloon_params_set(
    params: *mut BalloonParams,
    name: *const c_char,
    value: f64,
) -> BalloonStatus {
    run(|| {
        require(params, "params")?;
        // SAFETY: the caller's promises, as documented.
        let p = unsafe { named(name)? };
        unsafe { check_struct_size(params, "BalloonParams")? };
        // SAFETY: non-NULL, of this library's size, writable.
        let c = unsafe { params.read_unaligned() };
        let mut rust = c.to_rust()?;
        p.set(&mut rust, value)?;
        unsafe { params.write_unaligned(BalloonParams::from(&rust)) };
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::balloon;
    use std::ptr::null_mut;

    fn text(p: *const c_char) -> &'static str {
        unsafe { CStr::from_ptr(p) }.to_str().unwrap()
    }

    fn described(index: usize) -> Result<BalloonParamInfo, BalloonStatus> {
        let mut out = BalloonParamInfo {
            struct_size: size_of::<BalloonParamInfo>(),
            ..info(&PARAMETERS[0], &strings()[0])
        };
        match unsafe { balloon_param_info(index, &mut out) } {
            BalloonStatus::BALLOON_OK => Ok(out),
            status => Err(status),
        }
    }

    #[test]
    fn every_parameter_is_described_as_the_table_says() {
        assert_eq!(balloon_param_count(), PARAMETERS.len());
        for (i, p) in PARAMETERS.iter().enumerate() {
            let d = described(i).unwrap();
            assert_eq!(text(d.name), p.name);
            assert_eq!(text(d.flag), p.flag);
            assert_eq!(text(d.doc), p.doc);
            assert_eq!(text(d.allowed), p.allowed());
            assert_eq!(d.optional == 1, p.unset.is_some());
            assert_eq!(text(d.unset), p.unset.unwrap_or(""));
            assert!(d.minimum <= d.maximum, "{}", p.name);
            let default = p.default_value();
            assert!(default.is_nan() && d.default_value.is_nan() || default == d.default_value);
        }
        let step = described(6).unwrap();
        assert_eq!(text(step.name), "step_fraction");
        assert_eq!((step.minimum, step.minimum_inclusive), (0.0, 0));
        assert_eq!((step.maximum, step.maximum_inclusive), (1.0, 1));
        assert_eq!(step.kind, BalloonParamKind::BALLOON_PARAM_REAL);
        assert_eq!(
            described(PARAMETERS.len()).unwrap_err(),
            BalloonStatus::BALLOON_INVALID_ARGUMENT
        );
        assert_eq!(
            unsafe { balloon_param_info(0, null_mut()) },
            BalloonStatus::BALLOON_NULL_POINTER
        );
    }

    #[test]
    fn set_checks_the_range_and_get_reads_it_back() {
        let mut c = BalloonParams::from(&balloon::BalloonParams::default());
        let set = |c: &mut BalloonParams, name: &CStr, v: f64| unsafe {
            balloon_params_set(c, name.as_ptr(), v)
        };
        assert_eq!(
            set(&mut c, c"max_iterations", 7.0),
            BalloonStatus::BALLOON_OK
        );
        assert_eq!(c.max_iterations, 7);
        assert_eq!(set(&mut c, c"tolerance", 40.0), BalloonStatus::BALLOON_OK);
        assert_eq!(c.tolerance, 40.0);
        let before = c;
        assert_eq!(
            set(&mut c, c"max_iterations", 2.5),
            BalloonStatus::BALLOON_INVALID_ARGUMENT
        );
        assert_eq!(
            set(&mut c, c"no_such_thing", 1.0),
            BalloonStatus::BALLOON_INVALID_ARGUMENT
        );
        // Debug text, as the unset fields are NaN and unequal to themselves.
        assert_eq!(
            format!("{c:?}"),
            format!("{before:?}"),
            "a refused value leaves the struct as it was"
        );
        let mut value = 0.0;
        let status = unsafe { balloon_params_get(&c, c"max_iterations".as_ptr(), &mut value) };
        assert_eq!((status, value), (BalloonStatus::BALLOON_OK, 7.0));
        let status = unsafe { balloon_params_get(&c, c"reference_intensity".as_ptr(), &mut value) };
        assert!(status == BalloonStatus::BALLOON_OK && value.is_nan());
        assert_eq!(
            unsafe { balloon_params_get(&c, std::ptr::null(), &mut value) },
            BalloonStatus::BALLOON_NULL_POINTER
        );
    }
}
