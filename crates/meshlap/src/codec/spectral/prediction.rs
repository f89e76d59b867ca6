//! Inter-patch prediction: each patch is first predicted from the decoded vertices of
//! the patches coded before it, and only the difference is transformed.
//!
//! Patches are coded in index order; patch `p` predicts its coordinates from the
//! decoded vertices of patches `< p` that touch it: `x̂ = G y`, the minimizer of the
//! discrete thin-plate energy `‖L_U x̂ + L_S y‖²` of the umbrella operator over the
//! patch and its decoded ring ([`patch_prediction`]). `G` depends on connectivity
//! only, so the decoder builds the same matrix; the coder then transforms
//! `x − x̂`, and the decoder returns `x̂ + E_m X̃`. The coefficient error, hence the
//! vertex error, is unchanged; the rate falls because a patch no longer pays for its
//! position, orientation and the part of its shape its neighbours already imply
//! (figures in BENCHMARKS.md, Compression).

use super::patches::Arithmetic;
use crate::mesh::graph::VertexGraph;
use faer::Mat;

/// How a format version computes the prediction `x̂ = G y` ([`patch_prediction`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PredictorForm {
    /// Versions 4–6: `G = −M⁻¹ L_UᵀL_S` formed (n_p × |S|, one Cholesky solve per
    /// column of `L_UᵀL_S`), then `x̂ = G y`.
    Matrix,
    /// Version 7: `x̂ = −M⁻¹ (L_Uᵀ (L_S y))`, three right-hand sides per patch
    /// instead of |S|, from the kept dense Cholesky factor of `M` (fixed-order
    /// arithmetic). The same prediction up to rounding, at a fraction of the cost.
    Factored,
    /// Version 8 on: as [`PredictorForm::Factored`], but `M` (whose pattern is the
    /// patch's 2-ring) is renumbered by reverse Cuthill–McKee ([`rcm_order`]) and
    /// factored as a band matrix ([`band_cholesky`]): `O(n b²)` instead of `O(n³)`
    /// flops for a band of half-width b (about 20 at the default patch size
    /// against n ≈ 100). The same prediction up to rounding.
    Banded,
}

impl PredictorForm {
    /// The form files of format `version` were written with.
    pub fn for_version(version: u16) -> Self {
        if version >= 8 {
            PredictorForm::Banded
        } else if version >= 7 {
            PredictorForm::Factored
        } else {
            PredictorForm::Matrix
        }
    }
}

/// Prediction of a patch's coordinates from decoded vertices of earlier patches,
/// `x̂ = G·y` with `y` the positions of `src` (n_src×3).
pub(super) struct Prediction {
    src: Vec<u32>,
    how: How,
}

enum How {
    /// `G` (n_p×n_src), formed.
    Matrix(Mat<f64>),
    /// `G = −M⁻¹ L_UᵀL_S` kept factored: `L` of `M = LLᵀ` (row-major, n_p×n_p) and
    /// the sparse rows of `L_U` and `L_S`.
    Factored { np: usize, l: Vec<f64>, rows: Rows },
    /// As `Factored`, with `M` renumbered (`perm[a]`: new index of patch vertex a)
    /// and its factor `L` kept as a band of half-width `b` ([`band_cholesky`]).
    Banded {
        np: usize,
        b: usize,
        l: Vec<f64>,
        perm: Vec<u32>,
        rows: Rows,
    },
}

/// The sparse rows of `L_U` (unknown columns, patch-local indices) and `L_S` (known
/// columns, indices into the prediction's sources): row `r` of `L_U` is
/// `lu[lu_at[r]..lu_at[r + 1]]`, of `L_S` likewise. Flat, as the many small per-row
/// vectors cost more in the allocator than the rest of the set-up.
struct Rows {
    lu: Vec<(usize, f64)>,
    lu_at: Vec<usize>,
    ls: Vec<(usize, f64)>,
    ls_at: Vec<usize>,
}

impl Rows {
    fn with_capacity(rows: usize) -> Self {
        let mut r = Self {
            lu: Vec::with_capacity(8 * rows),
            lu_at: Vec::with_capacity(rows + 1),
            ls: Vec::with_capacity(4 * rows),
            ls_at: Vec::with_capacity(rows + 1),
        };
        r.lu_at.push(0);
        r.ls_at.push(0);
        r
    }

    /// Closes the row being filled.
    fn end_row(&mut self) {
        self.lu_at.push(self.lu.len());
        self.ls_at.push(self.ls.len());
    }

    /// Number of rows.
    fn len(&self) -> usize {
        self.lu_at.len() - 1
    }

    /// Row `r` of `L_U`.
    fn u(&self, r: usize) -> &[(usize, f64)] {
        &self.lu[self.lu_at[r]..self.lu_at[r + 1]]
    }

    /// Row `r` of `L_S`.
    fn s(&self, r: usize) -> &[(usize, f64)] {
        &self.ls[self.ls_at[r]..self.ls_at[r + 1]]
    }
}

/// `b = −L_Uᵀ (L_S y)` (three columns of n_p): each row's `L_S y` summed in entry
/// order, then scattered into b row by row, entry by entry.
fn right_hand_sides(np: usize, src: &[u32], rec: &[[f64; 3]], rows: &Rows) -> [Vec<f64>; 3] {
    let mut b = [vec![0.0f64; np], vec![0.0f64; np], vec![0.0f64; np]];
    for r in 0..rows.len() {
        let mut t = [0.0f64; 3];
        for &(c, w) in rows.s(r) {
            let y = rec[src[c] as usize];
            for k in 0..3 {
                t[k] += w * y[k];
            }
        }
        for &(a, w) in rows.u(r) {
            for k in 0..3 {
                b[k][a] -= w * t[k];
            }
        }
    }
    b
}

