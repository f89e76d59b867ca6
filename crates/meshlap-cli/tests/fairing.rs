//! End-to-end tests of `smooth`, `iterate` and `repair-sql` after the library took
//! over their defaults and decisions: what `--json` reports is what ran, option names
//! are the library's (an unknown one is a usage error, never a fallback), and the
//! errors carry the command-line hint.

mod common;
use common::*;

fn smooth(mesh: &str, args: &[&str]) -> serde_json::Value {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.ply");
    let mut a = vec!["smooth", mesh, "-o", out.to_str().unwrap(), "--json"];
    a.extend(args);
    json(&meshlap(&a))
}

fn max_iterations(v: &serde_json::Value) -> u64 {
    v["iterations"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| i.as_u64().unwrap())
        .max()
        .unwrap()
}

#[test]
fn bicgstab_reports_the_stopping_rule_it_used() {
    let tl = ["-k", "tl", "--solver", "bicgstab"];
    let strong = smooth(&data("cow.obj"), &[&tl[..], &["--stop", "strong"]].concat());
    assert_eq!(strong["stop"], "strong");
    assert_eq!(strong["solver"], "bicgstab");
    // The strong rule holds in every column.
    for r in strong["residuals"].as_array().unwrap() {
        assert!(r.as_f64().unwrap() < 1e-5, "{strong}");
    }
    let weak = smooth(&data("cow.obj"), &tl);
    assert_eq!(weak["stop"], "weak");
    assert!(max_iterations(&weak) <= max_iterations(&strong));
}

#[test]
fn json_names_the_solver_that_ran_and_what_it_knows() {
    let auto_tl = smooth("builtin:icosphere:3", &["-k", "tl"]);
    assert_eq!(auto_tl["solver"], "bicg");
    assert!(auto_tl["solves"][0]["plateau_at"].is_array());
    let auto_sql = smooth("builtin:icosphere:3", &["-k", "sql"]);
    assert_eq!(auto_sql["solver"], "cg");
    assert!(auto_sql["solves"][0].get("plateau_at").is_none());
    let chol = smooth(
        "builtin:icosphere:3",
        &["-k", "sql", "--solver", "cholesky"],
    );
    assert!(chol.get("stop").is_none() && chol.get("tolerance").is_none());
    let f = &chol["solves"][0]["factorization"];
    assert!(f["factor_nnz"].as_u64().unwrap() > 0, "{chol}");
    assert!(f["numeric_seconds"].as_f64().unwrap() > 0.0);
    let bbox = smooth(
        "builtin:icosphere:2",
        &["--filter", "explicit", "--preserve", "bbox"],
    );
    assert_eq!(bbox["preserve"], "bbox");
    assert_eq!(bbox["lambda"], 0.5);
    assert!(bbox.get("solver").is_none());
}

#[test]
fn unknown_option_names_are_usage_errors() {
    for (flag, value) in [
        ("--solver", "gmres"),
        ("--stop", "strongest"),
        ("--filter", "gaussian"),
        ("--preserve", "area"),
    ] {
        let o = meshlap(&["smooth", "builtin:icosphere:1", "-o", "x.ply", flag, value]);
        assert_eq!(o.status.code(), Some(2), "{flag} {value}");
    }
    let help = String::from_utf8_lossy(&meshlap(&["smooth", "--help"]).stdout).into_owned();
    assert!(help.contains("cg-sym") && help.contains("weak-vertex") && help.contains("bbox"));
}

#[test]
fn the_library_validates_and_the_cli_adds_the_hint() {
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path().join("x.ply");
    let o = o.to_str().unwrap();
    let e = meshlap(&["smooth", "builtin:icosphere:1", "-o", o, "--tol", "0"]);
    assert_one_line_error(&e, "tolerance");
    let e = meshlap(&["smooth", "builtin:icosphere:1", "-o", o, "-n", "0"]);
    assert_one_line_error(&e, "at least one step");
    let e = meshlap(&[
        "smooth",
        "builtin:icosphere:1",
        "-o",
        o,
        "--filter",
        "ideal",
    ]);
    assert_one_line_error(&e, "pass --passband");
    let tl_cg = ["-k", "tl", "--solver", "cholesky"];
    let mut a = vec!["smooth", "builtin:icosphere:1", "-o", o];
    a.extend(tl_cg);
    assert_one_line_error(&meshlap(&a), "use --solver bicg");
    let e = meshlap(&["iterate", "builtin:cube:2", "--kind", "kl", "--k=-1"]);
    assert_one_line_error(&e, "k must be positive");
    let e = meshlap(&[
        "repair-sql",
        &data("cow.obj"),
        "-o",
        o,
        "--max-dihedral",
        "0",
    ]);
    assert_one_line_error(&e, "dihedral");
    let e = meshlap(&["repair-sql", &data("beetle.obj"), "-o", o]);
    assert_one_line_error(&e, "meshlap clean --split-nonmanifold");
    assert!(dir_is_empty(dir.path()));
}
