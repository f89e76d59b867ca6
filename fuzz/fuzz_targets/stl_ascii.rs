//! Fuzz target `stl_ascii`: see `meshlap_fuzz::entry::stl_ascii`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| meshlap_fuzz::entry::stl_ascii(data));
