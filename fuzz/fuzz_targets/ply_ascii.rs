//! Fuzz target `ply_ascii`: see `meshlap_fuzz::entry::ply_ascii`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| meshlap_fuzz::entry::ply_ascii(data));
