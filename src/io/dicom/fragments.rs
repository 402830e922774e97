//! An encapsulated slice's compressed fragments, checked against the slice's Rows and Columns
//! before dicom-rs's codecs see them. The codecs trust the sizes the compressed stream
//! declares and allocate by them: dicom-rs 0.9's RLE decoder allocates a table of as many
//! segment offsets as the RLE header's first word says (a fuzzed slice asked for 3.3 GB), and
//! jpeg-decoder allocates its planes by the JPEG frame header's width and height, whatever the
//! DICOM header says. Here the RLE header (DICOM PS3.5 annex G) and the JPEG frame header
//! (ITU-T T.81 B.2.2) must describe exactly one frame of Rows × Columns single-sample pixels of
//! BitsAllocated bits; the codecs then allocate no more than [`super::header`] has bounded.

use std::path::Path;

use crate::error::{Error, Result};

/// An RLE fragment starts with a header of 16 little-endian words: the segment count and 15
/// segment offsets.
const RLE_HEADER_BYTES: usize = 64;

/// What the codec of a slice's transfer syntax must be given, and what it was given.
pub(super) struct Frame<'a> {
    pub path: &'a Path,
    pub columns: usize,
    pub rows: usize,
    pub bits_allocated: u16,
}

impl Frame<'_> {
    fn corrupt(&self, what: String) -> Error {
        Error::format(format!(
            "{}: {what}; the file is corrupt: replace it with the scanner's file or remove it \
             from the folder",
            self.path.display()
        ))
    }

    /// An RLE lossless slice: one fragment, whose header names one segment per byte of a
    /// sample, each starting after the header and after the one before, inside the fragment,
    /// and each decoding to at least Rows × Columns bytes: dicom-rs 0.9 copies that many from
    /// every segment's output and panics on a shorter one.
    pub fn check_rle(&self, fragments: &[Vec<u8>]) -> Result<()> {
        let [fragment] = fragments else {
            return Err(self.corrupt(format!(
                "its RLE pixel data holds {} fragments where one frame takes exactly one",
                fragments.len()
            )));
        };
        let Some(header) = fragment.get(..RLE_HEADER_BYTES) else {
            return Err(self.corrupt(format!(
                "its RLE fragment of {} bytes is shorter than the {RLE_HEADER_BYTES}-byte RLE \
                 header",
                fragment.len()
            )));
        };
        let words: Vec<u32> = header
            .chunks_exact(4)
            .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
            .collect();
        let segments = usize::from(self.bits_allocated / 8);
        if words[0] as usize != segments {
            return Err(self.corrupt(format!(
                "its RLE header declares {} segments where {}-bit single-sample pixels take \
                 {segments}",
                words[0], self.bits_allocated
            )));
        }
        let offsets = &words[1..=segments];
        let in_order = offsets[0] as usize == RLE_HEADER_BYTES
            && offsets.windows(2).all(|pair| pair[0] <= pair[1])
            && offsets[segments - 1] as usize <= fragment.len();
        if !in_order {
            return Err(self.corrupt(format!(
                "its RLE segment offsets {offsets:?} do not lie in order between the header and \
                 the fragment's end ({} bytes)",
                fragment.len()
            )));
        }
        let pixels = self.rows.saturating_mul(self.columns);
        let ends = offsets[1..]
            .iter()
            .map(|&o| o as usize)
            .chain([fragment.len()]);
        for (k, (start, end)) in offsets.iter().map(|&o| o as usize).zip(ends).enumerate() {
            let decoded = packbits_length(&fragment[start..end]);
            if decoded < pixels {
                return Err(self.corrupt(format!(
                    "its RLE segment {k} decodes to {decoded} bytes where Rows × Columns take \
                     {pixels}"
                )));
            }
        }
        Ok(())
    }

    /// A JPEG slice (baseline, extended or lossless): its frame header, the first one in the
    /// fragments joined, must be Rows × Columns with one component.
    pub fn check_jpeg(&self, fragments: &[Vec<u8>]) -> Result<()> {
        let stream: Vec<u8> = fragments.concat();
        let Some(frame) = jpeg_frame_header(&stream) else {
            return Err(self.corrupt("its JPEG stream has no frame header before its scan".into()));
        };
        if [frame.width, frame.height] != [self.columns, self.rows] || frame.components != 1 {
            return Err(self.corrupt(format!(
                "its JPEG frame is {}×{} pixels of {} components where Columns × Rows say {}×{} \
                 of one",
                frame.width, frame.height, frame.components, self.columns, self.rows
            )));
        }
        Ok(())
    }
}

