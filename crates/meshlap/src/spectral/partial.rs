//! The k smallest eigenpairs of a large sparse operator, by shift-invert Lanczos in
//! shifted bands.
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
//!    LDLᵀ (supernodal or simplicial, AMD ordering); the symbolic analysis is done
//!    once and reused for every shift (the pattern does not change).
//! 2. A thick-restart Lanczos (symmetric Krylov–Schur) iteration finds the `b` (band
//!    size) eigenpairs of `A_σ` of largest magnitude. It is a port of faer 0.24's
//!    `faer::matrix_free::eigen::partial_self_adjoint_eigen` (same restart, locking and
//!    purging scheme, faer's dense kernels) with two fixes: faer's
//!    re-orthogonalisation loops forever once the Krylov space becomes invariant —
//!    which happens on symmetric meshes with repeated eigenvalues (a 488-vertex
//!    `builtin:cube:9` hangs it) — and its restart compaction can overwrite a retained
//!    Ritz vector. Here breakdowns continue with a fresh random orthogonal vector.
//! 3. **Bands.** The first shift lies just below zero (`σ₀ = −10⁻³·mean(diag M⁻¹K)`),
//!    where `K − σ₀M` is positive definite. A band at σ whose farthest eigenvalue is at
//!    distance `r` has found *every* eigenvalue in the window `(σ − r + δ, σ + r − δ)`
//!    (`δ = 10⁻⁸·max(1, |σ| + r)`; eigenvalues at distance `r − δ … r` may be an
//!    incomplete multiple eigenvalue and are left to the next band). Bands are chained
//!    so that the windows overlap: the next shift is `U + 0.55 r`, `U` the upper edge
//!    of the windows so far; a band whose window does not reach down to `U` is redone
//!    with the shift halved towards `U`. From each band only the eigenvalues in
//!    `[U, new upper edge)` are kept, so the overlaps are deduplicated and every
//!    eigenvalue below the final edge appears once, with its full multiplicity (a
//!    multiple eigenvalue is never split between two bands, since the edges are kept
//!    `δ` away from the eigenvalues that defined them). It stops when k are found.
//!    **Completeness is checked by Sylvester's law of inertia**: the negative pivots of
//!    the LDLᵀ of `K − xM` count the eigenvalues below `x`, so each band knows exactly
//!    how many eigenvalues its kept interval holds. Lanczos from one start vector can
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
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::ldlt::factor::LdltRegularization;
use faer::linalg::matmul::matmul;
use faer::matrix_free::LinOp;
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, LdltRef, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::{SparseColMat, Triplet};
use faer::{Accum, Col, ColRef, Conj, Mat, MatMut, MatRef, Par, Side};
use serde::Serialize;

/// Smallest Krylov subspace faer's eigensolver uses; it needs `n` above twice this.
const MIN_KRYLOV: usize = 32;

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
    /// Eigenpairs computed per shift (the band size b); the Krylov subspace holds 2b.
    pub band_size: usize,
    /// Convergence tolerance of the Lanczos residuals of `A_σ`, relative to the
    /// largest |μ| of the band.
    pub tolerance: f64,
    /// Restart limit of the Krylov–Schur iteration per band.
    pub max_restarts: usize,
    /// Below this dimension the dense eigensolver is used.
    pub dense_below: usize,
    /// Seed of the Lanczos starting vectors.
    pub seed: u64,
}

