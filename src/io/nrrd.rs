//! NRRD (`.nrrd` with attached data, `.nhdr` with `data file:`) reading and writing, with the
//! geometry ITK's NrrdImageIO gives.
//!
//! `space directions` are per-axis world vectors that include the spacing (spacing = length,
//! direction column = normalised vector), `space origin` is the world position of voxel (0,0,0).
//! World coordinates are turned into LPS: `right-anterior-superior` negates x and y,
//! `left-anterior-superior` negates y; LPS, `scanner-xyz`, `3D-right-handed`/`-left-handed` and a
//! bare `space dimension: 3` are taken as they are. Without space directions, `spacings` give the
//! spacing and `axis mins` the origin (shifted by half a voxel unless `centers: node`, as ITK
//! does). Dimension 3; dimension 2 becomes one slice; dimension 4 is accepted when its extra
//! (non-spatial: no space direction, or the first without any) axis has size 1.
//!
//! Encodings raw and gzip (`gz`), either endianness, `byte skip` (-1: the data ends the file, raw
//! only) and `line skip`; `data file: LIST` with one file name per line. Types: the NRRD names of
//! the 8- to 32-bit integers, float and double.
//!
//! The writer writes gzip-encoded data in `left-posterior-superior` space, after the header for
//! `.nrrd`, in `<stem>.raw.gz` beside a `.nhdr`.

use std::borrow::Cow;
use std::path::Path;

use super::compression::{gzip, stream_voxels, VoxelData};
use super::files::{self, HeaderPrefix};
use super::text_header::{
    axes_of, beside, byte_count, concatenate_parts, fmt_list, geometry, geometry_from_axes,
    has_suffix, line_at, lines_from, number, numbers, sizes, take_bytes, Described,
};
use crate::error::{Error, Result};
use crate::geometry::Geometry;
use crate::volume::{Image, ScalarType};

/// NRRD's type names (teem's equivalents), the first of each type being the one written.
const TYPES: [(&str, ScalarType); 32] = [
    ("uint8", ScalarType::U8),
    ("uchar", ScalarType::U8),
    ("unsigned char", ScalarType::U8),
    ("uint8_t", ScalarType::U8),
    ("int8", ScalarType::I8),
    ("signed char", ScalarType::I8),
    ("int8_t", ScalarType::I8),
    ("uint16", ScalarType::U16),
    ("ushort", ScalarType::U16),
    ("unsigned short", ScalarType::U16),
    ("unsigned short int", ScalarType::U16),
    ("uint16_t", ScalarType::U16),
    ("int16", ScalarType::I16),
    ("short", ScalarType::I16),
    ("short int", ScalarType::I16),
    ("signed short", ScalarType::I16),
    ("signed short int", ScalarType::I16),
    ("int16_t", ScalarType::I16),
    ("uint32", ScalarType::U32),
    ("uint", ScalarType::U32),
    ("unsigned int", ScalarType::U32),
    ("uint32_t", ScalarType::U32),
    ("int32", ScalarType::I32),
    ("int", ScalarType::I32),
    ("signed int", ScalarType::I32),
    ("int32_t", ScalarType::I32),
    ("float", ScalarType::F32),
    ("double", ScalarType::F64),
    // Names the writer never uses but files do.
    ("unsigned long int", ScalarType::U32),
    ("long int", ScalarType::I32),
    ("float32", ScalarType::F32),
    ("float64", ScalarType::F64),
];

/// Reads a `.nrrd` or `.nhdr` image. Voxels attached after the header (with no `line skip`,
/// and a `byte skip` other than -1) are streamed from the file into the image's buffer, through
/// the inflater when gzip-encoded, so that the file's bytes are never held beside them; other
/// layouts are read whole.
pub fn read(path: &Path) -> Result<Image> {
    let prefix = HeaderPrefix::open(path)?;
    // The header must end, its blank line with its line feed, inside the bytes read so far.
    let attached = Header::parse(&prefix.bytes).ok().and_then(|h| {
        let start = h.data_start.filter(|&start| start < prefix.bytes.len())?;
        let skip = h
            .parsed::<usize>("byteskip", "byte skip")
            .ok()?
            .unwrap_or(0);
        let lines = h
            .parsed::<usize>("lineskip", "line skip")
            .ok()?
            .unwrap_or(0);
        (h.get("datafile").is_none() && lines == 0).then_some((h, start, skip))
    });
    let (Some((h, start, skip)), false) = (attached, prefix.is_whole_file()) else {
        drop(prefix);
        return files::parse_file(path, |bytes| decode(bytes, path));
    };
    let context = |e: Error| e.context(path.display());
    let d = describe(&h).map_err(context)?;
    let compressed = is_gzip(&h).map_err(context)?;
    let count = d.voxel_count().map_err(context)?;
    let (data, len) = prefix.data_from(start)?;
    let buffer = stream_voxels(
        data,
        len,
        compressed,
        skip,
        d.scalar,
        count,
        d.little_endian,
    )
    .map_err(context)?;
    Image::new(buffer, d.dims, d.geometry)
}

