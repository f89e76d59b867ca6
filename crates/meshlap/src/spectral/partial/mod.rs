//! The k smallest eigenpairs of a large sparse operator, by shift-invert block
//! Krylov–Schur in shifted bands.
//!
//! ## Problem
//! `K v = λ M v` with `K` sparse symmetric n×n and `M` the identity, a positive
//! diagonal, or any sparse symmetric positive definite matrix ([`Mass`]; below, the
//! diagonal case is described: a sparse `M = C Cᵀ` takes `C` where the text takes
//! `M^{1/2}`). It covers every operator of Zhang (2004) with a real spectrum (sign convention `F = D − W`: the operators are positive
//! semi-definite, so "smallest" means the low frequencies):
//!
//! - the symmetric KL, GL, SQL, SSTL: `K = F`, `M = I`;
//! - the cotangent operator with its lumped mass matrix (Desbrun et al. 1999;
//!   Vallet & Lévy 2008): `K = L`, `M = diag(mass)`;
//! - operators with a positive diagonal symmetrizer `S` (`S F` symmetric), such as the
//!   TL (`S = D`, the TL is similar to the GL), T² and the SDL: `K = S F`, `M = S`,
//!   since `F v = λ v ⇔ S F v = λ S v`.
//!
//! ## Method
//! Shift-invert (Ericsson & Ruhe 1980) with bands of shifts, as in Vallet & Lévy 2008,
//! *Spectral geometry processing with manifold harmonics*, and geogram:
//!
//! 1. The symmetric operator `A_σ = M^{1/2} (K − σM)^{-1} M^{1/2}` has eigenvalues
//!    `μ = 1/(λ − σ)`, so its largest-|μ| eigenpairs are the λ nearest σ; its
//!    eigenvectors are `w = M^{1/2} v`. `K − σM` is factored by faer's sparse
//!    LDLᵀ (supernodal or simplicial; AMD ordering, or METIS nested dissection from
//!    n = 50,000 on); the symbolic analysis is done once and reused for every shift
//!    (the pattern does not change). The solves with the factors are hand-written on
//!    interleaved blocks of right-hand sides (see `ShiftInvert`), split between the
//!    threads.
//! 2. A **block Krylov–Schur** iteration ([`super::krylov_schur`]: block
//!    thick-restart Lanczos with full re-orthogonalisation, blocks of `block_size`
//!    vectors, basis of `2.5 b`) finds the `b` (band size) eigenpairs of `A_σ` of
//!    largest magnitude, each to a residual `≤ tolerance·|μ|`. Blocks find multiple
//!    eigenvalues with all their copies (up to the block size) from one start, and
//!    breakdowns (invariant subspaces on symmetric meshes) continue with random
//!    directions. (Until 2026-11 this was a single-vector port of faer's
//!    `partial_self_adjoint_eigen`, which hangs on such meshes and was slower: see
//!    BENCHMARKS.md, "Partial spectra and partitioning".)
//! 3. **Bands.** The first shift lies just below zero (`σ₀ = −10⁻³·mean(diag M⁻¹K)`),
//!    where `K − σ₀M` is positive definite. A band at σ whose farthest eigenvalue is at
//!    distance `r` has found *every* eigenvalue in the window `(σ − r + δ, σ + r − δ)`
//!    (`δ = 10⁻⁸·max(1, |σ| + r)`; eigenvalues at distance `r − δ … r` may be an
//!    incomplete multiple eigenvalue and are left to the next band). Bands are chained
//!    so that the windows overlap: the next shift is `U + 0.7·b·s/2` (`s` the mean
//!    eigenvalue spacing of the last band, so that the next window of about `±b·s/2`
//!    reaches 30 % of its radius below `U`; at most `U + 0.55 r`), `U` the upper edge
//!    of the windows so far; a band whose window does not reach down to `U` is redone
//!    with the shift halved towards `U`. From each band only the eigenvalues in
//!    `[U, new upper edge)` are kept, so the overlaps are deduplicated and every
//!    eigenvalue below the final edge appears once, with its full multiplicity (a
//!    multiple eigenvalue is never split between two bands, since the edges are kept
//!    `δ` away from the eigenvalues that defined them). It stops when k are found.
//!    **Completeness is checked by Sylvester's law of inertia**: the negative pivots of
//!    the LDLᵀ of `K − xM` count the eigenvalues below `x`, so each band knows exactly
//!    how many eigenvalues its kept interval holds. A Krylov method from one start block can
//!    miss copies of a repeated eigenvalue; missing ones are then searched for in the
//!    complement of the band's vectors (deflated operator `PA_σP`), and a mismatch
//!    that remains is an error, never a silently wrong spectrum.
//! 4. **Refinement** (`PartialParams::refine`, on by default): each band's pairs get
//!    one step of subspace iteration with the band's factorization and a
//!    Rayleigh–Ritz step with the symmetric operator itself, which removes the
//!    high-frequency error that the tolerance on `A_σ` leaves (`polish`).
//! 5. Each eigenvalue is recomputed as the Rayleigh quotient `vᵀKv / vᵀMv`, and its
//!    **residual** `‖M^{-1/2}(K v − λ M v)‖` is reported for the `M`-normalised `v`
//!    (`vᵀMv = 1`): the residual of the symmetric problem `M^{-1/2}KM^{-1/2} w = λ w`
//!    with `‖w‖ = 1`, which for `M = I` is `‖F v − λ v‖` with `‖v‖ = 1`.
//!
//! Small problems (n below `dense_below`, or too small for the Krylov subspace) use
//! faer's dense self-adjoint eigensolver on `M^{-1/2} K M^{-1/2}` instead.
//!
//! ## Output
//! Eigenvalues ascending; eigenvectors as the columns of an n×k matrix `V` with
//! `VᵀMV = I` (orthonormal for `M = I`). Signs and the bases of repeated eigenvalues
//! follow the crate's one rule ([`super::sign`]), as on the dense path: a simple
//! eigenvector `v` has `v·r_0 ≥ 0` for the fixed probe `r_0`, and a cluster of
//! (numerically) equal eigenvalues gets the probe-defined basis of its eigenspace
//! (unique when the whole cluster lies among the k returned pairs).
//!
//! ## Layout
//! - this file: [`PartialParams`], [`PartialSpectrum`], the entry points;
//! - `problem`: [`SymmetricProblem`], an operator as `K v = λ M v`;
//! - `mass`: [`Mass`] and the factor `C` of `M = C Cᵀ` (sparse Cholesky);
//! - `dense`: the dense fallback for small n;
//! - `factor`: the pattern of `K − σM`, its numeric LDLᵀ and the inertia count;
//! - `ordering`: METIS nested dissection for large n;
//! - `solve`: the interleaved supernodal solves (`A_σ` as a block operator);
//! - `banded`: the band driver;
//! - `polish`: the refinement of a band's pairs (subspace iteration + Rayleigh–Ritz);
//! - `residuals`: Rayleigh quotients, residuals and the canonical vectors;
//! - `nearest`: the eigenvalue nearest a shift by inverse iteration (the property
//!   report's `λ_min`).

