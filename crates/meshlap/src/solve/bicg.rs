//! Blocked bi-conjugate gradients (Fletcher 1976; Barrett et al. 1994, *Templates*,
//! Fig. 2.8) for non-symmetric systems such as the Tutte system `(I + λT)x = b`.
//!
//! Needs `Aᵀ`, so the operator is a [`BiLinOp`]; costs two sparse products per
//! iteration, which is why the paper measures CG at 50–60% of BiCG's time (here the
//! two are one pass over the matrix, which narrows the gap). Two failure
//! modes are detected and reported, never hidden:
//!
//! - **breakdown**: `ρ = z̃ᵀr` or `p̃ᵀAp` vanishes (relative to the norms of its
//!   factors, below 1e-15) — [`BicgError::Breakdown`];
//! - **plateau**: the relative residual is above 99% of its value
//!   [`BicgParams::plateau_window`] iterations earlier; the first such iteration is
//!   recorded in [`BicgInfo::plateau_at`] (the solve goes on). The paper observed
//!   plateaus on Igea and Isis at λ = 100.

use super::krylov::{self, with_columns, Criterion, Sums};
use super::{csr::CHUNK, BiLinOp, Info, InputError, Jacobi, Params, Workspace, MAX_COLUMNS};
use crate::par::FoldInOrder;
use rayon::prelude::*;
use serde::Serialize;
use std::time::Instant;

/// Parameters of [`bicg()`]: the common ones and the plateau window.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct BicgParams {
    /// Tolerance, stopping criterion, cap, history.
    pub params: Params,
    /// A plateau is an iteration whose relative residual is above 99% of the one
    /// `plateau_window` iterations earlier (default 10; 0 turns detection off).
    pub plateau_window: usize,
}

impl Default for BicgParams {
    fn default() -> Self {
        BicgParams {
            params: Params::default(),
            plateau_window: 10,
        }
    }
}

impl From<Params> for BicgParams {
    fn from(params: Params) -> Self {
        BicgParams {
            params,
            ..Default::default()
        }
    }
}

/// What [`bicg()`] did: the common [`Info`] and the plateau.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct BicgInfo {
    /// Iterations, residuals, history, seconds.
    #[serde(flatten)]
    pub info: Info,
    /// The first iteration at which a plateau was seen, per column.
    pub plateau_at: Vec<Option<usize>>,
}

