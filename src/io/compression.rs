//! zlib and gzip streams of voxel data. A stream is inflated straight into the voxels' buffer,
//! exactly as many bytes as the header promises (then one more is asked for, to notice a stream
//! that holds more), and a promise that no DEFLATE stream of that length could keep is refused
//! before anything is allocated, so a lying header cannot make a reader allocate more than the
//! file really holds.

use std::borrow::Cow;
use std::io::{BufRead, Read, Write};

use flate2::read::{MultiGzDecoder, ZlibDecoder};
use flate2::write::{GzEncoder, ZlibEncoder};
use flate2::Compression;

use super::progress::{ReadStage, Reported};
use crate::error::{Error, Result};
use crate::volume::{ScalarType, VoxelBuffer};

/// DEFLATE expands at most about 1032:1 (a 258-byte match coded in two bits).
const MAX_DEFLATE_RATIO: usize = 1032;
/// zlib or gzip framing on top of the DEFLATE bound.
const FRAMING_BYTES: usize = 64;
/// zlib level 1: on a CT scan it writes about ten times faster than the default level 6 for
/// files about a fifth larger (aorta.mha: 4.0 MB instead of 3.4 MB).
const LEVEL: Compression = Compression::fast();

/// Refuses `expected` decompressed bytes from `compressed_len` bytes when DEFLATE cannot do it.
pub(crate) fn check_ratio(compressed_len: usize, expected: usize) -> Result<()> {
    let bound = compressed_len
        .saturating_mul(MAX_DEFLATE_RATIO)
        .saturating_add(FRAMING_BYTES);
    if expected > bound {
        return Err(Error::format(format!(
            "the header promises {expected} bytes of voxels but {compressed_len} compressed bytes \
             cannot hold more than {bound}: the header is wrong or the data truncated"
        )));
    }
    Ok(())
}

/// A data file's voxels as a reader finds them: raw bytes, or a zlib or gzip stream that
/// inflates to `skip` bytes to drop and then `voxel_bytes` bytes of voxels. A stream stays
/// compressed until the voxels' buffer is built and is inflated straight into it, so that the
/// inflated bytes are never held beside the buffer.
pub(crate) enum VoxelData<'a> {
    Raw(Cow<'a, [u8]>),
    Compressed {
        stream: Cow<'a, [u8]>,
        skip: usize,
        voxel_bytes: usize,
    },
}

impl<'a> VoxelData<'a> {
    /// The voxels, of `scalar` in the given byte order.
    pub(crate) fn into_buffer(
        self,
        scalar: ScalarType,
        little_endian: bool,
    ) -> Result<VoxelBuffer> {
        match self {
            VoxelData::Raw(bytes) => VoxelBuffer::from_bytes(scalar, &bytes, little_endian),
            VoxelData::Compressed {
                stream,
                skip,
                voxel_bytes,
            } => {
                let size = scalar.size_in_bytes();
                if voxel_bytes % size != 0 {
                    return Err(Error::format(format!(
                        "{voxel_bytes} bytes is not a whole number of {} voxels",
                        scalar.name()
                    )));
                }
                let count = voxel_bytes / size;
                inflate_voxels(
                    &stream[..],
                    stream.len(),
                    skip,
                    scalar,
                    count,
                    little_endian,
                )
            }
        }
    }

    /// The same data owning its bytes (from a data file read into a local buffer).
    pub(crate) fn into_owned(self) -> VoxelData<'static> {
        match self {
            VoxelData::Raw(bytes) => VoxelData::Raw(Cow::Owned(bytes.into_owned())),
            VoxelData::Compressed {
                stream,
                skip,
                voxel_bytes,
            } => VoxelData::Compressed {
                stream: Cow::Owned(stream.into_owned()),
                skip,
                voxel_bytes,
            },
        }
    }

    /// The voxels' bytes (one part of a data file LIST, which are joined as bytes).
    pub(crate) fn into_bytes(self) -> Result<Cow<'a, [u8]>> {
        match self {
            VoxelData::Raw(bytes) => Ok(bytes),
            compressed => match compressed.into_buffer(ScalarType::U8, true)? {
                VoxelBuffer::U8(bytes) => Ok(Cow::Owned(bytes)),
                _ => unreachable!("bytes are read as uint8"),
            },
        }
    }
}

/// Exactly `count` voxels from the zlib or gzip stream of `compressed_len` bytes that `source`
/// gives (told apart by gzip's magic bytes, as MetaIO does), after its first `skip` inflated
/// bytes; a stream that ends sooner or holds more is an error, and so is a promise no stream of
/// that length could keep (refused before anything is allocated).
pub(crate) fn inflate_voxels(
    mut source: impl BufRead,
    compressed_len: usize,
    skip: usize,
    scalar: ScalarType,
    count: usize,
    little_endian: bool,
) -> Result<VoxelBuffer> {
    let expected = count
        .checked_mul(scalar.size_in_bytes())
        .and_then(|bytes| bytes.checked_add(skip))
        .ok_or_else(|| Error::format("the header's sizes are impossibly large"))?;
    check_ratio(compressed_len, expected)?;
    let gzipped = source
        .fill_buf()
        .map_err(|e| Error::io(format!("cannot read the compressed voxel data ({e})")))?
        .starts_with(&[0x1f, 0x8b]);
    let mut source = Reported::new(source, compressed_len as u64, ReadStage::Decompressing);
    let mut inflated: Box<dyn Read + '_> = if gzipped {
        Box::new(MultiGzDecoder::new(&mut source))
    } else {
        Box::new(ZlibDecoder::new(&mut source))
    };
    let corrupt = |e: std::io::Error| {
        Error::format(format!(
            "the compressed voxel data is corrupt or truncated ({e})"
        ))
    };
    let outcome = (|| {
        let skipped = std::io::copy(&mut (&mut inflated).take(skip as u64), &mut std::io::sink())
            .map_err(corrupt)?;
        if skipped < skip as u64 {
            return Err(Error::format(format!(
                "the compressed data holds {skipped} bytes but the header's skip and sizes need \
                 {expected}: the file is truncated or its header is wrong"
            )));
        }
        let buffer = VoxelBuffer::read_from(scalar, count, little_endian, &mut inflated)?;
        if inflated.read(&mut [0]).map_err(corrupt)? > 0 {
            return Err(Error::format(format!(
                "the compressed data holds more than the {expected} bytes the header's sizes and \
                 type need: the header does not match the data"
            )));
        }
        Ok(buffer)
    })();
    drop(inflated);
    match source.cancelled() {
        Some(cancelled) => Err(cancelled),
        None => outcome,
    }
}

