//! Block Krylov–Schur (block thick-restart Lanczos) for the eigenpairs of largest
//! magnitude of a symmetric linear operator.
//!
//! ## Problem
//! `A` is a real symmetric n×n operator, known only through products `A·X` with
//! n×p blocks ([`BlockOperator`]). Wanted: the `nev` eigenpairs `(θ, y)` of largest
//! `|θ|`, with orthonormal `y`. In meshlap `A` is the shift-inverted operator
//! `M^{1/2}(K − σM)^{-1}M^{1/2}` of [`super::partial`], whose largest-|θ| pairs are the
//! eigenvalues of the (positive semi-definite, `F = D − W`) mesh operator nearest σ.
//!
//! ## Method
//! Stewart's Krylov–Schur restart (Stewart 2001, *A Krylov–Schur algorithm for large
//! eigenproblems*), in its symmetric form (thick-restart Lanczos, Wu & Simon 2000),
//! with a block of `p` vectors (block Lanczos, Golub & Underwood 1977):
//!
//! 1. The basis `V = [V₀ … V_j]` (orthonormal n×p blocks) satisfies
//!    `A V_{0..s} = V_{0..s} H + V_{s} R Eᵀ`. Each new block `W = A V_j` is
//!    orthogonalised by block classical Gram–Schmidt applied twice ("twice is
//!    enough": Giraud et al. 2005), as matrix products: the first pass against the
//!    blocks a Lanczos recurrence couples it to (the previous and current block, or
//!    all kept Ritz vectors right after a restart), the second measured first and
//!    applied only to the components above `10⁻¹³·‖w‖`. Loss of orthogonality goes
//!    towards the first converged Ritz vectors (Paige 1971), which sit at the front
//!    of the basis, so after measuring against the whole basis the second pass
//!    subtracts only the leading range of significant components. That range is
//!    short for a shift below the spectrum; for an interior shift (an indefinite
//!    `K − σM`) the components above the threshold spread over most of the basis,
//!    and the second pass is then close to a full one (measured in BENCHMARKS.md,
//!    "Partial spectra and partitioning"). The products of the tall basis with a
//!    thin block are memory-bound and use the streaming kernels of `thin_products`.
//!    The coefficients are stored as column block j of the projected matrix `H`; the
//!    remainder is factored `W = V_{j+1} R` by Cholesky QR twice (modified
//!    Gram–Schmidt when the block is ill-conditioned). Full re-orthogonalisation
//!    makes `H` the Rayleigh quotient `VᵀAV` up to rounding, so no Lanczos-specific
//!    structure has to be trusted: `H` is read from its upper triangle (the computed
//!    coefficients) and symmetrised. Each block thus reads the basis twice (measure,
//!    then subtract). Delaying the subtraction into the next block's measurement, as
//!    low-synchronisation Gram–Schmidt does, would read it once, but the operator is
//!    then applied to a block that still holds the components, which it amplifies
//!    by about ‖A‖/‖w‖ per block: tried and unstable (BENCHMARKS.md, "Partial spectra
//!    and partitioning", forty-fifth session).
//! 2. **Breakdown** (a column of `W` lies in the span of the basis to 10⁻¹⁰ — an
//!    invariant subspace, as happens with repeated eigenvalues of symmetric meshes):
//!    the column is replaced by a seeded random vector orthogonal to the basis, with a
//!    zero coupling coefficient, so the relation above stays exact.
//! 3. **Rayleigh–Ritz** at checkpoints (four per restart cycle, the last when the
//!    basis holds `m` = `max_dim` expanded columns, or earlier where the convergence
//!    rate measured between two checks predicts convergence): `H = QΘQᵀ`; Ritz pairs
//!    `(θᵢ, V qᵢ)` by decreasing `|θ|`, residual norms `‖A yᵢ − θᵢ yᵢ‖ = ‖R Q_{last,i}‖`
//!    (no extra products). Converged: residual ≤ `tolerance · |θᵢ|` per pair, ARPACK's
//!    criterion; for `A = (F − σ)^{-1}` it bounds `‖F y − λ y‖ ≤ ‖F − σ‖ · tolerance`.
//!    The estimates assume `H qᵢ = θᵢ qᵢ` exactly; faer's dense eigenvectors miss that
//!    by 10⁻¹³–10⁻¹²·‖H‖ at s ≈ 500, which would cap the true residual of the pairs far
//!    from the shift at ~10⁻¹¹·|θᵢ|. So before the pairs leave the projected problem
//!    (as the result, or as the kept vectors of a restart) the decomposition gets one
//!    refinement step (`refined_evd`, Ogita & Aishima 2018) and the estimates are
//!    taken again. **Accuracy floor:** the operator's own rounding (presumably that
//!    of the shift-invert solves) can hold the pairs of smallest `|θ|` just above
//!    that criterion, with the estimates going up and down from restart to restart.
//!    When the worst wanted estimate has not halved for [`STALL_RESTARTS`] restarts
//!    and is within [`STALL_SLACK`] times the tolerance, the run returns its pairs
//!    and says so (`KrylovSchurInfo::stagnated`) instead of restarting up to
//!    `max_restarts`.
//! 4. **Restart**: keep the `k = nev + 3(m − nev)/10` Ritz vectors of largest `|θ|`
//!    and the residual block; `H` becomes `diag(θ)` bordered by the coupling
//!    `R Q_last`, and the expansion continues. Converged vectors are not locked
//!    separately: they stay in the kept set, which costs nothing extra with full
//!    re-orthogonalisation.
//!
//! With blocks, a multiple eigenvalue of multiplicity up to `p` is found with all its
//! copies from one start (a single-vector Krylov space holds only one vector of each
//! eigenspace), and the solves `A·X` run on `p` right-hand sides at once.
//!
//! An optional orthonormal `deflate` block (n×d) is projected out of every basis
//! vector: the solver then works on `P A P`, `P = I − D Dᵀ` (used to find copies of a
//! multiple eigenvalue a previous run missed).

use faer::linalg::matmul::matmul;
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::{Accum, Mat, MatMut, MatRef, Par};

use super::thin_products;

