//! Blocked conjugate gradients, optionally Jacobi-preconditioned (Hestenes & Stiefel
//! 1952; Barrett et al. 1994, *Templates*, Fig. 2.5), for symmetric positive definite
//! systems such as `(I + λS)x = b` with the SQL, KL or SSTL, and the symmetrised Tutte
//! system `(D + λK)x = Db` (the paper's "CG (TL)").
//!
//! The k right-hand sides (n×k row-major) share every sparse product; each column has
//! its own α, β and stops on its own. One iteration is one fused product-and-dot
//! (`q = Bp`, `pᵀq`), one fused pass updating x and r and accumulating every norm the
//! stopping test needs, and one pass updating p.

use super::{
    check_dims, col_dots, col_norms2, csr::CHUNK, relative_residuals, Info, LinearOperator, Params,
    SolveError, Stopping,
};
use rayon::prelude::*;
use std::time::Instant;

/// Preconditioner of [`cg`].
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub enum Preconditioner {
    /// None (plain CG).
    #[default]
    None,
    /// Jacobi: the inverse of the matrix diagonal.
    Jacobi,
}

#[derive(Default, Clone, Copy)]
struct Sums {
    rr: [f64; 8],
    rz: [f64; 8],
    pp: [f64; 8],
    xx: [f64; 8],
    moving_vertices: usize,
}

impl Sums {
    fn add(mut self, o: Sums) -> Sums {
        for c in 0..8 {
            self.rr[c] += o.rr[c];
            self.rz[c] += o.rz[c];
            self.pp[c] += o.pp[c];
            self.xx[c] += o.xx[c];
        }
        self.moving_vertices += o.moving_vertices;
        self
    }
}

