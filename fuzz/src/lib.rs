//! The fuzz targets' entry points, in [`entry`]. The same file is compiled into the
//! stable test `crates/meshlap/tests/fuzz_replay.rs`, which replays the committed
//! corpora (`tests/data/fuzz/<target>/`) through exactly these functions.

pub mod entry;
