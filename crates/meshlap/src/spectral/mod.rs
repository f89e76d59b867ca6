//! Eigenvalue-decomposition (ED) transforms (Zhang 2004 §2.3, §2.6, §4.9; Karni &
//! Gotsman 2000).
//!
//! **Sign convention.** Every operator taken here is positive semi-definite,
//! `F = D − W` as in the paper (libigl/pmp use the negative), so eigenvalues are
//! ascending from the smoothest (lowest-frequency) basis vector.
//!
//! - [`basis`]: the dense eigenbasis `E` of an operator (symmetric, symmetrized
//!   through a positive diagonal similarity — the TL through the GL — or general),
//!   with canonical, deterministic vectors.
//! - [`blocked_evd`]: the default dense symmetric eigensolver (LAPACK's blocked
//!   tridiagonalisation and divide and conquer).
//! - [`tridiagonal_dc`]: all eigenpairs of a symmetric tridiagonal matrix by LAPACK's
//!   divide and conquer (`dstedc`), the middle stage of [`blocked_evd`].
//! - [`dense_evd`]: a bit-reproducible dense symmetric eigensolver for small n (the
//!   codec's patches), selectable in [`BasisOptions::dense_solver`].
//! - [`transform`]: the forward ED-transform `X = E⁻¹x`, its inverse and the truncated
//!   reconstruction `x⁽ᵐ⁾` from the first m coefficients.
//! - [`compaction`]: the transform efficiency (energy compaction) for every m.
//! - [`descriptors`]: heat and wave kernel signatures (Sun et al. 2009; Aubry et al.
//!   2011) from the smallest eigenpairs.

pub mod basis;
pub mod blocked_evd;
pub mod compaction;
pub mod dense_evd;
pub mod descriptors;
pub mod factored_evd;
pub mod transform;
pub mod tridiagonal_dc;

pub use basis::{BasisOptions, DenseSolver, EigenBasis, EigenPath, Normalization, DENSE_LIMIT};
pub use compaction::{energy_compaction, Compaction};
pub use factored_evd::FactoredEvd;
pub use smallest::{smallest, Smallest, SmallestInfo, SmallestParams, SmallestPath};
pub use transform::{forward, inverse, mat_to_positions, positions_to_mat, truncated};

pub mod extremes;
pub mod krylov_schur;
pub mod partial;
pub mod patchwise;
pub mod project;
pub(crate) mod refined_evd;
pub mod sign;
pub mod smallest;
pub(crate) mod thin_products;

