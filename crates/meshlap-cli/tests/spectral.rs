//! End-to-end tests of `spectrum`, `project`, `compaction` and `experiment eigen-cost`.

mod common;
use common::*;

#[test]
fn spectrum_json_and_vectors() {
    let dir = tempfile::tempdir().unwrap();
    let npy = dir.path().join("v.npy");
    let v = json(&meshlap(&[
        "spectrum",
        "builtin:icosahedron",
        "--kind",
        "kl",
        "--json",
        "--vectors",
        npy.to_str().unwrap(),
    ]));
    let ev: Vec<f64> = v["eigenvalues"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let s5 = 5f64.sqrt();
    let expected = [
        0.0,
        5. - s5,
        5. - s5,
        5. - s5,
        6.,
        6.,
        6.,
        6.,
        6.,
        5. + s5,
        5. + s5,
        5. + s5,
    ];
    for (a, b) in ev.iter().zip(expected) {
        assert!((a - b).abs() < 1e-12);
    }
    assert_eq!(v["multiplicities"], serde_json::json!([1, 3, 5, 3]));
    assert_eq!(v["path"], "symmetric");
    let e = meshlap::io::read_npy(&npy).unwrap();
    assert_eq!((e.nrows(), e.ncols()), (12, 12));
    let g = e.transpose() * &e;
    for i in 0..12 {
        for j in 0..12 {
            let d = if i == j { 1.0 } else { 0.0 };
            assert!((g[(i, j)] - d).abs() < 1e-12);
        }
    }
    // --count and the TL through the GL.
    let v = json(&meshlap(&[
        "spectrum",
        "builtin:step:4",
        "--kind",
        "tl",
        "--count",
        "4",
        "--json",
    ]));
    assert_eq!(v["eigenvalues"].as_array().unwrap().len(), 4);
    assert_eq!(v["path"], "symmetrized");
    assert!(v["max_residual"].as_f64().unwrap() < 1e-12);
    // The reproducible dense solver: the same spectrum and multiplicities as faer's,
    // residual and orthogonality at rounding level (the TL on a mesh with boundary,
    // the KL of the icosahedron with its multiplicities).
    for (mesh, kind) in [("builtin:step:4", "tl"), ("builtin:icosahedron", "kl")] {
        let run = |solver: &str| {
            json(&meshlap(&[
                "spectrum",
                mesh,
                "--kind",
                kind,
                "--dense-solver",
                solver,
                "--json",
            ]))
        };
        let (f, r) = (run("faer"), run("reproducible"));
        assert_eq!(f["multiplicities"], r["multiplicities"]);
        for (a, b) in f["eigenvalues"]
            .as_array()
            .unwrap()
            .iter()
            .zip(r["eigenvalues"].as_array().unwrap())
        {
            assert!((a.as_f64().unwrap() - b.as_f64().unwrap()).abs() < 1e-12);
        }
        assert!(r["max_residual"].as_f64().unwrap() < 1e-12);
        assert!(r["orthonormality_error"].as_f64().unwrap() < 1e-12);
    }
}

#[test]
fn spectrum_errors() {
    assert_one_line_error(
        &meshlap(&["spectrum", "builtin:grid:3", "--kind", "kl", "--count", "0"]),
        "--count",
    );
    assert_one_line_error(
        &meshlap(&[
            "spectrum",
            "builtin:step:3",
            "--kind",
            "tl",
            "--path",
            "symmetric",
        ]),
        "not symmetric",
    );
    assert_one_line_error(
        &meshlap(&["spectrum", "builtin:icosphere:5", "--kind", "kl"]),
        "exceeds",
    );
    let out = meshlap(&["spectrum", "builtin:grid:3", "--kind", "kl", "--path", "x"]);
    assert_eq!(out.status.code(), Some(2));
    let out = meshlap(&[
        "spectrum",
        "builtin:grid:3",
        "--kind",
        "kl",
        "--dense-solver",
        "lapack",
    ]);
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn project_keep_n_and_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p.ply");
    let o = out.to_str().unwrap();
    for kind in ["sql", "tl", "sstl"] {
        let v = json(&meshlap(&[
            "project",
            "builtin:cube:3",
            "--kind",
            kind,
            "--keep",
            "100%",
            "-o",
            o,
            "--json",
        ]));
        assert!(v["relative_error"].as_f64().unwrap() < 1e-10, "{kind}");
        assert!((v["energy_kept"].as_f64().unwrap() - 1.0).abs() < 1e-12);
    }
    let v = json(&meshlap(&[
        "project",
        "builtin:icosphere:2",
        "--kind",
        "sstl",
        "--keep",
        "1",
        "-o",
        o,
        "--json",
    ]));
    // x⁽¹⁾ of a GSML is the centroid: every vertex moves to it (the origin).
    assert!(v["max_displacement"].as_f64().unwrap() > 0.2);
    let m = meshlap::io::read_mesh(&out, None).unwrap().mesh;
    assert_eq!(m.n_faces(), 320);
    for p in &m.positions {
        assert!(p.iter().all(|c| c.abs() < 1e-6), "{p:?}");
    }
    let fresh = dir.path().join("never.obj");
    assert_one_line_error(
        &meshlap(&[
            "project",
            "builtin:grid:3",
            "--kind",
            "kl",
            "--keep",
            "17",
            "-o",
            fresh.to_str().unwrap(),
        ]),
        "--keep",
    );
    assert!(!fresh.exists());
}

#[test]
fn compaction_csv_and_json() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("c.csv");
    let v = json(&meshlap(&[
        "compaction",
        "builtin:step:6",
        "--kind",
        "sql",
        "--centre",
        "--json",
        "--csv",
        csv.to_str().unwrap(),
    ]));
    let n = v["vertices"].as_u64().unwrap() as usize;
    let total = v["total"].as_array().unwrap();
    assert_eq!(total.len(), n);
    assert!((total[n - 1].as_f64().unwrap() - 1.0).abs() < 1e-12);
    assert!(total[0].as_f64().unwrap() < 1e-20, "centred: no DC energy");
    assert_eq!(v["per_coordinate"].as_array().unwrap().len(), 3);
    let text = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(text.lines().count(), n + 1);
    assert!(text.starts_with("m,x,y,z,total\n"));
}

