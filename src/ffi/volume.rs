//! `BalloonVolume`, the caller's voxels as C describes them, turned into a borrowed
//! [`Volume`] after checking everything that could make the view unsound: NULL data, an
//! unknown scalar type, zero or overflowing dims, strides whose extent overflows or wraps the
//! address space, misaligned data, and (through [`Geometry::new`]) spacing and direction.

use std::ffi::c_void;
use std::mem::{align_of, size_of};

use super::boundary::{require, Failure};
use crate::error::Error;
use crate::geometry::Geometry;
use crate::volume::{Scalar, ScalarType, TypedVolume, Volume};

/// The voxel types, as carried in `BalloonVolume::scalar_type`.
#[repr(C)]
#[allow(non_camel_case_types)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BalloonScalarType {
    BALLOON_SCALAR_U8 = 0,
    BALLOON_SCALAR_I8 = 1,
    BALLOON_SCALAR_U16 = 2,
    BALLOON_SCALAR_I16 = 3,
    BALLOON_SCALAR_U32 = 4,
    BALLOON_SCALAR_I32 = 5,
    BALLOON_SCALAR_F32 = 6,
    BALLOON_SCALAR_F64 = 7,
}

/// A borrowed, strided 3-D array of voxels with its geometry. Nothing is copied: the voxels
/// must stay valid (and unchanged) for as long as the library uses them — until
/// `balloon_free` for a segmenter, until the call returns for a kernel.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct BalloonVolume {
    /// Element (0, 0, 0). Strides may be negative: offsets are counted from here.
    pub data: *const c_void,
    /// A `BalloonScalarType` value (a plain integer so that a wrong value is an error, not UB).
    pub scalar_type: u32,
    /// Samples along i, j, k; i is the fastest axis of the index, not necessarily of memory.
    pub dims: [usize; 3],
    /// Distance in ELEMENTS (not bytes) between neighbours along i, j, k.
    pub strides: [isize; 3],
    /// Voxel size in mm, each > 0. Segmentation refuses voxels more than 100 times longer
    /// along one axis than another (BALLOON_INVALID_VOLUME): the balloon's grids have the
    /// shortest spacing, and would have no useful bound.
    pub spacing: [f64; 3],
    /// World position (mm) of voxel (0, 0, 0).
    pub origin: [f64; 3],
    /// Row-major 3x3; its columns are the world directions of the i, j, k axes (ITK/VTK).
    pub direction: [f64; 9],
}

pub(crate) fn scalar_type_from_c(value: u32) -> Result<ScalarType, Failure> {
    ScalarType::ALL.get(value as usize).copied().ok_or_else(|| {
        Error::invalid_volume(format!(
            "scalar_type is {value}; use a BalloonScalarType value from 0 (BALLOON_SCALAR_U8) to \
             7 (BALLOON_SCALAR_F64)"
        ))
        .into()
    })
}

/// Checks that the elements `Σ idx·stride` a `dims` grid addresses around `address` (the byte
/// address of element (0, 0, 0)) fit the address space without wrapping.
pub(crate) fn check_addresses(
    dims: [usize; 3],
    strides: [isize; 3],
    element_size: usize,
    address: usize,
) -> Result<(), Error> {
    if let Some(axis) = dims.iter().position(|&d| d == 0) {
        return Err(Error::invalid_volume(format!(
            "dims[{axis}] is 0 (dims {dims:?}); a volume needs at least one voxel along every axis"
        )));
    }
    let bytes = dims
        .iter()
        .try_fold(element_size, |acc, &d| acc.checked_mul(d))
        .filter(|&b| b <= isize::MAX as usize);
    if bytes.is_none() {
        return Err(Error::invalid_volume(format!(
            "dims {dims:?} of {element_size}-byte voxels overflow the address space; check the dims"
        )));
    }
    // In i128 no product of a usize and an isize can overflow.
    let (mut lowest, mut highest) = (0i128, 0i128);
    for a in 0..3 {
        let extent = (dims[a] as i128 - 1) * strides[a] as i128;
        if extent < 0 {
            lowest += extent;
        } else {
            highest += extent;
        }
    }
    let size = element_size as i128;
    let total = (highest - lowest + 1) * size;
    let (start, end) = (
        address as i128 + lowest * size,
        address as i128 + (highest + 1) * size,
    );
    if total > isize::MAX as i128 || start < 0 || end > usize::MAX as i128 {
        return Err(Error::invalid_volume(format!(
            "dims {dims:?} with strides {strides:?} (elements) address elements {lowest}..={highest} \
             around data, which does not fit in memory; check the strides' units (elements, not \
             bytes) and their order (i, j, k)"
        )));
    }
    Ok(())
}

