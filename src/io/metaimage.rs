//! MetaImage (`.mha`, `.mhd`) reading and writing, with MetaIO's meaning of the header as ITK
//! uses it.
//!
//! Geometry: `TransformMatrix` (alias `Rotation`, `Orientation`) lists the direction matrix column
//! by column — the unit vector of the i axis first — as ITK writes and reads it (VTK's reader takes
//! it transposed; ITK is the reference, see docs/interfaces.md, "Coordinates"). `Offset` (alias
//! `Position`, `Origin`) is the world position of voxel (0,0,0); `ElementSpacing` (else
//! `ElementSize`) the spacing. A 2-D image becomes a volume one slice thick.
//!
//! Voxels: `ElementDataFile = LOCAL` (right after the header), a file name relative to the header
//! (`HeaderSize` bytes skipped first; -1 means the data ends the file), or `LIST` followed by one
//! file name per line (equal parts, concatenated). Raw or zlib/gzip (`CompressedData = True`;
//! `CompressedDataSize` may be absent), either byte order. Supported element types: MET_UCHAR,
//! MET_CHAR, MET_USHORT, MET_SHORT, MET_UINT, MET_INT (and MET_ULONG, MET_LONG, which MetaIO stores
//! in 4 bytes), MET_FLOAT, MET_DOUBLE; one channel.
//!
//! The writer writes `.mha` with zlib-compressed data after the header, or, for a `.mhd` path, the
//! header there and the compressed data beside it in `<stem>.zraw`.

use std::borrow::Cow;
use std::io::{BufRead, BufReader};
use std::path::Path;

use super::compression::{stream_voxels, zlib, VoxelData};
use super::files::{self, HeaderPrefix};
use super::text_header::{
    beside, byte_count, concatenate_parts, fmt_list, geometry, has_suffix, line_at, lines_from,
    number, numbers, sizes, take_bytes, Described,
};
use crate::error::{Error, Result};
use crate::geometry::Geometry;
use crate::volume::{Image, ScalarType};

/// MetaIO's element type names, the first name of each type being the one written.
const ELEMENT_TYPES: [(&str, ScalarType); 10] = [
    ("MET_UCHAR", ScalarType::U8),
    ("MET_CHAR", ScalarType::I8),
    ("MET_USHORT", ScalarType::U16),
    ("MET_SHORT", ScalarType::I16),
    ("MET_UINT", ScalarType::U32),
    ("MET_INT", ScalarType::I32),
    ("MET_FLOAT", ScalarType::F32),
    ("MET_DOUBLE", ScalarType::F64),
    ("MET_ULONG", ScalarType::U32),
    ("MET_LONG", ScalarType::I32),
];

/// Reads a `.mha` or `.mhd` image. Voxels that follow the header in the same file (`LOCAL`)
/// are streamed from the file into the image's buffer, through the inflater when compressed,
/// so that the file's bytes are never held beside them; other layouts are read whole.
pub fn read(path: &Path) -> Result<Image> {
    let prefix = HeaderPrefix::open(path)?;
    // The header must end, its last line with its line feed, inside the bytes read so far.
    let local = Header::parse(&prefix.bytes).ok().filter(|h| {
        prefix.bytes.get(h.data_start.wrapping_sub(1)) == Some(&b'\n')
            && h.get(&["ElementDataFile"])
                .is_some_and(|(_, file)| file.eq_ignore_ascii_case("LOCAL"))
    });
    let (Some(h), false) = (local, prefix.is_whole_file()) else {
        // Small, or a header this reader does not stream: the whole file, parsed from memory.
        drop(prefix);
        return files::parse_file(path, |bytes| decode(bytes, path));
    };
    let described = describe(&h).map_err(|e| e.context(path.display()))?;
    let (data, data_len) = prefix.data_from(h.data_start)?;
    local_stream(&h, described, data, data_len).map_err(|e| e.context(path.display()))
}

