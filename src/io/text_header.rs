//! What the image readers and writers share (files themselves are read and written by `files`):
//! the `key <separator> value` lines of the MetaImage and NRRD headers, number lists, number
//! formatting that reads back bit for bit, the checked size of a voxel block, and the geometry
//! built from the world vector of one step along each index axis (NRRD's `space directions`,
//! NIfTI's affine columns).

use std::borrow::Cow;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::geometry::Geometry;
use crate::volume::ScalarType;

/// A data file named in a header: relative names are relative to the header's folder.
pub(crate) fn beside(header: &Path, name: &str) -> PathBuf {
    let name = Path::new(name);
    if name.is_absolute() {
        name.to_path_buf()
    } else {
        header.parent().unwrap_or(Path::new("")).join(name)
    }
}

/// The trimmed non-empty lines from byte `start` to the end (file names after `LIST`).
pub(crate) fn lines_from(bytes: &[u8], start: usize) -> Vec<String> {
    std::iter::successors(line_at(bytes, start), |l| line_at(bytes, l.next))
        .map(|l| l.text.trim().to_string())
        .filter(|name| !name.is_empty())
        .collect()
}

/// Voxel bytes stored in equal parts in the files `names` (relative to `header`), each file's
/// part extracted by `part(file bytes, part length)`.
pub(crate) fn concatenate_parts(
    header: &Path,
    names: &[String],
    expected: usize,
    part: impl for<'b> Fn(&'b [u8], usize) -> Result<Cow<'b, [u8]>>,
) -> Result<Vec<u8>> {
    if names.is_empty() || expected % names.len() != 0 {
        return Err(Error::format(format!(
            "the data file LIST names {} files, which cannot hold equal parts of the {expected} \
             bytes of voxels",
            names.len()
        )));
    }
    let mut all = Vec::new();
    for name in names {
        let file = super::files::read(&beside(header, name))?;
        all.extend_from_slice(&part(&file, expected / names.len()).map_err(|e| e.context(name))?);
    }
    Ok(all)
}

/// Whether `path` ends with `.suffix`, ignoring case (`suffix` without the dot, lower case).
pub(crate) fn has_suffix(path: &Path, suffix: &str) -> bool {
    let name = path.to_string_lossy().to_ascii_lowercase();
    name.strip_suffix(suffix)
        .is_some_and(|stem| stem.ends_with('.'))
}

/// One line of a text header and the offset of the byte after its line feed.
pub(crate) struct Line<'a> {
    pub text: Cow<'a, str>,
    pub next: usize,
}

/// The line starting at byte `start`, without its `\n` or `\r\n`; `None` at the end of `bytes`.
pub(crate) fn line_at(bytes: &[u8], start: usize) -> Option<Line<'_>> {
    let rest = bytes.get(start..).filter(|r| !r.is_empty())?;
    let (raw, next) = match rest.iter().position(|&b| b == b'\n') {
        Some(n) => (&rest[..n], start + n + 1),
        None => (rest, bytes.len()),
    };
    let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
    Some(Line {
        text: String::from_utf8_lossy(raw),
        next,
    })
}

/// Parses exactly `count` whitespace-separated numbers of the field `key`.
pub(crate) fn numbers<T: std::str::FromStr>(
    key: &str,
    value: &str,
    count: usize,
) -> Result<Vec<T>> {
    let found: Vec<&str> = value.split_whitespace().collect();
    if found.len() != count {
        return Err(Error::format(format!(
            "{key} needs {count} values, found {}",
            found.len()
        )));
    }
    found.iter().map(|s| number(key, s)).collect()
}

pub(crate) fn number<T: std::str::FromStr>(key: &str, text: &str) -> Result<T> {
    text.trim().parse().map_err(|_| {
        Error::format(format!(
            "{key}: '{}' is not a valid number here",
            text.trim()
        ))
    })
}

/// Image sizes: each at least one voxel.
pub(crate) fn sizes(key: &str, value: &str, count: usize) -> Result<Vec<usize>> {
    let sizes: Vec<usize> = numbers(key, value, count)?;
    if sizes.contains(&0) {
        return Err(Error::format(format!(
            "{key} = {value}: every size must be at least 1"
        )));
    }
    Ok(sizes)
}

