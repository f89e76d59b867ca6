//! Linear solvers for implicit fairing (Zhang 2004 §4.10; Desbrun et al. 1999).
//!
//! The systems are `B x = b` with `B = M + λF` (`M = I`, or the degree matrix for the
//! paper's symmetrised Tutte system `(D + λK) x = D b`) and the right-hand side an n×3
//! block: the three coordinate columns are solved together, one blocked sparse product
//! per iteration, with per-column scalars and per-column convergence.
//!
//! - [`cg`]: conjugate gradients and Jacobi-preconditioned CG (symmetric positive
//!   definite `B`; a non-positive curvature `pᵀBp ≤ 0` is reported as
//!   [`SolveError::NotPositiveDefinite`] — the SQL with negative weights can lose
//!   definiteness);
//! - [`bicg`]: bi-conjugate gradients for the non-symmetric Tutte system, with
//!   breakdown and plateau detection;
//! - [`bicgstab`]: faer's BiCGSTAB, as a further reference;
//! - [`direct`]: sparse Cholesky (symbolic analysis kept and reused) and sparse LU.
//!
//! Iterative solvers follow faer's shape: [`Params`] with `Default`, an [`Info`] with
//! iterations and residual history per column, and [`SolveError`]. They solve against
//! the [`LinearOperator`] trait. Sign convention of the operators: `F = D − W`
//! (positive semi-definite).

pub mod bicg;
pub mod bicgstab;
pub mod cg;
pub mod csr;
pub mod direct;

pub use csr::CsrMatrix;

use serde::Serialize;

/// A square linear operator applied to n×k blocks stored row-major (entry (i, c) at
/// index `i·k + c`).
pub trait LinearOperator: Sync {
    /// n.
    fn dim(&self) -> usize;
    /// `y = A x`.
    fn apply(&self, x: &[f64], y: &mut [f64], k: usize);
    /// `y = A x` and `dot[c] = Σ_i w[i,c]·y[i,c]`; the default does it in two passes.
    fn apply_dot(&self, x: &[f64], y: &mut [f64], k: usize, w: &[f64], dot: &mut [f64]) {
        self.apply(x, y, k);
        for c in 0..k {
            dot[c] = (0..self.dim()).map(|i| w[i * k + c] * y[i * k + c]).sum();
        }
    }
    /// `y = A x`, `dot[c] = Σ_i w[i,c]·y[i,c]` and `norm2[c] = Σ_i y[i,c]²`; the
    /// default does it in separate passes.
    fn apply_dot_norm(
        &self,
        x: &[f64],
        y: &mut [f64],
        k: usize,
        w: &[f64],
        dot: &mut [f64],
        norm2: &mut [f64],
    ) {
        self.apply_dot(x, y, k, w, dot);
        norm2[..k].copy_from_slice(&col_norms2(y, k));
    }
    /// `y = Aᵀ x`, if the operator can (BiCG needs it).
    fn apply_transpose(&self, _x: &[f64], _y: &mut [f64], _k: usize) -> Result<(), SolveError> {
        Err(SolveError::Unsupported(
            "this operator cannot apply its transpose",
        ))
    }
    /// The diagonal, if known (for Jacobi preconditioning).
    fn diagonal(&self) -> Option<Vec<f64>> {
        None
    }
}

/// A sparse matrix with its transpose, as a [`LinearOperator`].
#[derive(Clone, Debug)]
pub struct SparseOperator {
    a: CsrMatrix,
    at: Option<CsrMatrix>,
}

impl SparseOperator {
    /// Wraps a faer CSC matrix; the transpose is stored too when `with_transpose`
    /// (needed by BiCG on non-symmetric matrices; for symmetric ones pass `false` and
    /// the matrix itself is used).
    pub fn new(m: &crate::SparseMatrix, with_transpose: bool) -> Self {
        Self::from_csr(
            CsrMatrix::from_csc(m),
            with_transpose.then(|| CsrMatrix::transpose_of_csc(m)),
        )
    }
    /// From CSR parts.
    pub fn from_csr(a: CsrMatrix, at: Option<CsrMatrix>) -> Self {
        SparseOperator { a, at }
    }
    /// The matrix.
    pub fn matrix(&self) -> &CsrMatrix {
        &self.a
    }
}