impl Prediction {
    /// `x̂ = G·y` (n_p×3) from the decoded positions `rec` (fixed summation order).
    pub fn predict(&self, rec: &[[f64; 3]]) -> Mat<f64> {
        match &self.how {
            How::Matrix(g) => {
                let mut out = Mat::<f64>::zeros(g.nrows(), 3);
                for (t, &v) in self.src.iter().enumerate() {
                    let y = rec[v as usize];
                    for j in 0..g.nrows() {
                        let w = g[(j, t)];
                        for k in 0..3 {
                            out[(j, k)] += w * y[k];
                        }
                    }
                }
                out
            }
            How::Factored { np, l, rows } => {
                let np = *np;
                let mut b = right_hand_sides(np, &self.src, rec, rows);
                let mut out = Mat::<f64>::zeros(np, 3);
                for (k, bk) in b.iter_mut().enumerate() {
                    solve_in_place(l, np, bk);
                    for (i, &x) in bk.iter().enumerate() {
                        out[(i, k)] = x;
                    }
                }
                out
            }
            How::Banded {
                np,
                b,
                l,
                perm,
                rows,
            } => {
                let np = *np;
                let rhs = right_hand_sides(np, &self.src, rec, rows);
                let mut out = Mat::<f64>::zeros(np, 3);
                let mut x = vec![0.0f64; np];
                for (k, r) in rhs.iter().enumerate() {
                    for (a, &v) in r.iter().enumerate() {
                        x[perm[a] as usize] = v;
                    }
                    band_solve(l, np, *b, &mut x);
                    for a in 0..np {
                        out[(a, k)] = x[perm[a] as usize];
                    }
                }
                out
            }
        }
    }
}

/// Reverse Cuthill–McKee numbering of the graph whose vertex v has the neighbours
/// `nbrs[at[v]..at[v + 1]]` (no self-loops, no repeats): `perm[v]` is v's new index. Per component (taken in order of their
/// smallest unvisited vertex of least degree), the start is a pseudo-peripheral
/// vertex (George and Liu: repeated breadth-first sweeps from a vertex of least
/// degree in the last level, up to five), then a breadth-first numbering with each
/// vertex's unnumbered neighbours by increasing degree (ties: lower index), reversed
/// at the end. Deterministic: integers only.
pub(super) fn rcm_order(at: &[usize], nbrs: &[u32]) -> Vec<u32> {
    let n = at.len() - 1;
    let adj = |v: usize| &nbrs[at[v]..at[v + 1]];
    let deg = |v: usize| at[v + 1] - at[v];
    let mut order: Vec<u32> = Vec::with_capacity(n);
    let mut seen = vec![false; n];
    let mut sweep = Sweep {
        stamp: vec![0; n],
        now: 0,
        cur: Vec::with_capacity(n),
        next: Vec::with_capacity(n),
    };
    let (mut last, mut l2) = (Vec::with_capacity(n), Vec::with_capacity(n));
    while order.len() < n {
        let mut start = (0..n)
            .filter(|&v| !seen[v])
            .min_by_key(|&v| (deg(v), v))
            .expect("an unseen vertex");
        let mut depth = sweep.levels(start, &seen, adj, &mut last);
        for _ in 0..5 {
            let cand = *last
                .iter()
                .min_by_key(|&&v| (deg(v as usize), v))
                .expect("a non-empty level") as usize;
            let d2 = sweep.levels(cand, &seen, adj, &mut l2);
            if d2 <= depth {
                break;
            }
            (start, depth) = (cand, d2);
            std::mem::swap(&mut last, &mut l2);
        }
        number_from(start, at, nbrs, &mut seen, &mut order);
    }
    reversed_permutation(&order)
}

/// [`rcm_order`]'s numbering of `start`'s component: breadth-first from `start`,
/// each vertex's unnumbered neighbours by increasing degree (ties: lower index),
/// appended to `order` and marked `seen`.
fn number_from(start: usize, at: &[usize], nbrs: &[u32], seen: &mut [bool], order: &mut Vec<u32>) {
    let deg = |v: usize| at[v + 1] - at[v];
    let mut head = order.len();
    seen[start] = true;
    order.push(start as u32);
    let mut nb: Vec<usize> = Vec::new();
    while head < order.len() {
        let v = order[head] as usize;
        head += 1;
        nb.clear();
        nb.extend(
            nbrs[at[v]..at[v + 1]]
                .iter()
                .map(|&w| w as usize)
                .filter(|&w| !seen[w]),
        );
        nb.sort_unstable_by_key(|&w| (deg(w), w));
        for &w in &nb {
            seen[w] = true;
            order.push(w as u32);
        }
    }
}

/// `perm[v]`: v's position in `order` reversed (the "reverse" of reverse
/// Cuthill–McKee).
fn reversed_permutation(order: &[u32]) -> Vec<u32> {
    let n = order.len();
    let mut perm = vec![0u32; n];
    for (i, &v) in order.iter().enumerate() {
        perm[v as usize] = (n - 1 - i) as u32;
    }
    perm
}

