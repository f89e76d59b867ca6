//! Spectral geometry coding after Karni and Gotsman, *Spectral compression of mesh
//! geometry* (SIGGRAPH 2000), as discussed in Zhang 2004 §2.6 and §4.9.
//!
//! The decoded connectivity is split into patches of about `P` vertices (default
//! 100; `patches.rs`). For each patch the n_p×n_p combinatorial operator `F = D − W`
//! (PSD sign convention) of the patch submesh is eigen-decomposed; its eigenvectors,
//! by increasing eigenvalue, are the patch's "frequencies". The default operator is
//! Kirchhoff's `K = D − A`, Karni and Gotsman's choice, which with inter-patch
//! prediction gave the lowest error at every rate we measured (BENCHMARKS.md,
//! Compression). The n_p×3 coordinates `x` are transformed, `X = E⁻¹x`, the first `m`
//! coefficients (low frequencies) are kept (default: all), quantized and range-coded
//! (`coefficients.rs`). Since the basis depends on connectivity only, the decoder
//! rebuilds it and computes `x̃ = E_m X̃`.
//!
//! * Symmetric operators (KL, GL, SQL, SSTL): `E` is orthonormal, `X = Eᵀx`, and the
//!   coefficient error equals the vertex error (Parseval).
//! * The Tutte Laplacian `T = I − D⁻¹A` is not symmetric, but it is similar to the
//!   normalized graph Laplacian `G = I − D^{-1/2} A D^{-1/2}`: `T = D^{-1/2} G D^{1/2}`,
//!   so `EigenBasis`' symmetrized path gives `E = D^{-1/2}U` (unit columns) and the
//!   coefficients by a D-weighted projection — no dense solve (Zhang §4.9 remarks that
//!   TL needs one otherwise).
//!
//! Before the transform each patch is predicted from the decoded vertices of the
//! patches coded before it, and only the difference is coded (`prediction.rs`);
//! vertices on no face of their patch, and with border-aware coding the patch-border
//! vertices, are coded by residuals (`residuals.rs`). The stream starts with a header
//! of the parameters the decoder needs (`header.rs`); `encoder.rs` and `decoder.rs` walk
//! the coefficients in the same order with the same models.
//!
//! **Determinism.** The decoder must reproduce the encoder's basis bit for bit,
//! including inside repeated eigenvalues (icosphere, cube). The bases come from
//! thread-independent, fixed-order arithmetic (factored bases, or
//! [`crate::spectral::EigenBasis`]' canonical vectors for Tutte and old files) on a
//! matrix built from the decoded connectivity in the decoded vertex order, so encoder
//! and decoder agree exactly; tests check this on `builtin:icosphere:3` and
//! `builtin:cube:8`.
//!
//! **Partition and patch size.** Patches come from [`crate::partition`], numbered
//! by their smallest vertex, which is also the coding (and prediction) order. Format
//! version 7 partitions by [`PartitionMethod::Lloyd`](crate::partition::PartitionMethod)
//! (Lloyd-relaxed graph Voronoi cells: integer arithmetic from the connectivity, an
//! edge cut close to METIS's in a fraction of its time; BENCHMARKS.md), after five
//! relaxation steps in versions 7 and 8 and two from version 9 on (the partition is
//! part of every encode and decode, before any basis: two steps take about a third
//! off it for slightly more geometry bits at the same error; BENCHMARKS.md); versions
//! 4–6 used METIS k-way with a fixed seed, and are still decoded with it. Basis cost grows as `n·P²` (a dense eigendecomposition per patch); with
//! inter-patch prediction the rate hardly depends on `P`, so the default, 100, is
//! chosen for speed (larger patches lower the error by a few per cent at several
//! times the basis cost; BENCHMARKS.md). Patches are at most [`MAX_PATCH`] vertices
//! (a hostile file cannot ask for more).
//!
//! **Memory.** A patch's basis takes n_p² values (80 KB at the default 100), or up
//! to 3n_p²/2 factored (reflectors and Z; the unit of the budgets below), so a
//! 10-million-vertex mesh's bases would take 8–12 GB. The layout of the
//! patches (vertices and faces) is kept for all of them; the bases are computed a chunk
//! of about 64 MiB at a time (`patches::stream`: the next chunk in parallel while the
//! current one is coded in order), by the decoder always and by the encoder when they
//! exceed [`CACHE_BYTES`] or when only one encode is needed (a fixed step); under
//! rate control bases that fit are kept for the repeated encodes. Streaming changes no
//! bit of the stream or of the decoding (tested).
//!
//! **Eigensolver.** Bases come from [`crate::spectral::dense_evd`]'s arithmetic
//! (tridiagonalisation, QL eigenvalues, inverse iteration): fixed-order and
//! correctly rounded, so the bases are the same bit for bit on every CPU (with or
//! without AVX2/FMA: `mul_add` is correctly rounded in hardware and in the C
//! library's `fma`), and faster than faer's solver at these sizes.
//!
//! **Factored bases** (format version 8 on, `patches::BasisForm`). A symmetric
//! operator's basis (Kirchhoff, graph, SQL, SSTL) is kept as its decomposition
//! [`crate::spectral::FactoredEvd`]: the Householder reflectors Q of the
//! tridiagonalisation and the tridiagonal eigenvectors Z, with `X = Zᵀ(Qᵀx)` and
//! `x̃ = Q(Z X̃)`. E = QZ is never formed, which skips the back-transformation (as
//! many flops as the tridiagonalisation) on both sides; the vectors are not
//! canonicalised (the decoder runs the same arithmetic, so it needs no sign or
//! cluster rule), and a decoder computes exactly the vectors up to a patch's last
//! non-zero coefficient. Eight patches are decomposed together
//! ([`crate::spectral::FactoredEvd::batch_dense`]: their QL iterations interleaved, the
//! same bits as one at a time), and the Kirchhoff operator is built straight from a
//! patch's faces. The Tutte operator, not symmetric, keeps the explicit basis
//! ([`crate::spectral::EigenBasis`] with [`crate::spectral::DenseSolver::Reproducible`]
//! and the canonicalization in `spectral::basis`), as every operator did up to
//! version 7, and as older files are still decoded.
//!
//! **Arithmetic of the products** (`patches::Arithmetic`). Since format version 6 the
//! coefficient products (`X = E⁻¹x`, `x̃ = E_m X̃`) and the predictor's Cholesky are
//! plain loops in index order (no fused operations); since version 7 the predictor
//! keeps its Cholesky factor and solves three right-hand sides per patch,
//! `x̂ = −M⁻¹(L_Uᵀ(L_S y))`, instead of forming `G` with one solve per known
//! neighbour, and since version 8 that factor is a band one, after a reverse
//! Cuthill–McKee numbering of `M` (`prediction::PredictorForm`; the same prediction
//! up to rounding), so a file encodes to the same
//! bytes and decodes to the same coordinates on every CPU, whatever its SIMD width
//! and whatever `MESHLAP_PORTABLE` says (tested in `meshlap-cli`'s
//! `tests/portable.rs`, and under an emulated CPU without AVX2/FMA, RELIABILITY.md).
//! Versions 4 and 5 used faer's kernels there, which `pulp` picks at run time (AVX2 +
//! FMA or scalar, different summation orders): they are still decoded that way, so
//! their coordinates can differ in the last bits between machines (at rounding
//! level: the integers are in the file).

mod coefficients;
mod decoder;
mod encoder;
mod header;
mod params;
mod patches;
mod prediction;
mod residuals;
#[cfg(test)]
mod tests;

pub use decoder::decode;
pub use encoder::{EncodedSpectral, SpectralEncoder, SpectralStats, CACHE_BYTES};
pub use params::{
    Keep, SpectralParams, MAX_BAND_SLOPE, MAX_DEAD_ZONE, MAX_PATCH, MIN_DEAD_ZONE, MIN_PATCH,
};
