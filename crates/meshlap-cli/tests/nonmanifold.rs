//! What every command does with non-manifold and inconsistently oriented meshes (the
//! generated `builtin:nm-*` meshes, and cow, beetle and suzanne from the test data):
//! `compress` codes them exactly, `project`, `smooth` and `operator` work with every
//! operator defined there and refuse the SQL on a non-manifold edge in one clear line.

mod common;
use common::*;
use meshlap::TriMesh;

/// Every generated configuration: an edge of three faces, of four, two closed or two
/// open fans at a vertex, a flipped face, a Möbius strip, all of them at once.
const GENERATED: [&str; 7] = [
    "builtin:nm-fin",
    "builtin:nm-book",
    "builtin:nm-bowtie",
    "builtin:nm-fans",
    "builtin:nm-flipped",
    "builtin:nm-moebius",
    "builtin:nm-mixed",
];

/// `meshlap compare`'s measurement of `b` against `a` (same vertex order): whether
/// the oriented face sets are identical, and the largest vertex error ÷ diagonal.
fn same_faces_and_error(a: &TriMesh, b: &TriMesh) -> (bool, f64) {
    let c = meshlap::metric::compare(
        a,
        b,
        None,
        &meshlap::metric::CompareOptions::without_msdm2(1000),
    )
    .unwrap();
    (c.same_connectivity, c.vertex_max.unwrap_or(f64::INFINITY))
}

/// The mesh a command reads: `spec` opened and cleaned.
fn cleaned(spec: &str) -> TriMesh {
    meshlap::input::open(spec, &Default::default())
        .unwrap()
        .mesh
}

fn read(p: &std::path::Path) -> TriMesh {
    meshlap::io::read_mesh(p, None).unwrap().mesh
}

#[test]
fn compress_keeps_the_faces_and_the_vertex_order_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let mut specs: Vec<String> = GENERATED.iter().map(|s| s.to_string()).collect();
    specs.extend(["cow.obj", "beetle.obj", "suzanne.obj"].map(data));
    for spec in &specs {
        let input = cleaned(spec);
        for (mode, preserve) in [("spatial", true), ("spectral", true), ("auto", false)] {
            let mlz = dir.path().join("m.mlz");
            let out = dir.path().join("m.obj");
            let mut args = vec![
                "compress",
                spec,
                "-o",
                mlz.to_str().unwrap(),
                "--mode",
                mode,
                "--json",
            ];
            if preserve {
                args.push("--preserve-order");
            }
            let r = json(&meshlap(&args));
            assert!(r["vertex_copies"].as_u64().unwrap() > 0, "{spec}: not cut");
            assert!(r["rejoin_bpv"].as_f64().unwrap() > 0.0, "{spec}");
            let o = meshlap(&[
                "decompress",
                mlz.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
            ]);
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            let d = read(&out);
            assert_eq!(d.n_vertices(), input.n_vertices(), "{spec} {mode}");
            assert_eq!(d.n_faces(), input.n_faces(), "{spec} {mode}");
            if preserve {
                // The input's faces in the input's numbering, each vertex where it was
                // (to the 10-bit default quantization).
                let (same, err) = same_faces_and_error(&input, &d);
                assert!(same, "{spec} {mode}: faces differ");
                assert!(err < 1.0 / 64.0, "{spec} {mode}: a vertex moved by {err}");
            }
        }
    }
}