/// [`rcm_order`] as format 8 first wrote it (a fresh mark array per sweep): the
/// reference its reused buffers are tested against.
#[cfg(test)]
pub(super) fn rcm_order_reference(at: &[usize], nbrs: &[u32]) -> Vec<u32> {
    let n = at.len() - 1;
    let adj = |v: usize| &nbrs[at[v]..at[v + 1]];
    let deg = |v: usize| at[v + 1] - at[v];
    let mut order: Vec<u32> = Vec::with_capacity(n);
    let mut seen = vec![false; n];
    // Breadth-first levels from `s` over unseen vertices (not marking them): the
    // last level and the number of levels.
    let levels = |s: usize, seen: &[bool]| -> (Vec<usize>, usize) {
        let mut mark = vec![false; n];
        mark[s] = true;
        let (mut cur, mut depth) = (vec![s], 1);
        loop {
            let mut next = Vec::new();
            for &v in &cur {
                for &w in adj(v) {
                    let w = w as usize;
                    if !seen[w] && !mark[w] {
                        mark[w] = true;
                        next.push(w);
                    }
                }
            }
            if next.is_empty() {
                return (cur, depth);
            }
            cur = next;
            depth += 1;
        }
    };
    while order.len() < n {
        let mut start = (0..n)
            .filter(|&v| !seen[v])
            .min_by_key(|&v| (deg(v), v))
            .expect("an unseen vertex");
        let (mut last, mut depth) = levels(start, &seen);
        for _ in 0..5 {
            let cand = *last
                .iter()
                .min_by_key(|&&v| (deg(v), v))
                .expect("a non-empty level");
            let (l2, d2) = levels(cand, &seen);
            if d2 <= depth {
                break;
            }
            (start, last, depth) = (cand, l2, d2);
        }
        number_from(start, at, nbrs, &mut seen, &mut order);
    }
    reversed_permutation(&order)
}

/// [`rcm_order`]'s breadth-first sweeps, their buffers kept from sweep to sweep (a
/// vertex is marked by the sweep's stamp, so no array is cleared between sweeps).
struct Sweep {
    stamp: Vec<u32>,
    now: u32,
    cur: Vec<u32>,
    next: Vec<u32>,
}

impl Sweep {
    /// Breadth-first levels from `s` over the vertices not `seen` (not marking
    /// them): the last level into `last` (in the order the sweep reached it), and
    /// the number of levels.
    fn levels<'a>(
        &mut self,
        s: usize,
        seen: &[bool],
        adj: impl Fn(usize) -> &'a [u32],
        last: &mut Vec<u32>,
    ) -> usize {
        self.now += 1;
        let now = self.now;
        self.stamp[s] = now;
        self.cur.clear();
        self.cur.push(s as u32);
        let mut depth = 1;
        loop {
            self.next.clear();
            for &v in &self.cur {
                for &w in adj(v as usize) {
                    let w = w as usize;
                    if !seen[w] && self.stamp[w] != now {
                        self.stamp[w] = now;
                        self.next.push(w as u32);
                    }
                }
            }
            if self.next.is_empty() {
                last.clear();
                last.extend_from_slice(&self.cur);
                return depth;
            }
            std::mem::swap(&mut self.cur, &mut self.next);
            depth += 1;
        }
    }
}

/// Row i of a band matrix of half-width `b`, stored row-major with `b + 1` slots per
/// row: slot `s` holds column `i − b + s` (slots before column 0 are zero).
#[inline(always)]
fn band_at(i: usize, c: usize, b: usize) -> usize {
    i * (b + 1) + (c + b - i)
}

/// The Cholesky factor `L` (`M = LLᵀ`) of the band matrix `m` (n×n, half-width `b`,
/// lower band in [`band_at`]'s layout), in place, in fixed-order arithmetic (the dot
/// products by [`dot4`], correctly rounded `+ − × ÷ √` only: the same bits on every
/// CPU). `None` when a pivot is not positive and finite.
///
/// Entry `(i, c)` is `(m_ic − Σ_{k<c} l_ik l_ck) / l_cc` over the band, `l_ii` the root
/// of the same sum; each reads its own row's earlier entries, so along a row the
/// entries form one chain of dependent dot products and divisions. The rows are taken
/// [`BAND_ROWS`] at a time, and the entries of those rows left of the block are
/// computed column by column, the rows' chains interleaved (independent: each
/// reads rows above the block and its own earlier entries); then the block's
/// triangle in row order. Each entry is computed from the same operands in the same
/// order as row by row (`band_cholesky_by_rows`, the tests' reference), so the bits
/// are the same.
pub(super) fn band_cholesky(m: &mut [f64], n: usize, b: usize) -> Option<()> {
    struct Factor<'a>(&'a mut [f64], usize, usize);
    impl crate::cpu::Kernel for Factor<'_> {
        type Output = Option<()>;
        #[inline(always)]
        fn portable(self) -> Option<()> {
            band_cholesky_in::<false>(self.0, self.1, self.2)
        }
        #[cfg(target_arch = "x86_64")]
        #[inline(always)]
        fn avx2_fma(self) -> Option<()> {
            band_cholesky_in::<true>(self.0, self.1, self.2)
        }
    }
    crate::cpu::dispatch(Factor(m, n, b))
}

