//! End-to-end tests of the `meshlap` binary.

use std::path::PathBuf;
mod common;
use common::*;

#[test]
fn info_json_has_the_documented_keys() {
    let v = json(&meshlap(&["info", "builtin:grid:4", "--json"]));
    for key in [
        "vertices",
        "faces",
        "edges",
        "boundary_edges",
        "boundary_loops",
        "components",
        "euler_characteristic",
        "non_manifold_edges",
        "non_manifold_vertices",
        "dropped_unreferenced_vertices",
        "dropped_degenerate_faces",
        "dropped_duplicate_faces",
    ] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    assert_eq!(v["vertices"], 25);
    assert_eq!(v["boundary_loops"], 1);
    assert_eq!(v["euler_characteristic"], 1);
    let text = meshlap(&["info", &data("suzanne.obj")]);
    assert!(String::from_utf8_lossy(&text.stdout).contains("468 polygons"));
}

#[test]
fn bad_input_gives_one_line_and_exit_1() {
    assert_one_line_error(
        &meshlap(&["info", "/no/such/mesh.obj"]),
        "/no/such/mesh.obj",
    );
    assert_one_line_error(&meshlap(&["info", "mesh.xyz"]), "unknown mesh format");
    assert_one_line_error(&meshlap(&["info", "builtin:nope"]), "unknown built-in mesh");
    assert_one_line_error(
        &meshlap(&["info", &data("malformed/bad_coordinate.obj")]),
        ":3: cannot parse \"1.0x\"",
    );
    assert_one_line_error(
        &meshlap(&["operator", &data("beetle.obj"), "--kind", "sql"]),
        "non-manifold",
    );
}

#[test]
fn usage_errors_exit_2() {
    assert_eq!(meshlap(&[]).status.code(), Some(2));
    assert_eq!(meshlap(&["info"]).status.code(), Some(2));
    assert_eq!(
        meshlap(&["operator", "builtin:cube:2", "--kind", "nope"])
            .status
            .code(),
        Some(2)
    );
    assert_eq!(
        meshlap(&["info", "builtin:cube:2", "--bogus"])
            .status
            .code(),
        Some(2)
    );
}

#[test]
fn help_on_every_command() {
    for cmd in [
        "info",
        "convert",
        "clean",
        "operator",
        "iterate",
        "repair-sql",
        "smooth",
    ] {
        let out = meshlap(&[cmd, "--help"]);
        assert!(out.status.success(), "{cmd}");
        assert!(out.stdout.len() > 200, "{cmd} help too short");
    }
}

