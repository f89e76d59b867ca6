//! The dense fallback for small problems.

use super::residuals::finish;
use super::PartialSpectrum;
use crate::operator::symmetrize::{symmetrized_dense, Scaling};
use crate::spectral::SpectralError;
use crate::SparseMatrix;
use faer::{Col, Side};

/// `√m_i` (all ones without a mass).
pub(super) fn msqrt_of(mass: Option<&[f64]>, n: usize) -> Vec<f64> {
    match mass {
        Some(m) => m.iter().map(|x| x.sqrt()).collect(),
        None => vec![1.0; n],
    }
}

/// Dense path: faer's self-adjoint eigensolver on `M^{-1/2} K M^{-1/2}`.
pub(super) fn dense(
    k: &SparseMatrix,
    mass: Option<&[f64]>,
    count: usize,
) -> Result<PartialSpectrum, SpectralError> {
    let n = k.nrows();
    let ms = msqrt_of(mass, n);
    let a = match mass {
        Some(m) => symmetrized_dense(k, Scaling::Congruence(m)),
        None => symmetrized_dense(k, Scaling::None),
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
    Ok(finish(k, &ms, pairs, vec![], true))
}