mod banded;
mod dense;
mod factor;
mod mass;
#[cfg(test)]
mod mass_tests;
mod nearest;
mod ordering;
mod polish;
mod problem;
mod residuals;
mod solve;
#[cfg(test)]
mod tests;

pub use factor::eigenvalues_below;
pub(crate) use factor::Inertia;
pub use mass::Mass;
use mass::Metric;
pub use nearest::eigenvalue_nearest;
pub use problem::SymmetricProblem;

use super::SpectralError;
use crate::operator::Operator;
use crate::SparseMatrix;
use faer::Mat;
use serde::Serialize;

/// Parameters of [`partial_spectrum`] (defaults: [`PartialParams::new`]).
#[derive(Clone, Copy, Debug)]
pub struct PartialParams {
    /// Number of eigenpairs wanted, k.
    pub count: usize,
    /// Eigenpairs computed per shift (the band size b); the Krylov–Schur basis holds
    /// `max(5b/2, b + 2p)` vectors. One band of 200 is fastest for k ≤ 200 on the
    /// bunny; larger k uses several bands (7 for the 1,000 smallest of Igea).
    pub band_size: usize,
    /// Vectors per block (p) of the block Krylov–Schur iteration: solves run on p
    /// right-hand sides at once, and eigenvalues of multiplicity up to p are found
    /// from one start.
    pub block_size: usize,
    /// Convergence tolerance of the Ritz residuals of `A_σ`, relative to each pair's
    /// |μ|: the residual of `K v = λ M v` is then at most about
    /// `‖M^{-1/2}(K − σM)M^{-1/2}‖ · tolerance`.
    pub tolerance: f64,
    /// Restart limit of the Krylov–Schur iteration per band.
    pub max_restarts: usize,
    /// Below this dimension the dense eigensolver is used.
    pub dense_below: usize,
    /// Seed of the starting blocks.
    pub seed: u64,
    /// Refine each band's pairs by one step of subspace iteration with the band's
    /// factorization and a Rayleigh–Ritz step with the operator itself (`polish`):
    /// residuals near ARPACK's (about 10⁻¹⁵ on the bunny's SQL instead of 10⁻¹³) for
    /// b more solves per band.
    pub refine: bool,
}

