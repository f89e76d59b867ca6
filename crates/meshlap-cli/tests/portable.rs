//! The portable path (issue 16, RELIABILITY.md): `.mlz` bytes and decoded meshes are
//! the same whether meshlap's kernels run their AVX-512 build, their AVX2 + FMA build
//! (`MESHLAP_NO_AVX512=1`) or the portable one (`MESHLAP_PORTABLE=1`; both read by
//! `meshlap::cpu`). Each file is compressed on every build the CPU has and decoded on
//! the next one. The codec's own arithmetic is fixed-order since format version 6 (no
//! faer kernels in anything it decodes), so the same holds on a CPU without
//! AVX2/FMA; RELIABILITY.md also records a run under an emulated CPU without them.

mod common;
use common::*;
use std::path::Path;
use std::process::{Command, Output};

/// Which build of meshlap's kernels a run asks for (see `meshlap::cpu`).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Build {
    /// The CPU's best: AVX-512 where it has it.
    Native,
    /// `MESHLAP_NO_AVX512=1`: AVX2 + FMA at most.
    Avx2,
    /// `MESHLAP_PORTABLE=1`.
    Portable,
}

impl Build {
    fn tag(self) -> &'static str {
        match self {
            Build::Native => "n",
            Build::Avx2 => "a",
            Build::Portable => "p",
        }
    }
}

/// Runs `meshlap --threads 2 ARGS` on `build` and asserts success.
fn run(build: Build, args: &[&str]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_meshlap"));
    cmd.args(["--threads", "2"]).args(args);
    cmd.env_remove("MESHLAP_PORTABLE")
        .env_remove("MESHLAP_NO_AVX512");
    match build {
        Build::Native => {}
        Build::Avx2 => {
            cmd.env("MESHLAP_NO_AVX512", "1");
        }
        Build::Portable => {
            cmd.env("MESHLAP_PORTABLE", "1");
        }
    }
    let out = cmd.output().expect("run meshlap");
    assert!(
        out.status.success(),
        "{args:?} ({build:?} build): {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

use meshlap::cpu::{cpu_has_avx2_fma, cpu_has_avx512};

/// The distinct builds this CPU can run: the portable one, AVX2 + FMA where it has
/// them, AVX-512 where it has that too.
fn builds() -> Vec<Build> {
    let mut b = Vec::new();
    if cpu_has_avx2_fma() && cpu_has_avx512() {
        b.push(Build::Native);
    }
    if cpu_has_avx2_fma() {
        b.push(Build::Avx2);
    }
    b.push(Build::Portable);
    b
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
    let path = |name: &str, build: Build, ext: &str| {
        let p = dir.path().join(format!("{name}-{}.{ext}", build.tag()));
        p.to_str().unwrap().to_string()
    };
    let builds = builds();
    for (name, args) in &cases {
        for (k, &build) in builds.iter().enumerate() {
            let mlz = path(name, build, "mlz");
            let mut a = vec!["compress"];
            a.extend_from_slice(args);
            a.extend_from_slice(&["-o", &mlz]);
            run(build, &a);
            // Decoded on the next build.
            let ply = path(name, build, "ply");
            run(
                builds[(k + 1) % builds.len()],
                &["decompress", &mlz, "-o", &ply],
            );
        }
        let read = |p: String| std::fs::read(Path::new(&p)).unwrap();
        for &build in &builds[1..] {
            for ext in ["mlz", "ply"] {
                assert!(
                    read(path(name, builds[0], ext)) == read(path(name, build, ext)),
                    "{name}: the {ext} files differ between the {:?} and the {build:?} build",
                    builds[0]
                );
            }
        }
    }
}

/// The geometric operators' per-face lanes (cotan, mean-value) vectorise in the AVX2
/// and AVX-512 builds: the matrices `meshlap operator -o` writes are the same files on
/// every build.
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
        let builds = builds();
        for &build in &builds {
            let out = dir.path().join(format!("{kind}-{}.mtx", build.tag()));
            let out_s = out.to_str().unwrap();
            run(
                build,
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
        for (f, build) in files.iter().zip(&builds).skip(1) {
            assert!(
                *f == files[0],
                "{kind}: the {build:?} build wrote another matrix than the {:?} build",
                builds[0]
            );
        }
    }
}
