//! The k smallest eigenpairs of a large sparse operator, by shift-invert block
//! Krylov–Schur in shifted bands.
//!
//! ## Problem
//! `K v = λ M v` with `K` sparse symmetric n×n and `M` a positive diagonal (the
//! identity for the ordinary problem). It covers every operator of Zhang (2004) with a
//! real spectrum (sign convention `F = D − W`: the operators are positive
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
//!    `partial_self_adjoint_eigen`, which hangs on such meshes; the block solver is
//!    about 8x faster on the bunny.)
//! 3. **Bands.** The first shift lies just below zero (`σ₀ = −10⁻³·mean(diag M⁻¹K)`),
//!    where `K − σ₀M` is positive definite. A band at σ whose farthest eigenvalue is at
//!    distance `r` has found *every* eigenvalue in the window `(σ − r + δ, σ + r − δ)`
//!    (`δ = 10⁻⁸·max(1, |σ| + r)`; eigenvalues at distance `r − δ … r` may be an
//!    incomplete multiple eigenvalue and are left to the next band). Bands are chained
//!    so that the windows overlap: the next shift is `U + 0.35·b·s` (`s` the mean
//!    eigenvalue spacing of the last band, so that the next window of about `±b·s/2`
//!    reaches below `U`; at most `U + 0.55 r`), `U` the upper edge
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
//! 4. Each eigenvalue is recomputed as the Rayleigh quotient `vᵀKv / vᵀMv`, and its
//!    **residual** `‖M^{-1/2}(K v − λ M v)‖` is reported for the `M`-normalised `v`
//!    (`vᵀMv = 1`): the residual of the symmetric problem `M^{-1/2}KM^{-1/2} w = λ w`
//!    with `‖w‖ = 1`, which for `M = I` is `‖F v − λ v‖` with `‖v‖ = 1`.
//!
//! Small problems (n below `dense_below`, or too small for the Krylov subspace) use
//! faer's dense self-adjoint eigensolver on `M^{-1/2} K M^{-1/2}` instead.
//!
//! ## Output
//! Eigenvalues ascending; eigenvectors as the columns of an n×k matrix `V` with
//! `VᵀMV = I` (orthonormal for `M = I`). **Sign convention:** every column is flipped
//! so that its entry of largest magnitude is positive; entries within `10⁻⁹·max|v|`
//! of the largest count as ties, and the lowest index among them decides. Vectors
//! of a multiple eigenvalue are an orthonormal basis of its eigenspace (not unique).

use crate::operator::{Operator, OperatorKind};
use crate::SparseMatrix;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::ldlt::factor::LdltRegularization;
use faer::reborrow::ReborrowMut;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, LdltRef, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::{SparseColMat, Triplet};
use faer::{Col, Conj, Mat, MatMut, MatRef, Par, Side};
use serde::Serialize;

use super::krylov_schur::{largest_magnitude, BlockOperator, KrylovSchurError, KrylovSchurParams};

