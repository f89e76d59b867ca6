//! The indexed triangle mesh and everything about its combinatorics.
//!
//! [`TriMesh`] stores `f64` positions and `u32` triangle corner indices. Its
//! connectivity ([`topology::Topology`]) is built once from the faces.

pub mod builtin;
pub mod clean;
pub(crate) mod component_labels;
pub mod edit;
pub mod graph;
pub mod nonmanifold;
pub mod topology;

use std::fmt;

/// Index of a vertex (a row of [`TriMesh::positions`]).
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct VertexId(pub u32);

/// Index of a triangle (a row of [`TriMesh::faces`]).
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct FaceId(pub u32);

/// Index of an undirected edge in a [`topology::Topology`].
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct EdgeId(pub u32);

macro_rules! id_impls {
    ($($t:ident),*) => {$(
        impl $t {
            /// The index as `usize`.
            #[inline]
            pub fn idx(self) -> usize {
                self.0 as usize
            }
        }
        impl fmt::Display for $t {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "{}", self.0)
            }
        }
    )*};
}
id_impls!(VertexId, FaceId, EdgeId);

/// An indexed triangle mesh: `positions` (n×3, `f64`) and `faces` (m×3, `u32` indices
/// into `positions`, counter-clockwise seen from outside when consistently oriented).
///
/// A `TriMesh` as read from a file may contain unreferenced vertices, degenerate or
/// duplicate faces; [`clean::clean`] removes those and reports what it found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions.
    pub positions: Vec<[f64; 3]>,
    /// Triangles as three vertex indices.
    pub faces: Vec<[u32; 3]>,
}

impl TriMesh {
    /// A mesh from positions and faces (no validation; see [`TriMesh::validate`]).
    pub fn new(positions: Vec<[f64; 3]>, faces: Vec<[u32; 3]>) -> Self {
        Self { positions, faces }
    }

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.positions.len()
    }

    /// Number of triangles.
    pub fn n_faces(&self) -> usize {
        self.faces.len()
    }

    /// Checks that every index is in range and every coordinate finite, and that
    /// the mesh has at least one face.
    pub fn validate(&self) -> Result<(), MeshError> {
        validate_parts(&self.positions, &self.faces)
    }

    /// Axis-aligned bounding box `(min, max)`; `None` for an empty mesh.
    pub fn bounding_box(&self) -> Option<([f64; 3], [f64; 3])> {
        let first = *self.positions.first()?;
        let mut lo = first;
        let mut hi = first;
        for p in &self.positions {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        Some((lo, hi))
    }

    /// Length of the bounding-box diagonal (0 for an empty mesh).
    pub fn bbox_diagonal(&self) -> f64 {
        match self.bounding_box() {
            Some((lo, hi)) => {
                ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2) + (hi[2] - lo[2]).powi(2)).sqrt()
            }
            None => 0.0,
        }
    }
}

/// Errors about a mesh's content or structure.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MeshError {
    /// The mesh has no faces.
    #[error("the mesh has no faces")]
    Empty,
    /// A coordinate is NaN or infinite.
    #[error("vertex {vertex} has a NaN or infinite coordinate")]
    NonFinite {
        /// The offending vertex.
        vertex: usize,
    },
    /// A face refers to a vertex that does not exist.
    #[error("face {face} refers to vertex {index}, but the mesh has {n_vertices} vertices")]
    IndexOutOfRange {
        /// The offending face.
        face: usize,
        /// The out-of-range index.
        index: usize,
        /// Number of vertices.
        n_vertices: usize,
    },
    /// A face uses one vertex at two corners (a degenerate face). Connectivity and
    /// the operators need three distinct corners; cleaning drops such faces.
    #[error("face {face} uses vertex {vertex} at two corners (clean the mesh first)")]
    RepeatedCorner {
        /// The offending face.
        face: usize,
        /// The repeated vertex.
        vertex: usize,
    },
    /// A face has the same three vertices as an earlier face (in any order or
    /// orientation): an exact duplicate. Cleaning drops the later copy
    /// ([`clean::CleanOptions::drop_duplicate_faces`]); [`clean::check_clean`]
    /// refuses it.
    #[error("face {face} repeats the vertices of face {first} (clean the mesh first)")]
    DuplicateFace {
        /// The later copy.
        face: usize,
        /// The first face with the same vertices.
        first: usize,
    },
    /// An edge is shared by more than two faces.
    #[error("edge ({a}, {b}) is shared by {faces} faces (non-manifold); run `meshlap clean --split-nonmanifold` first")]
    NonManifoldEdge {
        /// First endpoint.
        a: u32,
        /// Second endpoint.
        b: u32,
        /// Number of incident faces.
        faces: usize,
    },
    /// A vertex's faces do not form a single fan.
    #[error("vertex {vertex} is non-manifold; run `meshlap clean --split-nonmanifold` first")]
    NonManifoldVertex {
        /// The offending vertex.
        vertex: u32,
    },
    /// An edge flip is not allowed.
    #[error("cannot flip edge ({a}, {b}): {reason}")]
    IllegalFlip {
        /// First endpoint.
        a: u32,
        /// Second endpoint.
        b: u32,
        /// Why not.
        reason: &'static str,
    },
    /// A vertex split is not possible.
    #[error("cannot split vertex {vertex}: {reason}")]
    IllegalSplit {
        /// The vertex.
        vertex: u32,
        /// Why not.
        reason: &'static str,
    },
    /// More faces than the connectivity's 31-bit half-edge ids can address.
    #[error("the mesh has {faces} faces; at most {max} are supported")]
    TooManyFaces {
        /// Faces in the mesh.
        faces: usize,
        /// The limit.
        max: usize,
    },
    /// Invalid parameters for a generated mesh.
    #[error("invalid built-in mesh: {0}")]
    Builtin(String),
}

/// Checks that every corner of `faces` is below `n` ([`MeshError::IndexOutOfRange`]
/// names the first face that is not).
pub fn check_face_indices(faces: &[[u32; 3]], n: usize) -> Result<(), MeshError> {
    let bad = |t: &[u32; 3]| t.iter().any(|&v| v as usize >= n);
    match crate::par::position_first(faces, bad) {
        Some(f) => {
            let index = faces[f]
                .iter()
                .find(|&&v| v as usize >= n)
                .copied()
                .unwrap_or(0);
            Err(MeshError::IndexOutOfRange {
                face: f,
                index: index as usize,
                n_vertices: n,
            })
        }
        None => Ok(()),
    }
}

/// [`TriMesh::validate`] on borrowed arrays, in parallel; the error names the first
/// offending vertex or face, as a sequential scan would.
pub(crate) fn validate_parts(positions: &[[f64; 3]], faces: &[[u32; 3]]) -> Result<(), MeshError> {
    if faces.is_empty() {
        return Err(MeshError::Empty);
    }
    let not_finite = |p: &[f64; 3]| !p.iter().all(|c| c.is_finite());
    if let Some(vertex) = crate::par::position_first(positions, not_finite) {
        return Err(MeshError::NonFinite { vertex });
    }
    check_face_indices(faces, positions.len())
}
