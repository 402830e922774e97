//! How VTK XML files store a DataArray: `ascii` text, inline base64 (`binary`) or `appended`
//! after the XML (raw bytes or base64). Binary data starts with a header of UInt32 or UInt64
//! words: the byte count, or with `vtkZLibDataCompressor` the block count, the block size, the
//! size of a partial last block (0 when full) and each block's compressed size.
//!
//! VTK base64-encodes the header and the data separately (each padded), while some writers
//! encode them as one stream; decoding group by group, a padded group ending a segment, reads
//! both.

use std::borrow::Cow;
use std::io::Read;

use base64::engine::general_purpose::STANDARD;
use base64::Engine;
use rayon::prelude::*;

use super::scan::{self, Cursor, Encoding, NumType};
use super::xml::Element;
use crate::error::{Error, Result};
use crate::volume::{ScalarType, VoxelBuffer};

/// Where appended arrays live: the bytes after the `_` marker of `<AppendedData>`.
#[derive(Debug, Clone, Copy)]
enum Appended<'a> {
    Raw(&'a [u8]),
    Base64(&'a [u8]),
}

/// File-wide storage settings, from the `VTKFile` element's attributes.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Storage<'a> {
    big_endian: bool,
    header: NumType,
    compressed: bool,
    appended: Option<Appended<'a>>,
}

/// A decoded DataArray: element type, components and the values (text or bytes).
#[derive(Debug)]
pub(crate) struct Array<'a> {
    pub ty: NumType,
    pub components: usize,
    big_endian: bool,
    payload: Payload<'a>,
}

