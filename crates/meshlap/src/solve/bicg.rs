//! Blocked bi-conjugate gradients (Fletcher 1976; Barrett et al. 1994, *Templates*,
//! Fig. 2.8) for non-symmetric systems such as the Tutte system `(I + λT)x = b`.
//!
//! Needs `Aᵀ` ([`LinearOperator::apply_transpose`]); costs two sparse products per
//! iteration, which is why the paper measures CG at 50–60% of BiCG's time. Two failure
//! modes are detected and reported, never hidden:
//!
//! - **breakdown**: `ρ = z̃ᵀr` or `p̃ᵀAp` vanishes (relative to the norms of its
//!   factors, below 1e-15) — [`SolveError::Breakdown`];
//! - **plateau**: the relative residual is above 99% of its value
//!   [`Params::plateau_window`] iterations earlier; the first such iteration is recorded
//!   in [`Info::plateau_at`] (the solve goes on). The paper observed plateaus on Igea
//!   and Isis at λ = 100.

use super::cg::Preconditioner;
use super::{
    check_dims, col_norms2, csr::CHUNK, relative_residuals, Info, LinearOperator, Params,
    SolveError, Stopping,
};
use rayon::prelude::*;
use std::time::Instant;

#[derive(Default, Clone, Copy)]
struct Sums {
    /// ‖r‖² per column.
    rr: [f64; 8],
    /// ρ = r̃ᵀ M⁻¹ r.
    rho: [f64; 8],
    /// ‖M⁻¹ r‖².
    zz: [f64; 8],
    /// ‖r̃‖².
    rtrt: [f64; 8],
    /// ‖x⁽ⁿ⁻¹⁾‖² (weak criterion).
    xx: [f64; 8],
    /// Vertices whose update is not yet below ε (weak-vertex criterion).
    moving: usize,
}

impl Sums {
    fn add(mut self, o: Sums) -> Sums {
        for c in 0..8 {
            self.rr[c] += o.rr[c];
            self.rho[c] += o.rho[c];
            self.zz[c] += o.zz[c];
            self.rtrt[c] += o.rtrt[c];
            self.xx[c] += o.xx[c];
        }
        self.moving += o.moving;
        self
    }
}

