//! Blocked BiCGSTAB (van der Vorst 1992; Barrett et al. 1994, *Templates*, Fig. 2.10)
//! for non-symmetric systems such as the Tutte system `(I + λT)x = b`: a reference
//! beside BiCG that needs no transpose (two products with `A` per iteration) and
//! smooths BiCG's irregular convergence.
//!
//! Like [`super::cg()`] and [`super::bicg()`] it solves the k columns together with
//! per-column scalars, honors every [`Stopping`](super::Stopping) criterion (the weak
//! ones on the update `x⁽ⁿ⁾ − x⁽ⁿ⁻¹⁾ = αp + ωs` of the whole iteration) and reports a
//! vanishing `ρ = r̂ᵀr`, `r̂ᵀv` or `ω` as [`BicgstabError::Breakdown`].
//!
//! One iteration: the p update; `v = Ap` fused with `r̂ᵀv`; `s = r − αv`; `t = As`
//! fused with `tᵀs` and `‖t‖²`; and one pass updating x and r that accumulates every
//! norm of the stopping test and the next ρ. Five n×k work blocks (s overwrites r).

use super::krylov::{self, with_columns, Criterion, Sums};
use super::{csr::CHUNK, Fused, Info, InputError, LinOp, Params, Workspace, MAX_COLUMNS};
use crate::par::FoldInOrder;
use rayon::prelude::*;
use std::time::Instant;