/// Solves `B x = b` for the n×k block `b`, starting from and overwriting `x`.
pub fn cg(
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
            if let Some(i) = d.iter().position(|&v| v <= 0.0 || v.is_nan()) {
                return Err(SolveError::NotPositiveDefinite {
                    iteration: 0,
                    column: i % k.max(1),
                });
            }
            Some(d.iter().map(|v| 1.0 / v).collect())
        }
    };
    let eps = params.tolerance;
    let mut r = vec![0.0; n * k];
    op.apply(x, &mut r, k);
    r.par_iter_mut()
        .zip(b.par_iter())
        .for_each(|(ri, bi)| *ri = bi - *ri);
    let mut p: Vec<f64> = match &dinv {
        Some(d) => r.iter().enumerate().map(|(j, v)| v * d[j / k]).collect(),
        None => r.clone(),
    };
    let mut q = vec![0.0; n * k];
    let mut rz = col_dots(&r, &p, k);
    let bnorm: Vec<f64> = col_norms2(b, k)
        .iter()
        .map(|v| v.sqrt().max(f64::MIN_POSITIVE))
        .collect();
    let mut active = vec![true; k];
    let mut info = Info {
        iterations: vec![0; k],
        history: vec![Vec::new(); k],
        plateau_at: vec![None; k],
        ..Default::default()
    };
    let rr0 = col_norms2(&r, k);
    for c in 0..k {
        if rr0[c] == 0.0 {
            active[c] = false;
        }
        if params.record_history {
            info.history[c].push(rr0[c].sqrt() / bnorm[c]);
        }
    }
    let mut pq = vec![0.0; k];
    let mut it = 0;
    while active.iter().any(|&a| a) {
        if it >= params.max_iterations {
            info.residuals = relative_residuals(op, x, b, k);
            info.seconds = start.elapsed().as_secs_f64();
            return Err(SolveError::NoConvergence {
                info: Box::new(info),
            });
        }
        it += 1;
        op.apply_dot(&p, &mut q, k, &p, &mut pq);
        let mut alpha = [0.0f64; 8];
        for c in 0..k {
            if !active[c] {
                continue;
            }
            if pq[c] <= 0.0 || pq[c].is_nan() {
                if rz[c] == 0.0 {
                    active[c] = false;
                    info.iterations[c] = it - 1;
                    continue;
                }
                return Err(SolveError::NotPositiveDefinite {
                    iteration: it,
                    column: c,
                });
            }
            alpha[c] = rz[c] / pq[c];
        }
        let eps2 = eps * eps;
        let weak_vertex = params.stopping == Stopping::WeakVertex;
        let dinv_ref = dinv.as_deref();
        let sums = x
            .par_chunks_mut(CHUNK * k)
            .zip(r.par_chunks_mut(CHUNK * k))
            .zip(p.par_chunks(CHUNK * k).zip(q.par_chunks(CHUNK * k)))
            .enumerate()
            .map(|(blk, ((xs, rs), (ps, qs)))| {
                let mut s = Sums::default();
                for row in 0..xs.len() / k {
                    let mut dx2 = 0.0;
                    let mut x2 = 0.0;
                    let di = dinv_ref.map_or(1.0, |d| d[blk * CHUNK + row]);
                    for c in 0..k {
                        let j = row * k + c;
                        let xo = xs[j];
                        s.xx[c] += xo * xo;
                        x2 += xo * xo;
                        let dx = alpha[c] * ps[j];
                        dx2 += dx * dx;
                        xs[j] = xo + dx;
                        rs[j] -= alpha[c] * qs[j];
                        s.rr[c] += rs[j] * rs[j];
                        s.rz[c] += rs[j] * rs[j] * di;
                        s.pp[c] += ps[j] * ps[j];
                    }
                    if weak_vertex && dx2 >= eps2 * x2 && dx2 > 0.0 {
                        s.moving_vertices += 1;
                    }
                }
                s
            })
            .reduce(Sums::default, Sums::add);
        let mut beta = [0.0f64; 8];
        for c in 0..k {
            if !active[c] {
                continue;
            }
            info.iterations[c] = it;
            if params.record_history {
                info.history[c].push(sums.rr[c].sqrt() / bnorm[c]);
            }
            let done = match params.stopping {
                Stopping::Weak => alpha[c] * alpha[c] * sums.pp[c] < eps2 * sums.xx[c],
                Stopping::WeakVertex => sums.moving_vertices == 0,
                Stopping::Strong => sums.rr[c].sqrt() < eps * bnorm[c],
            };
            if done || sums.rr[c] == 0.0 {
                active[c] = false;
                continue;
            }
            beta[c] = sums.rz[c] / rz[c];
            rz[c] = sums.rz[c];
        }
        p.par_chunks_mut(CHUNK * k)
            .zip(r.par_chunks(CHUNK * k))
            .enumerate()
            .for_each(|(blk, (ps, rs))| {
                for row in 0..ps.len() / k {
                    let di = dinv_ref.map_or(1.0, |d| d[blk * CHUNK + row]);
                    for c in 0..k {
                        if active[c] {
                            let j = row * k + c;
                            ps[j] = rs[j] * di + beta[c] * ps[j];
                        }
                    }
                }
            });
    }
    info.residuals = relative_residuals(op, x, b, k);
    info.seconds = start.elapsed().as_secs_f64();
    Ok(info)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solve::{direct::CholeskySolver, shifted_system, test_util::*, SparseOperator};

    fn direct(a: &crate::solve::CsrMatrix, b: &[f64], k: usize) -> Vec<f64> {
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
        let op = SparseOperator::from_csr(a.clone(), None);
        let b = flat(&m);
        let want = direct(&a, &b, 3);
        for pre in [Preconditioner::None, Preconditioner::Jacobi] {
            let mut x = b.clone();
            let params = Params {
                stopping: Stopping::Strong,
                tolerance: 1e-10,
                ..Default::default()
            };
            let info = cg(&op, &b, &mut x, 3, &params, pre).unwrap();
            assert!(
                info.residuals.iter().all(|&r| r < 1e-9),
                "{:?}",
                info.residuals
            );
            let err = x
                .iter()
                .zip(&want)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(err < 1e-8, "{pre:?}: {err}");
        }
    }

    #[test]
    fn blocked_equals_single_columns() {
        let (m, _, sql, ..) = irregular(2);
        let a = shifted_system(&sql, None, 10.0);
        let op = SparseOperator::from_csr(a, None);
        let b = flat(&m);
        let params = Params {
            stopping: Stopping::Strong,
            tolerance: 1e-12,
            ..Default::default()
        };
        let mut x = b.clone();
        let info = cg(&op, &b, &mut x, 3, &params, Preconditioner::None).unwrap();
        for c in 0..3 {
            let bc: Vec<f64> = (0..m.n_vertices()).map(|i| b[3 * i + c]).collect();
            let mut xc = bc.clone();
            let ic = cg(&op, &bc, &mut xc, 1, &params, Preconditioner::None).unwrap();
            assert_eq!(ic.iterations[0], info.iterations[c]);
            for i in 0..m.n_vertices() {
                assert!((xc[i] - x[3 * i + c]).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn weak_stops_earlier_than_strong() {
        let (m, _, sql, ..) = irregular(5);
        let op = SparseOperator::from_csr(shifted_system(&sql, None, 30.0), None);
        let b = flat(&m);
        let run = |stopping| {
            let mut x = b.clone();
            let p = Params {
                stopping,
                ..Default::default()
            };
            cg(&op, &b, &mut x, 3, &p, Preconditioner::None).unwrap()
        };
        let (w, wv, s) = (
            run(Stopping::Weak),
            run(Stopping::WeakVertex),
            run(Stopping::Strong),
        );
        let max = |i: &Info| *i.iterations.iter().max().unwrap();
        assert!(max(&w) < max(&s), "{:?} {:?}", w.iterations, s.iterations);
        assert!(max(&w) <= max(&wv));
        assert!(wv.iterations.iter().all(|&i| i == wv.iterations[0]));
    }

    #[test]
    fn indefinite_matrix_is_reported() {
        // diag(1, -1, 1, ...) is symmetric indefinite.
        let n = 50;
        let trip: Vec<_> = (0..n)
            .map(|i| faer::sparse::Triplet::new(i, i, if i == 7 { -1.0 } else { 1.0 + i as f64 }))
            .collect();
        let m = crate::SparseMatrix::try_new_from_triplets(n, n, &trip).unwrap();
        let op = SparseOperator::new(&m, false);
        let b = vec![1.0; n];
        let mut x = vec![0.0; n];
        let e = cg(&op, &b, &mut x, 1, &Params::default(), Preconditioner::None).unwrap_err();
        assert!(matches!(e, SolveError::NotPositiveDefinite { .. }), "{e}");
    }

    #[test]
    fn iteration_cap_is_no_convergence() {
        let (m, _, sql, ..) = irregular(3);
        let op = SparseOperator::from_csr(shifted_system(&sql, None, 100.0), None);
        let b = flat(&m);
        let mut x = vec![0.0; b.len()];
        let p = Params {
            max_iterations: 2,
            stopping: Stopping::Strong,
            tolerance: 1e-14,
            ..Default::default()
        };
        match cg(&op, &b, &mut x, 3, &p, Preconditioner::None) {
            Err(SolveError::NoConvergence { info }) => assert_eq!(info.iterations, vec![2, 2, 2]),
            other => panic!("{other:?}"),
        }
    }
}
