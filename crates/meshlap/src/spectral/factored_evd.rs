//! The eigendecomposition of a small dense symmetric matrix kept in factored form,
//! `A = Q Z Λ Zᵀ Qᵀ` (n×n; Q the product of the Householder reflectors of the
//! tridiagonalisation `A = Q T Qᵀ`, Z the eigenvectors of T, Λ ascending), for the
//! codec's patch bases from `.mlz` format version 8 on.
//!
//! A spectral coder needs a basis only to transform three coordinate columns:
//! `X = Eᵀx` and `x̃ = E X̃` with `E = Q Z`. Forming E (the back-transformation,
//! `2n²k` flops for k vectors) costs as much as the tridiagonalisation, while
//! `Eᵀx = Zᵀ(Qᵀx)` and `E X̃ = Q(Z X̃)` cost `O(n²)` for the three columns. This type
//! keeps Q as its reflectors (n(n−1)/2 values) and the first `count` columns of Z,
//! and applies them.
//!
//! The decomposition is [`crate::spectral::dense_evd`]'s (the same scaling,
//! tridiagonalisation, QL eigenvalues and inverse iteration, bit for bit) without its
//! back-transformation. The products sum in a fixed order with correctly rounded
//! operations only (reductions in `dense_evd`'s four-lane order) and run on the build
//! `crate::cpu::dispatch` picks, so the results are the same bits on every CPU and
//! thread count. The vectors are not canonicalised (no sign or cluster rule): they are
//! whatever the fixed arithmetic gives, which is all a coder whose decoder runs the
//! same arithmetic needs. Sign convention: the operators decomposed here are PSD,
//! `F = D − W`.

use super::dense_evd::{
    axpy, ql_eigenvalues, ql_eigenvalues_many, scale_lower, tridiagonal_vectors_by_column,
    tridiagonalize, Scaling,
};

/// `A = Q Z Λ Zᵀ Qᵀ` with Q kept as reflectors and the first `count` eigenvectors of
/// the tridiagonal T (see the module documentation). Built by [`FactoredEvd::new`].
#[derive(Clone, Debug)]
pub struct FactoredEvd {
    n: usize,
    /// All n eigenvalues, ascending.
    eigenvalues: Vec<f64>,
    /// Eigenvectors of T kept.
    count: usize,
    /// Z's first `count` columns, column-major (`z[j·n + i]`).
    z: Vec<f64>,
    /// Reflector k (k = 0..n−1) acts on rows k+1..n: `H_k = I − τ_k v_k v_kᵀ`,
    /// `v_k` (n−k−1 entries, first 1) packed from `offset(k)`.
    refl: Vec<f64>,
    tau: Vec<f64>,
}

/// Start of reflector k in the packed reflectors of an n×n matrix.
fn offset(n: usize, k: usize) -> usize {
    k * (n - 1) - k * k.saturating_sub(1) / 2
}

impl FactoredEvd {
    /// Decomposes the symmetric matrix whose **lower triangle** is `a` (n×n; the upper
    /// triangle is not read), keeping the eigenvectors of the `count` smallest
    /// eigenvalues (clamped to n). `None` if `a` is not square, an entry or a result
    /// is not finite, or the QL iteration does not converge.
    pub fn new(a: faer::MatRef<'_, f64>, count: usize) -> Option<Self> {
        Self::batch(&[(a, count)]).pop().flatten()
    }

    /// [`FactoredEvd::batch`] of matrices given by value: each `(n, a, count)` with
    /// `a` the n×n column-major entries (`a[i + j·n]`), of which only the lower
    /// triangle is read (the buffer becomes the working matrix: no copy). The same
    /// bits as [`FactoredEvd::new`]; `None` for an entry whose length is not n².
    pub fn batch_dense(items: Vec<(usize, Vec<f64>, usize)>) -> Vec<Option<Self>> {
        let mut out: Vec<Option<Self>> = Vec::with_capacity(items.len());
        let mut work = Vec::new();
        for (idx, (n, a, count)) in items.into_iter().enumerate() {
            out.push(None);
            if a.len() != n * n {
                continue;
            }
            match prepare_owned(n, a, count) {
                Prepared::Done(f) => out[idx] = f,
                Prepared::Scaled(s) => work.push((idx, s)),
            }
        }
        let results = decompose_batch(&mut work);
        for ((idx, s), r) in work.into_iter().zip(results) {
            out[idx] = r.and_then(|r| s.finish(r));
        }
        out
    }

