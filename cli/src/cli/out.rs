//! Standard output that a closed pipe does not break. `println!` panics when
//! the reader has gone (`raytree info | head -3`); [`say!`] stops printing
//! instead, and the command goes on to write its files and exit as it
//! would have. Any other failure to write is reported once on stderr and
//! makes the command fail.

use std::io::{ErrorKind, Write};
use std::sync::atomic::{AtomicBool, Ordering};

/// The reader of standard output has gone.
static CLOSED: AtomicBool = AtomicBool::new(false);
/// The report goes to standard error: standard output carries the data.
static TO_STDERR: AtomicBool = AtomicBool::new(false);
/// Writing to standard output failed otherwise (a full disk, say).
static FAILED: AtomicBool = AtomicBool::new(false);

/// `println!` on standard output, through [`line`].
macro_rules! say {
    () => {
        $crate::cli::out::line(format_args!(""))
    };
    ($($arg:tt)*) => {
        $crate::cli::out::line(format_args!($($arg)*))
    };
}
pub(crate) use say;

/// Writes `args` and a line break, unless standard output can no longer be
/// written.
pub fn line(args: std::fmt::Arguments) {
    if TO_STDERR.load(Ordering::Relaxed) {
        eprintln!("{args}");
        return;
    }
    if CLOSED.load(Ordering::Relaxed) || FAILED.load(Ordering::Relaxed) {
        return;
    }
    let mut out = std::io::stdout().lock();
    if let Err(e) = writeln!(out, "{args}") {
        if e.kind() == ErrorKind::BrokenPipe {
            CLOSED.store(true, Ordering::Relaxed);
        } else {
            FAILED.store(true, Ordering::Relaxed);
            eprintln!("raytree: error: cannot write to standard output: {e}");
        }
    }
}

/// Sends what [`say!`] prints to standard error from now on: for a command
/// that writes its output file to standard output (`-o -`).
pub fn report_to_stderr() {
    TO_STDERR.store(true, Ordering::Relaxed);
}

/// Whether a write to standard output failed for a reason other than a
/// closed pipe.
pub fn failed() -> bool {
    FAILED.load(Ordering::Relaxed)
}
