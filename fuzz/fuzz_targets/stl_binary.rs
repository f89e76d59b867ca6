//! Fuzz target `stl_binary`: see `meshlap_fuzz::entry::stl_binary`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| meshlap_fuzz::entry::stl_binary(data));
