//! Fuzz target `ply_variants`: see `meshlap_fuzz::entry::ply_variants`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| meshlap_fuzz::entry::ply_variants(data));
