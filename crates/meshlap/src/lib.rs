//! # meshlap
//!
//! Discrete mesh Laplacians for digital geometry processing, after
//! H. Zhang, *Discrete Combinatorial Laplacian Operators for Digital Geometry
//! Processing* (Geometric Modeling and Computing, Seattle 2003; Nashboro Press 2004).
//!
//! ## Sign convention
//! Every operator in this crate is **positive semi-definite**: `F = D − W`, as in the
//! paper (the Kirchhoff operator has `+d_i` on the diagonal and `−1` off it). libigl's
//! `cotmatrix` and pmp-library use the opposite (negative semi-definite) sign.
//!
//! ## Layout
//! - [`mesh`]: the indexed triangle mesh, its half-edge connectivity, cleaning and
//!   validation, non-manifold splitting and built-in generated meshes.
//! - [`io`]: OBJ, OFF, PLY (ascii/binary, tristrips) and STL readers and writers.
//! - [`operator`]: the combinatorial (KL, TL, GL, SQL, SSTL, T²) and geometric (SDL,
//!   cotangent, mean-value) operators as sparse matrices.
//! - [`analysis`]: matrix-theoretic properties (symmetry, stochasticity, GSML status,
//!   eigenvalue bounds), smoothing iterations and SQL negative-weight repair.
//! - [`solve`]: CG, PCG, BiCG, BiCGSTAB and direct solvers for implicit fairing.
//! - [`codec`]: mesh compression (connectivity coding, spectral geometry coding, `.mlz`).
//! - [`metric`]: distortion metrics (vertex, Metro surface distance, Zhang, Karni–Gotsman).
//! - [`experiment`]: the paper's experiments as functions returning tables and charts
//!   (feature `experiments`).
//! - [`raster`]: RGB images, PNG, text and color maps (feature `pictures`).
//! - [`plot`]: PNG line charts for the experiments (feature `pictures`).
//! - [`render`]: software rendering of meshes to pictures, with per-vertex scalars
//!   through a color map (the paper's figures, eigenvectors; feature `pictures`).
//! - [`partition`]: METIS graph partitioning of a mesh into connected patches (used by
//!   the patch-wise transforms, the codec and watermarking).
//! - [`spectral`]: eigenvalue-decomposition (ED) transforms, the k smallest eigenpairs
//!   at any size ([`spectral::smallest()`]), partial spectra, extreme eigenvalues,
//!   patch-wise reconstruction.
//! - [`watermark`]: spectral mesh watermarking (Ohbuchi et al. 2001/2002) and the
//!   attacks of the watermarking benchmark (Wang et al. 2010).
//!
//! `ARCHITECTURE.md` at the repository root maps the layers to the modules.
//!
//! ## Features
//! - `pictures`: [`raster`], [`plot`] and [`render`] (dependencies plotters, png,
//!   ab_glyph and an embedded font).
//! - `experiments` (implies `pictures`): [`experiment`].
//!
//! Both are on by default; a user of the core library alone sets
//! `default-features = false` and compiles none of the picture dependencies.

// Index loops over vertices read like the formulas they implement.
#![allow(clippy::needless_range_loop)]
#![warn(missing_docs)]

pub mod analysis;
pub mod codec;
pub mod cpu;
pub mod error;
#[cfg(feature = "experiments")]
pub mod experiment;
pub mod filter;
pub mod input;
pub mod io;
mod mem;
pub mod mesh;
pub mod metric;
mod names;
pub mod operator;
pub mod par;
pub mod partition;
#[cfg(feature = "pictures")]
pub mod plot;
#[cfg(feature = "pictures")]
pub mod raster;
#[cfg(feature = "pictures")]
pub mod render;
pub mod rng;
pub mod solve;
pub mod spectral;
pub mod watermark;

pub use error::{Error, Result};
pub use mem::{keep_freed_memory, KEEP_FREED_BYTES, MMAP_THRESHOLD_BYTES};
pub use mesh::{FaceId, TriMesh, VertexId};

/// Sparse matrix type used throughout the crate: compressed sparse column, `f64`
/// values, `usize` indices (faer). For the symmetric operators CSC and CSR coincide.
pub type SparseMatrix = faer::sparse::SparseColMat<usize, f64>;
