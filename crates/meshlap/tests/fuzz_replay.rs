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

/// `tests/data/fuzz`: one folder per target's corpus, and `miri.txt`.
fn fuzz_data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/fuzz")
}

fn corpus_dir(target: &str) -> PathBuf {
    fuzz_data().join(target)
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

/// The files [`corpora_replay_without_panics`] replays for `target`: all of them, or
/// under Miri (`cargo +nightly miri test --test fuzz_replay`, RELIABILITY.md) the few
/// that `tests/data/fuzz/miri.txt` lists ([`miri_units`]). Miri interprets the
/// program thousands of times slower than a native build and stops at undefined
/// behaviour in any `unsafe` block these inputs reach: the readers' fast paths, the
/// parallel cleaning and connectivity, the decoder.
fn replayed(target: &str) -> Vec<PathBuf> {
    if cfg!(miri) {
        miri_units(target)
    } else {
        corpus(target)
    }
}

/// The units of `target` that `tests/data/fuzz/miri.txt` lists (one `target/file` a
/// line, `#` comments).
fn miri_units(target: &str) -> Vec<PathBuf> {
    let list = fuzz_data().join("miri.txt");
    let list = std::fs::read_to_string(&list).unwrap_or_else(|e| panic!("{}: {e}", list.display()));
    list.lines()
        .map(str::trim)
        .filter(|l| !l.starts_with('#') && !l.is_empty())
        .filter_map(|l| l.split_once('/'))
        .filter(|(t, _)| *t == target)
        .map(|(t, f)| corpus_dir(t).join(f))
        .collect()
}

/// Targets without units in `miri.txt`: `watermark_detect`'s set-up (the original's
/// bases, built once per process) had not finished after 25 minutes under Miri.
const NOT_UNDER_MIRI: [&str; 1] = ["watermark_detect"];

/// Every other target has units in `miri.txt`, and each is a file of its corpus (a
/// minimised corpus must keep them).
#[test]
fn the_miri_list_names_units_of_every_corpus() {
    for (name, _) in entry::TARGETS {
        let units = miri_units(name);
        assert_eq!(
            units.is_empty(),
            NOT_UNDER_MIRI.contains(&name),
            "{name}: units in miri.txt"
        );
        for u in units {
            assert!(u.is_file(), "miri.txt names a missing unit {}", u.display());
        }
    }
}

/// Every library test `.ci/miri` names (its `portable` and `avx2` lists, by module
/// path) is a `#[test]` function in the source file of its module, so that a renamed
/// test cannot drop out of the Miri sets unnoticed (`cargo test --exact` runs no test
/// for an unknown name and still succeeds).
#[test]
#[cfg_attr(
    miri,
    ignore = "a check of the script's list, no unsafe code: over a quarter of an hour under Miri"
)]
fn the_miri_script_names_library_tests() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let script = std::fs::read_to_string(root.join("../../.ci/miri")).unwrap();
    let names: Vec<&str> = script
        .lines()
        .map(str::trim)
        .filter(|l| l.contains("::tests::") && !l.contains(' '))
        .collect();
    assert!(names.len() >= 15, "{} tests in .ci/miri", names.len());
    for name in names {
        let parts: Vec<&str> = name.split("::").collect();
        let (module, test) = (&parts[..parts.len() - 2], parts[parts.len() - 1]);
        assert_eq!(parts[parts.len() - 2], "tests", "{name}");
        let dir = module.iter().fold(root.join("src"), |d, m| d.join(m));
        // The tests module inline in `m.rs` or `m/mod.rs`, or in `m/tests.rs`.
        let files = [
            dir.with_extension("rs"),
            dir.join("mod.rs"),
            dir.join("tests.rs"),
        ];
        let found = files.iter().any(|f| {
            let Ok(src) = std::fs::read_to_string(f) else {
                return false;
            };
            let lines: Vec<&str> = src.lines().map(str::trim).collect();
            let head = format!("fn {test}(");
            // `#[test]` among the attributes right above the function.
            (0..lines.len()).any(|i| {
                lines[i].starts_with(&head)
                    && lines[..i]
                        .iter()
                        .rev()
                        .take_while(|l| l.starts_with("#["))
                        .any(|l| *l == "#[test]")
            })
        });
        assert!(found, ".ci/miri names {name}, which is not a test there");
    }
}

#[test]
fn corpora_replay_without_panics() {
    for (name, target) in entry::TARGETS {
        for file in replayed(name) {
            let data = std::fs::read(&file).unwrap();
            if cfg!(miri) {
                eprintln!("{name}: {}", file.display());
            }
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
