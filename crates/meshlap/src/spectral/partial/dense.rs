//! The dense fallback for small problems.

use super::mass::Metric;
use super::residuals::finish;
use super::PartialSpectrum;
use crate::operator::symmetrize::{symmetrized_dense, Scaling};
use crate::spectral::SpectralError;
use crate::SparseMatrix;
use faer::{Col, Mat, Side};

/// Dense path: faer's self-adjoint eigensolver on `C⁻¹ K C⁻ᵀ` (`M = C Cᵀ`;
/// `M^{-1/2} K M^{-1/2}` for a diagonal `M`).
pub(super) fn dense(
    k: &SparseMatrix,
    metric: &Metric,
    count: usize,
) -> Result<PartialSpectrum, SpectralError> {
    let n = k.nrows();
    let a = match metric {
        Metric::Diagonal { m, .. } => symmetrized_dense(k, Scaling::Congruence(m)),
        Metric::Factor(_) => {
            // X = C⁻¹ K, then A = C⁻¹ Xᵀ = C⁻¹ K C⁻ᵀ, averaged with its transpose.
            let mut x = symmetrized_dense(k, Scaling::None);
            metric.solve_c(x.as_mut());
            let mut a = x.transpose().to_owned();
            metric.solve_c(a.as_mut());
            Mat::from_fn(n, n, |i, j| 0.5 * (a[(i, j)] + a[(j, i)]))
        }
    };
    let evd = a
        .self_adjoint_eigen(Side::Lower)
        .map_err(|_| SpectralError::NoConvergence {
            path: "dense partial",
        })?;
    let (u, s) = (evd.U(), evd.S());
    let mut pairs: Vec<(f64, Col<f64>)> = (0..count)
        .map(|j| (s[j], Col::from_fn(n, |i| u[(i, j)])))
        .collect();
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    Ok(finish(k, metric, pairs, vec![], true))
}