#[test]
fn failures_leave_no_output_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.obj");
    let o = meshlap(&[
        "convert",
        &data("malformed/truncated.ply"),
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(dir_is_empty(dir.path()));
    let o = meshlap(&[
        "convert",
        "builtin:cube:2",
        dir.path().join("out.xyz").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(dir_is_empty(dir.path()));
    let o = meshlap(&[
        "operator",
        &data("beetle.obj"),
        "--kind",
        "sql",
        "-o",
        dir.path().join("s.mtx").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(dir_is_empty(dir.path()));
    // Patch colours need PLY: refused by the writer, nothing written.
    let o = meshlap(&[
        "partition",
        "builtin:icosphere:2",
        "-p",
        "40",
        "-o",
        dir.path().join("p.obj").to_str().unwrap(),
    ]);
    assert_one_line_error(&o, "need a PLY file");
    assert!(dir_is_empty(dir.path()));
}

#[test]
fn convert_and_clean_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let ply: PathBuf = dir.path().join("cow.ply");
    assert!(
        meshlap(&["convert", &data("cow.obj"), ply.to_str().unwrap()])
            .status
            .success()
    );
    let v = json(&meshlap(&["info", ply.to_str().unwrap(), "--json"]));
    assert_eq!(
        (v["vertices"].as_u64(), v["faces"].as_u64()),
        (Some(2903), Some(5804))
    );
    let fixed = dir.path().join("beetle.obj");
    let c = json(&meshlap(&[
        "clean",
        &data("beetle.obj"),
        fixed.to_str().unwrap(),
        "--split-nonmanifold",
        "--json",
    ]));
    assert_eq!(c["non_manifold_edges"], 0);
    assert_eq!(c["split"]["non_manifold_edges_before"], 47);
    // the split beetle is accepted by the SQL
    assert!(
        meshlap(&["operator", fixed.to_str().unwrap(), "--kind", "sql"])
            .status
            .success()
    );
}

#[test]
fn operator_report_and_matrix_market() {
    let dir = tempfile::tempdir().unwrap();
    let mtx = dir.path().join("k.mtx");
    let v = json(&meshlap(&[
        "operator",
        "builtin:icosahedron",
        "--kind",
        "kl",
        "--json",
        "-o",
        mtx.to_str().unwrap(),
    ]));
    for key in [
        "symmetric",
        "negative_weights",
        "max_abs_row_sum",
        "gsml",
        "lambda_min",
        "lambda_max",
        "gershgorin_max",
    ] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    assert_eq!(v["symmetric"], true);
    assert_eq!(v["gsml"]["is_gsml"], true);
    assert!((v["lambda_max"].as_f64().unwrap() - (5.0 + 5f64.sqrt())).abs() < 1e-9);
    let text = std::fs::read_to_string(&mtx).unwrap();
    assert!(text.starts_with("%%MatrixMarket matrix coordinate real general"));
    assert!(text.contains("\n12 12 72\n"));
    let gl = json(&meshlap(&[
        "operator",
        "builtin:cube:3",
        "--kind",
        "gl",
        "--json",
    ]));
    assert_eq!(gl["gsml"]["is_gsml"], false);
    assert_eq!(gl["gsml"]["failing"][0], "zero row sum");
    assert!(gl["same_spectrum_max_difference"].as_f64().unwrap() < 1e-9);
    let printed = json(&meshlap(&[
        "operator",
        &data("teapot.obj"),
        "--kind",
        "sql",
        "--sql-diagonal",
        "printed",
        "--json",
        "--dense-limit",
        "0",
    ]));
    assert!((printed["max_abs_row_sum"].as_f64().unwrap() - 0.73).abs() < 0.01);
}

/// The negative weights of the SQL of the mesh at `path` (`meshlap operator --json`).
fn sql_negative_weights(path: &std::path::Path) -> serde_json::Value {
    let s = json(&meshlap(&[
        "operator",
        path.to_str().unwrap(),
        "--kind",
        "sql",
        "--json",
        "--dense-limit",
        "0",
    ]));
    s["negative_weights"].clone()
}

#[test]
fn repair_and_iterate() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cow.ply");
    let r = json(&meshlap(&[
        "repair-sql",
        &data("cow.obj"),
        "-o",
        out.to_str().unwrap(),
        "--json",
    ]));
    assert_eq!(r["negative_before"], 7);
    assert_eq!(r["negative_after"], 0);
    assert_eq!(sql_negative_weights(&out), 0);
    let it = json(&meshlap(&[
        "iterate",
        "builtin:cube:3",
        "--kind",
        "tl",
        "--steps",
        "300",
        "--json",
    ]));
    let steps = it["steps"].as_array().unwrap();
    assert_eq!(steps.len(), 301);
    let last = &steps[300];
    assert!(last["distance_to_weighted_centroid"].as_f64().unwrap() < 1e-6);
}

#[test]
fn smooth_json_reports_iterations_per_column_and_writes_the_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("smooth.ply");
    let o = out.to_str().unwrap();
    for (args, direct) in [
        (vec!["--implicit", "-k", "sql", "--solver", "cg"], false),
        (vec!["--implicit", "-k", "tl", "--solver", "bicg"], false),
        (
            vec![
                "--filter", "implicit", "-k", "tl", "--solver", "cg-sym", "--stop", "strong",
            ],
            false,
        ),
        (vec!["-k", "sql", "--solver", "cholesky"], true),
    ] {
        let mut a = vec![
            "smooth",
            "builtin:icosphere:3",
            "-o",
            o,
            "--json",
            "--lambda",
            "10",
        ];
        a.extend(args.iter());
        let v = json(&meshlap(&a));
        let its = v["iterations"].as_array().unwrap();
        assert_eq!(its.len(), 3, "{args:?}");
        assert_eq!(
            its.iter().all(|i| i.as_u64().unwrap() > 0),
            !direct,
            "{args:?}"
        );
        assert_eq!(v["residuals"].as_array().unwrap().len(), 3);
        assert!(v["solve_seconds"].as_f64().unwrap() >= 0.0);
        // the sphere shrinks under implicit fairing
        assert!(v["volume_after"].as_f64().unwrap() < v["volume_before"].as_f64().unwrap());
        assert!(out.exists());
    }
    for f in [
        vec!["--filter", "explicit"],
        vec!["--filter", "taubin", "--preserve", "volume"],
        vec!["--filter", "butterworth", "--passband", "0.2", "-k", "kl"],
        vec![
            "--filter",
            "ideal",
            "--passband",
            "0.5",
            "--preserve",
            "bbox",
        ],
    ] {
        let mut a = vec!["smooth", "builtin:icosphere:2", "-o", o, "--json"];
        a.extend(f.iter());
        let v = json(&meshlap(&a));
        assert!(v["seconds"].as_f64().is_some(), "{f:?}");
    }
}

#[test]
fn smooth_errors_are_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.obj");
    let o = out.to_str().unwrap();
    // CG on the non-symmetric Tutte Laplacian would solve the wrong system
    let e = meshlap(&[
        "smooth",
        "builtin:icosphere:2",
        "-o",
        o,
        "-k",
        "tl",
        "--solver",
        "cg",
    ]);
    assert_one_line_error(&e, "symmetric");
    let e = meshlap(&[
        "smooth",
        "builtin:icosphere:2",
        "-o",
        o,
        "--filter",
        "butterworth",
    ]);
    assert_one_line_error(&e, "--passband");
    let e = meshlap(&["smooth", "builtin:icosphere:2", "-o", o, "--lambda=-3"]);
    assert_one_line_error(&e, "λ");
    let e = meshlap(&[
        "smooth",
        "builtin:icosphere:2",
        "-o",
        o,
        "--filter",
        "ideal",
        "--passband",
        "1",
        "--dense-limit",
        "10",
    ]);
    assert_one_line_error(&e, "limit");
    let e = meshlap(&[
        "smooth",
        "builtin:icosphere:2",
        "-o",
        o,
        "--max-iterations",
        "1",
        "--stop",
        "strong",
        "--tol",
        "1e-12",
    ]);
    assert_one_line_error(&e, "no convergence");
    assert!(dir_is_empty(dir.path()));
    let e = meshlap(&[
        "smooth",
        "builtin:icosphere:2",
        "-o",
        o,
        "--implicit",
        "--filter",
        "taubin",
    ]);
    assert_eq!(e.status.code(), Some(2));
}

#[test]
fn experiment_fairing_writes_tables_and_plots() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    let v = json(&meshlap(&[
        "experiment",
        "fairing",
        "builtin:icosphere:3",
        &data("cow.obj"),
        "--lambda",
        "30",
        "--repeat",
        "1",
        "--out",
        d,
        "--json",
    ]));
    let tables = v["tables"].as_array().unwrap();
    assert_eq!(tables.len(), 2);
    assert_eq!(tables[1]["name"], "cow");
    assert_eq!(tables[1]["paper"]["cg_30"][1], 15);
    for t in tables {
        let runs = t["runs"].as_array().unwrap();
        assert_eq!(runs.len(), 3);
        for r in runs {
            assert!(r["error"].as_f64().unwrap() < 1e-3, "{r}");
        }
    }
    for f in [
        "table1-lambda30.md",
        "table1-lambda30.csv",
        "table1.json",
        "convergence-icosphere-3-lambda30.png",
        "convergence-cow-lambda30.png",
    ] {
        let p = dir.path().join(f);
        assert!(std::fs::metadata(&p).unwrap().len() > 100, "{f}");
    }
    let md = std::fs::read_to_string(dir.path().join("table1-lambda30.md")).unwrap();
    assert!(md.contains("| cow         | 2903 |"), "{md}");
    let e = meshlap(&[
        "experiment",
        "fairing",
        "builtin:icosphere:1",
        "--lambda",
        "0",
        "--out",
        d,
    ]);
    assert_one_line_error(&e, "--lambda");
}

