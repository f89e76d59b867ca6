//! Eigendecomposition of a dense symmetric matrix, `A = E Λ Eᵀ` (n×n, Λ ascending,
//! E orthonormal), with LAPACK's blocked tridiagonalisation (`dsytrd`/`dlatrd`),
//! meshlap's tridiagonal divide and conquer ([`super::tridiagonal_dc`], LAPACK
//! `dstedc`) and faer's blocked back-transformation: the
//! default dense solver of [`crate::spectral::basis`] (the paper's Fig. 3 and every
//! dense ED transform).
//!
//! **Why by hand.** faer's `self_adjoint_evd` reduces one column at a time: each step
//! reads *and writes* the whole trailing triangle (a fused rank-2 update and product).
//! LAPACK's `dsytrd`, and this module after it, reduces a panel of columns ([`PANEL`]
//! here) with products against the not-yet-updated trailing matrix plus low-rank
//! corrections (`dlatrd`), and updates the trailing matrix once per panel with a
//! rank-2·[`PANEL`] `syr2k` (a matrix product, compute-bound): per column one *read*
//! of the trailing triangle instead of a read and a write. At the sizes of the
//! paper's experiments (n ≈ 500–3000, 2–70 MB) the reduction is bound by memory
//! traffic, so this halves its dominant cost. faer's own divide and conquer
//! (`tridiagonal_self_adjoint_evd`) multiplies full n×n blocks at every merge,
//! deflated columns included, hence [`super::tridiagonal_dc`]; the
//! back-transformation is faer's. The better home for both is a contribution to
//! faer.
//!
//! **Method** (Golub & Van Loan §8.3.1, LAPACK `dsytrd`, `dlatrd`, `dlarfg`,
//! `dlarft`, `dormtr`):
//! 1. Scale by a power of two (exact) so that `max |a_ij|` is in `[1, 2)` (in place
//!    with [`symmetric_evd_owned`], on a copy with [`symmetric_evd`]).
//! 2. For each panel of columns `i..i+b` of the trailing matrix `A₂₂`: for each
//!    column, bring it up to date with the panel's earlier reflectors
//!    (`a ← a − V wᵢᵀ − W vᵢᵀ`), make the Householder reflector `Hᵢ = I − τ v vᵀ`
//!    that zeroes it below the subdiagonal (its norms as plain sums of squares, with
//!    faer's scaled `norm_l2` only when those leave the safe range), and form
//!    `w = τ (A₂₂ v − V Wᵀ v − W Vᵀ v)`, `w ← w − ½ τ (wᵀv) v` (one fused pass over
//!    the lower triangle of `A₂₂`, meshlap's own kernel: the axpy of the lower part
//!    and the dot of the upper part of each column together). Then
//!    `A₂₂ ← A₂₂ − V Wᵀ − W Vᵀ` on the lower triangle (`syr2k`, as faer products
//!    over blocks of columns). With more than one thread, a partner thread spins for
//!    the length of the reduction and takes parts of each column's product and each
//!    panel's update (`Team`): a rayon fork–join per column costs about as much as
//!    the column's work at these sizes. The parts are fixed by `par`, not by who
//!    computes them.
//! 3. The eigenvalues and eigenvectors `Z` of the tridiagonal matrix by LAPACK-style
//!    divide and conquer ([`crate::spectral::tridiagonal_dc`]).
//! 4. `E = Q Z` with `Q = H₀ H₁ ⋯ H_{n−2}` by faer's blocked Householder sequence
//!    (`I − V T⁻¹ Vᵀ` per block, the factor `T` formed here from the reflectors),
//!    applied to `par.degree()` fixed parts of Z's columns in parallel, each part
//!    through the whole sequence on one thread.
//!
//! The result is deterministic for a fixed parallelism (the products' splits depend
//! on `par`, never on the pool). For bit-identical results on any CPU use
//! [`crate::spectral::dense_evd`].
//!
//! **Sign convention.** The solver takes any symmetric matrix; meshlap gives it the
//! positive semi-definite operators `F = D − W` of the paper (libigl and pmp use the
//! negative), so the eigenvalues come out ascending from the smoothest vector.

use faer::linalg::matmul::matmul;
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::prelude::{Reborrow, ReborrowMut};
use faer::{Accum, Mat, MatMut, MatRef, Par};

/// Columns reduced per panel before the trailing `syr2k` update. LAPACK's default
/// `NB` for `dsytrd` is 32; 16 reduced faster at n = 500–2903 on 1 and 2 threads
/// (BENCHMARKS.md, "Spectra", forty-ninth session, on an Intel Xeon; not profiled:
/// a narrower panel makes shorter products with `V` and `W` per column, for a
/// `syr2k` pass over the trailing triangle every 16 columns instead of every 32).
pub const PANEL: usize = 16;

/// Below this trailing size the fused product runs on one thread (under Miri 24, so
/// that a matrix small enough to interpret reaches the team; RELIABILITY.md).
const PAR_MIN: usize = if cfg!(miri) { 24 } else { 224 };

/// Eigenvalues (ascending) and orthonormal eigenvectors (n×n, column j for λ_j) of
/// the symmetric matrix whose **lower triangle** is `a` (n×n; the upper triangle is
/// not read; columns contiguous). `par` is the parallelism of the products. `None` if
/// `a` is not square or not column-major, has a non-finite entry in its lower
/// triangle, or the divide and conquer does not converge.
pub fn symmetric_evd(a: MatRef<'_, f64>, par: Par) -> Option<(Vec<f64>, Mat<f64>)> {
    // On a pool worker: the reduction makes a parallel pass per column.
    crate::par::on_worker(|| {
        let n = a.nrows();
        if a.ncols() != n {
            return None;
        }
        let Some((scale, unscale)) = lower_scaling(a)? else {
            return Some((vec![0.0; n], Mat::identity(n, n)));
        };
        let mut w = Mat::<f64>::zeros(n, n);
        for j in 0..n {
            let src = &a.col(j).try_as_col_major()?.as_slice()[j..];
            let dst = &mut w.col_mut(j).try_as_col_major_mut()?.as_slice_mut()[j..];
            for (d, s) in dst.iter_mut().zip(src) {
                *d = s * scale;
            }
        }
        evd_scaled(w, unscale, par)
    })
}

