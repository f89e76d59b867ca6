//! Blocked conjugate gradients, optionally Jacobi-preconditioned (Hestenes & Stiefel
//! 1952; Barrett et al. 1994, *Templates*, Fig. 2.5), for symmetric positive definite
//! systems such as `(I + λS)x = b` with the SQL, KL or SSTL, and the symmetrized Tutte
//! system `(D + λK)x = Db` (the paper's "CG (TL)").
//!
//! The k right-hand sides (n×k row-major) share every sparse product; each column has
//! its own α, β and stops on its own. One iteration is one fused product-and-dot
//! (`q = Bp`, `pᵀq`), one fused pass updating x and r and accumulating every norm the
//! stopping test needs, and one pass updating p: the fewest passes over memory, since
//! an iteration is bound by memory bandwidth. With the residual criterion
//! ([`Stopping::Strong`]) the stopping test needs no norm of x, so x moves in the p
//! pass instead (`x += αp` with the old p, read there anyway): the update pass then
//! reads r and q and writes r, one n×k block fewer per iteration (10 blocks plus the
//! matrix instead of 11), and x gets the same bits. Before the first iteration one pass
//! ([`LinOp::residual`]) forms `r = b − Bx`, `p = M⁻¹r` and every norm the iteration
//! starts from; after the last, one pass into a spent work block recomputes the
//! residuals reported.

use super::krylov::{self, with_columns, Criterion, Sums};
use super::{
    csr::CHUNK, Fused, Info, InputError, Jacobi, LinOp, Params, Stopping, Workspace, MAX_COLUMNS,
};
use crate::par::FoldInOrder;
use rayon::prelude::*;
use std::time::Instant;