#[test]
fn repair_sql_vertex_split_method() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cow.obj");
    let run = |method: &str| {
        json(&meshlap(&[
            "repair-sql",
            &data("cow.obj"),
            "-o",
            out.to_str().unwrap(),
            "--method",
            method,
            "--max-dihedral",
            "30",
            "--json",
        ]))
    };
    let swap = run("swap");
    assert_eq!(swap["method"], "swap");
    assert!(swap["negative_after"].as_u64().unwrap() > 0);
    let both = run("swap-split");
    assert_eq!(both["method"], "swap-split");
    assert_eq!(both["negative_after"], 0);
    let added = both["vertices_added"].as_u64().unwrap();
    assert!(added > 0 && both["splits"].as_u64().unwrap() == added);
    let info = json(&meshlap(&["info", out.to_str().unwrap(), "--json"]));
    assert_eq!(info["vertices"].as_u64().unwrap(), 2903 + added);
    assert_eq!(info["non_manifold_edges"], 0);
    assert_eq!(sql_negative_weights(&out), 0);
    let bad = meshlap(&[
        "repair-sql",
        &data("cow.obj"),
        "-o",
        "x.obj",
        "--method",
        "nope",
    ]);
    assert_eq!(bad.status.code(), Some(2));
}

#[test]
fn render_writes_a_png_and_refuses_bad_sizes_without_output() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("m.png");
    let out = meshlap(&[
        "render",
        "builtin:torus:16:8",
        "-o",
        png.to_str().unwrap(),
        "--width",
        "120",
        "--height",
        "90",
        "--azimuth",
        "-30",
        "--colour",
        "degree",
    ]);
    assert!(out.status.success(), "{out:?}");
    let bytes = std::fs::read(&png).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    // IHDR width and height, big-endian
    assert_eq!(u32::from_be_bytes(bytes[16..20].try_into().unwrap()), 120);
    assert_eq!(u32::from_be_bytes(bytes[20..24].try_into().unwrap()), 90);

    let empty = tempfile::tempdir().unwrap();
    let bad = empty.path().join("bad.png");
    let out = meshlap(&[
        "render",
        "builtin:tetrahedron",
        "-o",
        bad.to_str().unwrap(),
        "--width",
        "3",
    ]);
    assert_one_line_error(&out, "size");
    assert!(dir_is_empty(empty.path()));
}

