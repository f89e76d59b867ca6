//! Fuzz target `watermark_detect`: see `meshlap_fuzz::entry::watermark_detect`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| meshlap_fuzz::entry::watermark_detect(data));