/// Why [`bicg()`] failed.
#[derive(Debug, thiserror::Error)]
pub enum BicgError {
    /// A Krylov recurrence broke down (division by a vanishing quantity); try another
    /// initial guess, BiCGSTAB, or a direct solver.
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
    #[error("no convergence within {} iterations (relative residuals {:?})", .info.info.iterations.iter().max().unwrap_or(&0), .info.info.residuals)]
    NoConvergence {
        /// What was done.
        info: Box<BicgInfo>,
    },
    /// The arguments are unusable.
    #[error(transparent)]
    Input(#[from] InputError),
}

fn breakdown(iteration: usize, column: usize, what: &'static str) -> BicgError {
    BicgError::Breakdown {
        iteration,
        column,
        what,
    }
}

// Indices of the per-column sums of the update pass.
const RR: usize = 0; // ‖r‖²
const RHO: usize = 1; // ρ = r̃ᵀ M⁻¹ r
const ZZ: usize = 2; // ‖M⁻¹ r‖²
const RTRT: usize = 3; // ‖r̃‖²
const XX: usize = 4; // ‖x⁽ⁿ⁻¹⁾‖² (weak criterion)

/// Solves `A x = b` for the n×k row-major block `b` (k ≤ [`MAX_COLUMNS`]) with BiCG,
/// starting from and overwriting `x`. `A` (n×n, any sign pattern) must apply its
/// transpose; `precond`: none, or Jacobi (`M = diag(A)`). `ws` keeps the six n×k work
/// blocks between calls.
///
/// One iteration is three parallel passes: the p, p̃ update; both products
/// `q = Ap` and `q̃ = Aᵀp̃` with `p̃ᵀq` and `‖q‖²` ([`BiLinOp::apply_both`]); and one
/// pass updating x, r, r̃ that also accumulates every norm and the next ρ. p and p̃
/// are kept side by side in one n×2k block, and so are q and q̃, so that a gather of
/// row j in the products reads both from one place; [`CsrWithTranspose`] keeps Aᵀ
/// merged with A, so both products are one pass over one pattern. When the operator
/// has a symmetrizer S ([`BiLinOp::symmetrizer`]: `Aᵀ = S A S⁻¹`, the Tutte system)
/// the shadow vectors are kept as `S⁻¹r̃`, `S⁻¹p̃`, `S⁻¹q̃`, and the products are A
/// applied to 2k columns: the same iterates in exact arithmetic, without Aᵀ.
///
/// [`CsrWithTranspose`]: super::CsrWithTranspose
pub fn bicg(
    op: &dyn BiLinOp,
    b: &[f64],
    x: &mut [f64],
    k: usize,
    bicg_params: &BicgParams,
    precond: Option<&Jacobi>,
    ws: &mut Workspace,
) -> Result<BicgInfo, BicgError> {
    // The time includes the hand-over to the pool.
    let start = Instant::now();
    crate::par::on_worker(|| bicg_on_worker(start, op, b, x, k, bicg_params, precond, ws))
}

/// [`bicg()`] on a worker of rayon's pool, timed from `start`.
#[allow(clippy::too_many_arguments)]
fn bicg_on_worker(
    start: Instant,
    op: &dyn BiLinOp,
    b: &[f64],
    x: &mut [f64],
    k: usize,
    bicg_params: &BicgParams,
    precond: Option<&Jacobi>,
    ws: &mut Workspace,
) -> Result<BicgInfo, BicgError> {
    let params = &bicg_params.params;
    krylov::check(op, b, x, k, params)?;
    let n = op.dim();
    if let Some(j) = precond {
        j.check(n)?;
    }
    let dinv = precond.map(Jacobi::inverse);
    // With a symmetrizer S (Aᵀ = S A S⁻¹) the shadow blocks hold r̂ = S⁻¹r̃, p̂ = S⁻¹p̃
    // and q̂ = S⁻¹q̃ = A p̂: the same recurrences (S is diagonal, like M), A in place
    // of Aᵀ, and S as a row weight wherever a shadow vector enters a sum.
    let sym = op.symmetrizer();
    if let Some(s) = sym {
        if s.len() != n {
            return Err(InputError::Block {
                what: "symmetrizer",
                len: s.len(),
                want: n,
            }
            .into());
        }
    }
    // r and r̃ (n×k each) in one allocation; p and p̃ side by side in the n×2k block
    // pp (row i is [p_i | p̃_i]), q = Ap and q̃ in qq: a gather of row j in the
    // products reads both halves from one place.
    let [rr, pp, qq] = ws.blocks::<3>(2 * n * k);
    let (r, rt) = rr.split_at_mut(n * k);
    // r = b − Ax, r̃ = r, ρ₀ and the norms of the initial residual: one pass (p and
    // p̃ are set from r and r̃ by the first iteration, which has β = 0).
    let mut sums = Sums::<5>::default();
    let s0 = match (dinv, sym) {
        (None, None) => op.residual(b, x, r, k, None, Some(rt))?,
        (Some(d), None) => {
            let s0 = op.residual(b, x, r, k, Some(d), None)?;
            krylov::copy(rt, r);
            s0
        }
        (d, Some(s)) => {
            let s0 = op.residual(b, x, r, k, d, None)?;
            // r̂ = S⁻¹r.
            rt.par_iter_mut()
                .zip(r.par_iter())
                .enumerate()
                .for_each(|(j, (h, v))| *h = v / s[j / k]);
            s0
        }
    };
    sums.v[RR] = s0.rr;
    sums.v[RHO] = s0.rz;
    sums.v[ZZ] = s0.zz;
    sums.v[RTRT] = s0.rr;
    let bnorm = krylov::norms_of_b(&s0, k);
    let mut active = krylov::all_active(k);
    let mut rho_prev = [0.0f64; MAX_COLUMNS];
    let mut info = BicgInfo {
        info: Info::new(k),
        plateau_at: vec![None; k],
    };
    // The plateau test reads the history, so it is kept even when not reported.
    let mut history: Vec<Vec<f64>> = vec![Vec::new(); k];
    for c in 0..k {
        history[c].push(sums.v[RR][c].sqrt() / bnorm[c]);
        if sums.v[RR][c] == 0.0 {
            active[c] = false;
        }
    }
    let crit = Criterion::new(params);
    let window = bicg_params.plateau_window;
    let mut it = 0;
    let (mut denom, mut qnorm) = ([0.0; MAX_COLUMNS], [0.0; MAX_COLUMNS]);
    while active.iter().any(|&a| a) && it < params.max_iterations {
        it += 1;
        let mut beta = [0.0f64; MAX_COLUMNS];
        for c in krylov::live(active) {
            let rho = sums.v[RHO][c];
            if krylov::vanished(rho, (sums.v[ZZ][c] * sums.v[RTRT][c]).sqrt()) {
                return Err(breakdown(it, c, "ρ = z̃ᵀr vanished"));
            }
            beta[c] = if it == 1 { 0.0 } else { rho / rho_prev[c] };
        }
        // p = M⁻¹r + βp, p̃ = M⁻ᵀr̃ + βp̃ (M diagonal), with ‖p‖² and ‖p̃‖².
        let (act, first) = (&active, it == 1);
        let pn = pp
            .par_chunks_mut(CHUNK * 2 * k)
            .zip(r.par_chunks(CHUNK * k).zip(rt.par_chunks(CHUNK * k)))
            .enumerate()
            .map(|(blk, (pps, (rs, rts)))| {
                with_columns!(k, K => {
                    let mut s = Sums::<2>::default();
                    for row in 0..rs.len() / K {
                        let di = dinv.map_or(1.0, |d| d[blk * CHUNK + row]);
                        let si = sym.map_or(1.0, |s| s[blk * CHUNK + row]);
                        for c in 0..K {
                            let (j, jp, jt) = (row * K + c, row * 2 * K + c, row * 2 * K + K + c);
                            if first {
                                // β = 0 and the blocks hold no values yet.
                                pps[jp] = di * rs[j];
                                pps[jt] = di * rts[j];
                            } else if act[c] {
                                pps[jp] = di * rs[j] + beta[c] * pps[jp];
                                pps[jt] = di * rts[j] + beta[c] * pps[jt];
                            }
                            let ptv = si * pps[jt];
                            s.v[0][c] += pps[jp] * pps[jp];
                            s.v[1][c] += ptv * ptv;
                        }
                    }
                    s
                })
            })
            .fold_in_order(Sums::default(), Sums::add);
        op.apply_both(pp, qq, k, &mut denom, &mut qnorm);
        let mut alpha = [0.0f64; MAX_COLUMNS];
        for c in krylov::live(active) {
            if krylov::vanished(denom[c], (pn.v[1][c] * qnorm[c]).sqrt()) {
                return Err(breakdown(it, c, "p̃ᵀAp vanished"));
            }
            alpha[c] = sums.v[RHO][c] / denom[c];
            rho_prev[c] = sums.v[RHO][c];
        }
        // x += αp, r -= αq, r̃ -= αq̃, with every norm of the next iteration.
        sums = x
            .par_chunks_mut(CHUNK * k)
            .zip(r.par_chunks_mut(CHUNK * k))
            .zip(rt.par_chunks_mut(CHUNK * k))
            .zip(
                pp.par_chunks(CHUNK * 2 * k)
                    .zip(qq.par_chunks(CHUNK * 2 * k)),
            )
            .enumerate()
            .map(|(blk, (((xs, rs), rts), (pps, qqs)))| {
                with_columns!(k, K => {
                    let mut s = Sums::<5>::default();
                    for row in 0..xs.len() / K {
                        let di = dinv.map_or(1.0, |d| d[blk * CHUNK + row]);
                        let si = sym.map_or(1.0, |s| s[blk * CHUNK + row]);
                        let (mut dx2, mut x2) = (0.0, 0.0);
                        for c in 0..K {
                            let (j, jp, jt) = (row * K + c, row * 2 * K + c, row * 2 * K + K + c);
                            let dx = alpha[c] * pps[jp];
                            krylov::advance(&mut xs[j], dx, &mut s.v[XX][c], &mut x2, &mut dx2);
                            let rv = rs[j] - alpha[c] * qqs[jp];
                            let rtv = rts[j] - alpha[c] * qqs[jt];
                            rs[j] = rv;
                            rts[j] = rtv;
                            // r̃ = S r̂ (S = I without a symmetrizer: the same bits).
                            let rtw = si * rtv;
                            s.v[RR][c] += rv * rv;
                            s.v[RHO][c] += rtw * di * rv;
                            s.v[ZZ][c] += rv * rv * di * di;
                            s.v[RTRT][c] += rtw * rtw;
                        }
                        s.moving += crit.moving(dx2, x2);
                    }
                    s
                })
            })
            .fold_in_order(Sums::default(), Sums::add);
        for c in krylov::live(active) {
            info.info.iterations[c] = it;
            let rr = sums.v[RR][c];
            let h = &mut history[c];
            h.push(rr.sqrt() / bnorm[c]);
            if info.plateau_at[c].is_none()
                && window > 0
                && h.len() > window
                && h[h.len() - 1] > 0.99 * h[h.len() - 1 - window]
            {
                info.plateau_at[c] = Some(it);
            }
            let step2 = alpha[c] * alpha[c] * pn.v[0][c];
            if crit.done(step2, sums.v[XX][c], sums.moving, rr, bnorm[c]) || rr == 0.0 {
                active[c] = false;
            }
        }
    }
    if params.record_history {
        info.info.history = history;
    }
    krylov::finish(&mut info.info, op, x, b, k, start, &mut rr[..n * k])?;
    if active.iter().any(|&a| a) {
        return Err(BicgError::NoConvergence {
            info: Box::new(info),
        });
    }
    Ok(info)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solve::{
        direct::LuSolver, shifted_system, test_util::*, CsrMatrix, CsrWithSymmetrizer,
        CsrWithTranspose, LinOp, Stopping,
    };

    type Solved = Result<BicgInfo, BicgError>;

    /// BiCG with `p` and a fresh workspace.
    fn go(op: &dyn BiLinOp, b: &[f64], x: &mut [f64], k: usize, p: BicgParams) -> Solved {
        bicg(op, b, x, k, &p, None, &mut Workspace::new())
    }

    fn tutte_system(level: usize, lambda: f64) -> (Vec<f64>, CsrWithTranspose) {
        let (m, tl, ..) = irregular(level);
        (
            flat(&m),
            CsrWithTranspose::new(shifted_system(&tl, None, lambda)),
        )
    }

    #[test]
    fn agrees_with_lu_on_the_tutte_system() {
        let (b, op) = tutte_system(3, 30.0);
        let mut want = b.clone();
        LuSolver::new(&op.matrix().to_csc())
            .unwrap()
            .solve_in_place(&mut want, 3)
            .unwrap();
        let jacobi = Jacobi::new(&op).unwrap();
        for pre in [None, Some(&jacobi)] {
            let mut x = b.clone();
            let p = Params {
                stopping: Stopping::Strong,
                tolerance: 1e-10,
                ..Default::default()
            };
            let info = bicg(
                &op,
                &b,
                &mut x,
                3,
                &BicgParams::from(p),
                pre,
                &mut Workspace::new(),
            )
            .unwrap();
            assert!(info.info.residuals.iter().all(|&r| r < 1e-9));
            let err = max_diff(&x, &want);
            assert!(err < 1e-8, "{err}");
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
        let op = CsrWithTranspose::new(CsrMatrix::from_csc(&m));
        let mut x = vec![0.0; 2];
        let e = bicg(
            &op,
            &[1.0, 0.0],
            &mut x,
            1,
            &BicgParams::default(),
            None,
            &mut Workspace::new(),
        )
        .unwrap_err();
        assert!(
            matches!(e, BicgError::Breakdown { iteration: 1, .. }),
            "{e}"
        );
    }

    #[test]
    fn iteration_counts_of_cg_on_sql_and_bicg_on_tl_are_of_the_same_order() {
        let (m, _, sql, ..) = irregular(4);
        let (b, op_t) = tutte_system(4, 30.0);
        let op_s = shifted_system(&sql, None, 30.0);
        let p = Params::default();
        let mut x = b.clone();
        let ib = go(&op_t, &b, &mut x, 3, BicgParams::from(p)).unwrap();
        let mut x = flat(&m);
        let ic = crate::solve::cg(&op_s, &b, &mut x, 3, &p, None, &mut Workspace::new()).unwrap();
        let (mb, mc) = (
            *ib.info.iterations.iter().max().unwrap() as f64,
            *ic.iterations.iter().max().unwrap() as f64,
        );
        assert!(mb / mc < 3.0 && mc / mb < 3.0, "BiCG {mb} vs CG {mc}");
    }

    #[test]
    fn plateau_is_detected_on_an_ill_conditioned_system_and_not_on_a_well_conditioned_one() {
        let n = 400;
        let params = Params {
            stopping: Stopping::Strong,
            tolerance: 1e-8,
            ..Default::default()
        };
        // BiCG on diag(values) from x = 0, b = 1.
        let solve = |values: &[f64], window: usize| {
            let mut x = vec![0.0; n];
            let op = CsrWithTranspose::new(diagonal(values));
            let p = BicgParams {
                params,
                plateau_window: window,
            };
            bicg(
                &op,
                &vec![1.0; n],
                &mut x,
                1,
                &p,
                None,
                &mut Workspace::new(),
            )
            .unwrap()
        };
        // Eigenvalues spread over 1..1e6: the residual stalls for many iterations.
        let spread: Vec<f64> = (0..n)
            .map(|i| 10f64.powf(6.0 * i as f64 / (n - 1) as f64))
            .collect();
        let window = BicgParams::default().plateau_window;
        let info = solve(&spread, window);
        let at = info.plateau_at[0].expect("a plateau on an ill-conditioned system");
        let h = &info.info.history[0];
        assert!(h[at] > 0.99 * h[at - window], "{at}: {h:?}");
        // Eigenvalues in [1, 2]: steady convergence, no plateau.
        let easy: Vec<f64> = (0..n).map(|i| 1.0 + i as f64 / n as f64).collect();
        assert_eq!(solve(&easy, window).plateau_at, vec![None]);
        // Window 0 turns detection off.
        assert_eq!(solve(&spread, 0).plateau_at, vec![None]);
    }

    #[test]
    fn iteration_cap_is_no_convergence() {
        let (b, op) = tutte_system(3, 100.0);
        let mut x = vec![0.0; b.len()];
        let p = Params {
            max_iterations: 3,
            stopping: Stopping::Strong,
            tolerance: 1e-14,
            ..Default::default()
        };
        match go(&op, &b, &mut x, 3, BicgParams::from(p)) {
            Err(BicgError::NoConvergence { info }) => {
                assert_eq!(info.info.iterations, vec![3, 3, 3]);
                assert!(info.info.residuals.iter().all(|&r| r > 1e-14));
                assert_eq!(info.plateau_at.len(), 3);
            }
            other => panic!("{other:?}"),
        }
    }

    /// A non-symmetric operator whose transpose is applied by a different code path
    /// than the product: BiCG must use the transpose capability, or it would solve
    /// with A in place of Aᵀ and lose the bi-orthogonality (and the answer).
    struct Counting<'a, T: BiLinOp> {
        a: &'a T,
        transposes: std::sync::atomic::AtomicUsize,
    }
    impl<T: BiLinOp> LinOp for Counting<'_, T> {
        fn dim(&self) -> usize {
            self.a.dim()
        }
        fn apply(&self, x: &[f64], y: &mut [f64], k: usize) {
            self.a.apply(x, y, k)
        }
    }
    impl<T: BiLinOp> BiLinOp for Counting<'_, T> {
        fn apply_transpose(&self, x: &[f64], y: &mut [f64], k: usize) {
            self.transposes
                .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            self.a.apply_transpose(x, y, k)
        }
        fn symmetrizer(&self) -> Option<&[f64]> {
            self.a.symmetrizer()
        }
    }

    #[test]
    fn the_transpose_capability_is_used_once_per_iteration() {
        let (b, op) = tutte_system(2, 5.0);
        let counting = Counting {
            a: &op,
            transposes: Default::default(),
        };
        let p = Params {
            stopping: Stopping::Strong,
            tolerance: 1e-10,
            ..Default::default()
        };
        let mut x = b.clone();
        let info = go(&counting, &b, &mut x, 3, BicgParams::from(p)).unwrap();
        let its = *info.info.iterations.iter().max().unwrap();
        assert_eq!(counting.transposes.into_inner(), its);
        // The fused matrix kernels (op) iterate as the trait's default passes
        // (counting applies the matrix only).
        let mut y = b.clone();
        let fused = go(&op, &b, &mut y, 3, BicgParams::from(p)).unwrap();
        assert_eq!(fused.info.iterations, info.info.iterations);
        assert!(max_diff(&x, &y) < 1e-12);
    }

    /// The Tutte system of icosphere `level` with its symmetrizer (the degrees, as
    /// `operator::symmetrize` finds them).
    fn tutte_with_symmetrizer(level: usize, lambda: f64) -> (Vec<f64>, CsrWithSymmetrizer) {
        let (m, tl, ..) = irregular(level);
        let s = crate::operator::symmetrize::symmetrizer(&tl).unwrap();
        let op = CsrWithSymmetrizer::new(shifted_system(&tl, None, lambda), s).unwrap();
        (flat(&m), op)
    }

    #[test]
    fn with_a_symmetrizer_bicg_iterates_as_with_the_transpose() {
        // Aᵀ = S A S⁻¹: the shadow vectors kept as S⁻¹p̃ give BiCG's iterates, up to
        // rounding, with one pass over A per iteration; the residual history of the
        // two runs agrees until it nears the rounding floor.
        for (level, lambda) in [(3, 30.0), (4, 100.0)] {
            let (b, sym) = tutte_with_symmetrizer(level, lambda);
            let (_, trans) = tutte_system(level, lambda);
            assert_eq!(sym.matrix(), trans.matrix());
            let jacobi = Jacobi::new(&trans).unwrap();
            for pre in [None, Some(&jacobi)] {
                let p = Params {
                    stopping: Stopping::Strong,
                    tolerance: 1e-10,
                    ..Default::default()
                };
                let run = |op: &dyn BiLinOp| {
                    let mut x = b.clone();
                    let info = bicg(
                        op,
                        &b,
                        &mut x,
                        3,
                        &BicgParams::from(p),
                        pre,
                        &mut Workspace::new(),
                    )
                    .unwrap();
                    (x, info)
                };
                let ((xs, is), (xt, it)) = (run(&sym), run(&trans));
                for c in 0..3 {
                    let (hs, ht) = (&is.info.history[c], &it.info.history[c]);
                    let d = hs.len() as isize - ht.len() as isize;
                    assert!(d.abs() <= 1, "iterations {} vs {}", hs.len(), ht.len());
                    for (u, v) in hs.iter().zip(ht).take_while(|(_, v)| **v > 1e-7) {
                        assert!((u - v).abs() <= 1e-6 * v, "{u} vs {v}");
                    }
                }
                assert!(is.info.residuals.iter().all(|&r| r < 1e-9));
                assert!(max_diff(&xs, &xt) < 1e-8);
            }
        }
    }

    #[test]
    fn the_pair_kernel_iterates_as_the_default_passes_and_no_transpose_is_applied() {
        let (b, op) = tutte_with_symmetrizer(3, 30.0);
        // The trait's default passes (Counting forwards the products and the
        // symmetrizer only), counting transposes: there must be none.
        let default = Counting {
            a: &op,
            transposes: Default::default(),
        };
        let p = Params {
            stopping: Stopping::Strong,
            tolerance: 1e-10,
            ..Default::default()
        };
        let (mut x1, mut x2) = (b.clone(), b.clone());
        let i1 = go(&op, &b, &mut x1, 3, BicgParams::from(p)).unwrap();
        let i2 = go(&default, &b, &mut x2, 3, BicgParams::from(p)).unwrap();
        assert_eq!(default.transposes.into_inner(), 0);
        assert_eq!(i1.info.iterations, i2.info.iterations);
        assert!(max_diff(&x1, &x2) < 1e-12);
    }

    #[test]
    fn a_short_initial_guess_is_an_error() {
        let (b, op) = tutte_system(1, 5.0);
        let mut x = vec![0.0; 5];
        assert!(matches!(
            bicg(
                &op,
                &b,
                &mut x,
                3,
                &BicgParams::from(Params::default()),
                None,
                &mut Workspace::new()
            ),
            Err(BicgError::Input(InputError::InitialGuess { .. }))
        ));
    }
}
