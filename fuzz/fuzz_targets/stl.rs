//! The STL loader on arbitrary bytes (ASCII or binary, told apart by size
//! and content): a mesh or an error, never a panic; a mesh it accepts maps
//! its triangles to geometries, builds a BVH and traces.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    raytree::fuzzing::mesh(data, "fuzz.stl");
});
