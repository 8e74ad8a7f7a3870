//! One error type for the whole crate. Every failure the user can cause becomes a one-line message
//! (`FILE: what is wrong`), so the binaries can print it and exit with code 2 instead of panicking.

use std::fmt;
use std::path::Path;

/// A user-facing error: the file it concerns (if any) and what is wrong with it.
#[derive(Debug, Clone, PartialEq)]
pub struct Error {
    pub file: Option<String>,
    pub message: String,
}

pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    pub fn new(message: impl Into<String>) -> Self {
        Error {
            file: None,
            message: message.into(),
        }
    }

    pub fn in_file(file: impl AsRef<Path>, message: impl Into<String>) -> Self {
        Error {
            file: Some(file.as_ref().display().to_string()),
            message: message.into(),
        }
    }

    /// Attach a file name unless the error already names one (the innermost file is the precise one).
    pub fn with_file(mut self, file: impl AsRef<Path>) -> Self {
        if self.file.is_none() {
            self.file = Some(file.as_ref().display().to_string());
        }
        self
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // Newlines would break the one-line contract of the CLI.
        let msg = self.message.replace('\n', " ");
        match &self.file {
            Some(file) => write!(f, "{file}: {msg}"),
            None => write!(f, "{msg}"),
        }
    }
}

impl std::error::Error for Error {}

/// Build an `Error` with `format!` syntax.
#[macro_export]
macro_rules! err {
    ($($arg:tt)*) => { $crate::error::Error::new(format!($($arg)*)) };
}
