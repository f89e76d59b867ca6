//! Products of a tall basis with a thin block, the Gram–Schmidt kernels of
//! [`super::krylov_schur`]:
//!
//! - [`tn`]: `C = Vᵀ W` for `V` n×s and `W` n×p (p small: the block size),
//! - [`sub_nn`]: `W ← W − V C` for `C` s×p,
//! - [`nn_in_place`]: `V ← V C` for a wide `C` (the restarts' and the refinement's
//!   coefficients), by faer's GEMM on blocks of rows;
//! - [`norm2`] (and [`col_norm2`] for a faer column): a vector's 2-norm without faer's
//!   scaled sums (their scaled squares of ordinary entries are subnormal: a microcode
//!   assist each on x86), for the block Gram–Schmidt's column norms, the dense
//!   reduction's reflectors and the partial solver's residuals, polish and inverse
//!   iteration.
//!
//! The first two stream `V` once and are memory-bound: `V` is hundreds of basis
//! vectors (the bunny's 200-pair bands hold up to 500 vectors of 34,817 entries,
//! 140 MB), far beyond the caches, while `W` is a few MB. The kernels split the rows between the
//! rayon threads, walk each thread's rows in chunks of [`CHUNK`] rows (the chunk of
//! `W`, at most 16×2048×8 B = 256 KiB, stays in L2) and, within a chunk, go down the
//! contiguous columns of `V`: every byte of `V` is read once, in runs of 16 KiB that
//! the hardware prefetchers follow. faer's general GEMM packs `V` into panels for
//! these shapes and reaches a fraction of the streaming bandwidth; these loops reach
//! the streaming rate (figures in BENCHMARKS.md, "Partial spectra and partitioning":
//! "Streaming thin-block kernels"). They are written with fixed-width accumulator
//! arrays that LLVM vectorises, compiled for AVX2 + FMA when the CPU has them
//! (dispatched at run time by `crate::cpu::dispatch`; `MESHLAP_PORTABLE=1` forces the
//! portable build), and fall back to faer's `matmul` for strided views.
//!
//! Rounding: each thread sums its rows in its own order and the halves are added, so
//! results depend on the thread count at the level of rounding (as any parallel
//! reduction does). They also depend on the build at that level: the AVX2 + FMA
//! kernels fuse each multiply-add, the portable ones (a CPU without them, or
//! `MESHLAP_PORTABLE=1`) round the product first, because a `mul_add` without
//! hardware FMA is a C-library call an order of magnitude slower. Only the
//! eigensolvers use these kernels; the `.mlz` codec does not.

use faer::linalg::matmul::matmul;
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::{Accum, Mat, MatMut, MatRef, Par};

/// Rows per cache chunk.
const CHUNK: usize = 512;
/// Minimum rows per thread before a product is split between threads.
const MIN_ROWS_PER_THREAD: usize = 4096;

fn threads_for(n: usize) -> usize {
    rayon::current_num_threads()
        .min(n / MIN_ROWS_PER_THREAD)
        .max(1)
}

fn unit_rows(m: MatRef<'_, f64>) -> bool {
    m.row_stride() == 1 || m.nrows() <= 1
}

/// Columns of `W` from which [`tn`] uses faer's (compute-bound) GEMM on each
/// thread's rows instead of the streaming kernels: these read all of `V` once per
/// group of 8 columns of `W`, so for a wide `W` (the refinement's b×b Gram matrices
/// of a band, `W` n×200) they stream `V` 25 times where a packed GEMM reads it about
/// once per cache block.
const WIDE_FROM: usize = 32;