/// Errors of partial eigensolves.
#[derive(Debug, thiserror::Error)]
pub enum PartialError {
    /// The operator has no real spectrum this solver can compute.
    #[error("the {0} operator is neither symmetric nor symmetrizable by a positive diagonal; its partial spectrum is not available")]
    NotSymmetrizable(OperatorKind),
    /// The matrix is not square, or the mass does not match it.
    #[error("shape mismatch: {0}")]
    Shape(String),
    /// The mass matrix has a non-positive or non-finite entry.
    #[error("mass matrix entry {index} is {value}; it must be positive and finite")]
    BadMass {
        /// The vertex.
        index: usize,
        /// Its mass.
        value: f64,
    },
    /// The matrix has a NaN or infinite entry.
    #[error("the matrix has a NaN or infinite entry")]
    NonFinite,
    /// More eigenpairs than the dimension were requested.
    #[error("asked for {count} eigenpairs of an {n}×{n} matrix")]
    TooMany {
        /// Requested.
        count: usize,
        /// Dimension.
        n: usize,
    },
    /// The Krylov–Schur iteration could not run (basis too large for the dimension,
    /// or a failed projected eigenproblem).
    #[error("Krylov–Schur at σ = {shift}: {message}")]
    Krylov {
        /// The shift.
        shift: f64,
        /// What failed.
        message: String,
    },
    /// The sparse factorization failed.
    #[error("factorization of K − σM at σ = {shift} failed: {message}")]
    Factorization {
        /// The shift.
        shift: f64,
        /// faer's message.
        message: String,
    },
    /// The dense eigensolver failed.
    #[error("dense eigensolver failed: {0}")]
    Dense(String),
    /// The Krylov–Schur iteration did not converge.
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
    /// Sylvester's inertia counts there.
    #[error("at σ = {shift}: found {found} eigenvalues in the band window, the inertia count is {expected}")]
    InertiaMismatch {
        /// The shift.
        shift: f64,
        /// Eigenvalues found in the window.
        found: usize,
        /// Eigenvalues in the window by inertia.
        expected: usize,
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

/// Options of [`partial_spectrum`].
#[derive(Clone, Copy, Debug)]
pub struct PartialOptions {
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
}

impl PartialOptions {
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
    /// The shifts used (empty for the dense path).
    pub bands: Vec<BandInfo>,
    /// True when the dense eigensolver was used.
    pub dense: bool,
}

/// The generalized problem `K v = λ M v` an operator's spectrum is computed from.
#[derive(Clone, Debug)]
pub struct SymmetricProblem {
    /// Symmetric stiffness `K` (both triangles stored).
    pub stiffness: SparseMatrix,
    /// Positive diagonal `M`; `None` for the identity.
    pub mass: Option<Vec<f64>>,
}

impl SymmetricProblem {
    /// The problem of an assembled operator: symmetric kinds as they are, the
    /// cotangent operator with its lumped mass when `use_mass`, and a non-symmetric
    /// operator through its positive diagonal symmetrizer `S` (`K = SF`, `M = S`).
    pub fn from_operator(op: &Operator, use_mass: bool) -> Result<Self, PartialError> {
        if op.kind.is_symmetric() {
            let mass = if use_mass { op.mass.clone() } else { None };
            return Ok(Self {
                stiffness: op.matrix.clone(),
                mass,
            });
        }
        let s = crate::analysis::properties::diagonal_symmetrizer(&op.matrix)
            .ok_or(PartialError::NotSymmetrizable(op.kind))?;
        let n = op.matrix.nrows();
        let mut trip = Vec::with_capacity(op.matrix.compute_nnz());
        for j in 0..n {
            for (&i, &v) in op
                .matrix
                .row_idx_of_col_raw(j)
                .iter()
                .zip(op.matrix.val_of_col(j))
            {
                trip.push(Triplet::new(i, j, s[i] * v));
            }
        }
        let mut k = SparseMatrix::try_new_from_triplets(n, n, &trip)
            .map_err(|e| PartialError::Shape(format!("{e:?}")))?;
        symmetrize_in_place(&mut k);
        Ok(Self {
            stiffness: k,
            mass: Some(s),
        })
    }
}

/// Replaces `K` by `(K + Kᵀ)/2` entry-wise (removes rounding asymmetry of `S F`).
fn symmetrize_in_place(k: &mut SparseMatrix) {
    let n = k.nrows();
    let dense_lookup = |m: &SparseMatrix, i: usize, j: usize| -> f64 {
        match m.row_idx_of_col_raw(j).binary_search(&i) {
            Ok(p) => m.val_of_col(j)[p],
            Err(_) => 0.0,
        }
    };
    let copy = k.clone();
    for j in 0..n {
        let rows: Vec<usize> = copy.row_idx_of_col_raw(j).to_vec();
        let vals = k.val_of_col_mut(j);
        for (p, &i) in rows.iter().enumerate() {
            vals[p] = 0.5 * (dense_lookup(&copy, i, j) + dense_lookup(&copy, j, i));
        }
    }
}

/// The `opts.count` smallest eigenpairs of an assembled operator (see
/// [`SymmetricProblem::from_operator`]). `progress(found, k)` is called after every band.
pub fn operator_partial_spectrum(
    op: &Operator,
    use_mass: bool,
    opts: &PartialOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<PartialSpectrum, PartialError> {
    let p = SymmetricProblem::from_operator(op, use_mass)?;
    partial_spectrum(&p.stiffness, p.mass.as_deref(), opts, progress)
}

/// The `opts.count` smallest eigenpairs of `K v = λ M v` (`mass = None`: `M = I`).
/// `K` must be symmetric with both triangles stored; only its lower triangle is read
/// by the factorization. `progress(found, k)` is called after every band.
pub fn partial_spectrum(
    k: &SparseMatrix,
    mass: Option<&[f64]>,
    opts: &PartialOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<PartialSpectrum, PartialError> {
    let n = k.nrows();
    if k.ncols() != n {
        return Err(PartialError::Shape(format!(
            "K is {}×{}, not square",
            n,
            k.ncols()
        )));
    }
    if let Some(m) = mass {
        if m.len() != n {
            return Err(PartialError::Shape(format!(
                "mass has {} entries for an {n}×{n} matrix",
                m.len()
            )));
        }
        if let Some((index, &value)) = m
            .iter()
            .enumerate()
            .find(|(_, &x)| !(x.is_finite() && x > 0.0))
        {
            return Err(PartialError::BadMass { index, value });
        }
    }
    if (0..n).any(|j| k.val_of_col(j).iter().any(|v| !v.is_finite())) {
        return Err(PartialError::NonFinite);
    }
    let count = opts.count;
    if count > n {
        return Err(PartialError::TooMany { count, n });
    }
    if count == 0 {
        return Ok(PartialSpectrum {
            eigenvalues: vec![],
            eigenvectors: Mat::zeros(n, 0),
            residuals: vec![],
            bands: vec![],
            dense: n < opts.dense_below,
        });
    }
    let band = opts.band_size.max(1).min(count);
    let p = opts.block_size.max(1);
    let out = if n < opts.dense_below || n < 2 * (krylov_dim(band, p) + p) {
        dense(k, mass, count)?
    } else {
        banded(k, mass, opts, progress)?
    };
    progress(out.eigenvalues.len(), count);
    Ok(out)
}

fn msqrt_of(mass: Option<&[f64]>, n: usize) -> Vec<f64> {
    match mass {
        Some(m) => m.iter().map(|x| x.sqrt()).collect(),
        None => vec![1.0; n],
    }
}

/// Dense path: faer's self-adjoint eigensolver on `M^{-1/2} K M^{-1/2}`.
fn dense(
    k: &SparseMatrix,
    mass: Option<&[f64]>,
    count: usize,
) -> Result<PartialSpectrum, PartialError> {
    let n = k.nrows();
    let ms = msqrt_of(mass, n);
    let kd = k.to_dense();
    let a = Mat::from_fn(n, n, |i, j| {
        0.5 * (kd[(i, j)] + kd[(j, i)]) / (ms[i] * ms[j])
    });
    let evd = a
        .self_adjoint_eigen(Side::Lower)
        .map_err(|e| PartialError::Dense(format!("{e:?}")))?;
    let (u, s) = (evd.U(), evd.S());
    let mut pairs: Vec<(f64, Col<f64>)> = (0..count)
        .map(|j| (s[j], Col::from_fn(n, |i| u[(i, j)])))
        .collect();
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    Ok(finish(k, mass, &ms, pairs, vec![], true))
}

/// Builds the pattern of `K − σM` once: `K` plus an explicit diagonal.
struct ShiftedPattern {
    base: SparseMatrix,
    diag_pos: Vec<usize>,
}

impl ShiftedPattern {
    fn new(k: &SparseMatrix) -> Result<Self, PartialError> {
        let n = k.nrows();
        let mut trip = Vec::with_capacity(k.compute_nnz() + n);
        for j in 0..n {
            for (&i, &v) in k.row_idx_of_col_raw(j).iter().zip(k.val_of_col(j)) {
                trip.push(Triplet::new(i, j, v));
            }
            trip.push(Triplet::new(j, j, 0.0));
        }
        let base: SparseMatrix = SparseColMat::try_new_from_triplets(n, n, &trip)
            .map_err(|e| PartialError::Shape(format!("{e:?}")))?;
        let mut diag_pos = Vec::with_capacity(n);
        let col_ptr = base.symbolic().col_ptr();
        for j in 0..n {
            let p = base
                .row_idx_of_col_raw(j)
                .binary_search(&j)
                .map_err(|_| PartialError::Shape("missing diagonal".into()))?;
            diag_pos.push(col_ptr[j] + p);
        }
        Ok(Self { base, diag_pos })
    }

    fn shifted(&self, sigma: f64, mass: Option<&[f64]>) -> SparseMatrix {
        let mut a = self.base.clone();
        let vals = a.val_mut();
        for (j, &p) in self.diag_pos.iter().enumerate() {
            vals[p] -= sigma * mass.map_or(1.0, |m| m[j]);
        }
        a
    }
}

/// `A_σ = M^{1/2} (K − σM)^{-1} M^{1/2}` (symmetric) as a block operator.
///
/// The solves with faer's LDLᵀ factors are done here by hand, on an *interleaved*
/// right-hand side (row-major n×c: the c values of one row are contiguous), walking
/// the supernodes column by column: each factor entry is loaded once and used for c
/// multiply-adds on contiguous memory, which the compiler vectorises. faer's own
/// supernodal solve works on column-major right-hand sides with a small dense product
/// per supernode; on mesh Laplacians (many small supernodes) it ran at about
/// 1–1.3 ms per vector on the bunny against about a quarter of that here. The
/// right-hand sides are split between the rayon threads (faer's parallel solve
/// spin-waits). A simplicial factorization (tiny matrices) falls back to faer.
struct ShiftInvert<'a> {
    symbolic: &'a SymbolicCholesky<usize>,
    values: Vec<f64>,
    msqrt: &'a [f64],
}

impl ShiftInvert<'_> {
    fn solve_cols(&self, out: MatMut<'_, f64>, threads: usize) {
        if threads <= 1 || out.ncols() <= 1 {
            self.solve_seq(out);
            return;
        }
        let half = out.ncols() / 2;
        let (a, b) = out.split_at_col_mut(half);
        rayon::join(
            || self.solve_cols(a, threads / 2),
            || self.solve_cols(b, threads - threads / 2),
        );
    }

    /// `out ← M^{1/2} (K − σM)^{-1} M^{1/2} out` on one thread.
    fn solve_seq(&self, mut out: MatMut<'_, f64>) {
        use faer::sparse::linalg::cholesky::SymbolicCholeskyRaw;
        let n = out.nrows();
        let c = out.ncols();
        let ms = self.msqrt;
        let SymbolicCholeskyRaw::Supernodal(sym) = self.symbolic.raw() else {
            for j in 0..c {
                for i in 0..n {
                    out[(i, j)] *= ms[i];
                }
            }
            let mut buf = MemBuffer::new(
                self.symbolic
                    .solve_in_place_scratch::<f64>(c.max(1), Par::Seq),
            );
            LdltRef::new(self.symbolic, &self.values).solve_in_place_with_conj(
                Conj::No,
                out.rb_mut(),
                Par::Seq,
                MemStack::new(&mut buf),
            );
            for j in 0..c {
                for i in 0..n {
                    out[(i, j)] *= ms[i];
                }
            }
            return;
        };
        let mut j0 = 0;
        while j0 < c {
            let left = c - j0;
            let w = if left >= 8 {
                8
            } else if left >= 4 {
                4
            } else {
                1
            };
            let cols = out.rb_mut().subcols_mut(j0, w);
            match w {
                8 => self.solve_dispatch::<8>(sym, cols),
                4 => self.solve_dispatch::<4>(sym, cols),
                _ => self.solve_dispatch::<1>(sym, cols),
            }
            j0 += w;
        }
    }

    /// [`Self::solve_fixed`] compiled for AVX2 + FMA when the CPU has them (the
    /// default x86-64 target has only SSE2; faer dispatches the same way at run time).
    fn solve_dispatch<const W: usize>(
        &self,
        sym: &faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky<usize>,
        out: MatMut<'_, f64>,
    ) {
        #[cfg(target_arch = "x86_64")]
        {
            #[target_feature(enable = "avx2,fma")]
            fn avx2<const W: usize>(
                this: &ShiftInvert<'_>,
                sym: &faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky<usize>,
                out: MatMut<'_, f64>,
            ) {
                this.solve_fixed::<W>(sym, out)
            }
            if std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma")
            {
                // SAFETY: the CPU supports the features `avx2` is compiled for.
                unsafe { avx2::<W>(self, sym, out) };
                return;
            }
        }
        self.solve_fixed::<W>(sym, out)
    }

    /// The supernodal solve on `W` interleaved columns (see the type's documentation).
    #[inline(always)]
    fn solve_fixed<const W: usize>(
        &self,
        sym: &faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky<usize>,
        mut out: MatMut<'_, f64>,
    ) {
        use faer::sparse::linalg::cholesky::supernodal::SupernodalLdltRef;
        let n = out.nrows();
        let ms = self.msqrt;
        let perm = self.symbolic.perm();
        let fwd = |i: usize| perm.map_or(i, |p| p.arrays().0[i]);
        // Gather into the permuted, interleaved x (row i of x = row fwd(i) of b).
        let mut x: Vec<[f64; W]> = (0..n)
            .map(|i| {
                let f = fwd(i);
                std::array::from_fn(|j| out[(f, j)] * ms[f])
            })
            .collect();
        let l = SupernodalLdltRef::new(sym, &self.values);
        let nsup = sym.n_supernodes();
        // Forward: L y = b, L unit lower, column-oriented scatter.
        for sn in 0..nsup {
            let node = l.supernode(sn);
            let val = node.val();
            let start = node.start();
            let pattern = node.pattern();
            let w = val.ncols();
            for j in 0..w {
                let xj = x[start + j];
                let col = val
                    .col(j)
                    .try_as_col_major()
                    .expect("contiguous supernode")
                    .as_slice();
                for (row, &lij) in x[start + j + 1..start + w].iter_mut().zip(&col[j + 1..w]) {
                    for t in 0..W {
                        row[t] -= lij * xj[t];
                    }
                }
                for (&pi, &lij) in pattern.iter().zip(&col[w..]) {
                    debug_assert!(pi < n);
                    // SAFETY: supernode patterns hold row indices below n (faer's
                    // symbolic factorization of an n×n matrix).
                    let row = unsafe { x.get_unchecked_mut(pi) };
                    for t in 0..W {
                        row[t] -= lij * xj[t];
                    }
                }
            }
        }
        // Diagonal: z = D⁻¹ y.
        for sn in 0..nsup {
            let node = l.supernode(sn);
            let val = node.val();
            let start = node.start();
            for j in 0..val.ncols() {
                let inv = 1.0 / val[(j, j)];
                for v in x[start + j].iter_mut() {
                    *v *= inv;
                }
            }
        }
        // Backward: Lᵀ x = z, column-oriented gather (dot products).
        for sn in (0..nsup).rev() {
            let node = l.supernode(sn);
            let val = node.val();
            let start = node.start();
            let pattern = node.pattern();
            let w = val.ncols();
            for j in (0..w).rev() {
                let mut acc = [0.0f64; W];
                let col = val
                    .col(j)
                    .try_as_col_major()
                    .expect("contiguous supernode")
                    .as_slice();
                for (row, &lij) in x[start + j + 1..start + w].iter().zip(&col[j + 1..w]) {
                    for t in 0..W {
                        acc[t] += lij * row[t];
                    }
                }
                for (&pi, &lij) in pattern.iter().zip(&col[w..]) {
                    debug_assert!(pi < n);
                    // SAFETY: as in the forward pass.
                    let row = unsafe { x.get_unchecked(pi) };
                    for t in 0..W {
                        acc[t] += lij * row[t];
                    }
                }
                let row = &mut x[start + j];
                for t in 0..W {
                    row[t] -= acc[t];
                }
            }
        }
        // Scatter back: row fwd(i) of the result is row i of x.
        for (i, row) in x.iter().enumerate() {
            let f = fwd(i);
            for (j, &v) in row.iter().enumerate() {
                out[(f, j)] = v * ms[f];
            }
        }
    }
}

impl BlockOperator for ShiftInvert<'_> {
    fn dim(&self) -> usize {
        self.msqrt.len()
    }
    fn apply_block(&self, x: MatRef<'_, f64>, mut out: MatMut<'_, f64>) {
        out.copy_from(x);
        self.solve_cols(out.rb_mut(), rayon::current_num_threads());
    }
}

/// From this dimension on, the LDLᵀ uses METIS' nested-dissection ordering instead
/// of AMD: on igea.ply (n = 134,345) it cuts the factor from 9.4 M to 6.3 M stored
/// values and the solves by about a fifth, for 0.6 s of ordering; on the bunny
/// (n = 34,834) the ordering costs as much as it saves.
const NESTED_DISSECTION_FROM: usize = 50_000;

/// METIS nested-dissection fill-reducing ordering (`METIS_NodeND`) of the pattern
/// of a symmetric matrix, as (forward, inverse) permutations; `None` if METIS fails
/// (the caller falls back to AMD). The `metis` crate wraps only METIS' partitioners,
/// so the call goes through its `metis-sys` bindings.
fn nested_dissection(a: &SparseMatrix) -> Option<(Vec<usize>, Vec<usize>)> {
    let n = a.nrows();
    let mut xadj: Vec<metis_sys::idx_t> = Vec::with_capacity(n + 1);
    let mut adjncy: Vec<metis_sys::idx_t> = Vec::with_capacity(a.compute_nnz());
    xadj.push(0);
    for j in 0..n {
        for &i in a.row_idx_of_col_raw(j) {
            if i != j {
                adjncy.push(metis_sys::idx_t::try_from(i).ok()?);
            }
        }
        xadj.push(metis_sys::idx_t::try_from(adjncy.len()).ok()?);
    }
    let mut nv = metis_sys::idx_t::try_from(n).ok()?;
    let mut options = [0 as metis_sys::idx_t; metis_sys::METIS_NOPTIONS as usize];
    let mut perm = vec![0 as metis_sys::idx_t; n];
    let mut iperm = vec![0 as metis_sys::idx_t; n];
    // SAFETY: `options` has METIS_NOPTIONS entries; the graph arrays are a valid CSR
    // of `nv` vertices (symmetric pattern, no self loops) and `perm`/`iperm` hold `nv`
    // entries each, as METIS_NodeND requires. METIS keeps no pointer after returning.
    let rc = unsafe {
        metis_sys::METIS_SetDefaultOptions(options.as_mut_ptr());
        metis_sys::METIS_NodeND(
            &mut nv,
            xadj.as_mut_ptr(),
            adjncy.as_mut_ptr(),
            std::ptr::null_mut(),
            options.as_mut_ptr(),
            perm.as_mut_ptr(),
            iperm.as_mut_ptr(),
        )
    };
    if rc != metis_sys::rstatus_et_METIS_OK {
        return None;
    }
    // METIS: perm[new] = old (faer's forward array), iperm[old] = new.
    let fwd: Vec<usize> = perm.iter().map(|&x| x as usize).collect();
    let inv: Vec<usize> = iperm.iter().map(|&x| x as usize).collect();
    let mut seen = vec![false; n];
    for &f in &fwd {
        if f >= n || std::mem::replace(&mut seen[f], true) {
            return None;
        }
    }
    Some((fwd, inv))
}

/// Numeric LDLᵀ factorization of `K − σM` on the shared symbolic analysis.
fn factor_at(
    pattern: &ShiftedPattern,
    symbolic: &SymbolicCholesky<usize>,
    mass: Option<&[f64]>,
    sigma: f64,
) -> Result<Vec<f64>, PartialError> {
    let par = faer::get_global_parallelism();
    let a = pattern.shifted(sigma, mass);
    let mut values = vec![0.0f64; symbolic.len_val()];
    let req = symbolic.factorize_numeric_ldlt_scratch::<f64>(par, Default::default());
    let mut buf = MemBuffer::new(req);
    symbolic
        .factorize_numeric_ldlt(
            &mut values,
            a.as_ref(),
            Side::Lower,
            LdltRegularization::default(),
            par,
            MemStack::new(&mut buf),
            Default::default(),
        )
        .map_err(|e| PartialError::Factorization {
            shift: sigma,
            message: format!("{e:?}"),
        })?;
    if values.iter().any(|v| !v.is_finite()) {
        return Err(PartialError::Factorization {
            shift: sigma,
            message: "non-finite pivot".into(),
        });
    }
    Ok(values)
}

/// Number of negative pivots of the LDLᵀ factors: by Sylvester's law of inertia,
/// the number of eigenvalues of `K v = λ M v` below the shift.
fn negative_pivots(symbolic: &SymbolicCholesky<usize>, values: &[f64]) -> usize {
    use faer::sparse::linalg::cholesky::{supernodal::SupernodalLdltRef, SymbolicCholeskyRaw};
    match symbolic.raw() {
        SymbolicCholeskyRaw::Simplicial(s) => {
            let (cp, ri) = (s.col_ptr(), s.row_idx());
            (0..s.ncols())
                .filter(|&j| {
                    (cp[j]..cp[j + 1])
                        .find(|&p| ri[p] == j)
                        .is_some_and(|p| values[p] < 0.0)
                })
                .count()
        }
        SymbolicCholeskyRaw::Supernodal(s) => {
            let l = SupernodalLdltRef::new(s, values);
            (0..s.n_supernodes())
                .map(|sn| {
                    let node = l.supernode(sn);
                    let val = node.val();
                    let ncols = val.ncols();
                    (0..ncols).filter(|&j| val[(j, j)] < 0.0).count()
                })
                .sum()
        }
    }
}

/// Eigenvalues of `K v = λ M v` below `x` (Sylvester inertia of `K − xM`).
fn count_below(
    pattern: &ShiftedPattern,
    symbolic: &SymbolicCholesky<usize>,
    mass: Option<&[f64]>,
    x: f64,
) -> Result<usize, PartialError> {
    let values = factor_at(pattern, symbolic, mass, x)?;
    Ok(negative_pivots(symbolic, &values))
}

/// The `b` eigenpairs of largest |μ| of `A_σ` (on the complement of `deflate`, when
/// given) as (λ = σ + 1/μ, w) with `w` in the symmetric coordinates (`w = M^{1/2} v`),
/// by block Krylov–Schur.
fn shift_invert_pairs(
    op: &ShiftInvert<'_>,
    sigma: f64,
    b: usize,
    deflate: Option<MatRef<'_, f64>>,
    opts: &PartialOptions,
    seed: u64,
) -> Result<Vec<(f64, Col<f64>)>, PartialError> {
    let params = krylov_params(opts, b, seed);
    let got = largest_magnitude(op, b, deflate, &params);
    let got = got.map_err(|e| match e {
        KrylovSchurError::NoConvergence {
            converged,
            wanted,
            restarts,
        } => PartialError::NotConverged {
            shift: sigma,
            converged,
            wanted,
            restarts,
        },
        other => PartialError::Krylov {
            shift: sigma,
            message: other.to_string(),
        },
    })?;
    Ok(got
        .values
        .iter()
        .enumerate()
        .map(|(j, &mu)| (sigma + 1.0 / mu, got.vectors.col(j).to_owned()))
        .collect())
}

/// Size of a band after the first when `need` eigenpairs are still missing: the full
/// band size, or — for the last band — enough for `need` (an interior band keeps
/// about 3/4 of its pairs, the rest overlap the previous window or lie beyond its
/// edge) instead of a full band for a handful of pairs.
fn next_band_size(need: usize, b_max: usize, block: usize) -> usize {
    let enough = need * 3 / 2 + 2 * block.max(1);
    enough.min(b_max).max(1)
}

/// Block size and basis size for `b` wanted pairs.
fn krylov_params(opts: &PartialOptions, b: usize, seed: u64) -> KrylovSchurParams {
    let p = opts.block_size.max(1);
    KrylovSchurParams {
        block: p,
        max_dim: krylov_dim(b, p),
        tolerance: opts.tolerance,
        max_restarts: opts.max_restarts,
        seed,
    }
}

/// The Krylov–Schur basis size for `b` wanted pairs and blocks of `p`.
fn krylov_dim(b: usize, p: usize) -> usize {
    (5 * b / 2).max(b + 2 * p)
}

/// Band-by-band shift-invert; see the module documentation.
fn banded(
    k: &SparseMatrix,
    mass: Option<&[f64]>,
    opts: &PartialOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<PartialSpectrum, PartialError> {
    let n = k.nrows();
    let count = opts.count;
    let msqrt = msqrt_of(mass, n);
    let pattern = ShiftedPattern::new(k)?;
    let nd = if n >= NESTED_DISSECTION_FROM {
        nested_dissection(&pattern.base)
    } else {
        None
    };
    let ordering = match &nd {
        Some((fwd, inv)) => {
            SymmetricOrdering::Custom(faer::perm::PermRef::new_checked(fwd, inv, n))
        }
        None => SymmetricOrdering::Amd,
    };
    let symbolic = factorize_symbolic_cholesky(
        pattern.base.symbolic(),
        Side::Lower,
        ordering,
        Default::default(),
    )
    .map_err(|e| PartialError::Factorization {
        shift: 0.0,
        message: format!("{e:?}"),
    })?;
    // Scale of the spectrum (mean diagonal of M⁻¹K) and a Gershgorin lower bound.
    let mut mean_diag = 0.0;
    let mut gersh = f64::INFINITY;
    for j in 0..n {
        let mj = mass.map_or(1.0, |m| m[j]);
        let (mut d, mut off) = (0.0, 0.0);
        for (&i, &v) in k.row_idx_of_col_raw(j).iter().zip(k.val_of_col(j)) {
            if i == j {
                d += v;
            } else {
                off += v.abs();
            }
        }
        mean_diag += d / mj / n as f64;
        gersh = gersh.min((d - off) / mj);
    }
    let scale = if mean_diag.is_finite() && mean_diag > 0.0 {
        mean_diag
    } else {
        1.0
    };
    let b_max = opts.band_size.max(1);
    let mut kept: Vec<(f64, Col<f64>)> = Vec::with_capacity(count);
    let mut bands = Vec::new();
    let mut upper = f64::NEG_INFINITY;
    let mut below_upper = 0usize;
    // Below the whole spectrum: every eigenvalue lies above σ₀.
    // σ₀ just below zero, as scipy users do; if K − σ₀M is indefinite (an operator
    // with negative eigenvalues) fall back to below the Gershgorin bound. A shift far
    // below the spectrum compresses the μ = 1/(λ − σ) and slows convergence.
    let mut sigma = -1e-3 * scale;
    let mut first = Some(factor_at(&pattern, &symbolic, mass, sigma)?);
    if first
        .as_ref()
        .is_some_and(|values| negative_pivots(&symbolic, values) > 0)
    {
        sigma = gersh.min(0.0) - 1e-3 * scale;
        first = None;
    }
    let mut band_no = 0usize;
    loop {
        let b = if kept.is_empty() {
            count.min(b_max)
        } else {
            next_band_size(count - kept.len(), b_max, opts.block_size)
        };
        let values = match first.take() {
            Some(values) => values,
            None => factor_at(&pattern, &symbolic, mass, sigma)?,
        };
        let op = ShiftInvert {
            symbolic: &symbolic,
            values,
            msqrt: &msqrt,
        };
        let seed = opts.seed.wrapping_add(1_000 * band_no as u64);
        let mut found = shift_invert_pairs(&op, sigma, b, None, opts, seed)?;
        band_no += 1;
        let r = found
            .iter()
            .map(|(l, _)| (l - sigma).abs())
            .fold(0.0f64, f64::max);
        let delta = 1e-8 * (sigma.abs() + r).max(1.0);
        let lower_edge = sigma - r + delta;
        if !(kept.is_empty() || lower_edge <= upper) {
            // The window misses eigenvalues just above `upper`: move the shift down.
            let step = (sigma - upper) / 2.0;
            if step <= delta {
                return Err(PartialError::Stalled {
                    band: band_no,
                    edge: upper,
                });
            }
            sigma = upper + step;
            continue;
        }
        let new_upper = sigma + r - delta;
        // Sylvester inertia: exactly how many eigenvalues [upper, new_upper) holds.
        let below_new = count_below(&pattern, &symbolic, mass, new_upper)?;
        let expected = below_new.saturating_sub(below_upper);
        let in_window = |l: f64| l >= upper && l < new_upper;
        let mut n_in = found.iter().filter(|(l, _)| in_window(*l)).count();
        // The Krylov method may miss copies of a repeated eigenvalue: look for them in the
        // complement of everything this band found.
        let mut tries = 0;
        while n_in < expected && tries < 8 {
            let w = Mat::from_fn(n, found.len(), |i, j| found[j].1[i]);
            let want = (expected - n_in).min(b).max(1);
            let more = shift_invert_pairs(
                &op,
                sigma,
                want,
                Some(w.as_ref()),
                opts,
                seed + 7 + tries as u64,
            )?;
            let mut added = 0;
            for (l, v) in more {
                if in_window(l) {
                    added += 1;
                    found.push((l, v));
                }
            }
            n_in += added;
            tries += 1;
            if added == 0 {
                break;
            }
        }
        if n_in != expected {
            return Err(PartialError::InertiaMismatch {
                shift: sigma,
                found: n_in,
                expected,
            });
        }
        // Mean eigenvalue spacing in this band, for the next shift.
        let (lo, hi) = found
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), (l, _)| {
                (a.min(*l), b.max(*l))
            });
        let spacing = (hi - lo) / (found.len().max(2) - 1) as f64;
        let mut fresh: Vec<(f64, Col<f64>)> = Vec::new();
        let mut edge: Vec<(f64, Col<f64>)> = Vec::new();
        for (l, w) in found {
            if in_window(l) {
                fresh.push((l, w));
            } else if l >= new_upper {
                edge.push((l, w));
            }
        }
        fresh.sort_by(|a, b| a.0.total_cmp(&b.0));
        edge.sort_by(|a, b| a.0.total_cmp(&b.0));
        let n_fresh = fresh.len();
        kept.extend(fresh);
        bands.push(BandInfo {
            shift: sigma,
            found: b,
            kept: n_fresh,
            upper_edge: new_upper,
        });
        progress(kept.len().min(count), count);
        if kept.len() + edge.len() >= count || kept.len() >= n {
            // The edge eigenvalues are the next ones above the complete window.
            kept.extend(edge);
            kept.truncate(count);
            break;
        }
        if new_upper <= upper {
            return Err(PartialError::Stalled {
                band: band_no,
                edge: upper,
            });
        }
        upper = new_upper;
        below_upper = below_new;
        // The next band's b eigenvalues nearest σ span about ±(b/2)·spacing: place σ
        // so that its window reaches 30 % of that radius below the edge.
        let b_next = next_band_size(count - kept.len(), b_max, opts.block_size);
        let step = 0.7 * 0.5 * b_next as f64 * spacing;
        sigma = upper
            + if step.is_finite() && step > 2.0 * delta {
                step.min(0.55 * r)
            } else {
                0.55 * r
            };
    }
    Ok(finish(k, mass, &msqrt, kept, bands, false))
}