/// [`band_cholesky`]; `AVX`: the dot products by `band_simd::dot` (x86-64, only
/// inside an AVX2 function).
#[inline(always)]
fn band_cholesky_in<const AVX: bool>(m: &mut [f64], n: usize, b: usize) -> Option<()> {
    let mut i0 = 0;
    while i0 < n {
        let i1 = (i0 + BAND_ROWS).min(n);
        for c in i0.saturating_sub(b)..i0 {
            for i in i0..i1 {
                let lo = i.saturating_sub(b);
                if c >= lo {
                    band_entry::<AVX>(m, i, c, lo, b);
                }
            }
        }
        for i in i0..i1 {
            let lo = i.saturating_sub(b);
            for c in lo.max(i0)..i {
                band_entry::<AVX>(m, i, c, lo, b);
            }
            let s = m[band_at(i, i, b)] - band_dot::<AVX>(m, i, i, lo, b);
            if !(s > 0.0 && s.is_finite()) {
                return None;
            }
            m[band_at(i, i, b)] = s.sqrt();
        }
        i0 = i1;
    }
    Some(())
}

/// Rows of [`band_cholesky`]'s blocks.
const BAND_ROWS: usize = 4;

/// `Σ_{lo ≤ k < c} l_ik l_ck` over rows i and c of the band (entries lo..c; both
/// inside their bands, lo ≥ c − b), as [`dot4`] sums it.
#[inline(always)]
fn band_dot<const AVX: bool>(m: &[f64], i: usize, c: usize, lo: usize, b: usize) -> f64 {
    let (x, y) = (
        &m[band_at(i, lo, b)..band_at(i, c, b)],
        &m[band_at(c, lo, b)..band_at(c, c, b)],
    );
    #[cfg(target_arch = "x86_64")]
    if AVX {
        // SAFETY: `AVX` is only set in code that runs when `cpu::avx2_fma()` is true.
        return unsafe { band_simd::dot(x, y) };
    }
    dot4(x, y)
}

/// Entry `(i, c)`, `c < i`, of [`band_cholesky`]'s factor.
#[inline(always)]
fn band_entry<const AVX: bool>(m: &mut [f64], i: usize, c: usize, lo: usize, b: usize) {
    let s = m[band_at(i, c, b)] - band_dot::<AVX>(m, i, c, lo, b);
    m[band_at(i, c, b)] = s / m[band_at(c, c, b)];
}

/// [`dot4`] as AVX2 intrinsics, without a branch for the tail.
#[cfg(target_arch = "x86_64")]
mod band_simd {
    use std::arch::x86_64::*;

    /// Lane masks for a tail of 0–3 entries.
    const TAIL: [[i64; 4]; 4] = [[0, 0, 0, 0], [-1, 0, 0, 0], [-1, -1, 0, 0], [-1, -1, -1, 0]];

    /// `Σ x_k y_k` summed as [`super::dot4`] sums it (lane `k mod 4`, then
    /// `(s₀ + s₁) + (s₂ + s₃)`, separate `×` and `+`): the same bits. The tail of
    /// `len mod 4` entries is a masked load, its other lanes zero; their products,
    /// `+0`, change no lane (a lane starts at `+0` and so is never `−0`).
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    pub(super) fn dot(x: &[f64], y: &[f64]) -> f64 {
        let len = x.len().min(y.len());
        let (q, r) = (len / 4, len % 4);
        let (px, py) = (x.as_ptr(), y.as_ptr());
        let mut s = _mm256_setzero_pd();
        for j in 0..q {
            // SAFETY: entries 4j..4j + 4 < len of both slices.
            let (a, b) = unsafe {
                (
                    _mm256_loadu_pd(px.add(4 * j)),
                    _mm256_loadu_pd(py.add(4 * j)),
                )
            };
            s = _mm256_add_pd(s, _mm256_mul_pd(a, b));
        }
        // SAFETY: the mask reads entries 4q..len only (masked lanes are not accessed).
        let (a, b) = unsafe {
            let mask = _mm256_loadu_si256(TAIL[r].as_ptr().cast());
            (
                _mm256_maskload_pd(px.add(4 * q), mask),
                _mm256_maskload_pd(py.add(4 * q), mask),
            )
        };
        s = _mm256_add_pd(s, _mm256_mul_pd(a, b));
        let pair = _mm_hadd_pd(_mm256_castpd256_pd128(s), _mm256_extractf128_pd(s, 1));
        _mm_cvtsd_f64(_mm_hadd_pd(pair, pair))
    }
}

/// [`band_cholesky`] entry by entry in row order: the reference its blocked order is
/// tested against.
#[cfg(test)]
pub(super) fn band_cholesky_by_rows(m: &mut [f64], n: usize, b: usize) -> Option<()> {
    for i in 0..n {
        let lo = i.saturating_sub(b);
        for c in lo..=i {
            // Entries lo..c of rows i and c (both inside their bands: lo ≥ c − b).
            let ri = &m[band_at(i, lo, b)..band_at(i, c, b)];
            let rc = &m[band_at(c, lo, b)..band_at(c, c, b)];
            let s = m[band_at(i, c, b)] - dot4(ri, rc);
            if c < i {
                m[band_at(i, c, b)] = s / m[band_at(c, c, b)];
            } else {
                if !(s > 0.0 && s.is_finite()) {
                    return None;
                }
                m[band_at(i, i, b)] = s.sqrt();
            }
        }
    }
    Some(())
}

