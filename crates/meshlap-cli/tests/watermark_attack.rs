//! End-to-end tests of `meshlap watermark attack` and the `msdm2` key of `compare`.

mod common;
use common::*;

fn attack_json(dir: &std::path::Path, mesh: &str, extra: &[&str]) -> (serde_json::Value, String) {
    let out = dir.join("out.obj").display().to_string();
    let mut args = vec!["watermark", "attack", mesh, "-o", &out, "--json"];
    args.extend_from_slice(extra);
    (json(&meshlap(&args)), out)
}

#[test]
fn every_kind_runs_and_reports_counts() {
    let dir = tempfile::tempdir().unwrap();
    let m = "builtin:icosphere:2"; // 162 vertices, 480 edges, 320 faces
    let cases: [(&[&str], usize, usize); 9] = [
        (&["--kind", "noise", "--amount", "0.5"], 162, 320),
        (
            &["--kind", "smooth", "--amount", "10", "--lambda", "0.2"],
            162,
            320,
        ),
        (&["--kind", "quantize", "--amount", "8"], 162, 320),
        (
            &["--kind", "similarity", "--amount", "2", "--seed", "5"],
            162,
            320,
        ),
        (&["--kind", "simplify", "--amount", "50"], 81, 158),
        (&["--kind", "subdivide", "--amount", "1"], 162 + 480, 1280),
        (
            &["--kind", "subdivide", "--amount", "1", "--scheme", "loop"],
            162 + 480,
            1280,
        ),
        (
            &["--kind", "subdivide", "--amount", "1", "--scheme", "sqrt3"],
            162 + 320,
            960,
        ),
        (&["--kind", "crop", "--amount", "0"], 162, 320),
    ];
    for (args, v, f) in cases {
        let (j, out) = attack_json(dir.path(), m, args);
        assert_eq!(j["vertices_before"], 162, "{args:?}");
        assert_eq!(
            (
                j["vertices_after"].as_u64().unwrap() as usize,
                j["faces_after"].as_u64().unwrap() as usize
            ),
            (v, f),
            "{args:?}"
        );
        assert_eq!(j["kind"], args[1]);
        for key in ["amount", "scheme", "lambda", "seed", "seconds", "output"] {
            assert!(j.get(key).is_some(), "missing {key}");
        }
        let info = json(&meshlap(&["info", &out, "--json"]));
        assert_eq!(
            info["vertices"].as_u64().unwrap() as usize,
            v,
            "{args:?} written"
        );
    }
    // Cropping really removes vertices.
    let (j, _) = attack_json(dir.path(), m, &["--kind", "crop", "--amount", "30"]);
    assert!(j["vertices_after"].as_u64().unwrap() <= 162 - 49);
}

#[test]
fn seeded_attacks_are_deterministic() {
    let dir = tempfile::tempdir().unwrap();
    let read = |p: &str| std::fs::read(p).unwrap();
    let (_, a) = attack_json(
        dir.path(),
        "builtin:torus:8:6",
        &["--kind", "noise", "--amount", "1", "--seed", "3"],
    );
    let first = read(&a);
    let (_, b) = attack_json(
        dir.path(),
        "builtin:torus:8:6",
        &["--kind", "noise", "--amount", "1", "--seed", "3"],
    );
    assert_eq!(first, read(&b));
    let (_, c) = attack_json(
        dir.path(),
        "builtin:torus:8:6",
        &["--kind", "noise", "--amount", "1", "--seed", "4"],
    );
    assert_ne!(first, read(&c));
}

#[test]
fn bad_amounts_are_one_line_errors_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.obj").display().to_string();
    let run = |extra: &[&str]| {
        let mut a = vec!["watermark", "attack", "builtin:icosahedron", "-o", &out];
        a.extend_from_slice(extra);
        meshlap(&a)
    };
    assert_one_line_error(&run(&["--kind", "quantize", "--amount", "0"]), "1..=52");
    assert_one_line_error(&run(&["--kind", "noise", "--amount", "-3"]), "[0, 100]");
    assert_one_line_error(
        &run(&["--kind", "smooth", "--amount", "3", "--lambda", "2"]),
        "(0, 1]",
    );
    let tet = [
        "watermark",
        "attack",
        "builtin:tetrahedron",
        "-o",
        &out,
        "--kind",
        "simplify",
        "--amount",
        "50",
    ];
    assert_one_line_error(&meshlap(&tet), "no legal collapse");
    assert!(dir_is_empty(dir.path()));
    assert_eq!(
        run(&["--kind", "nope", "--amount", "1"]).status.code(),
        Some(2)
    );
}

#[test]
fn compare_reports_msdm2() {
    let dir = tempfile::tempdir().unwrap();
    let m = "builtin:icosphere:3";
    let same = json(&meshlap(&["compare", m, m, "--json", "--samples", "1000"]));
    assert_eq!(same["msdm2"], 0.0);
    for key in [
        "diagonal",
        "hausdorff",
        "a_to_b_rms",
        "vertex_rms",
        "zhang_sdl",
        "karni_gotsman",
    ] {
        assert!(same.get(key).is_some(), "missing {key}");
    }
    let (_, noisy) = attack_json(dir.path(), m, &["--kind", "noise", "--amount", "1"]);
    let c = json(&meshlap(&[
        "compare",
        m,
        &noisy,
        "--json",
        "--samples",
        "1000",
    ]));
    let v = c["msdm2"].as_f64().unwrap();
    assert!(v > 0.0 && v < 1.0, "{v}");
    let text = meshlap(&["compare", m, &noisy, "--samples", "1000"]);
    assert!(String::from_utf8_lossy(&text.stdout).contains("MSDM2"));
}
