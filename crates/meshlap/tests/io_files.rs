//! Readers on the shared meshes, the malformed corpus, and seeded write→read round
//! trips of random meshes in every format.

mod common;
use common::*;
use meshlap::io::{read_mesh, write_mesh, Format, IoError, WriteOptions};
use meshlap::TriMesh;
use proptest::prelude::*;
use std::path::Path;

fn raw(path: &str) -> meshlap::io::LoadedMesh {
    read_mesh(Path::new(path), None).unwrap_or_else(|e| panic!("{path}: {e}"))
}

#[test]
fn shared_meshes_load_with_the_documented_counts() {
    // (file, cleaned V, F, E, boundary edges, non-manifold edges, components)
    let expected: &[(&str, usize, usize, usize, usize, usize, usize)] = &[
        ("cow.obj", 2903, 5804, 8706, 0, 0, 1),
        ("spot.obj", 2930, 5856, 8784, 0, 0, 1),
        ("fandisk.obj", 6475, 12946, 19419, 0, 0, 1),
        ("teapot.obj", 3644, 6320, 9998, 1036, 0, 4),
        ("woody.obj", 694, 1267, 1960, 119, 0, 1),
        ("beetle.obj", 1148, 2053, 3204, 296, 47, 2),
    ];
    for &(name, v, f, e, b, nm, c) in expected {
        let r = load(&data(name)).report();
        assert_eq!(
            (
                r.vertices,
                r.faces,
                r.edges,
                r.boundary_edges,
                r.non_manifold_edges,
                r.components
            ),
            (v, f, e, b, nm, c),
            "{name}"
        );
    }
    // suzanne: quads fan-triangulated to 968 triangles, one of them a duplicate.
    let s = load(&data("suzanne.obj"));
    assert_eq!(s.read_info.as_ref().unwrap().polygons_triangulated, 468);
    let r = s.report();
    assert_eq!(
        (r.vertices, r.faces + r.dropped_duplicate_faces, r.edges),
        (507, 968, 1472)
    );
    assert_eq!(
        (
            r.dropped_duplicate_faces,
            r.non_manifold_edges,
            r.components
        ),
        (1, 1, 3)
    );
}

#[test]
fn large_shared_meshes() {
    let bunny = raw(&shared("stanford-bunny.obj"));
    assert_eq!(
        (bunny.mesh.n_vertices(), bunny.mesh.n_faces()),
        (35947, 69451)
    );
    let r = load(&shared("stanford-bunny.obj")).report();
    assert_eq!(
        (
            r.vertices,
            r.dropped_unreferenced_vertices,
            r.edges,
            r.boundary_edges
        ),
        (34834, 1113, 104288, 223)
    );

    let horse = load(&shared("horse.ply")).report();
    assert_eq!(
        (horse.vertices, horse.faces, horse.edges, horse.genus),
        (48485, 96966, 145449, Some(0))
    );

    // Igea stores its faces as one triangle strip with -1 restarts.
    let igea = load(&shared("igea.ply"));
    let info = igea.read_info.as_ref().unwrap();
    assert_eq!(info.triangles_from_strips, 268_686);
    let r = igea.report();
    assert_eq!((r.vertices, r.faces, r.edges), (134_345, 268_686, 403_029));
    assert_eq!(
        (
            r.boundary_edges,
            r.inconsistently_oriented_edges,
            r.non_manifold_edges
        ),
        (0, 0, 0)
    );
    assert_eq!(r.genus, Some(0));
}

fn malformed(name: &str) -> IoError {
    let p = format!(
        "{}/../../tests/data/malformed/{name}",
        env!("CARGO_MANIFEST_DIR")
    );
    match read_mesh(Path::new(&p), None) {
        Ok(m) => panic!("{name}: read {} faces instead of failing", m.mesh.n_faces()),
        Err(e) => e,
    }
}