impl LinearOperator for SparseOperator {
    fn dim(&self) -> usize {
        self.a.nrows()
    }
    fn apply(&self, x: &[f64], y: &mut [f64], k: usize) {
        self.a.apply(x, y, k)
    }
    fn apply_dot(&self, x: &[f64], y: &mut [f64], k: usize, w: &[f64], dot: &mut [f64]) {
        self.a.apply_dot(x, y, k, Some((w, dot)))
    }
    fn apply_dot_norm(
        &self,
        x: &[f64],
        y: &mut [f64],
        k: usize,
        w: &[f64],
        dot: &mut [f64],
        norm2: &mut [f64],
    ) {
        self.a.apply_dot_norm(x, y, k, Some((w, dot, norm2)))
    }
    fn apply_transpose(&self, x: &[f64], y: &mut [f64], k: usize) -> Result<(), SolveError> {
        match &self.at {
            Some(at) => at.apply(x, y, k),
            None => self.a.apply(x, y, k),
        }
        Ok(())
    }
    fn diagonal(&self) -> Option<Vec<f64>> {
        Some(self.a.diagonal())
    }
}

/// A matrix-free operator from a closure `(x, y, k)`.
pub struct FnOperator<F: Fn(&[f64], &mut [f64], usize) + Sync> {
    /// n.
    pub dim: usize,
    /// `y = A x`.
    pub apply: F,
}

impl<F: Fn(&[f64], &mut [f64], usize) + Sync> LinearOperator for FnOperator<F> {
    fn dim(&self) -> usize {
        self.dim
    }
    fn apply(&self, x: &[f64], y: &mut [f64], k: usize) {
        (self.apply)(x, y, k)
    }
}

/// `M + λF` as a CSR matrix, `M = diag(mass)` (`None`: the identity). With F from
/// [`crate::operator`] (sign `F = D − W`) and λ > 0 this is the implicit-fairing matrix
/// of Desbrun et al. (1999): SPD for symmetric positive semi-definite F.
pub fn shifted_system(f: &crate::SparseMatrix, mass: Option<&[f64]>, lambda: f64) -> CsrMatrix {
    let n = f.nrows();
    let ones;
    let m = match mass {
        Some(m) => m,
        None => {
            ones = vec![1.0; n];
            &ones
        }
    };
    CsrMatrix::from_csc(f).shifted(m, lambda)
}

/// When to stop an iterative solve.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Serialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum Stopping {
    /// The paper's weak criterion, per coordinate column c:
    /// `‖x_c⁽ⁿ⁾ − x_c⁽ⁿ⁻¹⁾‖ < ε‖x_c⁽ⁿ⁻¹⁾‖`. Zhang writes it for `x_i` with the strong
    /// criterion `‖B x_i − b_i‖` beside it, which only makes sense for a coordinate
    /// column, so this is the paper's reading; each column stops on its own.
    #[default]
    Weak,
    /// The weak criterion per vertex: `‖x_i⁽ⁿ⁾ − x_i⁽ⁿ⁻¹⁾‖ < ε‖x_i⁽ⁿ⁻¹⁾‖` for every vertex
    /// i (rows of the n×3 block); all columns stop together. A vertex at the origin
    /// (‖x_i⁽ⁿ⁻¹⁾‖ = 0) must not move at all.
    WeakVertex,
    /// The strong criterion, per column: `‖B x_c − b_c‖ < ε‖b_c‖`.
    Strong,
}

impl std::str::FromStr for Stopping {
    type Err = SolveError;
    fn from_str(s: &str) -> Result<Self, SolveError> {
        match s {
            "weak" => Ok(Stopping::Weak),
            "weak-vertex" => Ok(Stopping::WeakVertex),
            "strong" => Ok(Stopping::Strong),
            _ => Err(SolveError::InvalidParameter(format!(
                "unknown stopping criterion `{s}` (weak, weak-vertex, strong)"
            ))),
        }
    }
}

/// Parameters of the iterative solvers.
#[derive(Clone, Copy, Debug)]
pub struct Params {
    /// ε of the stopping criterion (default 1e-5, as in the paper).
    pub tolerance: f64,
    /// Which criterion (default: the paper's weak one).
    pub stopping: Stopping,
    /// Iteration cap (default 10,000).
    pub max_iterations: usize,
    /// Keep the relative residual of every iteration (default true).
    pub record_history: bool,
    /// BiCG plateau window: a plateau is an iteration whose relative residual is
    /// above 99% of the one `plateau_window` iterations earlier (default 10).
    pub plateau_window: usize,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            tolerance: 1e-5,
            stopping: Stopping::Weak,
            max_iterations: 10_000,
            record_history: true,
            plateau_window: 10,
        }
    }
}

/// What an iterative solve did, per column.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Info {
    /// Iterations each column took.
    pub iterations: Vec<usize>,
    /// Final relative residual `‖B x_c − b_c‖ / ‖b_c‖` of each column (recomputed).
    pub residuals: Vec<f64>,
    /// Relative residual per iteration, per column (the solver's recurrence).
    pub history: Vec<Vec<f64>>,
    /// BiCG: the first iteration at which a plateau was seen, per column.
    pub plateau_at: Vec<Option<usize>>,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// Errors of the linear solvers.