/// `Vᵀ W` (s×p) for tall `V` (n×s) and `W` (n×p). Deterministic for a given thread
/// count (a fixed split of the rows, each part summed on one thread).
pub fn tn(v: MatRef<'_, f64>, w: MatRef<'_, f64>) -> Mat<f64> {
    assert_eq!(v.nrows(), w.nrows(), "tn: row counts differ");
    fn go(v: MatRef<'_, f64>, w: MatRef<'_, f64>, threads: usize) -> Mat<f64> {
        if threads <= 1 {
            let mut c = Mat::<f64>::zeros(v.ncols(), w.ncols());
            if w.ncols() >= WIDE_FROM && v.ncols() >= WIDE_FROM {
                matmul(c.as_mut(), Accum::Replace, v.transpose(), w, 1.0, Par::Seq);
            } else {
                product_seq::<true>(v, w, c.as_mut());
            }
            return c;
        }
        let h = v.nrows() / 2;
        let (v1, v2) = v.split_at_row(h);
        let (w1, w2) = w.split_at_row(h);
        let (mut c1, c2) = rayon::join(
            || go(v1, w1, threads / 2),
            || go(v2, w2, threads - threads / 2),
        );
        c1 += &c2;
        c1
    }
    go(v, w, threads_for(v.nrows()))
}

/// Rows per block of [`nn_in_place`]: a block's product (at most 512×p values, 2 MB
/// for p = 500) stays in cache before it is written back.
const IN_PLACE_ROWS: usize = 512;

/// `V[:, ..p] ← V C` in place for tall `V` (n×s) and `C` (s×p, p ≤ s): the restarts'
/// kept Ritz vectors and the refinement's new basis. A row of the product needs only
/// the same row of `V`, so each block of [`IN_PLACE_ROWS`] rows is computed into a
/// small scratch (faer's sequential GEMM) and written back: no second n×p matrix (at
/// a million rows and p ≈ 300 that was 2.4 GB of fresh pages for the kernel to zero
/// on every restart). The blocks run in parallel; they are fixed, so the bits do not
/// depend on the thread count.
pub fn nn_in_place(v: MatMut<'_, f64>, c: MatRef<'_, f64>) {
    use rayon::prelude::*;
    assert_eq!(v.ncols(), c.nrows(), "nn_in_place: inner dimensions differ");
    assert!(c.ncols() <= c.nrows(), "nn_in_place: C wider than V");
    let p = c.ncols();
    v.par_row_chunks_mut(IN_PLACE_ROWS).for_each(|block| {
        let mut tmp = Mat::<f64>::zeros(block.nrows(), p);
        matmul(tmp.as_mut(), Accum::Replace, block.rb(), c, 1.0, Par::Seq);
        block.subcols_mut(0, p).copy_from(&tmp);
    });
}

/// `f(out, x)` on fixed column halves of `out` and `x` (n×q each), recursively
/// until one of `threads` is left or fewer than `min_cols` columns remain, the
/// halves on `rayon::join`. Each part is computed by one sequential call in a split
/// that depends only on the thread count, so the bits do not change from run to run
/// (faer's parallel products may). Used where each output column depends only on
/// the same input column (`K X`, `A B` by columns of `B`).
pub(crate) fn by_column_halves(
    out: MatMut<'_, f64>,
    x: MatRef<'_, f64>,
    threads: usize,
    min_cols: usize,
    f: &(dyn Fn(MatMut<'_, f64>, MatRef<'_, f64>) + Sync),
) {
    if threads <= 1 || x.ncols() < min_cols.max(2) {
        f(out, x);
        return;
    }
    let h = x.ncols() / 2;
    let (x1, x2) = x.split_at_col(h);
    let (o1, o2) = out.split_at_col_mut(h);
    rayon::join(
        || by_column_halves(o1, x1, threads / 2, min_cols, f),
        || by_column_halves(o2, x2, threads - threads / 2, min_cols, f),
    );
}

