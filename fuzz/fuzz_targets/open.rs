//! Fuzz target `open`: see `meshlap_fuzz::entry::open`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| meshlap_fuzz::entry::open(data));