/// Why [`cg()`] failed.
#[derive(Debug, thiserror::Error)]
pub enum CgError {
    /// A search direction with non-positive curvature `pᵀBp ≤ 0`: B is not positive
    /// definite. For `I + λS` with the SQL, negative weights (Zhang 2004 §3.7) cause
    /// this; remove them (`analysis::repair`) or use a solver for indefinite or
    /// non-symmetric systems (BiCG, LU).
    #[error("the system matrix is not positive definite (curvature pᵀBp ≤ 0 at iteration {iteration}, column {column})")]
    NotPositiveDefinite {
        /// Iteration.
        iteration: usize,
        /// Column.
        column: usize,
    },
    /// A diagonal entry ≤ 0 under Jacobi preconditioning: B is not positive definite.
    #[error("the system matrix is not positive definite (diagonal entry {row} is {value})")]
    NonPositiveDiagonal {
        /// Row.
        row: usize,
        /// The entry.
        value: f64,
    },
    /// The iteration cap was reached; raise [`Params::max_iterations`] or the
    /// tolerance.
    #[error("no convergence within {} iterations (relative residuals {:?})", .info.iterations.iter().max().unwrap_or(&0), .info.residuals)]
    NoConvergence {
        /// What was done.
        info: Box<Info>,
    },
    /// The arguments are unusable.
    #[error(transparent)]
    Input(#[from] InputError),
}

// Indices of the per-column sums of the update pass.
const RR: usize = 0;
const RZ: usize = 1;
const PP: usize = 2;
const XX: usize = 3;

/// Solves `B x = b` for the n×k row-major block `b` (k ≤ [`MAX_COLUMNS`]), starting
/// from and overwriting `x`, with B symmetric positive definite given as a [`LinOp`]
/// (n×n). `precond`: none, or Jacobi. `ws` keeps the three n×k work blocks between
/// calls.
pub fn cg(
    op: &dyn LinOp,
    b: &[f64],
    x: &mut [f64],
    k: usize,
    params: &Params,
    precond: Option<&Jacobi>,
    ws: &mut Workspace,
) -> Result<Info, CgError> {
    // The time includes the hand-over to the pool.
    let start = Instant::now();
    // The residual criterion reads no norm of x: x can move in the p pass.
    let defer_x = params.stopping == Stopping::Strong;
    crate::par::on_worker(|| cg_on_worker(start, op, b, x, k, params, precond, ws, defer_x))
}

/// [`cg()`] on a worker of rayon's pool, timed from `start`. `defer_x`: x moves in the
/// p pass (only valid when the stopping test reads no norm of x).
#[allow(clippy::too_many_arguments)]
fn cg_on_worker(
    start: Instant,
    op: &dyn LinOp,
    b: &[f64],
    x: &mut [f64],
    k: usize,
    params: &Params,
    precond: Option<&Jacobi>,
    ws: &mut Workspace,
    defer_x: bool,
) -> Result<Info, CgError> {
    debug_assert!(!defer_x || params.stopping == Stopping::Strong);
    krylov::check(op, b, x, k, params)?;
    let n = op.dim();
    let dinv = match precond {
        None => None,
        Some(j) => {
            j.check(n)?;
            if let Some(row) = j.diagonal().iter().position(|&v| v <= 0.0) {
                return Err(CgError::NonPositiveDiagonal {
                    row,
                    value: j.diagonal()[row],
                });
            }
            Some(j.inverse())
        }
    };
    let [r, p, q] = ws.blocks::<3>(n * k);
    // r = b − Bx, p = M⁻¹r, ‖r‖², rᵀM⁻¹r and ‖b‖² per column: one pass.
    let s0 = op.residual(b, x, r, k, dinv, Some(p))?;
    let mut rz = s0.rz[..k].to_vec();
    let bnorm = krylov::norms_of_b(&s0, k);
    let mut active = krylov::all_active(k);
    let mut info = Info::new(k);
    let rr0 = s0.rr;
    for c in 0..k {
        if rr0[c] == 0.0 {
            active[c] = false;
        }
        if params.record_history {
            info.history[c].push(rr0[c].sqrt() / bnorm[c]);
        }
    }
    let crit = Criterion::new(params);
    let (mut pq, mut qq) = ([0.0; MAX_COLUMNS], [0.0; MAX_COLUMNS]);
    let mut it = 0;
    while active.iter().any(|&a| a) {
        if it >= params.max_iterations {
            krylov::finish(&mut info, op, x, b, k, start, q)?;
            return Err(CgError::NoConvergence {
                info: Box::new(info),
            });
        }
        it += 1;
        op.apply_fused(p, q, k, Fused::new(p, &mut pq, &mut qq));
        let mut alpha = [0.0f64; MAX_COLUMNS];
        for c in krylov::live(active) {
            if pq[c] <= 0.0 || pq[c].is_nan() {
                if rz[c] == 0.0 {
                    active[c] = false;
                    info.iterations[c] = it - 1;
                    continue;
                }
                return Err(CgError::NotPositiveDefinite {
                    iteration: it,
                    column: c,
                });
            }
            alpha[c] = rz[c] / pq[c];
        }
        let sums = if defer_x {
            // r −= αq with ‖r‖² and rᵀM⁻¹r; x moves in the p pass below.
            r.par_chunks_mut(CHUNK * k)
                .zip(q.par_chunks(CHUNK * k))
                .enumerate()
                .map(|(blk, (rs, qs))| {
                    with_columns!(k, K => {
                        let mut s = Sums::<4>::default();
                        for row in 0..rs.len() / K {
                            let di = dinv.map_or(1.0, |d| d[blk * CHUNK + row]);
                            for c in 0..K {
                                let j = row * K + c;
                                rs[j] -= alpha[c] * qs[j];
                                s.v[RR][c] += rs[j] * rs[j];
                                s.v[RZ][c] += rs[j] * rs[j] * di;
                            }
                        }
                        s
                    })
                })
                .fold_in_order(Sums::default(), Sums::add)
        } else {
            x.par_chunks_mut(CHUNK * k)
                .zip(r.par_chunks_mut(CHUNK * k))
                .zip(p.par_chunks(CHUNK * k).zip(q.par_chunks(CHUNK * k)))
                .enumerate()
                .map(|(blk, ((xs, rs), (ps, qs)))| {
                    with_columns!(k, K => {
                        let mut s = Sums::<4>::default();
                        for row in 0..xs.len() / K {
                            let (mut dx2, mut x2) = (0.0, 0.0);
                            let di = dinv.map_or(1.0, |d| d[blk * CHUNK + row]);
                            for c in 0..K {
                                let j = row * K + c;
                                let dx = alpha[c] * ps[j];
                                krylov::advance(&mut xs[j], dx, &mut s.v[XX][c], &mut x2, &mut dx2);
                                rs[j] -= alpha[c] * qs[j];
                                s.v[RR][c] += rs[j] * rs[j];
                                s.v[RZ][c] += rs[j] * rs[j] * di;
                                s.v[PP][c] += ps[j] * ps[j];
                            }
                            s.moving += crit.moving(dx2, x2);
                        }
                        s
                    })
                })
                .fold_in_order(Sums::default(), Sums::add)
        };
        let mut beta = [0.0f64; MAX_COLUMNS];
        for c in krylov::live(active) {
            info.iterations[c] = it;
            let rr = sums.v[RR][c];
            if params.record_history {
                info.history[c].push(rr.sqrt() / bnorm[c]);
            }
            let step2 = alpha[c] * alpha[c] * sums.v[PP][c];
            if crit.done(step2, sums.v[XX][c], sums.moving, rr, bnorm[c]) || rr == 0.0 {
                active[c] = false;
                continue;
            }
            beta[c] = sums.v[RZ][c] / rz[c];
            rz[c] = sums.v[RZ][c];
        }
        if defer_x {
            // x += αp (every column, α = 0 where a column did not step, as the update
            // pass does otherwise), then p = M⁻¹r + βp for the active columns.
            p.par_chunks_mut(CHUNK * k)
                .zip(r.par_chunks(CHUNK * k).zip(x.par_chunks_mut(CHUNK * k)))
                .enumerate()
                .for_each(|(blk, (ps, (rs, xs)))| {
                    with_columns!(k, K => {
                        for row in 0..ps.len() / K {
                            let di = dinv.map_or(1.0, |d| d[blk * CHUNK + row]);
                            for c in 0..K {
                                let j = row * K + c;
                                xs[j] += alpha[c] * ps[j];
                                if active[c] {
                                    ps[j] = rs[j] * di + beta[c] * ps[j];
                                }
                            }
                        }
                    })
                });
            continue;
        }
        p.par_chunks_mut(CHUNK * k)
            .zip(r.par_chunks(CHUNK * k))
            .enumerate()
            .for_each(|(blk, (ps, rs))| {
                with_columns!(k, K => {
                    for row in 0..ps.len() / K {
                        let di = dinv.map_or(1.0, |d| d[blk * CHUNK + row]);
                        for c in 0..K {
                            if active[c] {
                                let j = row * K + c;
                                ps[j] = rs[j] * di + beta[c] * ps[j];
                            }
                        }
                    }
                })
            });
    }
    krylov::finish(&mut info, op, x, b, k, start, q)?;
    Ok(info)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solve::{
        direct::CholeskySolver, shifted_system, test_util::*, CsrMatrix, LinOp, Stopping,
    };

    fn direct(a: &CsrMatrix, b: &[f64], k: usize) -> Vec<f64> {
        let mut x = b.to_vec();
        CholeskySolver::new(&a.to_csc())
            .unwrap()
            .solve_in_place(&mut x, k)
            .unwrap();
        x
    }

    #[test]
    fn agrees_with_cholesky_strong() {
        let (m, _, sql, ..) = irregular(3);
        let a = shifted_system(&sql, None, 30.0);
        let b = flat(&m);
        let want = direct(&a, &b, 3);
        let jacobi = Jacobi::new(&a).unwrap();
        for pre in [None, Some(&jacobi)] {
            let mut x = b.clone();
            let params = Params {
                stopping: Stopping::Strong,
                tolerance: 1e-10,
                ..Default::default()
            };
            let info = cg(&a, &b, &mut x, 3, &params, pre, &mut Workspace::new()).unwrap();
            assert!(
                info.residuals.iter().all(|&r| r < 1e-9),
                "{:?}",
                info.residuals
            );
            let err = max_diff(&x, &want);
            assert!(err < 1e-8, "{}: {err}", pre.is_some());
        }
    }

    #[test]
    fn blocked_equals_single_columns() {
        let (m, _, sql, ..) = irregular(2);
        let a = shifted_system(&sql, None, 10.0);
        let b = flat(&m);
        let params = Params {
            stopping: Stopping::Strong,
            tolerance: 1e-12,
            ..Default::default()
        };
        let mut x = b.clone();
        let info = cg(&a, &b, &mut x, 3, &params, None, &mut Workspace::new()).unwrap();
        for c in 0..3 {
            let bc: Vec<f64> = (0..m.n_vertices()).map(|i| b[3 * i + c]).collect();
            let mut xc = bc.clone();
            let ic = cg(&a, &bc, &mut xc, 1, &params, None, &mut Workspace::new()).unwrap();
            assert_eq!(ic.iterations[0], info.iterations[c]);
            for i in 0..m.n_vertices() {
                assert!((xc[i] - x[3 * i + c]).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn weak_stops_earlier_than_strong() {
        let (m, _, sql, ..) = irregular(5);
        let a = shifted_system(&sql, None, 30.0);
        let b = flat(&m);
        let solve = |stopping| {
            let mut x = b.clone();
            let p = Params {
                stopping,
                ..Default::default()
            };
            cg(&a, &b, &mut x, 3, &p, None, &mut Workspace::new()).unwrap()
        };
        let (w, wv, s) = (
            solve(Stopping::Weak),
            solve(Stopping::WeakVertex),
            solve(Stopping::Strong),
        );
        let max = |i: &Info| *i.iterations.iter().max().unwrap();
        assert!(max(&w) < max(&s), "{:?} {:?}", w.iterations, s.iterations);
        assert!(max(&w) <= max(&wv));
        assert!(wv.iterations.iter().all(|&i| i == wv.iterations[0]));
    }

    #[test]
    fn indefinite_matrix_is_reported() {
        // diag(1, -1, 1, ...) is symmetric indefinite.
        let d: Vec<f64> = (0..50)
            .map(|i| if i == 7 { -1.0 } else { 1.0 + i as f64 })
            .collect();
        let a = diagonal(&d);
        let b = vec![1.0; 50];
        let mut x = vec![0.0; 50];
        let e = cg(
            &a,
            &b,
            &mut x,
            1,
            &Params::default(),
            None,
            &mut Workspace::new(),
        )
        .unwrap_err();
        assert!(matches!(e, CgError::NotPositiveDefinite { .. }), "{e}");
        // Jacobi sees the negative diagonal before iterating.
        let j = Jacobi::new(&a).unwrap();
        let e = cg(
            &a,
            &b,
            &mut x,
            1,
            &Params::default(),
            Some(&j),
            &mut Workspace::new(),
        )
        .unwrap_err();
        assert!(
            matches!(e, CgError::NonPositiveDiagonal { row: 7, .. }),
            "{e}"
        );
    }

    #[test]
    fn iteration_cap_is_no_convergence() {
        let (m, _, sql, ..) = irregular(3);
        let a = shifted_system(&sql, None, 100.0);
        let b = flat(&m);
        let mut x = vec![0.0; b.len()];
        let p = Params {
            max_iterations: 2,
            stopping: Stopping::Strong,
            tolerance: 1e-14,
            ..Default::default()
        };
        match cg(&a, &b, &mut x, 3, &p, None, &mut Workspace::new()) {
            Err(CgError::NoConvergence { info }) => assert_eq!(info.iterations, vec![2, 2, 2]),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn bad_arguments_are_input_errors() {
        let (m, _, sql, ..) = irregular(1);
        let a = shifted_system(&sql, None, 1.0);
        let b = flat(&m);
        let fails = |b: &[f64], x: &mut [f64], p: &Params, pre: Option<&Jacobi>| match cg(
            &a,
            b,
            x,
            3,
            p,
            pre,
            &mut Workspace::new(),
        ) {
            Err(CgError::Input(e)) => e,
            other => panic!("{other:?}"),
        };
        let p = Params::default();
        let mut x = b.clone();
        let e = fails(&b, &mut x[1..], &p, None);
        assert!(matches!(e, InputError::InitialGuess { .. }));
        let e = fails(&b[1..], &mut x[1..], &p, None);
        assert!(matches!(e, InputError::RightHandSide { .. }));
        let zero_tol = Params {
            tolerance: 0.0,
            ..Default::default()
        };
        let e = fails(&b, &mut x, &zero_tol, None);
        assert!(matches!(e, InputError::Tolerance(_)));
        let wrong = Jacobi::from_diagonal(vec![1.0; 3]).unwrap();
        let e = fails(&b, &mut x, &p, Some(&wrong));
        assert!(matches!(e, InputError::Preconditioner { .. }));
    }

    #[test]
    fn the_fused_matrix_kernels_iterate_as_the_generic_operator() {
        // The CSR kernels (one-pass residual, fused product) against the trait's
        // default passes over the same matrix: the same iterations and the same
        // solution up to the rounding of the per-column sums.
        let (m, _, sql, ..) = irregular(5);
        let a = shifted_system(&sql, None, 30.0);
        let generic = crate::solve::FnOperator {
            dim: a.nrows(),
            apply: |x: &[f64], y: &mut [f64], k| a.apply(x, y, k),
        };
        let b = flat(&m);
        let jacobi = Jacobi::new(&a).unwrap();
        for pre in [None, Some(&jacobi)] {
            for stopping in [Stopping::Weak, Stopping::Strong] {
                let p = Params {
                    stopping,
                    ..Default::default()
                };
                let (mut x1, mut x2) = (b.clone(), b.clone());
                let i1 = cg(&a, &b, &mut x1, 3, &p, pre, &mut Workspace::new()).unwrap();
                let i2 = cg(&generic, &b, &mut x2, 3, &p, pre, &mut Workspace::new()).unwrap();
                assert_eq!(i1.iterations, i2.iterations);
                assert!(max_diff(&x1, &x2) < 1e-10, "{}", max_diff(&x1, &x2));
                for c in 0..3 {
                    assert!((i1.residuals[c] - i2.residuals[c]).abs() < 1e-9 * i1.residuals[c]);
                }
            }
        }
    }

    #[test]
    fn a_reused_workspace_gives_the_same_answer() {
        let (m, _, sql, ..) = irregular(3);
        let a = shifted_system(&sql, None, 30.0);
        let b = flat(&m);
        let p = Params::default();
        let mut ws = Workspace::new();
        let mut runs = Vec::new();
        for _ in 0..2 {
            let mut x = b.clone();
            let info = cg(&a, &b, &mut x, 3, &p, None, &mut ws).unwrap();
            runs.push((x, info.iterations, info.history));
        }
        assert_eq!(runs[0], runs[1]);
    }

    #[test]
    fn x_moved_in_the_p_pass_has_the_same_bits() {
        // The residual criterion moves x in the p pass; the other criteria in the update
        // pass. Forced both ways on the same strong-criterion solves: the same x, bit
        // for bit, the same iterations and residual histories, with columns that stop
        // at different iterations (a zero column stops before the first), with and
        // without Jacobi, and on hitting the iteration cap.
        let (m, _, sql, ..) = irregular(3);
        let a = shifted_system(&sql, None, 30.0);
        let mut b = flat(&m);
        for (i, v) in b.iter_mut().enumerate() {
            match i % 3 {
                1 => *v *= 1e-3 * (1.0 + (i as f64).sin()),
                2 => *v = 0.0,
                _ => {}
            }
        }
        let jacobi = Jacobi::new(&a).unwrap();
        for (pre, cap) in [(None, 1000), (Some(&jacobi), 1000), (None, 4)] {
            let params = Params {
                stopping: Stopping::Strong,
                tolerance: 1e-9,
                max_iterations: cap,
                record_history: true,
            };
            let run = |defer: bool| {
                let mut x: Vec<f64> = b.iter().map(|v| 0.5 * v).collect();
                let r = cg_on_worker(
                    Instant::now(),
                    &a,
                    &b,
                    &mut x,
                    3,
                    &params,
                    pre,
                    &mut Workspace::new(),
                    defer,
                );
                let info = match r {
                    Ok(info) => info,
                    Err(CgError::NoConvergence { info }) => *info,
                    Err(e) => panic!("{e}"),
                };
                let bits: Vec<u64> = x.iter().map(|v| v.to_bits()).collect();
                (bits, info.iterations, info.history, info.residuals)
            };
            let (moved, kept) = (run(true), run(false));
            assert_eq!(moved, kept);
            let its = &moved.1;
            assert!(its[2] == 0 && its[0] > 0 && its[1] > 0, "{its:?}");
        }
    }

    #[test]
    fn the_same_bits_on_every_run_and_thread_count() {
        // Enough rows for many parallel chunks: every pass's sums are folded in chunk
        // order (`par::FoldInOrder`), so α, β and x do not depend on how rayon split
        // the work.
        let m = crate::mesh::builtin::icosphere(6).unwrap();
        let t = crate::mesh::topology::Topology::new(&m).unwrap();
        let sql = crate::operator::sql::sql(&t, Default::default()).unwrap();
        let a = shifted_system(&sql, None, 30.0);
        assert!(a.nrows() > 8 * crate::solve::csr::CHUNK);
        let b = flat(&m);
        let params = Params {
            stopping: Stopping::Strong,
            tolerance: 1e-8,
            ..Default::default()
        };
        let solve = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let mut x = b.clone();
                let info = cg(&a, &b, &mut x, 3, &params, None, &mut Workspace::new()).unwrap();
                let bits: Vec<u64> = x.iter().map(|v| v.to_bits()).collect();
                (bits, info.iterations, info.residuals)
            })
        };
        let want = solve(1);
        for threads in [2, 2, 3, 2, 4] {
            let got = solve(threads);
            let first = got.0.iter().zip(&want.0).position(|(a, b)| a != b);
            assert!(
                got == want,
                "{threads} threads: x differs first at {first:?}, iterations {:?} vs {:?}",
                got.1,
                want.1
            );
        }
    }
}
