//! The eigenvalue of `K v = λ M v` nearest a shift, by inverse iteration with one
//! sparse LDLᵀ of `K − σM` (Golub & Van Loan, *Matrix Computations*, §8.2.2).
//!
//! **Sign convention.** Operators are `F = D − W`, positive semi-definite (libigl and
//! pmp use the negative); nothing here assumes definiteness.
//!
//! Used by the property report for `λ_min` when the inertia count says the spectrum
//! starts at zero: a shift `σ` just below zero makes `|λ₀ − σ| / |λ₁ − σ|` tiny even
//! when the low spectrum is tightly clustered (the SSTL `TᵀT` squares the Tutte
//! Laplacian's small eigenvalues), where a Krylov band started at `−10⁻³` of the
//! spectrum's scale cannot separate the smallest pair from the next ones.

use super::factor::{factor_at, symbolic_of, ShiftedPattern};
use super::mass::{symmetric_mul, Mass};
use super::solve::{ShiftInvert, TreeSplit, TREE_SPLIT_MIN_DIM};
use crate::spectral::krylov_schur::BlockOperator;
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
    crate::par::on_worker(|| nearest_on_worker(k, mass, sigma))
}

fn nearest_on_worker(
    k: &SparseMatrix,
    mass: Mass<'_>,
    sigma: f64,
) -> Result<(f64, Vec<f64>), SpectralError> {
    let metric = super::check_problem(k, mass)?;
    let n = k.nrows();
    if n == 0 {
        return Err(SpectralError::Empty);
    }
    let pattern = ShiftedPattern::new(k, &metric)?;
    let symbolic = symbolic_of(&pattern)?;
    let values = factor_at(&pattern, &symbolic, sigma)?;
    let mut ones = Vec::new();
    let msqrt = ShiftInvert::scale_of(&metric, &mut ones);
    let op = ShiftInvert {
        symbolic: &symbolic,
        values,
        metric: &metric,
        msqrt,
        split: TreeSplit::of(&symbolic, TREE_SPLIT_MIN_DIM),
        scratch: Default::default(),
    };
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
        op.apply_block(w.as_ref(), y.as_mut());
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
    // v = C⁻ᵀ w (M^{-1/2} w), M-normalised; λ = vᵀKv / vᵀMv.
    metric.solve_ct(w.as_mut());
    let mut v: Vec<f64> = w.col(0).iter().copied().collect();
    let mv = metric.mul_m(&v);
    let vmv: f64 = v.iter().zip(&mv).map(|(a, b)| a * b).sum();
    let kv = symmetric_mul(k, &v);
    let vkv: f64 = v.iter().zip(&kv).map(|(a, b)| a * b).sum();
    if !(vmv.is_finite() && vmv > 0.0 && vkv.is_finite()) {
        return Err(SpectralError::NoConvergence {
            path: "inverse iteration",
        });
    }
    let scale = 1.0 / vmv.sqrt();
    v.iter_mut().for_each(|x| *x *= scale);
    Ok((vkv / vmv, v))
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
