//! The PLY loader (ASCII and binary) on arbitrary bytes.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    raytree::fuzzing::mesh(data, "fuzz.ply");
});
