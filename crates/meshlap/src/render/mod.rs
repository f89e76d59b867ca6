//! Pictures of meshes: a small software rasterizer (z-buffer, flat or smooth Lambert
//! shading, per-vertex scalars through a color map with a legend) so that the
//! experiments can show what the paper shows in its figures (Fig. 1: GL versus GSML
//! truncated reconstructions; Fig. 4: KL artifacts at low-degree vertices), and
//! eigenvectors can be looked at, with no GPU, window system or external renderer.
//!
//! Written by hand because no maintained crate rasterizes a triangle mesh to a picture
//! without a GPU context (`wgpu`/`three-d` need one; `tiny-skia` is a 2-D vector
//! renderer with no depth buffer). The algorithm is the textbook one:
//!
//! - [`camera`]: vertices are turned into a camera frame (azimuth about +y, then
//!   elevation about +x) and projected orthographically; the framing fits the mesh's
//!   projected bounding rectangle (or a given sphere or window) to the picture;
//! - `zbuffer`: each triangle is scan-converted with barycentric coordinates and a
//!   depth test at `supersample²` samples per pixel, shaded two-sided (back faces are
//!   lit like front faces, so open and inconsistently oriented meshes still read
//!   well), and box-filtered down;
//! - [`Scalars`]: per-vertex values and their color map — degrees, height, a `.npy`
//!   file, or an operator's eigenvector;
//! - `legend`: a color bar with the range's ends for [`Coloring::Scalar`];
//! - [`Panel`] composes several pictures side by side with captions.
//!
//! [`render`] returns an [`Image`] (RGB8, row-major: what the Python bindings hand
//! out as an `(H, W, 3)` array); [`Image::write_png`] writes it. Only built with the
//! `pictures` feature.

pub mod camera;
mod draw;
mod legend;
mod options;
mod panel;
mod scalars;
mod zbuffer;

pub use crate::raster::{Colormap, Image};
pub use camera::{bounding_sphere, Framing, Window};
pub use draw::render;
pub use options::{Coloring, RenderOptions, LEGEND_MIN_SIZE};
pub use panel::Panel;
pub use scalars::Scalars;

/// Errors of rendering.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The mesh has no faces (or no vertices): nothing to draw.
    #[error("nothing to render: the mesh has no faces")]
    Empty,
    /// A face index is out of range or a coordinate is not finite; clean the mesh
    /// (`meshlap clean`) or fix the input.
    #[error(transparent)]
    Mesh(#[from] crate::mesh::MeshError),
    /// The picture size is outside 16 … 8192 pixels per side.
    #[error("picture size {width}×{height} outside 16…8192")]
    Size {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
    },
    /// Supersampling outside 1 … 4 samples per pixel and axis.
    #[error("supersample {0} outside 1…4")]
    Supersample(u32),
    /// The azimuth or elevation is NaN or infinite.
    #[error("view angles must be finite")]
    ViewAngle,
    /// A framing sphere without a positive finite radius, or a window with a non-finite
    /// or negative extent.
    #[error("the framing sphere or window must be finite with a positive size")]
    Framing,
    /// The scalars are not one per vertex (e.g. an array saved for another mesh, or
    /// for the mesh before cleaning dropped unreferenced vertices).
    #[error("{got} scalars for {expected} vertices; give one value per vertex")]
    ScalarCount {
        /// Values given.
        got: usize,
        /// Vertices of the mesh.
        expected: usize,
    },
    /// An explicit scalar range that is not finite with `lo < hi`.
    #[error("scalar range [{lo}, {hi}] must be finite with lo < hi")]
    ScalarRange {
        /// Value of the low end.
        lo: f64,
        /// Value of the high end.
        hi: f64,
    },
    /// A scalar file holds a 2-D array that is not one row or one column.
    #[error(
        "the scalars are a {rows}×{cols} array; give one value per vertex (shape (n,) or (n, 1))"
    )]
    ScalarShape {
        /// Rows of the array.
        rows: usize,
        /// Columns of the array.
        cols: usize,
    },
    /// The eigenvector index is not below the number of vertices.
    #[error("eigenvector {k} asked of an operator with {n} eigenvectors (0 … {})", n.saturating_sub(1))]
    EigenIndex {
        /// The index asked for.
        k: usize,
        /// Vertices (eigenvectors).
        n: usize,
    },
    /// The dense eigendecomposition failed (see [`crate::spectral::SpectralError`]).
    #[error(transparent)]
    Spectral(#[from] crate::spectral::SpectralError),
    /// A panel needs at least one picture.
    #[error("a panel needs at least one picture")]
    EmptyPanel,
    /// The composed panel would exceed 16384 pixels per side.
    #[error("panel {width}×{height} too large (at most 16384 per side)")]
    PanelSize {
        /// Width it would have.
        width: u64,
        /// Height it would have.
        height: u64,
    },
    /// Writing the PNG failed.
    #[error(transparent)]
    Io(#[from] crate::io::IoError),
}

#[cfg(test)]
mod tests;