/// `count` voxels of `scalar` streamed from `data` (`len` bytes) into their buffer: through
/// [`inflate_voxels`] when `compressed`, else read as they are after `skip` bytes, reporting
/// the reading to the progress sink.
pub(crate) fn stream_voxels(
    mut data: impl BufRead,
    len: u64,
    compressed: bool,
    skip: usize,
    scalar: ScalarType,
    count: usize,
    little_endian: bool,
) -> Result<VoxelBuffer> {
    if compressed {
        let len = usize::try_from(len).unwrap_or(usize::MAX);
        return inflate_voxels(data, len, skip, scalar, count, little_endian);
    }
    let needed = count
        .checked_mul(scalar.size_in_bytes())
        .and_then(|bytes| bytes.checked_add(skip))
        .ok_or_else(|| Error::format("the header's sizes are impossibly large"))?;
    if needed as u64 > len {
        return Err(Error::format(format!(
            "the voxel data holds {len} bytes but the header's sizes, type and skip need \
             {needed}: the file is truncated or its header is wrong"
        )));
    }
    std::io::copy(&mut (&mut data).take(skip as u64), &mut std::io::sink())
        .map_err(|e| Error::io(format!("cannot read the voxel data ({e})")))?;
    let mut source = Reported::new(data, len - skip as u64, ReadStage::Reading);
    let read = VoxelBuffer::read_from(scalar, count, little_endian, &mut source);
    match source.cancelled() {
        Some(cancelled) => Err(cancelled),
        None => read,
    }
}

fn compress_error(e: std::io::Error) -> Error {
    Error::io(format!("cannot compress the voxel data: {e}"))
}

/// A zlib stream (MetaImage's `CompressedData = True`).
pub(crate) fn zlib(bytes: &[u8]) -> Result<Vec<u8>> {
    let mut encoder = ZlibEncoder::new(Vec::new(), LEVEL);
    encoder
        .write_all(bytes)
        .and_then(|()| encoder.finish())
        .map_err(compress_error)
}

/// A gzip stream (NRRD's `encoding: gzip`, `.nii.gz`).
pub(crate) fn gzip(bytes: &[u8]) -> Result<Vec<u8>> {
    let mut encoder = GzEncoder::new(Vec::new(), LEVEL);
    encoder
        .write_all(bytes)
        .and_then(|()| encoder.finish())
        .map_err(compress_error)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn inflated(stream: &[u8], skip: usize, bytes: usize) -> Result<Vec<u8>> {
        let data = VoxelData::Compressed {
            stream: Cow::Borrowed(stream),
            skip,
            voxel_bytes: bytes,
        };
        data.into_bytes().map(Cow::into_owned)
    }

    #[test]
    fn zlib_and_gzip_streams_inflate_to_exactly_the_promised_size() {
        let data: Vec<u8> = (0..1000u32).map(|i| (i * 7 % 251) as u8).collect();
        for stream in [zlib(&data).unwrap(), gzip(&data).unwrap()] {
            assert_eq!(inflated(&stream, 0, 1000).unwrap(), data);
            assert_eq!(inflated(&stream, 10, 990).unwrap(), &data[10..]);
            let short = inflated(&stream, 0, 1001).unwrap_err();
            assert!(
                short.message().contains("ends within the 1001 bytes"),
                "{short}"
            );
            let long = inflated(&stream, 0, 999).unwrap_err();
            assert!(long.message().contains("more than"), "{long}");
            assert!(inflated(&stream, 1001, 0).is_err());
            assert!(inflated(&stream[..stream.len() / 2], 0, 1000).is_err());
        }
    }

    #[test]
    fn voxels_inflate_in_their_type_and_byte_order() {
        let values: Vec<i16> = (0..500).map(|i| i * 37 - 9000).collect();
        let big: Vec<u8> = values.iter().flat_map(|v| v.to_be_bytes()).collect();
        let stream = zlib(&big).unwrap();
        let data = VoxelData::Compressed {
            stream: Cow::Borrowed(&stream),
            skip: 0,
            voxel_bytes: big.len(),
        };
        assert_eq!(
            data.into_buffer(ScalarType::I16, false).unwrap(),
            VoxelBuffer::I16(values)
        );
    }

    #[test]
    fn impossible_promises_are_refused_before_decompressing() {
        let stream = zlib(&[0u8; 100]).unwrap();
        let e = inflated(&stream, 0, 1 << 40).unwrap_err();
        assert!(e.message().contains("cannot hold more than"), "{e}");
        // A real maximal-ratio stream stays within the bound.
        let zeros = vec![0u8; 1 << 20];
        let stream = zlib(&zeros).unwrap();
        assert_eq!(
            inflated(&stream, 0, zeros.len()).unwrap().len(),
            zeros.len()
        );
    }
}
