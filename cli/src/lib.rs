//! The `raytree` command line as a library: its commands ([`cli`]) and the
//! papers' measurements, reports and peers ([`bench`](mod@bench)), which the
//! integration tests call directly. The core library is the `raytree`
//! crate; this crate adds what only the command line needs (clap,
//! indicatif, Ctrl-C handling, HTML/SVG reports, Embree and obvhs).

pub mod bench;
pub mod cli;
pub use raytree::meter;
