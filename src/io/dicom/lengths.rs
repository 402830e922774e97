//! Every value length a DICOM file declares, checked against the bytes that follow it before
//! dicom-rs reads the file: dicom-rs (0.9) allocates a value's declared length before it reads
//! the value, so a file of a few hundred bytes declaring a 2.8 GB element made it allocate
//! 2.8 GB (found by the `dicom` fuzz target; GDCM had the same flaw, CVE-2026-3650). A length
//! no file of this size can hold is refused here, naming the element.
//!
//! The walk reads the data set with dicom-rs's lazy reader, the same state machine as the reader
//! that builds the object, which gives each value's header before its bytes: the value is
//! checked, then skipped. A token it cannot read ends the walk: dicom-rs stops at the same
//! token with its own error, before allocating anything for it. A deflated data set is walked
//! through its inflater, and its lengths are bounded by what DEFLATE can expand the file's
//! remaining bytes to.
//!
//! Where the walk reads the file otherwise than dicom-rs, dicom-rs reads headers the walk never
//! saw; four such places were found by fuzzing and are mirrored here: the meta group is read
//! by its group length whatever groups its elements have, that length is read as a u32 and the
//! transfer syntax UID as ISO 8859-1 text whatever their VRs, and a binary value must be a whole number of its VR's numbers
//! (dicom-rs reads the whole ones and takes the rest for the next header). The sizes inside
//! compressed pixel data are the codecs' to trust, and [`super::fragments`] checks them.

use std::path::Path;

use dicom_core::header::{HasLength, Header};
use dicom_core::{Tag, VR};
use dicom_encoding::text::{DefaultCharacterSetCodec, TextCodec};
use dicom_encoding::transfer_syntax::{Codec, TransferSyntaxIndex};
use dicom_parser::dataset::lazy_read::LazyDataSetReader;
use dicom_parser::dataset::LazyDataToken;
use dicom_parser::stateful::decode::{StatefulDecode, StatefulDecoder};
use dicom_transfer_syntax_registry::TransferSyntaxRegistry;

use crate::error::{Error, Result};

/// DICOM Part 10: the preamble and "DICM" come before the file meta group.
const META_START: u64 = 132;
/// DEFLATE expands at most about 1032:1 (a 258-byte match coded in two bits).
const MAX_DEFLATE_RATIO: u64 = 1032;
/// The file meta group's transfer syntax, whatever the data set's.
const EXPLICIT_VR_LITTLE_ENDIAN: &str = "1.2.840.10008.1.2.1";
const GROUP_LENGTH: Tag = Tag(0x0002, 0x0000);
const TRANSFER_SYNTAX_UID: Tag = Tag(0x0002, 0x0010);
const ITEM: Tag = Tag(0xFFFE, 0xE000);

/// Checks every value length in `file` (the bytes of the DICOM file at `path`) against the bytes
/// that follow it; an error names the first that cannot fit.
pub(super) fn check(path: &Path, file: &[u8]) -> Result<()> {
    let Some(meta) = file.get(META_START as usize..) else {
        return Ok(());
    };
    let explicit = TransferSyntaxRegistry
        .get(EXPLICIT_VR_LITTLE_ENDIAN)
        .ok_or_else(|| Error::internal("dicom-rs lacks explicit VR little endian"))?;
    let Ok(mut meta_decoder) = StatefulDecoder::new_with_ts(meta, explicit, 0) else {
        return Ok(());
    };
    let Some((data_set_start, syntax)) = walk_meta(path, file, &mut meta_decoder)? else {
        return Ok(());
    };
    let syntax = syntax.trim_end_matches(|c: char| c.is_whitespace() || c == '\0');
    let Some(syntax) = TransferSyntaxRegistry.get(syntax) else {
        return Ok(());
    };
    let rest = &file[data_set_start as usize..];
    match syntax.codec() {
        Codec::Dataset(Some(adapter)) => {
            let inflated = adapter.adapt_reader(Box::new(rest));
            let bound = (rest.len() as u64).saturating_mul(MAX_DEFLATE_RATIO);
            match StatefulDecoder::new_with_ts(inflated, syntax, 0) {
                Ok(decoder) => walk_data_set(path, bound, decoder),
                Err(_) => Ok(()),
            }
        }
        Codec::Dataset(None) => Ok(()),
        _ => match StatefulDecoder::new_with_ts(rest, syntax, data_set_start) {
            Ok(decoder) => walk_data_set(path, file.len() as u64, decoder),
            Err(_) => Ok(()),
        },
    }
}

