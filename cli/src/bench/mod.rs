//! Reproductions of the papers' measurements, shared by the CLI's `bench`
//! command and the tests.

pub mod dst;
pub mod machine;
pub mod peers;
pub mod report;
pub mod stackless;
pub mod svg;