/// Voxels of `described` streamed from `data`, the `data_len` bytes after a `LOCAL` header.
fn local_stream(
    h: &Header,
    described: Described,
    data: impl BufRead,
    data_len: u64,
) -> Result<Image> {
    let count = described.voxel_count()?;
    let Described {
        dims,
        scalar,
        little_endian,
        geometry,
    } = described;
    let buffer = if h.flag(&["CompressedData"])?.unwrap_or(false) {
        let stream_len = match h.parsed::<u64>("CompressedDataSize")? {
            Some(n) if n > data_len => {
                return Err(Error::format(format!(
                    "CompressedDataSize = {n} but only {data_len} bytes of data follow: the file \
                     is truncated"
                )))
            }
            Some(n) => n,
            None => data_len,
        };
        let stream = BufReader::new(data.take(stream_len));
        stream_voxels(stream, stream_len, true, 0, scalar, count, little_endian)?
    } else {
        stream_voxels(data, data_len, false, 0, scalar, count, little_endian)?
    };
    Image::new(buffer, dims, geometry)
}

/// Writes `image` as `.mha` (data after the header) or, for a `.mhd` path, with the data in a
/// `.zraw` file beside it; the data is zlib-compressed either way.
pub fn write(path: &Path, image: &Image) -> Result<()> {
    let data = zlib(&image.buffer().to_le_bytes())?;
    if has_suffix(path, "mhd") {
        let stem = path.file_stem().unwrap_or_default().to_string_lossy();
        let data_name = format!("{stem}.zraw");
        files::write_all(&beside(path, &data_name), &data)?;
        files::write_all(path, header_text(image, data.len(), &data_name).as_bytes())
    } else {
        let mut file = header_text(image, data.len(), "LOCAL").into_bytes();
        file.extend_from_slice(&data);
        files::write_all(path, &file)
    }
}

fn header_text(image: &Image, compressed_size: usize, data_file: &str) -> String {
    let g = image.geometry();
    let d = g.direction();
    // Column by column: the i axis' unit vector first, as ITK writes it.
    let columns: Vec<f64> = (0..3)
        .flat_map(|a| (0..3).map(move |r| d[3 * r + a]))
        .collect();
    let [nx, ny, nz] = image.dims();
    let type_name = ELEMENT_TYPES
        .iter()
        .find(|(_, t)| *t == image.scalar_type())
        .map_or("MET_NONE", |(name, _)| name);
    format!(
        "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n\
         CompressedData = True\nCompressedDataSize = {compressed_size}\n\
         TransformMatrix = {}\nOffset = {}\nCenterOfRotation = 0 0 0\nElementSpacing = {}\n\
         DimSize = {nx} {ny} {nz}\nElementType = {type_name}\nElementDataFile = {data_file}\n",
        fmt_list(&columns, " "),
        fmt_list(&g.origin(), " "),
        fmt_list(&g.spacing(), " "),
    )
}

/// The `Key = Value` fields up to and including `ElementDataFile`, and where the data starts.
struct Header {
    fields: Vec<(String, String)>,
    data_start: usize,
}

impl Header {
    fn parse(bytes: &[u8]) -> Result<Header> {
        let mut fields = Vec::new();
        let mut pos = 0;
        let mut line_number = 0;
        while let Some(line) = line_at(bytes, pos) {
            line_number += 1;
            pos = line.next;
            let text = line.text.trim();
            if text.is_empty() {
                continue;
            }
            let Some((key, value)) = text.split_once('=') else {
                let start: String = text.chars().take(40).collect();
                return Err(Error::format(format!(
                    "header line {line_number} ('{start}') is not 'Key = Value'; is this a \
                     MetaImage file?"
                )));
            };
            let key = key.trim();
            fields.push((key.to_string(), value.trim().to_string()));
            if key.eq_ignore_ascii_case("ElementDataFile") {
                return Ok(Header {
                    fields,
                    data_start: pos,
                });
            }
        }
        Err(Error::format(
            "the header has no ElementDataFile line: the file is truncated or not a MetaImage",
        ))
    }

