//! Degenerate geometry (issue 16): zero-area faces, coincident vertices, needle
//! triangles, isolated vertices and extreme scales, generated on top of the builtin
//! meshes by seeded property tests. Every operator and every metric either gives
//! finite values or a typed error that names the face, edge or vertex — never NaN or
//! infinity — and `io::write_mesh` refuses to write a non-finite coordinate.

use meshlap::io::{write_mesh, Format, IoError, WriteOptions};
use meshlap::mesh::{builtin, topology::Topology};
use meshlap::metric::msdm2::{msdm2, Msdm2Params};
use meshlap::metric::{compare, CompareOptions};
use meshlap::operator::{Operator, OperatorError, OperatorKind, OperatorOptions};
use meshlap::TriMesh;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

/// One way of damaging a mesh's geometry (the connectivity is left alone).
#[derive(Clone, Debug)]
enum Damage {
    /// Vertex `j` moved onto vertex `i` (coincident vertices; a zero-length edge and
    /// zero-area faces when they are neighbours).
    Collapse(usize, usize),
    /// The third corner of face `f` moved onto the line of the other two, at
    /// parameter `t` (a zero-area face with distinct corners when t ∉ {0, 1}).
    Flatten(usize, f64),
    /// The third corner of face `f` moved to `10^-e` (relative) off the line of the
    /// other two: a needle, below or above the rounding of its edges.
    Needle(usize, f64, i32),
    /// An unreferenced vertex appended.
    Isolated([f64; 3]),
    /// Every coordinate multiplied by `10^e`.
    Scale(i32),
}

fn damage() -> impl Strategy<Value = Damage> {
    prop_oneof![
        (0..10_000usize, 0..10_000usize).prop_map(|(i, j)| Damage::Collapse(i, j)),
        (
            0..10_000usize,
            prop_oneof![Just(0.0), Just(0.5), Just(1.0), Just(-0.5), -1.0..2.0f64]
        )
            .prop_map(|(f, t)| Damage::Flatten(f, t)),
        (0..10_000usize, -0.5..1.5f64, 4..24i32).prop_map(|(f, t, e)| Damage::Needle(f, t, e)),
        prop::array::uniform3(-2.0..2.0f64).prop_map(Damage::Isolated),
        (-20..20i32).prop_map(Damage::Scale),
    ]
}

fn base() -> impl Strategy<Value = TriMesh> {
    prop_oneof![
        Just(builtin::tetrahedron()),
        Just(builtin::icosahedron()),
        Just(builtin::grid(4).unwrap()),
        Just(builtin::torus(6, 4).unwrap()),
        Just(builtin::cube(2).unwrap()),
    ]
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn apply(m: &mut TriMesh, d: &Damage) {
    let n = m.positions.len();
    match *d {
        Damage::Collapse(i, j) => m.positions[j % n] = m.positions[i % n],
        Damage::Flatten(f, t) | Damage::Needle(f, t, _) => {
            let [a, b, c] = m.faces[f % m.faces.len()].map(|v| v as usize);
            let (pa, pb) = (m.positions[a], m.positions[b]);
            let ab = sub(pb, pa);
            let mut p = [0, 1, 2].map(|k| pa[k] + t * ab[k]);
            if let Damage::Needle(_, _, e) = *d {
                // Off the line by 10^-e times the edge length, along an axis not
                // parallel to the edge.
                let len = ab.iter().map(|x| x * x).sum::<f64>().sqrt();
                let k = (0..3)
                    .min_by(|&x, &y| ab[x].abs().total_cmp(&ab[y].abs()))
                    .unwrap();
                p[k] += len * 10f64.powi(-e);
            }
            m.positions[c] = p;
        }
        Damage::Isolated(p) => m.positions.push(p),
        Damage::Scale(e) => {
            let s = 10f64.powi(e);
            for p in &mut m.positions {
                *p = p.map(|x| x * s);
            }
        }
    }
}

/// (damaged mesh, the undamaged mesh at the same scale).
fn degenerate_mesh() -> impl Strategy<Value = (TriMesh, TriMesh)> {
    (base(), prop::collection::vec(damage(), 1..6)).prop_map(|(mut m, ds)| {
        let mut reference = m.clone();
        for d in &ds {
            apply(&mut m, d);
            if let Damage::Scale(_) = d {
                apply(&mut reference, d);
            }
        }
        (m, reference)
    })
}

/// A seeded runner: the same cases every run.
fn runner(seed: u8, cases: u32) -> TestRunner {
    let config = Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    };
    TestRunner::new_with_rng(
        config,
        TestRng::from_seed(RngAlgorithm::ChaCha, &[seed; 32]),
    )
}

