//! The codec's errors.

/// Errors of encoding and decoding.
#[derive(Debug, thiserror::Error)]
pub enum CodecError {
    /// The mesh has a non-manifold edge or vertex.
    #[error(
        "cannot compress a non-manifold mesh ({0}); run `meshlap clean --split-nonmanifold` first"
    )]
    NonManifold(String),
    /// The mesh is not consistently oriented.
    #[error("cannot compress a mesh that is not consistently oriented ({0} edges disagree)")]
    NotOriented(usize),
    /// The input ended early.
    #[error("truncated file: the {0} ends early")]
    Truncated(&'static str),
    /// The input is not a valid stream.
    #[error("corrupt file: {0}")]
    Corrupt(&'static str),
    /// Not an `.mlz` file.
    #[error("not a meshlap compressed file (bad magic number)")]
    BadMagic,
    /// A format version this build cannot read.
    #[error(
        "unsupported .mlz version {found}: this build reads version {supported} only; re-compress the mesh with this meshlap"
    )]
    Version {
        /// The file's version.
        found: u16,
        /// The version this build reads.
        supported: u16,
    },
    /// The checksum does not match.
    #[error("corrupt file: checksum mismatch in the {0} section")]
    Checksum(&'static str),
    /// A parameter is out of range.
    #[error("{0}")]
    Parameter(String),
    /// An internal invariant failed (a bug).
    #[error("internal codec error: {0}")]
    Internal(&'static str),
}