    /// The first of `keys` present (they are aliases, best first), with the key as written.
    fn get(&self, keys: &[&str]) -> Option<(&str, &str)> {
        keys.iter().find_map(|k| {
            self.fields
                .iter()
                .find(|(key, _)| key.eq_ignore_ascii_case(k))
                .map(|(key, value)| (key.as_str(), value.as_str()))
        })
    }

    fn require(&self, key: &str) -> Result<&str> {
        self.get(&[key]).map(|(_, v)| v).ok_or_else(|| {
            Error::format(format!(
                "the header has no {key} field, which MetaImage requires"
            ))
        })
    }

    fn flag(&self, keys: &[&str]) -> Result<Option<bool>> {
        self.get(keys)
            .map(|(key, value)| match value.to_ascii_lowercase().as_str() {
                "true" | "1" => Ok(true),
                "false" | "0" => Ok(false),
                _ => Err(Error::format(format!(
                    "{key} = {value}: expected True or False"
                ))),
            })
            .transpose()
    }

    fn parsed<T: std::str::FromStr>(&self, key: &str) -> Result<Option<T>> {
        self.get(&[key]).map(|(k, v)| number(k, v)).transpose()
    }

    /// `count` numbers from the first of `keys` present, else `default` each.
    fn floats(&self, keys: &[&str], count: usize, default: f64) -> Result<Vec<f64>> {
        match self.get(keys) {
            Some((key, value)) => numbers(key, value, count),
            None => Ok(vec![default; count]),
        }
    }
}

pub(crate) fn decode(bytes: &[u8], path: &Path) -> Result<Image> {
    let h = Header::parse(bytes)?;
    let Described {
        dims,
        scalar,
        little_endian,
        geometry,
    } = describe(&h)?;
    let expected = byte_count(dims, scalar)?;
    let buffer = voxel_data(&h, bytes, path, expected)?.into_buffer(scalar, little_endian)?;
    Image::new(buffer, dims, geometry)
}

/// The header's fields about the voxels, checked.
fn describe(h: &Header) -> Result<Described> {
    if let Some((_, kind)) = h.get(&["ObjectType"]) {
        if !kind.eq_ignore_ascii_case("Image") {
            return Err(Error::format(format!(
                "ObjectType = {kind}: only Image objects hold voxels"
            )));
        }
    }
    let ndims: usize = number("NDims", h.require("NDims")?)?;
    if !(2..=3).contains(&ndims) {
        return Err(Error::format(format!(
            "NDims = {ndims}: only 2-D and 3-D images are supported (take a 3-D volume out of a \
             4-D series first)"
        )));
    }
    let dims = sizes("DimSize", h.require("DimSize")?, ndims)?;
    let dims = [dims[0], dims[1], dims.get(2).copied().unwrap_or(1)];
    let channels: usize = h.parsed("ElementNumberOfChannels")?.unwrap_or(1);
    if channels != 1 {
        return Err(Error::format(format!(
            "ElementNumberOfChannels = {channels}: images with several components per voxel \
             (vector, RGB) are not supported; save one component as a scalar image first"
        )));
    }
    let scalar = element_type(h.require("ElementType")?)?;
    if h.flag(&["BinaryData"])? == Some(false) {
        return Err(Error::format(
            "BinaryData = False (voxels as text) is not supported; save the image as binary",
        ));
    }
    let big_endian = h
        .flag(&["BinaryDataByteOrderMSB", "ElementByteOrderMSB"])?
        .unwrap_or(false);
    Ok(Described {
        dims,
        scalar,
        little_endian: !big_endian,
        geometry: read_geometry(h, ndims)?,
    })
}

