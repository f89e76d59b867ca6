//! Implicit fairing on real and bunny-sized meshes (issue 5): every iterative solver
//! agrees with the direct solution under the strong criterion ε = 1e-10; CG on the SQL
//! and BiCG on the TL need iteration counts of the same order (Zhang 2004, Table 1).

mod common;

use common::{data, load, shared};
use meshlap::filter::{ImplicitSolver, SolverKind};
use meshlap::operator::{sql::sql, tutte::tutte};
use meshlap::solve::{Params, Stopping};
use meshlap::SparseMatrix;

fn strong() -> Params {
    Params {
        stopping: Stopping::Strong,
        tolerance: 1e-10,
        ..Default::default()
    }
}

fn solve(f: &SparseMatrix, kind: SolverKind, b: &[f64], p: &Params) -> (Vec<f64>, usize) {
    let mut s = ImplicitSolver::new(f, 30.0, kind).unwrap_or_else(|e| panic!("{kind}: {e}"));
    let mut x = b.to_vec();
    let info = s
        .solve(b, &mut x, p)
        .unwrap_or_else(|e| panic!("{kind}: {e}"));
    if !kind.is_direct() && p.stopping == Stopping::Strong {
        assert!(
            info.residuals().iter().all(|&r| r < 1e-9),
            "{kind}: {:?}",
            info.residuals()
        );
    }
    (x, *info.iterations().iter().max().unwrap())
}

/// Largest vertex distance between two n×3 blocks.
fn max_dist(a: &[f64], b: &[f64]) -> f64 {
    a.chunks_exact(3)
        .zip(b.chunks_exact(3))
        .map(|(p, q)| (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>().sqrt())
        .fold(0.0, f64::max)
}

fn check_agreement(mesh: &meshlap::TriMesh, topo: &meshlap::mesh::topology::Topology) {
    let b: Vec<f64> = mesh.positions.iter().flat_map(|p| *p).collect();
    let scale = mesh.bbox_diagonal();
    let s = sql(topo, Default::default()).unwrap();
    let (want, _) = solve(&s, SolverKind::Cholesky, &b, &strong());
    for kind in [SolverKind::Cg, SolverKind::Pcg, SolverKind::Lu] {
        let (x, _) = solve(&s, kind, &b, &strong());
        let e = max_dist(&x, &want) / scale;
        assert!(e < 1e-8, "SQL {kind}: {e}");
    }
    let t = tutte(topo).unwrap();
    let (want, _) = solve(&t, SolverKind::Lu, &b, &strong());
    for kind in [SolverKind::Bicg, SolverKind::CgSym, SolverKind::Bicgstab] {
        let (x, _) = solve(&t, kind, &b, &strong());
        let e = max_dist(&x, &want) / scale;
        assert!(e < 1e-8, "TL {kind}: {e}");
    }
}

#[test]
fn iterative_solvers_agree_with_direct_on_the_cow() {
    let input = load(&data("cow.obj"));
    check_agreement(&input.mesh, &input.topology);
}

#[test]
fn iterative_solvers_agree_with_direct_on_a_bunny_sized_mesh() {
    // builtin:icosphere:6 has 40,962 vertices (the bunny has 34,834), perturbed so that
    // fairing has noise to remove.
    let input = load("builtin:icosphere:6");
    let mut mesh = input.mesh.clone();
    assert!(mesh.n_vertices() > 40_000);
    for (i, p) in mesh.positions.iter_mut().enumerate() {
        let s = 1.0 + 0.02 * ((i * 7919) % 17) as f64 / 17.0;
        *p = p.map(|c| c * s);
    }
    check_agreement(&mesh, &input.topology);
}

#[test]
fn cg_on_sql_and_bicg_on_tl_need_iterations_of_the_same_order() {
    let input = load(&data("cow.obj"));
    let b: Vec<f64> = input.mesh.positions.iter().flat_map(|p| *p).collect();
    let weak = Params::default();
    let s = sql(&input.topology, Default::default()).unwrap();
    let t = tutte(&input.topology).unwrap();
    let (_, cg) = solve(&s, SolverKind::Cg, &b, &weak);
    let (_, bicg) = solve(&t, SolverKind::Bicg, &b, &weak);
    let (_, cg_tl) = solve(&t, SolverKind::CgSym, &b, &weak);
    let ratio = cg as f64 / bicg as f64;
    assert!((0.5..=2.0).contains(&ratio), "CG {cg} vs BiCG {bicg}");
    // The symmetrised TL converges more slowly than BiCG on the TL (the paper's
    // observation, 37 vs 15 iterations on its cow).
    assert!(cg_tl >= bicg, "CG (TL) {cg_tl} vs BiCG {bicg}");
}

#[test]
fn bicgstab_honours_the_stopping_rule_on_the_cow_and_the_bunny() {
    for path in [data("cow.obj"), shared("stanford-bunny.obj")] {
        let name = &path;
        let input = load(&path);
        let b: Vec<f64> = input.mesh.positions.iter().flat_map(|p| *p).collect();
        let t = tutte(&input.topology).unwrap();
        let mut solver = ImplicitSolver::new(&t, 30.0, SolverKind::Bicgstab).unwrap();
        let mut run = |stopping| {
            let mut x = b.clone();
            let p = Params {
                stopping,
                ..Default::default()
            };
            solver.solve(&b, &mut x, &p).unwrap()
        };
        let strong = run(Stopping::Strong);
        // Every column meets ε = 1e-5 on its own (faer's BiCGSTAB, used before, tested
        // the norm of the whole block and left columns above ε).
        assert!(
            strong.residuals().iter().all(|&r| r < 1e-5),
            "{name}: {:?}",
            strong.residuals()
        );
        let weak = run(Stopping::Weak);
        let most = |i: &[usize]| *i.iter().max().unwrap();
        assert!(
            most(weak.iterations()) <= most(strong.iterations()),
            "{name}"
        );
        let vertex = run(Stopping::WeakVertex);
        let its = vertex.iterations();
        assert!(its.iter().all(|&i| i == its[0]), "{name}: {its:?}");
    }
}

#[test]
fn direct_solvers_report_their_factorization_on_the_cow() {
    let input = load(&data("cow.obj"));
    let b: Vec<f64> = input.mesh.positions.iter().flat_map(|p| *p).collect();
    let s = sql(&input.topology, Default::default()).unwrap();
    for kind in [SolverKind::Cholesky, SolverKind::Lu] {
        let mut solver = ImplicitSolver::new(&s, 30.0, kind).unwrap();
        let before = solver.factorization().expect("a direct kind");
        let mut x = b.clone();
        let info = solver.solve(&b, &mut x, &Params::default()).unwrap();
        let f = info.factorization().expect("a direct solve");
        assert_eq!(f.matrix_nnz, solver.system_matrix().nnz());
        assert_eq!(f.numeric_seconds, before.numeric_seconds);
        assert_eq!(f.factor_nnz.is_some(), kind == SolverKind::Cholesky);
        if let Some(fill) = f.factor_nnz {
            // L at least holds the lower triangle of I + λS.
            assert!(fill >= (f.matrix_nnz + 2903) / 2, "{fill}");
        }
        assert!(info.residuals().iter().all(|&r| r < 1e-12));
    }
}
