//! The eigenvalue of `K v = λ M v` nearest a shift, with one sparse LDLᵀ of `K − σM`
//! ([`ShiftedFactor`], made by an inertia count): by inverse iteration (Golub & Van
//! Loan, *Matrix Computations*, §8.2.2), or as the Rayleigh quotient of a short block
//! Krylov–Schur run on `(K − σM)⁻¹`.
//!
//! **Sign convention.** Operators are `F = D − W`, positive semi-definite (libigl and
//! pmp use the negative); nothing here assumes definiteness.
//!
//! Used by the property report for `λ_min` when the inertia count says the spectrum
//! starts at zero: a shift `σ` just below zero makes `|λ₀ − σ| / |λ₁ − σ|` tiny even
//! when the low spectrum is tightly clustered (the SSTL `TᵀT` squares the Tutte
//! Laplacian's small eigenvalues), where a Krylov band started at `−10⁻³` of the
//! spectrum's scale cannot separate the smallest pair from the next ones. And for
//! `λ_max` ([`crate::spectral::extremes`]): with σ an inertia-certified upper bound,
//! the Krylov run resolves the top of a clustered spectrum that a Krylov run on `K`
//! itself cannot.

use super::factor::Inertia;
use super::mass::{symmetric_mul, Mass, Metric};
use super::solve::ShiftInvert;
use crate::spectral::krylov_schur::{largest_magnitude, BlockOperator, KrylovSchurParams};
use crate::spectral::SpectralError;
use crate::SparseMatrix;
use faer::Mat;

/// Inverse-iteration steps at most; the iteration stops earlier once the Rayleigh
/// quotient of `A_σ` changes by less than [`CONVERGED`] relatively.
const MAX_STEPS: usize = 100;
/// Relative change of the Rayleigh quotient at which the iteration stops.
const CONVERGED: f64 = 1e-14;

/// The eigenvalue of `K v = λ M v` nearest `sigma` (K symmetric n×n, both triangles
/// stored; M the identity, a positive diagonal or a sparse SPD matrix, see [`Mass`])
/// and its M-normalised eigenvector (length n), by inverse iteration with
/// `(K − σM)⁻¹M` from a fixed start; the eigenvalue is the Rayleigh quotient
/// `vᵀKv / vᵀMv` of the final vector.
///
/// Converges at the rate `|λ_nearest − σ| / |λ_next − σ|` per step; when two
/// eigenvalues are about equally near `sigma`, the result is a vector of their
/// span and its Rayleigh quotient lies between them.
///
/// # Errors
/// As [`super::partial_spectrum`] for the problem's checks; a failed or singular
/// factorization at `sigma` ([`SpectralError::Factorization`]).
pub fn eigenvalue_nearest<'a>(
    k: &SparseMatrix,
    mass: impl Into<Mass<'a>>,
    sigma: f64,
) -> Result<(f64, Vec<f64>), SpectralError> {
    // On a pool worker (see `crate::par::on_worker`): the factorization and the
    // inverse iteration's parallel passes.
    let mass = mass.into();
    crate::par::on_worker(|| {
        let inertia = Inertia::new(k, mass)?;
        match inertia.at(sigma)? {
            Some(factor) => factor.nearest_by_inverse_iteration(),
            None => Err(SpectralError::Empty),
        }
    })
}

/// One numeric LDLᵀ of `K − σM` (from an [`Inertia`]'s shared symbolic analysis) as
/// the operator `A_σ = M^{1/2} (K − σM)^{-1} M^{1/2}`, with the inertia count it
/// gives for free: the property report counts, then asks the same factorization for
/// the eigenvalue nearest σ. Sign convention: `K` is the positive semi-definite
/// `F = D − W` of the paper (libigl and pmp use the negative); nothing here assumes
/// definiteness.
pub(crate) struct ShiftedFactor<'a> {
    pub(super) op: ShiftInvert<'a>,
    /// `K` (the shifted pattern's base: `K` plus explicit zeros where `M` has entries).
    pub(super) k: &'a SparseMatrix,
    pub(super) metric: &'a Metric,
    /// Eigenvalues strictly below σ (negative pivots).
    pub(super) below: usize,
}