fn element_type(name: &str) -> Result<ScalarType> {
    // MetaIO names the one-channel case of a type with or without `_ARRAY`.
    let base = name.to_ascii_uppercase();
    let base = base.strip_suffix("_ARRAY").unwrap_or(&base);
    ELEMENT_TYPES
        .iter()
        .find(|(n, _)| *n == base)
        .map(|(_, t)| *t)
        .ok_or_else(|| {
            Error::format(format!(
                "ElementType = {name} is not supported; use MET_UCHAR, MET_CHAR, MET_USHORT, \
                 MET_SHORT, MET_UINT, MET_INT, MET_FLOAT or MET_DOUBLE (convert 64-bit integers \
                 to MET_DOUBLE or MET_INT first)"
            ))
        })
}

fn read_geometry(h: &Header, n: usize) -> Result<Geometry> {
    let spacing = h.floats(&["ElementSpacing", "ElementSize"], n, 1.0)?;
    let origin = h.floats(&["Offset", "Position", "Origin"], n, 0.0)?;
    let identity: Vec<f64> = (0..n * n)
        .map(|e| if e % (n + 1) == 0 { 1.0 } else { 0.0 })
        .collect();
    let matrix = match h.get(&["TransformMatrix", "Rotation", "Orientation"]) {
        Some((key, value)) => numbers(key, value, n * n)?,
        None => identity,
    };
    let mut direction = [1., 0., 0., 0., 1., 0., 0., 0., 1.];
    for axis in 0..n {
        for row in 0..n {
            direction[3 * row + axis] = matrix[axis * n + row];
        }
    }
    let pad = |v: &[f64], fill: f64| [v[0], v[1], v.get(2).copied().unwrap_or(fill)];
    geometry(pad(&spacing, 1.0), pad(&origin, 0.0), direction)
}

/// The voxels' bytes, raw, from wherever `ElementDataFile` says.
fn voxel_data<'a>(
    h: &Header,
    bytes: &'a [u8],
    path: &Path,
    expected: usize,
) -> Result<VoxelData<'a>> {
    let compressed = h.flag(&["CompressedData"])?.unwrap_or(false);
    let compressed_size: Option<usize> = h.parsed("CompressedDataSize")?;
    let data_file = h.require("ElementDataFile")?;
    if data_file.eq_ignore_ascii_case("LOCAL") {
        return block(
            &bytes[h.data_start..],
            expected,
            compressed,
            compressed_size,
        );
    }
    let header_size: i64 = h.parsed("HeaderSize")?.unwrap_or(0);
    if data_file.split_whitespace().next() == Some("LIST") {
        let names = lines_from(bytes, h.data_start);
        let all = concatenate_parts(path, &names, expected, |file, part| {
            detached(file, header_size, part, compressed, None)?.into_bytes()
        })?;
        return Ok(VoxelData::Raw(Cow::Owned(all)));
    }
    if data_file.contains('%') {
        return Err(Error::format(format!(
            "ElementDataFile = {data_file}: numbered file patterns are not supported; list the \
             files one per line after ElementDataFile = LIST instead"
        )));
    }
    let file = files::read(&beside(path, data_file))?;
    let part = detached(&file, header_size, expected, compressed, compressed_size)
        .map_err(|e| e.context(data_file))?;
    Ok(part.into_owned())
}

/// The voxels of a separate data file that starts with `header_size` bytes to skip.
fn detached(
    file: &[u8],
    header_size: i64,
    expected: usize,
    compressed: bool,
    compressed_size: Option<usize>,
) -> Result<VoxelData<'_>> {
    let start = match header_size {
        -1 if compressed => {
            return Err(Error::format(
                "HeaderSize = -1 (data at the end of the file) cannot locate compressed data",
            ))
        }
        -1 => file.len().checked_sub(expected),
        n => usize::try_from(n).ok().filter(|&n| n <= file.len()),
    }
    .ok_or_else(|| {
        Error::format(format!(
            "HeaderSize = {header_size} does not fit the {}-byte data file ({expected} bytes of \
             voxels expected)",
            file.len()
        ))
    })?;
    block(&file[start..], expected, compressed, compressed_size)
}

