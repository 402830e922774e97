//! NIfTI-1 single files (`.nii`, and `.nii.gz` — any gzip-compressed file is recognised by its
//! magic bytes) reading and writing, with the geometry ITK's NiftiImageIO gives.
//!
//! Geometry: the sform when `sform_code > 0` and the lengths of its columns are `pixdim`'s
//! spacing, else the qform (quaternion, `qfac` from `pixdim[0]`, spacing from `pixdim`) when
//! `qform_code > 0`; both map to NIfTI's RAS world and are turned into ITK's LPS by negating the
//! first two rows of the affine. With neither, ITK gives spacing `pixdim`, origin 0 and the
//! identity direction, and so do we. Unlike ITK, a sheared sform is kept as it is
//! (non-orthogonal direction columns) rather than replaced by the qform. An sform whose scales
//! are not `pixdim`'s (ITK warns "unexpected scales in sform") gives, as in ITK, `pixdim`'s
//! spacing with its own origin and normalised columns when those are orthonormal, else the qform:
//! a header that says 1e-9 mm along one axis in the sform and 1 mm in `pixdim` is 1 mm.
//!
//! Voxels: both byte orders (told apart by `sizeof_hdr`), datatypes uint8, int8, uint16, int16,
//! uint32, int32, float32, float64; `dim[0]` from 1 to 7 with every size past the third equal
//! to 1. Scaling: when `scl_slope` is finite and non-zero and (slope, intercept) is not (1, 0),
//! the image returned holds `slope · stored + intercept` as float32 (float64 for float64 data),
//! as ITK does.
//!
//! The writer writes little-endian NIfTI-1 (gzip-compressed for a `.gz` path) with both the
//! sform and the qform set (code 1, scanner), so ITK and nibabel read back the same geometry;
//! when the direction is not a rotation or a reflection, only the sform is written. NIfTI stores
//! geometry as float32, so it comes back to float32 precision.
//!
//! Ours rather than the `nifti` crate (0.18), measured in BENCHMARKS.md ("io: our readers
//! against the crates"): the crate gives the header and the voxels but no world geometry (its
//! affine is RAS, behind an nalgebra feature), so the sform/qform-to-LPS code above would stay;
//! it reads a .nii in 1.8 times our time and a .nii.gz in the same time; on the regression files
//! and 2000 mutations both readers had no panic, abort or hang.

use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

use glam::{DMat3, DVec3};

use flate2::read::MultiGzDecoder;

use super::compression::{check_ratio, gzip};
use super::files;
use super::progress::{ReadStage, Reported};
use super::text_header::{byte_count, geometry, geometry_from_axes, has_suffix};
use crate::error::{Error, Result};
use crate::geometry::Geometry;
use crate::volume::{Image, Scalar, ScalarType, VoxelBuffer};

const HEADER_BYTES: usize = 348;
const GZIP_MAGIC: [u8; 2] = [0x1f, 0x8b];
/// The header plus the four-byte extension flag: where single-file data starts at the earliest.
const DATA_OFFSET: usize = 352;
const NIFTI2_HEADER_BYTES: i32 = 540;
/// `xyzt_units` for millimetres.
const UNITS_MM: u8 = 2;
/// `qform_code`/`sform_code` for scanner coordinates.
const XFORM_SCANNER: i16 = 1;
/// How far from orthonormal a direction matrix may be and still be written as a quaternion.
const ROTATION_TOLERANCE: f64 = 1e-5;

const DATATYPES: [(i16, ScalarType); 8] = [
    (2, ScalarType::U8),
    (4, ScalarType::I16),
    (8, ScalarType::I32),
    (16, ScalarType::F32),
    (64, ScalarType::F64),
    (256, ScalarType::I8),
    (512, ScalarType::U16),
    (768, ScalarType::U32),
];

/// Reads a `.nii` or `.nii.gz` image, streaming its voxels from the file (through the
/// inflater) into the image's buffer: the read holds the voxels and a few buffers, never the
/// file's bytes beside them.
pub fn read(path: &Path) -> Result<Image> {
    let failed =
        |e: std::io::Error| Error::io(format!("{}: cannot read the file: {e}", path.display()));
    let file = File::open(path).map_err(failed)?;
    let size = file.metadata().map_err(failed)?.len();
    let mut buffered = BufReader::with_capacity(1 << 20, file);
    let gzipped = buffered
        .fill_buf()
        .map_err(failed)?
        .starts_with(&GZIP_MAGIC);
    let mut source = Reported::new(buffered, size, ReadStage::Reading);
    decode_from(&mut source, gzipped, size).map_err(|e| e.context(path.display()))
}

