//! The core library's integration tests, in one test binary (one compile
//! and link of every kernel instead of one per file): agreement with the
//! brute-force oracle, the papers' properties, bad input, determinism and
//! the recorded image hashes.

mod common;

mod all_hits;
mod bad_input;
mod cbvh;
mod determinism;
mod dst;
mod extremes;
mod fuzz_regressions;
mod htree;
mod image_hashes;
mod oracle;
mod paper_workload;
mod saved;
mod sbvh;
mod scenes;
mod shared_meshes;
mod simd_paths;
mod soups;
mod stackless;
mod watertight;
