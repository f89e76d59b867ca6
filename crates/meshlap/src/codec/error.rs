//! The codec's errors. Messages describe the problem; what to run about it (for
//! example `meshlap clean --split-nonmanifold` before compressing a non-manifold mesh)
//! is for the front end to add.
//!
//! Causes and fixes:
//! * [`CodecError::Parameter`]: an option of [`super::compress`] is out of its range
//!   (each [`ParameterError`] names the range); fix the option.
//! * [`CodecError::Mesh`]: the mesh itself is invalid (no faces, a NaN coordinate, an
//!   index out of range).
//! * [`CodecError::Unreferenced`], [`CodecError::DegenerateFace`]: a vertex belongs to
//!   no face, or a face uses a vertex twice; drop them first (`mesh::clean::clean`
//!   does, and every command of the CLI cleans its input).
//! * [`CodecError::NonManifold`], [`CodecError::NotOriented`]: only the connectivity
//!   coder alone ([`super::connectivity::encode`]) returns them; [`super::compress`]
//!   cuts such meshes itself and codes how to re-join them.
//! * [`CodecError::StepTooSmall`]: the quantization step is so fine that a quantized
//!   value exceeds 31 bits; use fewer bits.
//! * [`CodecError::Partition`], [`CodecError::PatchOperator`],
//!   [`CodecError::PatchBasis`]: the spectral coder's set-up failed on a patch (the
//!   source error says why); the spatial coder does not need it.
//! * [`CodecError::Truncated`], [`CodecError::Corrupt`], [`CodecError::Checksum`],
//!   [`CodecError::BadMagic`], [`CodecError::Version`]: the input is not a readable
//!   `.mlz` file of this version; nothing is decoded from it.
//! * [`CodecError::Internal`]: a bug.

use crate::mesh::MeshError;
use crate::operator::{OperatorError, OperatorKind};
use crate::partition::PartitionError;
use crate::spectral::SpectralError;

/// An option of [`super::compress`] outside its range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParameterError {
    /// Quantization bits outside their range.
    #[error("quantization bits must be in [{min}, {max}], got {got}")]
    Bits {
        /// The value given.
        got: f64,
        /// Smallest value.
        min: f64,
        /// Largest value.
        max: f64,
    },
    /// A rate target that is not a positive number.
    #[error("the target rate must be a positive number of bits per vertex, got {0}")]
    TargetBpv(f64),
    /// A patch size outside its range.
    #[error("the patch size must be between {min} and {max} vertices, got {got}")]
    PatchSize {
        /// The value given.
        got: usize,
        /// Smallest value.
        min: usize,
        /// Largest value.
        max: usize,
    },
    /// A keep ratio outside `(0, 1]`.
    #[error("the keep ratio must be in (0, 1], got {0}")]
    KeepRatio(f64),
    /// No coefficient kept per patch.
    #[error("at least one coefficient per patch must be kept, got {0}")]
    Coefficients(u32),
    /// A band slope outside its range.
    #[error("the band slope must be in [0, {max}], got {got}")]
    BandSlope {
        /// The value given.
        got: f64,
        /// Largest value.
        max: f64,
    },
    /// A dead-zone rounding offset outside its range.
    #[error("the dead-zone rounding offset must be in [{min}, {max}], got {got}")]
    DeadZone {
        /// The value given.
        got: f64,
        /// Smallest value.
        min: f64,
        /// Largest value.
        max: f64,
    },
    /// A rate–distortion multiplier outside its range.
    #[error("the rate-distortion multiplier must be in [0, {max}], got {got}")]
    RdoLambda {
        /// The value given.
        got: f64,
        /// Largest value.
        max: f64,
    },
    /// An operator the spectral coder cannot use.
    #[error(
        "the {0} operator cannot be used for compression (the coder takes kirchhoff, tutte, graph, sql or sstl)"
    )]
    Operator(OperatorKind),
    /// A quantization step that is not a positive finite number.
    #[error("the quantization step must be positive and finite, got {0}")]
    Step(f64),
    /// A geometry mode name that is not auto, spectral or spatial.
    #[error("unknown geometry mode {0:?} (expected auto, spectral or spatial)")]
    Mode(String),
}