#[derive(Debug, thiserror::Error)]
pub enum SolveError {
    /// The iteration cap was reached.
    #[error("no convergence within {} iterations (relative residuals {:?})", .info.iterations.iter().max().unwrap_or(&0), .info.residuals)]
    NoConvergence {
        /// What was done.
        info: Box<Info>,
    },
    /// A Krylov recurrence broke down (division by a vanishing quantity).
    #[error("breakdown at iteration {iteration} in column {column}: {what}")]
    Breakdown {
        /// Iteration.
        iteration: usize,
        /// Column.
        column: usize,
        /// Which quantity vanished.
        what: &'static str,
    },
    /// The matrix is not positive definite (CG curvature `pᵀBp ≤ 0`, or a Cholesky
    /// pivot ≤ 0).
    #[error("the system matrix is not positive definite (detected at iteration {iteration}, column {column}); an SQL with negative weights can cause this — run `meshlap repair-sql` or use --solver lu/bicg")]
    NotPositiveDefinite {
        /// Iteration (0 for a factorisation).
        iteration: usize,
        /// Column (or pivot index for a factorisation).
        column: usize,
    },
    /// Sizes do not match.
    #[error("dimension mismatch: {0}")]
    Dimension(String),
    /// A direct factorisation failed.
    #[error("factorisation failed: {0}")]
    Factorization(String),
    /// The operator cannot do what the solver needs.
    #[error("{0}")]
    Unsupported(&'static str),
    /// A parameter is out of range.
    #[error("{0}")]
    InvalidParameter(String),
}

pub(crate) fn check_dims(op: &dyn LinearOperator, b: &[f64], k: usize) -> Result<(), SolveError> {
    if k == 0 || b.len() != op.dim() * k {
        return Err(SolveError::Dimension(format!(
            "operator is {n}×{n} but the right-hand side has {} values for {k} columns",
            b.len(),
            n = op.dim()
        )));
    }
    Ok(())
}

/// Per-column squared norms of an n×k block.
pub(crate) fn col_norms2(x: &[f64], k: usize) -> Vec<f64> {
    use rayon::prelude::*;
    let parts = x
        .par_chunks(csr::CHUNK * k)
        .map(|ch| {
            let mut acc = [0.0; 8];
            for row in ch.chunks_exact(k) {
                for c in 0..k {
                    acc[c] += row[c] * row[c];
                }
            }
            acc
        })
        .reduce(|| [0.0; 8], |a, b| std::array::from_fn(|c| a[c] + b[c]));
    parts[..k].to_vec()
}

/// Per-column dot products of two n×k blocks.
pub(crate) fn col_dots(x: &[f64], y: &[f64], k: usize) -> Vec<f64> {
    use rayon::prelude::*;
    let parts = x
        .par_chunks(csr::CHUNK * k)
        .zip(y.par_chunks(csr::CHUNK * k))
        .map(|(a, b)| {
            let mut acc = [0.0; 8];
            for (ra, rb) in a.chunks_exact(k).zip(b.chunks_exact(k)) {
                for c in 0..k {
                    acc[c] += ra[c] * rb[c];
                }
            }
            acc
        })
        .reduce(|| [0.0; 8], |a, b| std::array::from_fn(|c| a[c] + b[c]));
    parts[..k].to_vec()
}

/// Relative residuals `‖B x_c − b_c‖/‖b_c‖`, recomputed from scratch.
pub fn relative_residuals(op: &dyn LinearOperator, x: &[f64], b: &[f64], k: usize) -> Vec<f64> {
    let mut r = vec![0.0; b.len()];
    op.apply(x, &mut r, k);
    for (ri, bi) in r.iter_mut().zip(b) {
        *ri = bi - *ri;
    }
    let rn = col_norms2(&r, k);
    let bn = col_norms2(b, k);
    rn.iter()
        .zip(&bn)
        .map(|(r, b)| if *b > 0.0 { (r / b).sqrt() } else { r.sqrt() })
        .collect()
}

#[cfg(test)]
pub(crate) mod test_util {
    use crate::mesh::{builtin, topology::Topology, TriMesh};
    use crate::SparseMatrix;

    /// An irregular closed mesh (icosphere: degrees 5 and 6) and its operators.
    pub fn irregular(
        level: usize,
    ) -> (TriMesh, SparseMatrix, SparseMatrix, SparseMatrix, Vec<u32>) {
        let m = builtin::icosphere(level).unwrap();
        let t = Topology::new(&m).unwrap();
        (
            m.clone(),
            crate::operator::tutte::tutte(&t).unwrap(),
            crate::operator::sql::sql(&t, Default::default()).unwrap(),
            crate::operator::kirchhoff::kirchhoff(&t),
            t.degrees(),
        )
    }

    pub fn flat(m: &TriMesh) -> Vec<f64> {
        m.positions.iter().flat_map(|p| p.iter().copied()).collect()
    }
}