/// [`symmetric_evd`] of a matrix the caller gives away: the lower triangle of `a` is
/// scaled and reduced in place (no n×n copy) and `a` is dropped. The same bits as
/// [`symmetric_evd`] on the same lower triangle; the upper triangle is not read.
pub fn symmetric_evd_owned(mut a: Mat<f64>, par: Par) -> Option<(Vec<f64>, Mat<f64>)> {
    crate::par::on_worker(|| {
        let n = a.nrows();
        if a.ncols() != n {
            return None;
        }
        let Some((scale, unscale)) = lower_scaling(a.as_ref())? else {
            return Some((vec![0.0; n], Mat::identity(n, n)));
        };
        if scale != 1.0 {
            for j in 0..n {
                let col = &mut a.col_mut(j).try_as_col_major_mut()?.as_slice_mut()[j..];
                col.iter_mut().for_each(|x| *x *= scale);
            }
        }
        evd_scaled(a, unscale, par)
    })
}

/// The exact power-of-two scaling `(scale, 1/scale)` that brings `max |a_ij|` over
/// the lower triangle of the square `a` into `[1, 2)`: `Some(None)` for a zero (or
/// empty) matrix, `None` if a column is not contiguous or an entry of the lower
/// triangle is not finite.
fn lower_scaling(a: MatRef<'_, f64>) -> Option<Option<(f64, f64)>> {
    // Eight lanes without branches, so that the loop vectorises: `x · 0` is NaN
    // exactly when x is not finite, and the lanes' maxima combine exactly.
    let (mut big, mut bad) = ([0.0f64; 8], [0.0f64; 8]);
    for j in 0..a.ncols() {
        let col = &a.col(j).try_as_col_major()?.as_slice()[j..];
        let mut chunks = col.chunks_exact(8);
        for c in &mut chunks {
            for ((m, b), &x) in big.iter_mut().zip(&mut bad).zip(c) {
                let ax = x.abs();
                *m = if ax > *m { ax } else { *m };
                *b += x * 0.0;
            }
        }
        for &x in chunks.remainder() {
            big[0] = big[0].max(x.abs());
            bad[0] += x * 0.0;
        }
    }
    if bad.iter().any(|b| b.is_nan()) {
        return None;
    }
    let amax = big.iter().fold(0.0f64, |m, &x| m.max(x));
    if amax == 0.0 {
        return Some(None);
    }
    Some(Some(super::dense_evd::power_of_two_scaling(amax)))
}

/// Steps 2–4 of the method on `w` (n×n, n ≥ 1, its lower triangle nonzero and
/// already scaled by [`lower_scaling`]); the eigenvalues are multiplied by `unscale`.
fn evd_scaled(mut w: Mat<f64>, unscale: f64, par: Par) -> Option<(Vec<f64>, Mat<f64>)> {
    let n = w.nrows();
    let (diag, sub, tau) = tridiagonalize(w.as_mut(), par);
    let (s, mut z) = super::tridiagonal_dc::tridiagonal_evd(&diag, &sub[..n - 1], par).ok()?;
    back_transform(w.as_ref(), &tau, z.as_mut(), par);
    drop(w);
    let lam: Vec<f64> = (0..n).map(|i| s[i] * unscale).collect();
    if lam.iter().any(|x| !x.is_finite()) {
        return None;
    }
    Some((lam, z))
}

/// Reduces the symmetric matrix whose lower triangle is `a` (n×n, n ≥ 1) to
/// tridiagonal form `Qᵀ A Q = T` (`dsytrd`, lower). Returns T's diagonal (n), its
/// subdiagonal (n entries, the last 0) and the n − 1 reflector coefficients τ; the
/// reflector `v_j` (unit at row j + 1) is left in `a[j+2.., j]`, and `a[j+1, j]`
/// holds T's subdiagonal entry.
fn tridiagonalize(a: MatMut<'_, f64>, par: Par) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let n = a.nrows();
    if par.degree() > 1 && n > PAR_MIN && rayon::current_num_threads() > 1 {
        // A partner for the parallel passes (see [`Team`]): the joined closure runs
        // on another worker if one is free, or after the reduction, when it returns
        // at once.
        let team = Team::new();
        let mut out = None;
        rayon::join(
            || {
                let _end = team.end_on_drop();
                out = Some(reduce(a, par, Some(&team)));
            },
            || team.serve(),
        );
        out.expect("the reduction ran")
    } else {
        reduce(a, par, None)
    }
}

/// The panels of [`tridiagonalize`], with `team` (if any) taking parts of every
/// parallel pass.
fn reduce(mut a: MatMut<'_, f64>, par: Par, team: Option<&Team>) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let n = a.nrows();
    let mut d = vec![0.0f64; n];
    let mut e = vec![0.0f64; n];
    let mut tau = vec![0.0f64; n.saturating_sub(1)];
    let mut wbuf = Mat::<f64>::zeros(n, PANEL);
    let mut ybufs = vec![vec![0.0f64; n]; par.degree().clamp(1, MAX_PARTS)];
    let mut ubuf = Mat::<f64>::zeros(n, 4 * PANEL);
    let mut i0 = 0;
    while i0 + 1 < n {
        let m = n - i0;
        let nb = PANEL.min(m - 1);
        let mut sub = a.rb_mut().submatrix_mut(i0, i0, m, m);
        let mut w = wbuf.as_mut().submatrix_mut(0, 0, m, nb);
        panel(
            sub.rb_mut(),
            w.rb_mut(),
            &mut e[i0..i0 + nb],
            &mut tau[i0..i0 + nb],
            par,
            team,
            &mut ybufs,
        );
        {
            let (_, _, v, a22) = sub.rb_mut().split_at_mut(nb, nb);
            syr2k_lower(
                a22,
                v.rb(),
                w.rb().subrows(nb, m - nb),
                &mut ubuf,
                par,
                team,
            );
        }
        for j in 0..nb {
            sub[(j + 1, j)] = e[i0 + j];
            d[i0 + j] = sub[(j, j)];
        }
        i0 += nb;
    }
    d[n - 1] = a[(n - 1, n - 1)];
    (d, e, tau)
}