/// Writes `image` gzip-encoded in LPS space: after the header for `.nrrd`, in a `.raw.gz` file
/// beside a `.nhdr` path.
pub fn write(path: &Path, image: &Image) -> Result<()> {
    let data = gzip(&image.buffer().to_le_bytes())?;
    if has_suffix(path, "nhdr") {
        let stem = path.file_stem().unwrap_or_default().to_string_lossy();
        let data_name = format!("{stem}.raw.gz");
        files::write_all(&beside(path, &data_name), &data)?;
        let header = header_text(image) + &format!("data file: {data_name}\n");
        files::write_all(path, header.as_bytes())
    } else {
        let mut file = (header_text(image) + "\n").into_bytes();
        file.extend_from_slice(&data);
        files::write_all(path, &file)
    }
}

fn header_text(image: &Image) -> String {
    let g = image.geometry();
    let directions: Vec<String> = axes_of(g)
        .iter()
        .map(|v| format!("({})", fmt_list(v, ",")))
        .collect();
    let type_name = TYPES
        .iter()
        .find(|(_, t)| *t == image.scalar_type())
        .map_or("block", |(name, _)| name);
    let [nx, ny, nz] = image.dims();
    format!(
        "NRRD0004\n# Complete NRRD file format specification at:\n\
         # http://teem.sourceforge.net/nrrd/format.html\n\
         type: {type_name}\ndimension: 3\nspace: left-posterior-superior\nsizes: {nx} {ny} {nz}\n\
         space directions: {}\nkinds: domain domain domain\nendian: little\nencoding: gzip\n\
         space origin: ({})\n",
        directions.join(" "),
        fmt_list(&g.origin(), ","),
    )
}

/// The header fields (keys lower case without spaces, so `data file` and `datafile` agree),
/// where attached data starts, and the file names after `data file: LIST`.
struct Header {
    fields: Vec<(String, String)>,
    data_start: Option<usize>,
    list: Vec<String>,
}

impl Header {
    fn parse(bytes: &[u8]) -> Result<Header> {
        let magic = line_at(bytes, 0).map(|l| l.text.trim().to_string());
        let Some(first) = line_at(bytes, 0).filter(|l| {
            l.text
                .trim()
                .strip_prefix("NRRD000")
                .is_some_and(|v| matches!(v, "1" | "2" | "3" | "4" | "5"))
        }) else {
            return Err(Error::format(format!(
                "the file starts with '{}', not NRRD0001..NRRD0005: not a NRRD file",
                magic
                    .unwrap_or_default()
                    .chars()
                    .take(20)
                    .collect::<String>()
            )));
        };
        let mut header = Header {
            fields: Vec::new(),
            data_start: None,
            list: Vec::new(),
        };
        let mut pos = first.next;
        let mut line_number = 1;
        while let Some(line) = line_at(bytes, pos) {
            line_number += 1;
            pos = line.next;
            let text = line.text.trim();
            if text.is_empty() {
                header.data_start = Some(pos);
                break;
            }
            if text.starts_with('#') {
                continue;
            }
            let Some((key, value)) = text.split_once(':') else {
                let start: String = text.chars().take(40).collect();
                return Err(Error::format(format!(
                    "header line {line_number} ('{start}') is not 'field: value'"
                )));
            };
            if value.starts_with('=') {
                // A `key:=value` pair: free-form metadata.
                continue;
            }
            let key: String = key.to_ascii_lowercase().split_whitespace().collect();
            let value = value.trim().to_string();
            let is_list = key == "datafile" && value.split_whitespace().next() == Some("LIST");
            header.fields.push((key, value));
            if is_list {
                // The names of the data files take up the rest of the header.
                header.list = lines_from(bytes, pos);
                break;
            }
        }
        Ok(header)
    }

