//! Files from `tests/regressions/` that once broke the product (issue 19), each pinned down by
//! a test named after what broke. They are small: the torus phantom written as NIfTI-1 by
//! SimpleITK with a few header bytes changed (see `../shared/regressions/README.md`).

#![cfg(feature = "io")]

use std::path::PathBuf;

use balloonseg::balloon::{BalloonParams, Segmenter};
use balloonseg::{io, mesh_checks};
use glam::DVec3;

fn regression(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/regressions")
        .join(name)
}

/// Reads `name`, checks the geometry SimpleITK 2.x gives for it, and segments it from voxel
/// (20, 20, 10) for three steps as `segment --max-iterations 3` did when it broke.
fn reads_as_itk_and_segments(name: &str, origin: [f64; 3], direction: [f64; 9]) {
    let image = io::read_image(&regression(name)).unwrap();
    let geometry = image.geometry();
    assert_eq!(image.dims(), [45, 45, 21]);
    assert_eq!(geometry.spacing(), [1.0; 3], "pixdim's spacing, as ITK");
    for (ours, itk) in geometry.origin().iter().zip(origin) {
        assert!((ours - itk).abs() < 1e-4, "{:?}", geometry.origin());
    }
    for (ours, itk) in geometry.direction().iter().zip(direction) {
        assert!((ours - itk).abs() < 1e-6, "{:?}", geometry.direction());
    }
    let params = BalloonParams {
        max_iterations: 3,
        ..BalloonParams::default()
    };
    let seed = geometry.index_to_world(DVec3::new(20.0, 20.0, 10.0));
    let mut segmenter = Segmenter::new(image.view(), params, seed).unwrap();
    let (mesh, _) = segmenter.segment().unwrap();
    assert!(mesh_checks::check(&mesh).is_valid_closed_surface());
}

#[test]
fn an_sform_scale_of_1e_minus_9_is_not_a_4_gib_grid() {
    // The sform's third column was 9.3e-10 mm long, pixdim 1: the balloon's grids of the
    // smallest spacing asked for 4 GiB and the process aborted.
    let identity = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    reads_as_itk_and_segments(
        "nifti-sform-4gib-allocation.nii.gz",
        [-22.0, -22.0, -10.0],
        identity,
    );
}

