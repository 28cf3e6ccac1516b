//! The dual-split and H-tree node decoders on arbitrary words.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    raytree::fuzzing::nodes(data);
});
