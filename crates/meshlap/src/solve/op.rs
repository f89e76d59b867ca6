//! What a solver may ask of an operator, as traits (faer's `LinOp` / `BiLinOp` shape):
//! [`LinOp`] applies `A` to an n×k row-major block, [`BiLinOp`] also applies `Aᵀ`
//! (BiCG needs it: an operator without a transpose cannot be passed to BiCG at all, a
//! compile-time fact rather than a run-time error), and [`Diagonal`] hands out the
//! diagonal for the [`Jacobi`] preconditioner.
//!
//! Implementations: [`CsrMatrix`] (`LinOp + Diagonal`), [`CsrWithTranspose`] (a matrix
//! stored with its transpose: `BiLinOp + Diagonal`) and [`FnOperator`] (matrix-free,
//! `LinOp` only). The operators of [`crate::operator`] use the sign `F = D − W`
//! (positive semi-definite); the systems solved here are `M + λF`.

use super::krylov::{col_dots, col_norms2};
use super::{CsrMatrix, InputError};

/// Reductions fused into a product `y = A x`: `dot[c] = Σ_i w[i,c]·y[i,c]` and
/// `norm2[c] = Σ_i y[i,c]²`, per column c (CG's `pᵀAp`, BiCG's `p̃ᵀAp` and `‖Ap‖²`).
#[derive(Debug)]
pub struct Fused<'a> {
    /// The n×k block `w` (row-major, like `y`).
    pub w: &'a [f64],
    /// Output: k dot products.
    pub dot: &'a mut [f64],
    /// Output: k squared column norms of `y`.
    pub norm2: &'a mut [f64],
}

impl<'a> Fused<'a> {
    /// The reductions against `w`, written to `dot` and `norm2`.
    pub fn new(w: &'a [f64], dot: &'a mut [f64], norm2: &'a mut [f64]) -> Self {
        Fused { w, dot, norm2 }
    }
}

/// A square linear operator applied to n×k blocks stored row-major (entry (i, c) at
/// index `i·k + c`).
pub trait LinOp: Sync {
    /// n.
    fn dim(&self) -> usize;
    /// `y = A x` for the n×k blocks `x` and `y`.
    fn apply(&self, x: &[f64], y: &mut [f64], k: usize);
    /// `y = A x` and the reductions of `fused`; the default makes a second pass over
    /// `y`, a matrix kernel fuses them into the product.
    fn apply_fused(&self, x: &[f64], y: &mut [f64], k: usize, fused: Fused<'_>) {
        self.apply(x, y, k);
        fused.dot[..k].copy_from_slice(&col_dots(fused.w, y, k));
        fused.norm2[..k].copy_from_slice(&col_norms2(y, k));
    }
}

/// An operator that can also apply its transpose (bi-conjugate gradients need it).
pub trait BiLinOp: LinOp {
    /// `y = Aᵀ x` for the n×k blocks `x` and `y`.
    fn apply_transpose(&self, x: &[f64], y: &mut [f64], k: usize);
}

/// An operator that knows its diagonal (for [`Jacobi`] preconditioning).
pub trait Diagonal {
    /// The n diagonal entries (0 where none is stored).
    fn diagonal(&self) -> Vec<f64>;
}

impl LinOp for CsrMatrix {
    fn dim(&self) -> usize {
        self.nrows()
    }
    fn apply(&self, x: &[f64], y: &mut [f64], k: usize) {
        self.product(x, y, k, None)
    }
    fn apply_fused(&self, x: &[f64], y: &mut [f64], k: usize, fused: Fused<'_>) {
        self.product(x, y, k, Some(fused))
    }
}

impl Diagonal for CsrMatrix {
    fn diagonal(&self) -> Vec<f64> {
        CsrMatrix::diagonal(self)
    }
}

/// A CSR matrix stored together with its transpose, so that both products stream a
/// matrix row by row: the [`BiLinOp`] of BiCG.
#[derive(Clone, Debug, PartialEq)]
pub struct CsrWithTranspose {
    a: CsrMatrix,
    at: CsrMatrix,
}

impl CsrWithTranspose {
    /// Stores `a` and computes its transpose (O(nnz)).
    pub fn new(a: CsrMatrix) -> Self {
        let at = a.transpose();
        CsrWithTranspose { a, at }
    }
    /// The matrix `A`.
    pub fn matrix(&self) -> &CsrMatrix {
        &self.a
    }
    /// The matrix, dropping the transpose.
    pub fn into_matrix(self) -> CsrMatrix {
        self.a
    }
}

impl LinOp for CsrWithTranspose {
    fn dim(&self) -> usize {
        self.a.nrows()
    }
    fn apply(&self, x: &[f64], y: &mut [f64], k: usize) {
        self.a.product(x, y, k, None)
    }
    fn apply_fused(&self, x: &[f64], y: &mut [f64], k: usize, fused: Fused<'_>) {
        self.a.product(x, y, k, Some(fused))
    }
}

impl BiLinOp for CsrWithTranspose {
    fn apply_transpose(&self, x: &[f64], y: &mut [f64], k: usize) {
        self.at.product(x, y, k, None)
    }
}

impl Diagonal for CsrWithTranspose {
    fn diagonal(&self) -> Vec<f64> {
        self.a.diagonal()
    }
}

/// A matrix-free operator from a closure `(x, y, k)` computing `y = A x`.
pub struct FnOperator<F: Fn(&[f64], &mut [f64], usize) + Sync> {
    /// n.
    pub dim: usize,
    /// `y = A x`.
    pub apply: F,
}