#[derive(Debug)]
enum Payload<'a> {
    Text(&'a [u8]),
    /// Borrowed from the file when stored raw and uncompressed.
    Bytes(Cow<'a, [u8]>),
}

pub(crate) fn num_type(name: &str) -> Result<NumType> {
    Ok(match name {
        "Int8" => NumType::I8,
        "UInt8" => NumType::U8,
        "Int16" => NumType::I16,
        "UInt16" => NumType::U16,
        "Int32" => NumType::I32,
        "UInt32" => NumType::U32,
        "Int64" => NumType::I64,
        "UInt64" => NumType::U64,
        "Float32" => NumType::F32,
        "Float64" => NumType::F64,
        _ => {
            return Err(Error::format(format!(
                "unsupported DataArray type {name:?}"
            )))
        }
    })
}

/// The bytes of one binary block (header and data), still encoded.
enum Source<'a> {
    Raw(&'a [u8]),
    Base64(Cow<'a, [u8]>),
}

impl<'a> Source<'a> {
    /// At most this many bytes can be decoded.
    fn capacity(&self) -> usize {
        match self {
            Source::Raw(bytes) => bytes.len(),
            Source::Base64(text) => text.len() / 4 * 3,
        }
    }

    /// The first `n` decoded bytes.
    fn prefix(&self, n: usize) -> Result<Cow<'a, [u8]>> {
        match *self {
            Source::Raw(bytes) => bytes.get(..n).map(Cow::Borrowed).ok_or_else(scan::eof),
            Source::Base64(ref text) => decode_base64_prefix(text, n).map(Cow::Owned),
        }
    }
}

/// Decodes base64 until `n` bytes are out. A group with padding ends a segment and the next
/// segment starts right after it, so separately encoded header and data decode as one stream.
fn decode_base64_prefix(text: &[u8], n: usize) -> Result<Vec<u8>> {
    let mut out = Vec::with_capacity(n);
    let mut pos = 0;
    while out.len() < n {
        let want = (n - out.len()).div_ceil(3) * 4;
        let window = &text[pos..(pos + want).min(text.len())];
        let end = match window.iter().position(|&c| c == b'=') {
            Some(pad) => (pos + (pad / 4 + 1) * 4).min(text.len()),
            None => pos + window.len() / 4 * 4,
        };
        if end == pos {
            return Err(scan::eof());
        }
        STANDARD
            .decode_vec(&text[pos..end], &mut out)
            .map_err(|e| Error::format(format!("invalid base64 data: {e}")))?;
        pos = end;
    }
    out.truncate(n);
    Ok(out)
}

impl<'a> Storage<'a> {
    /// Settings from the root `VTKFile` element and the appended data, if any.
    pub fn new(root: &Element, appended: Option<(&Element, &'a [u8])>) -> Result<Self> {
        let big_endian = match root.attribute("byte_order").unwrap_or("LittleEndian") {
            "LittleEndian" => false,
            "BigEndian" => true,
            other => return Err(Error::format(format!("unknown byte_order {other:?}"))),
        };
        let header = match root.attribute("header_type").unwrap_or("UInt32") {
            "UInt32" => NumType::U32,
            "UInt64" => NumType::U64,
            other => return Err(Error::format(format!("unknown header_type {other:?}"))),
        };
        let compressed = match root.attribute("compressor") {
            None | Some("") => false,
            Some("vtkZLibDataCompressor") => true,
            Some(other) => {
                return Err(Error::format(format!(
                    "compressor {other:?} is not supported; save the file with zlib compression \
                     or none"
                )))
            }
        };
        let appended = match appended {
            None => None,
            Some((element, bytes)) => Some(match element.attribute("encoding") {
                Some("raw") => Appended::Raw(bytes),
                Some("base64") => Appended::Base64(bytes),
                other => {
                    return Err(Error::format(format!(
                        "unknown AppendedData encoding {other:?}"
                    )))
                }
            }),
        };
        Ok(Storage {
            big_endian,
            header,
            compressed,
            appended,
        })
    }

    /// Reads the array stored by a `DataArray` element.
    pub fn array(&self, element: &Element<'a>) -> Result<Array<'a>> {
        let name = element.attribute("Name").unwrap_or("");
        self.read_array(element)
            .map_err(|e| e.context(format!("DataArray {name:?}")))
    }

    fn read_array(&self, element: &Element<'a>) -> Result<Array<'a>> {
        let ty = num_type(element.attribute("type").unwrap_or(""))?;
        let components =
            match element.attribute("NumberOfComponents") {
                None => 1,
                Some(n) => n.trim().parse().ok().filter(|&n| n > 0).ok_or_else(|| {
                    Error::format(format!("NumberOfComponents {n:?} is not a count"))
                })?,
            };
        let payload = match element.attribute("format").unwrap_or("ascii") {
            "ascii" => Payload::Text(element.text),
            "binary" => {
                let text = element.text;
                let text = if text.iter().any(u8::is_ascii_whitespace) {
                    Cow::Owned(
                        text.iter()
                            .copied()
                            .filter(|b| !b.is_ascii_whitespace())
                            .collect(),
                    )
                } else {
                    Cow::Borrowed(text)
                };
                Payload::Bytes(self.block(&Source::Base64(text))?)
            }
            "appended" => {
                let offset: usize = element
                    .attribute("offset")
                    .and_then(|o| o.trim().parse().ok())
                    .ok_or_else(|| Error::format("appended DataArray without a valid offset"))?;
                let at = |bytes: &'a [u8]| {
                    bytes.get(offset..).ok_or_else(|| {
                        Error::format(format!(
                            "offset {offset} is beyond the {} bytes of appended data",
                            bytes.len()
                        ))
                    })
                };
                let source = match self.appended {
                    None => return Err(Error::format("appended DataArray but no AppendedData")),
                    Some(Appended::Raw(bytes)) => Source::Raw(at(bytes)?),
                    Some(Appended::Base64(text)) => Source::Base64(Cow::Borrowed(at(text)?)),
                };
                Payload::Bytes(self.block(&source)?)
            }
            other => return Err(Error::format(format!("unknown DataArray format {other:?}"))),
        };
        Ok(Array {
            ty,
            components,
            big_endian: self.big_endian,
            payload,
        })
    }

    /// Header word `i` of `header`.
    fn word(&self, header: &[u8], i: usize) -> usize {
        let size = self.header.size();
        self.header.decode(&header[i * size..], self.big_endian) as usize
    }

    /// The data bytes of one binary block, decompressed.
    fn block(&self, source: &Source<'a>) -> Result<Cow<'a, [u8]>> {
        let size = self.header.size();
        let too_big = |what: &str, n: usize| {
            Error::format(format!(
                "the header claims {n} {what} but only {} bytes follow; the file is truncated or \
                 corrupt",
                source.capacity()
            ))
        };
        if !self.compressed {
            let n = self.word(&source.prefix(size)?, 0);
            let end = n.checked_add(size).filter(|&e| e <= source.capacity());
            let end = end.ok_or_else(|| too_big("bytes", n))?;
            return Ok(match source.prefix(end)? {
                Cow::Borrowed(all) => Cow::Borrowed(&all[size..]),
                Cow::Owned(mut all) => {
                    all.drain(..size);
                    Cow::Owned(all)
                }
            });
        }
        let head = source.prefix(3 * size)?;
        let (blocks, block_size, last_size) = (
            self.word(&head, 0),
            self.word(&head, 1),
            self.word(&head, 2),
        );
        if blocks > source.capacity() / size {
            return Err(too_big("compressed blocks", blocks));
        }
        let header_len = (3 + blocks) * size;
        let head = source.prefix(header_len)?;
        let sizes: Vec<usize> = (0..blocks).map(|b| self.word(&head, 3 + b)).collect();
        let end = sizes
            .iter()
            .try_fold(header_len, |a, &s| a.checked_add(s))
            .filter(|&e| e <= source.capacity())
            .ok_or_else(|| {
                too_big(
                    "compressed bytes",
                    sizes.iter().fold(0, |a: usize, &s| a.saturating_add(s)),
                )
            })?;
        let all = source.prefix(end)?;
        let starts: Vec<usize> = sizes
            .iter()
            .scan(header_len, |at, &size| {
                *at += size;
                Some(*at - size)
            })
            .collect();
        // Blocks inflate independently; errors are reported for the first bad block in order.
        let inflated: Vec<Result<Vec<u8>>> = (0..blocks)
            .into_par_iter()
            .map(|b| {
                let expected = if b + 1 == blocks && last_size != 0 {
                    last_size
                } else {
                    block_size
                };
                inflate(&all[starts[b]..starts[b] + sizes[b]], expected)
                    .map_err(|e| e.context(format!("compressed block {b}")))
            })
            .collect();
        let mut out = Vec::new();
        for block in inflated {
            out.extend_from_slice(&block?);
        }
        Ok(Cow::Owned(out))
    }
}

impl Array<'_> {
    /// Every value as f64.
    pub fn numbers(&self) -> Result<Vec<f64>> {
        match &self.payload {
            Payload::Text(text) => {
                let mut cursor = Cursor::new(text);
                let mut values = Vec::new();
                while let Some(word) = cursor.word() {
                    values.push(scan::text_number(word, self.ty, "DataArray value")?);
                }
                Ok(values)
            }
            Payload::Bytes(bytes) => {
                let size = self.ty.size();
                if bytes.len() % size != 0 {
                    return Err(Error::format(format!(
                        "{} bytes are not a whole number of {size}-byte values",
                        bytes.len()
                    )));
                }
                let mut cursor = Cursor::new(bytes);
                let encoding = Encoding::Binary {
                    big_endian: self.big_endian,
                };
                scan::numbers(&mut cursor, bytes.len() / size, self.ty, encoding, "values")
            }
        }
    }

    /// Exactly `count` values as voxels of `scalar_type` (which has the layout of `self.ty`).
    pub fn voxels(&self, count: usize, scalar_type: ScalarType) -> Result<VoxelBuffer> {
        let (mut cursor, encoding) = match &self.payload {
            Payload::Text(text) => (Cursor::new(text), Encoding::Text),
            Payload::Bytes(bytes) => (
                Cursor::new(bytes),
                Encoding::Binary {
                    big_endian: self.big_endian,
                },
            ),
        };
        let voxels = scan::voxels(&mut cursor, count, scalar_type, encoding)?;
        let more = match encoding {
            Encoding::Text => cursor.peek_word().is_some(),
            Encoding::Binary { .. } => cursor.remaining() > 0,
        };
        if more {
            return Err(Error::format(format!(
                "the array holds more than the {count} voxels of its extent"
            )));
        }
        Ok(voxels)
    }
}

/// A zlib stream that must inflate to exactly `expected` bytes.
fn inflate(compressed: &[u8], expected: usize) -> Result<Vec<u8>> {
    let mut out = Vec::new();
    // Reading at most one byte more than announced bounds the output by the header, whatever
    // the compressed stream holds.
    flate2::read::ZlibDecoder::new(compressed)
        .take((expected as u64).saturating_add(1))
        .read_to_end(&mut out)
        .map_err(|e| Error::format(e.to_string()))?;
    if out.len() != expected {
        return Err(Error::format(format!(
            "inflates to {} bytes, not the {expected} of its header",
            out.len()
        )));
    }
    Ok(out)
}

/// `raw` as the pieces of an appended binary block, to be written one after the other: its
/// UInt64 header, then its data, zlib-compressed in 32 KiB blocks (VTK's default block size)
/// when `compress`. Uncompressed data is moved, not copied.
pub(crate) fn encode(raw: Vec<u8>, compress: bool) -> Vec<Vec<u8>> {
    if !compress {
        return vec![(raw.len() as u64).to_le_bytes().to_vec(), raw];
    }
    const BLOCK: usize = 1 << 15;
    // Blocks are independent, so compressing them in parallel gives the same bytes.
    let blocks: Vec<Vec<u8>> = raw
        .par_chunks(BLOCK)
        .map(|chunk| {
            let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
            std::io::Write::write_all(&mut z, chunk).expect("writing to a Vec cannot fail");
            z.finish().expect("writing to a Vec cannot fail")
        })
        .collect();
    let sizes = blocks.iter().map(Vec::len);
    let header = [blocks.len(), BLOCK, raw.len() % BLOCK]
        .into_iter()
        .chain(sizes)
        .flat_map(|word| (word as u64).to_le_bytes())
        .collect();
    std::iter::once(header).chain(blocks).collect()
}
