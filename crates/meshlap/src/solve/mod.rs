//! Linear solvers for implicit fairing (Zhang 2004 §4.10; Desbrun et al. 1999).
//!
//! The systems are `B x = b` with `B = M + λF` (`M = I`, or the degree matrix for the
//! paper's symmetrized Tutte system `(D + λK) x = D b`), F an operator of
//! [`crate::operator`] with the sign `F = D − W` (positive semi-definite), and the
//! right-hand side an n×k row-major block (k ≤ [`MAX_COLUMNS`]; the three coordinate
//! columns of a mesh are solved together: one blocked sparse product per iteration,
//! per-column scalars and per-column convergence).
//!
//! Every iterative solver has faer's shape: it takes the operator through a trait
//! ([`LinOp`]; BiCG a [`BiLinOp`], which adds the transpose or a symmetrizer),
//! [`Params`] (with `Default`) and a [`Workspace`] of buffers, and returns an [`Info`]
//! (iterations, final residuals and residual history per column; BiCG's [`BicgInfo`]
//! adds its plateau) or its own typed error:
//!
//! - [`cg()`]: conjugate gradients, plain or with the [`Jacobi`] preconditioner, for
//!   symmetric positive definite `B` ([`CgError::NotPositiveDefinite`] on a
//!   non-positive curvature `pᵀBp ≤ 0`: the SQL with negative weights can lose
//!   definiteness);
//! - [`bicg()`]: bi-conjugate gradients for the non-symmetric Tutte system, with
//!   breakdown and plateau detection;
//! - [`bicgstab()`]: BiCGSTAB (one more reference for non-symmetric systems);
//! - [`direct`]: sparse Cholesky and LU, symbolic analysis then numeric factorization,
//!   each reporting a [`DirectInfo`] (times and fill).
//!
//! The stateful solver that keeps a system, its factorization, preconditioner and
//! buffers across solves is [`crate::filter::ImplicitSolver`]; [`SolveInfo`] is what
//! it reports whichever solver runs, and [`SolveError`] the error of this module,
//! wrapping each solver's.

pub mod bicg;
pub mod bicgstab;
pub mod cg;
pub mod csr;
pub mod direct;
mod krylov;
mod op;

pub(crate) use krylov::check_sizes;

pub use bicg::{bicg, BicgError, BicgInfo, BicgParams};
pub use bicgstab::{bicgstab, BicgstabError};
pub use cg::{cg, CgError};
pub use csr::CsrMatrix;
pub use direct::{CholeskySolver, DirectError, DirectInfo, LuSolver, SymbolicCholesky, SymbolicLu};
pub use krylov::Workspace;
pub use op::{
    check_residual, BiLinOp, CsrWithSymmetrizer, CsrWithTranspose, Diagonal, FnOperator, Fused,
    Jacobi, LinOp, ResidualSums,
};

use serde::Serialize;

/// The most right-hand sides an iterative solve takes at once.
pub const MAX_COLUMNS: usize = 8;

/// When to stop an iterative solve.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, Default)]
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

crate::names::option_names!(Stopping, InputError, |s| InputError::UnknownStopping(s.to_string()), {
    Weak => "weak",
    WeakVertex => "weak-vertex",
    Strong => "strong",
});

/// Parameters of the iterative solvers.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Params {
    /// ε of the stopping criterion (default 1e-5, as in the paper); positive and finite.
    pub tolerance: f64,
    /// Which criterion (default: the paper's weak one).
    pub stopping: Stopping,
    /// Iteration cap, at least 1 (default 10,000).
    pub max_iterations: usize,
    /// Keep the relative residual of every iteration (default true).
    pub record_history: bool,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            tolerance: 1e-5,
            stopping: Stopping::Weak,
            max_iterations: 10_000,
            record_history: true,
        }
    }
}

impl Params {
    /// Checks the tolerance (positive, finite) and the iteration cap (≥ 1).
    pub fn validate(&self) -> Result<(), InputError> {
        if !(self.tolerance > 0.0 && self.tolerance.is_finite()) {
            return Err(InputError::Tolerance(self.tolerance));
        }
        if self.max_iterations == 0 {
            return Err(InputError::MaxIterations);
        }
        Ok(())
    }
}

/// What an iterative solve did, per column.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Info {
    /// Iterations each column took.
    pub iterations: Vec<usize>,
    /// Final relative residual `‖B x_c − b_c‖ / ‖b_c‖` of each column (recomputed).
    pub residuals: Vec<f64>,
    /// Relative residual per iteration (the initial one first), per column, from the
    /// solver's recurrence; empty when [`Params::record_history`] is off.
    pub history: Vec<Vec<f64>>,
    /// Wall-clock seconds.
    pub seconds: f64,
}