/// Errors of spectral computations.
#[derive(Debug, thiserror::Error)]
pub enum SpectralError {
    /// The operator has no rows (empty mesh) or is not square.
    #[error("the operator is empty or not square")]
    Empty,
    /// Too many vertices for a dense eigendecomposition.
    #[error("n = {n} vertices exceeds the dense eigensolver's limit of {limit}")]
    TooLarge {
        /// Vertices.
        n: usize,
        /// The limit.
        limit: usize,
    },
    /// A stored operator entry is NaN or infinite.
    #[error("operator entry #{index} is not finite")]
    NonFinite {
        /// Index into the stored values.
        index: usize,
    },
    /// An input has the wrong length.
    #[error("{what} has {got} entries, expected {expected}")]
    ShapeMismatch {
        /// Which input.
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Actual length.
        got: usize,
    },
    /// A mass-matrix entry is not positive.
    #[error(
        "mass of vertex {vertex} is {value}; the lumped mass must be positive (degenerate faces?)"
    )]
    InvalidMass {
        /// The vertex.
        vertex: usize,
        /// Its mass.
        value: f64,
    },
    /// The symmetric path was asked for a non-symmetric operator.
    #[error("the operator is not symmetric; use the symmetrized or general path")]
    NotSymmetric,
    /// A non-symmetric operator without a positive diagonal symmetrizer.
    #[error("the operator is not symmetric and has no positive diagonal symmetrizer; use the general path")]
    NotSymmetrizable,
    /// The dense eigensolver did not converge.
    #[error("the {path} eigensolver did not converge")]
    NoConvergence {
        /// Which path.
        path: &'static str,
    },
    /// The general path met eigenvalues with a non-negligible imaginary part.
    #[error("the operator has complex eigenvalues (|Im λ| up to {max_imaginary:.3e}); its ED-transform is not real")]
    ComplexSpectrum {
        /// Largest |imaginary part|.
        max_imaginary: f64,
    },
    /// The general path's eigenvectors are (numerically) linearly dependent.
    #[error(
        "the eigenvectors are numerically dependent (defective operator); no ED-transform exists"
    )]
    SingularBasis,
    /// Unknown eigensolver path name.
    #[error("unknown eigensolver path `{0}`; choose auto, symmetric, symmetrized or general")]
    UnknownPath(String),
    /// Another invalid argument.
    #[error("{0}")]
    InvalidArgument(String),
    /// The operator kind has no real spectrum the partial solver can compute.
    ///
    /// Cause: the operator is neither symmetric nor symmetrizable by a positive
    /// diagonal (e.g. the mean-value operator). Fix: use a symmetric or symmetrizable
    /// kind, or the dense general path ([`EigenPath::General`]) on small meshes.
    #[error("the {0} operator is neither symmetric nor symmetrizable by a positive diagonal; its partial spectrum is not available")]
    NoRealSpectrum(crate::operator::OperatorKind),
    /// The matrix is not square.
    #[error("the matrix is {rows}×{cols}, not square")]
    NotSquare {
        /// Rows.
        rows: usize,
        /// Columns.
        cols: usize,
    },
    /// More eigenpairs than the dimension were requested.
    #[error("asked for {count} eigenpairs of an {n}×{n} matrix")]
    TooMany {
        /// Requested.
        count: usize,
        /// Dimension.
        n: usize,
    },
    /// The Ritz tolerance of the partial eigensolver is not a positive finite number
    /// below 1.
    ///
    /// Fix: pass a tolerance such as 1e-10 ([`partial::PartialParams::tolerance`]).
    #[error("the eigensolver tolerance must be in (0, 1), got {0}")]
    InvalidTolerance(f64),
    /// The band or block size of the partial eigensolver is zero, or the block is
    /// larger than the band.
    ///
    /// Cause: [`partial::PartialParams::band_size`] (eigenpairs per shift) and
    /// [`partial::PartialParams::block_size`] (vectors per Krylov block) must be
    /// positive, and a block holds at most one band. Fix: keep the defaults (bands of
    /// 200, blocks of 8), or pass `1 ≤ block_size ≤ band_size`.
    #[error("the eigensolver needs 1 ≤ block size ≤ band size, got a block of {block_size} and a band of {band_size}")]
    InvalidBlocking {
        /// The band size asked for.
        band_size: usize,
        /// The block size asked for.
        block_size: usize,
    },
    /// The number of coefficients to keep is out of range for the mesh.
    ///
    /// Fix: a count in `1..=n` or a percentage in (0, 100] ([`project::Keep`]).
    #[error(transparent)]
    Keep(#[from] project::KeepError),
    /// A sparse matrix could not be built (index out of range; kept from faer).
    #[error("cannot build the sparse matrix")]
    SparseCreation(#[source] faer::sparse::CreationError),
    /// The symbolic analysis (fill-reducing ordering) of `K − σM` failed (out of
    /// memory or index overflow; kept from faer).
    #[error("symbolic factorization of K − σM failed")]
    SymbolicFactorization(#[source] faer::sparse::FaerError),
    /// The numeric LDLᵀ factorization of `K − σM` failed.
    ///
    /// Cause: a zero pivot (σ exactly at an eigenvalue) or non-finite entries. The
    /// band driver moves its shifts off the computed eigenvalues, so this points at an
    /// operator with huge or tiny entries: check the mesh for degenerate faces.
    #[error("factorization of K − σM at σ = {shift} failed")]
    Factorization {
        /// The shift.
        shift: f64,
        /// What failed.
        #[source]
        source: FactorizationFailure,
    },
    /// The block Krylov–Schur iteration could not run at a shift.
    #[error("Krylov–Schur at σ = {shift} failed")]
    Krylov {
        /// The shift.
        shift: f64,
        /// The iteration's error.
        #[source]
        source: krylov_schur::KrylovSchurError,
    },
    /// The Krylov–Schur iteration did not converge within its restart limit.
    ///
    /// Fix: raise [`partial::PartialParams::max_restarts`] or loosen the tolerance.
    #[error("the eigensolver converged on {converged} of {wanted} eigenpairs at σ = {shift} within {restarts} restarts")]
    NotConverged {
        /// The shift.
        shift: f64,
        /// Converged pairs.
        converged: usize,
        /// Wanted pairs.
        wanted: usize,
        /// Restart limit.
        restarts: usize,
    },
    /// The eigensolver found a different number of eigenvalues in a window than
    /// Sylvester's inertia counts there: a result would have skipped eigenpairs, so
    /// none is returned.
    #[error("at σ = {shift}: found {found} eigenvalues in the band window, the inertia count is {expected}")]
    InertiaMismatch {
        /// The shift.
        shift: f64,
        /// Eigenvalues found in the window.
        found: usize,
        /// Eigenvalues in the window by inertia.
        expected: usize,
    },
    /// A matrix given to the partial eigensolver is not symmetric. Cause: a
    /// non-symmetric operator (TL, T², SDL, mean-value) passed as `K`, or a matrix
    /// assembled with one triangle only. Fix: pass the operator through
    /// [`partial::SymmetricProblem::from_operator`], or store both triangles.
    #[error("{what} must be symmetric: max |A − Aᵀ| = {asymmetry:.3e} (max |A| = {scale:.3e})")]
    NotSymmetricMatrix {
        /// Which matrix ("K" or "M").
        what: &'static str,
        /// `max |A − Aᵀ|`.
        asymmetry: f64,
        /// `max |A|`.
        scale: f64,
    },
    /// The sparse mass matrix `M` has no Cholesky factorization. Cause: `M` is not
    /// positive definite (a zero-area face gives a zero row of a consistent mass
    /// matrix; a stiffness matrix passed as `M`). Fix: clean the mesh, or check which
    /// matrix is `K` and which is `M`.
    #[error("the mass matrix M is not positive definite (its Cholesky factorization failed)")]
    MassNotPositiveDefinite {
        /// faer's error.
        #[source]
        source: faer::linalg::cholesky::llt::factor::LltError,
    },
    /// The bands made no progress (should not happen on a PSD operator).
    #[error("band {band}: no new eigenvalue found above {edge}")]
    Stalled {
        /// Band number.
        band: usize,
        /// Upper edge reached.
        edge: f64,
    },
}

/// Why a numeric factorization of `K − σM` failed.
#[derive(Debug, thiserror::Error)]
pub enum FactorizationFailure {
    /// faer's LDLᵀ met a zero pivot.
    #[error("zero pivot")]
    Ldlt(#[from] faer::linalg::cholesky::ldlt::factor::LdltError),
    /// A pivot came out NaN or infinite.
    #[error("non-finite pivot")]
    NonFinitePivot,
}

#[cfg(test)]
pub(crate) mod test_util {
    use crate::mesh::{builtin, TriMesh};
    use crate::operator::OperatorKind;

    /// The kinds with a real spectrum on every mesh (symmetric, or the TL through its
    /// diagonal symmetrizer; the cotangent operator with its mass).
    pub const REAL_SPECTRUM_KINDS: [OperatorKind; 6] = [
        OperatorKind::Kirchhoff,
        OperatorKind::Tutte,
        OperatorKind::Graph,
        OperatorKind::Sql,
        OperatorKind::Sstl,
        OperatorKind::Cotan,
    ];

    /// A dense symmetric n×n matrix with entries uniform in [−1, 1) (seeded).
    pub fn random_symmetric(n: usize, seed: u64) -> faer::Mat<f64> {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut a = faer::Mat::<f64>::zeros(n, n);
        for j in 0..n {
            for i in j..n {
                let x: f64 = rng.gen_range(-1.0..1.0);
                a[(i, j)] = x;
                a[(j, i)] = x;
            }
        }
        a
    }

    /// An icosphere with three faces removed far apart: irregular valences, three
    /// holes and no symmetry left, so its combinatorial spectra are simple.
    pub fn irregular() -> TriMesh {
        let mut m = builtin::icosphere(2).unwrap();
        for f in [250usize, 131, 7] {
            m.faces.remove(f);
        }
        m
    }
}
