//! The glTF loader on arbitrary bytes as a `.glb` file (binary when they
//! start with the GLB magic, JSON otherwise): a mesh or an error, never a
//! panic; a mesh it accepts maps its triangles to geometries, builds a BVH
//! and traces. External buffer files do not exist here: refused.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    raytree::fuzzing::mesh(data, "fuzz.glb");
});