/// A real symmetric operator applied to blocks of vectors.
pub trait BlockOperator: Sync {
    /// The dimension n.
    fn dim(&self) -> usize;
    /// `out = A x` for an n×p block `x`.
    fn apply_block(&self, x: MatRef<'_, f64>, out: MatMut<'_, f64>);
}

/// Parameters of [`largest_magnitude`].
#[derive(Clone, Copy, Debug)]
pub struct KrylovSchurParams {
    /// Block size p (vectors per operator application).
    pub block: usize,
    /// Expanded basis size m before a restart (the basis stores m + p vectors).
    pub max_dim: usize,
    /// Convergence: residual ≤ `tolerance · |θ|` for each wanted pair.
    pub tolerance: f64,
    /// Restart limit.
    pub max_restarts: usize,
    /// Seed of the starting block and of breakdown replacements.
    pub seed: u64,
}

impl Default for KrylovSchurParams {
    fn default() -> Self {
        Self {
            block: 16,
            max_dim: 160,
            tolerance: 1e-12,
            max_restarts: 500,
            seed: 0x5eed,
        }
    }
}

/// Statistics of a run.
#[derive(Clone, Debug, Default)]
pub struct KrylovSchurInfo {
    /// Restarts performed.
    pub restarts: usize,
    /// Vectors the operator was applied to.
    pub applications: usize,
    /// Breakdowns (columns replaced by random vectors).
    pub breakdowns: usize,
    /// Blocks whose second Gram–Schmidt pass found only rounding-level components
    /// (below `REORTH_SKIP·‖w‖`) and skipped the update.
    pub skipped_updates: usize,
    /// Largest residual estimate of the wanted pairs, relative to max|θ|, after each
    /// Rayleigh–Ritz step.
    pub residual_history: Vec<f64>,
    /// The run stopped at its accuracy floor: the wanted pairs' largest relative
    /// residual estimate had not halved for [`STALL_RESTARTS`] restarts and was within
    /// [`STALL_SLACK`] times the tolerance (see [`largest_magnitude`]).
    pub stagnated: bool,
}

/// Restarts without the worst wanted residual halving after which a run within
/// [`STALL_SLACK`] of its tolerance is accepted.
pub const STALL_RESTARTS: usize = 8;

/// How far above the tolerance a stagnated run may stop: the worst wanted pair's
/// residual estimate is then at most `STALL_SLACK · tolerance · |θ|`.
pub const STALL_SLACK: f64 = 10.0;

/// Errors of [`largest_magnitude`].
#[derive(Debug, thiserror::Error)]
pub enum KrylovSchurError {
    /// The basis does not fit: `nev + p > m` or `m + p` exceeds the free dimension.
    #[error("Krylov–Schur basis of {max_dim} + {block} vectors cannot hold {nev} eigenpairs in dimension {dim}")]
    TooLarge {
        /// Wanted pairs.
        nev: usize,
        /// Block size.
        block: usize,
        /// Basis size.
        max_dim: usize,
        /// Free dimension.
        dim: usize,
    },
    /// Not all wanted pairs converged within the restart limit.
    #[error("{converged} of {wanted} eigenpairs converged within {restarts} restarts")]
    NoConvergence {
        /// Converged pairs.
        converged: usize,
        /// Wanted pairs.
        wanted: usize,
        /// Restarts.
        restarts: usize,
    },
    /// The projected (dense) eigenproblem did not converge: the Krylov basis holds
    /// non-finite entries, which points at a non-finite operator.
    #[error("the projected eigenproblem of size {size} did not converge")]
    Projected {
        /// Dimension of the projected matrix.
        size: usize,
    },
}

/// Eigenpairs found by [`largest_magnitude`].
#[derive(Clone, Debug)]
pub struct RitzPairs {
    /// Eigenvalues θ by decreasing |θ|.
    pub values: Vec<f64>,
    /// n×nev orthonormal eigenvectors (columns), in the order of `values`.
    pub vectors: Mat<f64>,
    /// Residual estimates `‖A y − θ y‖`.
    pub residuals: Vec<f64>,
    /// Statistics.
    pub info: KrylovSchurInfo,
}

/// Deterministic pseudo-random entries in [−1, 1) (SplitMix64).
pub(crate) fn random_fill(mut x: MatMut<'_, f64>, seed: u64) {
    let mut rng = crate::rng::SplitMix64::new(seed);
    for j in 0..x.ncols() {
        for i in 0..x.nrows() {
            x[(i, j)] = rng.next_f64() * 2.0 - 1.0;
        }
    }
}

/// Rows per thread below which the dense products stay on one thread.
const MIN_ROWS_PER_THREAD: usize = 2048;

/// Number of row chunks for an n-row product.
fn row_threads(n: usize) -> usize {
    rayon::current_num_threads()
        .min(n / MIN_ROWS_PER_THREAD)
        .max(1)
}

