//! Test fixtures shared by the image format tests: an oblique, anisotropic, left-handed geometry,
//! images of pseudo-random bits of every scalar type, exact and approximate comparisons, and the
//! truncation / byte-flip loop that every reader must survive without panicking.

use std::panic::{catch_unwind, AssertUnwindSafe};

use crate::error::Result;
use crate::geometry::Geometry;
use crate::volume::{Image, ScalarType, VoxelBuffer};

/// A rotation by 0.7 rad about the axis (1, 2, 3), its k axis flipped (left-handed), with
/// anisotropic spacing and an origin that is not round in binary.
pub(crate) fn oblique_geometry() -> Geometry {
    let n = glam::DVec3::new(1.0, 2.0, 3.0).normalize();
    let r = glam::DMat3::from_axis_angle(n, 0.7);
    let d = glam::DMat3::from_cols(r.x_axis, r.y_axis, -r.z_axis);
    Geometry::new(
        [0.7, 1.3, 2.1],
        [-156.445, 24.6094, 0.1],
        d.transpose().to_cols_array(),
    )
    .expect("a valid geometry")
}

/// An image whose voxels are pseudo-random bits (floats include NaNs, infinities, subnormals).
pub(crate) fn pattern_image(
    scalar: ScalarType,
    dims: [usize; 3],
    geometry: Geometry,
    seed: u64,
) -> Image {
    let count = dims.iter().product::<usize>() * scalar.size_in_bytes();
    let mut state = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ 0x2545_f491_4f6c_dd1d;
    let bytes: Vec<u8> = (0..count)
        .map(|_| {
            // xorshift64*
            state ^= state >> 12;
            state ^= state << 25;
            state ^= state >> 27;
            (state.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 56) as u8
        })
        .collect();
    let buffer = VoxelBuffer::from_bytes(scalar, &bytes, true).expect("whole voxels");
    Image::new(buffer, dims, geometry).expect("matching dims")
}

/// Same dims, type and bit patterns (so NaNs compare equal).
pub(crate) fn assert_same_voxels(actual: &Image, expected: &Image) {
    assert_eq!(actual.dims(), expected.dims());
    assert_eq!(actual.scalar_type(), expected.scalar_type());
    assert!(
        actual.buffer().to_le_bytes() == expected.buffer().to_le_bytes(),
        "the voxels differ ({:?})",
        expected.scalar_type()
    );
}

pub(crate) fn assert_geometry_close(actual: &Geometry, expected: &Geometry, tolerance: f64) {
    let pairs = [
        (actual.spacing().to_vec(), expected.spacing().to_vec()),
        (actual.origin().to_vec(), expected.origin().to_vec()),
        (actual.direction().to_vec(), expected.direction().to_vec()),
    ];
    for (a, e) in pairs {
        for (x, y) in a.iter().zip(&e) {
            assert!(
                (x - y).abs() <= tolerance * y.abs().max(1.0),
                "{actual:?}\n!=\n{expected:?}"
            );
        }
    }
}

pub(crate) fn scratch_dir() -> tempfile::TempDir {
    tempfile::tempdir().expect("a temporary folder")
}

/// Every truncation of `file` and every byte flipped by a few masks either decodes or errors,
/// without panicking; a truncated file that still decodes must give the original voxels.
pub(crate) fn assert_never_panics(
    file: &[u8],
    original: &Image,
    decode: impl Fn(&[u8]) -> Result<Image>,
) {
    let run = |bytes: &[u8], what: &str| match catch_unwind(AssertUnwindSafe(|| decode(bytes))) {
        Err(_) => panic!("the reader panicked on the file {what}"),
        Ok(result) => result,
    };
    assert_same_voxels(
        &run(file, "as written").expect("the intact file reads"),
        original,
    );
    for n in 0..file.len() {
        if let Ok(image) = run(&file[..n], &format!("truncated to {n} bytes")) {
            assert_same_voxels(&image, original);
        }
    }
    for position in 0..file.len() {
        for mask in [0x01u8, 0x0f, 0x20, 0x80, 0xff] {
            let mut flipped = file.to_vec();
            flipped[position] ^= mask;
            // Any outcome but a panic is fine: a flip may well give another valid file.
            let _ = run(&flipped, &format!("with byte {position} xor {mask:#04x}"));
        }
    }
}
