//! Linear solvers for implicit fairing. (Filled in by the solver work.)

/// Errors of the linear solvers.
#[derive(Debug, thiserror::Error)]
pub enum SolveError {
    /// Placeholder until the solvers land.
    #[error("solvers not implemented")]
    Unimplemented,
}