/// The volume `volume` describes, borrowing its voxels.
///
/// # Safety
/// `volume` must be NULL or point to a readable `BalloonVolume` whose `data` points to voxels
/// covering every address the dims and strides describe, valid and unchanged for `'v`.
pub(crate) unsafe fn volume_from_c<'v>(
    volume: *const BalloonVolume,
) -> Result<Volume<'v>, Failure> {
    // SAFETY: NULL or readable, by the caller's promise.
    let v = unsafe { volume.as_ref() }.ok_or_else(|| Failure::null("volume"))?;
    require(v.data, "volume->data")?;
    let scalar_type = scalar_type_from_c(v.scalar_type)?;
    let geometry = Geometry::new(v.spacing, v.origin, v.direction)?;
    // SAFETY: forwarded from the caller.
    unsafe {
        match scalar_type {
            ScalarType::U8 => typed::<u8>(v, geometry),
            ScalarType::I8 => typed::<i8>(v, geometry),
            ScalarType::U16 => typed::<u16>(v, geometry),
            ScalarType::I16 => typed::<i16>(v, geometry),
            ScalarType::U32 => typed::<u32>(v, geometry),
            ScalarType::I32 => typed::<i32>(v, geometry),
            ScalarType::F32 => typed::<f32>(v, geometry),
            ScalarType::F64 => typed::<f64>(v, geometry),
        }
    }
}

