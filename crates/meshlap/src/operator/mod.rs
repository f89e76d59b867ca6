//! Discrete mesh Laplacian operators.

/// Errors of operator assembly.
#[derive(Debug, thiserror::Error)]
pub enum OperatorError {
    /// The mesh is unsuitable.
    #[error(transparent)]
    Mesh(#[from] crate::mesh::MeshError),
}