    /// [`FactoredEvd::new`] of each `(a, count)`, with the same bits: the QL
    /// iterations of four matrices at a time run interleaved (their chains of
    /// dependent divisions overlap), which makes a batch faster than as many calls.
    pub fn batch(items: &[(faer::MatRef<'_, f64>, usize)]) -> Vec<Option<Self>> {
        let mut out: Vec<Option<Self>> = Vec::with_capacity(items.len());
        let mut work = Vec::new();
        for (idx, &(a, count)) in items.iter().enumerate() {
            match prepare(a, count) {
                Prepared::Done(f) => out.push(f),
                Prepared::Scaled(s) => {
                    out.push(None);
                    work.push((idx, s));
                }
            }
        }
        let results = decompose_batch(&mut work);
        for ((idx, s), r) in work.into_iter().zip(results) {
            out[idx] = r.and_then(|r| s.finish(r));
        }
        out
    }
    /// Order n of the matrix.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Eigenvectors kept (the `count` given to [`FactoredEvd::new`], clamped to n).
    pub fn len(&self) -> usize {
        self.count
    }

    /// True when no eigenvector is kept.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// All n eigenvalues, ascending.
    pub fn eigenvalues(&self) -> &[f64] {
        &self.eigenvalues
    }

    /// Bytes this decomposition holds (reflectors, Z and the eigenvalues).
    pub fn bytes(&self) -> usize {
        (self.refl.len() + self.tau.len() + self.z.len() + self.eigenvalues.len())
            * std::mem::size_of::<f64>()
    }

    /// The first `m` coefficients `X = E_mᵀ x` (E = QZ orthonormal) of the three
    /// columns `x` (each of length n): `X[c][j] = z_jᵀ(Qᵀ x_c)`. Panics if `m` exceeds
    /// [`FactoredEvd::len`] or a column's length is not n.
    pub fn analyze(&self, x: [&[f64]; 3], m: usize) -> [Vec<f64>; 3] {
        assert!(m <= self.count && x.iter().all(|c| c.len() == self.n));
        struct Analyze<'a>(&'a FactoredEvd, [&'a [f64]; 3], usize);
        impl crate::cpu::Kernel for Analyze<'_> {
            type Output = [Vec<f64>; 3];
            #[inline(always)]
            fn portable(self) -> Self::Output {
                self.0.analyze_in::<false>(self.1, self.2)
            }
            #[cfg(target_arch = "x86_64")]
            #[inline(always)]
            fn avx2_fma(self) -> Self::Output {
                self.0.analyze_in::<true>(self.1, self.2)
            }
        }
        crate::cpu::dispatch(Analyze(self, x, m))
    }

    /// The three columns `x̃ = E_k X̃` (each of length n) from the coefficients `c`
    /// (three columns of k ≤ [`FactoredEvd::len`] entries): `Q(Σ_j z_j X̃_j)`, the sum in
    /// index order from zero. Panics if the columns' lengths differ or exceed the
    /// vectors kept.
    pub fn synthesize(&self, c: [&[f64]; 3]) -> [Vec<f64>; 3] {
        let k = c[0].len();
        assert!(k <= self.count && c.iter().all(|c| c.len() == k));
        struct Synthesize<'a>(&'a FactoredEvd, [&'a [f64]; 3]);
        impl crate::cpu::Kernel for Synthesize<'_> {
            type Output = [Vec<f64>; 3];
            #[inline(always)]
            fn portable(self) -> Self::Output {
                self.0.synthesize_in::<false>(self.1)
            }
            #[cfg(target_arch = "x86_64")]
            #[inline(always)]
            fn avx2_fma(self) -> Self::Output {
                self.0.synthesize_in::<true>(self.1)
            }
        }
        crate::cpu::dispatch(Synthesize(self, c))
    }

    /// [`FactoredEvd::analyze`]; `AVX`: the dot products by `dot3_simd::dot3`
    /// (x86-64, only inside an AVX2 function). Plain loops, no closures: a closure is
    /// compiled without the caller's target features, and its `mul_add` would be a
    /// library call.
    #[inline(always)]
    fn analyze_in<const AVX: bool>(&self, x: [&[f64]; 3], m: usize) -> [Vec<f64>; 3] {
        let n = self.n;
        let mut y = [x[0].to_vec(), x[1].to_vec(), x[2].to_vec()];
        // Qᵀ = H_{n−2} ⋯ H_0: reflector 0 first.
        for k in 0..n.saturating_sub(1) {
            self.reflect3::<AVX>(k, &mut y);
        }
        let mut out = [vec![0.0; m], vec![0.0; m], vec![0.0; m]];
        let y = [&y[0][..], &y[1][..], &y[2][..]];
        let mut j = 0;
        // Two vectors at a time: their six sums are independent chains.
        while j + 1 < m {
            let (za, zb) = self.z[j * n..(j + 2) * n].split_at(n);
            let [sa, sb] = dot3_pair::<AVX>([za, zb], y);
            for c in 0..3 {
                out[c][j] = sa[c];
                out[c][j + 1] = sb[c];
            }
            j += 2;
        }
        if j < m {
            let s = dot3::<AVX>(&self.z[j * n..(j + 1) * n], y);
            for c in 0..3 {
                out[c][j] = s[c];
            }
        }
        out
    }

    /// [`FactoredEvd::synthesize`]; `AVX` as in [`FactoredEvd::analyze_in`].
    #[inline(always)]
    fn synthesize_in<const AVX: bool>(&self, c: [&[f64]; 3]) -> [Vec<f64>; 3] {
        let n = self.n;
        let mut y = [vec![0.0f64; n], vec![0.0f64; n], vec![0.0f64; n]];
        for j in 0..c[0].len() {
            let zj = &self.z[j * n..(j + 1) * n];
            for k in 0..3 {
                axpy(&mut y[k], c[k][j], zj);
            }
        }
        // Q = H_0 ⋯ H_{n−2}: the last reflector first.
        for k in (0..n.saturating_sub(1)).rev() {
            self.reflect3::<AVX>(k, &mut y);
        }
        y
    }

    /// `y_c ← H_k y_c` for the three columns (rows k+1..): `y_c −= τ_k v_k (v_kᵀ y_c)`.
    #[inline(always)]
    fn reflect3<const AVX: bool>(&self, k: usize, y: &mut [Vec<f64>; 3]) {
        let t = self.tau[k];
        if t == 0.0 {
            return;
        }
        let n = self.n;
        let v = &self.refl[offset(n, k)..offset(n, k + 1)];
        let s = dot3::<AVX>(v, [&y[0][k + 1..], &y[1][k + 1..], &y[2][k + 1..]]);
        for c in 0..3 {
            axpy(&mut y[c][k + 1..], -(t * s[c]), v);
        }
    }
}

/// Three dot products `v·y_c` in one pass, each summed in [`dot`]'s order (the same
/// bits as three calls; three independent chains); the columns may be longer than
/// `v`. `AVX`: by `dot3_simd::dot3`, one register per column (x86-64, only inside an
/// AVX2 function).
#[inline(always)]
fn dot3<const AVX: bool>(v: &[f64], y: [&[f64]; 3]) -> [f64; 3] {
    let n = v.len();
    let (y0, y1, y2) = (&y[0][..n], &y[1][..n], &y[2][..n]);
    #[cfg(target_arch = "x86_64")]
    if AVX {
        // SAFETY: `AVX` is only set in code that runs when `cpu::avx2_fma()` is true.
        return unsafe { dot3_simd::dot3(v, y0, y1, y2) };
    }
    let n4 = n / 4 * 4;
    let mut acc = [[0.0f64; 4]; 3];
    for (((v4, a), b), c) in v[..n4]
        .chunks_exact(4)
        .zip(y0[..n4].chunks_exact(4))
        .zip(y1[..n4].chunks_exact(4))
        .zip(y2[..n4].chunks_exact(4))
    {
        for l in 0..4 {
            acc[0][l] = v4[l].mul_add(a[l], acc[0][l]);
            acc[1][l] = v4[l].mul_add(b[l], acc[1][l]);
            acc[2][l] = v4[l].mul_add(c[l], acc[2][l]);
        }
    }
    dot3_finish(v, [y0, y1, y2], acc)
}

/// [`dot3`] of two vectors of the same length against the same three columns (the
/// same bits as two calls). `AVX`: by `dot3_simd::dot3_pair`, whose six sums are
/// independent chains (one [`dot3`] waits on the latency of its three).
#[inline(always)]
fn dot3_pair<const AVX: bool>(v: [&[f64]; 2], y: [&[f64]; 3]) -> [[f64; 3]; 2] {
    let n = v[0].len();
    assert_eq!(v[1].len(), n);
    let (y0, y1, y2) = (&y[0][..n], &y[1][..n], &y[2][..n]);
    #[cfg(target_arch = "x86_64")]
    if AVX {
        // SAFETY: `AVX` is only set in code that runs when `cpu::avx2_fma()` is true.
        return unsafe { dot3_simd::dot3_pair(v, y0, y1, y2) };
    }
    [dot3::<false>(v[0], y), dot3::<false>(v[1], y)]
}

/// [`dot3`]'s end: each column's four partial sums as `(s₀ + s₁) + (s₂ + s₃)`, then
/// its tail of `len mod 4` entries in order.
#[inline(always)]
fn dot3_finish(v: &[f64], y: [&[f64]; 3], acc: [[f64; 4]; 3]) -> [f64; 3] {
    let n = v.len();
    let n4 = n / 4 * 4;
    let mut s = [0.0f64; 3];
    for c in 0..3 {
        s[c] = (acc[c][0] + acc[c][1]) + (acc[c][2] + acc[c][3]);
        for i in n4..n {
            s[c] = v[i].mul_add(y[c][i], s[c]);
        }
    }
    s
}

/// [`dot3`] in AVX2 + FMA. LLVM vectorises the portable loop poorly (its twelve
/// partial sums go to 128-bit registers, shuffles and spills), so here each column's
/// four partial sums are one register: the same fused multiply-adds per lane in the
/// same order, then the same end ([`dot3_finish`]): the same bits.
#[cfg(target_arch = "x86_64")]
mod dot3_simd {
    use std::arch::x86_64::*;

    /// `v·y0`, `v·y1`, `v·y2` (all of `v`'s length).
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    pub(super) fn dot3(v: &[f64], y0: &[f64], y1: &[f64], y2: &[f64]) -> [f64; 3] {
        let n = v.len();
        assert!(y0.len() == n && y1.len() == n && y2.len() == n);
        let (pv, p0, p1, p2) = (v.as_ptr(), y0.as_ptr(), y1.as_ptr(), y2.as_ptr());
        let (mut a0, mut a1, mut a2) = (
            _mm256_setzero_pd(),
            _mm256_setzero_pd(),
            _mm256_setzero_pd(),
        );
        for j in 0..n / 4 {
            // SAFETY: entries 4j..4j + 4 < n of all four slices.
            unsafe {
                let x = _mm256_loadu_pd(pv.add(4 * j));
                a0 = _mm256_fmadd_pd(x, _mm256_loadu_pd(p0.add(4 * j)), a0);
                a1 = _mm256_fmadd_pd(x, _mm256_loadu_pd(p1.add(4 * j)), a1);
                a2 = _mm256_fmadd_pd(x, _mm256_loadu_pd(p2.add(4 * j)), a2);
            }
        }
        let mut acc = [[0.0f64; 4]; 3];
        // SAFETY: each row of `acc` is four writable f64.
        unsafe {
            _mm256_storeu_pd(acc[0].as_mut_ptr(), a0);
            _mm256_storeu_pd(acc[1].as_mut_ptr(), a1);
            _mm256_storeu_pd(acc[2].as_mut_ptr(), a2);
        }
        super::dot3_finish(v, [y0, y1, y2], acc)
    }

    /// [`dot3`] of `v[0]` and of `v[1]` (each of the columns' length), interleaved.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    pub(super) fn dot3_pair(v: [&[f64]; 2], y0: &[f64], y1: &[f64], y2: &[f64]) -> [[f64; 3]; 2] {
        let n = y0.len();
        assert!(v[0].len() == n && v[1].len() == n && y1.len() == n && y2.len() == n);
        let (pa, pb) = (v[0].as_ptr(), v[1].as_ptr());
        let (p0, p1, p2) = (y0.as_ptr(), y1.as_ptr(), y2.as_ptr());
        let mut a = [_mm256_setzero_pd(); 3];
        let mut b = [_mm256_setzero_pd(); 3];
        for j in 0..n / 4 {
            // SAFETY: entries 4j..4j + 4 < n of all five slices.
            unsafe {
                let (xa, xb) = (
                    _mm256_loadu_pd(pa.add(4 * j)),
                    _mm256_loadu_pd(pb.add(4 * j)),
                );
                let ys = [
                    _mm256_loadu_pd(p0.add(4 * j)),
                    _mm256_loadu_pd(p1.add(4 * j)),
                    _mm256_loadu_pd(p2.add(4 * j)),
                ];
                for c in 0..3 {
                    a[c] = _mm256_fmadd_pd(xa, ys[c], a[c]);
                    b[c] = _mm256_fmadd_pd(xb, ys[c], b[c]);
                }
            }
        }
        let (mut acc_a, mut acc_b) = ([[0.0f64; 4]; 3], [[0.0f64; 4]; 3]);
        for c in 0..3 {
            // SAFETY: each row of `acc_a` and `acc_b` is four writable f64.
            unsafe {
                _mm256_storeu_pd(acc_a[c].as_mut_ptr(), a[c]);
                _mm256_storeu_pd(acc_b[c].as_mut_ptr(), b[c]);
            }
        }
        [
            super::dot3_finish(v[0], [y0, y1, y2], acc_a),
            super::dot3_finish(v[1], [y0, y1, y2], acc_b),
        ]
    }
}

/// A matrix ready for the decomposition, or its result when trivial.
enum Prepared {
    Done(Option<FactoredEvd>),
    Scaled(Scaled),
}

/// The full symmetric matrix scaled by a power of two (`w`, column-major n×n).
struct Scaled {
    n: usize,
    count: usize,
    w: Vec<f64>,
    unscale: f64,
}

/// What [`decompose_batch`] gives per matrix: all eigenvalues (scaled), the first
/// `count` eigenvectors of T (column-major) and τ; the reflectors are left in `w`.
type Decomposed = (Vec<f64>, Vec<f64>, Vec<f64>);

/// Checks `a` (square, finite lower triangle) and scales a copy of it, or decomposes
/// it directly when it is empty or zero.
fn prepare(a: faer::MatRef<'_, f64>, count: usize) -> Prepared {
    let n = a.nrows();
    if a.ncols() != n {
        return Prepared::Done(None);
    }
    let mut w = vec![0.0f64; n * n];
    for j in 0..n {
        for i in j..n {
            w[i + j * n] = a[(i, j)];
        }
    }
    prepare_owned(n, w, count)
}

/// [`prepare`] of the column-major n×n `a` (`a.len() = n²`), scaled in place; its
/// upper triangle is overwritten with the lower one.
fn prepare_owned(n: usize, mut a: Vec<f64>, count: usize) -> Prepared {
    let count = count.min(n);
    if n == 0 {
        return Prepared::Done(Some(FactoredEvd {
            n,
            eigenvalues: Vec::new(),
            count: 0,
            z: Vec::new(),
            refl: Vec::new(),
            tau: Vec::new(),
        }));
    }
    match scale_lower(&mut a, n) {
        Scaling::NonFinite => Prepared::Done(None),
        // Zero matrix: T = 0, Q = I, Z = I.
        Scaling::Zero => Prepared::Done(Some(FactoredEvd {
            n,
            eigenvalues: vec![0.0; n],
            count,
            z: (0..count * n)
                .map(|x| f64::from(u8::from(x % n == x / n)))
                .collect(),
            refl: vec![0.0; offset(n, n - 1)],
            tau: vec![0.0; n - 1],
        })),
        Scaling::By(unscale) => Prepared::Scaled(Scaled {
            n,
            count,
            w: a,
            unscale,
        }),
    }
}

impl Scaled {
    /// The decomposition from [`decompose_batch`]'s result: eigenvalues unscaled (by a
    /// power of two: exactly), reflectors packed.
    fn finish(self, (mut lam, z, tau): Decomposed) -> Option<FactoredEvd> {
        let Scaled {
            n,
            count,
            w,
            unscale,
        } = self;
        lam.iter_mut().for_each(|x| *x *= unscale);
        if lam.iter().chain(&z).any(|x| !x.is_finite()) {
            return None;
        }
        let mut refl = Vec::with_capacity(offset(n, n - 1));
        for k in 0..n - 1 {
            refl.extend_from_slice(&w[k * n + k + 1..(k + 1) * n]);
        }
        Some(FactoredEvd {
            n,
            eigenvalues: lam,
            count,
            z,
            refl,
            tau,
        })
    }
}

/// The matrices' QL iterations run this many at a time (two vectors of four lanes
/// with AVX2); a remainder of four or more runs four at a time.
const QL_BATCH: usize = 8;

/// Tridiagonalisation (in `w`, whose columns keep the reflectors), all eigenvalues
/// (QL, [`QL_BATCH`] matrices interleaved) and the first `count` eigenvectors of T
/// of each scaled matrix, on the build `crate::cpu::dispatch` picks; `None` for a
/// matrix whose QL iteration does not converge.
fn decompose_batch(work: &mut [(usize, Scaled)]) -> Vec<Option<Decomposed>> {
    struct Batch<'a>(&'a mut [(usize, Scaled)]);
    impl crate::cpu::Kernel for Batch<'_> {
        type Output = Vec<Option<Decomposed>>;
        #[inline(always)]
        fn portable(self) -> Self::Output {
            // Plain loops (no closures around the arithmetic: a closure is compiled
            // without the caller's target features).
            let mut tri: Vec<(Vec<f64>, Vec<f64>, Vec<f64>)> = Vec::with_capacity(self.0.len());
            for (_, s) in self.0.iter_mut() {
                let n = s.n;
                let mut d = vec![0.0; n];
                let mut e = vec![0.0; n];
                let mut tau = vec![0.0; n];
                tridiagonalize(&mut s.w, n, &mut d, &mut e, &mut tau);
                e.truncate(n - 1);
                tau.truncate(n - 1);
                tri.push((d, e, tau));
            }
            let mut lam: Vec<Option<Vec<f64>>> = Vec::with_capacity(tri.len());
            let mut groups = tri.chunks_exact(QL_BATCH);
            for g in &mut groups {
                let r = ql_eigenvalues_many::<QL_BATCH>(std::array::from_fn(|k| {
                    (g[k].0.as_slice(), g[k].1.as_slice())
                }));
                lam.extend(r);
            }
            let mut fours = groups.remainder().chunks_exact(4);
            for g in &mut fours {
                let r = ql_eigenvalues_many::<4>(std::array::from_fn(|k| {
                    (g[k].0.as_slice(), g[k].1.as_slice())
                }));
                lam.extend(r);
            }
            for t in fours.remainder() {
                lam.push(ql_eigenvalues(&t.0, &t.1));
            }
            let mut out = Vec::with_capacity(tri.len());
            for (((_, s), (d, e, tau)), lam) in self.0.iter().zip(tri).zip(lam) {
                out.push(match lam {
                    Some(lam) => {
                        let z = tridiagonal_vectors_by_column(&d, &e, &lam, s.count);
                        Some((lam, z, tau))
                    }
                    None => None,
                });
            }
            out
        }
    }
    crate::cpu::dispatch(Batch(work))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectral::dense_evd::power_of_two_scaling;
    use crate::spectral::test_util::random_symmetric;
    use faer::Mat;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// `dot3` gives each column the bits of `dense_evd::dot` (the order the format
    /// fixes), at every length and remainder, with columns longer than `v`.
    #[test]
    fn dot3_gives_the_dot_bits() {
        let mut rng = ChaCha8Rng::seed_from_u64(31);
        for n in 0..40 {
            let v: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
            let y: Vec<Vec<f64>> = (0..3)
                .map(|c| (0..n + c).map(|_| rng.gen_range(-1e3..1e3)).collect())
                .collect();
            let d: Vec<f64> = (0..3)
                .map(|c| crate::spectral::dense_evd::dot(&v, &y[c][..n]))
                .collect();
            let s = dot3::<false>(&v, [&y[0], &y[1], &y[2]]);
            for c in 0..3 {
                assert_eq!(s[c].to_bits(), d[c].to_bits(), "n = {n}, column {c}");
            }
            #[cfg(target_arch = "x86_64")]
            if crate::cpu::cpu_has_avx2_fma() {
                let (y0, y1, y2) = (&y[0][..n], &y[1][..n], &y[2][..n]);
                // SAFETY: the CPU has AVX2 and FMA.
                let s = unsafe { dot3_simd::dot3(&v, y0, y1, y2) };
                let w: Vec<f64> = v.iter().map(|x| x * 0.75 - 0.125).collect();
                // SAFETY: as above.
                let [pa, pb] = unsafe { dot3_simd::dot3_pair([&v, &w], y0, y1, y2) };
                let sw = dot3::<false>(&w, [y0, y1, y2]);
                for c in 0..3 {
                    assert_eq!(s[c].to_bits(), d[c].to_bits(), "AVX2, n = {n}, column {c}");
                    assert_eq!(pa[c].to_bits(), d[c].to_bits(), "pair, n = {n}, column {c}");
                    assert_eq!(
                        pb[c].to_bits(),
                        sw[c].to_bits(),
                        "pair, n = {n}, column {c}"
                    );
                }
            }
        }
    }

    /// The explicit basis E = QZ, column by column, through `synthesize` of unit
    /// coefficients.
    fn explicit(f: &FactoredEvd) -> Mat<f64> {
        let (n, k) = (f.n(), f.len());
        let mut e = Mat::<f64>::zeros(n, k);
        for j in 0..k {
            let mut c = vec![0.0; j + 1];
            c[j] = 1.0;
            let y = f.synthesize([&c, &c, &c]);
            for i in 0..n {
                e[(i, j)] = y[0][i];
            }
        }
        e
    }

    #[test]
    fn the_factored_basis_is_the_dense_solvers_up_to_sign() {
        // Same eigenvalues bit for bit; each vector ±dense_evd's (which canonicalises
        // nothing either: the difference is the back-transformation's rounding).
        for (n, seed) in [(1, 1), (2, 2), (7, 4), (40, 5), (123, 6)] {
            let a = random_symmetric(n, seed);
            let (lam, e) = crate::spectral::dense_evd::symmetric_evd(a.as_ref()).unwrap();
            let f = FactoredEvd::new(a.as_ref(), n).unwrap();
            assert_eq!(f.eigenvalues(), &lam[..]);
            let ef = explicit(&f);
            for j in 0..n {
                let dotp: f64 = (0..n).map(|i| ef[(i, j)] * e[(i, j)]).sum();
                assert!((dotp.abs() - 1.0).abs() < 1e-12, "n={n} j={j}: {dotp}");
            }
        }
    }

    #[test]
    fn analyze_inverts_synthesize_and_is_an_eigenbasis() {
        let n = 60;
        let a = random_symmetric(n, 9);
        let f = FactoredEvd::new(a.as_ref(), n).unwrap();
        let e = explicit(&f);
        // Residuals and orthogonality of E = QZ.
        let ae = &a * &e;
        let g = e.transpose() * &e;
        for j in 0..n {
            for i in 0..n {
                let r = ae[(i, j)] - f.eigenvalues()[j] * e[(i, j)];
                assert!(r.abs() < 1e-12, "residual {r:e}");
                let o = g[(i, j)] - f64::from(u8::from(i == j));
                assert!(o.abs() < 1e-12, "orthogonality {o:e}");
            }
        }
        let mut rng = ChaCha8Rng::seed_from_u64(10);
        let x: [Vec<f64>; 3] =
            std::array::from_fn(|_| (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect());
        let c = f.analyze([&x[0], &x[1], &x[2]], n);
        let back = f.synthesize([&c[0], &c[1], &c[2]]);
        for k in 0..3 {
            // X = Eᵀx against the explicit product.
            for j in 0..n {
                let r: f64 = (0..n).map(|i| e[(i, j)] * x[k][i]).sum();
                assert!((r - c[k][j]).abs() < 1e-12);
            }
            for i in 0..n {
                assert!((back[k][i] - x[k][i]).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn fewer_vectors_give_the_same_first_coefficients_bit_for_bit() {
        let n = 50;
        let a = random_symmetric(n, 12);
        let all = FactoredEvd::new(a.as_ref(), n).unwrap();
        let some = FactoredEvd::new(a.as_ref(), 17).unwrap();
        assert_eq!(some.len(), 17);
        let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        let ca = all.analyze([&x, &x, &x], 17);
        let cs = some.analyze([&x, &x, &x], 17);
        assert_eq!(ca, cs);
        let ya = all.synthesize([&ca[0], &ca[1], &ca[2]]);
        let ys = some.synthesize([&cs[0], &cs[1], &cs[2]]);
        assert_eq!(ya, ys);
    }

    #[test]
    fn a_batch_gives_each_ones_bits() {
        // Eleven matrices (two groups of four and a remainder), among them a zero one,
        // a 1×1 and one with a NaN.
        let mut mats: Vec<Mat<f64>> = (0..8)
            .map(|k| random_symmetric(20 + 7 * k, 30 + k as u64))
            .collect();
        mats.push(Mat::<f64>::zeros(5, 5));
        mats.push(random_symmetric(1, 3));
        let mut bad = random_symmetric(6, 4);
        bad[(3, 1)] = f64::NAN;
        mats.push(bad);
        let items: Vec<_> = mats
            .iter()
            .enumerate()
            .map(|(k, a)| (a.as_ref(), 3 + 5 * k))
            .collect();
        let batch = FactoredEvd::batch(&items);
        assert_eq!(batch.len(), items.len());
        for (&(a, count), b) in items.iter().zip(&batch) {
            let single = FactoredEvd::new(a, count);
            match (single, b) {
                (None, None) => {}
                (Some(s), Some(b)) => {
                    assert_eq!(s.eigenvalues, b.eigenvalues);
                    assert_eq!(s.z, b.z);
                    assert_eq!(s.refl, b.refl);
                    assert_eq!(s.tau, b.tau);
                }
                _ => panic!("batch and single disagree on failure"),
            }
        }
        assert!(batch[10].is_none());
    }

    #[test]
    fn matrices_by_value_give_the_same_bits() {
        let mats: Vec<Mat<f64>> = vec![
            random_symmetric(33, 41),
            Mat::<f64>::zeros(3, 3),
            random_symmetric(1, 42),
            random_symmetric(70, 43),
        ];
        let by_ref: Vec<_> = mats.iter().map(|a| (a.as_ref(), 20)).collect();
        let by_value: Vec<_> = mats
            .iter()
            .map(|a| {
                let n = a.nrows();
                // Garbage in the upper triangle: only the lower one is read.
                let v = (0..n * n)
                    .map(|x| {
                        if x % n >= x / n {
                            a[(x % n, x / n)]
                        } else {
                            7.0
                        }
                    })
                    .collect();
                (n, v, 20)
            })
            .chain(std::iter::once((4, vec![1.0; 15], 2)))
            .collect();
        let a = FactoredEvd::batch(&by_ref);
        let b = FactoredEvd::batch_dense(by_value);
        assert!(b[4].is_none(), "a buffer of the wrong length is refused");
        for (a, b) in a.iter().zip(&b) {
            let (a, b) = (a.as_ref().unwrap(), b.as_ref().unwrap());
            assert_eq!(a.eigenvalues, b.eigenvalues);
            assert_eq!((&a.z, &a.refl, &a.tau), (&b.z, &b.refl, &b.tau));
        }
    }

    #[test]
    fn zero_and_non_finite_matrices() {
        let z = Mat::<f64>::zeros(4, 4);
        let f = FactoredEvd::new(z.as_ref(), 4).unwrap();
        assert_eq!(f.eigenvalues(), &[0.0; 4]);
        let y = f.synthesize([&[1.0, 2.0][..], &[0.0, 0.0][..], &[0.0, 1.0][..]]);
        assert_eq!(y[0], vec![1.0, 2.0, 0.0, 0.0]);
        let mut b = Mat::<f64>::zeros(3, 3);
        b[(2, 1)] = f64::NAN;
        assert!(FactoredEvd::new(b.as_ref(), 3).is_none());
        assert!(FactoredEvd::new(Mat::<f64>::zeros(2, 3).as_ref(), 2).is_none());
        let empty = FactoredEvd::new(Mat::<f64>::zeros(0, 0).as_ref(), 5).unwrap();
        assert!(empty.is_empty());
    }

    #[test]
    fn the_portable_build_gives_the_same_bits() {
        if !crate::cpu::cpu_has_avx2_fma() {
            return;
        }
        // Run the same decomposition on both builds by calling the kernels' portable
        // paths directly (dispatch would pick AVX2 here).
        use crate::cpu::Kernel;
        let n = 90;
        let a = random_symmetric(n, 13);
        let f = FactoredEvd::new(a.as_ref(), n).unwrap();
        let mut w = vec![0.0; n * n];
        let (scale, unscale) = power_of_two_scaling(
            (0..n)
                .flat_map(|j| (j..n).map(move |i| (i, j)))
                .fold(0.0f64, |m, (i, j)| m.max(a[(i, j)].abs())),
        );
        for j in 0..n {
            for i in 0..n {
                w[i + j * n] = a[(i, j)] * scale;
            }
        }
        struct P<'a>(&'a mut [f64], usize);
        impl Kernel for P<'_> {
            type Output = Option<(Vec<f64>, Vec<f64>)>;
            fn portable(self) -> Self::Output {
                let P(w, n) = self;
                let (mut d, mut e, mut tau) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
                tridiagonalize(w, n, &mut d, &mut e, &mut tau);
                let lam = ql_eigenvalues(&d, &e[..n - 1])?;
                let z = crate::spectral::dense_evd::tridiagonal_vectors_by_column(
                    &d,
                    &e[..n - 1],
                    &lam,
                    n,
                );
                Some((lam, z))
            }
        }
        let (lam, z) = P(&mut w, n).portable().unwrap();
        let lam: Vec<f64> = lam.iter().map(|x| x * unscale).collect();
        assert_eq!(lam, f.eigenvalues());
        assert_eq!(z, f.z);
    }
}