#[test]
fn a_bowtie_file_compresses() {
    // Two triangles sharing only a vertex: refused before version 5 of the format.
    let dir = tempfile::tempdir().unwrap();
    let bowtie = dir.path().join("bowtie.obj");
    std::fs::write(
        &bowtie,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv -1 0 0\nv 0 -1 0\nf 1 2 3\nf 1 4 5\n",
    )
    .unwrap();
    let (mlz, out) = (dir.path().join("b.mlz"), dir.path().join("b.off"));
    let r = json(&meshlap(&[
        "compress",
        bowtie.to_str().unwrap(),
        "-o",
        mlz.to_str().unwrap(),
        "--preserve-order",
        "--json",
    ]));
    assert_eq!(r["vertex_copies"].as_u64(), Some(1));
    assert!(meshlap(&[
        "decompress",
        mlz.to_str().unwrap(),
        "-o",
        out.to_str().unwrap()
    ])
    .status
    .success());
    let (same, err) = same_faces_and_error(&cleaned(bowtie.to_str().unwrap()), &read(&out));
    assert!(same && err < 1e-2, "{err}");
}

#[test]
fn project_and_smooth_keep_the_connectivity() {
    let dir = tempfile::tempdir().unwrap();
    for spec in ["builtin:nm-mixed", &data("beetle.obj")] {
        let input = cleaned(spec);
        let out = dir.path().join("p.obj");
        let o = out.to_str().unwrap();
        for kind in ["kirchhoff", "tutte", "sstl", "cotan"] {
            let p = meshlap(&["project", spec, "-k", kind, "--keep", "50%", "-o", o]);
            assert!(p.status.success(), "project {kind} {spec}: {p:?}");
            let m = read(&out);
            assert_eq!(m.faces, input.faces, "project {kind} {spec}");
            assert!(m.positions.iter().flatten().all(|x| x.is_finite()));
        }
        for args in [
            &["--operator", "tutte"][..],
            &["--operator", "kirchhoff", "--filter", "taubin"],
            &[
                "--operator",
                "cotan",
                "--filter",
                "explicit",
                "--lambda",
                "0.1",
            ],
        ] {
            let mut a = vec!["smooth", spec, "-o", o];
            a.extend_from_slice(args);
            let s = meshlap(&a);
            assert!(s.status.success(), "smooth {args:?} {spec}: {s:?}");
            let m = read(&out);
            assert_eq!(m.faces, input.faces, "smooth {args:?} {spec}");
            assert!(m.positions.iter().flatten().all(|x| x.is_finite()));
        }
    }
}

#[test]
fn the_sql_refuses_a_non_manifold_edge_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.obj");
    let o = out.to_str().unwrap();
    for spec in ["builtin:nm-fin", "builtin:nm-book", &data("beetle.obj")] {
        for args in [
            vec!["operator", spec, "-k", "sql"],
            vec!["project", spec, "-k", "sql", "--keep", "50%", "-o", o],
            vec!["smooth", spec, "--operator", "sql", "-o", o],
            vec![
                "compress",
                spec,
                "--mode",
                "spectral",
                "--operator",
                "sql",
                "-o",
                o,
            ],
        ] {
            assert_one_line_error(&meshlap(&args), "faces (non-manifold)");
        }
    }
    assert!(!out.exists(), "no output after a refusal");
}

#[test]
fn operators_on_non_manifold_meshes() {
    // Every operator but the SQL is defined on any mesh; the GSMLs keep zero row
    // sums there. The SQL is defined at a non-manifold vertex whose edges have at most
    // two faces (two boundary fans: the per-edge boundary diagonal), with zero row
    // sums too.
    for spec in GENERATED {
        for kind in [
            "kirchhoff",
            "tutte",
            "graph",
            "sstl",
            "tutte2",
            "sdl",
            "cotan",
            "mean-value",
        ] {
            let r = json(&meshlap(&["operator", spec, "-k", kind, "--json"]));
            let row = r["max_abs_row_sum"].as_f64().unwrap();
            if kind != "graph" {
                assert!(row < 1e-9, "{kind} on {spec}: row sum {row}");
            }
        }
    }
    for spec in ["builtin:nm-bowtie", "builtin:nm-fans"] {
        let r = json(&meshlap(&["operator", spec, "-k", "sql", "--json"]));
        assert!(r["max_abs_row_sum"].as_f64().unwrap() < 1e-12, "{spec}");
    }
}
