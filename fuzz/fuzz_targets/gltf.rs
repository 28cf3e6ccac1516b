//! The glTF loader on arbitrary bytes as a `.gltf` file (JSON, with its
//! buffers in data: URIs): a mesh or an error, never a panic; a mesh it
//! accepts maps its triangles to geometries, builds a BVH and traces.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    raytree::fuzzing::mesh(data, "fuzz.gltf");
});
