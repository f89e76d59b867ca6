//! Stable guard of the fuzzing (see RELIABILITY.md): replays the minimised corpora
//! committed under `tests/data/fuzz/<target>/` through the fuzz targets' own entry
//! points (`fuzz/src/entry.rs`, compiled in here), so a reader or decoder regression
//! that panics fails `cargo test` without nightly or libFuzzer. Errors are fine; a
//! panic (or a successful read with an out-of-range face index or a non-finite
//! coordinate, or, in the differential targets, a variant of a reader or of the
//! decoder that gives other bits or another error than its sequential reference) is
//! not.

#[path = "../../../fuzz/src/entry.rs"]
mod entry;

use std::path::{Path, PathBuf};

fn corpus_dir(target: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/data/fuzz")
        .join(target)
}

/// The files of one corpus, sorted (so a failure names the same file every run).
fn corpus(target: &str) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(corpus_dir(target))
        .unwrap_or_else(|e| panic!("corpus of {target}: {e}"))
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    files
}

#[test]
fn every_target_has_a_corpus() {
    for (name, _) in entry::TARGETS {
        let files = corpus(name);
        assert!(
            files.len() >= 3,
            "{name}: {} corpus files (expected a minimised corpus)",
            files.len()
        );
        let bytes: u64 = files
            .iter()
            .map(|p| std::fs::metadata(p).unwrap().len())
            .sum();
        assert!(
            bytes < 300_000,
            "{name}: corpus of {bytes} bytes is too big"
        );
    }
}

#[test]
fn corpora_replay_without_panics() {
    for (name, target) in entry::TARGETS {
        for file in corpus(name) {
            let data = std::fs::read(&file).unwrap();
            let outcome = std::panic::catch_unwind(|| target(&data));
            assert!(outcome.is_ok(), "{name}: {} panics", file.display());
        }
    }
}

/// The harness reaches the section decoders: re-sealing a valid file gives it back
/// unchanged, and re-sealing a file with a flipped payload byte (which the decoder
/// refuses with a checksum error) gives the same sections with valid checksums.
#[test]
fn mlz_harness_reseals_checksums() {
    use meshlap::codec::{container, decompress, CodecError};
    let golden =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/mlz/torus-spatial.mlz");
    let bytes = std::fs::read(golden).unwrap();
    assert!(decompress(&bytes).is_ok());
    assert_eq!(entry::reseal(&bytes).as_deref(), Some(&bytes[..]));
    let mut bad = bytes.clone();
    let last = bad.len() - 1;
    bad[last] ^= 0x5a;
    assert!(matches!(decompress(&bad), Err(CodecError::Checksum(_))));
    // The last byte of the file is the last byte of the last section's payload.
    let mut payloads: Vec<(container::SectionKind, Vec<u8>)> = container::read(&bytes)
        .unwrap()
        .iter()
        .map(|(k, p)| (*k, p.to_vec()))
        .collect();
    let payload = &mut payloads.last_mut().unwrap().1;
    *payload.last_mut().unwrap() ^= 0x5a;
    let refs: Vec<_> = payloads.iter().map(|(k, p)| (*k, &p[..])).collect();
    let mut expected = container::write(&refs).unwrap();
    // The harness keeps the file's version (the golden file is version 4).
    expected[4..6].copy_from_slice(&bytes[4..6]);
    assert_eq!(entry::reseal(&bad), Some(expected.clone()));
    assert!(!matches!(
        decompress(&expected),
        Err(CodecError::Checksum(_))
    ));
    entry::mlz(&bad);
}
