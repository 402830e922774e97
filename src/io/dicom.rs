//! One DICOM series from a folder, read into an [`Image`] with the geometry and voxel values
//! ITK's ImageSeriesReader (GDCM) gives; dicom-rs parses the files and decodes the pixel data.
//!
//! The folder's files (not its subfolders) that carry DICOM's "DICM" mark at byte 128 are
//! grouped by SeriesInstanceUID; other files are skipped, except that a `.dcm` without the mark
//! is an error. Several series are an error that lists them, unless one is chosen by its UID.
//! The geometry follows [`stack`]: slices sorted along their normal, unequal gaps and a tilted
//! gantry refused. PixelSpacing is DICOM's row spacing then column spacing, so x is its second
//! value. A single slice takes SpacingBetweenSlices, else SliceThickness, else 1 mm, as slice
//! spacing.
//!
//! Pixels: one sample (MONOCHROME), one frame per file, BitsAllocated 8, 16 or 32 with any
//! BitsStored (the bits above HighBit are dropped, signed values sign-extended), signed or
//! unsigned (PixelRepresentation). RescaleSlope and RescaleIntercept are applied (to HU for CT),
//! and the voxel type follows GDCM's rule, so that values equal ITK's: integer slopes and
//! intercepts give the smallest of uint8, int8, uint16, int16, uint32 and int32 that holds every
//! rescaled value the stored bits can hold (a 12-bit CT with intercept −1024 stays int16;
//! a signed 16-bit one becomes int32), else float64; a non-integer slope or intercept gives
//! float32 (ITK: float64; float32 is what the balloon works in and halves the memory).
//!
//! Transfer syntaxes: implicit and explicit VR little endian, deflated explicit VR little
//! endian, encapsulated uncompressed, JPEG baseline, extended and lossless, and RLE lossless
//! (dicom-pixeldata's pure-Rust `native` codecs), except 8-bit RLE, which dicom-rs 0.9 decodes
//! one pixel late. JPEG-LS and JPEG 2000 need C codecs that are not linked. An undecodable file
//! is an error naming it and its transfer syntax.

mod fragments;
mod lengths;
mod stack;

use std::collections::BTreeMap;
use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};

use dicom_object::{OpenFileOptions, Tag};
use dicom_pixeldata::PixelDecoder;
use glam::DVec3;
use rayon::prelude::*;

use super::files;
use super::progress::{self, ReadStage};
use crate::allocation;
use crate::error::{Error, Result};
use crate::geometry::Geometry;
use crate::volume::{Image, ScalarType, VoxelBuffer};

const SERIES_INSTANCE_UID: Tag = Tag(0x0020, 0x000E);
const SERIES_DESCRIPTION: Tag = Tag(0x0008, 0x103E);
const IMAGE_POSITION_PATIENT: Tag = Tag(0x0020, 0x0032);
const IMAGE_ORIENTATION_PATIENT: Tag = Tag(0x0020, 0x0037);
const PIXEL_SPACING: Tag = Tag(0x0028, 0x0030);
const SLICE_THICKNESS: Tag = Tag(0x0018, 0x0050);
const SPACING_BETWEEN_SLICES: Tag = Tag(0x0018, 0x0088);
const SAMPLES_PER_PIXEL: Tag = Tag(0x0028, 0x0002);
const NUMBER_OF_FRAMES: Tag = Tag(0x0028, 0x0008);
const ROWS: Tag = Tag(0x0028, 0x0010);
const COLUMNS: Tag = Tag(0x0028, 0x0011);
const BITS_ALLOCATED: Tag = Tag(0x0028, 0x0100);
const BITS_STORED: Tag = Tag(0x0028, 0x0101);
const HIGH_BIT: Tag = Tag(0x0028, 0x0102);
const PIXEL_REPRESENTATION: Tag = Tag(0x0028, 0x0103);
const RESCALE_INTERCEPT: Tag = Tag(0x0028, 0x1052);
const RESCALE_SLOPE: Tag = Tag(0x0028, 0x1053);
const PIXEL_DATA: Tag = Tag(0x7FE0, 0x0010);
const RLE_LOSSLESS: &str = "1.2.840.10008.1.2.5";
/// JPEG baseline, extended, lossless and lossless first-order: the syntaxes jpeg-decoder reads.
const JPEG: [&str; 4] = [
    "1.2.840.10008.1.2.4.50",
    "1.2.840.10008.1.2.4.51",
    "1.2.840.10008.1.2.4.57",
    "1.2.840.10008.1.2.4.70",
];
/// No transfer syntax balloonseg decodes expands its bytes further than DEFLATE's 1032:1 (RLE
/// at most 64:1; JPEG, whose smallest 8×8 block takes two bits, 512:1 for 16-bit samples).
const MAX_EXPANSION: u64 = 1032;