#[test]
fn malformed_corpus_gives_the_expected_errors() {
    use IoError::*;
    let e = malformed("bad_coordinate.obj");
    assert!(
        matches!(&e, Parse { line: 3, token, .. } if token == "1.0x"),
        "{e}"
    );
    assert!(
        e.to_string()
            .contains("bad_coordinate.obj:3: cannot parse \"1.0x\""),
        "{e}"
    );
    assert!(matches!(
        malformed("bad_face_index.obj"),
        Parse { line: 4, .. }
    ));
    assert!(matches!(
        malformed("two_corner_face.obj"),
        Parse { line: 3, .. }
    ));
    assert!(matches!(
        malformed("index_out_of_range.obj"),
        IndexOutOfRange {
            line: 4,
            index: 4,
            vertices: 3,
            ..
        }
    ));
    assert!(matches!(
        malformed("zero_index.obj"),
        IndexOutOfRange { index: 0, .. }
    ));
    assert!(matches!(
        malformed("relative_below_first.obj"),
        IndexOutOfRange { index: -4, .. }
    ));
    assert!(matches!(
        malformed("nan_coordinate.obj"),
        NonFinite {
            line: 2,
            vertex: 1,
            ..
        }
    ));
    assert!(matches!(
        malformed("inf_coordinate.off"),
        NonFinite { vertex: 2, .. }
    ));
    assert!(matches!(malformed("no_faces.obj"), Empty { .. }));
    assert!(matches!(malformed("empty.off"), Header { .. }));
    assert!(matches!(malformed("not_off.off"), Header { .. }));
    assert!(matches!(
        malformed("truncated_vertices.off"),
        Truncated { .. }
    ));
    assert!(matches!(malformed("huge_counts.off"), Header { .. }));
    assert!(matches!(
        malformed("bad_polygon_size.off"),
        Parse { line: 6, .. }
    ));
    assert!(matches!(malformed("truncated.ply"), Truncated { .. }));
    assert!(matches!(malformed("huge_count.ply"), Header { .. }));
    assert!(matches!(malformed("bad_header.ply"), Header { .. }));
    assert!(matches!(malformed("unknown_type.ply"), Parse { .. }));
    assert!(matches!(
        malformed("out_of_range.ply"),
        IndexOutOfRange { index: 7, .. }
    ));
    assert!(matches!(malformed("bad_token.ply"), Parse { line: 12, .. }));
    assert!(matches!(malformed("huge_list.ply"), Truncated { .. }));
    assert!(matches!(malformed("truncated.stl"), Truncated { .. }));
    assert!(matches!(malformed("tiny.stl"), Truncated { .. }));
    assert!(matches!(malformed("mesh.txt"), UnknownFormat { .. }));
    assert!(matches!(
        read_mesh(Path::new("/nonexistent/m.obj"), None),
        Err(Open { .. })
    ));
}

#[test]
fn every_prefix_of_a_binary_ply_fails_cleanly() {
    let m = meshlap::mesh::builtin::icosphere(1).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("m.ply");
    write_mesh(&p, &m, &WriteOptions::default()).unwrap();
    let bytes = std::fs::read(&p).unwrap();
    for cut in 0..bytes.len() {
        assert!(meshlap::io::read_mesh_from_bytes(&bytes[..cut], Format::Ply).is_err());
    }
    assert!(meshlap::io::read_mesh_from_bytes(&bytes, Format::Ply).is_ok());
}

fn random_mesh() -> impl Strategy<Value = TriMesh> {
    (3usize..40).prop_flat_map(|n| {
        let coord = prop_oneof![
            -1e6f64..1e6,
            -1.0f64..1.0,
            Just(0.0),
            Just(-0.0),
            Just(1e-300)
        ];
        (
            prop::collection::vec([coord.clone(), coord.clone(), coord], n),
            prop::collection::vec([0..n as u32, 0..n as u32, 0..n as u32], 1..60),
        )
            .prop_map(|(p, f)| TriMesh::new(p, f))
    })
}

proptest! {
    // Deterministic: proptest's default RNG seed is fixed per test name unless
    // PROPTEST_RNG_SEED overrides it; failures persist nowhere (no regressions file).
    #![proptest_config(ProptestConfig { cases: 64, failure_persistence: None, ..ProptestConfig::default() })]
    #[test]
    fn random_meshes_survive_write_read(m in random_mesh()) {
        let dir = tempfile::tempdir().unwrap();
        for (ext, ascii) in [("obj", false), ("off", false), ("ply", false), ("ply", true)] {
            let p = dir.path().join(format!("m.{ext}"));
            write_mesh(&p, &m, &WriteOptions { ply_ascii: ascii, ..Default::default() }).unwrap();
            let back = read_mesh(&p, None).unwrap().mesh;
            prop_assert_eq!(&back, &m, "{} ascii={}", ext, ascii);
        }
        // STL: f32 positions, welded corners; the geometry of every face survives.
        let p = dir.path().join("m.stl");
        write_mesh(&p, &m, &WriteOptions::default()).unwrap();
        let back = read_mesh(&p, None).unwrap().mesh;
        prop_assert_eq!(back.n_faces(), m.n_faces());
        for (fb, fm) in back.faces.iter().zip(&m.faces) {
            for c in 0..3 {
                let a = back.positions[fb[c] as usize];
                let b = m.positions[fm[c] as usize];
                for k in 0..3 {
                    prop_assert_eq!(a[k], b[k] as f32 as f64);
                }
            }
        }
    }
}

