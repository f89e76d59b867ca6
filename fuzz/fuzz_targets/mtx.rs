//! Fuzz target `mtx`: see `meshlap_fuzz::entry::mtx`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| meshlap_fuzz::entry::mtx(data));
