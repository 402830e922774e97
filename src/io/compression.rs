//! zlib and gzip streams of voxel data. Decompression is capped at what the header promises
//! (plus one byte, to notice a stream that holds more), and a promise that no DEFLATE stream of
//! that length could keep is refused before anything is allocated, so a lying header cannot make
//! a reader allocate more than the file really holds.

use std::io::{Read, Write};

use flate2::read::{MultiGzDecoder, ZlibDecoder};
use flate2::write::{GzEncoder, ZlibEncoder};
use flate2::Compression;

use super::progress::{ReadStage, Reported};
use crate::error::{Error, Result};

/// DEFLATE expands at most about 1032:1 (a 258-byte match coded in two bits).
const MAX_DEFLATE_RATIO: usize = 1032;
/// zlib or gzip framing on top of the DEFLATE bound.
const FRAMING_BYTES: usize = 64;
/// zlib level 1: on a CT scan it writes about ten times faster than the default level 6 for
/// files about a fifth larger (aorta.mha: 4.0 MB instead of 3.4 MB).
const LEVEL: Compression = Compression::fast();
/// Up-front allocation relative to the compressed size; past it the output grows only as
/// decompressed bytes really arrive.
const PREALLOCATE_RATIO: usize = 16;

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

/// At most `limit` bytes of the zlib or gzip stream `data` (told apart by gzip's magic bytes,
/// as MetaIO does); fewer when the stream ends first.
pub(crate) fn inflate_prefix(data: &[u8], limit: usize) -> Result<Vec<u8>> {
    let mut out = Vec::with_capacity(limit.min(data.len().saturating_mul(PREALLOCATE_RATIO)));
    let mut source = Reported::new(data, data.len() as u64, ReadStage::Decompressing);
    let reader: Box<dyn Read + '_> = if data.starts_with(&[0x1f, 0x8b]) {
        Box::new(MultiGzDecoder::new(&mut source))
    } else {
        Box::new(ZlibDecoder::new(&mut source))
    };
    let inflated = reader.take(limit as u64).read_to_end(&mut out);
    if let Some(cancelled) = source.cancelled() {
        return Err(cancelled);
    }
    inflated.map_err(|e| {
        Error::format(format!(
            "the compressed voxel data is corrupt or truncated ({e})"
        ))
    })?;
    Ok(out)
}

/// Exactly `expected` bytes from a zlib or gzip stream; fewer or more is an error.
pub(crate) fn inflate_exact(data: &[u8], expected: usize) -> Result<Vec<u8>> {
    check_ratio(data.len(), expected)?;
    let out = inflate_prefix(data, expected.saturating_add(1))?;
    if out.len() < expected {
        return Err(Error::format(format!(
            "the compressed data holds {} bytes but the header's sizes and type need {expected}: \
             the file is truncated or its header is wrong",
            out.len()
        )));
    }
    if out.len() > expected {
        return Err(Error::format(format!(
            "the compressed data holds more than the {expected} bytes the header's sizes and type \
             need: the header does not match the data"
        )));
    }
    Ok(out)
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

    #[test]
    fn zlib_and_gzip_streams_inflate_to_exactly_the_promised_size() {
        let data: Vec<u8> = (0..1000u32).map(|i| (i * 7 % 251) as u8).collect();
        for stream in [zlib(&data).unwrap(), gzip(&data).unwrap()] {
            assert_eq!(inflate_exact(&stream, 1000).unwrap(), data);
            let short = inflate_exact(&stream, 1001).unwrap_err();
            assert!(short.message().contains("holds 1000 bytes"), "{short}");
            let long = inflate_exact(&stream, 999).unwrap_err();
            assert!(long.message().contains("more than"), "{long}");
            assert_eq!(inflate_prefix(&stream, 10).unwrap(), &data[..10]);
            assert!(inflate_exact(&stream[..stream.len() / 2], 1000).is_err());
        }
    }

    #[test]
    fn impossible_promises_are_refused_before_decompressing() {
        let stream = zlib(&[0u8; 100]).unwrap();
        let e = inflate_exact(&stream, 1 << 40).unwrap_err();
        assert!(e.message().contains("cannot hold more than"), "{e}");
        // A real maximal-ratio stream stays within the bound.
        let zeros = vec![0u8; 1 << 20];
        let stream = zlib(&zeros).unwrap();
        assert_eq!(
            inflate_exact(&stream, zeros.len()).unwrap().len(),
            zeros.len()
        );
    }
}