impl PartialOptions {
    /// Defaults for the `count` smallest eigenpairs.
    pub fn new(count: usize) -> Self {
        Self {
            count,
            band_size: 60,
            tolerance: 1e-13,
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
    let band = opts.band_size.max(1).min(count.max(MIN_KRYLOV / 2));
    let krylov = (2 * band).max(2 * MIN_KRYLOV);
    let out = if n < opts.dense_below || n <= krylov + 1 {
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

/// `A_σ = M^{1/2} (K − σM)^{-1} M^{1/2}` as a faer linear operator.
struct ShiftInvert<'a> {
    symbolic: &'a SymbolicCholesky<usize>,
    values: Vec<f64>,
    msqrt: &'a [f64],
}

impl std::fmt::Debug for ShiftInvert<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ShiftInvert")
            .field("n", &self.msqrt.len())
            .finish()
    }
}

impl LinOp<f64> for ShiftInvert<'_> {
    fn apply_scratch(&self, rhs_ncols: usize, par: Par) -> StackReq {
        self.symbolic.solve_in_place_scratch::<f64>(rhs_ncols, par)
    }
    fn nrows(&self) -> usize {
        self.msqrt.len()
    }
    fn ncols(&self) -> usize {
        self.msqrt.len()
    }
    fn apply(&self, out: MatMut<'_, f64>, rhs: MatRef<'_, f64>, par: Par, stack: &mut MemStack) {
        let mut out = out;
        for c in 0..rhs.ncols() {
            for i in 0..rhs.nrows() {
                out[(i, c)] = rhs[(i, c)] * self.msqrt[i];
            }
        }
        LdltRef::new(self.symbolic, &self.values).solve_in_place_with_conj(
            Conj::No,
            out.as_mut(),
            par,
            stack,
        );
        for c in 0..rhs.ncols() {
            for i in 0..rhs.nrows() {
                out[(i, c)] *= self.msqrt[i];
            }
        }
    }
    fn conj_apply(
        &self,
        out: MatMut<'_, f64>,
        rhs: MatRef<'_, f64>,
        par: Par,
        stack: &mut MemStack,
    ) {
        self.apply(out, rhs, par, stack)
    }
}

/// Deterministic starting vector (SplitMix64 in [−1, 1)).
fn start_vector(n: usize, seed: u64) -> Col<f64> {
    let mut state = seed;
    Col::from_fn(n, |_| {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    })
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

/// `P A P` with `P = I − WWᵀ`: the operator with the directions of `W` (orthonormal
/// columns) deflated.
struct Deflated<'a> {
    inner: &'a dyn LinOp<f64>,
    w: &'a Mat<f64>,
}

impl std::fmt::Debug for Deflated<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Deflated")
            .field("k", &self.w.ncols())
            .finish()
    }
}

impl Deflated<'_> {
    fn project(&self, mut x: MatMut<'_, f64>, par: Par) {
        let c = self.w.transpose() * x.rb();
        matmul(
            x.rb_mut(),
            Accum::Add,
            self.w.as_ref(),
            c.as_ref(),
            -1.0,
            par,
        );
    }
}

impl LinOp<f64> for Deflated<'_> {
    fn apply_scratch(&self, rhs_ncols: usize, par: Par) -> StackReq {
        self.inner.apply_scratch(rhs_ncols, par)
    }
    fn nrows(&self) -> usize {
        self.inner.nrows()
    }
    fn ncols(&self) -> usize {
        self.inner.ncols()
    }
    fn apply(&self, out: MatMut<'_, f64>, rhs: MatRef<'_, f64>, par: Par, stack: &mut MemStack) {
        let mut x = rhs.to_owned();
        self.project(x.as_mut(), par);
        let mut out = out;
        self.inner.apply(out.rb_mut(), x.as_ref(), par, stack);
        self.project(out, par);
    }
    fn conj_apply(
        &self,
        out: MatMut<'_, f64>,
        rhs: MatRef<'_, f64>,
        par: Par,
        stack: &mut MemStack,
    ) {
        self.apply(out, rhs, par, stack)
    }
}

/// The `b` eigenpairs of largest |μ| of `op` (= `A_σ`, possibly deflated) as
/// (λ = σ + 1/μ, w) with `w` in the symmetric coordinates (`w = M^{1/2} v`).
fn lanczos_pairs(
    op: &dyn LinOp<f64>,
    sigma: f64,
    b: usize,
    tol: f64,
    opts: &PartialOptions,
    seed: u64,
) -> Result<Vec<(f64, Col<f64>)>, PartialError> {
    let n = op.nrows();
    let par = faer::get_global_parallelism();
    let mut vecs = Mat::<f64>::zeros(n, b);
    let mut vals = vec![0.0f64; b];
    let v0 = start_vector(n, seed);
    let got = thick_restart_lanczos(
        op,
        vecs.as_mut(),
        &mut vals,
        v0.as_ref(),
        b.max(MIN_KRYLOV),
        (2 * b).max(2 * MIN_KRYLOV),
        tol,
        opts.max_restarts,
        seed,
        par,
    );
    if got < b {
        return Err(PartialError::NotConverged {
            shift: sigma,
            converged: got,
            wanted: b,
            restarts: opts.max_restarts,
        });
    }
    Ok((0..got)
        .map(|j| (sigma + 1.0 / vals[j], vecs.col(j).to_owned()))
        .collect())
}