/// `x ← (L Lᵀ)⁻¹ x` for [`band_cholesky`]'s factor: forward substitution by rows
/// ([`dot4`]), then back substitution as row updates (each entry receives its updates
/// in the fixed order i = n−1, n−2, …).
pub(super) fn band_solve(l: &[f64], n: usize, b: usize, x: &mut [f64]) {
    for i in 0..n {
        let lo = i.saturating_sub(b);
        x[i] =
            (x[i] - dot4(&l[band_at(i, lo, b)..band_at(i, i, b)], &x[lo..i])) / l[band_at(i, i, b)];
    }
    for i in (0..n).rev() {
        let lo = i.saturating_sub(b);
        let xi = x[i] / l[band_at(i, i, b)];
        x[i] = xi;
        for (xk, &lik) in x[lo..i]
            .iter_mut()
            .zip(&l[band_at(i, lo, b)..band_at(i, i, b)])
        {
            *xk -= lik * xi;
        }
    }
}

/// The predictor of patch `p` (vertices `U` = `verts`, ascending, as a
/// [`super::patches::PatchLayout`] lists them), or `None` when no vertex of an
/// earlier patch touches it (or the system is singular).
///
/// Known vertices are those of patches `< p` (decoded before `p`). With `K₁` the known
/// vertices adjacent to `U`, take the rows `R = U ∪ K₁` of the umbrella operator of
/// the graph restricted to `U ∪ known` (`(Lx)_i = x_i − mean_{w ∈ N'(i)} x_w`), split
/// as `L = [L_U | L_S]` over unknown and known columns (`S`: the known vertices these
/// rows touch). The prediction is the smoothest continuation of the decoded
/// neighbourhood into the patch, the minimizer of the discrete thin-plate energy
/// `‖L_U x_U + L_S y‖²` (affine continuations cost nearly nothing):
/// `x̂_U = G y` with `G = −(L_UᵀL_U)⁻¹ L_UᵀL_S` (n_p × |S|), a dense Cholesky (a band
/// one from format 8, [`PredictorForm::Banded`])
/// (sequential, so encoder and decoder get the same `G` bit for bit; with
/// [`Arithmetic::Fixed`] the same on every CPU too, [`cholesky_solve_fixed`]).
pub(super) fn patch_prediction(
    topo: &VertexGraph,
    owner: &[u32],
    verts: &[u32],
    p: u32,
    arith: Arithmetic,
    form: PredictorForm,
) -> Option<Prediction> {
    let np = verts.len();
    debug_assert!(
        verts.windows(2).all(|p| p[0] < p[1]),
        "patch vertices ascending"
    );
    SLOTS
        .with_borrow_mut(|slot| {
            if slot.len() < owner.len() {
                slot.resize(owner.len(), FREE);
            }
            let built = prediction_rows(topo, owner, verts, p, slot);
            // Every slot this patch used back to FREE, for the thread's next patch.
            for &v in verts.iter().chain(&built.k1).chain(&built.src) {
                slot[v as usize] = FREE;
            }
            built
        })
        .finish(np, arith, form)
}

/// A slot of [`SLOTS`] no patch uses.
const FREE: u32 = u32::MAX;
/// A slot marking a vertex of `K₁` while it is collected.
const IN_K1: u32 = u32::MAX - 1;
/// The flag of a slot holding a source's index.
const SOURCE: u32 = 1 << 31;

