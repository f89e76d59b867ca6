//! Fuzz target `npy`: see `meshlap_fuzz::entry::npy`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| meshlap_fuzz::entry::npy(data));