/// Writes `image` as NIfTI-1, gzip-compressed when the path ends with `.gz`.
pub fn write(path: &Path, image: &Image) -> Result<()> {
    let nii = encode(image, true)?;
    let file = if has_suffix(path, "gz") {
        gzip(&nii)?
    } else {
        nii
    };
    files::write_all(path, &file)
}

/// Decodes a whole `.nii` or `.nii.gz` file held in memory.
#[cfg(test)]
pub(crate) fn decode(file: &[u8]) -> Result<Image> {
    let mut source = Reported::new(file, file.len() as u64, ReadStage::Reading);
    decode_from(
        &mut source,
        file.starts_with(&GZIP_MAGIC),
        file.len() as u64,
    )
}

/// Decodes a NIfTI-1 file of `size` bytes from `source`, through the inflater when `gzipped`.
fn decode_from<R: Read>(source: &mut Reported<R>, gzipped: bool, size: u64) -> Result<Image> {
    let decoded = if gzipped {
        decode_stream(&mut MultiGzDecoder::new(&mut *source), true, size)
    } else {
        decode_stream(&mut *source, false, size)
    };
    match source.cancelled() {
        Some(cancelled) => Err(cancelled),
        None => decoded,
    }
}

/// The header, then the voxels at `vox_offset`, read from the (inflated) stream of a file of
/// `size` bytes; sizes no file of that size can hold are refused before the voxels' buffer is
/// allocated.
fn decode_stream(stream: &mut impl Read, gzipped: bool, size: u64) -> Result<Image> {
    let corrupt = |e: std::io::Error| Error::format(format!("cannot read the file ({e})"));
    let mut head = Vec::with_capacity(HEADER_BYTES);
    stream
        .take(HEADER_BYTES as u64)
        .read_to_end(&mut head)
        .map_err(corrupt)?;
    let h = Header::parse(&head)?;
    let bytes = byte_count(h.dims, h.scalar)?;
    let needed = h
        .vox_offset
        .checked_add(bytes)
        .ok_or_else(|| Error::format(format!("vox_offset {} is impossibly large", h.vox_offset)))?;
    let truncated = |held: u64| {
        Error::format(format!(
            "the voxel data holds {held} bytes but the header's sizes and type need {bytes}: the \
             file is truncated or its header is wrong"
        ))
    };
    if gzipped {
        check_ratio(usize::try_from(size).unwrap_or(usize::MAX), needed)?;
    } else if needed as u64 > size {
        return Err(truncated(size.saturating_sub(h.vox_offset as u64)));
    }
    let gap = (h.vox_offset - HEADER_BYTES) as u64;
    let skipped = std::io::copy(&mut stream.take(gap), &mut std::io::sink()).map_err(corrupt)?;
    if skipped < gap {
        return Err(truncated(0));
    }
    let count = h.dims.iter().product();
    let buffer = VoxelBuffer::read_from(h.scalar, count, h.little_endian, stream)?;
    let buffer = match h.scaling() {
        Some((slope, intercept)) => rescale(&buffer, slope, intercept),
        None => buffer,
    };
    Image::new(buffer, h.dims, h.geometry()?)
}

/// A header field reader for one byte order.
struct Fields<'a> {
    bytes: &'a [u8],
    little_endian: bool,
}

impl Fields<'_> {
    fn array<const N: usize>(&self, offset: usize) -> [u8; N] {
        let mut a = [0; N];
        a.copy_from_slice(&self.bytes[offset..offset + N]);
        if !self.little_endian {
            a.reverse();
        }
        a
    }

    fn i16(&self, offset: usize) -> i16 {
        i16::from_le_bytes(self.array(offset))
    }

    fn f32(&self, offset: usize) -> f64 {
        f32::from_le_bytes(self.array(offset)) as f64
    }

    fn f32s<const N: usize>(&self, offset: usize) -> [f64; N] {
        std::array::from_fn(|i| self.f32(offset + 4 * i))
    }
}