thread_local! {
    /// Per vertex of the mesh, what the patch whose predictor this thread is building
    /// made of it: its index in the patch, its index among the sources (`SOURCE |
    /// t`), `IN_K1`, or `FREE`. All `FREE` between patches (each resets the slots
    /// it used): a lookup instead of a binary search or a sort per entry. The array
    /// stays with its thread (4 bytes per vertex of the largest mesh the thread has
    /// coded, 40 MB at 10M vertices) for the next mesh.
    static SLOTS: std::cell::RefCell<Vec<u32>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// The rows of [`patch_prediction`]'s system, before its factorization.
struct PredictionRows {
    /// `K₁`, ascending.
    k1: Vec<u32>,
    /// The sources, in order of first appearance in the rows.
    src: Vec<u32>,
    rows: Rows,
}

/// [`patch_prediction`]'s rows: `L_U` with patch-local columns, `L_S` with source
/// indices, through `slot` (all `FREE` on entry; the caller frees the slots of the
/// patch, `k1` and `src` after).
fn prediction_rows(
    topo: &VertexGraph,
    owner: &[u32],
    verts: &[u32],
    p: u32,
    slot: &mut [u32],
) -> PredictionRows {
    let known = |w: u32| owner[w as usize] < p;
    for (i, &v) in verts.iter().enumerate() {
        slot[v as usize] = i as u32;
    }
    let mut k1: Vec<u32> = Vec::new();
    for &v in verts {
        for &w in topo.neighbors(crate::mesh::VertexId(v)) {
            if known(w) && slot[w as usize] == FREE {
                slot[w as usize] = IN_K1;
                k1.push(w);
            }
        }
    }
    k1.sort_unstable();
    let mut rows = Rows::with_capacity(verts.len() + k1.len());
    let mut src: Vec<u32> = Vec::new();
    if k1.is_empty() {
        return PredictionRows { k1, src, rows };
    }
    let mut nb: Vec<u32> = Vec::new();
    for &i in verts.iter().chain(k1.iter()) {
        nb.clear();
        nb.extend(
            topo.neighbors(crate::mesh::VertexId(i))
                .iter()
                .copied()
                .filter(|&w| known(w) || owner[w as usize] == p),
        );
        let inv = if nb.is_empty() {
            0.0
        } else {
            1.0 / nb.len() as f64
        };
        for (w, wt) in std::iter::once((i, 1.0)).chain(nb.iter().map(|&w| (w, -inv))) {
            if owner[w as usize] == p {
                rows.lu.push((slot[w as usize] as usize, wt));
                continue;
            }
            // A known vertex: a source, numbered at its first appearance.
            let sw = &mut slot[w as usize];
            if *sw == FREE || *sw == IN_K1 {
                *sw = SOURCE | src.len() as u32;
                src.push(w);
            }
            rows.ls.push(((*sw & !SOURCE) as usize, wt));
        }
        rows.end_row();
    }
    PredictionRows { k1, src, rows }
}

impl PredictionRows {
    /// The predictor from the rows (`None` without `K₁` or for a singular system).
    fn finish(self, np: usize, arith: Arithmetic, form: PredictorForm) -> Option<Prediction> {
        let PredictionRows { k1, src, rows } = self;
        if k1.is_empty() {
            return None;
        }
        prediction_from_rows(np, src, rows, arith, form)
    }
}

/// [`patch_prediction`] from its rows and sources.
fn prediction_from_rows(
    np: usize,
    src: Vec<u32>,
    rows: Rows,
    arith: Arithmetic,
    form: PredictorForm,
) -> Option<Prediction> {
    if form == PredictorForm::Banded {
        return banded_prediction(np, src, rows);
    }
    // M = L_UᵀL_U + ridge, G = −L_UᵀL_S.
    let mut m = Mat::<f64>::zeros(np, np);
    let factored = form == PredictorForm::Factored;
    let mut g = Mat::<f64>::zeros(np, if factored { 0 } else { src.len() });
    for r in 0..rows.len() {
        let (ru, rs) = (rows.u(r), rows.s(r));
        for &(a, wa) in ru {
            for &(c, wc) in ru {
                m[(a, c)] += wa * wc;
            }
            if !factored {
                for &(t, wt) in rs {
                    g[(a, t)] -= wa * wt;
                }
            }
        }
    }
    let tr = (0..np).map(|i| m[(i, i)]).sum::<f64>() / np as f64;
    for i in 0..np {
        m[(i, i)] += 1e-10 * tr;
    }
    if factored {
        // Fixed-order arithmetic only (format 7 on).
        let l = cholesky_fixed(&m)?;
        return Some(Prediction {
            src,
            how: How::Factored { np, l, rows },
        });
    }
    match arith {
        Arithmetic::Faer => cholesky_solve_faer(&mut m, &mut g)?,
        Arithmetic::Fixed => cholesky_solve_fixed(&m, &mut g)?,
    }
    if (0..g.ncols()).any(|c| g.col(c).iter().any(|x| !x.is_finite())) {
        return None;
    }
    Some(Prediction {
        src,
        how: How::Matrix(g),
    })
}

/// The [`PredictorForm::Banded`] predictor from the sparse rows of `L_U` and `L_S`:
/// `M = L_UᵀL_U + ridge` renumbered by [`rcm_order`] and factored in its band.
fn banded_prediction(np: usize, src: Vec<u32>, rows: Rows) -> Option<Prediction> {
    // Numbered by the patch's own graph: row a < n_p of L_U is vertex a (its first
    // entry) and its neighbours in the patch.
    let mut at = Vec::with_capacity(np + 1);
    let mut nbrs = Vec::with_capacity(rows.lu_at[np]);
    at.push(0);
    for a in 0..np {
        nbrs.extend(rows.u(a)[1..].iter().map(|&(c, _)| c as u32));
        at.push(nbrs.len());
    }
    let perm = rcm_order(&at, &nbrs);
    // The half-width of M = L_UᵀL_U: the widest spread of the new indices within a
    // row of L_U (every pair in a row is an entry of M).
    let mut b = 0;
    for r in 0..rows.len() {
        let ru = rows.u(r);
        let (mut lo, mut hi) = (u32::MAX, 0u32);
        for &(a, _) in ru {
            lo = lo.min(perm[a]);
            hi = hi.max(perm[a]);
        }
        if !ru.is_empty() {
            b = b.max((hi - lo) as usize);
        }
    }
    // The lower band of M in the new numbering, summed row by row, entry by entry
    // (as the dense form sums it).
    // Each row's new indices and weights are gathered once, then its pairs summed
    // in the same (a, c) order.
    let mut m = vec![0.0f64; np * (b + 1)];
    let mut row: Vec<(usize, f64)> = Vec::new();
    for r in 0..rows.len() {
        row.clear();
        row.extend(rows.u(r).iter().map(|&(a, w)| (perm[a] as usize, w)));
        for &(i, wa) in &row {
            let mi = &mut m[band_at(i, i, b) - b..=band_at(i, i, b)];
            for &(j, wc) in &row {
                if j <= i {
                    mi[j + b - i] += wa * wc;
                }
            }
        }
    }
    // The ridge, relative to the mean diagonal (summed in the original order).
    let tr = (0..np)
        .map(|a| m[band_at(perm[a] as usize, perm[a] as usize, b)])
        .sum::<f64>()
        / np as f64;
    for i in 0..np {
        m[band_at(i, i, b)] += 1e-10 * tr;
    }
    band_cholesky(&mut m, np, b)?;
    Some(Prediction {
        src,
        how: How::Banded {
            np,
            b,
            l: m,
            perm,
            rows,
        },
    })
}

/// `G ← M⁻¹G` by faer's dense Cholesky (format versions 4 and 5); `None` when `M` is
/// not numerically positive definite.
fn cholesky_solve_faer(m: &mut Mat<f64>, g: &mut Mat<f64>) -> Option<()> {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::linalg::cholesky::llt;
    let np = m.nrows();
    let par = faer::Par::Seq;
    let mut mem = MemBuffer::new(
        llt::factor::cholesky_in_place_scratch::<f64>(np, par, Default::default()).or(
            llt::solve::solve_in_place_scratch::<f64>(np, g.ncols(), par),
        ),
    );
    let stack = MemStack::new(&mut mem);
    llt::factor::cholesky_in_place(
        m.as_mut(),
        Default::default(),
        par,
        stack,
        Default::default(),
    )
    .ok()?;
    llt::solve::solve_in_place(m.as_ref(), g.as_mut(), par, stack);
    Some(())
}

/// `Σ a_k b_k` in a fixed order: four interleaved partial sums (lane `k mod 4`), added
/// as `(s₀ + s₁) + (s₂ + s₃)`. Correctly rounded `×` and `+` only, so the same bits on
/// every CPU; the four independent sums let the compiler vectorise without changing
/// a bit.
#[inline]
fn dot4(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut s = [0.0f64; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for l in 0..4 {
            s[l] += x[l] * y[l];
        }
    }
    for l in 0..ra.len() {
        s[l] += ra[l] * rb[l];
    }
    (s[0] + s[1]) + (s[2] + s[3])
}

/// `G ← M⁻¹G` for the symmetric `M` (lower triangle read) by a Cholesky factorization
/// `M = LLᵀ` and two triangular solves per column of `G`, in fixed-order arithmetic
/// (the dot products by [`dot4`], the back substitution as row updates in a fixed
/// order) with correctly rounded `+ − × ÷ √` only (no fused operations), so the result
/// is the same bit for bit on every CPU (format version 6). `None` when a pivot is not
/// positive (`M` not numerically positive definite).
///
/// Speed without changing a bit: the independent dot products — four rows of `L`
/// against one row in the factorization, one row of `L` against four columns' `y` in
/// the forward solve — run interleaved (each exactly as [`dot4`] sums it), so that
/// their dependent addition chains overlap, and the kernel runs the AVX2 build where
/// the CPU has it ([`crate::cpu::dispatch`]; Rust never fuses `×` and `+` on its own,
/// so the wider build computes the same roundings).
pub(super) fn cholesky_solve_fixed(m: &Mat<f64>, g: &mut Mat<f64>) -> Option<()> {
    struct Solve<'a>(&'a Mat<f64>, &'a mut Mat<f64>);
    impl crate::cpu::Kernel for Solve<'_> {
        type Output = Option<()>;
        #[inline(always)]
        fn portable(self) -> Self::Output {
            cholesky_solve_kernel(self.0, self.1)
        }
    }
    crate::cpu::dispatch(Solve(m, g))
}