/// `W ← W − V C` for tall `V` (n×s), `C` (s×p), `W` (n×p).
pub fn sub_nn(w: MatMut<'_, f64>, v: MatRef<'_, f64>, c: MatRef<'_, f64>) {
    assert_eq!(v.nrows(), w.nrows(), "sub_nn: row counts differ");
    assert_eq!(v.ncols(), c.nrows(), "sub_nn: inner dimensions differ");
    assert_eq!(w.ncols(), c.ncols(), "sub_nn: column counts differ");
    fn go(w: MatMut<'_, f64>, v: MatRef<'_, f64>, c: MatRef<'_, f64>, threads: usize) {
        if threads <= 1 {
            product_seq::<false>(v, c, w);
            return;
        }
        let h = v.nrows() / 2;
        let (w1, w2) = w.split_at_row_mut(h);
        let (v1, v2) = v.split_at_row(h);
        rayon::join(
            || go(w1, v1, c, threads / 2),
            || go(w2, v2, c, threads - threads / 2),
        );
    }
    go(w, v, c, threads_for(v.nrows()))
}

/// Columns of `W` handled by one kernel call when `left` remain: 8, 4, 2 or 1.
fn group_width(left: usize) -> usize {
    match left {
        8.. => 8,
        4..=7 => 4,
        2 | 3 => 2,
        _ => 1,
    }
}

/// One thread's `C += Vᵀ W` (`TN`, `thin` = `W`, `out` = `C`) or `W −= V C`
/// (`!TN`, `thin` = `C`, `out` = `W`), in groups of 8, 4, 2 or 1 columns of `out`.
fn product_seq<const TN: bool>(
    v: MatRef<'_, f64>,
    thin: MatRef<'_, f64>,
    mut out: MatMut<'_, f64>,
) {
    let tall = if TN { thin } else { out.rb() };
    if !unit_rows(v) || !unit_rows(tall) || v.ncols() == 0 || out.ncols() == 0 {
        if TN {
            matmul(out, Accum::Add, v.transpose(), thin, 1.0, Par::Seq);
        } else {
            matmul(out, Accum::Add, v, thin, -1.0, Par::Seq);
        }
        return;
    }
    let mut j0 = 0;
    while j0 < out.ncols() {
        let g = group_width(out.ncols() - j0);
        let thin = thin.subcols(j0, g);
        let out = out.rb_mut().subcols_mut(j0, g);
        match g {
            8 => crate::cpu::dispatch(Group::<8, TN> { v, thin, out }),
            4 => crate::cpu::dispatch(Group::<4, TN> { v, thin, out }),
            2 => crate::cpu::dispatch(Group::<2, TN> { v, thin, out }),
            _ => crate::cpu::dispatch(Group::<1, TN> { v, thin, out }),
        }
        j0 += g;
    }
}

/// One kernel call on `G` columns of `out`, on the build `crate::cpu::dispatch`
/// picks: `C += Vᵀ W` when `TN`, `W −= V C` otherwise (see [`product_seq`]).
struct Group<'a, 'b, const G: usize, const TN: bool> {
    v: MatRef<'a, f64>,
    thin: MatRef<'a, f64>,
    out: MatMut<'b, f64>,
}

impl<const G: usize, const TN: bool> crate::cpu::Kernel for Group<'_, '_, G, TN> {
    type Output = ();
    #[inline(always)]
    fn portable(self) {
        if TN {
            tn_kernel::<G, false>(self.v, self.thin, self.out)
        } else {
            nn_kernel::<G, false>(self.out, self.v, self.thin)
        }
    }
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn avx2_fma(self) {
        let Group { v, thin, out } = self;
        if TN {
            x86::tn_kernel::<G>(Group { v, thin, out })
        } else {
            x86::nn_kernel::<G>(Group { v, thin, out })
        }
    }
}

#[inline(always)]
fn fma<const FMA: bool>(a: f64, b: f64, c: f64) -> f64 {
    if FMA {
        a.mul_add(b, c)
    } else {
        a * b + c
    }
}