#[test]
fn experiment_eigen_cost_writes_its_tables() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("exp");
    let v = json(&meshlap(&[
        "experiment",
        "eigen-cost",
        "--mesh",
        "builtin:icosphere:2",
        "--sizes",
        "20,60",
        "--compaction-size",
        "80",
        "--out",
        out.to_str().unwrap(),
        "--json",
    ]));
    let cost = v["cost"].as_array().unwrap();
    assert_eq!(cost.len(), 2 * 6);
    assert!(cost
        .iter()
        .all(|r| r["eigen_seconds"].as_f64().unwrap() >= 0.0));
    assert_eq!(v["compaction_order"].as_array().unwrap().len(), 4);
    for f in ["eigen_cost.md", "compaction.md", "eigen_cost.json"] {
        assert!(out.join(f).exists(), "{f}");
    }
}

#[test]
fn help_on_spectral_commands() {
    for cmd in [
        &["spectrum", "--help"][..],
        &["project", "--help"],
        &["compaction", "--help"],
        &["experiment", "eigen-cost", "--help"],
    ] {
        let out = meshlap(cmd);
        assert!(out.status.success(), "{cmd:?}");
        assert!(out.stdout.len() > 200, "{cmd:?} help too short");
    }
}

#[test]
fn project_patch_by_patch() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p.ply");
    let o = out.to_str().unwrap();
    let run = |keep: &str| {
        json(&meshlap(&[
            "project",
            "builtin:icosphere:3",
            "--kind",
            "sql",
            "--keep",
            keep,
            "--patch-size",
            "100",
            "-o",
            o,
            "--json",
        ]))
    };
    let full = run("100%");
    assert!(full["partition"]["patches"].as_u64().unwrap() >= 5);
    assert!(full["relative_error"].as_f64().unwrap() < 1e-10);
    let low = run("10%");
    let e = low["relative_error"].as_f64().unwrap();
    assert!(e > 1e-4 && e < 0.1, "{e}");
    assert!(out.is_file());
}