impl ShiftedFactor<'_> {
    /// The number of eigenvalues strictly below σ (up to the factorization's rounding,
    /// see [`super::eigenvalues_below`]).
    pub(crate) fn below(&self) -> usize {
        self.below
    }

    /// [`eigenvalue_nearest`] with this factorization.
    pub(crate) fn nearest_by_inverse_iteration(&self) -> Result<(f64, Vec<f64>), SpectralError> {
        let n = self.op.dim();
        // Fixed, non-special start (no eigenvector of a symmetric mesh operator).
        let mut w = Mat::<f64>::from_fn(n, 1, |i, _| {
            1.0 + ((i as f64 + 1.0) * 0.618_033_988_749_895).fract()
        });
        let mut y = Mat::<f64>::zeros(n, 1);
        let mut mu_old = f64::NAN;
        for _ in 0..MAX_STEPS {
            let norm = crate::spectral::thin_products::col_norm2(w.col(0));
            if !(norm.is_finite() && norm > 0.0) {
                return Err(SpectralError::NoConvergence {
                    path: "inverse iteration",
                });
            }
            w.col_mut(0).iter_mut().for_each(|x| *x /= norm);
            self.op.apply_block(w.as_ref(), y.as_mut());
            let mu: f64 = w
                .col(0)
                .iter()
                .zip(y.col(0).iter())
                .map(|(a, b)| a * b)
                .sum();
            std::mem::swap(&mut w, &mut y);
            if (mu - mu_old).abs() <= CONVERGED * mu.abs() {
                break;
            }
            mu_old = mu;
        }
        self.rayleigh(w, "inverse iteration")
    }

    /// The Rayleigh quotient `vᵀKv / vᵀMv` of the Ritz vector of the eigenvalue nearest
    /// σ, by block Krylov–Schur on `A_σ` (blocks of 4, so that a multiple eigenvalue
    /// of up to that multiplicity is taken whole; residual `≤ tolerance·|μ|`). A
    /// Rayleigh quotient never exceeds `λ_max` nor falls below `λ_min`, so it is a
    /// bound whichever eigenvalue the run found; with a residual η in `K`'s terms it
    /// lies within `η²/gap` of the eigenvalue. Converges fast however clustered the
    /// spectrum is near σ, as long as σ is nearer the wanted eigenvalue than the
    /// cluster's spacing is small: the ratio that matters is
    /// `|λ₁ − λ₂| / |λ₁ − σ|`. `None` when the run does not converge within its
    /// restarts or the problem is too small for its basis.
    pub(crate) fn nearest_by_krylov(&self, tolerance: f64) -> Result<Option<f64>, SpectralError> {
        let n = self.op.dim();
        let block = if n >= 64 { 4 } else { 1 };
        let params = KrylovSchurParams {
            block,
            max_dim: 60.min(n.saturating_sub(block)),
            tolerance,
            max_restarts: 60,
            seed: 0x6e65_6172,
        };
        let Ok(top) = largest_magnitude(&self.op, 1, None, &params) else {
            return Ok(None);
        };
        let w = top.vectors.subcols(0, 1).to_owned();
        Ok(Some(self.rayleigh(w, "shift-invert Krylov–Schur")?.0))
    }

    /// `(vᵀKv / vᵀMv, v)` for `v = C⁻ᵀ w` (`M^{-1/2} w`), M-normalised, from the n×1
    /// symmetric-coordinates vector `w`; a non-finite quotient is an error of `path`.
    fn rayleigh(
        &self,
        mut w: Mat<f64>,
        path: &'static str,
    ) -> Result<(f64, Vec<f64>), SpectralError> {
        self.metric.solve_ct(w.as_mut());
        let mut v: Vec<f64> = w.col(0).iter().copied().collect();
        let mv = self.metric.mul_m(&v);
        let vmv: f64 = v.iter().zip(&mv).map(|(a, b)| a * b).sum();
        let kv = symmetric_mul(self.k, &v);
        let vkv: f64 = v.iter().zip(&kv).map(|(a, b)| a * b).sum();
        if !(vmv.is_finite() && vmv > 0.0 && vkv.is_finite()) {
            return Err(SpectralError::NoConvergence { path });
        }
        let scale = 1.0 / vmv.sqrt();
        v.iter_mut().for_each(|x| *x *= scale);
        Ok((vkv / vmv, v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{builtin, topology::Topology};
    use crate::operator::{Operator, OperatorKind, OperatorOptions};
    use crate::spectral::partial::{partial_spectrum, PartialParams};

    #[test]
    fn nearest_eigenvalue_matches_the_partial_spectrum() {
        let mesh = builtin::torus(24, 16).unwrap();
        let topo = Topology::new(&mesh).unwrap();
        for kind in [OperatorKind::Kirchhoff, OperatorKind::Sstl] {
            let op = Operator::assemble(kind, &mesh, &topo, &OperatorOptions::default()).unwrap();
            let k = &op.matrix;
            let all = partial_spectrum(k, None, &PartialParams::new(6), &mut |_, _| {}).unwrap();
            // Just below zero: the (simple) zero eigenvalue and the constant vector.
            let (l0, v0) = eigenvalue_nearest(k, None, -1e-12).unwrap();
            assert!(l0.abs() < 1e-12, "{kind}: {l0}");
            let c = v0[0];
            assert!(v0.iter().all(|x| (x - c).abs() < 1e-9 * c.abs()), "{kind}");
            // Between the first two nonzero eigenvalues, nearer the lower one.
            let (a, b) = (all.eigenvalues[1], all.eigenvalues[3]);
            if b - a > 1e-6 * b {
                let (l, v) = eigenvalue_nearest(k, None, a + 0.1 * (b - a)).unwrap();
                assert!((l - a).abs() < 1e-10 * b, "{kind}: {l} vs {a}");
                let kv = symmetric_mul(k, &v);
                let res = kv
                    .iter()
                    .zip(&v)
                    .map(|(p, q)| (p - l * q).powi(2))
                    .sum::<f64>()
                    .sqrt();
                assert!(res < 1e-6 * b, "{kind}: residual {res}");
            }
        }
    }

    #[test]
    fn with_a_mass_the_vector_is_m_normalised() {
        let mesh = builtin::icosphere(3).unwrap();
        let topo = Topology::new(&mesh).unwrap();
        let op = Operator::assemble(
            OperatorKind::Cotan,
            &mesh,
            &topo,
            &OperatorOptions::default(),
        )
        .unwrap();
        let mass = op.mass.clone().expect("the cotangent has a mass");
        let (l, v) = eigenvalue_nearest(&op.matrix, Some(&mass[..]), -1e-12).unwrap();
        assert!(l.abs() < 1e-10, "{l}");
        let vmv: f64 = v.iter().zip(&mass).map(|(a, b)| a * a * b).sum();
        assert!((vmv - 1.0).abs() < 1e-12, "{vmv}");
    }
}