/// The row ranges `r0..r1` of [`CHUNK`] rows (the last one shorter) covering `0..n`.
#[inline(always)]
fn chunks(n: usize) -> impl Iterator<Item = (usize, usize)> {
    (0..n)
        .step_by(CHUNK)
        .map(move |r0| (r0, (r0 + CHUNK).min(n)))
}

/// Columns `0..G` of a unit-row-stride view, rows `r0..r1`.
#[inline(always)]
fn col_slices<const G: usize>(m: MatRef<'_, f64>, r0: usize, r1: usize) -> [&[f64]; G] {
    std::array::from_fn(|j| col_slice(m, j, r0, r1))
}

/// Column `j` of a unit-row-stride view, rows `r0..r1`.
#[inline(always)]
fn col_slice<'a>(m: MatRef<'a, f64>, j: usize, r0: usize, r1: usize) -> &'a [f64] {
    let col = m.col(j);
    // SAFETY: rows have unit stride (checked by the callers), so the column's
    // entries r0..r1 are contiguous and inside the matrix.
    unsafe { std::slice::from_raw_parts(col.as_ptr().add(r0), r1 - r0) }
}

/// `C += Vᵀ W` for `G` columns of `W`: per chunk of rows, one pass down each column
/// of `V` with `4·G` accumulators.
#[inline(always)]
fn tn_kernel<const G: usize, const FMA: bool>(
    v: MatRef<'_, f64>,
    w: MatRef<'_, f64>,
    mut c: MatMut<'_, f64>,
) {
    let s = v.ncols();
    for (r0, r1) in chunks(v.nrows()) {
        let len = r1 - r0;
        let quads = len / 4 * 4;
        let ws = col_slices::<G>(w, r0, r1);
        for i in 0..s {
            let vi = col_slice(v, i, r0, r1);
            let mut acc = [[0.0f64; 4]; G];
            let mut k = 0;
            while k < quads {
                let x: [f64; 4] = vi[k..k + 4].try_into().unwrap();
                for j in 0..G {
                    let y: [f64; 4] = ws[j][k..k + 4].try_into().unwrap();
                    for l in 0..4 {
                        acc[j][l] = fma::<FMA>(x[l], y[l], acc[j][l]);
                    }
                }
                k += 4;
            }
            for j in 0..G {
                let mut t = (acc[j][0] + acc[j][1]) + (acc[j][2] + acc[j][3]);
                for kk in quads..len {
                    t = fma::<FMA>(vi[kk], ws[j][kk], t);
                }
                c[(i, j)] += t;
            }
        }
    }
}

/// `W −= V C` for `G` columns of `W`: per chunk of rows, four columns of `V` at a time.
#[inline(always)]
fn nn_kernel<const G: usize, const FMA: bool>(
    mut w: MatMut<'_, f64>,
    v: MatRef<'_, f64>,
    c: MatRef<'_, f64>,
) {
    let s = v.ncols();
    for (r0, r1) in chunks(v.nrows()) {
        let len = r1 - r0;
        let mut i = 0;
        while i < s {
            let t = (s - i).min(4);
            // −C rows i..i+t, zero-padded to four.
            let mut neg = [[0.0f64; G]; 4];
            for (a, row) in neg.iter_mut().enumerate().take(t) {
                for (j, x) in row.iter_mut().enumerate() {
                    *x = -c[(i + a, j)];
                }
            }
            let vs: [&[f64]; 4] = std::array::from_fn(|a| col_slice(v, i + a.min(t - 1), r0, r1));
            for j in 0..G {
                let col = w.rb_mut().col_mut(j);
                // SAFETY: unit row stride (checked by the caller); rows r0..r1 exist.
                let wj = unsafe { std::slice::from_raw_parts_mut(col.as_ptr_mut().add(r0), len) };
                let (n0, n1, n2, n3) = (neg[0][j], neg[1][j], neg[2][j], neg[3][j]);
                let rows = wj.iter_mut().zip(vs[0]).zip(vs[1]).zip(vs[2]).zip(vs[3]);
                for ((((y, &x0), &x1), &x2), &x3) in rows {
                    let mut a = *y;
                    a = fma::<FMA>(n0, x0, a);
                    a = fma::<FMA>(n1, x1, a);
                    a = fma::<FMA>(n2, x2, a);
                    a = fma::<FMA>(n3, x3, a);
                    *y = a;
                }
            }
            i += t;
        }
    }
}

