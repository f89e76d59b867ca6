//! Direct sparse solvers from faer: Cholesky `LLᵀ` for symmetric positive definite
//! systems, with the symbolic analysis (fill-reducing ordering and elimination tree)
//! kept so that a new λ only costs a numeric factorisation, and LU for non-symmetric
//! systems (the Tutte system). Right-hand sides are n×k row-major blocks.

use super::SolveError;
use crate::SparseMatrix;
use faer::linalg::solvers::SolveCore;
use faer::sparse::linalg::solvers::{Llt, Lu, SymbolicLlt, SymbolicLu};
use faer::{Conj, Mat, Side};

fn to_mat(b: &[f64], k: usize) -> Mat<f64> {
    Mat::from_fn(b.len() / k, k, |i, c| b[i * k + c])
}
fn from_mat(m: &Mat<f64>, b: &mut [f64], k: usize) {
    for i in 0..m.nrows() {
        for c in 0..k {
            b[i * k + c] = m[(i, c)];
        }
    }
}

/// Reusable sparse Cholesky solver.
#[derive(Debug)]
pub struct CholeskySolver {
    symbolic: SymbolicLlt<usize>,
    llt: Llt<usize, f64>,
}

impl CholeskySolver {
    /// Symbolic analysis and numeric factorisation of the SPD matrix `a` (both
    /// triangles stored; the lower one is read).
    pub fn new(a: &SparseMatrix) -> Result<Self, SolveError> {
        let symbolic = SymbolicLlt::try_new(a.symbolic(), Side::Lower)
            .map_err(|e| SolveError::Factorization(format!("{e:?}")))?;
        let llt = Self::numeric(&symbolic, a)?;
        Ok(CholeskySolver { symbolic, llt })
    }

    fn numeric(
        symbolic: &SymbolicLlt<usize>,
        a: &SparseMatrix,
    ) -> Result<Llt<usize, f64>, SolveError> {
        Llt::try_new_with_symbolic(symbolic.clone(), a.as_ref(), Side::Lower).map_err(|e| match e {
            faer::sparse::linalg::LltError::Numeric(
                faer::linalg::cholesky::llt::factor::LltError::NonPositivePivot { index },
            ) => SolveError::NotPositiveDefinite {
                iteration: 0,
                column: index,
            },
            e => SolveError::Factorization(format!("{e:?}")),
        })
    }

    /// Refactors a matrix with the same pattern (e.g. `I + λF` for a new λ), reusing
    /// the symbolic analysis.
    pub fn refactor(&mut self, a: &SparseMatrix) -> Result<(), SolveError> {
        self.llt = Self::numeric(&self.symbolic, a)?;
        Ok(())
    }

    /// Solves in place for the n×k row-major block `b`.
    pub fn solve_in_place(&self, b: &mut [f64], k: usize) -> Result<(), SolveError> {
        let mut m = to_mat(b, k);
        self.llt.solve_in_place_with_conj(Conj::No, m.as_mut());
        from_mat(&m, b, k);
        Ok(())
    }
}

/// Reusable sparse LU solver (non-symmetric systems).
#[derive(Debug)]
pub struct LuSolver {
    symbolic: SymbolicLu<usize>,
    lu: Lu<usize, f64>,
}

impl LuSolver {
    /// Symbolic analysis and numeric factorisation of `a`.
    pub fn new(a: &SparseMatrix) -> Result<Self, SolveError> {
        let symbolic = SymbolicLu::try_new(a.symbolic())
            .map_err(|e| SolveError::Factorization(format!("{e:?}")))?;
        let lu = Lu::try_new_with_symbolic(symbolic.clone(), a.as_ref())
            .map_err(|e| SolveError::Factorization(format!("{e:?}")))?;
        Ok(LuSolver { symbolic, lu })
    }

    /// Refactors a matrix with the same pattern, reusing the symbolic analysis.
    pub fn refactor(&mut self, a: &SparseMatrix) -> Result<(), SolveError> {
        self.lu = Lu::try_new_with_symbolic(self.symbolic.clone(), a.as_ref())
            .map_err(|e| SolveError::Factorization(format!("{e:?}")))?;
        Ok(())
    }

    /// Solves in place for the n×k row-major block `b`.
    pub fn solve_in_place(&self, b: &mut [f64], k: usize) -> Result<(), SolveError> {
        let mut m = to_mat(b, k);
        self.lu.solve_in_place_with_conj(Conj::No, m.as_mut());
        from_mat(&m, b, k);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solve::{shifted_system, test_util::*, LinearOperator, SparseOperator};

    #[test]
    fn cholesky_refactor_reuses_the_symbolic_analysis() {
        let (m, _, sql, ..) = irregular(2);
        let b = flat(&m);
        let a1 = shifted_system(&sql, None, 10.0).to_csc();
        let a2 = shifted_system(&sql, None, 50.0).to_csc();
        let mut s = CholeskySolver::new(&a1).unwrap();
        s.refactor(&a2).unwrap();
        let mut x = b.clone();
        s.solve_in_place(&mut x, 3).unwrap();
        let r = crate::solve::relative_residuals(
            &SparseOperator::new(&a2, false) as &dyn LinearOperator,
            &x,
            &b,
            3,
        );
        assert!(r.iter().all(|&v| v < 1e-12), "{r:?}");
    }

    #[test]
    fn cholesky_rejects_indefinite() {
        let trip: Vec<_> = (0..5)
            .map(|i| faer::sparse::Triplet::new(i, i, if i == 3 { -2.0 } else { 1.0 }))
            .collect();
        let a = SparseMatrix::try_new_from_triplets(5, 5, &trip).unwrap();
        assert!(matches!(
            CholeskySolver::new(&a),
            Err(SolveError::NotPositiveDefinite { .. })
        ));
    }
}