/// How the stored integers of a slice are laid out.
#[derive(Debug, Clone, Copy, PartialEq)]
struct PixelFormat {
    bits_allocated: u16,
    bits_stored: u16,
    high_bit: u16,
    signed: bool,
}

impl PixelFormat {
    /// The smallest and largest stored value.
    fn range(&self) -> (i64, i64) {
        let bits = u32::from(self.bits_stored);
        if self.signed {
            (-(1i64 << (bits - 1)), (1i64 << (bits - 1)) - 1)
        } else {
            (0, (1i64 << bits) - 1)
        }
    }

    /// The stored value of one little-endian sample: the BitsStored bits ending at HighBit,
    /// sign-extended when signed (the bits above are free for overlays).
    fn value(&self, sample: &[u8]) -> i64 {
        let raw = sample
            .iter()
            .rev()
            .fold(0u64, |v, &b| (v << 8) | u64::from(b));
        let shift = u32::from(self.high_bit) + 1 - u32::from(self.bits_stored);
        let bits = u32::from(self.bits_stored);
        let v = (raw >> shift) & ((1u64 << bits) - 1);
        if self.signed && v >> (bits - 1) == 1 {
            v as i64 - (1i64 << bits)
        } else {
            v as i64
        }
    }
}

/// What one file's header says about its slice.
#[derive(Debug, Clone)]
struct Slice {
    path: PathBuf,
    series: String,
    description: String,
    position: Option<DVec3>,
    orientation: Option<Vec<f64>>,
    pixel_spacing: Option<Vec<f64>>,
    slice_thickness: Option<f64>,
    spacing_between_slices: Option<f64>,
    size: [usize; 2],
    format: PixelFormat,
    slope: f64,
    intercept: f64,
}

/// Reads the one series in `folder`, or the series `series` (a SeriesInstanceUID) when given.
pub fn read(folder: &Path, series: Option<&str>) -> Result<Image> {
    let slices = headers(folder)?;
    let slices = choose_series(folder, slices, series)?;
    volume(&slices)
}

/// The headers of every DICOM file in `folder`, in file-name order.
fn headers(folder: &Path) -> Result<Vec<Slice>> {
    let listing = std::fs::read_dir(folder)
        .map_err(|e| Error::io(format!("{}: cannot list the folder: {e}", folder.display())))?;
    let mut paths = Vec::new();
    for entry in listing {
        let entry = entry
            .map_err(|e| Error::io(format!("{}: cannot list the folder: {e}", folder.display())))?;
        let path = entry.path();
        if path.is_file() {
            paths.push(path);
        }
    }
    paths.sort();
    let mut slices = Vec::new();
    let files = paths.len();
    for (n, path) in paths.into_iter().enumerate() {
        progress::report(n as f64 / files as f64, ReadStage::Reading)?;
        if has_dicom_mark(&path)? {
            slices.push(header(&path)?);
        } else if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("dcm"))
        {
            return Err(Error::format(format!(
                "{}: not a DICOM file (no \"DICM\" at byte 128; truncated or not DICOM Part 10); \
                 remove it or replace it with the scanner's file",
                path.display()
            )));
        }
    }
    if slices.is_empty() {
        return Err(Error::format(format!(
            "{}: no DICOM files in this folder (none has \"DICM\" at byte 128); give the folder \
             that holds the series' files, or a volume file",
            folder.display()
        )));
    }
    Ok(slices)
}

/// Whether the file has DICOM Part 10's 128-byte preamble followed by "DICM".
fn has_dicom_mark(path: &Path) -> Result<bool> {
    let mut start = [0u8; 132];
    let mut file = File::open(path)
        .map_err(|e| Error::io(format!("{}: cannot read the file: {e}", path.display())))?;
    let mut filled = 0;
    while filled < start.len() {
        match file.read(&mut start[filled..]) {
            Ok(0) => return Ok(false),
            Ok(n) => filled += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => {
                return Err(Error::io(format!(
                    "{}: cannot read the file: {e}",
                    path.display()
                )))
            }
        }
    }
    Ok(&start[128..] == b"DICM")
}