/// Converts `w` to `v = M^{-1/2} w`, recomputes λ as a Rayleigh quotient, fixes the
/// signs and computes the residuals.
fn finish(
    k: &SparseMatrix,
    _mass: Option<&[f64]>,
    msqrt: &[f64],
    pairs: Vec<(f64, Col<f64>)>,
    bands: Vec<BandInfo>,
    dense: bool,
) -> PartialSpectrum {
    use rayon::prelude::*;
    let n = msqrt.len();
    let m = pairs.len();
    // v = M^{-1/2} w / ‖w‖ with its canonical sign, per pair in parallel.
    let mut eigenvectors = Mat::<f64>::zeros(n, m);
    eigenvectors
        .par_col_chunks_mut(1)
        .zip(pairs.par_iter())
        .for_each(|(col, (_, w))| {
            let nw = w.norm_l2();
            let mut v: Vec<f64> = (0..n).map(|i| w[i] / nw / msqrt[i]).collect();
            canonical_sign(&mut v);
            col.col_mut(0).iter_mut().zip(&v).for_each(|(e, &x)| *e = x);
        });
    drop(pairs);
    // K V by rows (K is symmetric: row i of K V gathers over column i of K), on
    // interleaved chunks of 8 vectors; then the Rayleigh quotients and residuals.
    let mut eigenvalues = vec![0.0f64; m];
    let mut residuals = vec![0.0f64; m];
    const CW: usize = 8;
    let mut j0 = 0;
    while j0 < m {
        let w = CW.min(m - j0);
        let vt: Vec<[f64; CW]> = (0..n)
            .into_par_iter()
            .map(|i| {
                std::array::from_fn(|t| {
                    if t < w {
                        eigenvectors[(i, j0 + t)]
                    } else {
                        0.0
                    }
                })
            })
            .collect();
        let kvt: Vec<[f64; CW]> = (0..n)
            .into_par_iter()
            .map(|i| {
                let mut acc = [0.0f64; CW];
                for (&r, &a) in k.row_idx_of_col_raw(i).iter().zip(k.val_of_col(i)) {
                    let x = &vt[r];
                    for t in 0..CW {
                        acc[t] += a * x[t];
                    }
                }
                acc
            })
            .collect();
        // Σ v·Kv and Σ v²m per vector, then Σ ((Kv − λMv)/√m)², by parallel folds.
        let add = |mut a: [f64; CW], b: [f64; CW]| {
            for t in 0..CW {
                a[t] += b[t];
            }
            a
        };
        let (vkv, vmv) = (0..n)
            .into_par_iter()
            .fold(
                || ([0.0f64; CW], [0.0f64; CW]),
                |(mut a, mut b), i| {
                    let mi = msqrt[i] * msqrt[i];
                    for t in 0..CW {
                        a[t] += vt[i][t] * kvt[i][t];
                        b[t] += vt[i][t] * vt[i][t] * mi;
                    }
                    (a, b)
                },
            )
            .reduce(
                || ([0.0f64; CW], [0.0f64; CW]),
                |x, y| (add(x.0, y.0), add(x.1, y.1)),
            );
        let lambda: [f64; CW] =
            std::array::from_fn(|t| if vmv[t] > 0.0 { vkv[t] / vmv[t] } else { 0.0 });
        let rr = (0..n)
            .into_par_iter()
            .fold(
                || [0.0f64; CW],
                |mut a, i| {
                    let mi = msqrt[i] * msqrt[i];
                    for t in 0..CW {
                        let r = (kvt[i][t] - lambda[t] * mi * vt[i][t]) / msqrt[i];
                        a[t] += r * r;
                    }
                    a
                },
            )
            .reduce(|| [0.0f64; CW], add);
        for t in 0..w {
            eigenvalues[j0 + t] = lambda[t];
            residuals[j0 + t] = rr[t].sqrt() / vmv[t].sqrt();
        }
        j0 += w;
    }
    PartialSpectrum {
        eigenvalues,
        eigenvectors,
        residuals,
        bands,
        dense,
    }
}

