//! Operator invariants on the pinned real meshes (closed, with boundary, non-manifold).

mod common;
use common::*;
use meshlap::analysis::properties::{analyze, asymmetry, PropertyOptions};
use meshlap::analysis::repair::{repair_sql, RepairOptions};
use meshlap::operator::sql::{sql, sql_edge_weights, BoundaryDiagonal};
use meshlap::operator::{Operator, OperatorKind, OperatorOptions};
use meshlap::SparseMatrix;

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
        for kind in [
            OperatorKind::Kirchhoff,
            OperatorKind::Graph,
            OperatorKind::Sql,
            OperatorKind::Sstl,
        ] {
            let op = Operator::assemble(kind, &mesh, &topo, &OperatorOptions::default()).unwrap();
            // KL, GL and SQL are symmetric by construction (exactly); TᵀT up to rounding.
            let tol = if kind == OperatorKind::Sstl {
                1e-15
            } else {
                0.0
            };
            assert!(asymmetry(&op.matrix) <= tol, "{name} {kind}");
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

#[test]
fn zero_eigenvalue_multiplicity_equals_components_on_the_teapot() {
    let input = load(&data("teapot.obj"));
    let (_, components) = input.topology.components();
    assert_eq!(components, 4);
    for kind in [OperatorKind::Kirchhoff, OperatorKind::Sql] {
        let op = Operator::assemble(
            kind,
            &input.mesh,
            &input.topology,
            &OperatorOptions::default(),
        )
        .unwrap();
        let r = analyze(&op.matrix, &PropertyOptions::default());
        assert_eq!(r.zero_eigenvalue_multiplicity, Some(components), "{kind}");
        assert_eq!(r.pattern_components, components);
    }
}

#[test]
fn gershgorin_bounds_hold_on_the_cow() {
    let input = load(&data("cow.obj"));
    for kind in OperatorKind::ALL {
        let op = Operator::assemble(
            kind,
            &input.mesh,
            &input.topology,
            &OperatorOptions::default(),
        )
        .unwrap();
        let r = analyze(&op.matrix, &PropertyOptions::default());
        if r.lambda_max.is_some() {
            assert_eq!(r.gershgorin_holds, Some(true), "{kind}");
        }
    }
}

#[test]
fn sql_refuses_the_non_manifold_beetle_by_name() {
    let input = load(&data("beetle.obj"));
    let err = sql(&input.topology, BoundaryDiagonal::ZeroRowSum).unwrap_err();
    assert!(err.to_string().contains("shared by"), "{err}");
}