fn corrupt(path: &Path, what: impl std::fmt::Display) -> Error {
    Error::format(format!(
        "{}: {what}; the file is truncated or corrupt: replace it with the scanner's file or \
         remove it from the folder",
        path.display()
    ))
}

/// One file's header, read up to (not including) the pixel data, once every length the file
/// declares is known to fit in it (`lengths`).
fn header(path: &Path) -> Result<Slice> {
    let file = files::read(path)?;
    lengths::check(path, &file)?;
    let file_bytes = file.len() as u64;
    drop(file);
    let object = OpenFileOptions::new()
        .read_until(PIXEL_DATA)
        .open_file(path)
        .map_err(|e| corrupt(path, format!("cannot read the DICOM header ({e})")))?;
    let text = |tag| -> Option<String> {
        let element = object.element_opt(tag).ok()??;
        let value = element.to_str().ok()?;
        Some(value.trim_matches([' ', '\0']).to_string())
    };
    let numbers = |tag, name: &str| -> Result<Option<Vec<f64>>> {
        match object.element_opt(tag).ok().flatten() {
            None => Ok(None),
            Some(element) => element
                .to_multi_float64()
                .map(Some)
                .map_err(|e| corrupt(path, format!("{name} is not numbers ({e})"))),
        }
    };
    let number = |tag, name: &str| -> Result<Option<f64>> {
        Ok(numbers(tag, name)?.and_then(|v| v.first().copied()))
    };
    let integer = |tag, name: &str| -> Result<Option<u32>> {
        match object.element_opt(tag).ok().flatten() {
            None => Ok(None),
            Some(element) => element
                .to_int::<u32>()
                .map(Some)
                .map_err(|e| corrupt(path, format!("{name} is not an integer ({e})"))),
        }
    };
    let required = |tag, name: &str| -> Result<u32> {
        integer(tag, name)?.ok_or_else(|| corrupt(path, format!("it has no {name}")))
    };
    if integer(SAMPLES_PER_PIXEL, "SamplesPerPixel")?.unwrap_or(1) != 1 {
        return Err(Error::format(format!(
            "{}: a colour image (SamplesPerPixel is not 1) is not a CT or MR slice; remove it \
             from the folder",
            path.display()
        )));
    }
    if integer(NUMBER_OF_FRAMES, "NumberOfFrames")?.unwrap_or(1) != 1 {
        return Err(Error::format(format!(
            "{}: a multi-frame (enhanced) DICOM file is not supported; convert it to a volume \
             file (.nii.gz, .nrrd, .mha) with dcm2niix or Slicer, or to one file per slice",
            path.display()
        )));
    }
    let bits_allocated = required(BITS_ALLOCATED, "BitsAllocated")?;
    if !matches!(bits_allocated, 8 | 16 | 32) {
        return Err(Error::format(format!(
            "{}: BitsAllocated is {bits_allocated}; balloonseg reads 8, 16 and 32",
            path.display()
        )));
    }
    let bits_stored = integer(BITS_STORED, "BitsStored")?.unwrap_or(bits_allocated);
    let high_bit = integer(HIGH_BIT, "HighBit")?.unwrap_or(bits_stored.saturating_sub(1));
    if bits_stored == 0 || high_bit + 1 < bits_stored || high_bit >= bits_allocated {
        return Err(corrupt(
            path,
            format!(
                "BitsStored {bits_stored} and HighBit {high_bit} do not fit in BitsAllocated \
                 {bits_allocated}"
            ),
        ));
    }
    let position = numbers(IMAGE_POSITION_PATIENT, "ImagePositionPatient")?
        .map(|v| match v.as_slice() {
            [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(DVec3::new(*x, *y, *z)),
            _ => Err(corrupt(path, "ImagePositionPatient is not three numbers")),
        })
        .transpose()?;
    let size = [
        required(COLUMNS, "Columns")? as usize,
        required(ROWS, "Rows")? as usize,
    ];
    if size.contains(&0) {
        return Err(corrupt(path, "it has no pixels (Rows or Columns is 0)"));
    }
    // Bounds the series' voxel buffer, allocated before any slice is decoded, by the files.
    let pixel_bytes = (size[0] * size[1]) as u64 * u64::from(bits_allocated / 8);
    if pixel_bytes > file_bytes.saturating_mul(MAX_EXPANSION) {
        return Err(corrupt(
            path,
            format!(
                "its {}×{} pixels of {bits_allocated} bits take {pixel_bytes} bytes, more than \
                 any transfer syntax packs into a file of {file_bytes} bytes",
                size[0], size[1]
            ),
        ));
    }
    Ok(Slice {
        path: path.to_path_buf(),
        series: text(SERIES_INSTANCE_UID).unwrap_or_default(),
        description: text(SERIES_DESCRIPTION).unwrap_or_default(),
        position,
        orientation: numbers(IMAGE_ORIENTATION_PATIENT, "ImageOrientationPatient")?,
        pixel_spacing: numbers(PIXEL_SPACING, "PixelSpacing")?,
        slice_thickness: number(SLICE_THICKNESS, "SliceThickness")?,
        spacing_between_slices: number(SPACING_BETWEEN_SLICES, "SpacingBetweenSlices")?,
        size,
        format: PixelFormat {
            bits_allocated: bits_allocated as u16,
            bits_stored: bits_stored as u16,
            high_bit: high_bit as u16,
            signed: integer(PIXEL_REPRESENTATION, "PixelRepresentation")?.unwrap_or(0) == 1,
        },
        slope: number(RESCALE_SLOPE, "RescaleSlope")?.unwrap_or(1.0),
        intercept: number(RESCALE_INTERCEPT, "RescaleIntercept")?.unwrap_or(0.0),
    })
}

/// The slices of the one series, or of `chosen`; several series without a choice, or a choice
/// that is not there, is an error listing the series.
fn choose_series(folder: &Path, slices: Vec<Slice>, chosen: Option<&str>) -> Result<Vec<Slice>> {
    let mut by_series: BTreeMap<String, Vec<Slice>> = BTreeMap::new();
    for slice in slices {
        by_series
            .entry(slice.series.clone())
            .or_default()
            .push(slice);
    }
    let listing = || {
        by_series
            .iter()
            .map(|(uid, slices)| {
                format!(
                    "\n  {uid} ({:?}, {} files)",
                    slices[0].description,
                    slices.len()
                )
            })
            .collect::<String>()
    };
    match chosen {
        Some(uid) => {
            let listed = listing();
            by_series.remove(uid).ok_or_else(|| {
                Error::invalid_argument(format!(
                    "{}: no DICOM series {uid:?} in this folder; its series are:{listed}",
                    folder.display()
                ))
            })
        }
        None if by_series.len() > 1 => Err(Error::invalid_argument(format!(
            "{}: the folder holds {} DICOM series; choose one with --series UID (the command \
             line's option; a manifest's `series` column) or move each into its own folder:{}",
            folder.display(),
            by_series.len(),
            listing()
        ))),
        None => Ok(by_series.into_values().next().unwrap_or_default()),
    }
}

/// Checks that every slice matches the first in the attributes a volume shares.
fn check_alike(slices: &[Slice]) -> Result<()> {
    let first = &slices[0];
    for slice in &slices[1..] {
        let differ = |what: &str, theirs: String, ours: String| {
            Error::format(format!(
                "{}: its {what} is {theirs} but {} has {ours}; a series' slices must share it \
                 — remove the odd file (it may belong to another acquisition) or choose \
                 another series",
                slice.path.display(),
                first.path.display()
            ))
        };
        if slice.size != first.size {
            let size = |s: [usize; 2]| format!("{}×{} pixels", s[0], s[1]);
            return Err(differ("size", size(slice.size), size(first.size)));
        }
        if slice.format != first.format {
            let format = |f: PixelFormat| {
                format!(
                    "{} of {} bits, {}",
                    f.bits_stored,
                    f.bits_allocated,
                    if f.signed { "signed" } else { "unsigned" }
                )
            };
            return Err(differ(
                "pixel format",
                format(slice.format),
                format(first.format),
            ));
        }
        let close = |a: &Option<Vec<f64>>, b: &Option<Vec<f64>>| match (a, b) {
            (Some(a), Some(b)) => {
                a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-4)
            }
            (a, b) => a.is_none() && b.is_none(),
        };
        for (tag, here, there) in [
            (
                "ImageOrientationPatient",
                &slice.orientation,
                &first.orientation,
            ),
            ("PixelSpacing", &slice.pixel_spacing, &first.pixel_spacing),
        ] {
            if !close(here, there) {
                return Err(differ(tag, format!("{here:?}"), format!("{there:?}")));
            }
        }
    }
    Ok(())
}