/// The AVX2 + FMA kernels (4 doubles per register), same loops as the portable ones.
#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{chunks, col_slice, col_slices, Group};
    use faer::reborrow::ReborrowMut;
    use std::arch::x86_64::*;

    /// `C += Vᵀ W` for `G` columns of `W`. Per chunk of rows: four columns of `V`
    /// against two of `W` at a time (8 accumulators; each loaded vector of `V` feeds
    /// two FMAs and each of `W` four), so `W`'s chunk is re-read from L1 twice per
    /// four columns of `V` rather than once per column.
    #[inline(always)]
    pub(super) fn tn_kernel<const G: usize>(g: Group<'_, '_, G, true>) {
        let Group {
            v,
            thin: w,
            out: mut c,
        } = g;
        let s = v.ncols();
        for (r0, r1) in chunks(v.nrows()) {
            let len = r1 - r0;
            let quads = len / 4 * 4;
            let ws = col_slices::<G>(w, r0, r1);
            let mut i = 0;
            while i < s {
                let t = (s - i).min(4);
                let vs: [&[f64]; 4] =
                    std::array::from_fn(|a| col_slice(v, i + a.min(t - 1), r0, r1));
                let mut j = 0;
                while j < G {
                    let j1 = (j + 1).min(G - 1);
                    // SAFETY: every slice has `len` entries and `k + 4 <= quads <= len`;
                    // the caller is compiled with AVX2 + FMA.
                    unsafe {
                        let mut acc0 = [_mm256_setzero_pd(); 4];
                        let mut acc1 = [_mm256_setzero_pd(); 4];
                        let mut k = 0;
                        while k < quads {
                            let y0 = _mm256_loadu_pd(ws[j].as_ptr().add(k));
                            let y1 = _mm256_loadu_pd(ws[j1].as_ptr().add(k));
                            for a in 0..4 {
                                let x = _mm256_loadu_pd(vs[a].as_ptr().add(k));
                                acc0[a] = _mm256_fmadd_pd(x, y0, acc0[a]);
                                acc1[a] = _mm256_fmadd_pd(x, y1, acc1[a]);
                            }
                            k += 4;
                        }
                        for a in 0..t {
                            for (jj, acc) in [(j, &acc0), (j1, &acc1)] {
                                if jj == j1 && j1 == j && !std::ptr::eq(acc, &acc0) {
                                    continue;
                                }
                                let mut lanes = [0.0f64; 4];
                                _mm256_storeu_pd(lanes.as_mut_ptr(), acc[a]);
                                let mut sum = (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
                                for kk in quads..len {
                                    sum = vs[a][kk].mul_add(ws[jj][kk], sum);
                                }
                                c[(i + a, jj)] += sum;
                            }
                        }
                    }
                    j += 2;
                }
                i += t;
            }
        }
    }

    #[inline(always)]
    pub(super) fn nn_kernel<const G: usize>(g: Group<'_, '_, G, false>) {
        let Group {
            v,
            thin: c,
            out: mut w,
        } = g;
        let s = v.ncols();
        for (r0, r1) in chunks(v.nrows()) {
            let len = r1 - r0;
            let quads = len / 4 * 4;
            let mut i = 0;
            while i < s {
                let t = (s - i).min(4);
                let vs: [&[f64]; 4] =
                    std::array::from_fn(|a| col_slice(v, i + a.min(t - 1), r0, r1));
                for j in 0..G {
                    let coef: [f64; 4] =
                        std::array::from_fn(|a| if a < t { -c[(i + a, j)] } else { 0.0 });
                    let col = w.rb_mut().col_mut(j);
                    // SAFETY: unit row stride (checked by the caller); rows r0..r1
                    // exist; every slice has `len` entries and `k + 4 <= quads`.
                    unsafe {
                        let y = col.as_ptr_mut().add(r0);
                        let n0 = _mm256_set1_pd(coef[0]);
                        let n1 = _mm256_set1_pd(coef[1]);
                        let n2 = _mm256_set1_pd(coef[2]);
                        let n3 = _mm256_set1_pd(coef[3]);
                        let mut k = 0;
                        while k < quads {
                            let mut a = _mm256_loadu_pd(y.add(k));
                            a = _mm256_fmadd_pd(n0, _mm256_loadu_pd(vs[0].as_ptr().add(k)), a);
                            a = _mm256_fmadd_pd(n1, _mm256_loadu_pd(vs[1].as_ptr().add(k)), a);
                            a = _mm256_fmadd_pd(n2, _mm256_loadu_pd(vs[2].as_ptr().add(k)), a);
                            a = _mm256_fmadd_pd(n3, _mm256_loadu_pd(vs[3].as_ptr().add(k)), a);
                            _mm256_storeu_pd(y.add(k), a);
                            k += 4;
                        }
                        for kk in quads..len {
                            let mut a = *y.add(kk);
                            for (q, x) in coef.iter().zip(vs) {
                                a = q.mul_add(x[kk], a);
                            }
                            *y.add(kk) = a;
                        }
                    }
                }
                i += t;
            }
        }
    }
}