/// Four dot products `Σ a_r[k]·b_r[k]`, each summed exactly as [`dot4`] sums it
/// (lanes `k mod 4`, then `(s₀ + s₁) + (s₂ + s₃)`), interleaved. All slices have the
/// length of `a[0]`.
#[inline(always)]
fn dot4_x4(a: [&[f64]; 4], b: [&[f64]; 4]) -> [f64; 4] {
    let n = a[0].len();
    let a = a.map(|x| &x[..n]);
    let b = b.map(|x| &x[..n]);
    let mut s = [[0.0f64; 4]; 4];
    let n4 = n / 4 * 4;
    for c in (0..n4).step_by(4) {
        for r in 0..4 {
            for l in 0..4 {
                s[r][l] += a[r][c + l] * b[r][c + l];
            }
        }
    }
    for r in 0..4 {
        for l in 0..n - n4 {
            s[r][l] += a[r][n4 + l] * b[r][n4 + l];
        }
    }
    s.map(|s| (s[0] + s[1]) + (s[2] + s[3]))
}

/// The factorization of [`cholesky_solve_fixed`] (and [`cholesky_fixed`]), inlined
/// into the build `dispatch` picks.
#[inline(always)]
fn cholesky_factor_kernel(m: &Mat<f64>) -> Option<Vec<f64>> {
    let n = m.nrows();
    // L row-major: row i is l[i·n .. i·n + i + 1], so the dot products of the
    // factorization and of the forward solve run over contiguous rows.
    let mut l = vec![0.0f64; n * n];
    for j in 0..n {
        let (rowj, below) = l[j * n..].split_at_mut(n);
        let d = m[(j, j)] - dot4(&rowj[..j], &rowj[..j]);
        if !(d > 0.0 && d.is_finite()) {
            return None;
        }
        let djj = d.sqrt();
        rowj[j] = djj;
        let lj = &rowj[..j];
        // L[i][j] = (M[i][j] − L_i[..j]·L_j[..j]) / L[j][j] for the rows below, four
        // at a time.
        let rows = below.len() / n;
        let r4 = rows / 4 * 4;
        for r in (0..r4).step_by(4) {
            let quad = &mut below[r * n..(r + 4) * n];
            let s = {
                let (q0, q1) = quad.split_at(2 * n);
                dot4_x4([&q0[..j], &q0[n..n + j], &q1[..j], &q1[n..n + j]], [lj; 4])
            };
            for (t, st) in s.iter().enumerate() {
                quad[t * n + j] = (m[(j + 1 + r + t, j)] - st) / djj;
            }
        }
        for (r, li) in below[r4 * n..].chunks_exact_mut(n).enumerate() {
            let r = r4 + r;
            li[j] = (m[(j + 1 + r, j)] - dot4(&li[..j], lj)) / djj;
        }
    }
    Some(l)
}