/// `expected` bytes of voxels from the start of `data`, still compressed when they are.
fn block(
    data: &[u8],
    expected: usize,
    compressed: bool,
    compressed_size: Option<usize>,
) -> Result<VoxelData<'_>> {
    if !compressed {
        return take_bytes(data, expected, "the voxel data")
            .map(|d| VoxelData::Raw(Cow::Borrowed(d)));
    }
    let stream = match compressed_size {
        Some(n) => data.get(..n).ok_or_else(|| {
            Error::format(format!(
                "CompressedDataSize = {n} but only {} bytes of data follow: the file is truncated",
                data.len()
            ))
        })?,
        None => data,
    };
    Ok(VoxelData::Compressed {
        stream: Cow::Borrowed(stream),
        skip: 0,
        voxel_bytes: expected,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::test_images::{
        assert_never_panics, assert_same_voxels, oblique_geometry, pattern_image, scratch_dir,
    };
    use crate::volume::VoxelBuffer;
    use balloonseg_testkit::data_dir;

    #[test]
    fn every_scalar_type_round_trips_exactly_through_mha_and_mhd() {
        let dir = scratch_dir();
        for (n, scalar) in ScalarType::ALL.into_iter().enumerate() {
            let image = pattern_image(scalar, [5, 4, 3], oblique_geometry(), n as u64);
            for name in ["img.mha", "img.mhd"] {
                let path = dir.path().join(name);
                write(&path, &image).unwrap();
                let back = read(&path).unwrap();
                assert_same_voxels(&back, &image);
                assert_eq!(back.geometry(), image.geometry(), "{name} {scalar:?}");
            }
        }
    }

    #[test]
    fn compressed_data_size_may_be_absent() {
        let image = pattern_image(ScalarType::U16, [3, 2, 2], oblique_geometry(), 11);
        let mut file = header_text(&image, 0, "LOCAL")
            .replace("CompressedDataSize = 0\n", "")
            .into_bytes();
        file.extend_from_slice(&zlib(&image.buffer().to_le_bytes()).unwrap());
        assert_eq!(decode(&file, Path::new("x.mha")).unwrap(), image);
    }

    #[test]
    fn transform_matrix_lists_the_direction_column_by_column() {
        // SimpleITK writes direction (0,-1,0, 1,0,0, 0,0,1) (row-major) as below: the i axis
        // points along +y.
        let header = "ObjectType = Image\nNDims = 3\nTransformMatrix = 0 1 0 -1 0 0 0 0 1\n\
                      Offset = 1 2 3\nElementSpacing = 0.5 2 3\nDimSize = 2 1 1\n\
                      ElementType = MET_UCHAR\nElementDataFile = LOCAL\n";
        let mut file = header.as_bytes().to_vec();
        file.extend_from_slice(&[7, 9]);
        let image = decode(&file, Path::new("x.mha")).unwrap();
        let g = image.geometry();
        assert_eq!(g.direction(), [0., -1., 0., 1., 0., 0., 0., 0., 1.]);
        assert_eq!(g.spacing(), [0.5, 2.0, 3.0]);
        assert_eq!(g.origin(), [1.0, 2.0, 3.0]);
        assert_eq!(image.buffer(), &VoxelBuffer::U8(vec![7, 9]));
        let written = header_text(&image, 0, "LOCAL");
        assert!(
            written.contains("TransformMatrix = 0 1 0 -1 0 0 0 0 1\n"),
            "{written}"
        );
    }

    #[test]
    fn raw_big_endian_two_dimensional_images_with_aliases_read() {
        let header = "NDims = 2\nDimSize = 2 2\nElementType = MET_SHORT\nElementSize = 0.5 0.25\n\
                      Position = 4 5\nOrientation = 0 1 1 0\nBinaryData = True\r\n\
                      ElementByteOrderMSB = True\r\nElementDataFile = LOCAL\r\n";
        let mut file = header.as_bytes().to_vec();
        for v in [1i16, -2, 300, -400] {
            file.extend_from_slice(&v.to_be_bytes());
        }
        let image = decode(&file, Path::new("x.mha")).unwrap();
        assert_eq!(image.dims(), [2, 2, 1]);
        assert_eq!(image.buffer(), &VoxelBuffer::I16(vec![1, -2, 300, -400]));
        let g = image.geometry();
        assert_eq!(g.spacing(), [0.5, 0.25, 1.0]);
        assert_eq!(g.origin(), [4.0, 5.0, 0.0]);
        assert_eq!(g.direction(), [0., 1., 0., 1., 0., 0., 0., 0., 1.]);
    }

    /// A 40×30×20 int16 .mha (48 KB of voxels, past the streamed header prefix): raw
    /// big-endian, or zlib-compressed with the CompressedDataSize `declared` makes of the
    /// stream's true length (none when it gives `None`).
    fn local_mha(
        compressed: bool,
        declared: impl Fn(usize) -> Option<usize>,
    ) -> (Vec<u8>, Vec<i16>) {
        let voxels: Vec<i16> = (0..24_000).map(|n| (n * 37 % 5000 - 2500) as i16).collect();
        let raw: Vec<u8> = voxels.iter().flat_map(|v| v.to_be_bytes()).collect();
        let data = if compressed { zlib(&raw).unwrap() } else { raw };
        let mut header = "NDims = 3\nDimSize = 40 30 20\nElementType = MET_SHORT\n\
                          ElementByteOrderMSB = True\n"
            .to_string();
        if compressed {
            header.push_str("CompressedData = True\n");
        }
        if let Some(n) = declared(data.len()).filter(|_| compressed) {
            header.push_str(&format!("CompressedDataSize = {n}\n"));
        }
        header.push_str("ElementDataFile = LOCAL\n");
        let mut file = header.into_bytes();
        file.extend(data);
        (file, voxels)
    }

    #[test]
    fn local_voxels_are_streamed_from_the_file_as_they_are_parsed_from_memory() {
        let dir = scratch_dir();
        let path = dir.path().join("v.mha");
        let (raw, voxels) = local_mha(false, |_| None);
        let (zipped, _) = local_mha(true, |_| None);
        let (sized, _) = local_mha(true, Some);
        for file in [raw, zipped, sized] {
            std::fs::write(&path, &file).unwrap();
            let streamed = read(&path).unwrap();
            assert_eq!(streamed.buffer(), &VoxelBuffer::I16(voxels.clone()));
            assert_same_voxels(&streamed, &decode(&file, &path).unwrap());
        }
    }

    #[test]
    fn a_header_whose_line_feed_falls_just_past_the_streamed_prefix_is_read_whole() {
        // "ElementDataFile = LOCAL\r" ends the first 4,096 bytes and its line feed is the next
        // byte: the voxels start after it, not where the prefix ends.
        let (raw, voxels) = local_mha(false, |_| None);
        let data = &raw[raw.windows(6).position(|w| w == b"LOCAL\n").unwrap() + 6..];
        let start = "NDims = 3\nDimSize = 40 30 20\nElementType = MET_SHORT\n\
                     ElementByteOrderMSB = True\nComment = ";
        let end = "\nElementDataFile = LOCAL\r";
        let padding = "x".repeat(files::HEADER_PREFIX as usize - start.len() - end.len());
        let mut file = format!("{start}{padding}{end}\n").into_bytes();
        assert_eq!(file.len(), files::HEADER_PREFIX as usize + 1);
        file.extend_from_slice(data);
        let dir = scratch_dir();
        let path = dir.path().join("v.mha");
        std::fs::write(&path, &file).unwrap();
        assert_eq!(read(&path).unwrap().buffer(), &VoxelBuffer::I16(voxels));
    }

    #[test]
    fn streamed_local_voxels_that_the_file_cannot_hold_are_errors_naming_it() {
        let dir = scratch_dir();
        let path = dir.path().join("v.mha");
        let (raw, _) = local_mha(false, |_| None);
        std::fs::write(&path, &raw[..raw.len() - 1]).unwrap();
        let short = read(&path).unwrap_err().to_string();
        assert!(
            short.contains("v.mha") && short.contains("need 48000"),
            "{short}"
        );
        let (zipped, _) = local_mha(true, |_| Some(1 << 30));
        std::fs::write(&path, &zipped).unwrap();
        let lying = read(&path).unwrap_err().to_string();
        assert!(
            lying.contains("CompressedDataSize = 1073741824 but only"),
            "{lying}"
        );
        let (zipped, _) = local_mha(true, |_| None);
        std::fs::write(&path, &zipped[..zipped.len() - 100]).unwrap();
        assert!(read(&path).is_err());
    }

    #[test]
    fn detached_data_with_header_size_minus_one_and_lists_read() {
        let dir = scratch_dir();
        let voxels: Vec<u8> = (0..12).collect();
        let mut data = b"junk before the voxels".to_vec();
        data.extend_from_slice(&voxels);
        std::fs::write(dir.path().join("v.raw"), &data).unwrap();
        let header = "NDims = 3\nDimSize = 3 2 2\nElementType = MET_UCHAR\nHeaderSize = -1\n\
                      ElementDataFile = v.raw\n";
        std::fs::write(dir.path().join("a.mhd"), header).unwrap();
        let image = read(&dir.path().join("a.mhd")).unwrap();
        assert_eq!(image.buffer(), &VoxelBuffer::U8(voxels.clone()));

        std::fs::write(dir.path().join("s0.raw"), &voxels[..6]).unwrap();
        let list = "NDims = 3\nDimSize = 3 2 2\nElementType = MET_UCHAR\nCompressedData = False\n\
                    ElementDataFile = LIST 2D\ns0.raw\n\ns1.raw\n";
        std::fs::write(dir.path().join("s1.raw"), &voxels[6..]).unwrap();
        std::fs::write(dir.path().join("b.mhd"), list).unwrap();
        let image = read(&dir.path().join("b.mhd")).unwrap();
        assert_eq!(image.buffer(), &VoxelBuffer::U8(voxels));

        let missing =
            "NDims = 3\nDimSize = 3 2 2\nElementType = MET_UCHAR\nElementDataFile = no.raw\n";
        std::fs::write(dir.path().join("c.mhd"), missing).unwrap();
        let e = read(&dir.path().join("c.mhd")).unwrap_err();
        assert_eq!(e.kind(), crate::ErrorKind::Io);
        assert!(
            e.message().contains("c.mhd") && e.message().contains("no.raw"),
            "{e}"
        );
    }

    #[test]
    fn unsupported_headers_say_what_is_wrong() {
        let cases = [
            ("NDims = 3\nDimSize = 157 393\n", "DimSize needs 3 values, found 2"),
            ("NDims = 4\nDimSize = 1 1 1 1\n", "NDims = 4"),
            ("NDims = 3\nDimSize = 1 1 1\nElementType = MET_LONG_LONG\n", "MET_LONG_LONG"),
            (
                "NDims = 3\nDimSize = 1 1 1\nElementNumberOfChannels = 3\nElementType = MET_UCHAR\n",
                "ElementNumberOfChannels = 3",
            ),
            ("NDims = 3\nDimSize = 1 1 1\nElementType = MET_UCHAR\nCompressedData = maybe\n", "True or False"),
            ("NDims = 3\nDimSize = 2 2 2\nElementType = MET_FLOAT\n", "need 32"),
            ("NDims = 3\nDimSize = 9999999 9999999 9999999\nElementType = MET_DOUBLE\n", "overflow"),
            ("NDims = 3\nDimSize = 99999 99999 99\nElementType = MET_DOUBLE\n", "need 7919"),
            (
                "NDims = 3\nDimSize = 99999 99999 99999\nElementType = MET_DOUBLE\nCompressedData = True\n",
                "cannot hold",
            ),
            ("NDims = 3\nDimSize = 1 1 1\nElementType = MET_UCHAR\nTransformMatrix = 1 0 0 1 0 0 0 0 1\n", "singular"),
        ];
        for (fields, expected) in cases {
            let file = format!("{fields}ElementDataFile = LOCAL\n\x01\x02\x03\x04");
            let e = decode(file.as_bytes(), Path::new("aorta.mha")).unwrap_err();
            assert_eq!(e.kind(), crate::ErrorKind::Format);
            assert!(e.message().contains(expected), "{fields}: {e}");
        }
        let e = decode(b"\x89PNG\r\n", Path::new("x.mha")).unwrap_err();
        assert!(e.message().contains("not 'Key = Value'"), "{e}");
    }

    #[test]
    fn errors_name_the_file() {
        let dir = scratch_dir();
        let path = dir.path().join("aorta.mha");
        std::fs::write(
            &path,
            "NDims = 3\nDimSize = 157 393\nElementDataFile = LOCAL\n",
        )
        .unwrap();
        let e = read(&path).unwrap_err();
        assert_eq!(
            e.message(),
            format!("{}: DimSize needs 3 values, found 2", path.display())
        );
    }

    #[test]
    fn truncated_or_corrupted_files_never_panic() {
        let image = pattern_image(ScalarType::F32, [3, 4, 2], oblique_geometry(), 1);
        let dir = scratch_dir();
        let path = dir.path().join("t.mha");
        write(&path, &image).unwrap();
        let compressed = std::fs::read(&path).unwrap();
        let raw_header = header_text(&image, 0, "LOCAL")
            .replace("CompressedData = True", "CompressedData = False");
        let mut raw = raw_header.into_bytes();
        raw.extend_from_slice(&image.buffer().to_le_bytes());
        for file in [compressed, raw] {
            assert_never_panics(&file, &image, |b| decode(b, &path));
        }
    }

    fn voxel_sum(image: &Image) -> f64 {
        let VoxelBuffer::F32(v) = image.buffer() else {
            panic!("float32 expected")
        };
        v.iter().map(|&x| x as f64).sum()
    }

    #[test]
    fn reads_the_vmtk_aorta_as_itk_does() {
        let Some(dir) = data_dir() else { return };
        let image = read(&dir.join("vmtk-aorta/aorta.mha")).unwrap();
        assert_eq!(image.scalar_type(), ScalarType::F32);
        assert_eq!(image.dims(), [157, 393, 34]);
        let g = image.geometry();
        assert_eq!(g.spacing(), [0.878906, 0.878906, 1.50009]);
        assert_eq!(g.direction(), [-1., 0., 0., 0., -1., 0., 0., 0., 1.]);
        assert_eq!(g.origin(), [-156.445, -24.6094, 0.0]);
        // SimpleITK 2.5 reads 1855.9199 there and a voxel sum of 593110274.2395.
        assert_eq!(image.view().get_f64(74, 150, 15), 1855.9199_f32 as f64);
        assert!((voxel_sum(&image) - 593110274.2395).abs() < 1.0);
        let seed = g.index_to_world(glam::DVec3::new(74.0, 150.0, 15.0));
        assert!(
            (seed - glam::DVec3::new(-221.484, -156.445, 22.501))
                .abs()
                .max_element()
                < 1e-3
        );
    }

    #[test]
    fn reads_the_vtk_carotid() {
        let Some(dir) = data_dir() else { return };
        let image = read(&dir.join("vtk-carotid/carotid.mha")).unwrap();
        assert_eq!(image.dims(), [76, 49, 45]);
        assert_eq!(image.scalar_type(), ScalarType::F32);
        // SimpleITK 2.5 reads 403 at the seed and a voxel sum of 16598647.
        assert_eq!(image.view().get_f64(17, 23, 8), 403.0);
        assert!((voxel_sum(&image) - 16_598_647.0).abs() < 1e-3);
        assert_eq!(
            *image.geometry(),
            Geometry::with_spacing([1.0; 3], [100.0, 80.0, 1.0]).unwrap()
        );
    }
}
