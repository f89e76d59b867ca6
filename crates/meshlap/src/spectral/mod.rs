//! Eigenvalue-decomposition transforms. (Filled in by the spectral work.)

pub mod partial;
pub mod partition;

/// Errors of spectral computations.
#[derive(Debug, thiserror::Error)]
pub enum SpectralError {
    /// Placeholder until the spectral module lands.
    #[error("spectral module not implemented")]
    Unimplemented,
}
