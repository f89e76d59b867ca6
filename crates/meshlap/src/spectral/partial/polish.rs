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
//! 2. with the columns of `Y` normalised, `G = YᵀY = L Lᵀ` (Cholesky; `Y` is
//!    nearly orthonormal, so `G` is well conditioned) and `H = Yᵀ Â Y`;
//! 3. `L⁻¹ H L⁻ᵀ = U Θ Uᵀ` (b×b, symmetrised; faer's dense self-adjoint
//!    eigensolver), and the pairs `(θᵢ, Y L⁻ᵀ uᵢ)` (normalised).
//!
//! This is Rayleigh–Ritz refinement as in Saad, *Numerical Methods for Large
//! Eigenvalue Problems* (2011), §5.2 (subspace iteration with projection). It costs
//! b solves, three n×b×b products and a b×b eigenproblem per band.

use super::mass::Metric;
use super::solve::ShiftInvert;
use crate::spectral::krylov_schur::BlockOperator;
use crate::spectral::thin_products::{by_column_halves, nn_in_place, tn};
use crate::SparseMatrix;
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::{Accum, Col, Mat, Par, Side};

/// The refined pairs `(θ, w)` (ascending θ, `‖w‖ = 1`) of the band's pairs `found`
/// (symmetric coordinates), or `None` when the refinement cannot be trusted (a
/// rank-deficient product, a failed eigensolve, or non-finite values) and the
/// Krylov–Schur pairs should be kept.
///
/// `work` is scratch storage: its first 2b columns hold the two n×b work matrices
/// when it has n rows and at least 2b columns (the band's Krylov–Schur basis, which
/// has about 2.5 b), else it is replaced by a new n×2b matrix. Its contents on entry
/// do not matter (every entry used is written first) and are unspecified on return.
pub(super) fn polish(
    op: &ShiftInvert<'_>,
    k: &SparseMatrix,
    metric: &Metric,
    found: &[(f64, Col<f64>)],
    work: &mut Mat<f64>,
) -> Option<Vec<(f64, Col<f64>)>> {
    let n = op.dim();
    let b = found.len();
    if b == 0 || b >= n {
        return None;
    }
    // Two n×b work matrices in `work`: `x` holds W, then C⁻ᵀY; `y` holds Y, then
    // the new vectors (in place). With the product K C⁻ᵀY and the output, at most
    // four n×b matrices are alive besides `found`.
    crate::spectral::krylov_schur::reuse_or_zeroed(work, n, 2 * b);
    let (mut x, mut y) = work.as_mut().subcols_mut(0, 2 * b).split_at_col_mut(b);
    for (j, (_, w)) in found.iter().enumerate() {
        x.as_mut().col_mut(j).copy_from(w);
    }
    op.apply_block(x.as_ref(), y.as_mut());
    // Scale each column back to unit length (the columns of A_σ W are the μ-scaled
    // w's), so that the QR sees a well-conditioned block.
    for j in 0..b {
        let nj = crate::spectral::thin_products::col_norm2(y.as_ref().col(j));
        if !(nj.is_finite() && nj > 0.0) {
            return None;
        }
        y.as_mut().col_mut(j).iter_mut().for_each(|x| *x /= nj);
    }
    // Rayleigh–Ritz on span(Y): Y's normalised columns are nearly orthonormal (A_σ
    // maps the nearly orthonormal W to μ-scaled, nearly orthogonal columns), so the
    // Gram matrix G = YᵀY is well conditioned and G = L Lᵀ replaces an explicit QR:
    // Ĥ = L⁻¹ (YᵀÂY) L⁻ᵀ = U Θ Uᵀ and the vectors are Y L⁻ᵀ U. Three n×b×b products
    // instead of a Householder QR and two products. A Cholesky failure (a
    // rank-deficient Y) keeps the Krylov–Schur pairs.
    // Every product is deterministic for a given thread count (a fixed split of rows
    // or columns, each part on one thread), unlike faer's parallel GEMM: the results
    // must not change from run to run.
    let g = tn(y.as_ref(), y.as_ref());
    let llt = g.llt(Side::Lower).ok()?;
    let l = llt.L();
    // Â Y: x = M^{-1/2} Y (C⁻ᵀ Y), K x, then M^{-1/2} (C⁻¹) again.
    x.copy_from(y.as_ref());
    metric.solve_ct(x.as_mut());
    let mut kx = crate::mem::zeroed_mat(n, b);
    // Split by columns (each column's product alone, in one order).
    by_column_halves(
        kx.as_mut(),
        x.as_ref(),
        rayon::current_num_threads(),
        2,
        &|out, x| {
            faer::sparse::linalg::matmul::sparse_dense_matmul(
                out,
                Accum::Replace,
                k.as_ref(),
                x,
                1.0,
                Par::Seq,
            )
        },
    );
    metric.solve_c(kx.as_mut());
    let h = tn(y.as_ref(), kx.as_ref());
    drop(kx);
    // Ĥ = L⁻¹ H L⁻ᵀ (H symmetrised), by two triangular solves.
    let mut hh = Mat::from_fn(b, b, |i, j| 0.5 * (h[(i, j)] + h[(j, i)]));
    solve_lower_triangular_in_place(l, hh.as_mut(), Par::Seq);
    let mut hh = hh.transpose().to_owned();
    solve_lower_triangular_in_place(l, hh.as_mut(), Par::Seq);
    let hs = Mat::from_fn(b, b, |i, j| 0.5 * (hh[(i, j)] + hh[(j, i)]));
    let evd = hs.self_adjoint_eigen(Side::Lower).ok()?;
    // Coefficients C = L⁻ᵀ U, then the vectors Y C (normalised below).
    let mut c = evd.U().to_owned();
    solve_upper_triangular_in_place(l.transpose(), c.as_mut(), Par::Seq);
    nn_in_place(y.as_mut(), c.as_ref());
    let s = evd.S();
    let mut out = Vec::with_capacity(b);
    for j in 0..b {
        let theta = s[j];
        let mut col = y.as_ref().col(j).to_owned();
        let norm = crate::spectral::thin_products::col_norm2(col.as_ref());
        if !(theta.is_finite() && norm.is_finite() && norm > 0.0) {
            return None;
        }
        col.iter_mut().for_each(|v| *v /= norm);
        out.push((theta, col));
    }
    Some(out)
}
