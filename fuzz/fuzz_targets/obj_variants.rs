//! Fuzz target `obj_variants`: see `meshlap_fuzz::entry::obj_variants`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| meshlap_fuzz::entry::obj_variants(data));