#[test]
fn experiment_claims_writes_its_tables_and_chart() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("claims");
    let o = meshlap(&[
        "experiment",
        "claims",
        "--mesh",
        "builtin:icosahedron",
        "--boundary-mesh",
        "builtin:grid:5",
        "--repair-mesh",
        "builtin:step:6",
        "--limit-mesh",
        "builtin:grid:4",
        "--steps",
        "400",
        "--out",
        out.to_str().unwrap(),
        "--json",
    ]);
    let v = json(&o);
    assert_eq!(v["properties"].as_array().unwrap().len(), 9);
    assert!(v["erratum"][0]["printed_max_abs_row_sum"].as_f64().unwrap() > 0.05);
    assert!(
        v["erratum"][0]["corrected_max_abs_row_sum"]
            .as_f64()
            .unwrap()
            < 1e-12
    );
    for f in [
        "properties.md",
        "properties.csv",
        "erratum.md",
        "repair.md",
        "limits.md",
        "limits.png",
        "claims.json",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    // a missing mesh is one clear error line
    let bad = meshlap(&[
        "experiment",
        "claims",
        "--mesh",
        "/nonexistent.obj",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_one_line_error(&bad, "nonexistent");
}

#[test]
fn experiment_all_quick_writes_every_experiment_and_an_index() {
    let meshes = format!("{}/../../../shared/data/meshes", env!("CARGO_MANIFEST_DIR"));
    if !std::path::Path::new(&meshes).join("cow.obj").is_file() {
        panic!("the shared meshes are expected beside the repository at {meshes}");
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("exp");
    let o = meshlap(&[
        "experiment",
        "all",
        "--quick",
        "--meshes",
        &meshes,
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let index = std::fs::read_to_string(out.join("README.md")).unwrap();
    for d in ["claims", "figures", "eigen-cost", "fairing", "compression"] {
        assert!(index.contains(&format!("]({d}/)")), "{index}");
        let n = std::fs::read_dir(out.join(d)).unwrap().count();
        assert!(n >= 3, "{d}: {n} files");
    }
    assert!(out.join("figures/fig4_4_8_sphere.png").is_file());
    assert!(out.join("claims/erratum.md").is_file());
}

/// A reader that goes away (`meshlap … | head -0`) ends the command quietly with
/// exit 0: the broken pipe is recognised, not a panic and not an error line.
#[test]
fn closed_stdout_ends_quietly() {
    use std::process::{Command, Stdio};
    let mut child = Command::new(env!("CARGO_BIN_EXE_meshlap"))
        .args(["spectrum", "builtin:grid:40", "--kind", "kl"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{:?}: {stderr}", out.status);
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn the_cotangent_mass_matrix_is_written_beside_the_stiffness() {
    let dir = tempfile::tempdir().unwrap();
    let (l, m) = (dir.path().join("L.mtx"), dir.path().join("M.mtx"));
    let o = meshlap(&[
        "operator",
        &data("cow.obj"),
        "--kind",
        "cotan",
        "--mass",
        "barycentric",
        "-o",
        l.to_str().unwrap(),
        "--mass-output",
        m.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mass = meshlap::io::read_matrix_market(&m).unwrap();
    let stiffness = meshlap::io::read_matrix_market(&l).unwrap();
    let n = stiffness.nrows();
    assert_eq!((mass.nrows(), mass.ncols(), mass.compute_nnz()), (n, n, n));
    // The library's mass of the same (cleaned) mesh, value for value: a third of the
    // incident triangle areas.
    let input = meshlap::input::open(&data("cow.obj"), &Default::default()).unwrap();
    let want = meshlap::operator::cotan::mass(
        &input.mesh,
        meshlap::operator::cotan::MassKind::Barycentric,
    )
    .unwrap();
    assert_eq!(want.len(), n);
    for (j, &w) in want.iter().enumerate() {
        assert_eq!(mass.row_idx_of_col_raw(j), &[j]);
        assert_eq!(mass.val_of_col(j), &[w]);
    }
    // Another kind has no mass matrix: refused before anything is read or written.
    let o = meshlap(&[
        "operator",
        "builtin:icosphere:2",
        "--kind",
        "sql",
        "--mass-output",
        dir.path().join("none.mtx").to_str().unwrap(),
    ]);
    assert_one_line_error(&o, "--mass-output: the sql operator has no mass matrix");
    assert!(!dir.path().join("none.mtx").exists());
}
