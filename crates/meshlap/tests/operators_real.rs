//! Operator invariants on the pinned real meshes (closed, with boundary, non-manifold).

mod common;
use common::*;
use meshlap::analysis::properties::{analyze, asymmetry, PropertyOptions};
use meshlap::analysis::repair::{repair_sql, RepairMethod, RepairOptions};
use meshlap::operator::sql::{sql, sql_edge_weights, BoundaryDiagonal};
use meshlap::operator::{Operator, OperatorKind, OperatorOptions};
use meshlap::SparseMatrix;

/// KL, GL and SQL are symmetric by construction; the SSTL sums TᵀT in a symmetric
/// order: all four exactly.
const EXACTLY_SYMMETRIC: [OperatorKind; 5] = [
    OperatorKind::Kirchhoff,
    OperatorKind::Graph,
    OperatorKind::Sql,
    OperatorKind::Sstl,
    OperatorKind::Cotan,
];

#[test]
fn the_exactly_symmetric_kinds_are_the_ones_the_library_names() {
    for kind in OperatorKind::ALL {
        assert_eq!(
            kind.is_symmetric(),
            EXACTLY_SYMMETRIC.contains(&kind),
            "{kind}"
        );
    }
}

fn max_abs_row_sum(m: &SparseMatrix) -> f64 {
    let mut rs = vec![0.0; m.nrows()];
    for j in 0..m.ncols() {
        for (&i, &v) in m.row_idx_of_col_raw(j).iter().zip(m.val_of_col(j)) {
            rs[i] += v;
        }
    }
    rs.iter().fold(0.0f64, |a, &b| a.max(b.abs()))
}

fn negative_sql_edges(path: &str) -> usize {
    let input = load(path);
    let d: Vec<f64> = input.topology.degrees().iter().map(|&x| x as f64).collect();
    sql_edge_weights(&input.topology, &d)
        .unwrap()
        .iter()
        .filter(|&&w| w < 0.0)
        .count()
}

#[test]
fn zero_row_sums_and_symmetry_on_every_test_mesh() {
    for (name, mesh, topo) in manifold_meshes() {
        for kind in [
            OperatorKind::Kirchhoff,
            OperatorKind::Tutte,
            OperatorKind::Sql,
            OperatorKind::Sstl,
            OperatorKind::Tutte2,
            OperatorKind::Sdl,
            OperatorKind::MeanValue,
        ] {
            let op = Operator::assemble(kind, &mesh, &topo, &OperatorOptions::default()).unwrap();
            let rs = max_abs_row_sum(&op.matrix);
            assert!(rs <= 1e-12, "{name} {kind}: row sum {rs}");
        }
        for kind in EXACTLY_SYMMETRIC {
            let op = Operator::assemble(kind, &mesh, &topo, &OperatorOptions::default()).unwrap();
            // KL, GL and SQL are symmetric by construction; the SSTL sums TᵀT in a
            // symmetric order; the cotan writes both entries of an edge from its
            // one weight: all five exactly.
            assert!(asymmetry(&op.matrix) == 0.0, "{name} {kind}");
        }
    }
}

/// The same invariants on the paper's large models (read from the shared folder),
/// which have boundary holes (bunny) and up to 134K vertices (Igea).
#[test]
fn zero_row_sums_and_exact_symmetry_on_the_large_shared_meshes() {
    for name in ["stanford-bunny.obj", "horse.ply", "igea.ply"] {
        let input = load(&shared(name));
        let (mesh, topo) = (&input.mesh, &input.topology);
        let assemble = |kind| {
            Operator::assemble(kind, mesh, topo, &OperatorOptions::default())
                .unwrap()
                .matrix
        };
        for kind in [
            OperatorKind::Kirchhoff,
            OperatorKind::Tutte,
            OperatorKind::Sql,
            OperatorKind::Sstl,
        ] {
            let rs = max_abs_row_sum(&assemble(kind));
            assert!(rs <= 1e-12, "{name} {kind}: row sum {rs}");
        }
        for kind in EXACTLY_SYMMETRIC {
            assert!(asymmetry(&assemble(kind)) == 0.0, "{name} {kind}");
        }
    }
}

#[test]
fn printed_sql_boundary_diagonal_breaks_row_sums_as_documented() {
    for (path, expected) in [
        (data("teapot.obj"), 0.73),
        (shared("stanford-bunny.obj"), 0.46),
    ] {
        let input = load(&path);
        let printed = sql(&input.topology, BoundaryDiagonal::AsPrinted).unwrap();
        let rs = max_abs_row_sum(&printed);
        assert!(
            (rs - expected).abs() < 0.01,
            "{path}: printed sign row sum {rs}"
        );
        let fixed = sql(&input.topology, BoundaryDiagonal::ZeroRowSum).unwrap();
        assert!(max_abs_row_sum(&fixed) <= 1e-12, "{path}");
    }
}