/// `out ← β·out + α·A C` for tall `A` (n×s) and a wide `C` (the restarts' and the
/// final Ritz vectors: compute-bound, faer's GEMM), by row chunks on the rayon
/// threads, each a sequential faer product. (faer's own parallel products spin-wait
/// in their thread pool; on two shared cores that costs more than it gains.) The
/// memory-bound products with a thin block are in [`thin_products`].
fn nn_product(
    out: MatMut<'_, f64>,
    accum: Accum,
    a: MatRef<'_, f64>,
    c: MatRef<'_, f64>,
    alpha: f64,
) {
    /// `out ← … + α·A C` on `threads` threads: the rows of `out` and `A` are halved
    /// until one thread is left; `(accum, C, α)` is the same for every half.
    fn go(
        out: MatMut<'_, f64>,
        a: MatRef<'_, f64>,
        same: (Accum, MatRef<'_, f64>, f64),
        threads: usize,
    ) {
        if threads <= 1 {
            let (accum, c, alpha) = same;
            matmul(out, accum, a, c, alpha, Par::Seq);
            return;
        }
        let h = a.nrows() / 2;
        let (o1, o2) = out.split_at_row_mut(h);
        let (a1, a2) = a.split_at_row(h);
        rayon::join(
            || go(o1, a1, same, threads / 2),
            || go(o2, a2, same, threads - threads / 2),
        );
    }
    go(out, a, (accum, c, alpha), row_threads(a.nrows()))
}

/// Makes `work` usable as n × at least `cols` storage: kept as it is when it has n
/// rows and at least `cols` columns (its contents are then whatever it held), else
/// replaced by a zeroed n × `cols` matrix, the old one freed first so that the two are
/// never alive together.
pub(crate) fn reuse_or_zeroed(work: &mut Mat<f64>, n: usize, cols: usize) {
    if work.nrows() != n || work.ncols() < cols {
        *work = Mat::new();
        *work = crate::mem::zeroed_mat(n, cols);
    }
}

/// Relative size below which the components a second Gram–Schmidt pass measures
/// are left in place (the basis stays orthogonal to about this level).
const REORTH_SKIP: f64 = 1e-13;

/// `w ← w − B (Bᵀ w)` once; the coefficients are added to `coef` when given.
fn project_once(basis: MatRef<'_, f64>, mut w: MatMut<'_, f64>, coef: Option<MatMut<'_, f64>>) {
    if basis.ncols() == 0 {
        return;
    }
    let c = thin_products::tn(basis, w.rb());
    thin_products::sub_nn(w.rb_mut(), basis, c.as_ref());
    if let Some(mut acc) = coef {
        acc += &c;
    }
}

/// `w ← w − B (Bᵀ w)` twice; the coefficients are added to `coef` when given.
fn project_out(basis: MatRef<'_, f64>, mut w: MatMut<'_, f64>, mut coef: Option<MatMut<'_, f64>>) {
    for _ in 0..2 {
        project_once(basis, w.rb_mut(), coef.as_mut().map(|c| c.rb_mut()));
    }
}

/// Eigendecomposition of the small symmetric projected matrix, on one thread.
fn projected_evd(t: &Mat<f64>) -> Result<(Vec<f64>, Mat<f64>), KrylovSchurError> {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::linalg::evd::{self, ComputeEigenvectors};
    let n = t.nrows();
    let mut u = Mat::<f64>::zeros(n, n);
    let mut s = faer::diag::Diag::<f64>::zeros(n);
    let mut mem = MemBuffer::new(evd::self_adjoint_evd_scratch::<f64>(
        n,
        ComputeEigenvectors::Yes,
        Par::Seq,
        Default::default(),
    ));
    evd::self_adjoint_evd(
        t.as_ref(),
        s.as_mut(),
        Some(u.as_mut()),
        Par::Seq,
        MemStack::new(&mut mem),
        Default::default(),
    )
    .map_err(|_| KrylovSchurError::Projected { size: n })?;
    Ok(((0..n).map(|i| s[i]).collect(), u))
}

/// `‖w_j‖₂` by [`thin_products::col_norm2`].
fn col_norm(w: MatRef<'_, f64>, j: usize) -> f64 {
    thin_products::col_norm2(w.col(j))
}

/// Orthonormalises the block `w` (n×p) against `deflate`, the basis `v` (n×s) and
/// itself. Writes the basis coefficients into `coef` (s×p, accumulated) and the
/// intra-block factor into `r` (p×p upper triangular; a zero diagonal marks a
/// breakdown column replaced by a random one). The breakdown test is relative to the
/// column norms before any orthogonalisation. `scratch` (n×p, contents irrelevant)
/// is the intra-block factorization's work block, kept by the caller from block to
/// block.
///
/// `local_from`: in exact arithmetic `w = A V_j` has components only along the
/// columns `local_from..s` (the previous and current blocks of a Lanczos
/// recurrence; everything after a restart's kept Ritz vectors for the first block).
/// The first Gram–Schmidt pass is then restricted to them and the second pass
/// measures the components along the whole basis, subtracting only the significant
/// range — the "twice is enough" guarantee at well under the cost of two full
/// passes.
#[allow(clippy::too_many_arguments)]
fn orthonormalize_block(
    deflate: Option<MatRef<'_, f64>>,
    v: MatRef<'_, f64>,
    local_from: usize,
    mut w: MatMut<'_, f64>,
    mut coef: MatMut<'_, f64>,
    mut r: MatMut<'_, f64>,
    scratch: MatMut<'_, f64>,
    rng: &mut u64,
    info: &mut KrylovSchurInfo,
) {
    let p = w.ncols();
    let s = v.ncols();
    let raw: Vec<f64> = (0..p).map(|j| col_norm(w.rb(), j)).collect();
    if let Some(d) = deflate {
        project_out(d, w.rb_mut(), None);
    }
    if local_from == 0 {
        project_out(v, w.rb_mut(), Some(coef));
    } else {
        project_once(
            v.subcols(local_from, s - local_from),
            w.rb_mut(),
            Some(coef.rb_mut().subrows_mut(local_from, s - local_from)),
        );
        // Second pass: measure first, and subtract only the components above
        // rounding level. With a fully re-orthogonalised basis they are about
        // 1e-15·‖w‖ after the local pass; where orthogonality is being lost, it is
        // lost towards the earliest (first converged) Ritz vectors (Paige), so the
        // significant rows form a leading range, and only that range is subtracted:
        // short for a shift below the spectrum, most of the basis for an interior
        // shift (BENCHMARKS.md, "Partial spectra and partitioning"). (Measuring only
        // that range in most blocks, with a full measurement every 4th, saved 1 % on
        // the bunny and cost accuracy: Igea's k = 1000 residuals went from 5.5e-12 to
        // 3.9e-11, every 8th block gave 1.9e-11 on the bunny.)
        let thresholds: Vec<f64> = (0..p).map(|j| REORTH_SKIP * col_norm(w.rb(), j)).collect();
        let c = thin_products::tn(v, w.rb());
        let mut lo = usize::MAX;
        let mut hi = 0usize;
        for (j, &threshold) in thresholds.iter().enumerate() {
            for (i, x) in c.col(j).iter().enumerate() {
                if x.abs() > threshold {
                    lo = lo.min(i);
                    hi = hi.max(i);
                }
            }
        }
        if lo <= hi {
            let len = hi + 1 - lo;
            let part = c.as_ref().subrows(lo, len);
            thin_products::sub_nn(w.rb_mut(), v.subcols(lo, len), part);
            let mut dst = coef.subrows_mut(lo, len);
            dst += part;
        } else {
            info.skipped_updates += 1;
        }
    }
    r.fill(0.0);
    if p > 1 && cholesky_qr2(w.rb_mut(), r.rb_mut(), &raw, scratch) {
        return;
    }
    r.fill(0.0);
    for j in 0..p {
        for _ in 0..2 {
            for i in 0..j {
                let d = w.rb().col(i).transpose() * w.rb().col(j);
                sub_col(w.rb_mut(), i, j, d);
                r[(i, j)] += d;
            }
        }
        let norm = col_norm(w.rb(), j);
        let scale = raw[j].max(f64::MIN_POSITIVE);
        if norm.is_finite() && norm > 1e-10 * scale {
            if norm < 1e-3 * scale {
                // Heavy cancellation: one more pass against everything.
                reorthogonalize_column(deflate, v, w.rb_mut(), j);
            }
            let nw = col_norm(w.rb(), j);
            r[(j, j)] = norm;
            let inv = 1.0 / nw;
            w.rb_mut().col_mut(j).iter_mut().for_each(|x| *x *= inv);
        } else {
            // Breakdown: an invariant subspace. Continue with a random direction.
            info.breakdowns += 1;
            for i in 0..=j {
                r[(i, j)] = if i == j { 0.0 } else { r[(i, j)] };
            }
            *rng = rng.wrapping_add(0x2545_F491_4F6C_DD1D);
            random_fill(w.rb_mut().subcols_mut(j, 1), *rng);
            for _ in 0..2 {
                reorthogonalize_column(deflate, v, w.rb_mut(), j);
            }
            let nw = col_norm(w.rb(), j);
            let inv = if nw > 0.0 { 1.0 / nw } else { 0.0 };
            w.rb_mut().col_mut(j).iter_mut().for_each(|x| *x *= inv);
        }
    }
}

/// The intra-block factorization `W = Q R` by Cholesky QR applied twice (Stathopoulos
/// & Wu 2002; Fukaya et al. 2014): `G = WᵀW = R₁ᵀR₁`, `W ← W R₁⁻¹`, again with `R₂`,
/// `R = R₂R₁`. Two products over the n×p block per pass, split between the threads,
/// instead of the p(p−1) sequential dot products and updates of modified
/// Gram–Schmidt. Returns `false` and leaves `w` and `r` untouched when the block is
/// ill-conditioned — a pivot of the first pass below `10⁻³` of its column's raw norm
/// (heavy cancellation or a breakdown, which the caller's Gram–Schmidt path handles
/// with its extra re-orthogonalisation and random replacement columns) or a failed
/// Cholesky. `q` is work storage of w's shape (n×p), overwritten before it is read:
/// its contents on entry do not matter.
fn cholesky_qr2(
    mut w: MatMut<'_, f64>,
    mut r: MatMut<'_, f64>,
    raw: &[f64],
    mut q: MatMut<'_, f64>,
) -> bool {
    let p = w.ncols();
    let first = match cholesky_upper(&thin_products::tn(w.rb(), w.rb())) {
        Some(r1) => r1,
        None => return false,
    };
    let well_conditioned = (0..p).all(|j| first[(j, j)] > 1e-3 * raw[j].max(f64::MIN_POSITIVE));
    if !well_conditioned {
        return false;
    }
    nn_product(
        q.rb_mut(),
        Accum::Replace,
        w.rb(),
        upper_inverse(&first).as_ref(),
        1.0,
    );
    let second = match cholesky_upper(&thin_products::tn(q.rb(), q.rb())) {
        Some(r2) => r2,
        None => return false,
    };
    nn_product(
        w.rb_mut(),
        Accum::Replace,
        q.rb(),
        upper_inverse(&second).as_ref(),
        1.0,
    );
    r.copy_from(&second * &first);
    true
}

/// Upper Cholesky factor `R` (`G = RᵀR`) of a small symmetric matrix; `None` unless
/// every pivot is positive and finite. (p×p with p the block size: written out here
/// to get the failure as a value, without faer's allocation and error plumbing.)
fn cholesky_upper(g: &Mat<f64>) -> Option<Mat<f64>> {
    let p = g.nrows();
    let mut r = Mat::<f64>::zeros(p, p);
    for j in 0..p {
        let mut d = g[(j, j)];
        for k in 0..j {
            d -= r[(k, j)] * r[(k, j)];
        }
        if !(d > 0.0 && d.is_finite()) {
            return None;
        }
        let rjj = d.sqrt();
        r[(j, j)] = rjj;
        for i in j + 1..p {
            let mut x = g[(j, i)];
            for k in 0..j {
                x -= r[(k, j)] * r[(k, i)];
            }
            r[(j, i)] = x / rjj;
        }
    }
    Some(r)
}

/// Inverse of a small upper triangular matrix with a nonzero diagonal.
fn upper_inverse(r: &Mat<f64>) -> Mat<f64> {
    let p = r.nrows();
    let mut x = Mat::<f64>::zeros(p, p);
    for j in 0..p {
        x[(j, j)] = 1.0 / r[(j, j)];
        for i in (0..j).rev() {
            let mut s = 0.0;
            for k in i + 1..=j {
                s += r[(i, k)] * x[(k, j)];
            }
            x[(i, j)] = -s / r[(i, i)];
        }
    }
    x
}

/// Column `j` of `w` projected against `deflate`, `v` and the columns `0..j` of `w`.
fn reorthogonalize_column(
    deflate: Option<MatRef<'_, f64>>,
    v: MatRef<'_, f64>,
    mut w: MatMut<'_, f64>,
    j: usize,
) {
    if let Some(d) = deflate {
        project_out(d, w.rb_mut().subcols_mut(j, 1), None);
    }
    project_out(v, w.rb_mut().subcols_mut(j, 1), None);
    for i in 0..j {
        let d = w.rb().col(i).transpose() * w.rb().col(j);
        sub_col(w.rb_mut(), i, j, d);
    }
}

/// `w_j ← w_j − d·w_i` (`i < j`).
fn sub_col(w: MatMut<'_, f64>, i: usize, j: usize, d: f64) {
    let (left, right) = w.split_at_col_mut(j);
    let qi = left.rb().col(i);
    let mut wj = right.col_mut(0);
    wj -= faer::Scale(d) * qi;
}

/// The Ritz pairs of one Rayleigh–Ritz step, ranked.
struct Assessed {
    /// Indices of the pairs by decreasing |θ|.
    order: Vec<usize>,
    /// Residual estimate `‖R_last · Q[s−p..s, i]‖` of each pair, in `order`.
    res: Vec<f64>,
    /// Largest relative residual of the wanted pairs.
    worst: f64,
    /// Wanted pairs within `tolerance · |θ|`.
    converged: usize,
}

/// Ranks the Ritz pairs `(θ, Q)` of the s×s projected matrix and estimates their
/// residuals from the last coupling block of `h` (no operator products).
fn assess(
    h: &Mat<f64>,
    s: usize,
    p: usize,
    nev: usize,
    theta: &[f64],
    q: MatRef<'_, f64>,
    tolerance: f64,
) -> Assessed {
    let mut order: Vec<usize> = (0..s).collect();
    order.sort_by(|&a, &b| theta[b].abs().total_cmp(&theta[a].abs()));
    let r_last = h.as_ref().submatrix(s, s - p, p, p);
    let res: Vec<f64> = order
        .iter()
        .map(|&i| (r_last * q.submatrix(s - p, i, p, 1)).norm_l2())
        .collect();
    let relative = |(&i, &x): (&usize, &f64)| x / theta[i].abs().max(f64::MIN_POSITIVE);
    let worst = order[..nev]
        .iter()
        .zip(&res[..nev])
        .map(relative)
        .fold(0.0f64, f64::max);
    let converged = order[..nev]
        .iter()
        .zip(&res[..nev])
        .filter(|(&i, &x)| x <= tolerance * theta[i].abs())
        .count();
    Assessed {
        order,
        res,
        worst,
        converged,
    }
}

/// The `nev` eigenpairs of largest |θ| of the symmetric operator `op` (see the module
/// documentation). `deflate`, when given, is an orthonormal n×d block whose span is
/// excluded.
pub fn largest_magnitude(
    op: &dyn BlockOperator,
    nev: usize,
    deflate: Option<MatRef<'_, f64>>,
    params: &KrylovSchurParams,
) -> Result<RitzPairs, KrylovSchurError> {
    largest_magnitude_in(op, nev, deflate, params, &mut Mat::new())
}

/// [`largest_magnitude`] with the n×(m + p) basis kept in `basis` (m =
/// `params.max_dim` clamped as above, p the block size), for a caller that runs
/// several iterations in a row (the bands of [`super::partial`]): when `basis` already
/// has n rows and at least m + p columns its storage is used as it is, else it is
/// replaced by a new zeroed matrix of that size. Large bases are mapped from the
/// kernel by the allocator and given back when freed, so a new one per run pays a
/// page fault and a page clearing for every 4 KiB of its n × (m + p) values.
/// The iteration reads only basis columns it has written, so what
/// the storage held before does not matter: the result has the same bits either way.
/// On return `basis` holds the eigenvectors in its first `nev` columns (the
/// `vectors` returned are a copy of them) and unspecified values in the rest.
pub fn largest_magnitude_in(
    op: &dyn BlockOperator,
    nev: usize,
    deflate: Option<MatRef<'_, f64>>,
    params: &KrylovSchurParams,
    basis: &mut Mat<f64>,
) -> Result<RitzPairs, KrylovSchurError> {
    let got = largest_magnitude_in_place(op, nev, deflate, params, basis)?;
    Ok(RitzPairs {
        values: got.values,
        vectors: basis.as_ref().subcols(0, nev).to_owned(),
        residuals: got.residuals,
        info: got.info,
    })
}

/// Eigenvalues found by [`largest_magnitude_in_place`], whose eigenvectors are in
/// the basis.
#[derive(Clone, Debug)]
pub(crate) struct RitzValues {
    /// Eigenvalues θ by decreasing |θ|.
    pub(crate) values: Vec<f64>,
    /// Residual estimates `‖A y − θ y‖`.
    pub(crate) residuals: Vec<f64>,
    /// Statistics.
    pub(crate) info: KrylovSchurInfo,
}

/// [`largest_magnitude_in`] without the copy of the eigenvectors: on return (`Ok`)
/// the first `nev` columns of `basis` (n rows) hold them, orthonormal, in the order
/// of `values`; the caller takes what it needs from there. For a caller that copies
/// them elsewhere anyway (the bands of [`super::partial`] keep each pair as a
/// column of its own), this saves an n×nev matrix of memory the process has not
/// used (slow on a VM: the first touch of each page).
pub(crate) fn largest_magnitude_in_place(
    op: &dyn BlockOperator,
    nev: usize,
    deflate: Option<MatRef<'_, f64>>,
    params: &KrylovSchurParams,
    basis: &mut Mat<f64>,
) -> Result<RitzValues, KrylovSchurError> {
    let n = op.dim();
    let d = deflate.map_or(0, |x| x.ncols());
    let free = n.saturating_sub(d);
    let p = params.block.max(1);
    let m = params.max_dim.min(free.saturating_sub(p));
    if nev == 0 || nev + p > m || m + p > free {
        return Err(KrylovSchurError::TooLarge {
            nev,
            block: p,
            max_dim: params.max_dim,
            dim: free,
        });
    }
    let mut info = KrylovSchurInfo::default();
    let mut rng = params.seed ^ 0xA076_1D64_78BD_642F;
    reuse_or_zeroed(basis, n, m + p);
    let mut v = basis.as_mut().subcols_mut(0, m + p);
    let mut h = Mat::<f64>::zeros(m + p, m + p);
    // The intra-block factorization's n×p work block, allocated once instead of once
    // per block: fewer page faults, though no measurable time (BENCHMARKS.md,
    // "Partial spectra", forty-second session).
    let mut scratch = Mat::<f64>::zeros(n, p);
    // Starting block.
    {
        let mut w = Mat::<f64>::zeros(n, p);
        random_fill(w.as_mut(), params.seed);
        let mut c = Mat::<f64>::zeros(0, p);
        let mut r = Mat::<f64>::zeros(p, p);
        orthonormalize_block(
            deflate,
            v.as_ref().subcols(0, 0),
            0,
            w.as_mut(),
            c.as_mut(),
            r.as_mut(),
            scratch.as_mut(),
            &mut rng,
            &mut info,
        );
        v.as_mut().subcols_mut(0, p).copy_from(&w);
    }
    let mut s = 0usize;
    let mut restart_start = 0usize;
    let mut last_check: Option<(usize, f64)> = None;
    let mut predicted: Option<usize> = None;
    // The best worst-residual at a restart so far, and restarts since it last halved.
    let mut best_worst = f64::INFINITY;
    let mut stalled = 0usize;
    let mut w = Mat::<f64>::zeros(n, p);
    let mut r = Mat::<f64>::zeros(p, p);
    loop {
        // Expand block by block up to the next convergence check: four per cycle
        // (the last at m), none before the basis can hold the wanted pairs.
        let step = ((m - restart_start) / 4).max(p);
        let mut target = restart_start + step;
        while target < m && (target < s + p || target < nev + p) {
            target += step;
        }
        // Once two checks of this cycle have measured the convergence rate, jump
        // to where it predicts convergence (one block beyond), if that is sooner.
        if let Some(predicted) = predicted {
            if predicted >= s + p && predicted < target {
                target = predicted;
            }
        }
        let target = target.min(m);
        while s + p <= target {
            op.apply_block(v.as_ref().subcols(s, p), w.as_mut());
            info.applications += p;
            let mut c = Mat::<f64>::zeros(s + p, p);
            // Lanczos locality: the first block after a restart couples to the kept
            // Ritz vectors, later ones only to the previous block.
            let local_from = if s == restart_start { 0 } else { s - p };
            orthonormalize_block(
                deflate,
                v.as_ref().subcols(0, s + p),
                local_from,
                w.as_mut(),
                c.as_mut(),
                r.as_mut(),
                scratch.as_mut(),
                &mut rng,
                &mut info,
            );
            h.as_mut().submatrix_mut(0, s, s + p, p).copy_from(&c);
            h.as_mut().submatrix_mut(s + p, s, p, p).copy_from(&r);
            v.as_mut().subcols_mut(s + p, p).copy_from(&w);
            s += p;
        }
        // Rayleigh–Ritz on the symmetrised projected matrix (upper triangle).
        let t = Mat::from_fn(s, s, |i, j| h[(i.min(j), i.max(j))]);
        let (mut theta, mut q) = projected_evd(&t)?;
        let room = s + p <= m;
        let last_chance = !room && info.restarts >= params.max_restarts;
        let mut assessed = assess(&h, s, p, nev, &theta, q.as_ref(), params.tolerance);
        // The pairs leave the projected problem — as the result, or as the kept
        // vectors of a restart — only after one refinement step of the projected
        // eigendecomposition (see `refined_evd`): faer's eigenvectors of T carry a
        // residual of 10⁻¹³–10⁻¹²·‖T‖ that the estimates below do not see, a floor of
        // 10⁻¹¹·|θ| for the pairs far from the shift.
        if assessed.converged == nev || !room {
            super::refined_evd::refine_evd(t.as_ref(), &mut theta, &mut q);
            assessed = assess(&h, s, p, nev, &theta, q.as_ref(), params.tolerance);
        }
        let Assessed {
            order,
            res,
            worst,
            converged,
        } = assessed;
        let q = q.as_ref();
        let r_last = h.as_ref().submatrix(s, s - p, p, p);
        info.residual_history.push(worst);
        // Convergence rate per basis vector from the previous check of this cycle.
        predicted = None;
        if let Some((s0, w0)) = last_check {
            if s > s0 && worst > 0.0 && w0 > worst {
                let rate = (worst / w0).ln() / (s - s0) as f64;
                let more = (params.tolerance.ln() - worst.ln()) / rate;
                if more.is_finite() && more > 0.0 {
                    let blocks = (more / p as f64).ceil() as usize + 1;
                    predicted = Some(s + blocks * p);
                }
            }
        }
        last_check = Some((s, worst));
        // At a restart point: has the worst wanted residual stopped improving? The
        // operator's own rounding can hold the pairs far from the shift just above a
        // tolerance relative to their small |θ| (Igea, bands of 140: about
        // 1000·ε·max|θ|); the run then accepts that floor instead of restarting until
        // `max_restarts`.
        let mut at_floor = false;
        if !room {
            if worst < 0.5 * best_worst {
                best_worst = worst;
                stalled = 0;
            } else {
                stalled += 1;
            }
            at_floor = converged < nev
                && stalled >= STALL_RESTARTS
                && worst <= STALL_SLACK * params.tolerance;
        }
        if converged == nev || at_floor || last_chance {
            info.stagnated = at_floor;
            if converged < nev && !at_floor {
                return Err(KrylovSchurError::NoConvergence {
                    converged,
                    wanted: nev,
                    restarts: info.restarts,
                });
            }
            // The Ritz vectors V Q[:, order[..nev]], in place (see `nn_in_place`):
            // no n×nev matrix of fresh memory beside the basis.
            let qsel = Mat::from_fn(s, nev, |i, j| q[(i, order[j])]);
            thin_products::nn_in_place(v.as_mut().subcols_mut(0, s), qsel.as_ref());
            return Ok(RitzValues {
                values: order[..nev].iter().map(|&i| theta[i]).collect(),
                residuals: res[..nev].to_vec(),
                info,
            });
        }
        if room {
            // Not at m yet: keep expanding.
            continue;
        }
        // Restart: keep k Ritz vectors and the residual block.
        info.restarts += 1;
        let k = (nev + 3 * (m - nev) / 10).clamp(nev, m - p);
        let resid_block = v.as_ref().subcols(s, p).to_owned();
        let q_last = Mat::from_fn(p, k, |i, j| q[(s - p + i, order[j])]);
        let coupling = r_last * &q_last;
        // The kept Ritz vectors V Q[:, order[..k]], in place (see `nn_in_place`).
        let qsel = Mat::from_fn(s, k, |i, j| q[(i, order[j])]);
        thin_products::nn_in_place(v.as_mut().subcols_mut(0, s), qsel.as_ref());
        v.as_mut().subcols_mut(k, p).copy_from(&resid_block);
        h.fill(0.0);
        for (j, &i) in order[..k].iter().enumerate() {
            h[(j, j)] = theta[i];
        }
        // Lower coupling block (kept for completeness; T reads the upper triangle,
        // which the next expansion fills with its transpose).
        h.as_mut().submatrix_mut(k, 0, p, k).copy_from(&coupling);
        s = k;
        restart_start = k;
        last_check = None;
        predicted = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A diagonal operator with given eigenvalues in a random orthonormal basis would
    /// need a dense Q; a diagonal one is enough to test the iteration.
    struct Diagonal(Vec<f64>);
    impl BlockOperator for Diagonal {
        fn dim(&self) -> usize {
            self.0.len()
        }
        fn apply_block(&self, x: MatRef<'_, f64>, mut out: MatMut<'_, f64>) {
            for j in 0..x.ncols() {
                for i in 0..x.nrows() {
                    out[(i, j)] = self.0[i] * x[(i, j)];
                }
            }
        }
    }

    /// [`largest_magnitude`] of the diagonal operator `vals` with blocks of `block`
    /// and a basis of at most `max_dim` vectors.
    fn run(
        vals: Vec<f64>,
        nev: usize,
        deflate: Option<MatRef<'_, f64>>,
        block: usize,
        max_dim: usize,
    ) -> Result<RitzPairs, KrylovSchurError> {
        let params = KrylovSchurParams {
            block,
            max_dim,
            ..Default::default()
        };
        largest_magnitude(&Diagonal(vals), nev, deflate, &params)
    }

    /// `(value, copies)` groups, in order.
    fn repeated(groups: &[(f64, usize)]) -> Vec<f64> {
        groups
            .iter()
            .flat_map(|&(v, c)| std::iter::repeat_n(v, c))
            .collect()
    }

    /// Eigenvalues 1/(1 + i), i < 400, with a basis small enough for 20 pairs to
    /// need restarts.
    fn restarting_diagonal() -> (Vec<f64>, KrylovSchurParams) {
        let vals = (0..400).map(|i| 1.0 / (1.0 + i as f64)).collect();
        let params = KrylovSchurParams {
            block: 4,
            max_dim: 48,
            ..Default::default()
        };
        (vals, params)
    }

    /// A basis storage reused from an earlier run (here: NaN everywhere, and wider
    /// than needed) gives the bits of a fresh one, through restarts: the iteration
    /// reads only columns it has written.
    #[test]
    fn a_reused_basis_gives_the_same_bits() {
        let (vals, params) = restarting_diagonal();
        let fresh = largest_magnitude(&Diagonal(vals.clone()), 20, None, &params).unwrap();
        assert!(fresh.info.restarts > 0, "the test wants restarts");
        let mut basis = Mat::from_fn(400, 70, |_, _| f64::NAN);
        let reused = largest_magnitude_in(&Diagonal(vals), 20, None, &params, &mut basis).unwrap();
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&fresh.values), bits(&reused.values));
        assert_eq!(bits(&fresh.residuals), bits(&reused.residuals));
        for j in 0..fresh.vectors.ncols() {
            let col = |m: &Mat<f64>| m.col(j).iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(col(&fresh.vectors), col(&reused.vectors), "vector {j}");
        }
    }

    #[test]
    fn in_place_leaves_the_vectors_in_the_basis() {
        // The eigenvectors of a diagonal operator are unit vectors: the first 20
        // columns of the basis must be ±e_i for the 20 largest entries, orthonormal,
        // and the bits of `largest_magnitude_in`'s copy.
        let (vals, params) = restarting_diagonal();
        let copied = largest_magnitude(&Diagonal(vals.clone()), 20, None, &params).unwrap();
        let mut basis = Mat::from_fn(400, 70, |_, _| f64::NAN);
        let got =
            largest_magnitude_in_place(&Diagonal(vals), 20, None, &params, &mut basis).unwrap();
        assert_eq!(got.values, copied.values);
        let v = basis.as_ref().subcols(0, 20);
        for j in 0..20 {
            let col = |m: MatRef<'_, f64>| m.col(j).iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(col(v), col(copied.vectors.as_ref()), "vector {j}");
            // θ_j = 1/(1 + j): the vector is ±e_j.
            assert!((got.values[j] - 1.0 / (1.0 + j as f64)).abs() < 1e-12);
            assert!((v[(j, j)].abs() - 1.0).abs() < 1e-10, "vector {j}");
        }
        let gram = v.transpose() * v;
        assert!((&gram - Mat::<f64>::identity(20, 20)).norm_max() < 1e-12);
    }

    #[test]
    fn finds_largest_magnitude_of_two_sided_spectrum() {
        // Eigenvalues ±1/k: the largest magnitudes come in pairs of both signs.
        let n = 600;
        let vals: Vec<f64> = (0..n)
            .map(|i| {
                let k = (i / 2 + 1) as f64;
                if i % 2 == 0 {
                    1.0 / k
                } else {
                    -1.0 / (k + 0.3)
                }
            })
            .collect();
        let got = run(vals.clone(), 30, None, 8, 96).unwrap();
        let mut want: Vec<f64> = vals.clone();
        want.sort_by(|a, b| b.abs().total_cmp(&a.abs()));
        for j in 0..30 {
            assert!((got.values[j] - want[j]).abs() < 1e-12, "{j}");
            assert!(got.residuals[j] <= 1e-12);
        }
        let g = got.vectors.transpose() * &got.vectors;
        assert!((g - Mat::<f64>::identity(30, 30)).norm_max() < 1e-12);
        assert!(got.info.restarts > 0, "the test should exercise restarts");
    }

    /// A diagonal operator whose every application adds fixed pseudo-random noise of
    /// size `eta` per entry: its pairs of small |θ| cannot get below a residual floor.
    struct Noisy {
        vals: Vec<f64>,
        eta: f64,
        calls: std::sync::atomic::AtomicU64,
    }
    impl BlockOperator for Noisy {
        fn dim(&self) -> usize {
            self.vals.len()
        }
        fn apply_block(&self, x: MatRef<'_, f64>, mut out: MatMut<'_, f64>) {
            let c = self
                .calls
                .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            for j in 0..x.ncols() {
                for i in 0..x.nrows() {
                    let z = crate::rng::mix((c << 40) ^ ((j as u64) << 24) ^ i as u64);
                    let e = self.eta * (2.0 * crate::rng::unit(z) - 1.0);
                    out[(i, j)] = self.vals[i] * x[(i, j)] + e;
                }
            }
        }
    }

    /// A floor-limited run stops at its floor (`stagnated`) with pairs as accurate as
    /// the floor allows, when the floor lies within `STALL_SLACK` of the tolerance, and
    /// long before `max_restarts`; a tolerance far below the floor is still an error.
    /// The tolerances step by 3x, so at least one lies within 10x under the floor.
    #[test]
    fn a_noisy_operator_stops_at_its_accuracy_floor() {
        let vals: Vec<f64> = (0..400).map(|i| 1.0 / (1.0 + i as f64)).collect();
        let (nev, max_restarts) = (20, 80);
        let mut stagnated = 0;
        for tol in [1e-13, 3e-13, 1e-12, 3e-12, 1e-11, 3e-11, 1e-10, 3e-10, 1e-9] {
            let op = Noisy {
                vals: vals.clone(),
                eta: 1e-12,
                calls: Default::default(),
            };
            let params = KrylovSchurParams {
                block: 4,
                max_dim: 60,
                tolerance: tol,
                max_restarts,
                seed: 7,
            };
            match largest_magnitude(&op, nev, None, &params) {
                Ok(got) => {
                    for j in 0..nev {
                        let want = vals[j];
                        assert!((got.values[j] - want).abs() <= 1e-8 * want, "{tol} {j}");
                        let limit = if got.info.stagnated { STALL_SLACK } else { 1.0 };
                        assert!(got.residuals[j] <= limit * tol * want * (1.0 + 1e-9));
                    }
                    if got.info.stagnated {
                        stagnated += 1;
                        assert!(got.info.restarts < max_restarts / 2, "{tol}");
                    }
                }
                Err(KrylovSchurError::NoConvergence { .. }) => {
                    assert!(tol < 1e-11, "a loose tolerance {tol} must converge");
                }
                Err(e) => panic!("{e}"),
            }
        }
        assert!(stagnated > 0, "no tolerance reached the floor");
    }

    #[test]
    fn multiple_eigenvalue_found_with_every_copy() {
        // Eigenvalue 1 with multiplicity 6, then 1/2 with multiplicity 5, then a tail.
        let mut vals = repeated(&[(1.0, 6), (0.5, 5)]);
        vals.extend((0..300).map(|i| 0.3 / (1.0 + i as f64)));
        let got = run(vals, 11, None, 8, 64).unwrap();
        for j in 0..6 {
            assert!((got.values[j] - 1.0).abs() < 1e-12);
        }
        for j in 6..11 {
            assert!((got.values[j] - 0.5).abs() < 1e-12);
        }
    }

    #[test]
    fn breakdown_continues_with_random_directions() {
        // Three distinct eigenvalues: a block of 4 spans an invariant Krylov space of
        // dimension 12 at most, so the expansion to 24 must break down and continue
        // with random directions. (Krylov methods cannot promise every copy of a
        // multiple eigenvalue; `partial` checks counts by Sylvester inertia.)
        let vals = repeated(&[(1.0, 10), (0.5, 10), (0.1, 20)]);
        let got = run(vals, 12, None, 4, 24).unwrap();
        assert!(got.info.breakdowns > 0);
        let copies = |v: f64| {
            got.values
                .iter()
                .filter(|&&x| (x - v).abs() < 1e-12)
                .count()
        };
        let (ones, halves) = (copies(1.0), copies(0.5));
        assert_eq!(ones + halves, 12, "{:?}", got.values);
        assert!((4..=10).contains(&ones), "{:?}", got.values);
        assert!(got.residuals.iter().all(|&r| r < 1e-12));
        let g = got.vectors.transpose() * &got.vectors;
        assert!((g - Mat::<f64>::identity(12, 12)).norm_max() < 1e-12);
    }

    #[test]
    fn deflation_excludes_a_subspace() {
        let n = 200;
        let vals: Vec<f64> = (0..n).map(|i| 1.0 / (1.0 + i as f64)).collect();
        let d = Mat::<f64>::from_fn(n, 3, |i, j| if i == j { 1.0 } else { 0.0 });
        let got = run(vals, 5, Some(d.as_ref()), 4, 40).unwrap();
        for j in 0..5 {
            assert!((got.values[j] - 1.0 / (4.0 + j as f64)).abs() < 1e-12);
        }
    }

    #[test]
    fn cholesky_qr2_factors_and_declines_ill_conditioned_blocks() {
        let n = 5000;
        let mut w = Mat::<f64>::zeros(n, 6);
        random_fill(w.as_mut(), 9);
        let raw: Vec<f64> = (0..6).map(|j| col_norm(w.as_ref(), j)).collect();
        let orig = w.clone();
        let mut r = Mat::<f64>::zeros(6, 6);
        // The work block's contents do not matter: NaN is overwritten, never read.
        let mut q = Mat::from_fn(n, 6, |_, _| f64::NAN);
        assert!(cholesky_qr2(w.as_mut(), r.as_mut(), &raw, q.as_mut()));
        let gram = w.transpose() * &w;
        assert!((&gram - Mat::<f64>::identity(6, 6)).norm_max() < 1e-14);
        assert!((&w * &r - &orig).norm_max() < 1e-13);
        for i in 0..6 {
            for j in 0..i {
                assert_eq!(r[(i, j)], 0.0, "R is upper triangular");
            }
        }
        // Column 3 nearly a combination of columns 0 and 1 (relative 1e-6): the
        // block is handed back, untouched, to the Gram–Schmidt path.
        let mut bad = orig.clone();
        for i in 0..n {
            bad[(i, 3)] = orig[(i, 0)] - 2.0 * orig[(i, 1)] + 1e-6 * orig[(i, 3)];
        }
        let raw: Vec<f64> = (0..6).map(|j| col_norm(bad.as_ref(), j)).collect();
        let keep = bad.clone();
        let mut r = Mat::<f64>::zeros(6, 6);
        assert!(!cholesky_qr2(bad.as_mut(), r.as_mut(), &raw, q.as_mut()));
        assert_eq!(bad, keep);
        assert_eq!(r, Mat::<f64>::zeros(6, 6));
    }

    #[test]
    fn too_small_a_basis_is_an_error() {
        assert!(matches!(
            run(vec![1.0; 20], 14, None, 4, 16),
            Err(KrylovSchurError::TooLarge { .. })
        ));
    }
}