/// # Safety
/// As [`volume_from_c`], with `T` the type `v.scalar_type` names.
unsafe fn typed<'v, T: Scalar>(v: &BalloonVolume, geometry: Geometry) -> Result<Volume<'v>, Failure>
where
    Volume<'v>: From<TypedVolume<'v, T>>,
{
    let address = v.data as usize;
    check_addresses(v.dims, v.strides, size_of::<T>(), address)?;
    if address % align_of::<T>() != 0 {
        return Err(Error::invalid_volume(format!(
            "data ({:p}) is not aligned for {} voxels ({} bytes); pass an aligned buffer",
            v.data,
            T::TYPE.name(),
            align_of::<T>()
        ))
        .into());
    }
    // SAFETY: `check_addresses` checked what `address_range` checks (a voxel on every axis, extents that do
    // not overflow) and that the addressed elements fit in the address space without wrapping;
    // the caller promises they are its voxels, alive and unchanged for 'v. No slice spans the
    // buffer: the elements between the addressed ones (a stepped view) may be written by others.
    let view =
        unsafe { TypedVolume::from_raw_parts(v.data.cast::<T>(), v.dims, v.strides, geometry) };
    Ok(view.into())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ffi::status::BalloonStatus;

    const IDENTITY: [f64; 9] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];

    fn described(
        data: *const c_void,
        scalar_type: u32,
        dims: [usize; 3],
        strides: [isize; 3],
    ) -> BalloonVolume {
        BalloonVolume {
            data,
            scalar_type,
            dims,
            strides,
            spacing: [1.0, 2.0, 3.0],
            origin: [0.0; 3],
            direction: IDENTITY,
        }
    }

    fn failure(v: &BalloonVolume) -> Failure {
        unsafe { volume_from_c(v) }.unwrap_err()
    }

    #[test]
    fn c_and_fortran_and_flipped_views_read_the_same_voxels() {
        let dims = [4usize, 3, 2];
        // C order of numpy's [k][j][i] is i fastest; Fortran order of [i][j][k] is the same
        // memory; a view flipped along j starts at the last row and steps back.
        let data: Vec<i16> = (0..24).collect();
        let base = described(data.as_ptr().cast(), 3, dims, [1, 4, 12]);
        let flipped_j = BalloonVolume {
            data: data[8..].as_ptr().cast(),
            strides: [1, -4, 12],
            ..base
        };
        let a = unsafe { volume_from_c(&base) }.unwrap();
        let b = unsafe { volume_from_c(&flipped_j) }.unwrap();
        assert_eq!(a.scalar_type(), ScalarType::I16);
        for (i, j, k) in [(0, 0, 0), (3, 2, 1), (1, 1, 0)] {
            assert_eq!(a.get_f64(i, j, k), (i + 4 * j + 12 * k) as f64);
            assert_eq!(b.get_f64(i, 2 - j, k), a.get_f64(i, j, k));
        }
    }

    #[test]
    fn every_scalar_type_is_accepted_and_unknown_ones_are_invalid_volumes() {
        let data = [0f64; 8];
        for t in 0..8 {
            let v =
                unsafe { volume_from_c(&described(data.as_ptr().cast(), t, [2, 2, 2], [1, 2, 4])) };
            assert_eq!(v.unwrap().scalar_type(), ScalarType::ALL[t as usize]);
        }
        let f = failure(&described(data.as_ptr().cast(), 8, [2, 2, 2], [1, 2, 4]));
        assert_eq!(f.status, BalloonStatus::BALLOON_INVALID_VOLUME);
        assert!(f.message.contains("scalar_type is 8"), "{}", f.message);
    }

    #[test]
    fn the_c_scalar_type_values_name_the_same_types() {
        use BalloonScalarType::*;
        let c = [
            BALLOON_SCALAR_U8,
            BALLOON_SCALAR_I8,
            BALLOON_SCALAR_U16,
            BALLOON_SCALAR_I16,
            BALLOON_SCALAR_U32,
            BALLOON_SCALAR_I32,
            BALLOON_SCALAR_F32,
            BALLOON_SCALAR_F64,
        ];
        for (c, rust) in c.into_iter().zip(ScalarType::ALL) {
            assert_eq!(scalar_type_from_c(c as u32).unwrap(), rust);
            assert!(
                format!("{c:?}").ends_with(&format!("{rust:?}")),
                "{c:?} {rust:?}"
            );
        }
    }

    #[test]
    fn bad_volumes_are_named() {
        let data = [0u32; 8];
        let p = data.as_ptr().cast::<c_void>();
        assert_eq!(
            unsafe { volume_from_c(std::ptr::null()) }
                .unwrap_err()
                .status,
            BalloonStatus::BALLOON_NULL_POINTER
        );
        let null_data = failure(&described(std::ptr::null(), 4, [2, 2, 2], [1, 2, 4]));
        assert_eq!(null_data.status, BalloonStatus::BALLOON_NULL_POINTER);
        assert!(null_data.message.contains("volume->data"));
        let cases: [(BalloonVolume, &str); 6] = [
            (described(p, 4, [2, 0, 2], [1, 2, 4]), "dims[1] is 0"),
            (described(p, 4, [usize::MAX, 2, 2], [1, 2, 4]), "overflow"),
            (
                described(p, 4, [2, 2, 2], [1, 2, isize::MAX]),
                "does not fit",
            ),
            (
                described(p, 4, [2, 2, 2], [1, 2, isize::MIN / 4]),
                "does not fit",
            ),
            (
                described(p.wrapping_byte_add(1), 4, [2, 2, 2], [1, 2, 4]),
                "aligned",
            ),
            (
                BalloonVolume {
                    spacing: [1.0, f64::NAN, 1.0],
                    ..described(p, 4, [2, 2, 2], [1, 2, 4])
                },
                "spacing[1]",
            ),
        ];
        for (v, needle) in cases {
            let f = failure(&v);
            assert_eq!(
                f.status,
                BalloonStatus::BALLOON_INVALID_VOLUME,
                "{}",
                f.message
            );
            assert!(f.message.contains(needle), "{needle}: {}", f.message);
        }
        let singular = BalloonVolume {
            direction: [1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0],
            ..described(p, 4, [2, 2, 2], [1, 2, 4])
        };
        assert!(failure(&singular).message.contains("singular"));
    }

    #[test]
    fn addresses_count_negative_strides_backwards_from_data() {
        // Elements -8..=15 around element (0, 0, 0), 2 bytes each: 16 bytes before data, 32
        // from it to the end.
        let check = |address| check_addresses([4, 3, 2], [1, -4, 12], 2, address);
        assert!(check(1 << 20).is_ok());
        assert!(
            check(16).is_ok() && check(15).is_err(),
            "would start below address 0"
        );
        assert!(check(usize::MAX - 32).is_ok());
        assert!(check(usize::MAX - 31).is_err(), "wraps past the top");
    }
}