/// Doubled area and squared longest edge of face `f`, computed independently of the
/// library (Heron-free: the cross product in long form).
fn area2_and_longest2(m: &TriMesh, f: usize) -> (f64, f64) {
    let [a, b, c] = m.faces[f].map(|v| m.positions[v as usize]);
    let (u, v, w) = (sub(b, a), sub(c, a), sub(c, b));
    let n = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    let l2 = |x: [f64; 3]| x[0] * x[0] + x[1] * x[1] + x[2] * x[2];
    (l2(n).sqrt(), l2(u).max(l2(v)).max(l2(w)))
}

fn has_zero_length_edge(m: &TriMesh, topo: &Topology) -> bool {
    topo.edges()
        .iter()
        .any(|&[a, b]| m.positions[a as usize] == m.positions[b as usize])
}

#[test]
fn operators_are_finite_or_name_the_culprit() {
    // Outcomes of the geometric operators: ok, face errors, edge errors.
    let counts = [0, 1, 2].map(|_| std::cell::Cell::new(0usize));
    let count = |k: usize| counts[k].set(counts[k].get() + 1);
    runner(16, 300)
        .run(&degenerate_mesh(), |(m, _)| {
            let topo = Topology::new(&m).expect("damage keeps the connectivity");
            for kind in OperatorKind::ALL {
                match Operator::assemble(kind, &m, &topo, &OperatorOptions::default()) {
                    Ok(op) => {
                        prop_assert!(
                            op.matrix.val().iter().all(|v| v.is_finite()),
                            "{kind}: non-finite entry"
                        );
                        let mass = op.mass.as_deref().unwrap_or(&[]);
                        prop_assert!(mass.iter().all(|v| v.is_finite() && *v >= 0.0));
                        if !kind.is_combinatorial() {
                            count(0);
                        }
                    }
                    Err(OperatorError::IsolatedVertex { vertex }) => {
                        prop_assert!(topo.degrees()[vertex as usize] == 0)
                    }
                    Err(OperatorError::DegenerateFace { face, a, b, c, .. }) => {
                        prop_assert!(!kind.is_combinatorial() && kind != OperatorKind::Sdl);
                        prop_assert_eq!(m.faces[face as usize], [a, b, c]);
                        // Zero area to rounding (a loose, independent bound).
                        let (area2, l2) = area2_and_longest2(&m, face as usize);
                        prop_assert!(area2 <= 1e-12 * l2, "{kind}: face {face} {area2} {l2}");
                        count(1);
                    }
                    Err(OperatorError::ZeroLengthEdge { a, b, .. }) => {
                        prop_assert_eq!(m.positions[a as usize], m.positions[b as usize]);
                        count(2);
                    }
                    Err(e) => prop_assert!(false, "{kind}: unexpected error {e}"),
                }
            }
            // Cross-checks: the SDL needs only non-zero edge lengths; the cotangent
            // operator succeeds when every face is far from degenerate.
            let sdl = Operator::assemble(OperatorKind::Sdl, &m, &topo, &Default::default());
            prop_assert_eq!(sdl.is_ok(), !has_zero_length_edge(&m, &topo));
            let proper = (0..m.faces.len()).all(|f| {
                let (area2, l2) = area2_and_longest2(&m, f);
                area2 > 1e-14 * l2
            });
            let cot = Operator::assemble(OperatorKind::Cotan, &m, &topo, &Default::default());
            if proper {
                prop_assert!(cot.is_ok(), "{:?}", cot.err());
            }
            Ok(())
        })
        .unwrap();
    // The generator reaches every outcome.
    assert!(counts.iter().all(|c| c.get() > 0), "{counts:?}");
}

