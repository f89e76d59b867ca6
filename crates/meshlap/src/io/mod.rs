//! Mesh readers and writers. (Filled in by the I/O work.)

/// Errors of mesh reading and writing.
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    /// Placeholder until the readers land.
    #[error("i/o not implemented")]
    Unimplemented,
}