impl Info {
    /// An empty record for k columns.
    pub(crate) fn new(k: usize) -> Self {
        Info {
            iterations: vec![0; k],
            residuals: Vec::new(),
            history: vec![Vec::new(); k],
            seconds: 0.0,
        }
    }
}

/// What one solve did, whichever solver ran: the filters' per-solve record
/// (serialized without a tag; the BiCG and direct variants add their own fields).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum SolveInfo {
    /// CG, PCG, CG on the symmetrized system, BiCGSTAB.
    Iterative(Info),
    /// BiCG, with its plateau.
    Bicg(BicgInfo),
    /// A direct solve: no iterations, the residuals it left and the factorization.
    Direct {
        /// Iterations (all 0), residuals, empty history, solve seconds.
        #[serde(flatten)]
        info: Info,
        /// The factorization the solve used.
        factorization: DirectInfo,
    },
}

impl SolveInfo {
    /// The facts every solver reports.
    pub fn info(&self) -> &Info {
        match self {
            SolveInfo::Iterative(info) | SolveInfo::Direct { info, .. } => info,
            SolveInfo::Bicg(b) => &b.info,
        }
    }
    /// Iterations per column (0 for a direct solve).
    pub fn iterations(&self) -> &[usize] {
        &self.info().iterations
    }
    /// Final relative residuals per column.
    pub fn residuals(&self) -> &[f64] {
        &self.info().residuals
    }
    /// Relative residual per iteration, per column.
    pub fn history(&self) -> &[Vec<f64>] {
        &self.info().history
    }
    /// Seconds of the solve (for a direct solve, without the factorization).
    pub fn seconds(&self) -> f64 {
        self.info().seconds
    }
    /// BiCG's first plateau iteration per column; `None` for the other solvers.
    pub fn plateau_at(&self) -> Option<&[Option<usize>]> {
        match self {
            SolveInfo::Bicg(b) => Some(&b.plateau_at),
            _ => None,
        }
    }
    /// The factorization of a direct solve.
    pub fn factorization(&self) -> Option<&DirectInfo> {
        match self {
            SolveInfo::Direct { factorization, .. } => Some(factorization),
            _ => None,
        }
    }
}

/// Arguments a solver cannot work with. Fix the call: sizes, parameters or the
/// preconditioner.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InputError {
    /// The number of right-hand sides is 0 or above [`MAX_COLUMNS`].
    #[error("{k} right-hand sides at once; a solve takes 1 to {MAX_COLUMNS}")]
    Columns {
        /// Columns asked for.
        k: usize,
    },
    /// The right-hand side does not have n·k values.
    #[error("the operator is {n}×{n} but the right-hand side has {len} values for {k} columns")]
    RightHandSide {
        /// n.
        n: usize,
        /// k.
        k: usize,
        /// Values given.
        len: usize,
    },
    /// The initial guess differs in size from the right-hand side.
    #[error("the initial guess has {len} values, the right-hand side {want}")]
    InitialGuess {
        /// Values given.
        len: usize,
        /// Values of the right-hand side.
        want: usize,
    },
    /// A work block or weight vector has the wrong length.
    #[error("the {what} has {len} values, {want} expected")]
    Block {
        /// Which argument.
        what: &'static str,
        /// Values given.
        len: usize,
        /// Values expected.
        want: usize,
    },
    /// The tolerance is not positive and finite.
    #[error("the tolerance must be positive and finite, got {0}")]
    Tolerance(f64),
    /// The iteration cap is 0.
    #[error("the iteration cap must be at least 1")]
    MaxIterations,
    /// The preconditioner was built for another size.
    #[error("the preconditioner has {got} rows, the operator {n}")]
    Preconditioner {
        /// n of the operator.
        n: usize,
        /// Rows of the preconditioner.
        got: usize,
    },
    /// A zero or non-finite diagonal entry: Jacobi preconditioning would divide by it.
    #[error("diagonal entry {row} is {value}; Jacobi preconditioning needs a nonzero diagonal")]
    SingularDiagonal {
        /// Row.
        row: usize,
        /// The entry.
        value: f64,
    },
    /// An entry of a symmetrizer is not positive and finite.
    #[error("symmetrizer entry {row} is {value}; it must be positive and finite")]
    Symmetrizer {
        /// Row.
        row: usize,
        /// The entry.
        value: f64,
    },
    /// `s_i a_ij ≠ s_j a_ji`: the diagonal given does not make the matrix symmetric.
    /// Use [`CsrWithTranspose`] for a matrix without a symmetrizer.
    #[error("the symmetrizer does not make entries ({row}, {col}) and ({col}, {row}) equal")]
    NotSymmetrizable {
        /// Row of the entry.
        row: usize,
        /// Column of the entry.
        col: usize,
    },
    /// Not the name of a stopping criterion.
    #[error("unknown stopping criterion `{0}` (weak, weak-vertex, strong)")]
    UnknownStopping(String),
}