/// [`cholesky_solve_fixed`]'s arithmetic, inlined into the build `dispatch` picks.
#[inline(always)]
fn cholesky_solve_kernel(m: &Mat<f64>, g: &mut Mat<f64>) -> Option<()> {
    let n = m.nrows();
    let l = cholesky_factor_kernel(m)?;
    let nc = g.ncols();
    let c4 = nc / 4 * 4;
    // Four columns at a time: y[t] is column c + t.
    let mut y = [
        vec![0.0f64; n],
        vec![0.0f64; n],
        vec![0.0f64; n],
        vec![0.0f64; n],
    ];
    for c in (0..c4).step_by(4) {
        // L y = g.
        for i in 0..n {
            let li = &l[i * n..i * n + i];
            let s = dot4_x4([li; 4], [&y[0][..i], &y[1][..i], &y[2][..i], &y[3][..i]]);
            for t in 0..4 {
                y[t][i] = (g[(i, c + t)] - s[t]) / l[i * n + i];
            }
        }
        // Lᵀ x = y, as in the one-column loop below, for each of the four.
        for i in (0..n).rev() {
            let li = &l[i * n..i * n + i];
            for yt in y.iter_mut() {
                let xi = yt[i] / l[i * n + i];
                yt[i] = xi;
                for (yk, &lik) in yt[..i].iter_mut().zip(li) {
                    *yk -= lik * xi;
                }
            }
        }
        for (t, yt) in y.iter().enumerate() {
            for i in 0..n {
                g[(i, c + t)] = yt[i];
            }
        }
    }
    let y = &mut y[0];
    for c in c4..nc {
        solve_column(&l, n, g, c, y);
    }
    Some(())
}

/// `L` of `M = LLᵀ` (row-major, n×n, row i is `l[i·n .. i·n + i + 1]`) in the
/// fixed-order arithmetic of [`cholesky_solve_fixed`] (the same factorization, bit
/// for bit); `None` when a pivot is not positive and finite.
pub(super) fn cholesky_fixed(m: &Mat<f64>) -> Option<Vec<f64>> {
    struct Factor<'a>(&'a Mat<f64>);
    impl crate::cpu::Kernel for Factor<'_> {
        type Output = Option<Vec<f64>>;
        #[inline(always)]
        fn portable(self) -> Self::Output {
            cholesky_factor_kernel(self.0)
        }
    }
    crate::cpu::dispatch(Factor(m))
}

/// `b ← (L Lᵀ)⁻¹ b` for the row-major factor `l` (n×n) of [`cholesky_fixed`], in the
/// fixed order of [`solve_column`].
fn solve_in_place(l: &[f64], n: usize, b: &mut [f64]) {
    for i in 0..n {
        b[i] = (b[i] - dot4(&l[i * n..i * n + i], &b[..i])) / l[i * n + i];
    }
    for i in (0..n).rev() {
        let xi = b[i] / l[i * n + i];
        b[i] = xi;
        let (head, _) = b.split_at_mut(i);
        for (yk, &lik) in head.iter_mut().zip(&l[i * n..i * n + i]) {
            *yk -= lik * xi;
        }
    }
}

/// Column `c` of `g` (n rows) replaced by `(L Lᵀ)⁻¹ g_c`, one row at a time: `l` is
/// L row-major (row i is `l[i·n .. i·n + i + 1]`), `y` an n-value scratch.
#[inline(always)]
fn solve_column(l: &[f64], n: usize, g: &mut Mat<f64>, c: usize, y: &mut [f64]) {
    // L y = g.
    for i in 0..n {
        y[i] = (g[(i, c)] - dot4(&l[i * n..i * n + i], &y[..i])) / l[i * n + i];
    }
    // Lᵀ x = y, x overwriting y from the bottom up: once x_i is known, subtract
    // its multiple of row i of L from the entries above (each entry receives its
    // updates in the fixed order i = n−1, n−2, …).
    for i in (0..n).rev() {
        let xi = y[i] / l[i * n + i];
        y[i] = xi;
        let (head, _) = y.split_at_mut(i);
        for (yk, &lik) in head.iter_mut().zip(&l[i * n..i * n + i]) {
            *yk -= lik * xi;
        }
    }
    for i in 0..n {
        g[(i, c)] = y[i];
    }
}

/// The one-column, one-row-at-a-time form of [`cholesky_solve_fixed`] (the format's
/// definition before the interleaving), kept to check that the fast kernel gives the
/// same bits.
#[cfg(test)]
pub(super) fn cholesky_solve_reference(m: &Mat<f64>, g: &mut Mat<f64>) -> Option<()> {
    let n = m.nrows();
    // L row-major: row i is l[i·n .. i·n + i + 1], so the dot products of the
    // factorization and of the forward solve run over contiguous rows.
    let mut l = vec![0.0f64; n * n];
    for j in 0..n {
        let (rowj, below) = l[j * n..].split_at_mut(n);
        let d = m[(j, j)] - dot4(&rowj[..j], &rowj[..j]);
        if !(d > 0.0 && d.is_finite()) {
            return None;
        }
        let djj = d.sqrt();
        rowj[j] = djj;
        let lj = &rowj[..j];
        for (r, li) in below.chunks_exact_mut(n).enumerate() {
            li[j] = (m[(j + 1 + r, j)] - dot4(&li[..j], lj)) / djj;
        }
    }
    let mut y = vec![0.0f64; n];
    for c in 0..g.ncols() {
        solve_column(&l, n, g, c, &mut y);
    }
    Some(())
}
