//! The two calls of balloonseg's `crate::error` that the XML parsers make, so that they compile
//! here unchanged.

#[derive(Debug)]
pub struct Error(String);

impl Error {
    pub fn format(message: impl Into<String>) -> Self {
        Error(message.into())
    }
}

impl std::fmt::Display for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

pub type Result<T> = std::result::Result<T, Error>;
