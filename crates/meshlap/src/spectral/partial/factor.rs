//! `K − σM`: its pattern (built once), the symbolic analysis (shared by every shift),
//! the numeric LDLᵀ at a shift, and the inertia count (Sylvester's law: the negative
//! pivots of `K − xM = LDLᵀ` are the eigenvalues of `K v = λ M v` below x).

use super::mass::{Mass, Metric};
use super::nearest::ShiftedFactor;
use super::ordering::{nested_dissection, NESTED_DISSECTION_FROM};
use super::solve::{ShiftInvert, TreeSplit, TREE_SPLIT_MIN_DIM};
use crate::spectral::{FactorizationFailure, SpectralError};
use crate::SparseMatrix;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::ldlt::factor::LdltRegularization;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::{SparseColMat, Triplet};
use faer::Side;

/// Builds the pattern of `K − σM` once: `K` plus the pattern of `M` (an explicit
/// diagonal for a diagonal `M`), and where each entry of `M` sits in it.
pub(super) struct ShiftedPattern {
    pub(super) base: SparseMatrix,
    /// `(position in base's values, M_ij)` for every stored entry of `M`.
    shift: Vec<(usize, f64)>,
}

impl ShiftedPattern {
    pub(super) fn new(k: &SparseMatrix, metric: &Metric) -> Result<Self, SpectralError> {
        let n = k.nrows();
        let entries = metric.entries();
        let mut trip = Vec::with_capacity(k.compute_nnz() + entries.len());
        for j in 0..n {
            for (&i, &v) in k.row_idx_of_col_raw(j).iter().zip(k.val_of_col(j)) {
                trip.push(Triplet::new(i, j, v));
            }
        }
        trip.extend(entries.iter().map(|&(i, j, _)| Triplet::new(i, j, 0.0)));
        let base: SparseMatrix = SparseColMat::try_new_from_triplets(n, n, &trip)
            .map_err(SpectralError::SparseCreation)?;
        let col_ptr = base.symbolic().col_ptr();
        // Every entry of M has a place in base (an explicit, possibly zero, entry was
        // added above, and duplicates are summed into one; rows are sorted).
        let shift = entries
            .iter()
            .map(|&(i, j, v)| {
                let p = base.row_idx_of_col_raw(j).partition_point(|&r| r < i);
                (col_ptr[j] + p, v)
            })
            .collect();
        Ok(Self { base, shift })
    }

    fn shifted(&self, sigma: f64) -> SparseMatrix {
        let mut a = self.base.clone();
        let vals = a.val_mut();
        for &(p, m) in &self.shift {
            vals[p] -= sigma * m;
        }
        a
    }
}

/// The numeric LDLᵀ factorization of `K − σM` (`pattern` shifted by `sigma`) on the
/// supernodal structure `symbolic`: its factor values, or
/// [`SpectralError::Factorization`] when faer fails or a pivot is not finite.
///
/// Runs on a pool worker ([`crate::par::on_worker`]): faer's parallel factorization
/// called from outside the pool hands every task to it and sleeps, which is
/// measurably slower (figures in BENCHMARKS.md).
pub(super) fn factor_at(
    pattern: &ShiftedPattern,
    symbolic: &SymbolicCholesky<usize>,
    sigma: f64,
) -> Result<Vec<f64>, SpectralError> {
    crate::par::on_worker(|| factor_at_on_worker(pattern, symbolic, sigma))
}

fn factor_at_on_worker(
    pattern: &ShiftedPattern,
    symbolic: &SymbolicCholesky<usize>,
    sigma: f64,
) -> Result<Vec<f64>, SpectralError> {
    let par = faer::get_global_parallelism();
    let a = pattern.shifted(sigma);
    let mut values = vec![0.0f64; symbolic.len_val()];
    let req = symbolic.factorize_numeric_ldlt_scratch::<f64>(par, Default::default());
    let mut buf = MemBuffer::new(req);
    symbolic
        .factorize_numeric_ldlt(
            &mut values,
            a.as_ref(),
            Side::Lower,
            LdltRegularization::default(),
            par,
            MemStack::new(&mut buf),
            Default::default(),
        )
        .map_err(|e| SpectralError::Factorization {
            shift: sigma,
            source: e.into(),
        })?;
    if values.iter().any(|v| !v.is_finite()) {
        return Err(SpectralError::Factorization {
            shift: sigma,
            source: FactorizationFailure::NonFinitePivot,
        });
    }
    Ok(values)
}

/// Number of negative pivots of the LDLᵀ factors: by Sylvester's law of inertia,
/// the number of eigenvalues of `K v = λ M v` below the shift.
pub(super) fn negative_pivots(symbolic: &SymbolicCholesky<usize>, values: &[f64]) -> usize {
    use faer::sparse::linalg::cholesky::{supernodal::SupernodalLdltRef, SymbolicCholeskyRaw};
    match symbolic.raw() {
        SymbolicCholeskyRaw::Simplicial(s) => {
            let (cp, ri) = (s.col_ptr(), s.row_idx());
            (0..s.ncols())
                .filter(|&j| {
                    (cp[j]..cp[j + 1])
                        .find(|&p| ri[p] == j)
                        .is_some_and(|p| values[p] < 0.0)
                })
                .count()
        }
        SymbolicCholeskyRaw::Supernodal(s) => {
            let l = SupernodalLdltRef::new(s, values);
            (0..s.n_supernodes())
                .map(|sn| {
                    let node = l.supernode(sn);
                    let val = node.val();
                    let ncols = val.ncols();
                    (0..ncols).filter(|&j| val[(j, j)] < 0.0).count()
                })
                .sum()
        }
    }
}

