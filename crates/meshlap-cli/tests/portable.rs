//! The portable path (issue 16, RELIABILITY.md): `.mlz` bytes and decoded meshes are
//! the same whether meshlap's kernels run their AVX2 + FMA build or the portable one
//! (`MESHLAP_PORTABLE=1`, read by `meshlap::cpu`). Each file is compressed on both
//! paths and decoded on the other one. The codec's own arithmetic is fixed-order since
//! format version 6 (no faer kernels in anything it decodes), so the same holds on a
//! CPU without AVX2/FMA; RELIABILITY.md also records a run under an emulated CPU
//! without them.

mod common;
use common::*;
use std::path::Path;
use std::process::{Command, Output};

/// Runs `meshlap --threads 2 ARGS`, with `MESHLAP_PORTABLE=1` when `portable`, and
/// asserts success.
fn run(portable: bool, args: &[&str]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_meshlap"));
    cmd.args(["--threads", "2"]).args(args);
    if portable {
        cmd.env("MESHLAP_PORTABLE", "1");
    } else {
        cmd.env_remove("MESHLAP_PORTABLE");
    }
    let out = cmd.output().expect("run meshlap");
    assert!(
        out.status.success(),
        "{args:?} (portable: {portable}): {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn cpu_has_avx2_fma() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

#[test]
fn mlz_bytes_and_decoded_meshes_are_the_same_on_the_portable_path() {
    if !cpu_has_avx2_fma() {
        eprintln!(
            "skipped: this CPU has no AVX2 + FMA, so the default path is already the \
             portable one (nothing to compare)"
        );
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let cow = data("cow.obj");
    let two = data("mlz/two-components.obj");
    let cases: Vec<(&str, Vec<&str>)> = vec![
        (
            "kirchhoff",
            vec![
                "builtin:icosphere:3",
                "--mode",
                "spectral",
                "--patch-size",
                "120",
            ],
        ),
        (
            "sql-po",
            vec![
                "builtin:torus:12:8",
                "--mode",
                "spectral",
                "--operator",
                "sql",
                "--patch-size",
                "24",
                "--preserve-order",
            ],
        ),
        (
            "tutte-border",
            vec![
                "builtin:grid:8",
                "--mode",
                "spectral",
                "--operator",
                "tutte",
                "--patch-size",
                "20",
                "--keep-ratio",
                "0.5",
                "--border-residuals",
            ],
        ),
        (
            "sstl",
            vec!["builtin:cube:3", "--mode", "spectral", "--operator", "sstl"],
        ),
        (
            "nm-spectral",
            vec![
                "builtin:nm-mixed",
                "--mode",
                "spectral",
                "--patch-size",
                "16",
            ],
        ),
        (
            "two-components",
            vec![&two, "--mode", "spectral", "--patch-size", "4"],
        ),
        ("cow-spectral", vec![&cow, "--mode", "spectral"]),
        ("spatial", vec!["builtin:torus:24:16", "--mode", "spatial"]),
        (
            "auto-rate",
            vec![
                "builtin:torus:30:20",
                "--patch-size",
                "150",
                "--target-bpv",
                "6",
            ],
        ),
    ];
    let path = |name: &str, portable: bool, ext: &str| {
        let p = dir
            .path()
            .join(format!("{name}-{}.{ext}", if portable { "p" } else { "d" }));
        p.to_str().unwrap().to_string()
    };
    for (name, args) in &cases {
        for portable in [false, true] {
            let mlz = path(name, portable, "mlz");
            let mut a = vec!["compress"];
            a.extend_from_slice(args);
            a.extend_from_slice(&["-o", &mlz]);
            run(portable, &a);
            // Decoded on the other path.
            let ply = path(name, portable, "ply");
            run(!portable, &["decompress", &mlz, "-o", &ply]);
        }
        let read = |p: String| std::fs::read(Path::new(&p)).unwrap();
        assert!(
            read(path(name, false, "mlz")) == read(path(name, true, "mlz")),
            "{name}: .mlz bytes differ between the AVX2 + FMA and the portable path"
        );
        assert!(
            read(path(name, false, "ply")) == read(path(name, true, "ply")),
            "{name}: decoded meshes differ between the AVX2 + FMA and the portable path"
        );
    }
}

/// The geometric operators' per-face lanes (cotan, mean-value) vectorise in the AVX2
/// build: the matrices `meshlap operator -o` writes are the same files on both paths.
#[test]
fn geometric_operators_are_the_same_on_the_portable_path() {
    if !cpu_has_avx2_fma() {
        eprintln!("skipped: this CPU has no AVX2 + FMA (nothing to compare)");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let cow = data("cow.obj");
    for kind in ["cotan", "mean-value"] {
        let mut files = Vec::new();
        for portable in [false, true] {
            let out = dir.path().join(format!("{kind}-{portable}.mtx"));
            let out_s = out.to_str().unwrap();
            run(
                portable,
                &[
                    "operator",
                    cow.as_str(),
                    "--kind",
                    kind,
                    "--dense-limit",
                    "0",
                    "-o",
                    out_s,
                ],
            );
            files.push(std::fs::read(&out).unwrap());
        }
        assert!(files[0].len() > 1000, "{kind}");
        assert!(
            files[0] == files[1],
            "{kind}: the portable build wrote another matrix"
        );
    }
}
