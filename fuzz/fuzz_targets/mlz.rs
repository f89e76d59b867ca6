//! Fuzz target `mlz`: see `meshlap_fuzz::entry::mlz`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| meshlap_fuzz::entry::mlz(data));
