//! One step of subspace iteration and a Rayleigh–Ritz step on a band's vectors.
//!
//! The Krylov–Schur pairs of a band meet their tolerance on `A_σ`, but their vectors
//! keep a small error in the *high-frequency* eigenvectors (far from σ): rounding in
//! the solves and the restarts, which the convergence test on `A_σ` (whose
//! eigenvalues there are tiny) does not see. It leaves the residuals of
//! `Â w = λ w` (`Â = M^{-1/2} K M^{-1/2}`, or `C⁻¹ K C⁻ᵀ` for a sparse `M`) at about
//! `10⁻¹³` on the bunny's SQL whatever the tolerance, 60x ARPACK's. One product with
//! `A_σ` (already factored) damps those components by `|λ_kept − σ| / |λ_far − σ|`,
//! and the Rayleigh–Ritz step with `Â` itself (not `A_σ`) then takes the best pairs in
//! the new subspace:
//!
//! 1. `Y = A_σ W` for the band's vectors `W` (n×b);
//! 2. `Q` = an orthonormal basis of `Y` (Householder QR, faer);
//! 3. `H = Qᵀ Â Q` (b×b, symmetrised), `H = U Θ Uᵀ` (faer's dense self-adjoint
//!    eigensolver), and the pairs `(θᵢ, Q uᵢ)`.
//!
//! This is Rayleigh–Ritz refinement as in Saad, *Numerical Methods for Large
//! Eigenvalue Problems* (2011), §5.2 (subspace iteration with projection). It costs
//! b solves, two n×b×b products and a b×b eigenproblem per band.

use super::mass::Metric;
use super::solve::ShiftInvert;
use crate::spectral::krylov_schur::BlockOperator;
use crate::SparseMatrix;
use faer::linalg::matmul::matmul;
use faer::reborrow::ReborrowMut;
use faer::{Accum, Col, Mat, Par, Side};

/// The refined pairs `(θ, w)` (ascending θ, `‖w‖ = 1`) of the band's pairs `found`
/// (symmetric coordinates), or `None` when the refinement cannot be trusted (a
/// rank-deficient product, a failed eigensolve, or non-finite values) and the
/// Krylov–Schur pairs should be kept.
pub(super) fn polish(
    op: &ShiftInvert<'_>,
    k: &SparseMatrix,
    metric: &Metric,
    found: &[(f64, Col<f64>)],
) -> Option<Vec<(f64, Col<f64>)>> {
    let n = op.dim();
    let b = found.len();
    if b == 0 || b >= n {
        return None;
    }
    let w = Mat::from_fn(n, b, |i, j| found[j].1[i]);
    let mut y = Mat::<f64>::zeros(n, b);
    op.apply_block(w.as_ref(), y.as_mut());
    // Scale each column back to unit length (the columns of A_σ W are the μ-scaled
    // w's), so that the QR sees a well-conditioned block.
    for j in 0..b {
        let nj = y.col(j).norm_l2();
        if !(nj.is_finite() && nj > 0.0) {
            return None;
        }
        y.col_mut(j).iter_mut().for_each(|x| *x /= nj);
    }
    let q = y.qr().compute_thin_Q();
    // Â Q: x = M^{-1/2} Q (C⁻ᵀ Q), K x, then M^{-1/2} (C⁻¹) again.
    let mut x = q.clone();
    scale_or_solve(metric, x.as_mut(), Side::Upper);
    let mut kx = Mat::<f64>::zeros(n, b);
    faer::sparse::linalg::matmul::sparse_dense_matmul(
        kx.as_mut(),
        Accum::Replace,
        k.as_ref(),
        x.as_ref(),
        1.0,
        Par::rayon(0),
    );
    scale_or_solve(metric, kx.as_mut(), Side::Lower);
    let mut h = Mat::<f64>::zeros(b, b);
    matmul(
        h.as_mut(),
        Accum::Replace,
        q.transpose(),
        kx.as_ref(),
        1.0,
        Par::rayon(0),
    );
    let hs = Mat::from_fn(b, b, |i, j| 0.5 * (h[(i, j)] + h[(j, i)]));
    let evd = hs.self_adjoint_eigen(Side::Lower).ok()?;
    let u = evd.U();
    let mut wn = Mat::<f64>::zeros(n, b);
    matmul(
        wn.as_mut(),
        Accum::Replace,
        q.as_ref(),
        u,
        1.0,
        Par::rayon(0),
    );
    let s = evd.S();
    let mut out = Vec::with_capacity(b);
    for j in 0..b {
        let theta = s[j];
        let col = wn.col(j).to_owned();
        if !theta.is_finite() || col.iter().any(|v| !v.is_finite()) {
            return None;
        }
        out.push((theta, col));
    }
    Some(out)
}

/// `x ← M^{-1/2} x` for a diagonal `M`; for a sparse `M = C Cᵀ`, `x ← C⁻ᵀ x`
/// (`Side::Upper`, before `K`) or `x ← C⁻¹ x` (`Side::Lower`, after it).
fn scale_or_solve(metric: &Metric, mut x: faer::MatMut<'_, f64>, side: Side) {
    match metric.diagonal_sqrt() {
        Some(msqrt) => {
            for j in 0..x.ncols() {
                for (i, v) in x.rb_mut().col_mut(j).iter_mut().enumerate() {
                    *v /= msqrt[i];
                }
            }
        }
        None => match side {
            Side::Upper => metric.solve_ct(x),
            Side::Lower => metric.solve_c(x),
        },
    }
}
