//! The ray-file and hit-file readers on arbitrary bytes.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    raytree::fuzzing::rayfile(data);
});