/// Eigenvalues of `K v = λ M v` below `x` (Sylvester inertia of `K − xM`).
pub(super) fn count_below(
    pattern: &ShiftedPattern,
    symbolic: &SymbolicCholesky<usize>,
    x: f64,
) -> Result<usize, SpectralError> {
    let values = factor_at(pattern, symbolic, x)?;
    Ok(negative_pivots(symbolic, &values))
}

/// The symbolic LDLᵀ analysis of the pattern: AMD ordering, or METIS nested
/// dissection from [`NESTED_DISSECTION_FROM`] vertices on.
pub(super) fn symbolic_of(
    pattern: &ShiftedPattern,
) -> Result<SymbolicCholesky<usize>, SpectralError> {
    let n = pattern.base.nrows();
    let nd = if n >= NESTED_DISSECTION_FROM {
        nested_dissection(&pattern.base)
    } else {
        None
    };
    let ordering = match &nd {
        Some((fwd, inv)) => {
            SymmetricOrdering::Custom(faer::perm::PermRef::new_checked(fwd, inv, n))
        }
        None => SymmetricOrdering::Amd,
    };
    factorize_symbolic_cholesky(
        pattern.base.symbolic(),
        Side::Lower,
        ordering,
        Default::default(),
    )
    .map_err(SpectralError::SymbolicFactorization)
}

/// The number of eigenvalues of `K v = λ M v` strictly below `x` (each `x` one sparse
/// LDLᵀ of `K − xM`; Sylvester's law of inertia), for `K` symmetric n×n (both
/// triangles stored) and `M` the identity, a positive diagonal or a sparse symmetric
/// positive definite matrix (see [`Mass`]).
///
/// Exact up to the factorization's rounding: an eigenvalue within rounding of `x` may
/// be counted on either side. Used by the property report for the multiplicity of
/// the zero eigenvalue at any n.
pub fn eigenvalues_below<'a>(
    k: &SparseMatrix,
    mass: impl Into<Mass<'a>>,
    x: f64,
) -> Result<usize, SpectralError> {
    Inertia::new(k, mass)?.below(x)
}

/// Repeated inertia counts of one problem `K v = λ M v` ([`eigenvalues_below`] at
/// several x): the pattern of `K − xM` and its symbolic analysis are built once, each
/// count is one numeric LDLᵀ, which [`Inertia::at`] keeps as the shift-invert operator
/// at x (for the eigenvalue nearest x, [`ShiftedFactor`]).
pub(crate) struct Inertia {
    n: usize,
    parts: Option<InertiaParts>,
    factorizations: std::cell::Cell<usize>,
}

struct InertiaParts {
    metric: Metric,
    pattern: ShiftedPattern,
    symbolic: SymbolicCholesky<usize>,
    /// The solves' scaling for a sparse `M` (ones; see [`ShiftInvert::scale_of`]).
    ones: Vec<f64>,
    split: Option<TreeSplit>,
}

impl Inertia {
    /// The problem's pattern and symbolic analysis; errors as [`eigenvalues_below`].
    pub(crate) fn new<'a>(
        k: &SparseMatrix,
        mass: impl Into<Mass<'a>>,
    ) -> Result<Self, SpectralError> {
        let metric = super::check_problem(k, mass.into())?;
        let n = k.nrows();
        let factorizations = std::cell::Cell::new(0);
        if n == 0 {
            return Ok(Self {
                n,
                parts: None,
                factorizations,
            });
        }
        let pattern = ShiftedPattern::new(k, &metric)?;
        let symbolic = symbolic_of(&pattern)?;
        let mut ones = Vec::new();
        let _ = ShiftInvert::scale_of(&metric, &mut ones);
        let split = TreeSplit::of(&symbolic, TREE_SPLIT_MIN_DIM);
        Ok(Self {
            n,
            parts: Some(InertiaParts {
                metric,
                pattern,
                symbolic,
                ones,
                split,
            }),
            factorizations,
        })
    }

    /// The dimension n.
    pub(crate) fn dim(&self) -> usize {
        self.n
    }

    /// Numeric factorizations made so far (one per count).
    #[cfg(test)]
    pub(crate) fn factorizations(&self) -> usize {
        self.factorizations.get()
    }

    /// The number of eigenvalues strictly below `x` (up to the factorization's
    /// rounding, see [`eigenvalues_below`]).
    pub(crate) fn below(&self, x: f64) -> Result<usize, SpectralError> {
        Ok(self.at(x)?.map_or(0, |f| f.below()))
    }

    /// The LDLᵀ of `K − xM` as the shift-invert operator at x, with its inertia count;
    /// `None` for n = 0.
    pub(crate) fn at(&self, x: f64) -> Result<Option<ShiftedFactor<'_>>, SpectralError> {
        let Some(parts) = &self.parts else {
            return Ok(None);
        };
        let values = factor_at(&parts.pattern, &parts.symbolic, x)?;
        self.factorizations.set(self.factorizations.get() + 1);
        let below = negative_pivots(&parts.symbolic, &values);
        let msqrt = parts.metric.diagonal_sqrt().unwrap_or(&parts.ones);
        Ok(Some(ShiftedFactor {
            op: ShiftInvert {
                symbolic: &parts.symbolic,
                values,
                metric: &parts.metric,
                msqrt,
                split: parts.split,
                scratch: Default::default(),
            },
            k: &parts.pattern.base,
            metric: &parts.metric,
            below,
        }))
    }
}