/// The bytes a PackBits stream (DICOM PS3.5 G.3.1) decodes to, as dicom-rs 0.9 decodes it: a
/// header byte n of 0..=127 copies the n + 1 bytes after it (as many as are left), one of
/// -127..=-1 repeats the byte after it 1 - n times, and -128 does nothing. A repeat without
/// its byte counts nothing (dicom-rs reports an error there).
fn packbits_length(stream: &[u8]) -> usize {
    let (mut at, mut decoded) = (0, 0usize);
    while let Some(&header) = stream.get(at) {
        let n = header as i8;
        at += 1;
        match n {
            0..=127 => {
                let copied = (n as usize + 1).min(stream.len() - at);
                decoded += copied;
                at += copied;
            }
            -127..=-1 if at < stream.len() => {
                decoded += (1 - n as isize) as usize;
                at += 1;
            }
            _ => {}
        }
    }
    decoded
}

#[derive(Debug, PartialEq)]
struct JpegFrame {
    width: usize,
    height: usize,
    components: u8,
}

/// The first start-of-frame segment of a JPEG stream, read marker by marker from its
/// start-of-image; `None` when the stream ends, breaks or reaches a scan first.
fn jpeg_frame_header(stream: &[u8]) -> Option<JpegFrame> {
    if stream.get(..2)? != [0xFF, 0xD8] {
        return None;
    }
    let mut at = 2;
    loop {
        if *stream.get(at)? != 0xFF {
            return None;
        }
        // Any number of 0xFF may pad the space before a marker (T.81 B.1.1.2).
        while *stream.get(at + 1)? == 0xFF {
            at += 1;
        }
        let marker = *stream.get(at + 1)?;
        at += 2;
        match marker {
            // Markers without a length: TEM and the restart markers.
            0x01 | 0xD0..=0xD7 => continue,
            // Start of scan or end of image before any frame.
            0xDA | 0xD9 => return None,
            _ => {}
        }
        let length = usize::from(u16::from_be_bytes([*stream.get(at)?, *stream.get(at + 1)?]));
        let is_frame = matches!(marker, 0xC0..=0xCF) && !matches!(marker, 0xC4 | 0xC8 | 0xCC);
        if is_frame {
            let segment = stream.get(at..at + length.max(8))?;
            return Some(JpegFrame {
                height: usize::from(u16::from_be_bytes([segment[3], segment[4]])),
                width: usize::from(u16::from_be_bytes([segment[5], segment[6]])),
                components: segment[7],
            });
        }
        at += length;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(bits_allocated: u16) -> Frame<'static> {
        Frame {
            path: Path::new("slice.dcm"),
            columns: 4,
            rows: 2,
            bits_allocated,
        }
    }

    /// An RLE header of `words` and, to `length` bytes, PackBits runs of 8 bytes each (the
    /// test frame's Rows × Columns) two bytes apart.
    fn rle_fragment(words: &[u32], length: usize) -> Vec<u8> {
        let mut bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
        bytes.resize(RLE_HEADER_BYTES, 0);
        bytes.extend(
            [(-7i8) as u8, 1]
                .iter()
                .cycle()
                .take(length - RLE_HEADER_BYTES),
        );
        bytes
    }

    fn message(outcome: Result<()>) -> String {
        outcome.expect_err("refused").to_string()
    }

    #[test]
    fn an_rle_header_with_one_segment_per_sample_byte_in_order_is_accepted() {
        assert!(frame(16)
            .check_rle(&[rle_fragment(&[2, 64, 70], 80)])
            .is_ok());
        assert!(frame(8).check_rle(&[rle_fragment(&[1, 64], 70)]).is_ok());
    }

    #[test]
    fn an_rle_segment_count_the_pixels_do_not_take_is_refused_before_dicom_rs_allocates_it() {
        let refused = message(frame(16).check_rle(&[rle_fragment(&[822_083_587, 64, 70], 80)]));
        assert!(refused.contains("declares 822083587 segments"), "{refused}");
    }

    #[test]
    fn rle_offsets_out_of_order_or_past_the_fragment_are_refused() {
        for words in [[2, 60, 70], [2, 64, 63], [2, 64, 81]] {
            let refused = message(frame(16).check_rle(&[rle_fragment(&words, 80)]));
            assert!(
                refused.contains("do not lie in order"),
                "{words:?}: {refused}"
            );
        }
    }

    #[test]
    fn packbits_lengths_count_literal_and_repeated_runs_as_dicom_rs_decodes_them() {
        // dicom-rs's own example: 24 bytes.
        let example = [
            0xFE, 0xAA, 0x02, 0x80, 0x00, 0x2A, 0xFD, 0xAA, 0x03, 0x80, 0x00, 0x2A, 0x22, 0xF7,
            0xAA,
        ];
        assert_eq!(packbits_length(&example), 24);
        // A literal run cut short copies what is left; a repeat without its byte, nothing;
        // -128 is no run.
        assert_eq!(packbits_length(&[0x05, 1, 2]), 2);
        assert_eq!(packbits_length(&[0x00, 9, 0xF9]), 1);
        assert_eq!(packbits_length(&[0x80, 0x80]), 0);
        assert_eq!(packbits_length(&[]), 0);
    }

    #[test]
    fn regression_dicom_rs_panicked_on_an_rle_segment_shorter_than_the_frame() {
        // The fuzzer's dicom target hit dicom-rs 0.9's `rle_lossless.rs:114` many times: it
        // indexes each segment's output up to Rows × Columns. The reader caught the panic,
        // but the message still reached standard error.
        let mut fragment = rle_fragment(&[2, 64, 70], 80);
        fragment[70..80].copy_from_slice(&[0x06, 1, 2, 3, 4, 5, 6, 7, 0xF9, 0xFF]);
        assert!(frame(16).check_rle(&[fragment.clone()]).is_ok());
        fragment[78] = 0x80;
        let refused = message(frame(16).check_rle(&[fragment]));
        assert!(
            refused.contains("segment 1 decodes to 7 bytes where Rows × Columns take 8"),
            "{refused}"
        );
    }

    #[test]
    fn rle_pixel_data_must_be_one_whole_fragment() {
        let one = rle_fragment(&[2, 64, 70], 80);
        assert!(message(frame(16).check_rle(&[one.clone(), one])).contains("2 fragments"));
        assert!(message(frame(16).check_rle(&[vec![2, 0, 0, 0]])).contains("shorter"));
    }

    /// SOI, an APP0 segment, fill bytes, then a lossless SOF3 of `height`×`width`, `components`.
    fn jpeg(height: u16, width: u16, components: u8) -> Vec<u8> {
        let mut bytes = vec![
            0xFF, 0xD8, 0xFF, 0xE0, 0x00, 0x04, b'J', b'F', 0xFF, 0xFF, 0xC3,
        ];
        bytes.extend(8u16.to_be_bytes());
        bytes.push(16);
        bytes.extend(height.to_be_bytes());
        bytes.extend(width.to_be_bytes());
        bytes.push(components);
        bytes.extend([0xFF, 0xDA]);
        bytes
    }

    #[test]
    fn the_jpeg_frame_header_is_found_past_other_segments_and_fill_bytes() {
        assert_eq!(
            jpeg_frame_header(&jpeg(2, 4, 1)),
            Some(JpegFrame {
                width: 4,
                height: 2,
                components: 1
            })
        );
        assert!(frame(16).check_jpeg(&[jpeg(2, 4, 1)]).is_ok());
        let split = jpeg(2, 4, 1);
        assert!(frame(16)
            .check_jpeg(&[split[..9].to_vec(), split[9..].to_vec()])
            .is_ok());
    }

    #[test]
    fn a_jpeg_frame_larger_than_rows_and_columns_is_refused_before_it_is_decoded() {
        let refused = message(frame(16).check_jpeg(&[jpeg(65_535, 65_535, 1)]));
        assert!(
            refused.contains("65535×65535 pixels of 1 components"),
            "{refused}"
        );
        assert!(message(frame(16).check_jpeg(&[jpeg(2, 4, 3)])).contains("of 3 components"));
    }

    #[test]
    fn a_jpeg_stream_without_a_frame_header_is_refused() {
        for stream in [vec![], vec![0xFF, 0xD8], vec![0xFF, 0xD8, 0xFF, 0xDA, 0, 2]] {
            let refused = message(frame(16).check_jpeg(std::slice::from_ref(&stream)));
            assert!(refused.contains("no frame header"), "{stream:?}: {refused}");
        }
    }
}
