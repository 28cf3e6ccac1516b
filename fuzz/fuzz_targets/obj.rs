//! The OBJ loader on arbitrary bytes: a mesh or an error, never a panic;
//! a mesh it accepts builds a BVH and traces.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    raytree::fuzzing::mesh(data, "fuzz.obj");
});
