//! Fuzz target `obj`: see `meshlap_fuzz::entry::obj`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| meshlap_fuzz::entry::obj(data));
