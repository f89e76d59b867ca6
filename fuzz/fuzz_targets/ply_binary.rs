//! Fuzz target `ply_binary`: see `meshlap_fuzz::entry::ply_binary`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| meshlap_fuzz::entry::ply_binary(data));
