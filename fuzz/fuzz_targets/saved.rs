//! The saved-structure reader on arbitrary bytes, as they are and with
//! their checksums recomputed: a structure or an error naming the file,
//! never a panic; a structure it accepts traces rays.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    raytree::fuzzing::saved(data);
});
