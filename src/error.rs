//! The library's one error type: a kind that callers (and the C ABI) can branch on, and a
//! message written for the person who has to fix the input — what is wrong and what to change.

use std::fmt;

/// What went wrong, coarse enough to map one-to-one onto the C ABI's status codes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ErrorKind {
    /// A parameter or argument is out of range or inconsistent.
    InvalidArgument,
    /// A volume's sizes, strides, spacing or direction are unusable.
    InvalidVolume,
    /// A mesh has out-of-range indices, non-finite points or a structure the operation needs.
    InvalidMesh,
    /// A file could not be read or written.
    Io,
    /// A file was read but its contents are corrupt, truncated or unsupported.
    Format,
    /// The caller's progress callback asked to stop.
    Cancelled,
    /// The balloon grew past its vertex limit: it has most likely leaked out of the structure.
    Leak,
    /// A result failed the library's own guarantees (a bug: please report it with the input).
    Internal,
    /// A buffer the input or the parameters call for could not be allocated.
    OutOfMemory,
}

/// An error with a human-readable message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Error {
    kind: ErrorKind,
    message: String,
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    pub fn new(kind: ErrorKind, message: impl Into<String>) -> Self {
        Error {
            kind,
            message: message.into(),
        }
    }

    pub fn invalid_argument(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::InvalidArgument, message)
    }

    pub fn invalid_volume(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::InvalidVolume, message)
    }

    pub fn invalid_mesh(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::InvalidMesh, message)
    }

    pub fn io(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::Io, message)
    }

    pub fn format(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::Format, message)
    }

    pub fn cancelled(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::Cancelled, message)
    }

    pub fn leak(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::Leak, message)
    }

    pub fn internal(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::Internal, message)
    }

    pub fn out_of_memory(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::OutOfMemory, message)
    }

    pub fn kind(&self) -> ErrorKind {
        self.kind
    }

    pub fn message(&self) -> &str {
        &self.message
    }

    /// The same error with `context` put in front of its message (for example the file name).
    pub fn context(self, context: impl fmt::Display) -> Self {
        Error {
            kind: self.kind,
            message: format!("{context}: {}", self.message),
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Error {}
