//! The crate's error type: every failure names its cause (file and line, or
//! the limit that was passed).

use std::path::PathBuf;

/// Every failure of the crate; `Display` gives one line naming the cause.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file read or written.
        path: PathBuf,
        /// What the operating system reported.
        source: std::io::Error,
    },
    /// A malformed or invalid input file; `line` is 1-based where known.
    #[error("{}{}: {message}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    Parse {
        /// The file parsed.
        path: PathBuf,
        /// 1-based line of the fault in a text format; `None` for a binary
        /// format (`message` then names the byte offset) or the whole file.
        line: Option<usize>,
        /// What is wrong.
        message: String,
    },
    /// An input the call cannot use: an unknown name (a structure, a scene,
    /// an image format), slices of different lengths, a size out of range, a
    /// BVH a layout cannot encode.
    #[error("{0}")]
    Invalid(String),
    /// A tree that does not fit a layout: too deep, too many nodes, an offset
    /// that overflows its bits, a reservation beyond a limit.
    #[error("{0}")]
    Limit(String),
}

/// `std::result::Result` with the crate's [`Error`].
pub type Result<T> = std::result::Result<T, Error>;
