//! Fuzz target `mlz_threads`: see `meshlap_fuzz::entry::mlz_threads`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| meshlap_fuzz::entry::mlz_threads(data));
