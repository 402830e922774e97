//! Whole-file reads and buffered writes, with errors that name the file.
//!
//! Most readers parse from memory: one read of the whole file is the fastest buffered IO there
//! is, and it lets every count in a header be checked against the bytes that really follow.
//! The volume readers that stream (NIfTI, MetaImage's attached voxels) check against the
//! file's size instead.

use std::fs::File;
use std::io::{BufWriter, Read, Write};
use std::path::Path;

use super::progress::{self, ReadStage};
use crate::allocation;
use crate::error::{Error, Result};

/// Bytes read per call, and between two progress reports.
const CHUNK: u64 = 8 << 20;

/// The whole content of `path`. A file larger than one chunk reports its reading to the
/// [`progress`] sink, chunk by chunk, and may be cancelled there.
pub(crate) fn read(path: &Path) -> Result<Vec<u8>> {
    let failed =
        |e: std::io::Error| Error::io(format!("{}: cannot read the file: {e}", path.display()));
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