#[test]
fn sql_negative_weight_counts() {
    assert_eq!(negative_sql_edges(&data("cow.obj")), 7);
    assert_eq!(negative_sql_edges(&data("teapot.obj")), 16);
    assert_eq!(negative_sql_edges(&shared("horse.ply")), 13);
}

#[test]
fn repair_sql_removes_every_negative_weight_of_the_cow() {
    let input = load(&data("cow.obj"));
    let (fixed, report) = repair_sql(&input.mesh, &RepairOptions::default()).unwrap();
    assert_eq!(report.negative_before, 7);
    assert_eq!(report.negative_after, 0, "{report:?}");
    let t = meshlap::mesh::topology::Topology::new(&fixed).unwrap();
    // The cow has one pinch vertex (two fans meeting at vertex 253); flips must not add
    // any non-manifold edge or vertex.
    assert_eq!(t.non_manifold_edges().count(), 0);
    assert_eq!(
        t.non_manifold_vertices().count(),
        input.topology.non_manifold_vertices().count()
    );
    let s = sql(&t, BoundaryDiagonal::ZeroRowSum).unwrap();
    let r = analyze(&s, &PropertyOptions::default());
    assert_eq!(r.negative_weights, 0);
    assert!(r.gsml.is_gsml, "{:?}", r.gsml);
    assert!(r.smoothing.doubly_stochastic);
}

/// With a fold-over/dihedral limit of 30°, edge swapping leaves a negative weight on
/// the cow; adding the vertex split removes it, and the result is still a manifold,
/// consistently oriented mesh with non-degenerate faces and the same Euler
/// characteristic.
#[test]
fn vertex_split_finishes_what_constrained_swapping_leaves_on_the_cow() {
    let input = load(&data("cow.obj"));
    let chi = |t: &meshlap::mesh::topology::Topology| {
        t.n_vertices() as i64 - t.n_edges() as i64 + t.n_faces() as i64
    };
    let opts = |method| RepairOptions {
        max_dihedral_degrees: Some(30.0),
        method,
        ..Default::default()
    };
    let (_, swap) = repair_sql(&input.mesh, &opts(RepairMethod::Swap)).unwrap();
    assert!(swap.negative_after > 0, "{swap:?}");
    let (fixed, both) = repair_sql(&input.mesh, &opts(RepairMethod::SwapSplit)).unwrap();
    assert_eq!(both.negative_after, 0, "{both:?}");
    assert!(both.splits > 0);
    assert_eq!(
        fixed.n_vertices(),
        input.mesh.n_vertices() + both.vertices_added
    );
    let t = meshlap::mesh::topology::Topology::new(&fixed).unwrap();
    assert_eq!(t.non_manifold_edges().count(), 0);
    assert_eq!(t.inconsistently_oriented_edges(), 0);
    assert_eq!(chi(&t), chi(&input.topology));
    assert_eq!(meshlap::mesh::clean::zero_area_faces(&fixed), 0);
    let s = sql(&t, BoundaryDiagonal::ZeroRowSum).unwrap();
    let d: Vec<f64> = t.degrees().iter().map(|&x| x as f64).collect();
    assert!(sql_edge_weights(&t, &d).unwrap().iter().all(|&w| w >= 0.0));
    assert!(max_abs_row_sum(&s) <= 1e-12);
}

#[test]
fn zero_eigenvalue_multiplicity_equals_components_on_the_teapot() {
    let input = load(&data("teapot.obj"));
    let (_, components) = input.topology.components();
    assert_eq!(components, 4);
    // One dense eigensolve of the 3644×3644 Kirchhoff matrix (the SQL's analysis is
    // the same code path; a second 3644² eigensolve doubled this test's minute).
    let op = Operator::assemble(
        OperatorKind::Kirchhoff,
        &input.mesh,
        &input.topology,
        &OperatorOptions::default(),
    )
    .unwrap();
    let r = analyze(&op.matrix, &PropertyOptions::default());
    assert_eq!(r.zero_eigenvalue_multiplicity, Some(components));
    assert_eq!(r.pattern_components, components);
}

#[test]
fn gershgorin_bounds_hold_on_woody() {
    // woody.obj (694 vertices, open): every kind's full dense spectrum is cheap; on
    // the cow (2903) nine dense eigensolves took about a minute of CPU.
    let input = load(&data("woody.obj"));
    for kind in OperatorKind::ALL {
        let op = Operator::on_input(kind, &input).unwrap();
        let r = analyze(&op.matrix, &PropertyOptions::default());
        assert!(r.lambda_max.is_some(), "{kind}: spectrum not computed");
        assert_eq!(r.gershgorin_holds, Some(true), "{kind}");
    }
}

#[test]
fn sql_refuses_the_non_manifold_beetle_by_name() {
    let input = load(&data("beetle.obj"));
    let err = sql(&input.topology, BoundaryDiagonal::ZeroRowSum).unwrap_err();
    assert!(err.to_string().contains("shared by"), "{err}");
}