/// Walks the file meta group (always explicit VR little endian, its decoder started at byte
/// 132) of `file` as dicom-rs reads it: its group length first, then elements,
/// of any group, until that many bytes are read. Returns where the data set starts and its
/// transfer syntax's UID, or `None` where dicom-rs's reading fails too.
fn walk_meta(
    path: &Path,
    file: &[u8],
    decoder: &mut impl StatefulDecode,
) -> Result<Option<(u64, String)>> {
    let size = file.len() as u64;
    let Ok(header) = decoder.decode_header() else {
        return Ok(None);
    };
    if header.tag() != GROUP_LENGTH || header.length().get() != Some(4) {
        return Ok(None);
    }
    // dicom-rs reads the group length as a little-endian u32 whatever VR the header gives it.
    let Some(group_length) = value_bytes(file, decoder.position(), 4)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    else {
        return Ok(None);
    };
    if decoder.skip_bytes(4).is_err() {
        return Ok(None);
    }
    let mut syntax = None;
    let end = decoder.position().saturating_add(u64::from(group_length));
    while decoder.position() < end {
        let Ok(header) = decoder.decode_header() else {
            return Ok(None);
        };
        let Some(length) = header.length().get() else {
            return Ok(None);
        };
        let remaining = size.saturating_sub(META_START + decoder.position());
        fits(path, header.tag(), length, remaining)?;
        if header.tag() == TRANSFER_SYNTAX_UID {
            // dicom-rs reads this value's bytes as text (ISO 8859-1, whose 0x85 is a
            // whitespace it trims) whatever VR the header gives it.
            let Some(value) = value_bytes(file, decoder.position(), length) else {
                return Ok(None);
            };
            let Ok(text) = DefaultCharacterSetCodec.decode(value) else {
                return Ok(None);
            };
            syntax = Some(text);
        }
        if decoder.skip_bytes(length).is_err() {
            return Ok(None);
        }
    }
    Ok(syntax.map(|uid| (META_START + decoder.position(), uid)))
}

/// The `length` bytes of a meta group value that starts `position` bytes after byte 132.
fn value_bytes(file: &[u8], position: u64, length: u32) -> Option<&[u8]> {
    let start = usize::try_from(META_START + position).ok()?;
    file.get(start..start.checked_add(length as usize)?)
}

/// Walks a data set whose decoder counts positions in a stream of at most `size` bytes, token by
/// token with dicom-rs's lazy reader: the same state machine as the reader that builds the
/// object (sequences and items of defined and undefined length, any undefined-length element
/// taken for a sequence, encapsulated pixel data's items for fragments), which yields each
/// value's header before its bytes, so that the value can be checked and skipped.
fn walk_data_set(path: &Path, size: u64, decoder: impl StatefulDecode) -> Result<()> {
    let mut reader = LazyDataSetReader::new(decoder);
    // A token dicom-rs cannot read ends its reading with an error at the same place.
    while let Some(Ok(token)) = reader.advance() {
        let (tag, vr, length, decoder) = match token {
            LazyDataToken::LazyValue { header, decoder } => {
                let Some(length) = header.length().get() else {
                    return Ok(());
                };
                (header.tag(), header.vr(), length, decoder)
            }
            LazyDataToken::LazyItemValue { len, decoder } => (ITEM, VR::OB, len, decoder),
            _ => continue,
        };
        whole_values(path, tag, vr, length)?;
        fits(path, tag, length, size.saturating_sub(decoder.position()))?;
        if decoder.skip_bytes(length).is_err() {
            return Ok(());
        }
    }
    Ok(())
}

/// Refuses a binary value whose length is not a whole number of its VR's numbers: dicom-rs
/// reads only the whole ones and takes the bytes left over for the next element's header (a
/// fuzzed UL of 2 bytes made it read a header declaring 4,294,901,760 bytes).
fn whole_values(path: &Path, tag: Tag, vr: VR, length: u32) -> Result<()> {
    let size = match vr {
        VR::US | VR::SS | VR::OW => 2,
        VR::UL | VR::SL | VR::FL | VR::OF | VR::OL | VR::AT => 4,
        VR::FD | VR::OD | VR::SV | VR::UV | VR::OV => 8,
        _ => 1,
    };
    if length % size != 0 {
        return Err(Error::format(format!(
            "{}: element {tag} ({vr:?}) declares {length} bytes, not a whole number of its \
             {size}-byte values; the file is corrupt: replace it with the scanner's file or \
             remove it from the folder",
            path.display()
        )));
    }
    Ok(())
}

