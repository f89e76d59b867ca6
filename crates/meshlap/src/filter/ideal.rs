//! Ideal low-pass filter through the dense eigenvalue-decomposition (ED) transform
//! (Zhang 2004 §2.6; Taubin 1995): keep the spectral components with eigenvalue
//! γ ≤ γ_PB, drop the rest. Needs every eigenvector, so O(n³) time and O(n²) memory:
//! small meshes only (the caller enforces a size limit).
//!
//! For a symmetric F (`F = D − W` sign) the ED basis is orthonormal and the filter is
//! the orthogonal projection `U_≤ U_≤ᵀ x`. For an F with a positive diagonal
//! symmetriser S (`S·F` symmetric, e.g. the Tutte Laplacian with S = D), F is similar
//! to the symmetric `S^{1/2} F S^{-1/2}` = `U Γ Uᵀ`; its eigenvectors are
//! `S^{-1/2} U`, and the filter is `S^{-1/2} U_≤ U_≤ᵀ S^{1/2} x` (the S-orthogonal
//! projection). Positions are the n×3 row-major block.

use super::FilterError;
use crate::analysis::properties::{diagonal_symmetrizer, symmetrized_dense};
use crate::SparseMatrix;
use faer::Mat;

/// The ideal low-pass of the n×3 row-major `x`; returns the filtered block.
pub fn ideal_lowpass(f: &SparseMatrix, x: &[f64], passband: f64) -> Result<Vec<f64>, FilterError> {
    let n = f.nrows();
    if x.len() != 3 * n {
        return Err(FilterError::InvalidParameter(format!(
            "{} coordinates for {n} vertices",
            x.len()
        )));
    }
    if passband.is_nan() {
        return Err(FilterError::InvalidParameter("pass-band is NaN".into()));
    }
    let s = diagonal_symmetrizer(f).ok_or_else(|| {
        FilterError::Spectrum("the ideal filter needs a symmetric or symmetrizable operator".into())
    })?;
    let r: Vec<f64> = s.iter().map(|v| v.sqrt()).collect();
    let evd = symmetrized_dense(f, &s)
        .self_adjoint_eigen(faer::Side::Lower)
        .map_err(|e| FilterError::Spectrum(format!("eigendecomposition failed: {e:?}")))?;
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
    use crate::mesh::{builtin, topology::Topology};
    use crate::operator::{kirchhoff::kirchhoff, tutte::tutte};

    fn bumpy() -> (Vec<f64>, Topology) {
        let m = builtin::icosphere(2).unwrap();
        let t = Topology::new(&m).unwrap();
        let x = m
            .positions
            .iter()
            .enumerate()
            .flat_map(|(i, p)| p.map(|c| c * (1.0 + 0.05 * ((i * 7919) % 13) as f64 / 13.0)))
            .collect();
        (x, t)
    }

    #[test]
    fn extreme_pass_bands_are_identity_and_weighted_centroid() {
        let (x, t) = bumpy();
        let same = ideal_lowpass(&kirchhoff(&t), &x, 1e9).unwrap();
        assert!(same.iter().zip(&x).all(|(a, b)| (a - b).abs() < 1e-10));
        // Only γ = 0 kept: for the TL the S-orthogonal projection onto constants is the
        // degree-weighted centroid Σ dᵢxᵢ / Σ dᵢ.
        let d: Vec<f64> = t.degrees().iter().map(|&v| v as f64).collect();
        let dsum: f64 = d.iter().sum();
        let c: Vec<f64> = (0..3)
            .map(|k| (0..d.len()).map(|i| d[i] * x[3 * i + k]).sum::<f64>() / dsum)
            .collect();
        let flat = ideal_lowpass(&tutte(&t).unwrap(), &x, 1e-9).unwrap();
        for (j, v) in flat.iter().enumerate() {
            assert!((v - c[j % 3]).abs() < 1e-10, "{v} vs {}", c[j % 3]);
        }
    }

    #[test]
    fn is_a_projection() {
        let (x, t) = bumpy();
        let f = tutte(&t).unwrap();
        let once = ideal_lowpass(&f, &x, 0.5).unwrap();
        let twice = ideal_lowpass(&f, &once, 0.5).unwrap();
        assert!(once.iter().zip(&twice).all(|(a, b)| (a - b).abs() < 1e-10));
        let diff: f64 = once.iter().zip(&x).map(|(a, b)| (a - b).abs()).sum();
        assert!(diff > 1e-3, "a mid pass-band must change a bumpy mesh");
    }
}