#[test]
fn metrics_are_finite_on_degenerate_meshes() {
    runner(17, 120)
        .run(&degenerate_mesh(), |(m, reference)| {
            for (a, b) in [(&m, &reference), (&reference, &m)] {
                match compare(a, b, None, &CompareOptions::without_msdm2(200)) {
                    Ok(c) => {
                        let v = serde_json::to_value(&c).unwrap();
                        for (k, x) in v.as_object().unwrap() {
                            if let Some(f) = x.as_f64() {
                                prop_assert!(f.is_finite(), "{k} = {f}");
                            }
                        }
                    }
                    // Only a damaged mesh collapsed to one point has nothing to
                    // normalise by.
                    Err(e) => prop_assert!(a.bbox_diagonal() == 0.0, "{e}"),
                }
            }
            // And against the damaged mesh shifted by a quarter of the reference's
            // size: a positive, finite distance.
            let d = reference.bbox_diagonal();
            let mut shifted = m.clone();
            for p in &mut shifted.positions {
                p[0] += 0.25 * d;
            }
            let c = compare(
                &reference,
                &shifted,
                None,
                &CompareOptions::without_msdm2(200),
            )
            .unwrap();
            prop_assert!(c.hausdorff.is_finite() && c.hausdorff > 0.0);
            prop_assert!(c.karni_gotsman.is_none_or(f64::is_finite));
            prop_assert!(c.zhang_sdl.is_none_or(f64::is_finite));
            Ok(())
        })
        .unwrap();
}

/// MSDM2 (through `compare`, as `meshlap compare` computes it) on the same damaged
/// meshes: a finite score in [0, 1.2), zero for a mesh against itself, or the one
/// documented error (a reference collapsed to a point).
#[test]
fn msdm2_is_finite_on_degenerate_meshes() {
    let opts = CompareOptions {
        samples: 100,
        msdm2: true,
    };
    let seen = std::cell::Cell::new(0usize);
    runner(18, 60)
        .run(&degenerate_mesh(), |(m, reference)| {
            for (a, b) in [(&m, &reference), (&reference, &m), (&m, &m)] {
                match compare(a, b, None, &opts) {
                    Ok(c) => {
                        let v = c.msdm2.expect("msdm2 was asked for");
                        prop_assert!(v.is_finite() && (0.0..1.2).contains(&v), "msdm2 = {v}");
                        if std::ptr::eq(a, b) {
                            prop_assert_eq!(v, 0.0, "against itself");
                        }
                        seen.set(seen.get() + 1);
                    }
                    Err(e) => prop_assert!(a.bbox_diagonal() == 0.0, "{e}"),
                }
            }
            Ok(())
        })
        .unwrap();
    assert!(seen.get() > 100, "{}", seen.get());
}

/// Each kind of damage alone, on a fine sphere (so the balls hold several edges), at
/// scales far beyond the property test's (10⁻²⁰⁰ … 10²⁰⁰: the squared radius and the
/// Gaussian weights would underflow or overflow in the input's units; `msdm2` itself
/// there, as `compare` refuses such diagonals): finite, and the same score at every
/// scale.
#[test]
fn msdm2_of_each_damage_and_at_extreme_scales() {
    let sphere = builtin::icosphere(3).unwrap();
    let opts = CompareOptions {
        samples: 100,
        msdm2: true,
    };
    let score = |a: &TriMesh, b: &TriMesh| compare(a, b, None, &opts).unwrap().msdm2.unwrap();
    for d in [
        Damage::Collapse(5, 6),
        Damage::Collapse(0, 1),
        Damage::Flatten(3, 0.5),
        Damage::Flatten(7, 1.0),
        Damage::Needle(9, 0.3, 12),
        Damage::Needle(11, 0.7, 23),
        Damage::Isolated([0.1, 0.2, 0.3]),
        Damage::Isolated([5.0, 0.0, 0.0]),
    ] {
        let mut m = sphere.clone();
        apply(&mut m, &d);
        let v = score(&sphere, &m);
        assert!(v.is_finite() && (0.0..1.2).contains(&v), "{d:?}: {v}");
        assert_eq!(score(&m, &m), 0.0, "{d:?} against itself");
        for e in [-200, -160, -20, 20, 160, 200] {
            let (mut a, mut b) = (sphere.clone(), m.clone());
            apply(&mut a, &Damage::Scale(e));
            apply(&mut b, &Damage::Scale(e));
            // `compare` refuses a diagonal whose square leaves f64 (its other measures
            // need it); MSDM2 itself works in units of the bounding box.
            let w = if e.abs() <= 20 {
                score(&a, &b)
            } else {
                msdm2(&a, &b, &Msdm2Params::default()).unwrap()
            };
            // 10^e is not exact: the same score up to the rounding of the scaled
            // coordinates (a vertex on a ball's sphere may fall either side).
            assert!(
                (w - v).abs() <= 1e-3 * v + 1e-12,
                "{d:?} at 1e{e}: {w} vs {v}"
            );
        }
    }
    // A face with a repeated corner cannot be walked: a typed error naming the face.
    let mut bad = sphere.clone();
    bad.faces[4][1] = bad.faces[4][0];
    let e = compare(&sphere, &bad, None, &opts).unwrap_err();
    assert!(
        matches!(
            e,
            meshlap::metric::MetricError::Topology { which: "test", .. }
        ),
        "{e}"
    );
    assert!(e.to_string().contains('4'), "{e}");
}