#[test]
fn ply_with_scalar_and_colours() {
    let m = meshlap::mesh::builtin::octahedron();
    let s: Vec<f64> = (0..6).map(|i| i as f64 * 0.25).collect();
    let c: Vec<[u8; 3]> = (0..6).map(|i| [i as u8, 2, 3]).collect();
    let dir = tempfile::tempdir().unwrap();
    for ascii in [false, true] {
        let p = dir.path().join("o.ply");
        let opts = WriteOptions {
            vertex_scalar: Some(("quality", &s)),
            vertex_colors: Some(&c),
            ply_ascii: ascii,
            ..Default::default()
        };
        write_mesh(&p, &m, &opts).unwrap();
        let text = std::fs::read(&p).unwrap();
        let header = String::from_utf8_lossy(&text[..text.len().min(400)]).to_string();
        assert!(
            header.contains("property double quality") && header.contains("property uchar red")
        );
        assert_eq!(read_mesh(&p, None).unwrap().mesh, m);
        // The values themselves, vertex by vertex: x y z quality red green blue.
        let body_at = text.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        let body = &text[body_at..];
        for v in 0..6 {
            let (q, rgb) = if ascii {
                let line = String::from_utf8_lossy(body)
                    .lines()
                    .nth(v)
                    .unwrap()
                    .to_string();
                let t: Vec<&str> = line.split_whitespace().collect();
                assert_eq!(t.len(), 7, "{line}");
                let rgb: Vec<u8> = t[4..].iter().map(|x| x.parse().unwrap()).collect();
                (t[3].parse::<f64>().unwrap(), [rgb[0], rgb[1], rgb[2]])
            } else {
                let rec = &body[v * 35..(v + 1) * 35];
                let q = f64::from_le_bytes(rec[24..32].try_into().unwrap());
                (q, [rec[32], rec[33], rec[34]])
            };
            assert_eq!(q, s[v], "{ascii} vertex {v}");
            assert_eq!(rgb, c[v], "{ascii} vertex {v}");
        }
    }
    let bad = WriteOptions {
        vertex_scalar: Some(("q", &s[..3])),
        ..Default::default()
    };
    assert!(matches!(
        write_mesh(&dir.path().join("x.ply"), &m, &bad),
        Err(IoError::InvalidData(_))
    ));
    assert!(!dir.path().join("x.ply").exists());
    // Properties are refused, not dropped, for formats without them.
    for ext in ["obj", "off", "stl"] {
        let path = dir.path().join(format!("x.{ext}"));
        let colors_only = WriteOptions {
            vertex_colors: Some(&c),
            ..Default::default()
        };
        assert!(matches!(
            write_mesh(&path, &m, &colors_only),
            Err(IoError::PropertiesNeedPly { .. })
        ));
        assert!(!path.exists());
    }
}

/// `open_mesh` (read and clean, no connectivity) gives `open`'s mesh and clean report
/// on every test mesh (some need cleaning) and on a generated one, and each cleaned
/// mesh passes `check_clean`.
#[test]
fn open_mesh_equals_open_without_the_connectivity() {
    use meshlap::input::{open, open_mesh, OpenOptions};
    let opts = OpenOptions::default();
    let mut specs: Vec<String> = CLOSED
        .iter()
        .chain(WITH_BOUNDARY)
        .chain(NON_MANIFOLD)
        .map(|m| data(m))
        .collect();
    specs.push("builtin:icosphere:3".into());
    for spec in &specs {
        let input = open(spec, &opts).unwrap();
        let (mesh, report) = open_mesh(spec, &opts).unwrap();
        assert_eq!(mesh, input.mesh, "{spec}");
        assert_eq!(
            serde_json::to_string(&report).unwrap(),
            serde_json::to_string(&input.clean).unwrap(),
            "{spec}"
        );
        assert_eq!(
            meshlap::mesh::clean::check_clean(mesh.n_vertices(), &mesh.faces),
            Ok(()),
            "{spec}"
        );
    }
}
