//! Direct sparse solvers from faer, split as faer splits them: a symbolic analysis of
//! the sparsity pattern (fill-reducing ordering, elimination tree, supernodes), then a
//! numeric factorization of any matrix with that pattern, then triangular solves.
//!
//! - [`SymbolicCholesky`] → [`CholeskySolver`]: `LLᵀ` of a symmetric positive definite
//!   matrix (both triangles stored, the lower one read), e.g. `I + λS`;
//! - [`SymbolicLu`] → [`LuSolver`]: `LU` with partial pivoting for non-symmetric
//!   matrices such as the Tutte system `I + λT`.
//!
//! A new λ, or a new factor of the Butterworth cascade, has the same pattern and only
//! costs a numeric factorization ([`CholeskySolver::refactor`]). Each solver reports
//! a [`DirectInfo`]: the time of each phase and the size of the factor. Right-hand
//! sides are n×k row-major blocks.

use super::InputError;
use crate::SparseMatrix;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::solvers::SolveCore;
use faer::sparse::linalg::cholesky::{self, LltRef};
use faer::sparse::linalg::solvers::{Lu, SymbolicLu as FaerSymbolicLu};
use faer::sparse::{FaerError, SymbolicSparseColMatRef};
use faer::{Conj, Mat, Side};
use serde::Serialize;
use std::sync::Arc;
use std::time::Instant;

/// What a direct solver's phases cost and produced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct DirectInfo {
    /// Seconds of the symbolic analysis (once per sparsity pattern).
    pub symbolic_seconds: f64,
    /// Seconds of the latest numeric factorization.
    pub numeric_seconds: f64,
    /// Seconds of the latest solve (0 before the first).
    pub solve_seconds: f64,
    /// Stored entries of the matrix.
    pub matrix_nnz: usize,
    /// Values stored for the factor (Cholesky: `L`, supernodal blocks included), the
    /// fill; `None` where faer does not expose it (LU).
    pub factor_nnz: Option<usize>,
}