/// `Σ x_i²` in a fixed order (eight running sums, lane k over the entries `i ≡ k mod
/// 8`, added pairwise at the end, then the tail), so the same bits whatever the
/// thread count; the compiler vectorises the eight lanes.
pub(crate) fn sum_of_squares(x: &[f64]) -> f64 {
    let mut lanes = [0.0f64; 8];
    let mut chunks = x.chunks_exact(8);
    for c in &mut chunks {
        for (l, v) in lanes.iter_mut().zip(c) {
            *l += v * v;
        }
    }
    let mut s = ((lanes[0] + lanes[4]) + (lanes[1] + lanes[5]))
        + ((lanes[2] + lanes[6]) + (lanes[3] + lanes[7]));
    for v in chunks.remainder() {
        s += v * v;
    }
    s
}

/// `‖x‖₂`: the plain [`sum_of_squares`] when it is safely inside the normal range,
/// else faer's scaled `norm_l2` (tiny or huge entries, whose squares would underflow
/// or overflow). faer's scaled sums are avoided on the common path because their
/// scaled squares of ordinary entries are subnormal, which costs a microcode assist
/// per operation on x86.
pub(crate) fn norm2(x: &[f64]) -> f64 {
    let s = sum_of_squares(x);
    if (1e-200..1e200).contains(&s) {
        s.sqrt()
    } else {
        faer::ColRef::from_slice(x).norm_l2()
    }
}