/// A lower bound of the dominant |μ| of `A_σ` from a few power iterations.
fn dominant_estimate(op: &ShiftInvert<'_>, v0: &Col<f64>, par: Par) -> f64 {
    let n = v0.nrows();
    let mut buf = MemBuffer::new(op.apply_scratch(1, par));
    let mut x = v0.clone();
    let mut y = Col::<f64>::zeros(n);
    let mut est = 0.0;
    for _ in 0..4 {
        let nx = x.norm_l2();
        if nx == 0.0 {
            return 1.0;
        }
        x /= nx;
        op.apply(y.as_mat_mut(), x.as_mat(), par, MemStack::new(&mut buf));
        est = y.norm_l2();
        std::mem::swap(&mut x, &mut y);
    }
    if est.is_finite() && est > 0.0 {
        est
    } else {
        1.0
    }
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
    let par = faer::get_global_parallelism();
    let msqrt = msqrt_of(mass, n);
    let pattern = ShiftedPattern::new(k)?;
    let symbolic = factorize_symbolic_cholesky(
        pattern.base.symbolic(),
        Side::Lower,
        SymmetricOrdering::Amd,
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
    let mut sigma = gersh.min(0.0) - 1e-3 * scale;
    let mut band_no = 0usize;
    loop {
        let b = if kept.is_empty() && count <= b_max {
            count
        } else {
            b_max
        }
        .min(n.saturating_sub(2 * MIN_KRYLOV + 1).max(1));
        let values = factor_at(&pattern, &symbolic, mass, sigma)?;
        let op = ShiftInvert {
            symbolic: &symbolic,
            values,
            msqrt: &msqrt,
        };
        let seed = opts.seed.wrapping_add(1_000 * band_no as u64);
        // The tolerance is absolute on the residuals of A_σ: scale it by the dominant
        // |μ| ≈ 1/min|λ − σ|, estimated by a few power iterations.
        let tol = opts.tolerance * dominant_estimate(&op, &start_vector(n, seed), par);
        let mut found = lanczos_pairs(&op, sigma, b, tol, opts, seed)?;
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
        // Lanczos may miss copies of a repeated eigenvalue: look for them in the
        // complement of everything this band found.
        let mut tries = 0;
        while n_in < expected && tries < 8 {
            let w = Mat::from_fn(n, found.len(), |i, j| found[j].1[i]);
            let defl = Deflated { inner: &op, w: &w };
            let want = (expected - n_in).min(b).max(1);
            let more = lanczos_pairs(&defl, sigma, want, tol, opts, seed + 7 + tries as u64)?;
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
        sigma = upper + 0.55 * r;
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
    let n = msqrt.len();
    let m = pairs.len();
    let mut eigenvalues = Vec::with_capacity(m);
    let mut residuals = Vec::with_capacity(m);
    let mut eigenvectors = Mat::<f64>::zeros(n, m);
    let mut kv = vec![0.0f64; n];
    for (j, (_, w)) in pairs.into_iter().enumerate() {
        let nw = w.norm_l2();
        let mut v: Vec<f64> = (0..n).map(|i| w[i] / nw / msqrt[i]).collect();
        canonical_sign(&mut v);
        // K v
        kv.iter_mut().for_each(|x| *x = 0.0);
        for c in 0..n {
            let vc = v[c];
            for (&r, &a) in k.row_idx_of_col_raw(c).iter().zip(k.val_of_col(c)) {
                kv[r] += a * vc;
            }
        }
        let vkv: f64 = (0..n).map(|i| v[i] * kv[i]).sum();
        let vmv: f64 = (0..n).map(|i| v[i] * v[i] * msqrt[i] * msqrt[i]).sum();
        let lambda = vkv / vmv;
        let res = (0..n)
            .map(|i| {
                let r = (kv[i] - lambda * msqrt[i] * msqrt[i] * v[i]) / msqrt[i];
                r * r
            })
            .sum::<f64>()
            .sqrt()
            / vmv.sqrt();
        eigenvalues.push(lambda);
        residuals.push(res);
        for i in 0..n {
            eigenvectors[(i, j)] = v[i];
        }
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

/// Classical Gram–Schmidt, applied twice: removes from the column `w` its components
/// along the orthonormal columns of `basis` (n×j), using `coef` (≥ j rows) as
/// workspace. Returns the total coefficient along the last basis column (the Lanczos
/// α when `w = A·basis_last`).
fn orthogonalize_twice(
    basis: MatRef<'_, f64>,
    mut w: MatMut<'_, f64>,
    mut coef: MatMut<'_, f64>,
    par: Par,
) -> f64 {
    let j = basis.ncols();
    let mut last = 0.0;
    for _ in 0..2 {
        let mut c = coef.rb_mut().subrows_mut(0, j);
        matmul(
            c.rb_mut(),
            Accum::Replace,
            basis.transpose(),
            w.rb(),
            1.0,
            par,
        );
        last += c[(j - 1, 0)];
        matmul(w.rb_mut(), Accum::Add, basis, c.rb(), -1.0, par);
    }
    last
}
/// Extends the Lanczos basis `V` (n×(max_dim+1)) from column `start` to `end`
/// (inclusive), writing α into `H[(j−1, j−1)]` and β into `H[(j, j−1)]`.
/// Re-orthogonalisation is classical Gram–Schmidt applied twice ("twice is
/// enough", Giraud et al. 2005) against every previous column; on breakdown (the
/// Krylov space is invariant, as happens for repeated eigenvalues) the next vector is
/// a fresh random one orthogonal to the basis, with β = 0.
#[allow(clippy::too_many_arguments)]
fn lanczos_extend(
    op: &dyn LinOp<f64>,
    h: &mut Mat<f64>,
    v: &mut Mat<f64>,
    start: usize,
    end: usize,
    rng: &mut u64,
    par: Par,
    buf: &mut MemBuffer,
) {
    let n = v.nrows();
    let mut w = Mat::<f64>::zeros(n, 1);
    let mut coef = Mat::<f64>::zeros(end + 1, 1);
    for j in start..=end {
        for i in 0..h.nrows() {
            h[(i, j - 1)] = 0.0;
        }
        op.apply(
            w.as_mut(),
            v.as_ref().subcols(j - 1, 1),
            par,
            MemStack::new(buf),
        );
        let norm_in = w.col(0).norm_l2();
        let alpha = orthogonalize_twice(v.as_ref().subcols(0, j), w.as_mut(), coef.as_mut(), par);
        h[(j - 1, j - 1)] = alpha;
        let mut beta = w.col(0).norm_l2();
        if beta.is_nan() || beta <= 1e3 * f64::EPSILON * norm_in {
            // Breakdown: continue with a random vector orthogonal to the basis.
            beta = 0.0;
            *rng = rng.wrapping_add(0x2545_F491_4F6C_DD1D);
            let r = start_vector(n, *rng);
            w.col_mut(0).copy_from(&r);
            orthogonalize_twice(v.as_ref().subcols(0, j), w.as_mut(), coef.as_mut(), par);
        }
        let nw = w.col(0).norm_l2();
        let inv = if nw > 0.0 { 1.0 / nw } else { 0.0 };
        for i in 0..n {
            v[(i, j)] = w[(i, 0)] * inv;
        }
        h[(j, j - 1)] = beta;
    }
}

/// Thick-restart Lanczos (the symmetric Krylov–Schur method of Stewart 2001 /
/// Wu & Simon 2000) for the `nev` eigenpairs of largest magnitude of the symmetric
/// operator `op`, with locking. A port of faer 0.24's
/// `matrix_free::eigen::partial_self_adjoint_eigen` with two fixes: faer's
/// re-orthogonalisation loops forever once the Krylov space becomes invariant (it
/// does on symmetric meshes with repeated eigenvalues), and its restart compaction
/// overwrites a retained Ritz vector when a locked one follows it. Returns the number
/// of converged pairs written to `vecs`/`vals` (by decreasing |μ|).
#[allow(clippy::too_many_arguments)]
fn thick_restart_lanczos(
    op: &dyn LinOp<f64>,
    mut vecs: MatMut<'_, f64>,
    vals: &mut [f64],
    v0: ColRef<'_, f64>,
    min_dim: usize,
    max_dim: usize,
    tol: f64,
    restarts: usize,
    seed: u64,
    par: Par,
) -> usize {
    let n = op.nrows();
    let nev = vals.len();
    let max_dim = max_dim.min(n - 1);
    let min_dim = min_dim.max(nev).min(max_dim - 1);
    let mut buf = MemBuffer::new(op.apply_scratch(1, par));
    let mut rng = seed ^ 0xA076_1D64_78BD_642F;
    let mut h = Mat::<f64>::zeros(max_dim + 1, max_dim);
    let mut v = Mat::<f64>::zeros(n, max_dim + 1);
    let nv0 = v0.norm_l2();
    for i in 0..n {
        v[(i, 0)] = if nv0 > 0.0 {
            v0[i] / nv0
        } else {
            1.0 / (n as f64).sqrt()
        };
    }
    lanczos_extend(op, &mut h, &mut v, 1, min_dim, &mut rng, par, &mut buf);
    let mut k = min_dim;
    let mut active = 0usize;
    let mut residual = vec![0.0f64; max_dim];
    for _ in 0..restarts {
        lanczos_extend(op, &mut h, &mut v, k + 1, max_dim, &mut rng, par, &mut buf);
        let hmm = h[(max_dim, max_dim - 1)];
        let m = max_dim - active;
        let mut q = Mat::<f64>::identity(max_dim, max_dim);
        // Eigen-decomposition of the active block (lower triangle read).
        let block = Mat::from_fn(m, m, |i, j| {
            let (a, b) = (active + i.max(j), active + i.min(j));
            h[(a, b)]
        });
        let Ok(evd) = block.self_adjoint_eigen(Side::Lower) else {
            break;
        };
        // Order by decreasing |θ|.
        let mut order: Vec<usize> = (0..m).collect();
        order.sort_by(|&a, &b| evd.S()[b].abs().total_cmp(&evd.S()[a].abs()));
        for (c, &src) in order.iter().enumerate() {
            for r in 0..m {
                q[(active + r, active + c)] = evd.U()[(r, src)];
            }
        }
        for i in active..max_dim {
            for j in active..max_dim {
                h[(i, j)] = 0.0;
            }
        }
        for (c, &src) in order.iter().enumerate() {
            h[(active + c, active + c)] = evd.S()[src];
            residual[active + c] = hmm.abs() * q[(max_dim - 1, active + c)].abs();
        }
        // Lock converged wanted pairs (they must come first), retain the other
        // wanted ones and some more, purge the rest.
        let mut locked = Vec::new();
        let mut retained = Vec::new();
        for j in 0..nev {
            if residual[j] <= tol {
                locked.push(j);
            } else {
                retained.push(j);
            }
        }
        let nlock = locked.len();
        let ideal = (nlock + min_dim).min((min_dim + max_dim) / 2);
        for i in nev..max_dim {
            if locked.len() + retained.len() < ideal && residual[i] > tol {
                retained.push(i);
            }
        }
        let keep: Vec<usize> = locked.iter().chain(retained.iter()).copied().collect();
        k = keep.len();
        let purge = (0..active.min(nlock))
            .take_while(|&i| locked.get(i) == Some(&i))
            .count();
        let q_old = q.clone();
        let diag: Vec<f64> = (0..max_dim).map(|i| h[(i, i)]).collect();
        let res_old = residual.clone();
        for (dst, &src) in keep.iter().enumerate() {
            h[(dst, dst)] = diag[src];
            residual[dst] = res_old[src];
            for r in 0..max_dim {
                q[(r, dst)] = q_old[(r, src)];
            }
        }
        for i in k..max_dim {
            h[(i, i)] = 0.0;
        }
        // V[:, purge..k] = V[:, purge..max_dim] · Q[purge..max_dim, purge..k].
        let mut vtmp = Mat::<f64>::zeros(n, k - purge);
        matmul(
            vtmp.as_mut(),
            Accum::Replace,
            v.as_ref().subcols(purge, max_dim - purge),
            q.as_ref()
                .submatrix(purge, purge, max_dim - purge, k - purge),
            1.0,
            par,
        );
        v.as_mut().subcols_mut(purge, k - purge).copy_from(&vtmp);
        // Residual row b = H[max_dim, :] · Q.
        let row: Vec<f64> = (0..max_dim)
            .map(|c| (0..max_dim).map(|r| h[(max_dim, r)] * q[(r, c)]).sum())
            .collect();
        for c in 0..max_dim {
            h[(k, c)] = if c < k { row[c] } else { 0.0 };
            h[(max_dim, c)] = 0.0;
        }
        for i in 0..n {
            v[(i, k)] = v[(i, max_dim)];
        }
        active = nlock;
        if nlock >= nev {
            break;
        }
    }
    let mut order: Vec<usize> = (0..active).collect();
    order.sort_by(|&a, &b| h[(b, b)].abs().total_cmp(&h[(a, a)].abs()));
    for (dst, &src) in order.iter().enumerate() {
        vals[dst] = h[(src, src)];
        vecs.rb_mut().col_mut(dst).copy_from(v.col(src));
    }
    active
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