/// Refuses a value of `length` bytes where only `remaining` follow.
fn fits(path: &Path, tag: Tag, length: u32, remaining: u64) -> Result<()> {
    if u64::from(length) > remaining {
        return Err(Error::format(format!(
            "{}: element {tag} declares {length} bytes but only {remaining} follow; the file \
             is truncated or corrupt: replace it with the scanner's file or remove it from the \
             folder",
            path.display()
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An explicit VR little endian element: tag, VR, and a 2- or 4-byte length as the VR has.
    fn element(tag: Tag, vr: &[u8; 2], length: u32, value: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        out.extend(tag.group().to_le_bytes());
        out.extend(tag.element().to_le_bytes());
        out.extend(vr);
        if matches!(vr, b"OB" | b"OW" | b"SQ" | b"UN" | b"UT") {
            out.extend([0, 0]);
            out.extend(length.to_le_bytes());
        } else {
            out.extend((length as u16).to_le_bytes());
        }
        out.extend(value);
        out
    }

    /// An item or delimiter: a tag and a 4-byte length, no VR.
    fn marker(tag: Tag, length: u32) -> Vec<u8> {
        let mut out = Vec::new();
        out.extend(tag.group().to_le_bytes());
        out.extend(tag.element().to_le_bytes());
        out.extend(length.to_le_bytes());
        out
    }

    /// A Part 10 file: preamble, "DICM", a meta group naming `syntax`, then `data_set`.
    fn file(syntax: &str, data_set: &[u8]) -> Vec<u8> {
        let mut uid = syntax.as_bytes().to_vec();
        if uid.len() % 2 == 1 {
            uid.push(0);
        }
        let syntax = element(TRANSFER_SYNTAX_UID, b"UI", uid.len() as u32, &uid);
        file_with_meta(b"UL", &[syntax], data_set)
    }

    /// A Part 10 file whose meta group holds `meta`, its group length under the VR
    /// `length_vr`, then `data_set`.
    fn file_with_meta(length_vr: &[u8; 2], meta: &[Vec<u8>], data_set: &[u8]) -> Vec<u8> {
        let meta = meta.concat();
        let mut out = vec![0; 128];
        out.extend(b"DICM");
        let group_length = (meta.len() as u32).to_le_bytes();
        out.extend(element(GROUP_LENGTH, length_vr, 4, &group_length));
        out.extend(meta);
        out.extend(data_set);
        out
    }

    /// Asserts that the walk refuses `bytes` with a message holding `expected`.
    fn assert_refused(bytes: &[u8], expected: &str) {
        let error = checked(bytes).unwrap_err();
        assert!(error.to_string().contains(expected), "{error}");
    }

    fn checked(bytes: &[u8]) -> Result<()> {
        check(Path::new("slice.dcm"), bytes)
    }

    const UNDEFINED: u32 = u32::MAX;
    const PIXEL_DATA: Tag = Tag(0x7FE0, 0x0010);
    const SEQUENCE_DELIMITER: Tag = Tag(0xFFFE, 0xE0DD);
    const SLICE_THICKNESS: Tag = Tag(0x0018, 0x0050);
    const REFERENCED_IMAGES: Tag = Tag(0x0008, 0x1140);

    #[test]
    fn lengths_that_fit_pass_and_the_first_that_does_not_is_named() {
        let thickness = element(SLICE_THICKNESS, b"DS", 4, b"1.25");
        assert!(checked(&file(EXPLICIT_VR_LITTLE_ENDIAN, &thickness)).is_ok());
        let mut lying = element(SLICE_THICKNESS, b"OB", 2_863_311_530, b"");
        lying.extend([0; 10]);
        assert_refused(
            &file(EXPLICIT_VR_LITTLE_ENDIAN, &lying),
            "(0018,0050) declares 2863311530 bytes but only 10 follow",
        );
        // A meta group element that lies.
        let syntax = element(TRANSFER_SYNTAX_UID, b"UI", 60_000, b"1.2");
        assert_refused(
            &file_with_meta(b"UL", &[syntax], b""),
            "(0002,0010) declares",
        );
    }

    #[test]
    fn an_element_inside_a_sequence_item_is_bounded_too() {
        let mut data_set = element(REFERENCED_IMAGES, b"SQ", UNDEFINED, b"");
        data_set.extend(marker(ITEM, UNDEFINED));
        data_set.extend(element(SLICE_THICKNESS, b"UT", 1 << 30, b"1.25"));
        data_set.extend(marker(Tag(0xFFFE, 0xE00D), 0));
        data_set.extend(marker(SEQUENCE_DELIMITER, 0));
        assert_refused(
            &file(EXPLICIT_VR_LITTLE_ENDIAN, &data_set),
            "(0018,0050) declares",
        );
    }

    #[test]
    fn an_encapsulated_fragment_is_bounded_and_a_true_one_passes() {
        let fragments = |second: u32| {
            let mut data_set = element(PIXEL_DATA, b"OB", UNDEFINED, b"");
            data_set.extend(marker(ITEM, 0));
            data_set.extend(marker(ITEM, second));
            data_set.extend([7; 4]);
            data_set.extend(marker(SEQUENCE_DELIMITER, 0));
            file("1.2.840.10008.1.2.5", &data_set)
        };
        assert!(checked(&fragments(4)).is_ok());
        assert_refused(&fragments(1 << 31), "(FFFE,E000) declares");
    }

    #[test]
    fn a_deflated_data_set_is_bounded_by_what_its_bytes_can_inflate_to() {
        use std::io::Write;
        let deflate = |data_set: &[u8]| {
            let mut encoder =
                flate2::write::DeflateEncoder::new(Vec::new(), flate2::Compression::fast());
            encoder.write_all(data_set).unwrap();
            file("1.2.840.10008.1.2.1.99", &encoder.finish().unwrap())
        };
        let thickness = element(SLICE_THICKNESS, b"DS", 4, b"1.25");
        assert!(checked(&deflate(&thickness)).is_ok());
        let lying = element(SLICE_THICKNESS, b"OB", 3_000_000_000, b"");
        assert!(checked(&deflate(&lying)).is_err());
    }

    #[test]
    fn regression_an_element_of_another_group_in_the_meta_group_hid_the_data_set() {
        // dicom-rs reads the meta group by its group length, whatever groups the elements in
        // it have; the walk took the first element of another group for the data set's start,
        // found no transfer syntax before it and checked nothing (a fuzzed slice whose data
        // set then declared 3,184,309,496 bytes).
        let syntax = EXPLICIT_VR_LITTLE_ENDIAN.as_bytes();
        let stray = element(Tag(0x7FFF, 0x0002), b"UI", 2, b"1\0");
        let real = element(TRANSFER_SYNTAX_UID, b"UI", syntax.len() as u32, syntax);
        let lying = element(SLICE_THICKNESS, b"OB", 3_184_309_496, b"");
        let bytes = file_with_meta(b"UL", &[stray, real], &lying);
        assert_refused(&bytes, "(0018,0050) declares");
    }

    #[test]
    fn regression_a_two_byte_ul_put_dicom_rs_out_of_step() {
        let mut data_set = element(Tag(0x0028, 0x0103), b"UL", 2, &[0, 0]);
        data_set.extend(element(SLICE_THICKNESS, b"DS", 4, b"1.25"));
        let error = checked(&file(EXPLICIT_VR_LITTLE_ENDIAN, &data_set)).unwrap_err();
        assert!(
            error
                .to_string()
                .contains("(0028,0103) (UL) declares 2 bytes"),
            "{error}"
        );
        let whole = element(Tag(0x0028, 0x0103), b"UL", 4, &[0; 4]);
        assert!(checked(&file(EXPLICIT_VR_LITTLE_ENDIAN, &whole)).is_ok());
    }

    #[test]
    fn regression_a_transfer_syntax_uid_under_another_vr_hid_the_data_set() {
        // A fuzzed slice gave (0002,0010) the VR SS: the walk read its value as numbers, found
        // no transfer syntax and checked nothing, while dicom-rs reads the bytes as text (RLE
        // lossless) and then allocated the 2,896,403,089 bytes an element declared.
        let odd = element(TRANSFER_SYNTAX_UID, b"SS", 20, b"1.2.840.10008.1.2.5\0");
        let lying = element(SLICE_THICKNESS, b"OB", 2_896_403_089, b"");
        assert_refused(
            &file_with_meta(b"UL", &[odd], &lying),
            "(0018,0050) declares",
        );
    }

    #[test]
    fn regression_a_meta_group_length_under_another_vr_hid_the_data_set() {
        // A fuzzed slice gave (0002,0000) the VR FD: the walk read no number from its 4 bytes
        // and checked nothing, while dicom-rs reads them as a u32 whatever the VR.
        let syntax = element(TRANSFER_SYNTAX_UID, b"UI", 20, b"1.2.840.10008.1.2.5\0");
        let lying = element(SLICE_THICKNESS, b"OB", 2_147_811_328, b"");
        assert_refused(
            &file_with_meta(b"FD", &[syntax], &lying),
            "(0018,0050) declares",
        );
    }

    #[test]
    fn regression_a_transfer_syntax_uid_ending_in_latin_1_whitespace_hid_the_data_set() {
        // A fuzzed slice's UID ended in the byte 0x85: the walk decoded it as UTF-8, knew no
        // such syntax and checked nothing; dicom-rs decodes ISO 8859-1, where 0x85 is NEL, a
        // whitespace it trims, and read the data set as implicit VR little endian.
        let syntax = element(TRANSFER_SYNTAX_UID, b"UI", 18, b"1.2.840.10008.1.2\x85");
        let mut implicit = vec![0x18, 0, 0x50, 0];
        implicit.extend(4_143_979_008u32.to_le_bytes());
        let bytes = file_with_meta(b"UL", &[syntax], &implicit);
        assert_refused(&bytes, "(0018,0050) declares 4143979008");
    }

    #[test]
    fn bytes_that_are_not_dicom_end_the_walk_without_an_error() {
        assert!(checked(b"").is_ok());
        assert!(checked(&[0xAB; 300]).is_ok());
    }
}