/// `‖c‖₂` by [`norm2`] when the column is contiguous, else faer's `norm_l2`.
pub(crate) fn col_norm2(c: faer::ColRef<'_, f64>) -> f64 {
    match c.try_as_col_major() {
        Some(x) => norm2(x.as_slice()),
        None => c.norm_l2(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;

    fn filled(n: usize, m: usize, seed: u64) -> Mat<f64> {
        let mut x = Mat::<f64>::zeros(n, m);
        crate::spectral::krylov_schur::random_fill(x.as_mut(), seed);
        x
    }

    /// The kernel the dispatch picks (AVX2 + FMA, or AVX-512, where the CPU has them)
    /// gives the bits of the portable loops with the same rounding (each multiply-add
    /// fused on those builds, see the module documentation), without faer's
    /// products: lengths around the quads and a chunk, every group width, both
    /// products. Small enough for Miri with AVX2 compiled in (RELIABILITY.md), where
    /// faer's products cannot run.
    #[test]
    fn dispatched_kernels_give_the_portable_bits() {
        use crate::cpu::dispatch;
        fn bits(m: &Mat<f64>) -> Vec<u64> {
            (0..m.ncols())
                .flat_map(|j| (0..m.nrows()).map(move |i| m[(i, j)].to_bits()))
                .collect()
        }
        fn check<const G: usize>(n: usize, s: usize) {
            let fused = crate::cpu::avx2_fma();
            let v = filled(n, s, 21 + n as u64);
            let thin = filled(n, G, 22 + G as u64);
            let small = filled(s, G, 23 + G as u64);
            // C += Vᵀ W from a non-zero C.
            let (mut cp, mut cd) = (small.clone(), small.clone());
            if fused {
                tn_kernel::<G, true>(v.as_ref(), thin.as_ref(), cp.as_mut());
            } else {
                tn_kernel::<G, false>(v.as_ref(), thin.as_ref(), cp.as_mut());
            }
            dispatch(Group::<G, true> {
                v: v.as_ref(),
                thin: thin.as_ref(),
                out: cd.as_mut(),
            });
            assert!(bits(&cp) == bits(&cd), "tn, G = {G}, n = {n}, s = {s}");
            // W −= V C.
            let (mut wp, mut wd) = (thin.clone(), thin.clone());
            if fused {
                nn_kernel::<G, true>(wp.as_mut(), v.as_ref(), small.as_ref());
            } else {
                nn_kernel::<G, false>(wp.as_mut(), v.as_ref(), small.as_ref());
            }
            dispatch(Group::<G, false> {
                v: v.as_ref(),
                thin: small.as_ref(),
                out: wd.as_mut(),
            });
            assert!(bits(&wp) == bits(&wd), "nn, G = {G}, n = {n}, s = {s}");
        }
        for n in [1usize, 3, 4, 5, 37, CHUNK + 7] {
            for s in [1usize, 3] {
                check::<1>(n, s);
                check::<2>(n, s);
                check::<4>(n, s);
                check::<8>(n, s);
            }
        }
    }

    /// The wide path (faer's GEMM per row part) matches the product, on and around
    /// the width where it takes over, and is the same bits on every call.
    #[test]
    fn wide_products_match_and_repeat() {
        for &(n, s, p) in &[
            (9000usize, 40usize, 31usize),
            (9000, 40, 32),
            (20_000, 64, 50),
        ] {
            let v = filled(n, s, 3 + p as u64);
            let w = filled(n, p, 4 + p as u64);
            let c = tn(v.as_ref(), w.as_ref());
            let want = v.transpose() * &w;
            assert!(
                (&c - &want).norm_max() <= 1e-13 * (n as f64).sqrt(),
                "tn n={n} s={s} p={p}"
            );
            assert!(c == tn(v.as_ref(), w.as_ref()), "tn is deterministic");
            // nn_in_place: V (n×s) times an s×q matrix (q ≤ s) into V's first q
            // columns, the rest of V untouched; the same bits on 1 and 2 threads.
            let q = p.min(s);
            let cc = filled(s, q, 5 + p as u64);
            let want = &v * &cc;
            let run = |threads: usize| {
                let mut got = v.clone();
                rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap()
                    .install(|| nn_in_place(got.as_mut(), cc.as_ref()));
                got
            };
            let got = run(2);
            assert!(
                (got.as_ref().subcols(0, q) - &want).norm_max() <= 1e-13 * (s as f64).sqrt(),
                "nn_in_place n={n} s={s} q={q}"
            );
            assert!(
                got.as_ref().subcols(q, s - q) == v.as_ref().subcols(q, s - q),
                "nn_in_place leaves the other columns"
            );
            assert!(got == run(1), "nn_in_place does not depend on the threads");
        }
    }

    #[test]
    fn products_match_faer_for_every_width_and_length() {
        // Lengths around the chunk and quad boundaries, widths through every group
        // size and a remainder, and a row count large enough to split threads.
        for &(n, s) in &[(1usize, 1usize), (7, 3), (2051, 5), (9000, 9), (20_000, 17)] {
            for &p in &[1usize, 2, 3, 7, 8, 13] {
                let v = filled(n, s, 1 + n as u64);
                let w = filled(n, p, 2 + p as u64);
                let c = tn(v.as_ref(), w.as_ref());
                let want = v.transpose() * &w;
                let scale = (n as f64).sqrt();
                assert!(
                    (&c - &want).norm_max() <= 1e-13 * scale,
                    "tn n={n} s={s} p={p}"
                );
                let mut got = w.clone();
                sub_nn(got.as_mut(), v.as_ref(), c.as_ref());
                let want = &w - &v * &c;
                assert!(
                    (&got - &want).norm_max() <= 1e-12 * scale,
                    "sub_nn n={n} s={s} p={p}"
                );
            }
        }
    }

    #[test]
    fn portable_kernels_match_faer() {
        // The kernels used when the CPU lacks AVX2 + FMA (always compiled).
        let (n, s) = (1500usize, 6usize);
        let v = filled(n, s, 11);
        let w8 = filled(n, 8, 12);
        let w1 = filled(n, 1, 13);
        let mut c8 = Mat::<f64>::zeros(s, 8);
        tn_kernel::<8, false>(v.as_ref(), w8.as_ref(), c8.as_mut());
        assert!((&c8 - v.transpose() * &w8).norm_max() <= 1e-12);
        let mut c1 = Mat::<f64>::zeros(s, 1);
        tn_kernel::<1, true>(v.as_ref(), w1.as_ref(), c1.as_mut());
        assert!((&c1 - v.transpose() * &w1).norm_max() <= 1e-12);
        let mut got = w8.clone();
        nn_kernel::<8, false>(got.as_mut(), v.as_ref(), c8.as_ref());
        assert!((&got - (&w8 - &v * &c8)).norm_max() <= 1e-12);
    }

    #[test]
    fn strided_views_fall_back_to_faer() {
        let v = filled(300, 4, 3);
        let w = filled(4, 300, 4);
        // wᵀ is a 300×4 view with non-unit row stride.
        let c = tn(v.as_ref(), w.transpose());
        let want = v.transpose() * w.transpose();
        assert!((&c - &want).norm_max() <= 1e-12);
    }

    #[test]
    fn norm_matches_faer_in_and_out_of_the_plain_range() {
        let mut rng = SplitMix64::new(7);
        for len in [0usize, 1, 7, 8, 9, 33, 500] {
            let x: Vec<f64> = (0..len).map(|_| rng.next_f64() - 0.5).collect();
            // Ordinary entries (plain sum), entries whose squares underflow or
            // overflow (faer's scaled sums), and a mix spanning both.
            for scale in [1.0, 1e-170, 1e-300, 1e170, 1e300] {
                let y: Vec<f64> = x.iter().map(|v| v * scale).collect();
                let want = faer::ColRef::from_slice(&y).norm_l2();
                let got = norm2(&y);
                assert!(
                    (got - want).abs() <= 4.0 * f64::EPSILON * want,
                    "len {len}, scale {scale:e}: {got:e} vs {want:e}"
                );
                let ss = sum_of_squares(&x);
                let exact: f64 = x.iter().map(|v| v * v).sum();
                assert!((ss - exact).abs() <= 1e-15 * exact.max(1.0));
            }
        }
        let mixed = [1e-300, 3.0, 4.0, 1e-300];
        assert_eq!(norm2(&mixed), 5.0);
        assert_eq!(norm2(&[0.0; 12]), 0.0);
    }
}