    fn get(&self, key: &str) -> Option<&str> {
        self.fields
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    fn require(&self, key: &str, name: &str) -> Result<&str> {
        self.get(key).ok_or_else(|| {
            Error::format(format!(
                "the header has no '{name}' field, which NRRD requires"
            ))
        })
    }

    fn parsed<T: std::str::FromStr>(&self, key: &str, name: &str) -> Result<Option<T>> {
        self.get(key).map(|v| number(name, v)).transpose()
    }
}

pub(crate) fn decode(bytes: &[u8], path: &Path) -> Result<Image> {
    let h = Header::parse(bytes)?;
    let d = describe(&h)?;
    let expected = byte_count(d.dims, d.scalar)?;
    let buffer = voxel_data(&h, bytes, path, expected)?.into_buffer(d.scalar, d.little_endian)?;
    Image::new(buffer, d.dims, d.geometry)
}

fn describe(h: &Header) -> Result<Described> {
    let type_name = h.require("type", "type")?;
    let scalar = TYPES
        .iter()
        .find(|(name, _)| name.eq_ignore_ascii_case(type_name))
        .map(|(_, t)| *t)
        .ok_or_else(|| {
            Error::format(format!(
                "type: {type_name} is not supported; use an 8-, 16- or 32-bit integer type, \
                 float or double"
            ))
        })?;
    let dimension: usize = number("dimension", h.require("dimension", "dimension")?)?;
    if !(2..=4).contains(&dimension) {
        return Err(Error::format(format!(
            "dimension: {dimension}: only 2-D and 3-D images (and 4-D with one sample along the \
             extra axis) are supported"
        )));
    }
    let all_sizes = sizes("sizes", h.require("sizes", "sizes")?, dimension)?;
    let space = Space::of(h)?;
    let directions = match h.get("spacedirections") {
        Some(value) => Some(space_directions(value, dimension, space.dimension)?),
        None => None,
    };
    let spatial = spatial_axes(&all_sizes, directions.as_deref())?;
    let dims = [
        all_sizes[spatial[0]],
        all_sizes[spatial[1]],
        spatial.get(2).map_or(1, |&a| all_sizes[a]),
    ];
    let geometry = read_geometry(h, &space, directions.as_deref(), &spatial, dimension)?;
    let little_endian = match h.get("endian") {
        Some(e) if e.eq_ignore_ascii_case("little") => true,
        Some(e) if e.eq_ignore_ascii_case("big") => false,
        Some(e) => {
            return Err(Error::format(format!(
                "endian: {e}: expected little or big"
            )))
        }
        None if scalar.size_in_bytes() == 1 => true,
        None => {
            return Err(Error::format(format!(
                "the header has no 'endian' field, which {} data needs",
                scalar.name()
            )))
        }
    };
    Ok(Described {
        dims,
        scalar,
        little_endian,
        geometry,
    })
}

/// The world frame of the header: its dimension and which axes to negate to reach LPS.
struct Space {
    dimension: usize,
    negate: [bool; 3],
}

impl Space {
    fn of(h: &Header) -> Result<Space> {
        let Some(name) = h.get("space") else {
            let dimension = h.parsed("spacedimension", "space dimension")?.unwrap_or(0);
            if !matches!(dimension, 0 | 2 | 3) {
                return Err(Error::format(format!(
                    "space dimension: {dimension}: only 2 and 3 are supported"
                )));
            }
            return Ok(Space {
                dimension,
                negate: [false; 3],
            });
        };
        let negate = match name.to_ascii_lowercase().as_str() {
            "right-anterior-superior" | "ras" => [true, true, false],
            "left-anterior-superior" | "las" => [false, true, false],
            "left-posterior-superior"
            | "lps"
            | "scanner-xyz"
            | "3d-right-handed"
            | "3d-left-handed" => [false; 3],
            _ => {
                return Err(Error::format(format!(
                    "space: {name} is not supported; use a 3-D space such as \
                     left-posterior-superior or right-anterior-superior (time series are not \
                     supported)"
                )))
            }
        };
        Ok(Space {
            dimension: 3,
            negate,
        })
    }

    fn to_lps(&self, v: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|i| if self.negate[i] { -v[i] } else { v[i] })
    }
}