#[test]
fn descriptors_write_hks_and_wks_columns() {
    let dir = tempfile::tempdir().unwrap();
    let npy = dir.path().join("d.npy");
    let v = json(&meshlap(&[
        "descriptors",
        "builtin:icosphere:2",
        "--kind",
        "cotan",
        "--hks",
        "4",
        "--wks",
        "3",
        "-k",
        "30",
        "-o",
        npy.to_str().unwrap(),
        "--json",
    ]));
    assert_eq!(v["vertices"], 162);
    assert_eq!(v["columns"], 7);
    assert_eq!(v["eigenvalues"].as_array().unwrap().len(), 30);
    let m = meshlap::io::read_npy(&npy).unwrap();
    assert_eq!((m.nrows(), m.ncols()), (162, 7));
    // The HKS decreases with t at every vertex (heat flows away).
    for i in 0..162 {
        for t in 1..4 {
            assert!(m[(i, t)] < m[(i, t - 1)]);
        }
    }
    let out = meshlap(&[
        "descriptors",
        "builtin:icosphere:2",
        "--kind",
        "cotan",
        "--hks",
        "0",
        "-o",
        npy.to_str().unwrap(),
    ]);
    assert_one_line_error(&out, "hks + wks columns");
}

#[test]
fn spectrum_refinement_and_tolerance_flags() {
    // 10,242 vertices: above the dense limit, so the shift-invert path runs.
    let argv = |count: &'static str, extra: &[&'static str]| {
        let mut args = vec![
            "spectrum",
            "builtin:icosphere:5",
            "--kind",
            "sql",
            "--count",
            count,
        ];
        args.extend_from_slice(extra);
        args
    };
    let run = |extra: &[&'static str]| {
        let mut args = argv("30", extra);
        args.push("--json");
        json(&meshlap(&args))
    };
    let refined = run(&[]);
    let plain = run(&["--no-refine"]);
    assert_eq!(refined["path"], "shift-invert");
    assert_eq!(refined["stagnated_bands"], 0);
    // A tolerance below the rounding of the solves: the band stops at its accuracy
    // floor, says so, and its true residuals stay at rounding level.
    let floor = run(&["--tol", "1e-16"]);
    assert_eq!(floor["bands"], 1);
    assert_eq!(floor["stagnated_bands"], 1);
    assert!(floor["max_residual"].as_f64().unwrap() < 1e-14);
    let (r, p) = (
        refined["max_residual"].as_f64().unwrap(),
        plain["max_residual"].as_f64().unwrap(),
    );
    assert!(r < p, "refined {r:e} vs plain {p:e}");
    let (a, b) = (
        refined["eigenvalues"].as_array().unwrap(),
        plain["eigenvalues"].as_array().unwrap(),
    );
    for (x, y) in a.iter().zip(b) {
        assert!((x.as_f64().unwrap() - y.as_f64().unwrap()).abs() < 1e-10);
    }
    for bad in ["0", "-1e-3", "NaN", "2"] {
        assert_one_line_error(
            &meshlap(&[
                "spectrum",
                "builtin:icosphere:5",
                "--kind",
                "sql",
                "--count",
                "5",
                &format!("--tol={bad}"),
            ]),
            "tolerance",
        );
    }
    // Smaller bands and blocks: several bands, the same eigenvalues.
    let bands = run(&["--band-size", "12", "--block-size", "4"]);
    assert!(bands["bands"].as_u64().unwrap() >= 3, "{}", bands["bands"]);
    let c = bands["eigenvalues"].as_array().unwrap();
    for (x, y) in a.iter().zip(c) {
        assert!((x.as_f64().unwrap() - y.as_f64().unwrap()).abs() < 1e-10);
    }
    for bad in [["--block-size", "0"], ["--band-size", "4"]] {
        assert_one_line_error(&meshlap(&argv("5", &bad)), "block size");
    }
}