/// Why [`bicgstab()`] failed.
#[derive(Debug, thiserror::Error)]
pub enum BicgstabError {
    /// A recurrence broke down (division by a vanishing quantity); try BiCG or a direct
    /// solver.
    #[error("breakdown at iteration {iteration} in column {column}: {what}")]
    Breakdown {
        /// Iteration.
        iteration: usize,
        /// Column.
        column: usize,
        /// Which quantity vanished.
        what: &'static str,
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
const RR: usize = 0; // ‖r‖²
const RHO: usize = 1; // r̂ᵀr
const STEP: usize = 2; // ‖αp + ωs‖²
const XX: usize = 3; // ‖x⁽ⁿ⁻¹⁾‖²

fn breakdown(iteration: usize, column: usize, what: &'static str) -> BicgstabError {
    BicgstabError::Breakdown {
        iteration,
        column,
        what,
    }
}

/// Solves `A x = b` for the n×k row-major block `b` (k ≤ [`MAX_COLUMNS`]) with
/// BiCGSTAB, starting from and overwriting `x`; `A` is any n×n [`LinOp`]. `ws` keeps
/// the five n×k work blocks between calls.
pub fn bicgstab(
    op: &dyn LinOp,
    b: &[f64],
    x: &mut [f64],
    k: usize,
    params: &Params,
    ws: &mut Workspace,
) -> Result<Info, BicgstabError> {
    // The time includes the hand-over to the pool.
    let start = Instant::now();
    crate::par::on_worker(|| bicgstab_on_worker(start, op, b, x, k, params, ws))
}

/// [`bicgstab()`] on a worker of rayon's pool, timed from `start`.
#[allow(clippy::too_many_arguments)]
fn bicgstab_on_worker(
    start: Instant,
    op: &dyn LinOp,
    b: &[f64],
    x: &mut [f64],
    k: usize,
    params: &Params,
    ws: &mut Workspace,
) -> Result<Info, BicgstabError> {
    krylov::check(op, b, x, k, params)?;
    let n = op.dim();
    let [r, rh, p, v, t] = ws.blocks::<5>(n * k);
    // r = b − Ax, r̂ = r, ‖r‖², ‖b‖²: one pass.
    let s0 = op.residual(b, x, r, k, None, Some(rh))?;
    krylov::zero(p);
    krylov::zero(v);
    let bnorm = krylov::norms_of_b(&s0, k);
    let rr0 = &s0.rr[..k];
    // r̂ = r⁽⁰⁾: ρ₀ = ‖r⁽⁰⁾‖², and ‖r̂‖ scales the breakdown tests.
    let rh_norm: Vec<f64> = rr0.iter().map(|v| v.sqrt()).collect();
    let (mut rho, mut rr) = ([0.0; MAX_COLUMNS], [0.0; MAX_COLUMNS]);
    rho[..k].copy_from_slice(rr0);
    rr[..k].copy_from_slice(rr0);
    let mut active = krylov::all_active(k);
    for c in 0..k {
        active[c] = rr0[c] != 0.0;
    }
    let mut info = Info::new(k);
    if params.record_history {
        for c in 0..k {
            info.history[c].push(rr0[c].sqrt() / bnorm[c]);
        }
    }
    let crit = Criterion::new(params);
    let (mut rho_prev, mut alpha, mut omega) = (
        [1.0f64; MAX_COLUMNS],
        [0.0f64; MAX_COLUMNS],
        [0.0f64; MAX_COLUMNS],
    );
    let (mut rhv, mut vv, mut ts, mut tt) = (
        [0.0; MAX_COLUMNS],
        [0.0; MAX_COLUMNS],
        [0.0; MAX_COLUMNS],
        [0.0; MAX_COLUMNS],
    );
    let mut it = 0;
    while active.iter().any(|&a| a) && it < params.max_iterations {
        it += 1;
        let mut beta = [0.0f64; MAX_COLUMNS];
        for c in krylov::live(active) {
            if krylov::vanished(rho[c], rh_norm[c] * rr[c].sqrt()) {
                return Err(breakdown(it, c, "ρ = r̂ᵀr vanished"));
            }
            beta[c] = if it == 1 {
                0.0
            } else {
                (rho[c] / rho_prev[c]) * (alpha[c] / omega[c])
            };
        }
        // p = r + β(p − ωv).
        let act = &active;
        p.par_chunks_mut(CHUNK * k)
            .zip(r.par_chunks(CHUNK * k).zip(v.par_chunks(CHUNK * k)))
            .for_each(|(ps, (rs, vs))| {
                for (j, pv) in ps.iter_mut().enumerate() {
                    let c = j % k;
                    if act[c] {
                        *pv = rs[j] + beta[c] * (*pv - omega[c] * vs[j]);
                    }
                }
            });
        op.apply_fused(p, v, k, Fused::new(rh, &mut rhv, &mut vv));
        for c in 0..k {
            if !active[c] {
                alpha[c] = 0.0;
                continue;
            }
            if krylov::vanished(rhv[c], rh_norm[c] * vv[c].sqrt()) {
                return Err(breakdown(it, c, "r̂ᵀAp vanished"));
            }
            alpha[c] = rho[c] / rhv[c];
        }
        // s = r − αv, in place of r.
        r.par_chunks_mut(CHUNK * k)
            .zip(v.par_chunks(CHUNK * k))
            .for_each(|(rs, vs)| {
                for (j, rv) in rs.iter_mut().enumerate() {
                    *rv -= alpha[j % k] * vs[j];
                }
            });
        op.apply_fused(r, t, k, Fused::new(r, &mut ts, &mut tt));
        for c in 0..k {
            omega[c] = if active[c] && tt[c] > 0.0 {
                ts[c] / tt[c]
            } else {
                0.0
            };
        }
        // x += αp + ωs, r = s − ωt, with every norm of the stopping test and the next ρ.
        let sums = x
            .par_chunks_mut(CHUNK * k)
            .zip(r.par_chunks_mut(CHUNK * k))
            .zip(
                p.par_chunks(CHUNK * k)
                    .zip(t.par_chunks(CHUNK * k))
                    .zip(rh.par_chunks(CHUNK * k)),
            )
            .map(|((xs, rs), ((ps, ts), rhs))| {
                with_columns!(k, K => {
                    let mut s = Sums::<4>::default();
                    for row in 0..xs.len() / K {
                        let (mut dx2, mut x2) = (0.0, 0.0);
                        for c in 0..K {
                            let j = row * K + c;
                            let dx = alpha[c] * ps[j] + omega[c] * rs[j];
                            s.v[STEP][c] += dx * dx;
                            krylov::advance(&mut xs[j], dx, &mut s.v[XX][c], &mut x2, &mut dx2);
                            let rv = rs[j] - omega[c] * ts[j];
                            rs[j] = rv;
                            s.v[RR][c] += rv * rv;
                            s.v[RHO][c] += rhs[j] * rv;
                        }
                        s.moving += crit.moving(dx2, x2);
                    }
                    s
                })
            })
            .fold_in_order(Sums::default(), Sums::add);
        for c in krylov::live(active) {
            info.iterations[c] = it;
            rr[c] = sums.v[RR][c];
            if params.record_history {
                info.history[c].push(rr[c].sqrt() / bnorm[c]);
            }
            if crit.done(sums.v[STEP][c], sums.v[XX][c], sums.moving, rr[c], bnorm[c])
                || rr[c] == 0.0
            {
                active[c] = false;
                continue;
            }
            if omega[c] == 0.0 {
                return Err(breakdown(it, c, "ω = tᵀs/tᵀt vanished"));
            }
            rho_prev[c] = rho[c];
            rho[c] = sums.v[RHO][c];
        }
    }
    krylov::finish(&mut info, op, x, b, k, start, t)?;
    if active.iter().any(|&a| a) {
        return Err(BicgstabError::NoConvergence {
            info: Box::new(info),
        });
    }
    Ok(info)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solve::{direct::LuSolver, shifted_system, test_util::*, CsrMatrix, Stopping};

    fn tutte_system(level: usize, lambda: f64) -> (Vec<f64>, CsrMatrix) {
        let (m, tl, ..) = irregular(level);
        (flat(&m), shifted_system(&tl, None, lambda))
    }

    #[test]
    fn agrees_with_lu() {
        let (b, a) = tutte_system(3, 30.0);
        let mut want = b.clone();
        LuSolver::new(&a.to_csc())
            .unwrap()
            .solve_in_place(&mut want, 3)
            .unwrap();
        let mut x = b.clone();
        let p = Params {
            tolerance: 1e-11,
            ..Default::default()
        };
        let info = bicgstab(&a, &b, &mut x, 3, &p, &mut Workspace::new()).unwrap();
        assert!(
            info.residuals.iter().all(|&r| r < 1e-9),
            "{:?}",
            info.residuals
        );
        assert!(max_diff(&x, &want) < 1e-8);
    }

    #[test]
    fn iteration_cap_is_no_convergence() {
        let (b, a) = tutte_system(3, 100.0);
        let mut x = vec![0.0; b.len()];
        let p = Params {
            tolerance: 1e-14,
            max_iterations: 2,
            ..Default::default()
        };
        match bicgstab(&a, &b, &mut x, 3, &p, &mut Workspace::new()) {
            Err(BicgstabError::NoConvergence { info }) => {
                assert_eq!(info.iterations, vec![2, 2, 2]);
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn honours_the_weak_and_strong_stopping_rules() {
        let (b, a) = tutte_system(5, 30.0);
        let solve = |stopping| {
            let mut x = b.clone();
            let p = Params {
                stopping,
                ..Default::default()
            };
            let info = bicgstab(&a, &b, &mut x, 3, &p, &mut Workspace::new()).unwrap();
            (x, info)
        };
        let (_, weak) = solve(Stopping::Weak);
        let (_, vertex) = solve(Stopping::WeakVertex);
        let (_, strong) = solve(Stopping::Strong);
        let max = |i: &Info| *i.iterations.iter().max().unwrap();
        // The weak criterion stops on the size of the update, before the residual
        // reaches ε (at ε = 1e-5 on this system: fewer iterations, larger residual).
        assert!(max(&weak) < max(&strong), "{weak:?} {strong:?}");
        assert!(weak.residuals.iter().any(|&r| r >= 1e-5), "{weak:?}");
        // The strong criterion stops on the residual, at its first iteration below ε.
        for c in 0..3 {
            let h = &strong.history[c];
            assert!(h[h.len() - 1] < 1e-5 && h[h.len() - 2] >= 1e-5, "{h:?}");
            assert!(strong.residuals[c] < 1e-5);
        }
        // The weak-vertex criterion stops every column together.
        assert!(vertex.iterations.iter().all(|&i| i == vertex.iterations[0]));
        assert!(max(&vertex) >= max(&weak));
    }

    #[test]
    fn a_short_initial_guess_is_an_error_not_a_panic() {
        let (b, a) = tutte_system(2, 30.0);
        let mut x = vec![0.0; b.len() - 3];
        assert!(matches!(
            bicgstab(&a, &b, &mut x, 3, &Params::default(), &mut Workspace::new()),
            Err(BicgstabError::Input(InputError::InitialGuess { .. }))
        ));
        let mut x = b.clone();
        assert!(matches!(
            bicgstab(&a, &b, &mut x, 9, &Params::default(), &mut Workspace::new()),
            Err(BicgstabError::Input(InputError::Columns { k: 9 }))
        ));
    }

    #[test]
    fn a_zero_right_hand_side_needs_no_iteration() {
        let (b, a) = tutte_system(1, 3.0);
        let zero = vec![0.0; b.len()];
        let mut x = vec![0.0; b.len()];
        let info = bicgstab(
            &a,
            &zero,
            &mut x,
            3,
            &Params::default(),
            &mut Workspace::new(),
        )
        .unwrap();
        assert_eq!(info.iterations, vec![0, 0, 0]);
        assert!(x.iter().all(|&v| v == 0.0));
    }
}