impl PartialParams {
    /// Defaults for the `count` smallest eigenpairs.
    pub fn new(count: usize) -> Self {
        Self {
            count,
            band_size: 200,
            block_size: 8,
            tolerance: 1e-11,
            max_restarts: 1000,
            dense_below: 600,
            seed: 0x5eed,
            refine: true,
        }
    }
}

/// One shift of the band sequence.
#[derive(Clone, Debug, Serialize)]
pub struct BandInfo {
    /// The shift σ.
    pub shift: f64,
    /// Eigenpairs found nearest σ.
    pub found: usize,
    /// Eigenpairs kept (new, inside the complete window).
    pub kept: usize,
    /// Upper edge of the windows after this band.
    pub upper_edge: f64,
    /// Krylov–Schur restarts (all runs of the band, including the searches for
    /// missed copies of repeated eigenvalues).
    pub restarts: usize,
    /// Vectors `A_σ` was applied to (each one forward and one backward solve with the
    /// band's factors), including the refinement's.
    pub solves: usize,
    /// Numeric LDLᵀ factorizations of `K − xM` (at the shift, unless it was the first
    /// band's trial factorization, and for the inertia count at the upper edge).
    pub factorizations: usize,
    /// A Krylov–Schur run of the band stopped at its accuracy floor, up to 10x above
    /// the tolerance (`krylov_schur::KrylovSchurInfo::stagnated`); the residuals
    /// reported for its pairs are their true ones.
    pub stagnated: bool,
}

/// The k smallest eigenpairs; see the module documentation.
#[derive(Clone, Debug)]
pub struct PartialSpectrum {
    /// Eigenvalues, ascending.
    pub eigenvalues: Vec<f64>,
    /// n×k eigenvectors (columns), `VᵀMV = I`, signs canonical.
    pub eigenvectors: Mat<f64>,
    /// Residual `‖M^{-1/2}(Kv − λMv)‖` of each pair (`‖Fv − λv‖` when `M = I`).
    pub residuals: Vec<f64>,
    /// How the pairs were computed.
    pub info: PartialInfo,
}

/// How a [`PartialSpectrum`] was computed.
#[derive(Clone, Debug, Default, Serialize)]
pub struct PartialInfo {
    /// The shifts used, one per band (empty for the dense path).
    pub bands: Vec<BandInfo>,
    /// True when the dense eigensolver was used.
    pub dense: bool,
}