/// A number written so that parsing it gives back the same f64: Rust's shortest round-trip
/// digits, in exponent form only where plain digits would be long.
pub(crate) fn fmt_f64(x: f64) -> String {
    let a = x.abs();
    if a == 0.0 || (1e-4..1e15).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

pub(crate) fn fmt_list(values: &[f64], separator: &str) -> String {
    values
        .iter()
        .map(|&v| fmt_f64(v))
        .collect::<Vec<_>>()
        .join(separator)
}

/// What a volume's text header (MetaImage, NRRD) says of its voxels: sizes, type, byte order
/// and geometry.
pub(crate) struct Described {
    pub dims: [usize; 3],
    pub scalar: ScalarType,
    pub little_endian: bool,
    pub geometry: Geometry,
}

impl Described {
    /// How many voxels there are (their bytes checked against the address space).
    pub fn voxel_count(&self) -> Result<usize> {
        Ok(byte_count(self.dims, self.scalar)? / self.scalar.size_in_bytes())
    }
}

/// Bytes of `dims` voxels of `scalar`, without overflow.
pub(crate) fn byte_count(dims: [usize; 3], scalar: ScalarType) -> Result<usize> {
    dims.iter()
        .try_fold(scalar.size_in_bytes(), |n, &d| n.checked_mul(d))
        .ok_or_else(|| {
            Error::format(format!(
                "the sizes {dims:?} of {} voxels overflow the address space",
                scalar.name()
            ))
        })
}

/// The first `count` bytes of `data`, or an error saying how short the data is.
pub(crate) fn take_bytes<'a>(data: &'a [u8], count: usize, what: &str) -> Result<&'a [u8]> {
    data.get(..count).ok_or_else(|| {
        Error::format(format!(
            "{what} holds {} bytes but the header's sizes and type need {count}: the file is \
             truncated or its header is wrong",
            data.len()
        ))
    })
}

/// A geometry from the world vectors of one index step along i, j and k: spacing is their
/// length and the direction columns are the normalised vectors.
pub(crate) fn geometry_from_axes(axes: [[f64; 3]; 3], origin: [f64; 3]) -> Result<Geometry> {
    let mut spacing = [0.0; 3];
    let mut direction = [0.0; 9];
    for (a, v) in axes.iter().enumerate() {
        let len = v.iter().map(|c| c * c).sum::<f64>().sqrt();
        if !(len.is_finite() && len > 0.0) {
            return Err(Error::format(format!(
                "the vector of index axis {a} is {v:?}; it must be finite and non-zero"
            )));
        }
        spacing[a] = len;
        for (row, c) in v.iter().enumerate() {
            direction[3 * row + a] = c / len;
        }
    }
    geometry(spacing, origin, direction)
}

/// `Geometry::new` with its complaint reported as a format error of the file being read.
pub(crate) fn geometry(
    spacing: [f64; 3],
    origin: [f64; 3],
    direction: [f64; 9],
) -> Result<Geometry> {
    Geometry::new(spacing, origin, direction).map_err(|e| Error::format(e.message()))
}

/// The world vectors of one index step along each axis, `D · diag(spacing)` column by column.
pub(crate) fn axes_of(geometry: &Geometry) -> [[f64; 3]; 3] {
    let m = geometry.index_to_world_matrix();
    [
        m.x_axis.to_array(),
        m.y_axis.to_array(),
        m.z_axis.to_array(),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formatted_numbers_parse_back_bit_for_bit() {
        for x in [
            0.0,
            -0.0,
            0.878906,
            1.0 / 3.0,
            -156.445,
            1e-300,
            6.02e23,
            1e-5,
            f64::MIN_POSITIVE,
        ] {
            let s = fmt_f64(x);
            assert_eq!(s.parse::<f64>().unwrap().to_bits(), x.to_bits(), "{s}");
            assert!(s.len() < 26, "{s}");
        }
    }

    #[test]
    fn number_lists_say_what_they_needed() {
        let e = numbers::<usize>("DimSize", "157 393", 3).unwrap_err();
        assert_eq!(e.message(), "DimSize needs 3 values, found 2");
        let e = sizes("sizes", "4 0 2", 3).unwrap_err();
        assert!(e.message().contains("at least 1"), "{e}");
        assert!(numbers::<f64>("Offset", "1 x 3", 3).is_err());
    }

    #[test]
    fn lines_end_at_lf_or_crlf() {
        let b = b"a = 1\r\nb = 2\nc";
        let l = line_at(b, 0).unwrap();
        assert_eq!((l.text.as_ref(), l.next), ("a = 1", 7));
        let l = line_at(b, 7).unwrap();
        assert_eq!((l.text.as_ref(), l.next), ("b = 2", 13));
        let l = line_at(b, 13).unwrap();
        assert_eq!((l.text.as_ref(), l.next), ("c", 14));
        assert!(line_at(b, 14).is_none());
    }

    #[test]
    fn axes_give_spacing_and_unit_direction_columns() {
        let g = geometry_from_axes(
            [[0.0, 2.0, 0.0], [-3.0, 0.0, 0.0], [0.0, 0.0, 0.5]],
            [1.0, 2.0, 3.0],
        )
        .unwrap();
        assert_eq!(g.spacing(), [2.0, 3.0, 0.5]);
        assert_eq!(g.direction(), [0., -1., 0., 1., 0., 0., 0., 0., 1.]);
        assert_eq!(
            axes_of(&g),
            [[0.0, 2.0, 0.0], [-3.0, 0.0, 0.0], [0.0, 0.0, 0.5]]
        );
        assert!(geometry_from_axes([[0.0; 3], [0., 1., 0.], [0., 0., 1.]], [0.0; 3]).is_err());
    }
}
