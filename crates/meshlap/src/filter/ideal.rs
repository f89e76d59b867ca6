//! Ideal low-pass filter through the dense eigenvalue-decomposition (ED) transform
//! (Zhang 2004 §2.6; Taubin 1995): keep the spectral components with eigenvalue
//! γ ≤ γ_PB, drop the rest. Needs every eigenvector, so O(n³) time and O(n²) memory:
//! small meshes only ([`IdealOptions::dense_limit`]).
//!
//! For a symmetric F (`F = D − W` sign) the ED basis is orthonormal and the filter is
//! the orthogonal projection `U_≤ U_≤ᵀ x`. For an F with a positive diagonal
//! symmetrizer S (`S·F` symmetric, e.g. the Tutte Laplacian with S = D), F is similar
//! to the symmetric `S^{1/2} F S^{-1/2}` = `U Γ Uᵀ`; its eigenvectors are
//! `S^{-1/2} U`, and the filter is `S^{-1/2} U_≤ U_≤ᵀ S^{1/2} x` (the S-orthogonal
//! projection). Positions are the n×3 row-major block.

use super::{Filter, FilterError, IdealOptions};
use crate::operator::symmetrize::{diagonal_symmetrizer, symmetrized_dense, Scaling};
use crate::SparseMatrix;
use faer::Mat;

/// The ideal low-pass `opts` of the n×3 row-major `x` under the n×n operator `f`
/// (`F = D − W`, symmetric or with a positive diagonal symmetrizer); returns the
/// filtered block.
///
/// # Errors
/// A pass-band that is not a number ≥ 0; `x` not n×3; n above `opts.dense_limit`
/// ([`FilterError::TooLarge`]); F without a symmetrizer; a dense eigensolver that does
/// not converge.
pub fn ideal_lowpass(
    f: &SparseMatrix,
    x: &[f64],
    opts: &IdealOptions,
) -> Result<Vec<f64>, FilterError> {
    let n = f.nrows();
    if x.len() != 3 * n || f.ncols() != n {
        return Err(FilterError::Positions { len: x.len(), n });
    }
    Filter::Ideal(*opts).validate()?;
    let passband = opts.passband;
    if n > opts.dense_limit {
        return Err(FilterError::TooLarge {
            n,
            limit: opts.dense_limit,
        });
    }
    let s = diagonal_symmetrizer(f).ok_or(FilterError::NoSymmetrizer {
        what: "the ideal low-pass",
    })?;
    let r: Vec<f64> = s.iter().map(|v| v.sqrt()).collect();
    let evd = symmetrized_dense(f, Scaling::Similarity(&s))
        .self_adjoint_eigen(faer::Side::Lower)
        .map_err(|_| FilterError::EigenNoConvergence)?;
    let kept = evd
        .S()
        .column_vector()
        .iter()
        .filter(|&&g| g <= passband)
        .count();
    // Eigenvalues come ascending: the kept ones are the first `kept` columns.
    let u = evd.U().subcols(0, kept);
    let xs = Mat::from_fn(n, 3, |i, c| r[i] * x[3 * i + c]);
    let coef = u.transpose() * &xs;
    let y = u * &coef;
    Ok((0..n)
        .flat_map(|i| (0..3).map(move |c| (i, c)))
        .map(|(i, c)| y[(i, c)] / r[i])
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::test_util::{bumpy_sphere, positions};
    use crate::operator::{kirchhoff::kirchhoff, tutte::tutte};

    fn lowpass(f: &SparseMatrix, x: &[f64], passband: f64) -> Vec<f64> {
        ideal_lowpass(f, x, &IdealOptions::new(passband)).unwrap()
    }

    #[test]
    fn extreme_pass_bands_are_identity_and_weighted_centroid() {
        let (m, t) = bumpy_sphere();
        let x = positions(&m);
        let same = lowpass(&kirchhoff(&t), &x, 1e9);
        assert!(same.iter().zip(&x).all(|(a, b)| (a - b).abs() < 1e-10));
        // Only γ = 0 kept: for the TL the S-orthogonal projection onto constants is the
        // degree-weighted centroid Σ dᵢxᵢ / Σ dᵢ.
        let d: Vec<f64> = t.degrees().iter().map(|&v| v as f64).collect();
        let dsum: f64 = d.iter().sum();
        let c: Vec<f64> = (0..3)
            .map(|k| (0..d.len()).map(|i| d[i] * x[3 * i + k]).sum::<f64>() / dsum)
            .collect();
        let flat = lowpass(&tutte(&t).unwrap(), &x, 1e-9);
        for (j, v) in flat.iter().enumerate() {
            assert!((v - c[j % 3]).abs() < 1e-10, "{v} vs {}", c[j % 3]);
        }
    }

    #[test]
    fn is_a_projection() {
        let (m, t) = bumpy_sphere();
        let x = positions(&m);
        let f = tutte(&t).unwrap();
        let once = lowpass(&f, &x, 0.5);
        let twice = lowpass(&f, &once, 0.5);
        assert!(once.iter().zip(&twice).all(|(a, b)| (a - b).abs() < 1e-10));
        let diff: f64 = once.iter().zip(&x).map(|(a, b)| (a - b).abs()).sum();
        assert!(diff > 1e-3, "a mid pass-band must change a bumpy mesh");
    }

    #[test]
    fn bad_input_is_a_typed_error() {
        let (m, t) = bumpy_sphere();
        let x = positions(&m);
        let f = tutte(&t).unwrap();
        let opts = |passband, dense_limit| IdealOptions {
            passband,
            dense_limit,
        };
        assert!(matches!(
            ideal_lowpass(&f, &x, &opts(f64::NAN, 3000)),
            Err(FilterError::NotNonNegative { .. })
        ));
        assert!(matches!(
            ideal_lowpass(&f, &x, &opts(0.5, 100)),
            Err(FilterError::TooLarge { limit: 100, .. })
        ));
        assert!(matches!(
            ideal_lowpass(&f, &x[3..], &opts(0.5, 3000)),
            Err(FilterError::Positions { .. })
        ));
        // A non-symmetric pattern has no diagonal symmetrizer.
        let n = m.n_vertices();
        let trip: Vec<_> = (0..n)
            .map(|i| faer::sparse::Triplet::new(i, (i + 1) % n, 1.0))
            .collect();
        let shift = SparseMatrix::try_new_from_triplets(n, n, &trip).unwrap();
        assert!(matches!(
            ideal_lowpass(&shift, &x, &opts(0.5, 3000)),
            Err(FilterError::NoSymmetrizer { .. })
        ));
    }
}
