//! The status codes every fallible C function returns, their static descriptions, and the
//! one-to-one mapping from the library's [`ErrorKind`].

use std::ffi::{c_char, c_int, CStr};

use super::boundary::run_infallible;
use crate::error::ErrorKind;

/// The result of every fallible function. The values are stable and never reused: new ones
/// are added at the end.
#[repr(C)]
#[allow(non_camel_case_types)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BalloonStatus {
    /// Success; the outputs were written.
    BALLOON_OK = 0,
    /// A required pointer argument was NULL.
    BALLOON_NULL_POINTER = 1,
    /// A parameter, seed or argument is out of range.
    BALLOON_INVALID_ARGUMENT = 2,
    /// Dims, strides, spacing, direction or scalar type of a volume are unusable.
    BALLOON_INVALID_VOLUME = 3,
    /// A mesh given to a kernel is malformed (index out of range, non-finite point), or unfit
    /// for it (balloon_simplify: empty, open, non-manifold, inconsistently oriented or
    /// self-intersecting).
    BALLOON_INVALID_MESH = 4,
    /// A struct's `struct_size` differs from its size in this library (a caller compiled
    /// against another version of the header).
    BALLOON_PARAMS_SIZE_MISMATCH = 5,
    /// A caller buffer is too small; the size needed was reported.
    BALLOON_BUFFER_TOO_SMALL = 6,
    /// The progress callback returned non-zero.
    BALLOON_CANCELLED = 7,
    /// The balloon exceeded max_vertices: it most likely leaked out of the structure.
    BALLOON_LEAK = 8,
    /// A result failed the library's own guarantees (a bug: please report it).
    BALLOON_INTERNAL_ERROR = 9,
    /// A Rust panic was caught at the boundary (a bug: please report it). Only
    /// `balloon_free` is safe on a handle afterwards.
    BALLOON_PANIC = 10,
    /// A buffer the volume, the mesh or the parameters call for could not be allocated. A
    /// handle keeps the state of its last completed step and stays usable.
    BALLOON_OUT_OF_MEMORY = 11,
}

impl BalloonStatus {
    const ALL: [BalloonStatus; 12] = [
        BalloonStatus::BALLOON_OK,
        BalloonStatus::BALLOON_NULL_POINTER,
        BalloonStatus::BALLOON_INVALID_ARGUMENT,
        BalloonStatus::BALLOON_INVALID_VOLUME,
        BalloonStatus::BALLOON_INVALID_MESH,
        BalloonStatus::BALLOON_PARAMS_SIZE_MISMATCH,
        BalloonStatus::BALLOON_BUFFER_TOO_SMALL,
        BalloonStatus::BALLOON_CANCELLED,
        BalloonStatus::BALLOON_LEAK,
        BalloonStatus::BALLOON_INTERNAL_ERROR,
        BalloonStatus::BALLOON_PANIC,
        BalloonStatus::BALLOON_OUT_OF_MEMORY,
    ];

    /// The status of an error of the safe API. No C function reads or writes files, so an
    /// I/O or format error reaching the boundary would be a bug.
    pub fn from_kind(kind: ErrorKind) -> Self {
        match kind {
            ErrorKind::InvalidArgument => BalloonStatus::BALLOON_INVALID_ARGUMENT,
            ErrorKind::InvalidVolume => BalloonStatus::BALLOON_INVALID_VOLUME,
            ErrorKind::InvalidMesh => BalloonStatus::BALLOON_INVALID_MESH,
            ErrorKind::Cancelled => BalloonStatus::BALLOON_CANCELLED,
            ErrorKind::Leak => BalloonStatus::BALLOON_LEAK,
            ErrorKind::OutOfMemory => BalloonStatus::BALLOON_OUT_OF_MEMORY,
            ErrorKind::Io | ErrorKind::Format | ErrorKind::Internal => {
                BalloonStatus::BALLOON_INTERNAL_ERROR
            }
        }
    }