/// A point at distance 1 from a degenerate (collinear or collapsed) triangle is at
/// distance 1, not NaN (the closest-point routine treats it as its edges).
#[test]
fn closest_point_on_degenerate_triangles() {
    use meshlap::metric::bvh::closest_on_triangle;
    let (a, b) = ([0.0, 0.0, 0.0], [2.0, 0.0, 0.0]);
    for c in [a, b, [1.0, 0.0, 0.0], [3.0, 0.0, 0.0]] {
        for (tri, p, want) in [
            ((a, b, c), [1.0, 1.0, 0.0], [1.0, 0.0, 0.0]),
            ((a, a, c), [-1.0, 0.0, 0.0], a),
            ((c, a, b), [1.0, 0.0, 1.0], [1.0, 0.0, 0.0]),
        ] {
            let q = closest_on_triangle(p, tri.0, tri.1, tri.2);
            assert!(q.iter().all(|x| x.is_finite()), "{tri:?}");
            if tri.1 != tri.0 || c != a {
                let d = sub(p, q).iter().map(|x| x * x).sum::<f64>();
                let dw = sub(p, want).iter().map(|x| x * x).sum::<f64>();
                assert!((d - dw).abs() < 1e-12, "{tri:?} {p:?}: {q:?}");
            }
        }
    }
}

#[test]
fn writing_refuses_non_finite_coordinates() {
    let dir = tempfile::tempdir().unwrap();
    let mut m = builtin::icosahedron();
    m.positions[7][1] = f64::NAN;
    for ext in ["obj", "off", "ply", "stl"] {
        let p = dir.path().join(format!("m.{ext}"));
        match write_mesh(&p, &m, &WriteOptions::default()) {
            Err(IoError::NonFiniteOutput { vertex, path }) => {
                assert_eq!((vertex, path), (7, p.clone()))
            }
            r => panic!("{ext}: {r:?}"),
        }
    }
    m.positions[7][1] = f64::NEG_INFINITY;
    let e = write_mesh(&dir.path().join("m.ply"), &m, &WriteOptions::default()).unwrap_err();
    assert!(e.to_string().contains("vertex 7"), "{e}");
    // Nothing was written, not even a temporary file.
    assert!(std::fs::read_dir(dir.path()).unwrap().next().is_none());
    // Finite but beyond f32: refused for STL only (it would be written as infinity).
    m.positions[7][1] = 1e39;
    let stl = dir.path().join("m.stl");
    let opts = WriteOptions {
        format: Some(Format::Stl),
        ..Default::default()
    };
    assert!(matches!(
        write_mesh(&stl, &m, &opts),
        Err(IoError::NonFiniteOutput { vertex: 7, .. })
    ));
    let obj = dir.path().join("m.obj");
    write_mesh(&obj, &m, &WriteOptions::default()).unwrap();
    let back = meshlap::io::read_mesh(&obj, None).unwrap().mesh;
    assert_eq!(back.positions[7][1], 1e39);
}
