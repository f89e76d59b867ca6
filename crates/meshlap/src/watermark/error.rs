//! The error of [`super::embed`] and [`super::detect`]: each cause names its fix; the
//! error of the step underneath (partitioning, operator, eigensolver, registration) is
//! kept as the source.

use super::message::MessageError;
use super::register::RegisterError;
use super::resample::ResampleError;
use crate::mesh::MeshError;
use crate::operator::{OperatorError, OperatorKind};
use crate::partition::PartitionError;
use crate::spectral::SpectralError;

/// Errors of spectral watermark embedding and detection.
#[derive(Debug, thiserror::Error)]
pub enum WatermarkError {
    /// The message text is invalid (see [`MessageError`]).
    #[error("message: {0}")]
    Message(#[from] MessageError),
    /// The mesh has too few low-frequency coefficients for the message: fewer than
    /// `bits × chip_rate` slots. Fix: a smaller patch size, a wider band, a lower chip
    /// rate or a shorter message.
    #[error("the mesh offers {slots} coefficient slots but {bits} bits × chip rate {chip_rate} need {needed}; use a smaller --patch-size, a lower --chip-rate or a shorter message")]
    TooSmall {
        /// Bits of the message.
        bits: usize,
        /// Chips per bit (at least 1).
        chip_rate: usize,
        /// `bits × chip_rate`.
        needed: usize,
        /// Slots available: 3 × Σ over patches of the band's coefficients.
        slots: usize,
    },
    /// A parameter is out of range; the message names the valid range.
    #[error("parameter `{name}` = {value}: {reason}")]
    InvalidParameter {
        /// The field of the parameters struct.
        name: &'static str,
        /// Its value, as text.
        value: String,
        /// The valid range.
        reason: &'static str,
    },
    /// The operator depends on the geometry or has no real spectrum; watermarking
    /// needs a combinatorial operator (kirchhoff, tutte, graph, sql, sstl, tutte2).
    #[error("the {0} operator is not combinatorial; use kirchhoff, tutte, sql or sstl")]
    UnsupportedOperator(OperatorKind),
    /// The mesh is empty or its connectivity is invalid (non-manifold edges, bad
    /// indices): clean or repair it first (`meshlap clean`).
    #[error("mesh: {0}")]
    Mesh(#[from] MeshError),
    /// Partitioning into patches failed (e.g. an isolated vertex: clean the mesh).
    #[error("partition: {0}")]
    Partition(#[from] PartitionError),
    /// A patch operator could not be assembled.
    #[error("patch operator: {0}")]
    Operator(#[from] OperatorError),
    /// A patch's low-frequency eigenvectors could not be computed.
    #[error("patch spectrum: {0}")]
    Spectrum(#[from] SpectralError),
    /// The suspect could not be registered to the original: it has nothing in common
    /// with it (or a registration parameter is invalid).
    #[error("registration: {0}")]
    Registration(#[from] RegisterError),
    /// MSDM2 of the marked mesh could not be measured.
    #[error("msdm2: {0}")]
    Metric(#[from] crate::metric::MetricError),
    /// The registered suspect could not be resampled onto the original.
    #[error("resampling: {0}")]
    Resample(#[from] ResampleError),
}