/// `dimension` entries, each a vector of `space_dimension` numbers `(x,y,z)` or `none`.
fn space_directions(
    value: &str,
    dimension: usize,
    space_dimension: usize,
) -> Result<Vec<Option<[f64; 3]>>> {
    if space_dimension == 0 {
        return Err(Error::format(
            "space directions are given without a space or space dimension field",
        ));
    }
    let mut entries = Vec::new();
    let mut rest = value.trim();
    while !rest.is_empty() {
        if let Some(after) = rest.strip_prefix("none") {
            entries.push(None);
            rest = after.trim_start();
            continue;
        }
        let inner = rest
            .strip_prefix('(')
            .and_then(|r| r.split_once(')'))
            .ok_or_else(|| {
                Error::format(format!(
                    "space directions: '{value}' must be vectors like (1,0,0) or 'none'"
                ))
            })?;
        let v: Vec<f64> = inner
            .0
            .split(',')
            .map(|c| number("space directions", c))
            .collect::<Result<_>>()?;
        if v.len() != space_dimension {
            return Err(Error::format(format!(
                "space directions: ({}) has {} components but the space has {space_dimension}",
                inner.0,
                v.len()
            )));
        }
        entries.push(Some([v[0], v[1], v.get(2).copied().unwrap_or(0.0)]));
        rest = inner.1.trim_start();
    }
    if entries.len() != dimension {
        return Err(Error::format(format!(
            "space directions needs {dimension} entries, found {}",
            entries.len()
        )));
    }
    Ok(entries)
}

/// Which axes are the image's i, j (and k): those with a space direction, else all of a 2-D or
/// 3-D array and the last three of a 4-D one. Any other axis must have size 1.
fn spatial_axes(sizes: &[usize], directions: Option<&[Option<[f64; 3]>]>) -> Result<Vec<usize>> {
    let spatial: Vec<usize> = match directions {
        Some(d) => (0..sizes.len()).filter(|&a| d[a].is_some()).collect(),
        None => (sizes.len().saturating_sub(3)..sizes.len()).collect(),
    };
    if !(2..=3).contains(&spatial.len()) {
        return Err(Error::format(format!(
            "{} axes have a space direction; an image needs 2 or 3",
            spatial.len()
        )));
    }
    if let Some(a) = (0..sizes.len()).find(|a| !spatial.contains(a) && sizes[*a] != 1) {
        return Err(Error::format(format!(
            "axis {a} is not spatial and has {} samples: images with several values per voxel \
             or several time points are not supported; save one 3-D volume",
            sizes[a]
        )));
    }
    Ok(spatial)
}

fn read_geometry(
    h: &Header,
    space: &Space,
    directions: Option<&[Option<[f64; 3]>]>,
    spatial: &[usize],
    n: usize,
) -> Result<Geometry> {
    let origin = match h.get("spaceorigin") {
        Some(value) => {
            let inner = value
                .trim()
                .strip_prefix('(')
                .and_then(|r| r.strip_suffix(')'))
                .ok_or_else(|| {
                    Error::format(format!(
                        "space origin: '{value}' must be a vector like (0,0,0)"
                    ))
                })?;
            let v: Vec<f64> = inner
                .split(',')
                .map(|c| number("space origin", c))
                .collect::<Result<_>>()?;
            if v.len() != space.dimension {
                return Err(Error::format(format!(
                    "space origin: {value} has {} components but the space has {}",
                    v.len(),
                    space.dimension
                )));
            }
            Some(space.to_lps([v[0], v[1], v.get(2).copied().unwrap_or(0.0)]))
        }
        None => None,
    };
    if let Some(directions) = directions {
        let mut axes: Vec<[f64; 3]> = spatial
            .iter()
            .map(|&a| space.to_lps(directions[a].unwrap_or_default()))
            .collect();
        if axes.len() == 2 {
            // A single slice: its k axis is the unit normal of the slice plane.
            let normal = glam::DVec3::from(axes[0])
                .cross(glam::DVec3::from(axes[1]))
                .normalize_or_zero();
            axes.push(normal.to_array());
        }
        return geometry_from_axes([axes[0], axes[1], axes[2]], origin.unwrap_or_default());
    }
    let per_axis = |key: &str, name: &str| -> Result<Option<Vec<f64>>> {
        h.get(key).map(|v| numbers::<f64>(name, v, n)).transpose()
    };
    let spacings = per_axis("spacings", "spacings")?;
    let mins = per_axis("axismins", "axis mins")?;
    let centers: Vec<String> = h
        .get("centers")
        .or_else(|| h.get("centerings"))
        .map(|v| v.split_whitespace().map(str::to_ascii_lowercase).collect())
        .unwrap_or_default();
    let mut spacing = [1.0; 3];
    let mut from_mins = [0.0; 3];
    for (i, &a) in spatial.iter().enumerate() {
        if let Some(s) = spacings.as_ref().map(|s| s[a]).filter(|s| s.is_finite()) {
            spacing[i] = s.abs();
        }
        if let Some(m) = mins.as_ref().map(|m| m[a]).filter(|m| m.is_finite()) {
            // Cell centring (teem's default) puts the first sample half a voxel in.
            let node = centers.get(a).is_some_and(|c| c == "node");
            from_mins[i] = if node { m } else { m + spacing[i] / 2.0 };
        }
    }
    geometry(
        spacing,
        origin.unwrap_or(from_mins),
        [1., 0., 0., 0., 1., 0., 0., 0., 1.],
    )
}