/// The volume of one series' slices.
fn volume(slices: &[Slice]) -> Result<Image> {
    check_alike(slices)?;
    let first = &slices[0];
    let name = first.path.display().to_string();
    let orientation = first.orientation.as_deref().ok_or_else(|| {
        Error::format(format!(
            "{name}: no ImageOrientationPatient, so the slices have no place in the patient; \
             balloonseg needs a CT or MR image series"
        ))
    })?;
    let (row, column) = stack::orientation(orientation, &name)?;
    let positions = slices
        .iter()
        .map(|s| {
            s.position.ok_or_else(|| {
                Error::format(format!(
                    "{}: no ImagePositionPatient, so the slice has no place in the stack",
                    s.path.display()
                ))
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let names: Vec<String> = slices
        .iter()
        .map(|s| s.path.display().to_string())
        .collect();
    let stack = stack::stack(row, column, &positions, &names)?;
    let [row_spacing, column_spacing] = match first.pixel_spacing.as_deref() {
        Some(&[r, c]) => [r, c],
        Some(_) => return Err(corrupt(&first.path, "PixelSpacing is not two numbers")),
        None => [1.0, 1.0],
    };
    let slice_spacing = stack.slice_spacing.unwrap_or_else(|| {
        first
            .spacing_between_slices
            .or(first.slice_thickness)
            .filter(|s| s.is_finite() && *s > 0.0)
            .unwrap_or(1.0)
    });
    let geometry = Geometry::new(
        [column_spacing, row_spacing, slice_spacing],
        stack.origin.to_array(),
        stack.direction,
    )
    .map_err(|e| e.context(&name))?;
    let sorted: Vec<&Slice> = stack.order.iter().map(|&n| &slices[n]).collect();
    let dims = [first.size[0], first.size[1], sorted.len()];
    let buffer = match output_type(&sorted) {
        ScalarType::U8 => VoxelBuffer::U8(voxels(&sorted, |v| v as u8)?),
        ScalarType::I8 => VoxelBuffer::I8(voxels(&sorted, |v| v as i8)?),
        ScalarType::U16 => VoxelBuffer::U16(voxels(&sorted, |v| v as u16)?),
        ScalarType::I16 => VoxelBuffer::I16(voxels(&sorted, |v| v as i16)?),
        ScalarType::U32 => VoxelBuffer::U32(voxels(&sorted, |v| v as u32)?),
        ScalarType::I32 => VoxelBuffer::I32(voxels(&sorted, |v| v as i32)?),
        ScalarType::F32 => VoxelBuffer::F32(voxels(&sorted, |v| v as f32)?),
        ScalarType::F64 => VoxelBuffer::F64(voxels(&sorted, |v| v)?),
    };
    Image::new(buffer, dims, geometry)
}

/// GDCM's choice of voxel type for the rescaled values (see the module's comment).
fn output_type(slices: &[&Slice]) -> ScalarType {
    let integral = |x: f64| x.is_finite() && x.fract() == 0.0;
    if !slices
        .iter()
        .all(|s| integral(s.slope) && integral(s.intercept))
    {
        return ScalarType::F32;
    }
    let (low, high) = slices[0].format.range();
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for s in slices {
        for v in [low, high] {
            let rescaled = v as f64 * s.slope + s.intercept;
            lo = lo.min(rescaled);
            hi = hi.max(rescaled);
        }
    }
    let fits = |min: f64, max: f64| lo >= min && hi <= max;
    [
        (ScalarType::U8, 0.0, u8::MAX as f64),
        (ScalarType::I8, i8::MIN as f64, i8::MAX as f64),
        (ScalarType::U16, 0.0, u16::MAX as f64),
        (ScalarType::I16, i16::MIN as f64, i16::MAX as f64),
        (ScalarType::U32, 0.0, u32::MAX as f64),
        (ScalarType::I32, i32::MIN as f64, i32::MAX as f64),
    ]
    .into_iter()
    .find(|&(_, min, max)| fits(min, max))
    .map_or(ScalarType::F64, |(t, _, _)| t)
}

/// Every slice's rescaled values, slice after slice, converted by `convert` (which the choice of
/// type keeps in range).
fn voxels<T: Copy + Default + Send>(
    slices: &[&Slice],
    convert: impl Fn(f64) -> T + Sync,
) -> Result<Vec<T>> {
    let plane = slices[0].size[0] * slices[0].size[1];
    let total_slices = slices.len();
    let total = plane.checked_mul(total_slices).ok_or_else(|| {
        Error::invalid_volume("the series has more voxels than this machine can address")
    })?;
    let mut data = allocation::filled(total, T::default(), "the series' voxels")?;
    // Decoded in parallel a batch at a time, so that progress is reported (on this thread)
    // between batches.
    let batch = 4 * rayon::current_num_threads();
    for (n, (planes, slices)) in data
        .chunks_mut(plane * batch)
        .zip(slices.chunks(batch))
        .enumerate()
    {
        progress::report(
            (n * batch) as f64 / total_slices as f64,
            ReadStage::Decoding,
        )?;
        planes
            .par_chunks_mut(plane)
            .zip(slices.par_iter())
            .try_for_each(|(out, slice)| decode_slice(slice, out, &convert))?;
    }
    Ok(data)
}

/// Checks the compressed fragments of an RLE or JPEG slice against its header before a codec
/// allocates by what they declare (see [`fragments`]).
fn check_fragments(
    slice: &Slice,
    object: &dicom_object::DefaultDicomObject,
    syntax: &str,
) -> Result<()> {
    let rle = syntax == RLE_LOSSLESS;
    if !rle && !JPEG.contains(&syntax) {
        return Ok(());
    }
    let Some(element) = object.element_opt(PIXEL_DATA).ok().flatten() else {
        return Ok(());
    };
    // dicom-rs's codecs would take a plain value for one fragment and trust its first bytes.
    let fragments = element.value().fragments().ok_or_else(|| {
        corrupt(
            &slice.path,
            "its pixel data is a plain value where its compressed transfer syntax needs \
             encapsulated fragments",
        )
    })?;
    let frame = fragments::Frame {
        path: &slice.path,
        columns: slice.size[0],
        rows: slice.size[1],
        bits_allocated: slice.format.bits_allocated,
    };
    if rle {
        frame.check_rle(fragments)
    } else {
        frame.check_jpeg(fragments)
    }
}

/// Decodes one file's pixels into `out` (one plane, i fastest).
fn decode_slice<T>(slice: &Slice, out: &mut [T], convert: &impl Fn(f64) -> T) -> Result<()> {
    let path = &slice.path;
    let object = OpenFileOptions::new()
        .open_file(path)
        .map_err(|e| corrupt(path, format!("cannot read the DICOM file ({e})")))?;
    let syntax = object.meta().transfer_syntax();
    let undecodable = |why: String| {
        Error::format(format!(
            "{}: cannot decode the pixel data ({why}); transfer syntax {syntax}. balloonseg \
             decodes uncompressed, deflated, JPEG (baseline, extended, lossless) and 16-bit RLE \
             series; convert others with `gdcmconv --raw` or dcmdjpeg",
            path.display(),
        ))
    };
    if syntax == RLE_LOSSLESS && slice.format.bits_allocated == 8 {
        // dicom-rs 0.9 puts 8-bit RLE pixels one place late (the last one lost).
        return Err(undecodable(
            "8-bit RLE, which dicom-rs 0.9 decodes wrongly".into(),
        ));
    }
    check_fragments(slice, &object, syntax)?;
    // The codecs index their input without checking it everywhere: a corrupt file must be an
    // error, never a crash.
    let decoded =
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| object.decode_pixel_data()))
            .map_err(|_| undecodable("the decoder failed on corrupt data".into()))?
            .map_err(|e| undecodable(e.to_string()))?;
    let bytes = usize::from(slice.format.bits_allocated / 8);
    let data = decoded.data();
    if data.len() < out.len() * bytes {
        return Err(corrupt(
            path,
            format!(
                "the pixel data holds {} bytes but {}×{} pixels need {}",
                data.len(),
                slice.size[0],
                slice.size[1],
                out.len() * bytes
            ),
        ));
    }
    for (o, sample) in out.iter_mut().zip(data.chunks_exact(bytes)) {
        *o = convert(slice.format.value(sample) as f64 * slice.slope + slice.intercept);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::test_images::{assert_never_panics, scratch_dir};
    use dicom_core::{DataElement, PrimitiveValue, VR};
    use dicom_object::{FileMetaTableBuilder, InMemDicomObject};

    /// A multi-valued string element's value.
    fn strings(values: &[&str]) -> PrimitiveValue {
        PrimitiveValue::Strs(values.iter().map(|v| v.to_string()).collect())
    }

    /// A one-slice series file: 3×2 signed 16-bit pixels with a CT rescale, sagittal (the
    /// normal is −x) at `x`.
    fn slice_file(x: f64, pixels: &[i16; 6]) -> Vec<u8> {
        let mut object = InMemDicomObject::new_empty();
        let mut put = |tag, vr, value| object.put(DataElement::new(tag, vr, value));
        put(SERIES_INSTANCE_UID, VR::UI, PrimitiveValue::from("1.2.3"));
        put(
            Tag(0x0008, 0x0016),
            VR::UI,
            PrimitiveValue::from("1.2.840.10008.5.1.4.1.1.2"),
        );
        put(Tag(0x0008, 0x0018), VR::UI, PrimitiveValue::from("1.2.3.4"));
        put(
            Tag(0x0028, 0x0004),
            VR::CS,
            PrimitiveValue::from("MONOCHROME2"),
        );
        let x = x.to_string();
        put(IMAGE_POSITION_PATIENT, VR::DS, strings(&[&x, "7.5", "4"]));
        let cosines = strings(&["0", "1", "0", "0", "0", "-1"]);
        put(IMAGE_ORIENTATION_PATIENT, VR::DS, cosines);
        put(PIXEL_SPACING, VR::DS, strings(&["0.5", "0.25"]));
        put(SAMPLES_PER_PIXEL, VR::US, PrimitiveValue::from(1u16));
        put(ROWS, VR::US, PrimitiveValue::from(2u16));
        put(COLUMNS, VR::US, PrimitiveValue::from(3u16));
        put(BITS_ALLOCATED, VR::US, PrimitiveValue::from(16u16));
        put(BITS_STORED, VR::US, PrimitiveValue::from(16u16));
        put(HIGH_BIT, VR::US, PrimitiveValue::from(15u16));
        put(PIXEL_REPRESENTATION, VR::US, PrimitiveValue::from(1u16));
        put(RESCALE_INTERCEPT, VR::DS, PrimitiveValue::from("-1024"));
        put(RESCALE_SLOPE, VR::DS, PrimitiveValue::from("1"));
        let bytes: Vec<u8> = pixels.iter().flat_map(|p| p.to_le_bytes()).collect();
        put(PIXEL_DATA, VR::OW, PrimitiveValue::from(bytes));
        let meta = FileMetaTableBuilder::new().transfer_syntax("1.2.840.10008.1.2.1");
        let mut file = Vec::new();
        object
            .with_meta(meta)
            .unwrap()
            .write_all(&mut file)
            .unwrap();
        file
    }

    #[test]
    fn a_written_series_reads_with_its_geometry_and_rescaled_voxels() {
        let dir = scratch_dir();
        // File names in the opposite order of the positions: only the positions sort them.
        std::fs::write(dir.path().join("a.dcm"), slice_file(-7.0, &[0; 6])).unwrap();
        std::fs::write(
            dir.path().join("b.dcm"),
            slice_file(-5.0, &[1, 2, 3, 4, 5, 6]),
        )
        .unwrap();
        std::fs::write(dir.path().join("notes.txt"), "not DICOM").unwrap();
        let image = read(dir.path(), None).unwrap();
        assert_eq!(image.dims(), [3, 2, 2]);
        let g = image.geometry();
        assert_eq!(g.spacing(), [0.25, 0.5, 2.0]);
        assert_eq!(g.origin(), [-5.0, 7.5, 4.0]);
        // Columns: the row cosine (0,1,0), the column cosine (0,0,-1), their cross (-1,0,0).
        let direction = [0.0, 0.0, -1.0, 1.0, 0.0, 0.0, 0.0, -1.0, 0.0];
        assert_eq!(g.direction(), direction);
        let mut voxels: Vec<i32> = (1..=6).map(|v| v - 1024).collect();
        voxels.extend([-1024; 6]);
        // Signed 16-bit with an intercept: int32, as GDCM chooses.
        assert_eq!(image.buffer(), &VoxelBuffer::I32(voxels));
    }

    #[test]
    fn a_series_reports_its_files_read_and_its_slices_decoded() {
        let dir = scratch_dir();
        for k in 0..5 {
            let name = dir.path().join(format!("{k}.dcm"));
            std::fs::write(name, slice_file(2.0 * k as f64, &[k as i16; 6])).unwrap();
        }
        let (progress, seen) = crate::io::progress::tests::recorder();
        let image = crate::io::read_image_reporting(dir.path(), None, progress).unwrap();
        assert_eq!(image.dims(), [3, 2, 5]);
        let seen = seen.lock().unwrap();
        let reading: Vec<f64> = seen
            .iter()
            .filter(|(_, s)| *s == ReadStage::Reading)
            .map(|(f, _)| *f)
            .collect();
        assert_eq!(reading, [0.0, 0.2, 0.4, 0.6, 0.8]);
        assert!(seen.iter().any(|(_, s)| *s == ReadStage::Decoding));
    }

    #[test]
    fn a_slice_declaring_more_pixels_than_its_file_can_hold_is_refused_before_any_allocation() {
        let dir = scratch_dir();
        let mut file = slice_file(0.0, &[0; 6]);
        for (element, value) in [(0x10u8, 2u8), (0x11, 3)] {
            let header = [0x28, 0, element, 0, b'U', b'S', 2, 0, value, 0];
            let at = file.windows(10).position(|w| w == header).unwrap();
            file[at + 8..at + 10].copy_from_slice(&[0xFF, 0xFF]);
        }
        std::fs::write(dir.path().join("slice.dcm"), &file).unwrap();
        let refused = read(dir.path(), None).unwrap_err().to_string();
        assert!(
            refused.contains("65535×65535 pixels of 16 bits take 8589672450 bytes, more than"),
            "{refused}"
        );
    }

    #[test]
    fn corrupt_and_truncated_slices_are_errors_never_panics() {
        let dir = scratch_dir();
        let pixels = [-3, 0, 7, 1000, -1000, 5];
        let file = slice_file(0.0, &pixels);
        let path = dir.path().join("slice.dcm");
        let original = {
            std::fs::write(&path, &file).unwrap();
            read(dir.path(), None).unwrap()
        };
        assert_never_panics(&file, &original, |bytes| {
            std::fs::write(&path, bytes).unwrap();
            read(dir.path(), None)
        });
    }

    fn format(bits_allocated: u16, bits_stored: u16, signed: bool) -> PixelFormat {
        PixelFormat {
            bits_allocated,
            bits_stored,
            high_bit: bits_stored - 1,
            signed,
        }
    }

    #[test]
    fn stored_values_drop_the_bits_above_the_high_bit_and_extend_the_sign() {
        let twelve = format(16, 12, true);
        // 0xF800: overlay bits 12-15 set, value bits 0x800 = -2048 in 12-bit two's complement.
        assert_eq!(twelve.value(&[0x00, 0xF8]), -2048);
        assert_eq!(twelve.value(&[0xFF, 0x07]), 2047);
        assert_eq!(format(16, 12, false).value(&[0xFF, 0xFF]), 4095);
        assert_eq!(format(16, 16, true).value(&[0x18, 0xFC]), -1000);
        assert_eq!(format(8, 8, false).value(&[200]), 200);
        assert_eq!(format(8, 8, true).value(&[200]), -56);
        assert_eq!(format(32, 32, false).value(&[0, 0, 0, 0x80]), 1 << 31);
        assert_eq!(format(16, 12, false).range(), (0, 4095));
        assert_eq!(format(16, 16, true).range(), (-32768, 32767));
    }

    fn slice(format: PixelFormat, slope: f64, intercept: f64) -> Slice {
        Slice {
            path: PathBuf::from("a.dcm"),
            series: String::new(),
            description: String::new(),
            position: None,
            orientation: None,
            pixel_spacing: None,
            slice_thickness: None,
            spacing_between_slices: None,
            size: [1, 1],
            format,
            slope,
            intercept,
        }
    }

    #[test]
    fn the_voxel_type_is_the_smallest_that_holds_every_rescaled_stored_value() {
        let cases = [
            (format(8, 8, false), 1.0, 0.0, ScalarType::U8),
            (format(8, 8, true), 1.0, 0.0, ScalarType::I8),
            (format(16, 12, false), 1.0, 0.0, ScalarType::U16),
            (format(16, 12, false), 1.0, -1024.0, ScalarType::I16),
            (format(16, 16, true), 1.0, 0.0, ScalarType::I16),
            (format(16, 16, true), 1.0, -1024.0, ScalarType::I32),
            (format(16, 16, false), 1.0, -1024.0, ScalarType::I32),
            (format(16, 12, false), 0.5, -1024.0, ScalarType::F32),
            (format(32, 32, true), 2.0, 0.0, ScalarType::F64),
        ];
        for (f, slope, intercept, expected) in cases {
            let s = slice(f, slope, intercept);
            assert_eq!(output_type(&[&s]), expected, "{f:?} {slope} {intercept}");
        }
        let (a, b) = (
            slice(format(8, 8, false), 1.0, 0.0),
            slice(format(8, 8, false), 1.0, 100.0),
        );
        assert_eq!(output_type(&[&a, &b]), ScalarType::U16);
    }
}