/// What the reader uses of the 348-byte header.
struct Header {
    little_endian: bool,
    dims: [usize; 3],
    scalar: ScalarType,
    vox_offset: usize,
    pixdim: [f64; 8],
    scl_slope: f64,
    scl_inter: f64,
    qform_code: i16,
    sform_code: i16,
    quatern: [f64; 3],
    qoffset: [f64; 3],
    srow: [[f64; 4]; 3],
}

impl Header {
    fn parse(bytes: &[u8]) -> Result<Header> {
        let bytes = bytes.get(..HEADER_BYTES).ok_or_else(|| {
            Error::format(format!(
                "the file holds {} bytes, fewer than the {HEADER_BYTES} of a NIfTI-1 header",
                bytes.len()
            ))
        })?;
        let sizeof_hdr = i32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]);
        let little_endian = match (sizeof_hdr, sizeof_hdr.swap_bytes()) {
            (348, _) => true,
            (_, 348) => false,
            (NIFTI2_HEADER_BYTES, _) | (_, NIFTI2_HEADER_BYTES) => {
                return Err(Error::format(
                    "this is a NIfTI-2 file, which is not supported; save it as NIfTI-1",
                ))
            }
            _ => {
                return Err(Error::format(format!(
                    "sizeof_hdr is {sizeof_hdr}, not 348: not a NIfTI-1 file"
                )))
            }
        };
        match &bytes[344..348] {
            b"n+1\0" => {}
            b"ni1\0" => {
                return Err(Error::format(
                    "this is the header of a .hdr/.img pair (magic ni1); only single-file .nii \
                     is supported",
                ))
            }
            _ => {
                return Err(Error::format(
                    "the NIfTI-1 magic 'n+1' is missing (an Analyze 7.5 file?); only single-file \
                     NIfTI-1 is supported",
                ))
            }
        }
        let f = Fields {
            bytes,
            little_endian,
        };
        let dim: [i16; 8] = std::array::from_fn(|i| f.i16(40 + 2 * i));
        let rank = dim[0];
        if !(1..=7).contains(&rank) {
            return Err(Error::format(format!(
                "dim[0] is {rank}; it must be the number of dimensions, 1 to 7"
            )));
        }
        let rank = rank as usize;
        if let Some(d) = (1..=rank).find(|&d| dim[d] < 1) {
            return Err(Error::format(format!(
                "dim[{d}] is {}; every size must be at least 1",
                dim[d]
            )));
        }
        if let Some(d) = (4..=rank).find(|&d| dim[d] != 1) {
            let what = if d == 4 {
                "a time series; save one 3-D volume"
            } else {
                "several values per voxel, which is not supported"
            };
            return Err(Error::format(format!("dim[{d}] is {}: {what}", dim[d])));
        }
        let size = |d: usize| if d <= rank { dim[d] as usize } else { 1 };
        let datatype = f.i16(70);
        let scalar = DATATYPES
            .iter()
            .find(|(code, _)| *code == datatype)
            .map(|(_, t)| *t)
            .ok_or_else(|| {
                Error::format(format!(
                    "datatype {datatype} ({}) is not supported; use uint8, int8, uint16, int16, \
                     uint32, int32, float32 or float64",
                    datatype_name(datatype)
                ))
            })?;
        let vox_offset = f.f32(108);
        if !vox_offset.is_finite() {
            return Err(Error::format(format!("vox_offset is {vox_offset}")));
        }
        Ok(Header {
            little_endian,
            dims: [size(1), size(2), size(3)],
            scalar,
            // As nifti1_io does: data never starts inside the header.
            vox_offset: if vox_offset < HEADER_BYTES as f64 {
                DATA_OFFSET
            } else {
                vox_offset as usize
            },
            pixdim: f.f32s(76),
            scl_slope: f.f32(112),
            scl_inter: f.f32(116),
            qform_code: f.i16(252),
            sform_code: f.i16(254),
            quatern: f.f32s(256),
            qoffset: f.f32s(268),
            srow: [f.f32s(280), f.f32s(296), f.f32s(312)],
        })
    }

    /// The (slope, intercept) to apply, if any.
    fn scaling(&self) -> Option<(f64, f64)> {
        let slope = self.scl_slope;
        let intercept = if self.scl_inter.is_finite() {
            self.scl_inter
        } else {
            0.0
        };
        let identity = slope == 1.0 && intercept == 0.0;
        (slope.is_finite() && slope != 0.0 && !identity).then_some((slope, intercept))
    }

    fn geometry(&self) -> Result<Geometry> {
        // nifti1_io's rule: a non-positive pixdim means 1.
        let spacing: [f64; 3] = std::array::from_fn(|a| {
            let p = self.pixdim[a + 1];
            if p > 0.0 && p.is_finite() {
                p
            } else {
                1.0
            }
        });
        let sform = (self.sform_code > 0).then(|| {
            let axes: [[f64; 3]; 3] = std::array::from_fn(|a| {
                ras_to_lps([self.srow[0][a], self.srow[1][a], self.srow[2][a]])
            });
            let origin = ras_to_lps([self.srow[0][3], self.srow[1][3], self.srow[2][3]]);
            (axes, origin)
        });
        if let Some((axes, origin)) = sform {
            let lengths = axes.map(|v| DVec3::from_array(v).length());
            if (0..3).all(|a| (lengths[a] - spacing[a]).abs() <= SFORM_SCALE_TOLERANCE) {
                return geometry_from_axes(axes, origin);
            }
            // "Unexpected scales in sform": ITK keeps pixdim's spacing, and the sform's
            // direction only when its columns, normalised, are orthonormal.
            if let Some(direction) = orthonormal_columns(axes) {
                return geometry(spacing, origin, direction);
            }
        }
        if self.qform_code > 0 {
            let r = quaternion_to_rotation(self.quatern);
            let qfac = if self.pixdim[0] < 0.0 { -1.0 } else { 1.0 };
            let scale = DVec3::new(spacing[0], spacing[1], spacing[2] * qfac);
            let m = r * DMat3::from_diagonal(scale);
            let axes = [m.x_axis, m.y_axis, m.z_axis].map(|c| ras_to_lps(c.to_array()));
            geometry_from_axes(axes, ras_to_lps(self.qoffset))
        } else {
            geometry(spacing, [0.0; 3], [1., 0., 0., 0., 1., 0., 0., 0., 1.])
        }
    }
}