/// What makes a mesh non-manifold for the connectivity coder.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NonManifold {
    /// An edge shared by more than two faces.
    Edge {
        /// First endpoint.
        a: u32,
        /// Second endpoint.
        b: u32,
    },
    /// A vertex whose faces form several fans.
    Vertex(u32),
    /// A boundary loop that passes through a vertex twice.
    BoundaryLoop,
}

impl std::fmt::Display for NonManifold {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            NonManifold::Edge { a, b } => write!(f, "edge ({a}, {b})"),
            NonManifold::Vertex(v) => write!(f, "vertex {v}"),
            NonManifold::BoundaryLoop => f.write_str("a boundary loop touches itself"),
        }
    }
}

/// Errors of encoding and decoding.
#[derive(Debug, thiserror::Error)]
pub enum CodecError {
    /// An option is out of its range.
    #[error(transparent)]
    Parameter(#[from] ParameterError),
    /// The mesh is invalid (no faces, a non-finite coordinate, an index out of range).
    #[error("cannot compress this mesh: {0}")]
    Mesh(#[source] MeshError),
    /// A face uses a vertex twice (`compress` needs cleaned faces).
    #[error(
        "cannot compress face {face}: it uses a vertex twice; drop such faces first (clean the mesh)"
    )]
    DegenerateFace {
        /// The first such face.
        face: usize,
    },
    /// A vertex belongs to no face (`compress` needs every vertex in a face).
    #[error(
        "cannot compress vertex {vertex}: no face references it ({count} such vertices); drop them first (clean the mesh)"
    )]
    Unreferenced {
        /// The first such vertex.
        vertex: u32,
        /// How many vertices no face references.
        count: usize,
    },
    /// The mesh has a non-manifold edge or vertex (the connectivity coder alone).
    #[error("cannot compress a non-manifold mesh ({0})")]
    NonManifold(NonManifold),
    /// The mesh is not consistently oriented (the connectivity coder alone).
    #[error("cannot compress a mesh that is not consistently oriented ({0} edges disagree)")]
    NotOriented(usize),
    /// The quantization step is too fine for the coordinates.
    #[error(
        "the quantization step is too small for these coordinates (a quantized value exceeds 31 bits)"
    )]
    StepTooSmall,
    /// Partitioning the mesh into patches failed.
    #[error("partitioning the mesh into patches failed: {0}")]
    Partition(#[source] PartitionError),
    /// The operator of a patch could not be assembled.
    #[error("assembling the operator of a patch failed: {0}")]
    PatchOperator(#[source] OperatorError),
    /// The eigenbasis of a patch could not be computed or applied.
    #[error("the eigenbasis of a patch failed: {0}")]
    PatchBasis(#[source] SpectralError),
    /// A section does not fit the container's 32-bit lengths.
    #[error("a section of {0} bytes is larger than the format's 4 GiB limit")]
    SectionTooLarge(usize),
    /// The input ended early.
    #[error("truncated file: the {0} ends early")]
    Truncated(&'static str),
    /// The input is not a valid stream.
    #[error("corrupt file: {0}")]
    Corrupt(&'static str),
    /// The decoded faces do not form a mesh.
    #[error("corrupt file: the decoded faces do not form a mesh: {0}")]
    CorruptFaces(#[source] MeshError),
    /// Not an `.mlz` file.
    #[error("not a meshlap compressed file (bad magic number)")]
    BadMagic,
    /// A format version this build cannot read.
    #[error(
        "unsupported .mlz version {found}: this build reads versions {oldest} to {newest}; re-compress the mesh with this meshlap"
    )]
    Version {
        /// The file's version.
        found: u16,
        /// The oldest version this build reads.
        oldest: u16,
        /// The newest version this build reads (and writes).
        newest: u16,
    },
    /// The checksum does not match.
    #[error("corrupt file: checksum mismatch in the {0} section")]
    Checksum(&'static str),
    /// An internal invariant failed (a bug).
    #[error("internal codec error: {0}")]
    Internal(&'static str),
    /// An internal invariant failed on a patch's connectivity (a bug).
    #[error("internal codec error: a patch's faces do not form a mesh: {0}")]
    PatchTopology(#[source] MeshError),
}
