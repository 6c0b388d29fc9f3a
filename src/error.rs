//! The library's one error type.
//!
//! Every user-facing failure is a single line naming the file, the place in it and the problem
//! (docs/design.md §7, §8): `file: place: problem`. The binary maps [`Error`] to exit status 2.

use std::fmt;
use std::path::{Path, PathBuf};

/// A failure of `fosls`, always printable as one line.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Bad input: the file, the place in it (array, cell, key, line) and what is wrong.
    #[error("{}: {place}: {problem}", file.display())]
    Input {
        file: PathBuf,
        place: String,
        problem: String,
    },
    /// An operating-system failure while reading or writing `file`.
    #[error("{}: {source}", file.display())]
    Io {
        file: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// Wrong usage of the command line or the library (no file involved).
    #[error("{0}")]
    Usage(String),
}

impl Error {
    /// Bad input in `file` at `place`.
    pub fn input(file: &Path, place: impl fmt::Display, problem: impl fmt::Display) -> Self {
        Error::Input {
            file: file.to_path_buf(),
            place: place.to_string(),
            problem: problem.to_string(),
        }
    }

    /// An I/O failure on `file`.
    pub fn io(file: &Path, source: std::io::Error) -> Self {
        Error::Io {
            file: file.to_path_buf(),
            source,
        }
    }
}

/// The library's result type.
pub type Result<T> = std::result::Result<T, Error>;