/// Flips `v` so that its largest-magnitude entry is positive (entries within
/// `10⁻⁹·max|v|` of the largest tie; the lowest index decides).
pub fn canonical_sign(v: &mut [f64]) {
    let max = v.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
    if max == 0.0 {
        return;
    }
    if let Some(i) = v.iter().position(|&x| x.abs() >= max * (1.0 - 1e-9)) {
        if v[i] < 0.0 {
            v.iter_mut().for_each(|x| *x = -*x);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{builtin, topology::Topology, TriMesh};
    use crate::operator::OperatorOptions;

    fn assemble(kind: OperatorKind, mesh: &TriMesh) -> Operator {
        let topo = Topology::new(mesh).unwrap();
        Operator::assemble(kind, mesh, &topo, &OperatorOptions::default()).unwrap()
    }

    /// Dense reference: eigenpairs of M^{-1/2} K M^{-1/2}, ascending (w coordinates).
    fn dense_reference(k: &SparseMatrix, mass: Option<&[f64]>) -> (Vec<f64>, Mat<f64>) {
        let n = k.nrows();
        let ms = msqrt_of(mass, n);
        let kd = k.to_dense();
        let a = Mat::from_fn(n, n, |i, j| kd[(i, j)] / (ms[i] * ms[j]));
        let evd = a.self_adjoint_eigen(Side::Lower).unwrap();
        let s: Vec<f64> = (0..n).map(|i| evd.S()[i]).collect();
        (s, evd.U().to_owned())
    }

    /// Checks a partial spectrum against the dense one: eigenvalues to 1e-8,
    /// residuals ≤ 1e-9, VᵀMV = I to 1e-9, and every complete cluster of equal
    /// eigenvalues spans the dense eigenspace.
    fn check_against_dense(k: &SparseMatrix, mass: Option<&[f64]>, ps: &PartialSpectrum) {
        let n = k.nrows();
        let m = ps.eigenvalues.len();
        let (s, u) = dense_reference(k, mass);
        let ms = msqrt_of(mass, n);
        for j in 0..m {
            assert!(
                (ps.eigenvalues[j] - s[j]).abs() < 1e-8,
                "λ_{j}: {} vs dense {}",
                ps.eigenvalues[j],
                s[j]
            );
            assert!(ps.residuals[j] <= 1e-9, "residual {j}: {}", ps.residuals[j]);
        }
        // M-orthonormality.
        let w = Mat::from_fn(n, m, |i, j| ps.eigenvectors[(i, j)] * ms[i]);
        let g = w.transpose() * &w;
        for a in 0..m {
            for b in 0..m {
                let want = if a == b { 1.0 } else { 0.0 };
                assert!(
                    (g[(a, b)] - want).abs() < 1e-9,
                    "WᵀW[{a},{b}] = {}",
                    g[(a, b)]
                );
            }
        }
        // Clusters: [lo, hi) with equal dense eigenvalues, complete inside 0..m.
        let mut lo = 0;
        while lo < m {
            let mut hi = lo + 1;
            while hi < n && (s[hi] - s[lo]).abs() < 1e-7 {
                hi += 1;
            }
            if hi <= m {
                // ‖W_c − U_c U_cᵀ W_c‖ small.
                let uc = u.subcols(lo, hi - lo);
                let wc = w.subcols(lo, hi - lo);
                let proj = uc * (uc.transpose() * wc);
                let err = (&proj - wc).norm_max();
                assert!(err < 1e-7, "cluster {lo}..{hi}: subspace error {err}");
            }
            lo = hi;
        }
    }

    #[test]
    fn interleaved_supernodal_solve_matches_faer_for_both_orderings() {
        use faer::sparse::linalg::cholesky::SymbolicCholeskyRaw;
        // icosphere:5 (10,242 vertices) gets a supernodal factorization.
        let mesh = builtin::icosphere(5).unwrap();
        let op = assemble(OperatorKind::Sql, &mesh);
        let n = mesh.n_vertices();
        let pattern = ShiftedPattern::new(&op.matrix).unwrap();
        let nd = nested_dissection(&pattern.base).expect("METIS ordering");
        let msqrt: Vec<f64> = (0..n).map(|i| 1.0 + (i % 5) as f64 * 0.1).collect();
        let mut x = Mat::<f64>::zeros(n, 13);
        super::super::krylov_schur::random_fill(x.as_mut(), 42);
        for custom in [false, true] {
            let ordering = if custom {
                SymmetricOrdering::Custom(faer::perm::PermRef::new_checked(&nd.0, &nd.1, n))
            } else {
                SymmetricOrdering::Amd
            };
            let symbolic = factorize_symbolic_cholesky(
                pattern.base.symbolic(),
                Side::Lower,
                ordering,
                Default::default(),
            )
            .unwrap();
            assert!(matches!(symbolic.raw(), SymbolicCholeskyRaw::Supernodal(_)));
            // A shift inside the spectrum: K − σI is indefinite.
            let sigma = 0.37;
            let values = factor_at(&pattern, &symbolic, None, sigma).unwrap();
            let si = ShiftInvert {
                symbolic: &symbolic,
                values: values.clone(),
                msqrt: &msqrt,
            };
            for p in [1usize, 3, 8, 13] {
                let xb = x.as_ref().subcols(0, p);
                let mut ours = Mat::<f64>::zeros(n, p);
                si.apply_block(xb, ours.as_mut());
                // faer's solve of the same system.
                let mut reference = Mat::from_fn(n, p, |i, j| xb[(i, j)] * msqrt[i]);
                let mut buf = MemBuffer::new(symbolic.solve_in_place_scratch::<f64>(p, Par::Seq));
                LdltRef::new(&symbolic, &values).solve_in_place_with_conj(
                    Conj::No,
                    reference.as_mut(),
                    Par::Seq,
                    MemStack::new(&mut buf),
                );
                let reference = Mat::from_fn(n, p, |i, j| reference[(i, j)] * msqrt[i]);
                let err = (&ours - &reference).norm_max() / reference.norm_max();
                assert!(err < 1e-10, "p = {p}, METIS = {custom}: {err}");
                // And it solves (K − σI) y = M^{1/2} x for y = M^{-1/2} out.
                let y = Mat::from_fn(n, p, |i, j| ours[(i, j)] / msqrt[i]);
                let ky = op.matrix.as_ref() * &y;
                let res = Mat::from_fn(n, p, |i, j| {
                    ky[(i, j)] - sigma * y[(i, j)] - msqrt[i] * xb[(i, j)]
                });
                assert!(res.norm_max() < 1e-8 * y.norm_max().max(1.0), "p = {p}");
            }
        }
    }

    #[test]
    fn band_shifts_find_the_dense_smallest_with_multiplicities() {
        // icosphere:3 (642 vertices): highly repeated eigenvalues.
        let mesh = builtin::icosphere(3).unwrap();
        let op = assemble(OperatorKind::Sql, &mesh);
        let mut opts = PartialOptions::new(80);
        opts.dense_below = 0;
        opts.band_size = 24; // several bands, overlapping clusters
        let mut calls = 0;
        let ps = operator_partial_spectrum(&op, true, &opts, &mut |_, _| calls += 1).unwrap();
        assert!(!ps.dense);
        assert!(ps.bands.len() >= 3, "{:?}", ps.bands);
        assert!(calls >= ps.bands.len());
        assert_eq!(ps.eigenvalues.len(), 80);
        check_against_dense(&op.matrix, None, &ps);
        // The multiplicities are real: some eigenvalue repeats at least 5 times.
        let (s, _) = dense_reference(&op.matrix, None);
        let mut max_mult = 1;
        let mut run = 1;
        for j in 1..80 {
            run = if (s[j] - s[j - 1]).abs() < 1e-7 {
                run + 1
            } else {
                1
            };
            max_mult = max_mult.max(run);
        }
        assert!(max_mult >= 5, "max multiplicity {max_mult}");
    }

    #[test]
    fn single_band_agrees_with_dense_kirchhoff_on_irregular_mesh() {
        let mesh = builtin::cube(9).unwrap();
        let op = assemble(OperatorKind::Kirchhoff, &mesh);
        let mut opts = PartialOptions::new(30);
        opts.dense_below = 0;
        let ps = operator_partial_spectrum(&op, true, &opts, &mut |_, _| {}).unwrap();
        assert_eq!(ps.bands.len(), 1);
        check_against_dense(&op.matrix, None, &ps);
        assert!(ps.eigenvalues[0].abs() < 1e-10);
    }

    #[test]
    fn generalized_cotangent_problem_matches_dense_mass_normalized() {
        let mesh = builtin::torus(30, 14).unwrap();
        let op = assemble(OperatorKind::Cotan, &mesh);
        let mass = op.mass.clone().unwrap();
        let mut opts = PartialOptions::new(45);
        opts.dense_below = 0;
        opts.band_size = 20;
        let ps = operator_partial_spectrum(&op, true, &opts, &mut |_, _| {}).unwrap();
        check_against_dense(&op.matrix, Some(&mass), &ps);
        // L v = λ M v directly.
        let n = mesh.n_vertices();
        for j in 0..45 {
            let v = ps.eigenvectors.col(j);
            let lv = op.matrix.as_ref() * v;
            let err = (0..n)
                .map(|i| (lv[i] - ps.eigenvalues[j] * mass[i] * v[i]).abs())
                .fold(0.0f64, f64::max);
            assert!(err < 1e-8, "pair {j}: {err}");
        }
    }

    #[test]
    fn tutte_through_its_symmetrizer_has_the_graph_spectrum() {
        let mesh = builtin::step(16).unwrap();
        let tl = assemble(OperatorKind::Tutte, &mesh);
        let gl = assemble(OperatorKind::Graph, &mesh);
        let mut opts = PartialOptions::new(25);
        opts.dense_below = 0;
        let pt = operator_partial_spectrum(&tl, true, &opts, &mut |_, _| {}).unwrap();
        let pg = operator_partial_spectrum(&gl, true, &opts, &mut |_, _| {}).unwrap();
        for j in 0..25 {
            assert!((pt.eigenvalues[j] - pg.eigenvalues[j]).abs() < 1e-9);
            // T v = λ v for the returned (D-normalised) vectors.
            let v = pt.eigenvectors.col(j);
            let tv = tl.matrix.as_ref() * v;
            let err = (&tv - v * faer::Scale(pt.eigenvalues[j])).norm_max();
            assert!(err < 1e-9 * v.norm_max().max(1.0), "pair {j}: {err}");
        }
    }

    #[test]
    fn dense_path_and_signs_are_canonical() {
        let mesh = builtin::icosphere(1).unwrap();
        let op = assemble(OperatorKind::Graph, &mesh);
        let ps =
            operator_partial_spectrum(&op, true, &PartialOptions::new(10), &mut |_, _| {}).unwrap();
        assert!(ps.dense);
        check_against_dense(&op.matrix, None, &ps);
        for j in 0..10 {
            let col: Vec<f64> = (0..mesh.n_vertices())
                .map(|i| ps.eigenvectors[(i, j)])
                .collect();
            let max = col.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
            let first = col
                .iter()
                .position(|x| x.abs() >= max * (1.0 - 1e-9))
                .unwrap();
            assert!(col[first] > 0.0);
        }
        let mut v = vec![0.5, -1.0, 1.0, 0.2];
        canonical_sign(&mut v);
        assert_eq!(v, vec![-0.5, 1.0, -1.0, -0.2]);
    }

    #[test]
    fn bad_input_is_an_error() {
        let mesh = builtin::icosahedron();
        let op = assemble(OperatorKind::Kirchhoff, &mesh);
        let opts = PartialOptions::new(3);
        assert!(matches!(
            partial_spectrum(&op.matrix, Some(&[1.0; 5]), &opts, &mut |_, _| {}),
            Err(PartialError::Shape(_))
        ));
        let mut bad = vec![1.0; 12];
        bad[4] = 0.0;
        assert!(matches!(
            partial_spectrum(&op.matrix, Some(&bad), &opts, &mut |_, _| {}),
            Err(PartialError::BadMass { index: 4, .. })
        ));
        assert!(matches!(
            partial_spectrum(&op.matrix, None, &PartialOptions::new(13), &mut |_, _| {}),
            Err(PartialError::TooMany { count: 13, n: 12 })
        ));
        // F_01 F_10 < 0: no positive diagonal symmetrizer.
        let trip = [
            Triplet::new(0usize, 0usize, 1.0),
            Triplet::new(0, 1, -1.0),
            Triplet::new(1, 0, 1.0),
            Triplet::new(1, 1, 1.0),
        ];
        let m = SparseMatrix::try_new_from_triplets(2, 2, &trip).unwrap();
        let op = Operator {
            kind: OperatorKind::MeanValue,
            matrix: m,
            mass: None,
        };
        assert!(matches!(
            operator_partial_spectrum(&op, true, &opts, &mut |_, _| {}),
            Err(PartialError::NotSymmetrizable(OperatorKind::MeanValue))
        ));
    }
}
