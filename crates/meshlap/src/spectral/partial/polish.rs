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
//!    nearly orthonormal, so `G` is well conditioned) and `H = Yᵀ Â Y`, computed as
//!    `XᵀK X` with `X = C⁻ᵀY` (`Â = C⁻¹ K C⁻ᵀ`, `C = M^{1/2}` for a diagonal `M`);
//! 3. `L⁻¹ H L⁻ᵀ = U Θ Uᵀ` (b×b, symmetrised; faer's dense self-adjoint
//!    eigensolver), and the pairs `(θᵢ, Y L⁻ᵀ uᵢ)` (normalised), the vectors formed as
//!    `Cᵀ(X L⁻ᵀ uᵢ)`.
//!
//! This is Rayleigh–Ritz refinement as in Saad, *Numerical Methods for Large
//! Eigenvalue Problems* (2011), §5.2 (subspace iteration with projection). It costs
//! b solves, three n×b×b products and a b×b eigenproblem per band, in two n×b work
//! matrices: `K X` overwrites `Y`, which `Cᵀ X` gives back, and the refined vectors
//! stay in the work matrices until the caller has checked their values, then
//! overwrite the band's own vectors ([`replace_with_refined`]). A third n×b matrix
//! for `K X` and new columns for the result took memory the process had not used
//! before (slow on a VM: the first touch of each page) and raised the peak memory;
//! measured on the million-vertex torus in BENCHMARKS.md ("Partial spectra and
//! partitioning", forty-sixth session).

use super::mass::{symmetric_mul_block, Metric};
use super::solve::ShiftInvert;
use crate::spectral::krylov_schur::BlockOperator;
use crate::spectral::thin_products::{nn_in_place, tn};
use crate::SparseMatrix;
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::{Col, Mat, MatRef, Par, Side};

/// The refined eigenvalues θ (ascending) of the band's pairs `found` (symmetric
/// coordinates, n×1 each, b pairs), with their unit vectors left in the first b
/// columns of `work` (column j for θ_j); or `None` when the refinement cannot be
/// trusted (a rank-deficient product, a failed eigensolve, or non-finite values) and
/// the Krylov–Schur pairs should be kept. [`replace_with_refined`] moves the result
/// into `found`.
///
/// `work` is scratch storage: its first 2b columns hold the two n×b work matrices
/// when it has n rows and at least 2b columns (the band's Krylov–Schur basis, which
/// has about 2.5 b), else it is replaced by a new n×2b matrix. Its contents on entry
/// do not matter (every entry used is written first); on return its first b
/// columns hold the refined vectors and the rest is unspecified.
pub(super) fn polish(
    op: &ShiftInvert<'_>,
    k: &SparseMatrix,
    metric: &Metric,
    found: &[(f64, Col<f64>)],
    work: &mut Mat<f64>,
) -> Option<Vec<f64>> {
    let n = op.dim();
    let b = found.len();
    if b == 0 || b >= n {
        return None;
    }
    // Two n×b work matrices in `work`: `x` holds W, then X = C⁻ᵀY, then the new
    // vectors (in place); `y` holds Y, then K X.
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
    // YᵀÂY = XᵀK X with X = C⁻ᵀY; K X overwrites Y (given back below as Cᵀ X).
    x.copy_from(y.as_ref());
    metric.solve_ct(x.as_mut());
    symmetric_mul_block(k, x.as_ref(), y.as_mut());
    let h = tn(x.as_ref(), y.as_ref());
    // Ĥ = L⁻¹ H L⁻ᵀ (H symmetrised), by two triangular solves.
    let mut hh = Mat::from_fn(b, b, |i, j| 0.5 * (h[(i, j)] + h[(j, i)]));
    solve_lower_triangular_in_place(l, hh.as_mut(), Par::Seq);
    let mut hh = hh.transpose().to_owned();
    solve_lower_triangular_in_place(l, hh.as_mut(), Par::Seq);
    let hs = Mat::from_fn(b, b, |i, j| 0.5 * (hh[(i, j)] + hh[(j, i)]));
    let evd = hs.self_adjoint_eigen(Side::Lower).ok()?;
    // Coefficients L⁻ᵀ U, then the vectors Y L⁻ᵀ U = Cᵀ (X L⁻ᵀ U), normalised.
    let mut c = evd.U().to_owned();
    solve_upper_triangular_in_place(l.transpose(), c.as_mut(), Par::Seq);
    nn_in_place(x.as_mut(), c.as_ref());
    metric.mul_ct(x.as_mut());
    let s = evd.S();
    let mut values = Vec::with_capacity(b);
    for j in 0..b {
        let theta = s[j];
        let norm = crate::spectral::thin_products::col_norm2(x.as_ref().col(j));
        if !(theta.is_finite() && norm.is_finite() && norm > 0.0) {
            return None;
        }
        x.as_mut().col_mut(j).iter_mut().for_each(|v| *v /= norm);
        values.push(theta);
    }
    Some(values)
}

/// Overwrites the band's pairs `found` with the refined ones of [`polish`]: θ_j from
/// `values` and the vector from column j of `work` (the order of `values`), into
/// `found[j]`'s own storage (no new n-vectors).
///
/// # Panics
/// If `values`, `found` and `work`'s leading columns disagree in count or length
/// (a caller's bug: `polish` returned `values` for this `found` and `work`).
pub(super) fn replace_with_refined(
    found: &mut [(f64, Col<f64>)],
    values: &[f64],
    work: MatRef<'_, f64>,
) {
    assert_eq!(found.len(), values.len(), "one refined value per pair");
    for (j, ((l, w), &theta)) in found.iter_mut().zip(values).enumerate() {
        *l = theta;
        w.copy_from(work.col(j));
    }
}
