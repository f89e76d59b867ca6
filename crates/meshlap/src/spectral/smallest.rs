//! The k smallest eigenpairs of a mesh operator, by whichever path suits its size:
//! the one-shot entry point behind `meshlap spectrum` and the Python `eigs`.
//!
//! **Sign convention.** Operators are `F = D − W`, positive semi-definite (libigl and
//! pmp use the negative), so the smallest eigenvalues are the lowest frequencies, the
//! ED-transform's leading basis vectors (Zhang 2004, §2.3).
//!
//! Path: up to [`DENSE_LIMIT`] vertices the full dense eigenbasis
//! ([`EigenBasis::compute`], any [`super::EigenPath`]); above it the banded
//! shift-invert partial solver ([`super::partial`]), which needs the count. Both
//! return canonical vectors by the same rule ([`super::sign`]). The cotangent operator
//! is solved with its lumped mass (`L v = λ M v`) on both paths.

use super::basis::{BasisOptions, EigenBasis, EigenPath, DENSE_LIMIT};
use super::partial::{operator_partial_spectrum, BandInfo, PartialParams};
use super::SpectralError;
use crate::operator::Operator;
use faer::Mat;
use serde::Serialize;

/// Parameters of [`smallest`].
#[derive(Clone, Copy, Debug)]
pub struct SmallestParams {
    /// Options of the dense path.
    pub basis: BasisOptions,
    /// Options of the partial path (its `count` is set by [`smallest`]).
    pub partial: PartialParams,
    /// Largest n for the dense path.
    pub dense_limit: usize,
}

impl Default for SmallestParams {
    fn default() -> Self {
        Self {
            basis: BasisOptions::default(),
            partial: PartialParams::new(0),
            dense_limit: DENSE_LIMIT,
        }
    }
}

/// Which path computed a [`Smallest`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SmallestPath {
    /// The dense eigenbasis, by the given [`EigenPath`].
    Dense(EigenPath),
    /// Banded shift-invert block Krylov–Schur.
    ShiftInvert,
}

impl std::fmt::Display for SmallestPath {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SmallestPath::Dense(p) => write!(f, "{p}"),
            SmallestPath::ShiftInvert => f.write_str("shift-invert"),
        }
    }
}

/// How a [`Smallest`] was computed, and its quality.
#[derive(Clone, Debug, Serialize)]
pub struct SmallestInfo {
    /// The path taken.
    pub path: SmallestPath,
    /// Sizes of the eigenvalue clusters among the returned ones, in order (the last
    /// one may be cut by the count).
    pub multiplicities: Vec<usize>,
    /// `max_j ‖F e_j − λ_j e_j‖` (with the mass: `‖M^{-1/2}(L e − λ M e)‖` for
    /// `M`-normalized e).
    pub max_residual: f64,
    /// `max |EᵀSE − I|` over the returned vectors (`None` on the dense general path).
    pub orthonormality_error: Option<f64>,
    /// The shift-invert bands (empty on the dense path).
    pub bands: Vec<BandInfo>,
}

/// The k smallest eigenpairs of an operator.
#[derive(Clone, Debug)]
pub struct Smallest {
    /// Eigenvalues, ascending (k).
    pub eigenvalues: Vec<f64>,
    /// n×k eigenvectors, column j ↔ `eigenvalues[j]`, canonical signs.
    pub eigenvectors: Mat<f64>,
    /// Residual of each pair on the partial path; `None` on the dense path (see
    /// [`SmallestInfo::max_residual`]).
    pub residuals: Option<Vec<f64>>,
    /// How they were computed.
    pub info: SmallestInfo,
}