/// The voxels' raw bytes, attached or from the data file(s), after `line skip` and `byte skip`.
fn voxel_data<'a>(
    h: &Header,
    bytes: &'a [u8],
    path: &Path,
    expected: usize,
) -> Result<VoxelData<'a>> {
    let compressed = is_gzip(h)?;
    let skip = Skip {
        lines: h.parsed("lineskip", "line skip")?.unwrap_or(0),
        bytes: h.parsed("byteskip", "byte skip")?.unwrap_or(0),
        compressed,
    };
    let Some(data_file) = h.get("datafile") else {
        let start = h.data_start.ok_or_else(|| {
            Error::format(
                "the header neither ends with a blank line before the data nor names a data file",
            )
        })?;
        return skip.apply(&bytes[start..], expected);
    };
    if data_file.split_whitespace().next() == Some("LIST") {
        let all = concatenate_parts(path, &h.list, expected, |file, part| {
            skip.apply(file, part)?.into_bytes()
        })?;
        return Ok(VoxelData::Raw(Cow::Owned(all)));
    }
    if data_file.contains('%') {
        return Err(Error::format(format!(
            "data file: {data_file}: numbered file patterns are not supported; use data file: \
             LIST with one file name per line"
        )));
    }
    let file = files::read(&beside(path, data_file))?;
    let part = skip
        .apply(&file, expected)
        .map_err(|e| e.context(data_file))?;
    Ok(part.into_owned())
}

/// Whether the data is gzip-encoded (else raw).
fn is_gzip(h: &Header) -> Result<bool> {
    let encoding = h.require("encoding", "encoding")?.to_ascii_lowercase();
    match encoding.as_str() {
        "raw" => Ok(false),
        "gzip" | "gz" => Ok(true),
        _ => Err(Error::format(format!(
            "encoding: {encoding} is not supported; use raw or gzip"
        ))),
    }
}

struct Skip {
    lines: usize,
    bytes: i64,
    compressed: bool,
}