#[test]
fn an_sform_scale_of_2e_minus_4_is_not_a_hang() {
    // The sform's first column was 2.4e-4 mm long, pixdim 1: segment ran for minutes. ITK
    // keeps the column's direction, flipped in LPS.
    let flipped_x = [-1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    reads_as_itk_and_segments(
        "nifti-sform-scales-hang.nii.gz",
        [-22.000_108_718_872_07, -22.0, -10.0],
        flipped_x,
    );
}

/// Reads the DICOM series in the folder `name` and expects an error that says `expected`.
fn assert_refused(name: &str, expected: &str) {
    let message = io::read_image(&regression(name)).unwrap_err().to_string();
    assert!(message.contains(expected), "{message}");
}

#[test]
fn regression_dicom_rs_allocated_a_slices_declared_length_before_reading_it() {
    // Found by the `dicom` fuzz target: an 836-byte slice whose SliceThickness declares
    // 2,863,311,530 bytes. dicom-rs 0.9 allocated them before finding the file short, an abort
    // where the allocation fails (libFuzzer's 2 GiB limit, `ulimit -v`). The declared lengths are
    // now checked against the file first, and the error names the element.
    assert_refused(
        "dicom-declared-length-2863311530",
        "slice.dcm: element (0018,0050) declares 2863311530 bytes but only",
    );
}

#[test]
fn regression_a_stray_element_in_the_dicom_meta_group_hid_a_declared_length_from_the_check() {
    // Found by CI's 15 s of the `dicom` target: the meta group holds an element of group 7FFF.
    // dicom-rs reads the meta group by its group length; the check took that element for the
    // data set's start, found no transfer syntax and checked nothing, and dicom-rs then
    // allocated the 3,184,309,496 bytes that (0028,9A7D) declares.
    assert_refused(
        "dicom-meta-group-stray-element",
        "slice.dcm: element (0028,9A7D) declares 3184309496 bytes but only",
    );
}

#[test]
fn regression_a_two_byte_ul_put_dicom_rs_out_of_step_with_the_file() {
    // Found by the `dicom` target: PixelRepresentation as a UL of 2 bytes. dicom-rs reads only
    // whole 4-byte numbers, took the 2 bytes left over for the next header and allocated the
    // 4,294,901,760 bytes that header declared.
    assert_refused(
        "dicom-ul-of-two-bytes",
        "slice.dcm: element (0028,0103) (UL) declares 2 bytes, not a whole",
    );
}

#[test]
fn regression_dicom_rs_allocated_the_segment_table_an_rle_header_declared() {
    // Found by the `dicom` target: an RLE fragment whose header declares 822,083,586 segments
    // where 16-bit pixels take two. dicom-rs 0.9's RLE decoder allocated a 3.3 GB table of
    // segment offsets before it looked at them. RLE and JPEG headers are now checked against
    // Rows, Columns and BitsAllocated before a codec sees them.
    assert_refused(
        "dicom-rle-822083586-segments",
        "slice.dcm: its RLE header declares 822083586 segments where 16-bit",
    );
}

#[test]
fn regression_a_transfer_syntax_uid_under_another_vr_hid_a_declared_length_from_the_check() {
    // Found by the `dicom` target: (0002,0010) with the VR SS. dicom-rs reads the transfer
    // syntax's bytes as text whatever the VR (RLE lossless here); the check read numbers, knew
    // no syntax and checked nothing, and dicom-rs allocated the 2,896,403,089 bytes that
    // (0008,0000) declares. The check now reads the UID as dicom-rs does.
    assert_refused(
        "dicom-transfer-syntax-uid-as-ss",
        "slice.dcm: element (0008,0000) declares 2896403089 bytes but only",
    );
}

#[test]
fn regression_a_meta_group_length_under_another_vr_hid_a_declared_length_from_the_check() {
    // Found by the `dicom` target: (0002,0000) with the VR FD. dicom-rs reads its 4 bytes as a
    // u32 whatever the VR; the check read no number, checked nothing, and dicom-rs allocated
    // the 2,147,811,328 bytes a later header declared.
    assert_refused(
        "dicom-meta-group-length-as-fd",
        "slice.dcm: element (0000,0000) declares 2147811328 bytes but only",
    );
}

#[test]
fn regression_a_transfer_syntax_uid_ending_in_latin_1_whitespace_hid_a_declared_length() {
    // Found by the `dicom` target: the UID "1.2.840.10008.1.2" followed by the byte 0x85.
    // dicom-rs decodes it as ISO 8859-1, where 0x85 is NEL, a whitespace it trims, and reads
    // implicit VR little endian; the check decoded UTF-8, knew no such syntax and checked
    // nothing, and dicom-rs allocated the 4,143,979,008 bytes an element declared.
    assert_refused(
        "dicom-transfer-syntax-uid-latin-1-whitespace",
        "slice.dcm: element (0820,1600) declares 4143979008 bytes but only",
    );
}

#[test]
fn regression_rle_pixel_data_as_a_plain_value_reached_the_decoder_unchecked() {
    // Found by the `dicom` target: an RLE slice whose pixel data is a plain OF value of 60
    // bytes, not encapsulated fragments. dicom-rs's RLE decoder takes a plain value for one
    // fragment and allocated the 9,182,773,252 bytes of segment offsets its first word
    // declared; the fragment check only looked at encapsulated data.
    assert_refused(
        "dicom-rle-pixel-data-not-encapsulated",
        "slice.dcm: its pixel data is a plain value where its compressed transfer syntax needs",
    );
}
