//! Whole-file reads and buffered writes, with errors that name the file.
//!
//! Most readers parse from memory: one read of the whole file is the fastest buffered IO there
//! is, and it lets every count in a header be checked against the bytes that really follow.
//! The volume readers that stream (NIfTI, the voxels after a MetaImage or NRRD header) check
//! against the file's size instead.

use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Seek, SeekFrom, Write};
use std::path::Path;

use super::progress::{self, ReadStage};
use crate::allocation;
use crate::error::{Error, Result};

/// Bytes read per call, and between two progress reports.
const CHUNK: u64 = 8 << 20;

/// The whole content of `path`. A file larger than one chunk reports its reading to the
/// [`progress`] sink, chunk by chunk, and may be cancelled there.
pub(crate) fn read(path: &Path) -> Result<Vec<u8>> {
    let failed = |e: std::io::Error| read_error(path, e);
    let mut file = File::open(path).map_err(failed)?;
    let size = file.metadata().map_err(failed)?.len();
    let capacity = usize::try_from(size).unwrap_or(usize::MAX);
    let mut bytes = allocation::with_capacity(capacity, "the file's bytes")?;
    loop {
        let read = (&mut file)
            .take(CHUNK)
            .read_to_end(&mut bytes)
            .map_err(failed)?;
        if read == 0 {
            return Ok(bytes);
        }
        if size > CHUNK {
            progress::report(bytes.len() as f64 / size as f64, ReadStage::Reading)?;
        }
    }
}

/// The bytes read first, in which a text header must end for the voxels after it to be
/// streamed from the file: MetaImage and NRRD headers take a few hundred bytes.
pub(crate) const HEADER_PREFIX: u64 = 4096;

/// The first [`HEADER_PREFIX`] bytes of a file, for a text header parsed from memory with the
/// voxels after it streamed from the file.
pub(crate) struct HeaderPrefix<'p> {
    path: &'p Path,
    file: File,
    size: u64,
    pub bytes: Vec<u8>,
}

impl<'p> HeaderPrefix<'p> {
    pub fn open(path: &'p Path) -> Result<Self> {
        let mut file = File::open(path).map_err(|e| read_error(path, e))?;
        let size = file.metadata().map_err(|e| read_error(path, e))?.len();
        let mut bytes = Vec::new();
        (&mut file)
            .take(HEADER_PREFIX)
            .read_to_end(&mut bytes)
            .map_err(|e| read_error(path, e))?;
        Ok(HeaderPrefix {
            path,
            file,
            size,
            bytes,
        })
    }

    /// Whether the prefix is the whole file.
    pub fn is_whole_file(&self) -> bool {
        self.size <= self.bytes.len() as u64
    }

    /// The file from byte `start` on, buffered, and how many bytes that is. From the file
    /// itself, not the prefix chained before it: an inflater's first read must see both of
    /// gzip's magic bytes.
    pub fn data_from(mut self, start: usize) -> Result<(BufReader<File>, u64)> {
        self.file
            .seek(SeekFrom::Start(start as u64))
            .map_err(|e| read_error(self.path, e))?;
        let len = self.size.saturating_sub(start as u64);
        Ok((BufReader::with_capacity(1 << 20, self.file), len))
    }
}

fn read_error(path: &Path, e: std::io::Error) -> Error {
    Error::io(format!("{}: cannot read the file: {e}", path.display()))
}

/// Creates (or truncates) `path` and fills it through a buffered writer.
pub(crate) fn write(
    path: &Path,
    fill: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<()> {
    let failed = |e: std::io::Error| {
        Error::io(format!(
            "{}: cannot write the file: {e}; check that the folder exists and is writable",
            path.display()
        ))
    };
    let mut out = BufWriter::with_capacity(1 << 20, File::create(path).map_err(failed)?);
    fill(&mut out).map_err(failed)?;
    out.flush().map_err(failed)
}

/// Creates (or truncates) `path` with `bytes` as its content.
pub(crate) fn write_all(path: &Path, bytes: &[u8]) -> Result<()> {
    write(path, |out| out.write_all(bytes))
}

/// Parses `bytes` with `parse` and puts the file name in front of any error.
pub(crate) fn parse_file<T>(path: &Path, parse: impl FnOnce(&[u8]) -> Result<T>) -> Result<T> {
    let bytes = read(path)?;
    parse(&bytes).map_err(|e| e.context(path.display()))
}
