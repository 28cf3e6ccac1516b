//! The crate's error type: every failure names its cause (file and line, or
//! the limit that was passed).

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    /// A malformed or invalid input file; `line` is 1-based where known.
    #[error("{}{}: {message}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    Parse {
        path: PathBuf,
        line: Option<usize>,
        message: String,
    },
    #[error("{0}")]
    Invalid(String),
    /// A tree that does not fit a layout: too deep, too many nodes, an offset
    /// that overflows its bits, a reservation beyond a limit.
    #[error("{0}")]
    Limit(String),
}

pub type Result<T> = std::result::Result<T, Error>;