impl Skip {
    /// `expected` voxel bytes from a data file (still compressed when they are): `line skip`
    /// lines of the file skipped, then `byte skip` bytes of the (decompressed) data.
    fn apply<'b>(&self, file: &'b [u8], expected: usize) -> Result<VoxelData<'b>> {
        let mut start = 0;
        for _ in 0..self.lines {
            start = line_at(file, start)
                .filter(|l| l.next > start && file[l.next - 1] == b'\n')
                .ok_or_else(|| {
                    Error::format(format!(
                        "line skip: {} is more lines than the data holds",
                        self.lines
                    ))
                })?
                .next;
        }
        let data = &file[start..];
        match (self.bytes, self.compressed) {
            (-1, false) => {
                let start = data.len().checked_sub(expected).ok_or_else(|| {
                    Error::format(format!(
                        "the data holds {} bytes but the header's sizes and type need {expected}",
                        data.len()
                    ))
                })?;
                Ok(VoxelData::Raw(Cow::Borrowed(&data[start..])))
            }
            (-1, true) => Err(Error::format(
                "byte skip: -1 (data at the end of the file) works only with raw encoding",
            )),
            (skip, compressed) => {
                let skip = usize::try_from(skip).map_err(|_| {
                    Error::format(format!("byte skip: {skip}: must be -1 or a byte count"))
                })?;
                let total = expected.checked_add(skip).ok_or_else(|| {
                    Error::format(format!("byte skip: {skip} is impossibly large"))
                })?;
                if compressed {
                    Ok(VoxelData::Compressed {
                        stream: Cow::Borrowed(data),
                        skip,
                        voxel_bytes: expected,
                    })
                } else {
                    take_bytes(data, total, "the voxel data")
                        .map(|d| VoxelData::Raw(Cow::Borrowed(&d[skip..])))
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::test_images::{
        assert_geometry_close, assert_never_panics, assert_same_voxels, oblique_geometry,
        pattern_image, scratch_dir,
    };
    use crate::volume::VoxelBuffer;

    /// Space directions carry spacing × direction, so the spacing read back is a vector length,
    /// equal to the one written up to rounding.
    const DIRECTION_ROUNDING: f64 = 1e-14;

    fn attached(header: &str, data: &[u8]) -> Vec<u8> {
        let mut file = header.as_bytes().to_vec();
        file.extend_from_slice(data);
        file
    }

    #[test]
    fn every_scalar_type_round_trips_through_nrrd_and_nhdr() {
        let dir = scratch_dir();
        for (n, scalar) in ScalarType::ALL.into_iter().enumerate() {
            let image = pattern_image(scalar, [5, 4, 3], oblique_geometry(), n as u64);
            for name in ["img.nrrd", "img.nhdr"] {
                let path = dir.path().join(name);
                write(&path, &image).unwrap();
                let back = read(&path).unwrap();
                assert_same_voxels(&back, &image);
                assert_geometry_close(back.geometry(), image.geometry(), DIRECTION_ROUNDING);
            }
        }
        // Axis-aligned geometries come back bit for bit.
        let g = Geometry::new(
            [0.878906, 0.878906, 1.50009],
            [-156.445, -24.6094, 0.0],
            [-1., 0., 0., 0., -1., 0., 0., 0., 1.],
        )
        .unwrap();
        let image = pattern_image(ScalarType::F32, [3, 2, 2], g, 9);
        let path = dir.path().join("aligned.nrrd");
        write(&path, &image).unwrap();
        assert_eq!(read(&path).unwrap(), image);
    }

    #[test]
    fn right_anterior_superior_space_is_turned_into_lps() {
        // pynrrd writes this file; SimpleITK reads origin (-1,-2,3), direction diag(-1,-1,1).
        let header = "NRRD0005\ntype: int16\ndimension: 3\nspace: right-anterior-superior\n\
                      sizes: 2 1 1\nspace directions: (0.5,0,0) (0,2,0) (0,0,3)\n\
                      DICOM_0008_0060:=MR\ncontent: a:=b\n\
                      endian: big\nencoding: raw\nspace origin: (1,2,3)\n\n";
        let image = decode(&attached(header, &[0, 1, 255, 254]), Path::new("x.nrrd")).unwrap();
        assert_eq!(image.buffer(), &VoxelBuffer::I16(vec![1, -2]));
        let g = image.geometry();
        assert_eq!(g.origin(), [-1.0, -2.0, 3.0]);
        assert_eq!(g.spacing(), [0.5, 2.0, 3.0]);
        assert_eq!(g.direction(), [-1., 0., 0., 0., -1., 0., 0., 0., 1.]);
    }

    #[test]
    fn oblique_space_directions_give_spacing_and_direction_columns() {
        let header = "NRRD0004\ntype: uchar\ndimension: 3\nspace: left-posterior-superior\n\
                      sizes: 1 1 1\nspace directions: (0, 2, 0) (-3,0,0) (0,0,0.5)\n\
                      encoding: raw\nspace origin: (1,2,3)\n\n";
        let g = *decode(&attached(header, &[5]), Path::new("x.nrrd"))
            .unwrap()
            .geometry();
        assert_eq!(g.spacing(), [2.0, 3.0, 0.5]);
        assert_eq!(g.direction(), [0., -1., 0., 1., 0., 0., 0., 0., 1.]);
        assert_eq!(g.origin(), [1.0, 2.0, 3.0]);
    }

    #[test]
    fn a_leading_axis_of_one_sample_and_type_aliases_are_accepted() {
        for (alias, scalar) in TYPES {
            let header = format!(
                "NRRD0004\ntype: {alias}\ndimension: 4\nsizes: 1 2 1 1\n\
                 space dimension: 3\nspace directions: none (1,0,0) (0,1,0) (0,0,1)\n\
                 kinds: list domain domain domain\nendian: little\nencoding: raw\n\n"
            );
            let data = vec![3u8; 2 * scalar.size_in_bytes()];
            let image = decode(&attached(&header, &data), Path::new("x.nrrd")).unwrap();
            assert_eq!(
                (image.scalar_type(), image.dims()),
                (scalar, [2, 1, 1]),
                "{alias}"
            );
        }
        let header = "NRRD0004\ntype: float\ndimension: 4\nsizes: 3 2 1 1\nendian: little\n\
                      encoding: raw\n\n";
        let e = decode(&attached(header, &[0; 24]), Path::new("x.nrrd")).unwrap_err();
        assert!(
            e.message()
                .contains("axis 0 is not spatial and has 3 samples"),
            "{e}"
        );
    }

    #[test]
    fn spacings_and_axis_mins_give_the_origin_itk_gives() {
        // pynrrd's file; SimpleITK reads origin (10.25, 21, 31.5): cell centring by default.
        let header = "NRRD0005\ntype: int8\ndimension: 3\nsizes: 1 1 1\nspacings: 0.5 2 3\n\
                      axis mins: 10 20 30\nencoding: raw\n\n";
        let g = *decode(&attached(header, &[1]), Path::new("x.nrrd"))
            .unwrap()
            .geometry();
        assert_eq!(g.origin(), [10.25, 21.0, 31.5]);
        assert_eq!(g.spacing(), [0.5, 2.0, 3.0]);
        let node = header.replace("encoding", "centers: node node cell\nencoding");
        let g = *decode(&attached(&node, &[1]), Path::new("x.nrrd"))
            .unwrap()
            .geometry();
        assert_eq!(g.origin(), [10.0, 20.0, 31.5]);
    }

    #[test]
    fn skips_and_detached_lists_read() {
        let dir = scratch_dir();
        let voxels: Vec<u8> = (10..22).collect();
        let mut data = b"line one\nline two\nXX".to_vec();
        data.extend_from_slice(&gzip(&[b"pad".as_slice(), &voxels].concat()).unwrap());
        std::fs::write(dir.path().join("v.gz"), &data).unwrap();
        // Line skip counts lines of the file; byte skip counts bytes of the decompressed data.
        let header = "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 3 2 2\nencoding: gzip\n\
                      line skip: 2\nbyte skip: 3\ndata file: v.gz\n";
        std::fs::write(dir.path().join("a.nhdr"), header).unwrap();
        // The two stray bytes before the gzip stream make it invalid: the skip must be exact.
        assert!(read(&dir.path().join("a.nhdr")).is_err());
        data.drain(18..20);
        std::fs::write(dir.path().join("v.gz"), &data).unwrap();
        assert_eq!(
            read(&dir.path().join("a.nhdr")).unwrap().buffer(),
            &VoxelBuffer::U8(voxels.clone())
        );

        std::fs::write(
            dir.path().join("p0"),
            [b"hdr".as_slice(), &voxels[..6]].concat(),
        )
        .unwrap();
        std::fs::write(
            dir.path().join("p1"),
            [b"hdr".as_slice(), &voxels[6..]].concat(),
        )
        .unwrap();
        let list = "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 3 2 2\nencoding: raw\n\
                    byte skip: -1\ndata file: LIST 2\np0\np1\n";
        std::fs::write(dir.path().join("b.nhdr"), list).unwrap();
        assert_eq!(
            read(&dir.path().join("b.nhdr")).unwrap().buffer(),
            &VoxelBuffer::U8(voxels)
        );
    }

    #[test]
    fn unsupported_headers_say_what_is_wrong() {
        let base =
            "NRRD0004\ntype: float\ndimension: 3\nsizes: 1 1 1\nendian: little\nencoding: raw\n";
        let cases = [
            (base.replace("float", "int64"), "type: int64"),
            (base.replace("raw", "bzip2"), "encoding: bzip2"),
            (base.replace("dimension: 3", "dimension: 5"), "dimension: 5"),
            (
                base.replace("sizes: 1 1 1", "sizes: 1 1"),
                "sizes needs 3 values, found 2",
            ),
            (base.replace("endian: little\n", ""), "endian"),
            (base.replace("sizes: 1 1 1", "sizes: 2 2 2"), "need 32"),
            (
                format!("{base}space: right-anterior-superior-time\n"),
                "right-anterior-superior-time",
            ),
            (
                format!("{base}space: RAS\nspace directions: (1,0,0) (0,1,0)\n"),
                "needs 3 entries",
            ),
            (
                format!("{base}space: RAS\nspace directions: (1,0,0) (0,1,0) (0,0,1,0)\n"),
                "4 components",
            ),
            (
                format!("{base}space: RAS\nspace directions: (1,0,0) (1,0,0) (0,0,1)\n"),
                "singular",
            ),
            ("NRRD0004\ntype: float\n".to_string(), "no 'dimension'"),
        ];
        for (header, expected) in cases {
            let e = decode(
                &attached(&format!("{header}\n"), &[0; 4]),
                Path::new("x.nrrd"),
            )
            .unwrap_err();
            assert_eq!(e.kind(), crate::ErrorKind::Format);
            assert!(e.message().contains(expected), "{header}: {e}");
        }
        let e = decode(b"P5\n", Path::new("x.nrrd")).unwrap_err();
        assert!(e.message().contains("not a NRRD file"), "{e}");
    }

    /// A 40×30×20 int16 .nrrd (48 KB of voxels, past the streamed header prefix), big-endian,
    /// raw or gzip-encoded, with `byte_skip` bytes before the voxels (inflated ones, for gzip).
    fn attached_nrrd(gzip_encoded: bool, byte_skip: usize) -> (Vec<u8>, Vec<i16>) {
        let voxels: Vec<i16> = (0..24_000).map(|n| (n * 37 % 5000 - 2500) as i16).collect();
        let mut raw = vec![0xab; byte_skip];
        raw.extend(voxels.iter().flat_map(|v| v.to_be_bytes()));
        let (encoding, data) = if gzip_encoded {
            ("gzip", gzip(&raw).unwrap())
        } else {
            ("raw", raw)
        };
        let header = format!(
            "NRRD0004\ntype: short\ndimension: 3\nsizes: 40 30 20\nspacings: 0.7 0.8 2.5\n\
             endian: big\nencoding: {encoding}\nbyte skip: {byte_skip}\n\n"
        );
        (attached(&header, &data), voxels)
    }

    #[test]
    fn attached_voxels_are_streamed_from_the_file_as_they_are_parsed_from_memory() {
        let dir = scratch_dir();
        let path = dir.path().join("v.nrrd");
        for (gzip_encoded, skip) in [(false, 0), (false, 13), (true, 0), (true, 13)] {
            let (file, voxels) = attached_nrrd(gzip_encoded, skip);
            std::fs::write(&path, &file).unwrap();
            let streamed = read(&path).unwrap();
            assert_eq!(streamed.buffer(), &VoxelBuffer::I16(voxels));
            let parsed = decode(&file, &path).unwrap();
            assert_same_voxels(&streamed, &parsed);
            assert_geometry_close(streamed.geometry(), parsed.geometry(), 0.0);
        }
    }

    #[test]
    fn a_header_whose_blank_line_ends_just_past_the_streamed_prefix_is_read_whole() {
        // The blank line is "\r\n" with its "\r" the prefix's last byte: the voxels start
        // after the line feed, not where the prefix ends.
        let (file, voxels) = attached_nrrd(false, 0);
        let data = &file[file.windows(2).position(|w| w == b"\n\n").unwrap() + 2..];
        let start = "NRRD0004\ntype: short\ndimension: 3\nsizes: 40 30 20\nendian: big\n\
                     encoding: raw\n# ";
        let padding = "x".repeat(files::HEADER_PREFIX as usize - start.len() - 2);
        let mut file = format!("{start}{padding}\n\r\n").into_bytes();
        assert_eq!(file.len(), files::HEADER_PREFIX as usize + 1);
        file.extend_from_slice(data);
        let dir = scratch_dir();
        let path = dir.path().join("v.nrrd");
        std::fs::write(&path, &file).unwrap();
        assert_eq!(read(&path).unwrap().buffer(), &VoxelBuffer::I16(voxels));
    }

    #[test]
    fn streamed_voxels_that_the_file_cannot_hold_are_errors_naming_it() {
        let dir = scratch_dir();
        let path = dir.path().join("v.nrrd");
        let (raw, _) = attached_nrrd(false, 13);
        std::fs::write(&path, &raw[..raw.len() - 1]).unwrap();
        let short = read(&path).unwrap_err().to_string();
        assert!(
            short.contains("v.nrrd") && short.contains("need 48013"),
            "{short}"
        );
        let (zipped, _) = attached_nrrd(true, 0);
        std::fs::write(&path, &zipped[..zipped.len() - 100]).unwrap();
        let cut = read(&path).unwrap_err().to_string();
        assert!(cut.contains("v.nrrd") && cut.contains("truncated"), "{cut}");
    }

    #[test]
    fn truncated_or_corrupted_files_never_panic() {
        let image = pattern_image(ScalarType::I16, [3, 4, 2], oblique_geometry(), 2);
        let dir = scratch_dir();
        let path = dir.path().join("t.nrrd");
        write(&path, &image).unwrap();
        let compressed = std::fs::read(&path).unwrap();
        let mut raw = (header_text(&image).replace("gzip", "raw") + "\n").into_bytes();
        raw.extend_from_slice(&image.buffer().to_le_bytes());
        for file in [compressed, raw] {
            assert_never_panics(&file, &image, |b| decode(b, &path));
        }
    }
}