fn datatype_name(code: i16) -> &'static str {
    match code {
        1 => "binary",
        32 => "complex64",
        128 => "RGB24",
        1024 => "int64",
        1280 => "uint64",
        1536 => "float128",
        1792 => "complex128",
        2048 => "complex256",
        2304 => "RGBA32",
        _ => "unknown",
    }
}

/// How far (mm) the length of an sform column may be from `pixdim` for the sform to be taken
/// as it is: ITK's tolerance, as the sform is stored in float32.
const SFORM_SCALE_TOLERANCE: f64 = 1e-3;

/// The direction matrix (row-major) of the columns `axes` normalised, when they are finite,
/// non-zero and orthonormal within ITK's tolerance (1e-4).
fn orthonormal_columns(axes: [[f64; 3]; 3]) -> Option<[f64; 9]> {
    let columns = axes.map(|v| DVec3::from_array(v).try_normalize());
    let [x, y, z] = [columns[0]?, columns[1]?, columns[2]?];
    let m = DMat3::from_cols(x, y, z);
    let off = (m * m.transpose() - DMat3::IDENTITY).to_cols_array();
    if off.iter().any(|e| e.abs() > 1e-4) {
        return None;
    }
    Some(m.transpose().to_cols_array())
}

/// NIfTI's RAS world to ITK's LPS (and back: the map is its own inverse).
fn ras_to_lps(v: [f64; 3]) -> [f64; 3] {
    [-v[0], -v[1], v[2]]
}

