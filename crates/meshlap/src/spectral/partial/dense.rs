//! The dense fallback for small problems.

use super::mass::Metric;
use super::residuals::finish;
use super::PartialSpectrum;
use crate::operator::symmetrize::{symmetrized_dense, Scaling};
use crate::spectral::{dense_evd, SpectralError};
use crate::SparseMatrix;
use faer::{Col, Mat};

/// Dense path: the reproducible dense eigensolver ([`dense_evd`]) on `C⁻¹ K C⁻ᵀ`
/// (`M = C Cᵀ`; `M^{-1/2} K M^{-1/2}` for a diagonal `M`), eigenvectors of the
/// `count` smallest eigenvalues only.
///
/// Not faer's `self_adjoint_eigen`: [`dense_evd`] gives the same bits on every
/// thread count and CPU, and computes only the `count` vectors asked for (no slower
/// than faer below the dense threshold).
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
    let (s, u) =
        dense_evd::symmetric_evd_lowest(a.as_ref(), count).ok_or(SpectralError::NoConvergence {
            path: "dense partial",
        })?;
    let pairs: Vec<(f64, Col<f64>)> = (0..count.min(n))
        .map(|j| (s[j], Col::from_fn(n, |i| u[(i, j)])))
        .collect();
    Ok(finish(k, metric, pairs, vec![], true))
}
