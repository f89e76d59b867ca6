//! End-to-end tests of `meshlap compress`, `decompress` and `compare`.

mod common;
use common::*;

#[test]
fn compress_decompress_compare_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let mlz = dir.path().join("s.mlz");
    let out = dir.path().join("s.ply");
    let (mlz_s, out_s) = (mlz.to_str().unwrap(), out.to_str().unwrap());
    let r = json(&meshlap(&[
        "compress",
        "builtin:icosphere:3",
        "-o",
        mlz_s,
        "--preserve-order",
        "--bits",
        "12",
        "--measure",
        "--samples",
        "2000",
        "--json",
    ]));
    for key in [
        "bits_per_vertex",
        "connectivity_bpv",
        "geometry_bpv",
        "permutation_bpv",
        "step",
        "quantization_bits",
        "distortion",
    ] {
        assert!(r.get(key).is_some(), "missing {key}");
    }
    assert!(r["distortion"]["same_connectivity"].as_bool().unwrap());
    let size = std::fs::metadata(&mlz).unwrap().len();
    assert_eq!(size, r["bytes"].as_u64().unwrap());
    assert!(meshlap(&["decompress", mlz_s, "-o", out_s])
        .status
        .success());
    let c = json(&meshlap(&[
        "compare",
        "builtin:icosphere:3",
        out_s,
        "--samples",
        "2000",
        "--json",
    ]));
    // With the order preserved the decoded mesh has the same connectivity, and its
    // error is within the 12-bit quantization (step = diag/4096, RMS ≈ step/2).
    assert!(c["same_connectivity"].as_bool().unwrap());
    assert!(c["vertex_rms"].as_f64().unwrap() < 2.0 / 4096.0);
    assert!(c["hausdorff"].as_f64().unwrap() < 4.0 / 4096.0);
}

#[test]
fn corrupt_and_foreign_files_fail_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let mlz = dir.path().join("t.mlz");
    let mlz_s = mlz.to_str().unwrap();
    assert!(meshlap(&["compress", "builtin:torus:8:6", "-o", mlz_s])
        .status
        .success());
    let mut bytes = std::fs::read(&mlz).unwrap();
    let out = dir.path().join("o.obj");
    let out_s = out.to_str().unwrap();
    bytes.truncate(bytes.len() - 7);
    std::fs::write(&mlz, &bytes).unwrap();
    assert_one_line_error(&meshlap(&["decompress", mlz_s, "-o", out_s]), "truncated");
    std::fs::write(&mlz, b"solid ascii stl").unwrap();
    assert_one_line_error(&meshlap(&["decompress", mlz_s, "-o", out_s]), "magic");
    assert!(!out.exists(), "no partial output");
}

#[test]
fn options_out_of_range_are_one_line_errors_naming_the_option() {
    let dir = tempfile::tempdir().unwrap();
    let mlz = dir.path().join("p.mlz");
    let mlz_s = mlz.to_str().unwrap();
    for (args, needle) in [
        (&["--patch-size", "2"][..], "patch size"),
        (&["--keep-ratio", "1.5"][..], "keep ratio"),
        (&["--coefficients", "0"][..], "at least one coefficient"),
        (&["--bits", "50"][..], "quantization bits"),
        (&["--target-bpv=-1"][..], "target rate"),
        (&["--dead-zone", "0.9"][..], "dead-zone"),
        (&["--band-slope", "20"][..], "band slope"),
        (&["--rdo-lambda", "11"][..], "rate-distortion multiplier"),
        (&["--operator", "cotan", "--mode", "spectral"][..], "cotan"),
    ] {
        let mut a = vec!["compress", "builtin:icosphere:2", "-o", mlz_s];
        a.extend_from_slice(args);
        assert_one_line_error(&meshlap(&a), needle);
        assert!(!mlz.exists(), "{args:?}");
    }
    // An enum value the library does not know is a usage error (exit 2).
    let o = meshlap(&[
        "compress",
        "builtin:icosphere:2",
        "-o",
        mlz_s,
        "--mode",
        "fractal",
    ]);
    assert_eq!(o.status.code(), Some(2));
    // The old name of the spatial mode is still accepted.
    let r = json(&meshlap(&[
        "compress",
        "builtin:icosphere:2",
        "-o",
        mlz_s,
        "--mode",
        "predictive",
        "--json",
    ]));
    assert_eq!(r["geometry_mode"], "spatial");
}

#[test]
fn golden_file_decompresses() {
    // One of the library's golden files (tests/data/mlz) through the command line.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t.obj");
    let o = meshlap(&[
        "decompress",
        &data("mlz/torus-spectral-sql-po.mlz"),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let c = json(&meshlap(&[
        "compare",
        "builtin:torus:12:8",
        out.to_str().unwrap(),
        "--samples",
        "500",
        "--json",
    ]));
    // The file kept the input order: same connectivity, error within the 10-bit step.
    assert!(c["same_connectivity"].as_bool().unwrap());
    assert!(c["vertex_rms"].as_f64().unwrap() < 1.0 / 1024.0);
}