/// Solves `A x = b` for the n×k block `b` with BiCG, starting from and overwriting `x`.
///
/// One iteration is four parallel passes over the n×k blocks: the p, p̃ update; the
/// product `q = Ap` fused with `p̃ᵀq` and `‖q‖²`; `q̃ = Aᵀp̃`; and one pass updating x,
/// r, r̃ that also accumulates every norm and the next ρ.
pub fn bicg(
    op: &dyn LinearOperator,
    b: &[f64],
    x: &mut [f64],
    k: usize,
    params: &Params,
    precond: Preconditioner,
) -> Result<Info, SolveError> {
    check_dims(op, b, k)?;
    if x.len() != b.len() {
        return Err(SolveError::Dimension(
            "initial guess and right-hand side differ in size".into(),
        ));
    }
    if k > 8 {
        return Err(SolveError::InvalidParameter(
            "at most 8 right-hand sides at once".into(),
        ));
    }
    let start = Instant::now();
    let n = op.dim();
    let dinv: Option<Vec<f64>> = match precond {
        Preconditioner::None => None,
        Preconditioner::Jacobi => {
            let d = op.diagonal().ok_or(SolveError::Unsupported(
                "Jacobi needs the operator's diagonal",
            ))?;
            if let Some(i) = d.iter().position(|&v| v == 0.0 || v.is_nan()) {
                return Err(SolveError::Breakdown {
                    iteration: 0,
                    column: i,
                    what: "zero diagonal entry (Jacobi preconditioner)",
                });
            }
            Some(d.iter().map(|v| 1.0 / v).collect())
        }
    };
    let dinv = dinv.as_deref();
    let mut r = vec![0.0; n * k];
    op.apply(x, &mut r, k);
    r.par_iter_mut()
        .zip(b.par_iter())
        .for_each(|(ri, bi)| *ri = bi - *ri);
    let mut rt = r.clone();
    let (mut p, mut pt) = (vec![0.0; n * k], vec![0.0; n * k]);
    let (mut q, mut qt) = (vec![0.0; n * k], vec![0.0; n * k]);
    let bnorm: Vec<f64> = col_norms2(b, k)
        .iter()
        .map(|v| v.sqrt().max(f64::MIN_POSITIVE))
        .collect();
    // ρ₀ and the norms of the initial residual.
    let mut sums = r
        .par_chunks(CHUNK * k)
        .enumerate()
        .map(|(blk, rs)| {
            let mut s = Sums::default();
            for row in 0..rs.len() / k {
                let di = dinv.map_or(1.0, |d| d[blk * CHUNK + row]);
                for c in 0..k {
                    let v = rs[row * k + c];
                    s.rr[c] += v * v;
                    s.rho[c] += v * v * di;
                    s.zz[c] += v * v * di * di;
                    s.rtrt[c] += v * v;
                }
            }
            s
        })
        .reduce(Sums::default, Sums::add);
    let mut active = vec![true; k];
    let mut rho_prev = [0.0f64; 8];
    let mut info = Info {
        iterations: vec![0; k],
        history: vec![Vec::new(); k],
        plateau_at: vec![None; k],
        ..Default::default()
    };
    let mut hist_all: Vec<Vec<f64>> = vec![Vec::new(); k];
    for c in 0..k {
        hist_all[c].push(sums.rr[c].sqrt() / bnorm[c]);
        if sums.rr[c] == 0.0 {
            active[c] = false;
        }
    }
    let eps = params.tolerance;
    let eps2 = eps * eps;
    let weak_vertex = params.stopping == Stopping::WeakVertex;
    let mut it = 0;
    let (mut denom, mut qq) = (vec![0.0; k], vec![0.0; k]);
    while active.iter().any(|&a| a) {
        if it >= params.max_iterations {
            break;
        }
        it += 1;
        let mut beta = [0.0f64; 8];
        for c in 0..k {
            if !active[c] {
                continue;
            }
            let rho = sums.rho[c];
            if rho == 0.0 || rho.abs() <= 1e-15 * (sums.zz[c] * sums.rtrt[c]).sqrt() {
                return Err(SolveError::Breakdown {
                    iteration: it,
                    column: c,
                    what: "ρ = z̃ᵀr vanished",
                });
            }
            beta[c] = if it == 1 { 0.0 } else { rho / rho_prev[c] };
        }
        // p = M⁻¹r + βp, p̃ = M⁻ᵀr̃ + βp̃ (M diagonal), with ‖p‖² and ‖p̃‖².
        let act = &active;
        let (pn, ptn) = p
            .par_chunks_mut(CHUNK * k)
            .zip(pt.par_chunks_mut(CHUNK * k))
            .zip(r.par_chunks(CHUNK * k).zip(rt.par_chunks(CHUNK * k)))
            .enumerate()
            .map(|(blk, ((ps, pts), (rs, rts)))| {
                let (mut a, mut t) = ([0.0f64; 8], [0.0f64; 8]);
                for row in 0..ps.len() / k {
                    let di = dinv.map_or(1.0, |d| d[blk * CHUNK + row]);
                    for c in 0..k {
                        let j = row * k + c;
                        if act[c] {
                            ps[j] = di * rs[j] + beta[c] * ps[j];
                            pts[j] = di * rts[j] + beta[c] * pts[j];
                        }
                        a[c] += ps[j] * ps[j];
                        t[c] += pts[j] * pts[j];
                    }
                }
                (a, t)
            })
            .reduce(
                || ([0.0; 8], [0.0; 8]),
                |a, b| {
                    (
                        std::array::from_fn(|c| a.0[c] + b.0[c]),
                        std::array::from_fn(|c| a.1[c] + b.1[c]),
                    )
                },
            );
        op.apply_dot_norm(&p, &mut q, k, &pt, &mut denom, &mut qq);
        op.apply_transpose(&pt, &mut qt, k)?;
        let mut alpha = [0.0f64; 8];
        for c in 0..k {
            if !active[c] {
                continue;
            }
            if denom[c] == 0.0 || denom[c].abs() <= 1e-15 * (ptn[c] * qq[c]).sqrt() {
                return Err(SolveError::Breakdown {
                    iteration: it,
                    column: c,
                    what: "p̃ᵀAp vanished",
                });
            }
            alpha[c] = sums.rho[c] / denom[c];
            rho_prev[c] = sums.rho[c];
        }
        // x += αp, r -= αq, r̃ -= αq̃, with every norm of the next iteration.
        sums = x
            .par_chunks_mut(CHUNK * k)
            .zip(r.par_chunks_mut(CHUNK * k))
            .zip(rt.par_chunks_mut(CHUNK * k))
            .zip(
                p.par_chunks(CHUNK * k)
                    .zip(q.par_chunks(CHUNK * k))
                    .zip(qt.par_chunks(CHUNK * k)),
            )
            .enumerate()
            .map(|(blk, (((xs, rs), rts), ((ps, qs), qts)))| {
                let mut s = Sums::default();
                for row in 0..xs.len() / k {
                    let di = dinv.map_or(1.0, |d| d[blk * CHUNK + row]);
                    let (mut dx2, mut x2) = (0.0, 0.0);
                    for c in 0..k {
                        let j = row * k + c;
                        let xo = xs[j];
                        s.xx[c] += xo * xo;
                        x2 += xo * xo;
                        let dx = alpha[c] * ps[j];
                        dx2 += dx * dx;
                        xs[j] = xo + dx;
                        let rv = rs[j] - alpha[c] * qs[j];
                        let rtv = rts[j] - alpha[c] * qts[j];
                        rs[j] = rv;
                        rts[j] = rtv;
                        s.rr[c] += rv * rv;
                        s.rho[c] += rtv * di * rv;
                        s.zz[c] += rv * rv * di * di;
                        s.rtrt[c] += rtv * rtv;
                    }
                    if weak_vertex && dx2 > 0.0 && dx2 >= eps2 * x2 {
                        s.moving += 1;
                    }
                }
                s
            })
            .reduce(Sums::default, Sums::add);
        for c in 0..k {
            if !active[c] {
                continue;
            }
            info.iterations[c] = it;
            let rel = sums.rr[c].sqrt() / bnorm[c];
            hist_all[c].push(rel);
            let w = params.plateau_window;
            if info.plateau_at[c].is_none() && w > 0 && hist_all[c].len() > w {
                let h = &hist_all[c];
                if h[h.len() - 1] > 0.99 * h[h.len() - 1 - w] {
                    info.plateau_at[c] = Some(it);
                }
            }
            let done = match params.stopping {
                Stopping::Weak => alpha[c] * alpha[c] * pn[c] < eps2 * sums.xx[c],
                Stopping::WeakVertex => sums.moving == 0,
                Stopping::Strong => rel < eps,
            };
            if done || sums.rr[c] == 0.0 {
                active[c] = false;
            }
        }
    }
    if params.record_history {
        info.history = hist_all;
    }
    info.residuals = relative_residuals(op, x, b, k);
    info.seconds = start.elapsed().as_secs_f64();
    if active.iter().any(|&a| a) {
        return Err(SolveError::NoConvergence {
            info: Box::new(info),
        });
    }
    Ok(info)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solve::{direct::LuSolver, shifted_system, test_util::*, SparseOperator};

    #[test]
    fn agrees_with_lu_on_the_tutte_system() {
        let (m, tl, ..) = irregular(3);
        let a = shifted_system(&tl, None, 30.0);
        let at = CsrMatrixT::of(&a);
        let op = SparseOperator::from_csr(a.clone(), Some(at));
        let b = flat(&m);
        let mut want = b.clone();
        LuSolver::new(&a.to_csc())
            .unwrap()
            .solve_in_place(&mut want, 3)
            .unwrap();
        for pre in [Preconditioner::None, Preconditioner::Jacobi] {
            let mut x = b.clone();
            let p = Params {
                stopping: Stopping::Strong,
                tolerance: 1e-10,
                ..Default::default()
            };
            let info = bicg(&op, &b, &mut x, 3, &p, pre).unwrap();
            assert!(info.residuals.iter().all(|&r| r < 1e-9));
            let err = x
                .iter()
                .zip(&want)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(err < 1e-8, "{err}");
        }
    }

    /// CSR of the transpose of a CSR matrix, via faer's CSC.
    struct CsrMatrixT;
    impl CsrMatrixT {
        fn of(a: &crate::solve::CsrMatrix) -> crate::solve::CsrMatrix {
            crate::solve::CsrMatrix::transpose_of_csc(&a.to_csc())
        }
    }

    #[test]
    fn breakdown_is_reported() {
        // A = [[0, 1], [1, 0]] with b = e1: r̃ᵀAp = 0 at the first step.
        let trip = [
            faer::sparse::Triplet::new(0, 1, 1.0),
            faer::sparse::Triplet::new(1, 0, 1.0),
        ];
        let m = crate::SparseMatrix::try_new_from_triplets(2, 2, &trip).unwrap();
        let op = SparseOperator::new(&m, true);
        let mut x = vec![0.0; 2];
        let e = bicg(
            &op,
            &[1.0, 0.0],
            &mut x,
            1,
            &Params::default(),
            Preconditioner::None,
        )
        .unwrap_err();
        assert!(
            matches!(e, SolveError::Breakdown { iteration: 1, .. }),
            "{e}"
        );
    }

    #[test]
    fn iteration_counts_of_cg_on_sql_and_bicg_on_tl_are_of_the_same_order() {
        let (m, tl, sql, ..) = irregular(4);
        let b = flat(&m);
        let a = shifted_system(&tl, None, 30.0);
        let op_t = SparseOperator::from_csr(a.clone(), Some(CsrMatrixT::of(&a)));
        let op_s = SparseOperator::from_csr(shifted_system(&sql, None, 30.0), None);
        let p = Params::default();
        let mut x = b.clone();
        let ib = bicg(&op_t, &b, &mut x, 3, &p, Preconditioner::None).unwrap();
        let mut x = b.clone();
        let ic = crate::solve::cg::cg(&op_s, &b, &mut x, 3, &p, Preconditioner::None).unwrap();
        let (mb, mc) = (
            *ib.iterations.iter().max().unwrap() as f64,
            *ic.iterations.iter().max().unwrap() as f64,
        );
        assert!(mb / mc < 3.0 && mc / mb < 3.0, "BiCG {mb} vs CG {mc}");
    }

    fn diagonal(values: &[f64]) -> SparseOperator {
        let trip: Vec<_> = values
            .iter()
            .enumerate()
            .map(|(i, &v)| faer::sparse::Triplet::new(i, i, v))
            .collect();
        let n = values.len();
        SparseOperator::new(
            &crate::SparseMatrix::try_new_from_triplets(n, n, &trip).unwrap(),
            true,
        )
    }

    #[test]
    fn plateau_is_detected_on_an_ill_conditioned_system_and_not_on_a_well_conditioned_one() {
        // Eigenvalues spread over 1..1e6: the residual stalls for many iterations.
        let n = 400;
        let spread: Vec<f64> = (0..n)
            .map(|i| 10f64.powf(6.0 * i as f64 / (n - 1) as f64))
            .collect();
        let p = Params {
            stopping: Stopping::Strong,
            tolerance: 1e-8,
            ..Default::default()
        };
        let b = vec![1.0; n];
        let mut x = vec![0.0; n];
        let info = bicg(&diagonal(&spread), &b, &mut x, 1, &p, Preconditioner::None).unwrap();
        let at = info.plateau_at[0].expect("a plateau on an ill-conditioned system");
        let h = &info.history[0];
        assert!(h[at] > 0.99 * h[at - p.plateau_window], "{at}: {h:?}");
        // Eigenvalues in [1, 2]: steady convergence, no plateau.
        let easy: Vec<f64> = (0..n).map(|i| 1.0 + i as f64 / n as f64).collect();
        let mut x = vec![0.0; n];
        let info = bicg(&diagonal(&easy), &b, &mut x, 1, &p, Preconditioner::None).unwrap();
        assert_eq!(info.plateau_at, vec![None]);
    }

    #[test]
    fn iteration_cap_is_no_convergence() {
        let (m, tl, ..) = irregular(3);
        let a = shifted_system(&tl, None, 100.0);
        let op = SparseOperator::from_csr(a.clone(), Some(CsrMatrixT::of(&a)));
        let b = flat(&m);
        let mut x = vec![0.0; b.len()];
        let p = Params {
            max_iterations: 3,
            stopping: Stopping::Strong,
            tolerance: 1e-14,
            ..Default::default()
        };
        match bicg(&op, &b, &mut x, 3, &p, Preconditioner::None) {
            Err(SolveError::NoConvergence { info }) => {
                assert_eq!(info.iterations, vec![3, 3, 3]);
                assert!(info.residuals.iter().all(|&r| r > 1e-14));
            }
            other => panic!("{other:?}"),
        }
    }
}