/// Most parts of one parallel pass of [`Team`] (bits of its claim mask).
const MAX_PARTS: usize = 16;

/// Two threads sharing the reduction's parallel passes, as OpenBLAS's threads do: the
/// reduction makes one parallel `symv` per column (tens of microseconds at n ≈ 1000),
/// and a rayon fork–join that wakes a sleeping worker costs a good part of that. The
/// partner ([`Team::serve`]) spins for the length of one reduction and takes parts of
/// each pass from the back while the caller ([`Team::run`]) takes them from the front;
/// the caller also takes any part the partner has not claimed, so it never waits for
/// a partner that has not started (or never will: a busy pool), only for parts
/// already being computed. Who computes a part never changes what it computes: the
/// results do not depend on the thread count. Part counts and column ranges stay the
/// same from one column to the next, so each thread keeps reading the same columns
/// from its own cache.
///
/// State: `state` packs the generation (bits 32..64), the pass's part count (16..32)
/// and the claimed parts (0..16); `job` is written by the caller only while no part is
/// claimed or running, and read by the partner only after it has claimed a part of
/// the current generation (which the caller cannot finish without it).
struct Team {
    state: std::sync::atomic::AtomicU64,
    done: std::sync::atomic::AtomicU32,
    job: std::cell::UnsafeCell<*const (dyn Fn(usize) + Sync + 'static)>,
    finished: std::sync::atomic::AtomicBool,
}

// SAFETY: `job` is only accessed under the protocol described on `Team`.
unsafe impl Sync for Team {}

/// Sets [`Team::finished`] when dropped (also when the reduction panics, so that the
/// partner stops spinning and the join returns).
struct EndOnDrop<'a>(&'a Team);

impl Drop for EndOnDrop<'_> {
    fn drop(&mut self) {
        self.0
            .finished
            .store(true, std::sync::atomic::Ordering::Release);
    }
}

impl Team {
    fn new() -> Self {
        fn nothing(_: usize) {}
        Team {
            state: std::sync::atomic::AtomicU64::new(0),
            done: std::sync::atomic::AtomicU32::new(0),
            job: std::cell::UnsafeCell::new(&nothing as &(dyn Fn(usize) + Sync)),
            finished: std::sync::atomic::AtomicBool::new(false),
        }
    }