/// The `count` smallest eigenpairs of `op` (`None`: all n, dense path only), n×n with
/// n the vertex count; `progress(found, count)` is called as pairs are found on the
/// partial path.
///
/// Errors: `count` 0 or above n ([`SpectralError::TooMany`]); n above
/// `params.dense_limit` without a count ([`SpectralError::TooLarge`]: ask for the k
/// smallest); the solvers' own errors.
pub fn smallest(
    op: &Operator,
    count: Option<usize>,
    params: &SmallestParams,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Smallest, SpectralError> {
    let n = op.matrix.nrows();
    if n == 0 {
        return Err(SpectralError::Empty);
    }
    let k = count.unwrap_or(n);
    if k == 0 || k > n {
        return Err(SpectralError::TooMany { count: k, n });
    }
    if n > params.dense_limit {
        if count.is_none() {
            return Err(SpectralError::TooLarge {
                n,
                limit: params.dense_limit,
            });
        }
        let p = PartialParams {
            count: k,
            ..params.partial
        };
        let ps = operator_partial_spectrum(op, true, &p, progress)?;
        let max_residual = ps.residuals.iter().fold(0.0f64, |a, &b| a.max(b));
        let multiplicities =
            super::sign::clusters(&ps.eigenvalues, BasisOptions::DEFAULT_CLUSTER_TOLERANCE)
                .into_iter()
                .map(|c| c.1)
                .collect();
        return Ok(Smallest {
            eigenvalues: ps.eigenvalues,
            eigenvectors: ps.eigenvectors,
            residuals: Some(ps.residuals),
            info: SmallestInfo {
                path: SmallestPath::ShiftInvert,
                multiplicities,
                max_residual,
                orthonormality_error: None,
                bands: ps.info.bands,
            },
        });
    }
    let basis = EigenBasis::compute(op, &params.basis)?;
    progress(k, k);
    let multiplicities = basis
        .clusters()
        .iter()
        .filter(|c| c.0 < k)
        .map(|c| c.1.min(k - c.0))
        .collect();
    let max_residual = basis.max_residual_first(&op.matrix, op.mass.as_deref(), k);
    let orthonormality_error = basis.orthonormality_error_first(k);
    Ok(Smallest {
        eigenvalues: basis.eigenvalues()[..k].to_vec(),
        eigenvectors: basis.vectors().subcols(0, k).to_owned(),
        residuals: None,
        info: SmallestInfo {
            path: SmallestPath::Dense(basis.path()),
            multiplicities,
            max_residual,
            orthonormality_error,
            bands: Vec::new(),
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{builtin, topology::Topology};
    use crate::operator::{OperatorKind, OperatorOptions};

    #[test]
    fn both_paths_agree_and_errors_are_typed() {
        let m = builtin::icosphere(3).unwrap();
        let t = Topology::new(&m).unwrap();
        let op =
            Operator::assemble(OperatorKind::Sql, &m, &t, &OperatorOptions::default()).unwrap();
        let dense = smallest(&op, Some(16), &SmallestParams::default(), &mut |_, _| {}).unwrap();
        let params = SmallestParams {
            dense_limit: 100,
            partial: PartialParams {
                dense_below: 100,
                ..PartialParams::new(0)
            },
            ..Default::default()
        };
        let part = smallest(&op, Some(16), &params, &mut |_, _| {}).unwrap();
        assert_eq!(part.info.path, SmallestPath::ShiftInvert);
        assert!(matches!(dense.info.path, SmallestPath::Dense(_)));
        // 16 = 1 + 3 + 5 + 7 closes a cluster of the icosahedral spectrum.
        assert_eq!(dense.info.multiplicities.iter().sum::<usize>(), 16);
        assert!(
            dense.info.multiplicities.len() < 16,
            "repeated eigenvalues expected"
        );
        assert_eq!(part.info.multiplicities, dense.info.multiplicities);
        let diff = (&dense.eigenvectors - &part.eigenvectors).norm_max();
        assert!(diff < 1e-7, "{diff}");
        for (a, b) in dense.eigenvalues.iter().zip(&part.eigenvalues) {
            assert!((a - b).abs() < 1e-9);
        }
        assert!(dense.info.max_residual < 1e-9 && part.info.max_residual < 1e-9);
        assert!(matches!(
            smallest(&op, None, &params, &mut |_, _| {}),
            Err(SpectralError::TooLarge { n: 642, limit: 100 })
        ));
        assert!(matches!(
            smallest(&op, Some(0), &params, &mut |_, _| {}),
            Err(SpectralError::TooMany { count: 0, .. })
        ));
    }
}