fn rescale(buffer: &VoxelBuffer, slope: f64, intercept: f64) -> VoxelBuffer {
    fn to_f32<T: Scalar>(v: &[T], slope: f64, intercept: f64) -> VoxelBuffer {
        VoxelBuffer::F32(
            v.iter()
                .map(|x| (x.to_f64() * slope + intercept) as f32)
                .collect(),
        )
    }
    match buffer {
        VoxelBuffer::U8(v) => to_f32(v, slope, intercept),
        VoxelBuffer::I8(v) => to_f32(v, slope, intercept),
        VoxelBuffer::U16(v) => to_f32(v, slope, intercept),
        VoxelBuffer::I16(v) => to_f32(v, slope, intercept),
        VoxelBuffer::U32(v) => to_f32(v, slope, intercept),
        VoxelBuffer::I32(v) => to_f32(v, slope, intercept),
        VoxelBuffer::F32(v) => to_f32(v, slope, intercept),
        VoxelBuffer::F64(v) => VoxelBuffer::F64(v.iter().map(|x| x * slope + intercept).collect()),
    }
}

/// The rotation of the unit quaternion (a, b, c, d) with a ≥ 0 derived from (b, c, d), as
/// nifti1_io computes it.
fn quaternion_to_rotation([b, c, d]: [f64; 3]) -> DMat3 {
    let mut a = 1.0 - (b * b + c * c + d * d);
    let (mut b, mut c, mut d) = (b, c, d);
    if a < 1e-7 {
        // Not a unit quaternion: normalise (b, c, d), a 180° rotation.
        let n = (b * b + c * c + d * d).sqrt();
        (b, c, d) = (b / n, c / n, d / n);
        a = 0.0;
    } else {
        a = a.sqrt();
    }
    DMat3::from_cols_array(&[
        a * a + b * b - c * c - d * d,
        2.0 * (b * c + a * d),
        2.0 * (b * d - a * c),
        2.0 * (b * c - a * d),
        a * a + c * c - b * b - d * d,
        2.0 * (c * d + a * b),
        2.0 * (b * d + a * c),
        2.0 * (c * d - a * b),
        a * a + d * d - c * c - b * b,
    ])
}

/// The (b, c, d) of the rotation `r` (a ≥ 0), as nifti1_io's `mat44_to_quatern` does it.
fn rotation_to_quaternion(r: DMat3) -> [f64; 3] {
    let e = |row: usize, col: usize| r.col(col)[row];
    let trace = e(0, 0) + e(1, 1) + e(2, 2) + 1.0;
    let (a, b, c, d);
    if trace > 0.5 {
        a = 0.5 * trace.sqrt();
        b = 0.25 * (e(2, 1) - e(1, 2)) / a;
        c = 0.25 * (e(0, 2) - e(2, 0)) / a;
        d = 0.25 * (e(1, 0) - e(0, 1)) / a;
    } else {
        let xd = 1.0 + e(0, 0) - (e(1, 1) + e(2, 2));
        let yd = 1.0 + e(1, 1) - (e(0, 0) + e(2, 2));
        let zd = 1.0 + e(2, 2) - (e(0, 0) + e(1, 1));
        if xd > 1.0 {
            b = 0.5 * xd.sqrt();
            c = 0.25 * (e(0, 1) + e(1, 0)) / b;
            d = 0.25 * (e(0, 2) + e(2, 0)) / b;
            a = 0.25 * (e(2, 1) - e(1, 2)) / b;
        } else if yd > 1.0 {
            c = 0.5 * yd.sqrt();
            b = 0.25 * (e(0, 1) + e(1, 0)) / c;
            d = 0.25 * (e(1, 2) + e(2, 1)) / c;
            a = 0.25 * (e(0, 2) - e(2, 0)) / c;
        } else {
            d = 0.5 * zd.sqrt();
            b = 0.25 * (e(0, 2) + e(2, 0)) / d;
            c = 0.25 * (e(1, 2) + e(2, 1)) / d;
            a = 0.25 * (e(1, 0) - e(0, 1)) / d;
        }
    }
    if a < 0.0 {
        [-b, -c, -d]
    } else {
        [b, c, d]
    }
}

/// The qform of a direction matrix: (quaternion b c d, qfac) when `D` (in RAS) is a rotation or
/// a rotation with its k axis flipped.
fn qform(direction_ras: DMat3) -> Option<([f64; 3], f64)> {
    let qfac = if direction_ras.determinant() < 0.0 {
        -1.0
    } else {
        1.0
    };
    let r = DMat3::from_cols(
        direction_ras.x_axis,
        direction_ras.y_axis,
        direction_ras.z_axis * qfac,
    );
    let error = (r.transpose() * r - DMat3::IDENTITY)
        .to_cols_array()
        .iter()
        .fold(0.0f64, |m, x| m.max(x.abs()));
    (error <= ROTATION_TOLERANCE).then(|| (rotation_to_quaternion(r), qfac))
}