    fn end_on_drop(&self) -> EndOnDrop<'_> {
        EndOnDrop(self)
    }

    /// Claims part `p` of generation `generation`; false if another thread has, or
    /// the generation is over.
    fn claim(&self, generation: u64, p: usize) -> bool {
        use std::sync::atomic::Ordering::{AcqRel, Acquire};
        let bit = 1u64 << p;
        let mut s = self.state.load(Acquire);
        loop {
            if s >> 32 != generation || s & bit != 0 {
                return false;
            }
            match self
                .state
                .compare_exchange_weak(s, s | bit, AcqRel, Acquire)
            {
                Ok(_) => return true,
                Err(now) => s = now,
            }
        }
    }

    /// Runs `work(0) … work(parts − 1)` (parts ≤ [`MAX_PARTS`]), some of them on the
    /// partner, and returns when all are done.
    fn run(&self, parts: usize, work: &(dyn Fn(usize) + Sync)) {
        use std::sync::atomic::Ordering::{Acquire, Relaxed, Release};
        debug_assert!(parts <= MAX_PARTS);
        let generation = (self.state.load(Relaxed) >> 32) + 1;
        // SAFETY: every part of the previous generation has finished (the last run
        // waited for them) and the partner reads `job` only after claiming a part of
        // the generation published below. The lifetime is erased for the duration
        // of this call only: the partner cannot start a part after `done` reaches
        // `parts`, and this call does not return before that.
        unsafe {
            *self.job.get() = std::mem::transmute::<
                *const (dyn Fn(usize) + Sync + '_),
                *const (dyn Fn(usize) + Sync + 'static),
            >(work);
        }
        self.done.store(0, Relaxed);
        self.state
            .store((generation << 32) | ((parts as u64) << 16), Release);
        for p in 0..parts {
            if self.claim(generation, p) {
                work(p);
                self.done.fetch_add(1, Release);
            }
        }
        while (self.done.load(Acquire) as usize) < parts {
            std::hint::spin_loop();
        }
    }

    /// The partner's loop: claims parts of each new pass from the back until the
    /// reduction ends.
    fn serve(&self) {
        use std::sync::atomic::Ordering::{Acquire, Release};
        let mut seen = 0;
        while !self.finished.load(Acquire) {
            let s = self.state.load(Acquire);
            let generation = s >> 32;
            if generation == seen {
                std::hint::spin_loop();
                continue;
            }
            seen = generation;
            let parts = ((s >> 16) & 0xffff) as usize;
            for p in (0..parts).rev() {
                if self.claim(generation, p) {
                    // SAFETY: see `Team`: the claimed part keeps generation
                    // `generation` — and its `job` — alive until `done` counts it.
                    let work = unsafe { &**self.job.get() };
                    work(p);
                    self.done.fetch_add(1, Release);
                }
            }
        }
    }
}

/// Runs parts `0..parts` of a pass: through `team` if there is one, else in order
/// on this thread (no team: a pool of one thread, or a matrix too small to share).
fn run_parts(team: Option<&Team>, parts: usize, work: &(dyn Fn(usize) + Sync)) {
    match team {
        Some(team) if parts > 1 => team.run(parts, work),
        _ => (0..parts).for_each(work),
    }
}

/// Columns per block of [`syr2k_lower`].
const SYR2K_BLOCK: usize = 48;

/// `A ← A − V Wᵀ − W Vᵀ` on the lower triangle of `a` (r×r; `v`, `w` r×b): one
/// product `[V W] [W V]ᵀ` of inner dimension 2b per block of [`SYR2K_BLOCK`]
/// columns, restricted to the rows at and below the block (the strict upper
/// triangle inside a diagonal block is written too: it is never read). With `par`,
/// the blocks are dealt to `par.degree()` parts that `team` shares out, each product
/// on one thread. faer's triangular product was
/// measured slower here (BENCHMARKS.md, "Spectra"), hence the blocks.
fn syr2k_lower(
    mut a: MatMut<'_, f64>,
    v: MatRef<'_, f64>,
    w: MatRef<'_, f64>,
    ubuf: &mut Mat<f64>,
    par: Par,
    team: Option<&Team>,
) {
    let (r, b) = (v.nrows(), v.ncols());
    if r == 0 || b == 0 {
        return;
    }
    let (mut u, mut z) = ubuf
        .as_mut()
        .submatrix_mut(0, 0, r, 4 * b)
        .split_at_col_mut(2 * b);
    u.rb_mut().subcols_mut(0, b).copy_from(v);
    u.rb_mut().subcols_mut(b, b).copy_from(w);
    z.rb_mut().subcols_mut(0, b).copy_from(w);
    z.rb_mut().subcols_mut(b, b).copy_from(v);
    let (u, z) = (u.rb(), z.rb());
    let mut blocks = Vec::with_capacity(r.div_ceil(SYR2K_BLOCK));
    let mut rest = a.rb_mut();
    let mut c0 = 0;
    while c0 < r {
        let cb = SYR2K_BLOCK.min(r - c0);
        let (block, tail) = rest.split_at_col_mut(cb);
        blocks.push((c0, block.subrows_mut(c0, r - c0)));
        rest = tail;
        c0 += cb;
    }
    let update = |(c0, block): (usize, MatMut<'_, f64>)| {
        let cb = block.ncols();
        matmul(
            block,
            Accum::Add,
            u.subrows(c0, r - c0),
            z.subrows(c0, cb).transpose(),
            -1.0,
            Par::Seq,
        );
    };
    let parts = if r >= PAR_MIN {
        par.degree().clamp(1, MAX_PARTS)
    } else {
        1
    };
    // Part p updates blocks p, p + parts, …: the block columns shorten to the right,
    // so the parts interleave to stay balanced. Each block is independent.
    let blocks: Vec<_> = blocks
        .into_iter()
        .map(|b| std::sync::Mutex::new(Some(b)))
        .collect();
    run_parts(team, parts, &|p| {
        for slot in blocks.iter().skip(p).step_by(parts) {
            let taken = slot.lock().unwrap_or_else(|e| e.into_inner()).take();
            if let Some(block) = taken {
                update(block);
            }
        }
    });
}

/// `dlatrd` (lower) on the trailing matrix `a` (m×m): reduces its first `w.ncols()`
/// columns (< m) and fills `w` (m×nb) so that the update of `a[nb.., nb..]` is
/// `− V Wᵀ − W Vᵀ`. On return `a[j+1, j] = 1` (the reflector's unit, restored by the
/// caller), `e[j]` holds the subdiagonal entry and `tau[j]` the coefficient.
fn panel(
    mut a: MatMut<'_, f64>,
    mut w: MatMut<'_, f64>,
    e: &mut [f64],
    tau: &mut [f64],
    par: Par,
    team: Option<&Team>,
    ybufs: &mut [Vec<f64>],
) {
    let m = a.nrows();
    let nb = w.ncols();
    let mut t = Mat::<f64>::zeros(nb, 1);
    for i in 0..nb {
        // Bring column i up to date with the panel's reflectors 0..i.
        if i > 0 {
            let (vl, mut right) = a.rb_mut().split_at_col_mut(i);
            let (wl, _) = w.rb_mut().split_at_col_mut(i);
            let mut ai = right.rb_mut().col_mut(0).subrows_mut(i, m - i);
            let (vl, wl) = (vl.rb(), wl.rb());
            for (x, y) in [(vl, wl), (wl, vl)] {
                matmul(
                    ai.rb_mut().as_mat_mut(),
                    Accum::Add,
                    x.subrows(i, m - i),
                    y.row(i).transpose().as_mat(),
                    -1.0,
                    Par::Seq,
                );
            }
        }
        // The reflector that zeroes a[i+2.., i] (`dlarfg`, with τ recomputed as
        // 2 / vᵀv as faer does, so that the back-transformation's factor — built from
        // v alone — describes exactly the reflector applied here; a zero tail gets
        // τ = 0, the identity, whose factor entry is 1/τ = ∞ as in faer).
        let t_i;
        {
            let col = a
                .rb_mut()
                .col_mut(i)
                .try_as_col_major_mut()
                .unwrap()
                .as_slice_mut();
            let (head, tail) = col[i + 1..].split_at_mut(1);
            let alpha = head[0];
            let xnorm = super::thin_products::norm2(tail);
            if xnorm == 0.0 {
                t_i = 0.0;
                e[i] = alpha;
            } else {
                let beta = -alpha.hypot(xnorm).copysign(alpha);
                let s = 1.0 / (alpha - beta);
                tail.iter_mut().for_each(|x| *x *= s);
                // |tail entries| ≤ 1 after the division: no overflow, and an
                // underflowing square is negligible next to the 1.
                t_i = 2.0 / (1.0 + super::thin_products::sum_of_squares(tail));
                e[i] = beta;
            }
            head[0] = 1.0;
            tau[i] = t_i;
        }
        // w = τ (A₂₂ v − V Wᵀ v − W Vᵀ v), then w ← w − ½ τ (wᵀ v) v.
        let r = m - i - 1;
        let (left, right) = a.rb_mut().split_at_col_mut(i + 1);
        let (left, right) = (left.rb(), right.rb());
        let v = left.col(i).subrows(i + 1, r);
        let (wl, wr) = w.rb_mut().split_at_col_mut(i);
        let mut wi = wr.col_mut(0).subrows_mut(i + 1, r);
        symv_lower(
            right.submatrix(i + 1, 0, r, r),
            v.try_as_col_major().unwrap().as_slice(),
            wi.rb_mut().try_as_col_major_mut().unwrap().as_slice_mut(),
            par,
            team,
            ybufs,
        );
        if i > 0 {
            let vl = left.submatrix(i + 1, 0, r, i);
            let wl = wl.rb().submatrix(i + 1, 0, r, i);
            let mut ti = t.as_mut().subrows_mut(0, i);
            for (x, y) in [(wl, vl), (vl, wl)] {
                matmul(
                    ti.rb_mut(),
                    Accum::Replace,
                    x.transpose(),
                    v.as_mat(),
                    1.0,
                    Par::Seq,
                );
                matmul(
                    wi.rb_mut().as_mat_mut(),
                    Accum::Add,
                    y,
                    ti.rb(),
                    -1.0,
                    Par::Seq,
                );
            }
        }
        let wi = wi.try_as_col_major_mut().unwrap().as_slice_mut();
        let v = v.try_as_col_major().unwrap().as_slice();
        wi.iter_mut().for_each(|x| *x *= t_i);
        let dot: f64 = wi.iter().zip(v).map(|(x, y)| x * y).sum();
        let alpha = -0.5 * t_i * dot;
        wi.iter_mut().zip(v).for_each(|(x, y)| *x += alpha * y);
    }
}

/// `y = A v` for the symmetric `A` whose lower triangle is `a` (r×r), one pass over
/// the lower triangle: column j adds `a[j.., j] v_j` to `y[j..]` and `a[j+1.., j]ᵀ
/// v[j+1..]` to `y_j`. With `par`, the columns are split into `par.degree()` ranges
/// of equal triangle area, each part summing into its own buffer of `ybufs` (the
/// parts shared out by `team`, then added in order).
fn symv_lower(
    a: MatRef<'_, f64>,
    v: &[f64],
    y: &mut [f64],
    par: Par,
    team: Option<&Team>,
    ybufs: &mut [Vec<f64>],
) {
    let r = a.nrows();
    let threads = if r < PAR_MIN {
        1
    } else {
        par.degree().clamp(1, ybufs.len().min(MAX_PARTS))
    };
    if threads == 1 {
        y.fill(0.0);
        crate::cpu::dispatch(Symv {
            a,
            v,
            y,
            cols: 0..r,
        });
        return;
    }
    let bound = |t: usize| -> usize {
        if t == threads {
            r
        } else {
            ((1.0 - (1.0 - t as f64 / threads as f64).sqrt()) * r as f64) as usize
        }
    };
    let part = |t: usize, buf: &mut [f64]| {
        let y = &mut buf[..r];
        y.fill(0.0);
        crate::cpu::dispatch(Symv {
            a,
            v,
            y,
            cols: bound(t)..bound(t + 1),
        });
    };
    let bufs: Vec<std::sync::Mutex<&mut Vec<f64>>> = ybufs[..threads]
        .iter_mut()
        .map(std::sync::Mutex::new)
        .collect();
    run_parts(team, threads, &|t| {
        part(t, &mut bufs[t].lock().unwrap_or_else(|e| e.into_inner()));
    });
    y.copy_from_slice(&ybufs[0][..r]);
    for buf in &ybufs[1..threads] {
        y.iter_mut().zip(&buf[..r]).for_each(|(a, b)| *a += b);
    }
}

/// The fused product of [`symv_lower`] over the columns `cols` (adds into `y`), four
/// columns per pass so that `y` and `v` are read once per four matrix columns.
struct Symv<'a, 'y> {
    a: MatRef<'a, f64>,
    v: &'a [f64],
    y: &'y mut [f64],
    cols: std::ops::Range<usize>,
}

/// Columns per pass of [`Symv`].
const GROUP: usize = 4;

impl Symv<'_, '_> {
    /// Column `j`'s slice from row `from` on.
    #[inline(always)]
    fn col(&self, j: usize, from: usize) -> &[f64] {
        &self.a.col(j).try_as_col_major().unwrap().as_slice()[from..]
    }

    /// The triangle of a group: rows and columns `j..j+g` of the lower triangle.
    #[inline(always)]
    fn head(&mut self, j: usize, g: usize) {
        for c in j..j + g {
            let vc = self.v[c];
            let mut acc = 0.0;
            for r in c..j + g {
                let x = self.a[(r, c)];
                if r == c {
                    acc += x * vc;
                } else {
                    self.y[r] += x * vc;
                    acc += x * self.v[r];
                }
            }
            self.y[c] += acc;
        }
    }

    /// The rows below a group's triangle, one column at a time: `y[j+g..] += a[j+g..,
    /// c] v_c` and `y_c += a[j+g.., c]ᵀ v[j+g..]` for `c` in `j..j+g`.
    #[inline(always)]
    fn columns(&mut self, j: usize, g: usize) {
        let (a, from) = (self.a, j + g);
        for c in j..j + g {
            let vc = self.v[c];
            let col = &a.col(c).try_as_col_major().unwrap().as_slice()[from..];
            let mut acc = 0.0;
            for (k, x) in col.iter().enumerate() {
                self.y[from + k] += x * vc;
                acc += x * self.v[from + k];
            }
            self.y[c] += acc;
        }
    }
}

impl crate::cpu::Kernel for Symv<'_, '_> {
    type Output = ();

    #[inline(always)]
    fn portable(mut self) {
        let cols = self.cols.clone();
        let mut j = cols.start;
        while j < cols.end {
            let g = GROUP.min(cols.end - j);
            self.head(j, g);
            self.columns(j, g);
            j += g;
        }
    }

    /// Four columns per pass with 256-bit fused multiply-adds (LLVM does not
    /// vectorise the portable loop's mixed axpy and dot).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn avx2_fma(mut self) {
        use std::arch::x86_64::*;
        let r = self.a.nrows();
        let cols = self.cols.clone();
        let mut j = cols.start;
        while j < cols.end {
            let g = GROUP.min(cols.end - j);
            self.head(j, g);
            let from = j + g;
            let len = r - from;
            if g < GROUP {
                self.columns(j, g);
                j += g;
                continue;
            }
            let (c0, c1, c2, c3) = (
                self.col(j, from).as_ptr(),
                self.col(j + 1, from).as_ptr(),
                self.col(j + 2, from).as_ptr(),
                self.col(j + 3, from).as_ptr(),
            );
            let main = len - len % 4;
            let mut lanes = [[0.0f64; 4]; GROUP];
            // SAFETY: AVX2 and FMA are enabled (`crate::cpu::dispatch`); the four
            // column slices, `v[from..]` and `y[from..]` all have `len` entries and
            // every access is at an index below `main ≤ len`.
            unsafe {
                let pv = self.v[from..].as_ptr();
                let py = self.y[from..].as_mut_ptr();
                let b0 = _mm256_set1_pd(self.v[j]);
                let b1 = _mm256_set1_pd(self.v[j + 1]);
                let b2 = _mm256_set1_pd(self.v[j + 2]);
                let b3 = _mm256_set1_pd(self.v[j + 3]);
                let mut s0 = _mm256_setzero_pd();
                let mut s1 = _mm256_setzero_pd();
                let mut s2 = _mm256_setzero_pd();
                let mut s3 = _mm256_setzero_pd();
                let mut k = 0;
                while k < main {
                    let x = _mm256_loadu_pd(pv.add(k));
                    let a0 = _mm256_loadu_pd(c0.add(k));
                    let a1 = _mm256_loadu_pd(c1.add(k));
                    let a2 = _mm256_loadu_pd(c2.add(k));
                    let a3 = _mm256_loadu_pd(c3.add(k));
                    let mut yy = _mm256_loadu_pd(py.add(k));
                    yy = _mm256_fmadd_pd(b0, a0, yy);
                    yy = _mm256_fmadd_pd(b1, a1, yy);
                    yy = _mm256_fmadd_pd(b2, a2, yy);
                    yy = _mm256_fmadd_pd(b3, a3, yy);
                    _mm256_storeu_pd(py.add(k), yy);
                    s0 = _mm256_fmadd_pd(a0, x, s0);
                    s1 = _mm256_fmadd_pd(a1, x, s1);
                    s2 = _mm256_fmadd_pd(a2, x, s2);
                    s3 = _mm256_fmadd_pd(a3, x, s3);
                    k += 4;
                }
                _mm256_storeu_pd(lanes[0].as_mut_ptr(), s0);
                _mm256_storeu_pd(lanes[1].as_mut_ptr(), s1);
                _mm256_storeu_pd(lanes[2].as_mut_ptr(), s2);
                _mm256_storeu_pd(lanes[3].as_mut_ptr(), s3);
            }
            let mut s = lanes.map(|l| (l[0] + l[1]) + (l[2] + l[3]));
            for k in from + main..r {
                let x = self.v[k];
                let mut yk = self.y[k];
                for (c, sc) in s.iter_mut().enumerate() {
                    let ac = self.a[(k, j + c)];
                    yk = ac.mul_add(self.v[j + c], yk);
                    *sc = ac.mul_add(x, *sc);
                }
                self.y[k] = yk;
            }
            for (c, sc) in s.iter().enumerate() {
                self.y[j + c] += sc;
            }
            j += GROUP;
        }
    }
}