    pub fn description(self) -> &'static CStr {
        match self {
            BalloonStatus::BALLOON_OK => c"success",
            BalloonStatus::BALLOON_NULL_POINTER => c"a required pointer argument was NULL",
            BalloonStatus::BALLOON_INVALID_ARGUMENT => c"an argument is out of range",
            BalloonStatus::BALLOON_INVALID_VOLUME => {
                c"the volume's dims, strides, spacing, direction or scalar type are unusable"
            }
            BalloonStatus::BALLOON_INVALID_MESH => c"the mesh is malformed",
            BalloonStatus::BALLOON_PARAMS_SIZE_MISMATCH => {
                c"struct_size differs from the struct's size in this library (header and library versions differ)"
            }
            BalloonStatus::BALLOON_BUFFER_TOO_SMALL => c"the caller's buffer is too small",
            BalloonStatus::BALLOON_CANCELLED => c"cancelled by the progress callback",
            BalloonStatus::BALLOON_LEAK => {
                c"the balloon exceeded max_vertices: it has most likely leaked out of the structure"
            }
            BalloonStatus::BALLOON_INTERNAL_ERROR => {
                c"internal error: a result failed the library's own checks (please report it)"
            }
            BalloonStatus::BALLOON_PANIC => {
                c"internal error: a panic was caught at the C boundary (please report it)"
            }
            BalloonStatus::BALLOON_OUT_OF_MEMORY => {
                c"out of memory: a buffer the input or the parameters call for could not be allocated"
            }
        }
    }

    /// The status with this C value, if there is one.
    pub fn from_c(value: c_int) -> Option<Self> {
        Self::ALL.into_iter().find(|&s| s as c_int == value)
    }
}

/// A static, NUL-terminated description of a status; never NULL. The status is taken as an
/// int so that any value, even one this version does not know, is safe to pass: unknown
/// values give "unknown status".
#[no_mangle]
pub extern "C" fn balloon_status_string(status: c_int) -> *const c_char {
    let unknown = c"unknown status";
    run_infallible(unknown.as_ptr(), || {
        BalloonStatus::from_c(status)
            .map_or(unknown, BalloonStatus::description)
            .as_ptr()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_status_has_its_own_description_and_value() {
        for (i, s) in BalloonStatus::ALL.into_iter().enumerate() {
            assert_eq!(s as usize, i);
            assert_eq!(BalloonStatus::from_c(i as c_int), Some(s));
            assert!(!s.description().is_empty());
        }
        let distinct: std::collections::HashSet<_> =
            BalloonStatus::ALL.map(|s| s.description()).into();
        assert_eq!(distinct.len(), BalloonStatus::ALL.len());
        for unknown in [-1, 12, c_int::MAX] {
            let text = unsafe { CStr::from_ptr(balloon_status_string(unknown)) };
            assert_eq!(text, c"unknown status");
        }
    }

    #[test]
    fn error_kinds_map_onto_their_statuses() {
        use BalloonStatus::*;
        for (kind, status) in [
            (ErrorKind::InvalidArgument, BALLOON_INVALID_ARGUMENT),
            (ErrorKind::InvalidVolume, BALLOON_INVALID_VOLUME),
            (ErrorKind::InvalidMesh, BALLOON_INVALID_MESH),
            (ErrorKind::Cancelled, BALLOON_CANCELLED),
            (ErrorKind::Leak, BALLOON_LEAK),
            (ErrorKind::OutOfMemory, BALLOON_OUT_OF_MEMORY),
            (ErrorKind::Internal, BALLOON_INTERNAL_ERROR),
            (ErrorKind::Io, BALLOON_INTERNAL_ERROR),
            (ErrorKind::Format, BALLOON_INTERNAL_ERROR),
        ] {
            assert_eq!(BalloonStatus::from_kind(kind), status);
        }
    }
}