/// A header field writer for one byte order.
struct Writer {
    bytes: Vec<u8>,
    little_endian: bool,
}

impl Writer {
    fn put(&mut self, offset: usize, le_bytes: &[u8]) {
        let field = &mut self.bytes[offset..offset + le_bytes.len()];
        field.copy_from_slice(le_bytes);
        if !self.little_endian {
            field.reverse();
        }
    }

    fn i16(&mut self, offset: usize, v: i16) {
        self.put(offset, &v.to_le_bytes());
    }

    fn f32s(&mut self, offset: usize, values: &[f64]) {
        for (i, v) in values.iter().enumerate() {
            self.put(offset + 4 * i, &(*v as f32).to_le_bytes());
        }
    }
}

/// The `.nii` bytes of `image` (big-endian only for tests of the reader).
fn encode(image: &Image, little_endian: bool) -> Result<Vec<u8>> {
    let dims = image.dims();
    let dim = |a: usize| {
        i16::try_from(dims[a]).map_err(|_| {
            Error::invalid_argument(format!(
                "NIfTI-1 sizes are at most {}; {dims:?} is too large, write .mha or .nrrd instead",
                i16::MAX
            ))
        })
    };
    let scalar = image.scalar_type();
    let datatype = DATATYPES
        .iter()
        .find(|(_, t)| *t == scalar)
        .map_or(0, |(code, _)| *code);
    let g = image.geometry();
    let lps_to_ras = DMat3::from_diagonal(DVec3::new(-1.0, -1.0, 1.0));
    let affine = lps_to_ras * g.index_to_world_matrix();
    let origin_ras = ras_to_lps(g.origin());
    let direction = lps_to_ras * DMat3::from_cols_array(&g.direction()).transpose();
    let qform = qform(direction);

    let mut w = Writer {
        bytes: vec![0; DATA_OFFSET],
        little_endian,
    };
    w.put(0, &(HEADER_BYTES as i32).to_le_bytes());
    for (i, d) in [3, dim(0)?, dim(1)?, dim(2)?, 1, 1, 1, 1]
        .into_iter()
        .enumerate()
    {
        w.i16(40 + 2 * i, d);
    }
    w.i16(70, datatype);
    w.i16(72, 8 * scalar.size_in_bytes() as i16);
    let qfac = qform.map_or(1.0, |(_, qfac)| qfac);
    // The lengths of the sform's columns: the spacing, unless the direction's columns are not
    // unit vectors (a sheared direction may come that way), which readers would otherwise take
    // for an sform with unexpected scales.
    let s = [affine.x_axis, affine.y_axis, affine.z_axis].map(|c| c.length());
    w.f32s(76, &[qfac, s[0], s[1], s[2], 1.0, 1.0, 1.0, 1.0]);
    w.f32s(108, &[DATA_OFFSET as f64, 1.0, 0.0]);
    w.bytes[123] = UNITS_MM;
    w.bytes[148..158].copy_from_slice(b"balloonseg");
    if let Some((quatern, _)) = qform {
        w.i16(252, XFORM_SCANNER);
        w.f32s(256, &quatern);
    }
    w.f32s(268, &origin_ras);
    w.i16(254, XFORM_SCANNER);
    for (row, t) in origin_ras.iter().enumerate() {
        let r = affine.row(row);
        w.f32s(280 + 16 * row, &[r.x, r.y, r.z, *t]);
    }
    w.bytes[344..348].copy_from_slice(b"n+1\0");

    let mut data = image.buffer().to_le_bytes();
    if !little_endian {
        for v in data.chunks_exact_mut(scalar.size_in_bytes()) {
            v.reverse();
        }
    }
    let mut file = w.bytes;
    file.extend_from_slice(&data);
    Ok(file)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::test_images::{
        assert_geometry_close, assert_never_panics, assert_same_voxels, oblique_geometry,
        pattern_image, scratch_dir,
    };

    /// NIfTI stores geometry as float32.
    const FLOAT32_ROUNDING: f64 = 1e-6;

    fn set_i16(file: &mut [u8], offset: usize, v: i16) {
        file[offset..offset + 2].copy_from_slice(&v.to_le_bytes());
    }

    fn set_f32(file: &mut [u8], offset: usize, v: f32) {
        file[offset..offset + 4].copy_from_slice(&v.to_le_bytes());
    }

    #[test]
    fn every_scalar_type_round_trips_through_nii_and_nii_gz() {
        let dir = scratch_dir();
        for (n, scalar) in ScalarType::ALL.into_iter().enumerate() {
            let image = pattern_image(scalar, [5, 4, 3], oblique_geometry(), n as u64);
            for name in ["img.nii", "img.nii.gz"] {
                let path = dir.path().join(name);
                write(&path, &image).unwrap();
                let back = read(&path).unwrap();
                assert_same_voxels(&back, &image);
                assert_geometry_close(back.geometry(), image.geometry(), FLOAT32_ROUNDING);
            }
        }
        assert!(std::fs::read(dir.path().join("img.nii.gz"))
            .unwrap()
            .starts_with(&[0x1f, 0x8b]));
    }

    #[test]
    fn the_qform_alone_gives_the_same_left_handed_geometry() {
        let image = pattern_image(ScalarType::U8, [2, 2, 2], oblique_geometry(), 3);
        let mut file = encode(&image, true).unwrap();
        assert_eq!(
            f32::from_le_bytes(file[76..80].try_into().unwrap()),
            -1.0,
            "qfac"
        );
        set_i16(&mut file, 254, 0);
        let back = decode(&file).unwrap();
        assert_geometry_close(back.geometry(), image.geometry(), FLOAT32_ROUNDING);
    }

    #[test]
    fn quaternions_and_rotations_convert_both_ways() {
        for (axis, angle) in [
            (DVec3::X, 0.0),
            (DVec3::new(1.0, -2.0, 0.5), 2.9),
            (DVec3::Z, std::f64::consts::PI),
            (DVec3::Y, 3.1),
        ] {
            let r = DMat3::from_axis_angle(axis.normalize(), angle);
            let back = quaternion_to_rotation(rotation_to_quaternion(r));
            assert!(
                (back - r).to_cols_array().iter().all(|e| e.abs() < 1e-12),
                "{axis} {angle}"
            );
        }
    }

    #[test]
    fn a_sheared_direction_is_written_as_an_sform_only() {
        let g = Geometry::new(
            [1.0, 2.0, 3.0],
            [4.0, 5.0, 6.0],
            [1., 0.5, 0., 0., 1., 0., 0., 0., 1.],
        )
        .unwrap();
        let image = pattern_image(ScalarType::I16, [2, 3, 2], g, 4);
        let file = encode(&image, true).unwrap();
        assert_eq!(i16::from_le_bytes([file[252], file[253]]), 0, "qform_code");
        let back = decode(&file).unwrap();
        let expected = g.index_to_world_matrix().to_cols_array();
        let actual = back.geometry().index_to_world_matrix().to_cols_array();
        assert!(expected
            .iter()
            .zip(&actual)
            .all(|(e, a)| (e - a).abs() < 1e-6));
    }

    #[test]
    fn an_sform_whose_scales_are_not_pixdim_gives_pixdim_as_itk_does() {
        // ITK warns "unexpected scales in sform" and keeps pixdim's spacing, with the sform's
        // origin and normalised columns when they are orthonormal, else the qform.
        let image = pattern_image(ScalarType::U8, [2, 2, 2], oblique_geometry(), 7);
        let mut file = encode(&image, true).unwrap();
        for row in 0..3 {
            let at = 280 + 16 * row + 8;
            let v = f32::from_le_bytes(file[at..at + 4].try_into().unwrap());
            set_f32(&mut file, at, v * 1e-9);
        }
        let g = *decode(&file).unwrap().geometry();
        assert_geometry_close(&g, image.geometry(), FLOAT32_ROUNDING);
        // Sheared as well: the qform (the same geometry here).
        set_f32(&mut file, 280 + 4, 0.7);
        let g = *decode(&file).unwrap().geometry();
        assert_geometry_close(&g, image.geometry(), FLOAT32_ROUNDING);
    }

    #[test]
    fn big_endian_files_read() {
        let image = pattern_image(ScalarType::F64, [3, 2, 2], oblique_geometry(), 5);
        let back = decode(&encode(&image, false).unwrap()).unwrap();
        assert_same_voxels(&back, &image);
        assert_geometry_close(back.geometry(), image.geometry(), FLOAT32_ROUNDING);
    }

    #[test]
    fn without_any_transform_the_direction_is_the_identity_as_in_itk() {
        // SimpleITK reads nibabel's file with qform_code = sform_code = 0 and pixdim (0.5, 2, 3)
        // as spacing (0.5, 2, 3), origin 0, identity direction.
        let image = pattern_image(ScalarType::I16, [4, 3, 2], oblique_geometry(), 6);
        let mut file = encode(&image, true).unwrap();
        set_i16(&mut file, 252, 0);
        set_i16(&mut file, 254, 0);
        for (i, p) in [0.5, 2.0, 3.0].into_iter().enumerate() {
            set_f32(&mut file, 80 + 4 * i, p);
        }
        let g = *decode(&file).unwrap().geometry();
        assert_eq!(
            g,
            Geometry::with_spacing([0.5, 2.0, 3.0], [0.0; 3]).unwrap()
        );
    }

    #[test]
    fn scaled_integers_become_float32() {
        let g = Geometry::identity();
        let image = Image::new(VoxelBuffer::I16(vec![-2, 0, 7, 100]), [2, 2, 1], g).unwrap();
        let mut file = encode(&image, true).unwrap();
        set_f32(&mut file, 112, 0.5);
        set_f32(&mut file, 116, -1024.0);
        let back = decode(&file).unwrap();
        assert_eq!(
            back.buffer(),
            &VoxelBuffer::F32(vec![-1025.0, -1024.0, -1020.5, -974.0])
        );
        // Slope 0 means "no scaling"; so does (1, 0).
        set_f32(&mut file, 112, 0.0);
        assert_eq!(decode(&file).unwrap().buffer(), image.buffer());
    }

    #[test]
    fn unsupported_headers_say_what_is_wrong() {
        let image = pattern_image(ScalarType::U8, [2, 2, 2], Geometry::identity(), 7);
        let good = encode(&image, true).unwrap();
        let check = |file: &[u8], expected: &str| {
            let e = decode(file).unwrap_err();
            assert_eq!(e.kind(), crate::ErrorKind::Format);
            assert!(e.message().contains(expected), "{expected}: {e}");
        };
        let fields: [(&[(usize, i16)], &str); 6] = [
            (&[(40, 4), (48, 0)], "dim[4] is 0"),
            (&[(40, 4), (48, 5)], "dim[4] is 5: a time series"),
            (&[(40, 5), (50, 3)], "dim[5] is 3"),
            (&[(40, 9)], "dim[0] is 9"),
            (&[(70, 128)], "datatype 128 (RGB24)"),
            (&[(44, 30000)], "need"),
        ];
        for (edits, expected) in fields {
            let mut file = good.clone();
            for &(offset, value) in edits {
                set_i16(&mut file, offset, value);
            }
            check(&file, expected);
        }
        let mut file = good.clone();
        file[0..4].copy_from_slice(&540i32.to_le_bytes());
        check(&file, "NIfTI-2");
        let mut file = good.clone();
        file[344..348].copy_from_slice(b"ni1\0");
        check(&file, ".hdr/.img");
        check(&good[..356], "holds 4 bytes but");
        check(&[0; 100], "fewer than the 348");
        let huge = pattern_image(ScalarType::U8, [40000, 1, 1], Geometry::identity(), 8);
        assert_eq!(
            encode(&huge, true).unwrap_err().kind(),
            crate::ErrorKind::InvalidArgument
        );
    }

    #[test]
    fn truncated_or_corrupted_files_never_panic() {
        let image = pattern_image(ScalarType::U16, [3, 4, 2], oblique_geometry(), 8);
        let nii = encode(&image, true).unwrap();
        let gz = gzip(&nii).unwrap();
        for file in [nii, gz] {
            assert_never_panics(&file, &image, decode);
        }
    }
}