/// Why a factorization or direct solve failed.
#[derive(Debug, thiserror::Error)]
pub enum DirectError {
    /// A Cholesky pivot ≤ 0: the matrix is not positive definite. For `I + λS` with
    /// the SQL, negative weights (Zhang 2004 §3.7) cause this; remove them or use LU.
    #[error("the matrix is not positive definite (Cholesky pivot {pivot} is not positive)")]
    NotPositiveDefinite {
        /// Pivot index (in the fill-reducing order).
        pivot: usize,
    },
    /// The LU factorization found no pivot: the matrix is singular.
    #[error("the matrix is singular (no LU pivot at step {step})")]
    Singular {
        /// Elimination step.
        step: usize,
    },
    /// The matrix is not square.
    #[error("the matrix is {nrows}×{ncols}, not square")]
    NotSquare {
        /// Rows.
        nrows: usize,
        /// Columns.
        ncols: usize,
    },
    /// A refactorization was given a matrix of another sparsity pattern than the one
    /// analyzed; analyze the new pattern instead.
    #[error("the matrix does not have the sparsity pattern of the symbolic analysis")]
    PatternMismatch,
    /// faer ran out of memory or indices.
    #[error("sparse factorization failed: {0}")]
    Faer(#[source] FaerError),
    /// The right-hand side does not fit.
    #[error(transparent)]
    Input(#[from] InputError),
}

/// What a symbolic analysis was made for: the sparsity pattern, compressed by
/// columns (refactorizations are checked against it), and how long it took.
#[derive(Clone, Debug, PartialEq)]
struct Pattern {
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    seconds: f64,
}

impl Pattern {
    /// Runs the symbolic analysis `analyze` of the square matrix `a`, timed.
    fn analyze<T>(
        a: &SparseMatrix,
        analyze: impl FnOnce(SymbolicSparseColMatRef<'_, usize>) -> Result<T, FaerError>,
    ) -> Result<(T, Self), DirectError> {
        let t = Instant::now();
        let mut pattern = Pattern::of(a.symbolic())?;
        let inner = analyze(a.symbolic()).map_err(DirectError::Faer)?;
        pattern.seconds = t.elapsed().as_secs_f64();
        Ok((inner, pattern))
    }

    fn of(a: SymbolicSparseColMatRef<'_, usize>) -> Result<Self, DirectError> {
        if a.nrows() != a.ncols() {
            return Err(DirectError::NotSquare {
                nrows: a.nrows(),
                ncols: a.ncols(),
            });
        }
        let mut col_ptr = Vec::with_capacity(a.ncols() + 1);
        col_ptr.push(0);
        let mut row_idx = Vec::with_capacity(a.compute_nnz());
        for j in 0..a.ncols() {
            row_idx.extend_from_slice(a.row_idx_of_col_raw(j));
            col_ptr.push(row_idx.len());
        }
        Ok(Pattern {
            n: a.nrows(),
            col_ptr,
            row_idx,
            seconds: 0.0,
        })
    }

    fn check(&self, a: &SparseMatrix) -> Result<(), DirectError> {
        let same = a.nrows() == self.n
            && a.ncols() == self.n
            && (0..self.n).all(|j| {
                a.row_idx_of_col_raw(j) == &self.row_idx[self.col_ptr[j]..self.col_ptr[j + 1]]
            });
        if same {
            Ok(())
        } else {
            Err(DirectError::PatternMismatch)
        }
    }

    fn nnz(&self) -> usize {
        self.row_idx.len()
    }
}

fn faer_error(e: impl Into<FaerError>) -> DirectError {
    DirectError::Faer(e.into())
}

/// Copies the n×k row-major block `b` into a faer matrix, applies `solve`, copies back;
/// returns `info` with the seconds this took.
fn solve_block(
    info: DirectInfo,
    n: usize,
    b: &mut [f64],
    k: usize,
    solve: impl FnOnce(faer::MatMut<'_, f64>) -> Result<(), DirectError>,
) -> Result<DirectInfo, DirectError> {
    let t = Instant::now();
    if k == 0 {
        return Err(InputError::Columns { k }.into());
    }
    if b.len() != n * k {
        return Err(InputError::RightHandSide { n, k, len: b.len() }.into());
    }
    let mut m = Mat::from_fn(n, k, |i, c| b[i * k + c]);
    solve(m.as_mut())?;
    for i in 0..n {
        for c in 0..k {
            b[i * k + c] = m[(i, c)];
        }
    }
    Ok(DirectInfo {
        solve_seconds: t.elapsed().as_secs_f64(),
        ..info
    })
}

/// The symbolic analysis of a sparse Cholesky factorization of one sparsity pattern
/// (AMD ordering, elimination tree, supernodes); [`SymbolicCholesky::factor`] turns it
/// into a [`CholeskySolver`] for any symmetric positive definite matrix of that
/// pattern.
#[derive(Clone, Debug)]
pub struct SymbolicCholesky {
    inner: Arc<cholesky::SymbolicCholesky<usize>>,
    pattern: Pattern,
}

impl SymbolicCholesky {
    /// Analyzes the pattern of the n×n matrix `a` (its lower triangle is read).
    pub fn new(a: &SparseMatrix) -> Result<Self, DirectError> {
        let (inner, pattern) = Pattern::analyze(a, |s| {
            cholesky::factorize_symbolic_cholesky(
                s,
                Side::Lower,
                Default::default(),
                Default::default(),
            )
        })?;
        Ok(SymbolicCholesky {
            inner: Arc::new(inner),
            pattern,
        })
    }

    /// Values the factor `L` will store (the fill).
    pub fn factor_nnz(&self) -> usize {
        self.inner.len_val()
    }

    /// Numeric factorization of `a`, which must have the analyzed pattern.
    pub fn factor(self, a: &SparseMatrix) -> Result<CholeskySolver, DirectError> {
        let mut solver = CholeskySolver {
            info: DirectInfo {
                symbolic_seconds: self.pattern.seconds,
                matrix_nnz: self.pattern.nnz(),
                factor_nnz: Some(self.factor_nnz()),
                ..Default::default()
            },
            symbolic: self,
            values: Vec::new(),
        };
        solver.refactor(a)?;
        Ok(solver)
    }
}

/// A sparse Cholesky factorization `A = LLᵀ` (with its symbolic analysis, so that a
/// matrix of the same pattern is refactored numerically only).
#[derive(Clone, Debug)]
pub struct CholeskySolver {
    symbolic: SymbolicCholesky,
    values: Vec<f64>,
    info: DirectInfo,
}

impl CholeskySolver {
    /// Symbolic analysis and numeric factorization of the SPD n×n matrix `a` (both
    /// triangles stored; the lower one is read).
    pub fn new(a: &SparseMatrix) -> Result<Self, DirectError> {
        SymbolicCholesky::new(a)?.factor(a)
    }

    /// Refactors a matrix with the same pattern (e.g. `I + λF` for a new λ), reusing
    /// the symbolic analysis. On failure the previous factorization is kept.
    pub fn refactor(&mut self, a: &SparseMatrix) -> Result<(), DirectError> {
        self.symbolic.pattern.check(a)?;
        let t = Instant::now();
        let sym = &self.symbolic.inner;
        // On a pool worker: faer's parallel factorization called from outside the
        // pool hands every task to it and sleeps (figures in BENCHMARKS.md,
        // "Implicit fairing solvers").
        let values = crate::par::on_worker(|| {
            let par = faer::get_global_parallelism();
            let mut values = Vec::new();
            values
                .try_reserve_exact(sym.len_val())
                .map_err(faer_error)?;
            values.resize(sym.len_val(), 0.0);
            let mut mem = MemBuffer::try_new(
                sym.factorize_numeric_llt_scratch::<f64>(par, Default::default()),
            )
            .map_err(faer_error)?;
            sym.factorize_numeric_llt::<f64>(
                &mut values,
                a.as_ref(),
                Side::Lower,
                Default::default(),
                par,
                MemStack::new(&mut mem),
                Default::default(),
            )
            .map_err(|e| match e {
                faer::linalg::solvers::LltError::NonPositivePivot { index } => {
                    DirectError::NotPositiveDefinite { pivot: index }
                }
            })?;
            Ok::<_, DirectError>(values)
        })?;
        self.values = values;
        self.info.numeric_seconds = t.elapsed().as_secs_f64();
        Ok(())
    }

    /// Times and sizes of the analysis and the latest factorization.
    pub fn info(&self) -> DirectInfo {
        self.info
    }

    /// Solves `A x = b` in place for the n×k row-major block `b`; returns
    /// [`DirectInfo`] with the solve's seconds.
    pub fn solve_in_place(&self, b: &mut [f64], k: usize) -> Result<DirectInfo, DirectError> {
        let sym = &self.symbolic.inner;
        solve_block(self.info, self.symbolic.pattern.n, b, k, |m| {
            // On a pool worker, as the factorization.
            crate::par::on_worker(|| {
                let par = faer::get_global_parallelism();
                let scratch = sym.solve_in_place_scratch::<f64>(m.ncols(), par);
                let mut mem = MemBuffer::try_new(scratch).map_err(faer_error)?;
                let llt = LltRef::<usize, f64>::new(sym, &self.values);
                llt.solve_in_place_with_conj(Conj::No, m, par, MemStack::new(&mut mem));
                Ok(())
            })
        })
    }
}

/// The symbolic analysis of a sparse LU factorization of one sparsity pattern (COLAMD
/// column ordering, supernodes); [`SymbolicLu::factor`] turns it into an [`LuSolver`].
#[derive(Clone, Debug)]
pub struct SymbolicLu {
    inner: FaerSymbolicLu<usize>,
    pattern: Pattern,
}

impl SymbolicLu {
    /// Analyzes the pattern of the n×n matrix `a`.
    pub fn new(a: &SparseMatrix) -> Result<Self, DirectError> {
        let (inner, pattern) = Pattern::analyze(a, FaerSymbolicLu::try_new)?;
        Ok(SymbolicLu { inner, pattern })
    }

    /// Numeric factorization of `a`, which must have the analyzed pattern.
    pub fn factor(self, a: &SparseMatrix) -> Result<LuSolver, DirectError> {
        let (lu, numeric_seconds) = lu_numeric(&self, a)?;
        Ok(LuSolver {
            info: DirectInfo {
                symbolic_seconds: self.pattern.seconds,
                numeric_seconds,
                matrix_nnz: self.pattern.nnz(),
                ..Default::default()
            },
            symbolic: self,
            lu,
        })
    }
}

fn lu_numeric(
    symbolic: &SymbolicLu,
    a: &SparseMatrix,
) -> Result<(Lu<usize, f64>, f64), DirectError> {
    symbolic.pattern.check(a)?;
    let t = Instant::now();
    // On a pool worker, as the Cholesky factorization.
    let lu =
        crate::par::on_worker(|| Lu::try_new_with_symbolic(symbolic.inner.clone(), a.as_ref()))
            .map_err(|e| match e {
                faer::sparse::linalg::LuError::SymbolicSingular { index } => {
                    DirectError::Singular { step: index }
                }
                faer::sparse::linalg::LuError::Generic(e) => DirectError::Faer(e),
            })?;
    Ok((lu, t.elapsed().as_secs_f64()))
}

/// A sparse LU factorization with partial pivoting (non-symmetric systems), with its
/// symbolic analysis for refactorizations.
#[derive(Debug)]
pub struct LuSolver {
    symbolic: SymbolicLu,
    lu: Lu<usize, f64>,
    info: DirectInfo,
}

impl LuSolver {
    /// Symbolic analysis and numeric factorization of the n×n matrix `a`.
    pub fn new(a: &SparseMatrix) -> Result<Self, DirectError> {
        SymbolicLu::new(a)?.factor(a)
    }

    /// Refactors a matrix with the same pattern, reusing the symbolic analysis. On
    /// failure the previous factorization is kept.
    pub fn refactor(&mut self, a: &SparseMatrix) -> Result<(), DirectError> {
        let (lu, seconds) = lu_numeric(&self.symbolic, a)?;
        self.lu = lu;
        self.info.numeric_seconds = seconds;
        Ok(())
    }

    /// Times and sizes of the analysis and the latest factorization.
    pub fn info(&self) -> DirectInfo {
        self.info
    }

    /// Solves `A x = b` in place for the n×k row-major block `b`; returns
    /// [`DirectInfo`] with the solve's seconds.
    pub fn solve_in_place(&self, b: &mut [f64], k: usize) -> Result<DirectInfo, DirectError> {
        solve_block(self.info, self.symbolic.pattern.n, b, k, |m| {
            crate::par::on_worker(|| self.lu.solve_in_place_with_conj(Conj::No, m));
            Ok(())
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solve::{relative_residuals, shifted_system, test_util::*, CsrMatrix};

    #[test]
    fn cholesky_refactor_reuses_the_symbolic_analysis() {
        let (m, _, sql, ..) = irregular(2);
        let b = flat(&m);
        let a1 = shifted_system(&sql, None, 10.0);
        let a2 = shifted_system(&sql, None, 50.0);
        let mut s = CholeskySolver::new(&a1.to_csc()).unwrap();
        let symbolic = s.info().symbolic_seconds;
        s.refactor(&a2.to_csc()).unwrap();
        assert_eq!(s.info().symbolic_seconds, symbolic);
        let mut x = b.clone();
        s.solve_in_place(&mut x, 3).unwrap();
        let r = relative_residuals(&a2, &x, &b, 3).unwrap();
        assert!(r.iter().all(|&v| v < 1e-12), "{r:?}");
    }

    #[test]
    fn cholesky_rejects_indefinite() {
        let a = diagonal(&[1.0, 1.0, 1.0, -2.0, 1.0]).to_csc();
        assert!(matches!(
            CholeskySolver::new(&a),
            Err(DirectError::NotPositiveDefinite { .. })
        ));
    }

    #[test]
    fn info_reports_the_phases_and_the_fill() {
        let (m, tl, sql, ..) = irregular(3);
        let b = flat(&m);
        let a = shifted_system(&sql, None, 30.0).to_csc();
        let symbolic = SymbolicCholesky::new(&a).unwrap();
        let fill = symbolic.factor_nnz();
        let chol = symbolic.factor(&a).unwrap();
        let info = chol.info();
        assert_eq!(info.matrix_nnz, a.compute_nnz());
        assert_eq!(info.factor_nnz, Some(fill));
        // L holds at least the lower triangle of A.
        assert!(fill >= (a.compute_nnz() + a.nrows()) / 2, "{fill}");
        assert!(info.symbolic_seconds > 0.0 && info.numeric_seconds > 0.0);
        assert_eq!(info.solve_seconds, 0.0);
        let mut x = b.clone();
        let solved = chol.solve_in_place(&mut x, 3).unwrap();
        assert!(solved.solve_seconds > 0.0);
        assert_eq!(solved.numeric_seconds, info.numeric_seconds);
        let t = shifted_system(&tl, None, 30.0).to_csc();
        let lu = LuSolver::new(&t).unwrap();
        let info = lu.info();
        assert_eq!((info.matrix_nnz, info.factor_nnz), (t.compute_nnz(), None));
        assert!(info.symbolic_seconds > 0.0 && info.numeric_seconds > 0.0);
        let mut y = b.clone();
        assert!(lu.solve_in_place(&mut y, 3).unwrap().solve_seconds > 0.0);
        let r = relative_residuals(&CsrMatrix::from_csc(&t), &y, &b, 3).unwrap();
        assert!(r.iter().all(|&v| v < 1e-12), "{r:?}");
    }

    #[test]
    fn another_pattern_or_a_wrong_block_is_an_error_not_a_panic() {
        let (_, tl, sql, ..) = irregular(1);
        let s = shifted_system(&sql, None, 1.0).to_csc();
        let mut chol = CholeskySolver::new(&s).unwrap();
        let other = diagonal(&vec![1.0; s.nrows()]).to_csc();
        assert!(matches!(
            chol.refactor(&other),
            Err(DirectError::PatternMismatch)
        ));
        let t = shifted_system(&tl, None, 1.0).to_csc();
        let mut lu = LuSolver::new(&t).unwrap();
        assert!(matches!(
            lu.refactor(&other),
            Err(DirectError::PatternMismatch)
        ));
        let mut short = vec![1.0; 5];
        assert!(matches!(
            chol.solve_in_place(&mut short, 3),
            Err(DirectError::Input(InputError::RightHandSide { .. }))
        ));
        assert!(matches!(
            lu.solve_in_place(&mut short, 0),
            Err(DirectError::Input(InputError::Columns { k: 0 }))
        ));
        let rect = crate::SparseMatrix::try_new_from_triplets(
            2,
            3,
            &[faer::sparse::Triplet::new(0, 0, 1.0)],
        )
        .unwrap();
        assert!(matches!(
            SymbolicLu::new(&rect),
            Err(DirectError::NotSquare { .. })
        ));
    }

    #[test]
    fn singular_lu_is_reported() {
        // Structurally singular: an empty column.
        let a = crate::SparseMatrix::try_new_from_triplets(
            3,
            3,
            &[
                faer::sparse::Triplet::new(0, 0, 1.0),
                faer::sparse::Triplet::new(1, 0, 1.0),
                faer::sparse::Triplet::new(2, 2, 1.0),
            ],
        )
        .unwrap();
        assert!(matches!(
            LuSolver::new(&a),
            Err(DirectError::Singular { .. })
        ));
    }
}