impl<F: Fn(&[f64], &mut [f64], usize) + Sync> LinOp for FnOperator<F> {
    fn dim(&self) -> usize {
        self.dim
    }
    fn apply(&self, x: &[f64], y: &mut [f64], k: usize) {
        (self.apply)(x, y, k)
    }
}

/// The Jacobi preconditioner `M = diag(A)`: the solvers multiply residuals by `M⁻¹`.
///
/// Built once per matrix and kept (see [`crate::filter::ImplicitSolver`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Jacobi {
    diagonal: Vec<f64>,
    inverse: Vec<f64>,
}

impl Jacobi {
    /// The preconditioner of `op`'s diagonal.
    ///
    /// # Errors
    /// [`InputError::SingularDiagonal`] for a zero or non-finite diagonal entry, which
    /// Jacobi would divide by. (CG further needs every entry positive and reports a
    /// non-positive one as not positive definite.)
    pub fn new(op: &(impl Diagonal + ?Sized)) -> Result<Self, InputError> {
        Self::from_diagonal(op.diagonal())
    }

    /// The preconditioner of a given diagonal; errors as [`Jacobi::new`].
    pub fn from_diagonal(diagonal: Vec<f64>) -> Result<Self, InputError> {
        if let Some(row) = diagonal.iter().position(|v| *v == 0.0 || !v.is_finite()) {
            return Err(InputError::SingularDiagonal {
                row,
                value: diagonal[row],
            });
        }
        let inverse = diagonal.iter().map(|v| 1.0 / v).collect();
        Ok(Jacobi { diagonal, inverse })
    }

    /// The diagonal `M`.
    pub fn diagonal(&self) -> &[f64] {
        &self.diagonal
    }

    /// `M⁻¹`, one entry per row.
    pub fn inverse(&self) -> &[f64] {
        &self.inverse
    }

    /// Checks that the preconditioner fits an n×n operator.
    pub(crate) fn check(&self, n: usize) -> Result<(), InputError> {
        if self.inverse.len() == n {
            Ok(())
        } else {
            Err(InputError::Preconditioner {
                n,
                got: self.inverse.len(),
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lower_bidiagonal(n: usize) -> CsrMatrix {
        let mut trip = Vec::new();
        for i in 0..n {
            trip.push(faer::sparse::Triplet::new(i, i, 2.0 + i as f64));
            if i > 0 {
                trip.push(faer::sparse::Triplet::new(i, i - 1, -1.0 - 0.1 * i as f64));
            }
        }
        CsrMatrix::from_csc(&crate::SparseMatrix::try_new_from_triplets(n, n, &trip).unwrap())
    }

    #[test]
    fn transpose_capability_applies_the_transpose() {
        let a = lower_bidiagonal(7);
        let op = CsrWithTranspose::new(a.clone());
        let dense = a.to_csc().to_dense();
        let x: Vec<f64> = (0..14).map(|i| (i as f64 * 0.3).cos()).collect();
        let (mut y, mut yt) = (vec![0.0; 14], vec![0.0; 14]);
        op.apply(&x, &mut y, 2);
        op.apply_transpose(&x, &mut yt, 2);
        for i in 0..7 {
            for c in 0..2 {
                let want: f64 = (0..7).map(|j| dense[(i, j)] * x[2 * j + c]).sum();
                let want_t: f64 = (0..7).map(|j| dense[(j, i)] * x[2 * j + c]).sum();
                assert!((y[2 * i + c] - want).abs() < 1e-14);
                assert!((yt[2 * i + c] - want_t).abs() < 1e-14);
            }
        }
        assert_eq!(op.diagonal(), a.diagonal());
    }

    #[test]
    fn default_fused_reductions_match_the_matrix_kernel() {
        let a = lower_bidiagonal(9);
        let f = FnOperator {
            dim: 9,
            apply: |x: &[f64], y: &mut [f64], k| a.apply(x, y, k),
        };
        let x: Vec<f64> = (0..27).map(|i| (i as f64).sin()).collect();
        let w: Vec<f64> = (0..27).map(|i| 1.0 + i as f64).collect();
        let (mut y1, mut y2) = (vec![0.0; 27], vec![0.0; 27]);
        let (mut d1, mut d2, mut n1, mut n2) = ([0.0; 3], [0.0; 3], [0.0; 3], [0.0; 3]);
        let fused = |dot, norm2| Fused { w: &w, dot, norm2 };
        a.apply_fused(&x, &mut y1, 3, fused(&mut d1, &mut n1));
        f.apply_fused(&x, &mut y2, 3, fused(&mut d2, &mut n2));
        assert_eq!(y1, y2);
        for c in 0..3 {
            assert!((d1[c] - d2[c]).abs() < 1e-12 * d1[c].abs().max(1.0));
            assert!((n1[c] - n2[c]).abs() < 1e-12 * n1[c]);
        }
    }

    #[test]
    fn jacobi_refuses_a_zero_diagonal() {
        assert!(matches!(
            Jacobi::from_diagonal(vec![1.0, 0.0, 2.0]),
            Err(InputError::SingularDiagonal { row: 1, .. })
        ));
        assert!(Jacobi::from_diagonal(vec![1.0, f64::NAN]).is_err());
        let j = Jacobi::new(&lower_bidiagonal(3)).unwrap();
        assert_eq!(j.inverse(), &[0.5, 1.0 / 3.0, 0.25]);
        assert!(j.check(4).is_err() && j.check(3).is_ok());
    }
}
