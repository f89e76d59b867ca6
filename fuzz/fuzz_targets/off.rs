//! Fuzz target `off`: see `meshlap_fuzz::entry::off`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| meshlap_fuzz::entry::off(data));