/// Errors of this module: each solver's own error, or bad arguments.
#[derive(Debug, thiserror::Error)]
pub enum SolveError {
    /// Conjugate gradients failed.
    #[error(transparent)]
    Cg(#[from] CgError),
    /// Bi-conjugate gradients failed.
    #[error(transparent)]
    Bicg(#[from] BicgError),
    /// BiCGSTAB failed.
    #[error(transparent)]
    Bicgstab(#[from] BicgstabError),
    /// A sparse factorization or direct solve failed.
    #[error(transparent)]
    Direct(#[from] DirectError),
    /// The arguments are unusable.
    #[error(transparent)]
    Input(#[from] InputError),
}

impl SolveError {
    /// What the solver did before it stopped at the iteration cap, if that is why it
    /// failed.
    pub fn unconverged(&self) -> Option<SolveInfo> {
        match self {
            SolveError::Cg(CgError::NoConvergence { info })
            | SolveError::Bicgstab(BicgstabError::NoConvergence { info }) => {
                Some(SolveInfo::Iterative((**info).clone()))
            }
            SolveError::Bicg(BicgError::NoConvergence { info }) => {
                Some(SolveInfo::Bicg((**info).clone()))
            }
            _ => None,
        }
    }

    /// True when the system matrix was found not to be positive definite (a CG
    /// curvature `pᵀBp ≤ 0`, a non-positive diagonal under Jacobi, or a Cholesky
    /// pivot ≤ 0). For `I + λS` with the SQL, negative weights are the usual cause.
    pub fn is_not_positive_definite(&self) -> bool {
        matches!(
            self,
            SolveError::Cg(CgError::NotPositiveDefinite { .. })
                | SolveError::Cg(CgError::NonPositiveDiagonal { .. })
                | SolveError::Direct(DirectError::NotPositiveDefinite { .. })
        )
    }
}

/// `M + λF` as a CSR matrix, `M = diag(mass)` (`None`: the identity). With F from
/// [`crate::operator`] (n×n, sign `F = D − W`) and λ > 0 this is the implicit-fairing
/// matrix of Desbrun et al. (1999): SPD for symmetric positive semi-definite F.
pub fn shifted_system(f: &crate::SparseMatrix, mass: Option<&[f64]>, lambda: f64) -> CsrMatrix {
    let ones;
    let m = match mass {
        Some(m) => m,
        None => {
            ones = vec![1.0; f.nrows()];
            &ones
        }
    };
    CsrMatrix::from_csc(f).shifted(m, lambda)
}

/// Relative residuals `‖B x_c − b_c‖/‖b_c‖` of the n×k blocks `x`, `b`, recomputed
/// from scratch (absolute residuals for zero columns of `b`).
///
/// # Errors
/// [`InputError`] for k outside 1 ..= [`MAX_COLUMNS`] or blocks that are not n×k.
pub fn relative_residuals(
    op: &(impl LinOp + ?Sized),
    x: &[f64],
    b: &[f64],
    k: usize,
) -> Result<Vec<f64>, InputError> {
    let mut r = vec![0.0; b.len()];
    Ok(op.residual(b, x, &mut r, k, None, None)?.relative(k))
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

    /// Largest entry-wise difference of two blocks.
    pub fn max_diff(a: &[f64], b: &[f64]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
    }

    /// The diagonal matrix of `values`.
    pub fn diagonal(values: &[f64]) -> crate::solve::CsrMatrix {
        let trip: Vec<_> = values
            .iter()
            .enumerate()
            .map(|(i, &v)| faer::sparse::Triplet::new(i, i, v))
            .collect();
        let n = values.len();
        crate::solve::CsrMatrix::from_csc(
            &crate::SparseMatrix::try_new_from_triplets(n, n, &trip).unwrap(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn params_are_validated() {
        assert!(Params::default().validate().is_ok());
        for tolerance in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let p = Params {
                tolerance,
                ..Default::default()
            };
            assert!(matches!(p.validate(), Err(InputError::Tolerance(_))));
        }
        let p = Params {
            max_iterations: 0,
            ..Default::default()
        };
        assert_eq!(p.validate(), Err(InputError::MaxIterations));
    }
}