/// The `opts.count` smallest eigenpairs of an assembled operator (see
/// [`SymmetricProblem::from_operator`]). `progress(found, k)` is called after every band.
pub fn operator_partial_spectrum(
    op: &Operator,
    use_mass: bool,
    opts: &PartialParams,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<PartialSpectrum, SpectralError> {
    let p = SymmetricProblem::from_operator(op, use_mass)?;
    partial_spectrum(&p.stiffness, p.mass.as_deref(), opts, progress)
}

/// The `opts.count` smallest eigenpairs of `K v = λ M v` (`mass = None`: `M = I`;
/// `Some(m)`: `M = diag(m)`). See [`partial_spectrum_with_mass`].
pub fn partial_spectrum(
    k: &SparseMatrix,
    mass: Option<&[f64]>,
    opts: &PartialParams,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<PartialSpectrum, SpectralError> {
    partial_spectrum_with_mass(k, mass.into(), opts, progress)
}

/// The `opts.count` smallest eigenpairs of `K v = λ M v`, with `K` an n×n symmetric
/// sparse matrix (both triangles stored; only the lower one is read by the
/// factorization; sign convention of the paper's operators `F = D − W`, so `K` is
/// positive semi-definite and "smallest" means the low frequencies) and `M` the
/// identity, a positive diagonal, or a sparse symmetric positive definite matrix
/// ([`Mass`]; a non-diagonal `M` is handled through its sparse Cholesky factor
/// `M = C Cᵀ`, the problem being `C⁻¹ K C⁻ᵀ w = λ w`, `v = C⁻ᵀ w`). Eigenvectors
/// are `M`-orthonormal. `progress(found, k)` is called after every band.
///
/// # Errors
/// [`SpectralError::NotSquare`], [`SpectralError::NonFinite`],
/// [`SpectralError::NotSymmetricMatrix`] (K or M), [`SpectralError::InvalidTolerance`],
/// [`SpectralError::InvalidBlocking`], [`SpectralError::InvalidMass`] /
/// [`SpectralError::MassNotPositiveDefinite`], [`SpectralError::TooMany`], and the
/// solver's failures (see [`SpectralError`]).
pub fn partial_spectrum_with_mass(
    k: &SparseMatrix,
    mass: Mass<'_>,
    opts: &PartialParams,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<PartialSpectrum, SpectralError> {
    let n = k.nrows();
    let metric = check_problem(k, mass)?;
    if !(opts.tolerance > 0.0 && opts.tolerance < 1.0) {
        return Err(SpectralError::InvalidTolerance(opts.tolerance));
    }
    if opts.block_size == 0 || opts.block_size > opts.band_size {
        return Err(SpectralError::InvalidBlocking {
            band_size: opts.band_size,
            block_size: opts.block_size,
        });
    }
    let count = opts.count;
    if count > n {
        return Err(SpectralError::TooMany { count, n });
    }
    if count == 0 {
        return Ok(PartialSpectrum {
            eigenvalues: vec![],
            eigenvectors: Mat::zeros(n, 0),
            residuals: vec![],
            info: PartialInfo {
                bands: vec![],
                dense: n < opts.dense_below,
            },
        });
    }
    let band = opts.band_size.max(1).min(count);
    let p = opts.block_size.max(1);
    let out = if n < opts.dense_below || n < 2 * (banded::krylov_dim(band, p) + p) {
        crate::par::on_worker(|| dense::dense(k, &metric, count))?
    } else {
        banded::banded(k, &metric, opts, progress)?
    };
    progress(out.eigenvalues.len(), count);
    Ok(out)
}

/// Checks that `K` is square, finite and symmetric and that `M` matches it (a
/// positive, finite diagonal, or a symmetric positive definite matrix, which is
/// factored here).
pub(crate) fn check_problem(k: &SparseMatrix, mass: Mass<'_>) -> Result<Metric, SpectralError> {
    let n = k.nrows();
    if k.ncols() != n {
        return Err(SpectralError::NotSquare {
            rows: n,
            cols: k.ncols(),
        });
    }
    if let Some(index) = k.val().iter().position(|v| !v.is_finite()) {
        return Err(SpectralError::NonFinite { index });
    }
    mass::check_symmetric("K", k)?;
    Metric::new(mass, n)
}

/// Checks that a lumped mass has n entries, all positive and finite.
pub(crate) fn check_mass(m: &[f64], n: usize) -> Result<(), SpectralError> {
    if m.len() != n {
        return Err(SpectralError::ShapeMismatch {
            what: "mass",
            expected: n,
            got: m.len(),
        });
    }
    match m.iter().position(|x| !(x.is_finite() && *x > 0.0)) {
        Some(vertex) => Err(SpectralError::InvalidMass {
            vertex,
            value: m[vertex],
        }),
        None => Ok(()),
    }
}