/// `z ← Q z` with `Q = H₀ ⋯ H_{n−2}` from [`tridiagonalize`] (`dormtr`): faer's
/// blocked Householder sequence, with each block's factor `T` (`H_j ⋯ H_{j+b−1} =
/// I − V T⁻¹ Vᵀ`, upper triangular: `T_cc = v_cᵀv_c / 2 = 1/τ_c`, `T_rc = v_rᵀv_c`)
/// formed here from the reflectors. An identity reflector (τ = 0) has `T_cc = ∞`,
/// faer's own encoding: its solve with `T` gives that reflector's component 0.
fn back_transform(a: MatRef<'_, f64>, tau: &[f64], z: MatMut<'_, f64>, par: Par) {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::linalg::householder;
    let n = a.nrows();
    if n < 2 {
        return;
    }
    let nr = n - 1;
    let bs = faer::linalg::qr::no_pivoting::factor::recommended_block_size::<f64>(n, n).max(1);
    let mut factor = Mat::<f64>::zeros(bs, nr);
    let essentials = a.submatrix(1, 0, nr, nr);
    for j0 in (0..nr).step_by(bs) {
        let b = bs.min(nr - j0);
        let rows = nr - j0;
        // V (rows×b): unit lower trapezoidal, v_c's tail in a[j0+c+2.., j0+c].
        let mut v = Mat::<f64>::zeros(rows, b);
        for c in 0..b {
            v[(c, c)] = 1.0;
            let src = &essentials
                .col(j0 + c)
                .try_as_col_major()
                .unwrap()
                .as_slice()[j0 + c + 1..];
            let dst = &mut v.col_mut(c).try_as_col_major_mut().unwrap().as_slice_mut()[c + 1..];
            dst.copy_from_slice(src);
        }
        let mut t = factor.as_mut().submatrix_mut(0, j0, b, b);
        triangular::matmul(
            t.rb_mut(),
            BlockStructure::StrictTriangularUpper,
            Accum::Replace,
            v.transpose(),
            BlockStructure::Rectangular,
            v.as_ref(),
            BlockStructure::Rectangular,
            1.0,
            Par::Seq,
        );
        for c in 0..b {
            t[(c, c)] = 1.0 / tau[j0 + c];
        }
    }
    // Each part of z's columns goes through the whole sequence on one thread: one
    // fork–join for the product instead of one per block of reflectors. The parts are
    // fixed by `par`, so the bits do not depend on the pool.
    let apply = |mut zc: MatMut<'_, f64>| {
        let mut mem = MemBuffer::new(
            householder::apply_block_householder_sequence_on_the_left_in_place_scratch::<f64>(
                nr,
                bs,
                zc.ncols(),
            ),
        );
        householder::apply_block_householder_sequence_on_the_left_in_place_with_conj(
            essentials,
            factor.as_ref(),
            faer::Conj::No,
            zc.rb_mut().subrows_mut(1, nr),
            Par::Seq,
            MemStack::new(&mut mem),
        );
    };
    let cols = z.ncols();
    let parts = par
        .degree()
        .clamp(1, MAX_PARTS)
        .min(cols.div_ceil(BACK_MIN_COLS));
    if parts <= 1 {
        apply(z);
        return;
    }
    let mut blocks = Vec::with_capacity(parts);
    let mut rest = z;
    for p in 0..parts {
        let take = cols * (p + 1) / parts - cols * p / parts;
        let (block, tail) = rest.split_at_col_mut(take);
        blocks.push(block);
        rest = tail;
    }
    use rayon::prelude::*;
    blocks.into_par_iter().with_max_len(1).for_each(apply);
}

