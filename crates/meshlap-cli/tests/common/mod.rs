//! Helpers shared by the end-to-end tests of the `meshlap` binary.
#![allow(dead_code)] // each test crate uses a subset

use std::path::Path;
use std::process::{Command, Output};

/// Runs the binary with `args`.
pub fn meshlap(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_meshlap"))
        .args(args)
        .output()
        .expect("run meshlap")
}

/// A file of the repository's test data.
pub fn data(name: &str) -> String {
    format!("{}/../../tests/data/{name}", env!("CARGO_MANIFEST_DIR"))
}

/// The JSON a successful run printed.
pub fn json(out: &Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("valid JSON")
}

/// Exit code 1 and exactly one line on stderr, starting `meshlap: error: `.
pub fn assert_one_line_error(out: &Output, needle: &str) {
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.starts_with("meshlap: error: "), "{err}");
    assert!(err.contains(needle), "{err} should mention {needle}");
}

/// True when the directory has no entries.
pub fn dir_is_empty(p: &Path) -> bool {
    std::fs::read_dir(p).unwrap().next().is_none()
}