/// Fewest columns of `z` per part of [`back_transform`] (under Miri 8, as
/// [`PAR_MIN`]).
const BACK_MIN_COLS: usize = if cfg!(miri) { 8 } else { 64 };

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;

    fn random_symmetric(n: usize, seed: u64) -> Mat<f64> {
        let mut rng = SplitMix64::new(seed);
        let mut a = Mat::<f64>::zeros(n, n);
        for j in 0..n {
            for i in j..n {
                let x = rng.next_f64() - 0.5;
                a[(i, j)] = x;
                a[(j, i)] = x;
            }
        }
        a
    }

    /// The reduction's partner thread ([`Team`]) changes who computes a part, never
    /// what: the same bits on pools of 1, 2 and 3 threads, with the pool idle or its
    /// other workers busy with a second decomposition at the same time.
    #[test]
    fn same_bits_on_any_pool_with_or_without_a_partner() {
        // Under Miri (RELIABILITY.md) sizes it can interpret, above its `PAR_MIN`.
        let (na, nb) = if cfg!(miri) { (30, 27) } else { (600, 520) };
        let a = random_symmetric(na, 41);
        let b = random_symmetric(nb, 42);
        let pool = |t: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .unwrap()
        };
        let reference = pool(1).install(|| symmetric_evd(a.as_ref(), Par::rayon(2)).unwrap());
        let reference_b = pool(1).install(|| symmetric_evd(b.as_ref(), Par::rayon(2)).unwrap());
        for threads in [2, 3] {
            let got = pool(threads).install(|| symmetric_evd(a.as_ref(), Par::rayon(2)).unwrap());
            assert_eq!(got.0, reference.0);
            assert!(got.1 == reference.1, "{threads} threads");
            // Two at once: each may or may not find a free worker for its partner.
            let (x, y) = pool(threads).install(|| {
                rayon::join(
                    || symmetric_evd(a.as_ref(), Par::rayon(2)).unwrap(),
                    || symmetric_evd(b.as_ref(), Par::rayon(2)).unwrap(),
                )
            });
            assert!(
                x.1 == reference.1 && y.1 == reference_b.1,
                "{threads} threads, two at once"
            );
        }
        // Called from outside any pool (the global one).
        let got = symmetric_evd(a.as_ref(), Par::rayon(2)).unwrap();
        assert!(got.1 == reference.1);
    }

    fn check(a: &Mat<f64>, par: Par) {
        let n = a.nrows();
        let (lam, e) = symmetric_evd(a.as_ref(), par).unwrap();
        let norm = a.norm_l2().max(f64::MIN_POSITIVE);
        let r = a * &e - &e * faer::ColRef::from_slice(&lam).as_diagonal();
        let res = r.norm_max() / norm;
        let orth = (e.transpose() * &e - Mat::<f64>::identity(n, n)).norm_max();
        assert!(
            res < 1e-13 * (n as f64).sqrt().max(1.0),
            "n={n} residual {res}"
        );
        assert!(
            orth < 1e-13 * (n as f64).sqrt().max(1.0),
            "n={n} orthogonality {orth}"
        );
        assert!(lam.windows(2).all(|w| w[0] <= w[1]));
        // The eigenvalues agree with faer's own solver.
        let faer_lam = a.self_adjoint_eigenvalues(faer::Side::Lower).unwrap();
        for (x, y) in lam.iter().zip(&faer_lam) {
            assert!((x - y).abs() < 1e-12 * norm, "λ {x} vs faer {y}");
        }
    }

    #[test]
    fn random_matrices_across_panel_boundaries() {
        for (k, n) in [
            1usize, 2, 3, 15, 16, 17, 31, 32, 33, 34, 65, 130, 200, 401, 500,
        ]
        .into_iter()
        .enumerate()
        {
            let a = random_symmetric(n, 17 + k as u64);
            check(&a, Par::Seq);
            check(&a, Par::rayon(2));
        }
    }

    #[test]
    fn path_laplacian_closed_form() {
        // Kirchhoff operator of a path of n vertices: λ_k = 2 − 2 cos(πk/n).
        let n = 450;
        let mut a = Mat::<f64>::zeros(n, n);
        for i in 0..n {
            let deg = if i == 0 || i == n - 1 { 1.0 } else { 2.0 };
            a[(i, i)] = deg;
            if i + 1 < n {
                a[(i + 1, i)] = -1.0;
                a[(i, i + 1)] = -1.0;
            }
        }
        check(&a, Par::rayon(2));
        let (lam, _) = symmetric_evd(a.as_ref(), Par::rayon(2)).unwrap();
        for (k, l) in lam.iter().enumerate() {
            let exact = 2.0 - 2.0 * (std::f64::consts::PI * k as f64 / n as f64).cos();
            assert!((l - exact).abs() < 1e-12, "λ_{k} = {l}, exact {exact}");
        }
    }

    #[test]
    fn already_tridiagonal_diagonal_and_zero() {
        // Zero tails (τ = 0) everywhere: a diagonal matrix.
        let n = 100;
        let a = Mat::<f64>::from_fn(n, n, |i, j| if i == j { (i % 7) as f64 - 3.0 } else { 0.0 });
        check(&a, Par::rayon(2));
        let z = Mat::<f64>::zeros(n, n);
        let (lam, e) = symmetric_evd(z.as_ref(), Par::Seq).unwrap();
        assert!(lam.iter().all(|&x| x == 0.0));
        assert_eq!(e, Mat::<f64>::identity(n, n));
        // Scaled far from 1: the power-of-two scaling keeps the relative accuracy.
        let a = random_symmetric(80, 5) * faer::Scale(1e-200);
        check(&a, Par::Seq);
    }

    #[test]
    fn fused_product_both_builds_match_the_dense_product() {
        // Column ranges that start and end inside and outside groups of four; the
        // size is above `PAR_MIN` so that the threaded split runs too, and above 202
        // so that the cuts below ascend (under Miri, whose `PAR_MIN` is smaller).
        let r = (PAR_MIN + 19).max(203);
        let a = random_symmetric(r, 11);
        let mut rng = SplitMix64::new(12);
        let v: Vec<f64> = (0..r).map(|_| rng.next_f64() - 0.5).collect();
        let exact = &a * faer::ColRef::from_slice(&v);
        let mut lower = a.clone();
        for j in 0..r {
            for i in 0..j {
                lower[(i, j)] = f64::NAN; // the upper triangle is never read
            }
        }
        for cuts in [
            vec![0, r],
            vec![0, 1, 6, 99, 100, r - 102, r],
            vec![0, 4, 8, r],
        ] {
            assert!(cuts.windows(2).all(|c| c[0] <= c[1]), "{cuts:?}");
            let (mut yp, mut yd) = (vec![0.0; r], vec![0.0; r]);
            for c in cuts.windows(2) {
                let k = Symv {
                    a: lower.as_ref(),
                    v: &v,
                    y: &mut yp,
                    cols: c[0]..c[1],
                };
                crate::cpu::Kernel::portable(k);
                let k = Symv {
                    a: lower.as_ref(),
                    v: &v,
                    y: &mut yd,
                    cols: c[0]..c[1],
                };
                crate::cpu::dispatch(k);
            }
            for i in 0..r {
                assert!((yp[i] - exact[i]).abs() < 1e-12, "portable row {i}");
                assert!((yd[i] - exact[i]).abs() < 1e-12, "dispatched row {i}");
            }
        }
        let mut ybufs = vec![vec![0.0; r]; 2];
        let mut y = vec![0.0; r];
        symv_lower(lower.as_ref(), &v, &mut y, Par::rayon(2), None, &mut ybufs);
        for i in 0..r {
            assert!((y[i] - exact[i]).abs() < 1e-12);
        }
    }

    /// The in-place entry point gives the same bits as the copying one and never reads
    /// the upper triangle (NaN there), on pools of one and two threads.
    #[test]
    fn owned_matches_borrowed_bit_for_bit() {
        for (n, seed) in [(1usize, 1u64), (2, 2), (33, 3), (130, 4), (450, 5)] {
            let a = random_symmetric(n, seed) * faer::Scale(3.7);
            let mut owned = a.clone();
            for j in 0..n {
                for i in 0..j {
                    owned[(i, j)] = f64::NAN;
                }
            }
            for threads in [1, 2] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let want = pool.install(|| symmetric_evd(a.as_ref(), Par::rayon(2)).unwrap());
                let got =
                    pool.install(|| symmetric_evd_owned(owned.clone(), Par::rayon(2)).unwrap());
                assert_eq!(got.0, want.0, "n={n}");
                assert!(got.1 == want.1, "n={n}");
            }
        }
        let (lam, e) = symmetric_evd_owned(Mat::zeros(5, 5), Par::Seq).unwrap();
        assert_eq!(lam, vec![0.0; 5]);
        assert_eq!(e, Mat::<f64>::identity(5, 5));
        let mut bad = random_symmetric(20, 9);
        bad[(12, 3)] = f64::INFINITY;
        assert!(symmetric_evd_owned(bad, Par::Seq).is_none());
        assert!(symmetric_evd_owned(Mat::zeros(3, 4), Par::Seq).is_none());
    }

    #[test]
    fn rejects_non_finite_and_non_square() {
        let mut a = random_symmetric(40, 3);
        a[(30, 2)] = f64::NAN;
        assert!(symmetric_evd(a.as_ref(), Par::Seq).is_none());
        // In a column's last, partial group of eight (column 1's lower part is rows
        // 1..40, 39 entries: rows 33..40 are the remainder after four groups), in a
        // full group (row 5), and infinite rather than NaN.
        for (i, x) in [(39, f64::NAN), (38, f64::NEG_INFINITY), (5, f64::INFINITY)] {
            let mut a = random_symmetric(40, 3);
            a[(i, 1)] = x;
            assert!(symmetric_evd(a.as_ref(), Par::Seq).is_none(), "{x} at {i}");
        }
        let b = Mat::<f64>::zeros(3, 4);
        assert!(symmetric_evd(b.as_ref(), Par::Seq).is_none());
    }
}
