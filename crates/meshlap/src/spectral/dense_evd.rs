//! Bit-reproducible eigendecomposition of a small dense symmetric matrix,
//! `A = E Λ Eᵀ` (n×n, Λ ascending, E orthonormal), for the codec's patch bases.
//!
//! **Why by hand.** faer's `self_adjoint_evd` is the reference, but (1) it
//! dispatches on the CPU (AVX-512, AVX2 or scalar kernels with different summation
//! orders), so a basis computed on one machine can differ in its last bits from the
//! same basis computed on another, and the codec's decoder should rebuild the
//! encoder's bases exactly wherever it runs; and (2) at the codec's patch sizes
//! (n ≈ 100–150) it is slower, mostly in the tridiagonal divide and conquer.
//! This module uses only IEEE operations that are correctly rounded (`+ − × ÷ √` and
//! fused `mul_add`), in a fixed order (no reassociation, reductions in a fixed
//! four-lane order), so the result is the same bit for bit on any CPU and thread
//! count. On x86-64 with AVX2+FMA the same code is compiled with those features
//! enabled (elementwise loops vectorise without changing a bit; [`crate::cpu`]
//! decides, and `MESHLAP_PORTABLE=1` forces the portable build); elsewhere it runs
//! the identical portable code, where `mul_add` without hardware FMA is a C-library
//! call: an order of magnitude slower, and bit-identical only if that `fma` is
//! correctly rounded (glibc's is; some Windows runtimes' were not). Above n ≈ 1000
//! the whole spectrum of a Laplacian chains into one Gram–Schmidt cluster and faer
//! is faster.
//!
//! **Method** (Golub & Van Loan §8.3, LAPACK `dsytd2`/`dsterf`/`dstein`):
//! 1. Scale by a power of two (exact) so that `max |a_ij|` is in `[1, 2)` (for
//!    `2^-1000 ≤ max |a_ij| < 2^1001`; beyond, by `2^±1000`).
//! 2. Householder tridiagonalisation `A = Q T Qᵀ` on the full (both-triangle)
//!    column-major matrix, one fused pass per step over the trailing matrix: the
//!    rank-2 update of step k−1 and the product `B v_k` of step k (2n³ flops, all
//!    contiguous `axpy`s).
//! 3. Eigenvalues of `T` by the root-free (Pal–Walker–Kahan) QL iteration with
//!    Wilkinson shifts (values only, O(n²)).
//! 4. Eigenvectors of `T` by inverse iteration with the computed eigenvalues (LU with
//!    partial pivoting of `T − λI`, two solves from a fixed pseudo-random start),
//!    Gram–Schmidt against the previous vectors of the same cluster (eigenvalues
//!    closer than `10⁻³‖T‖`), with `dstein`'s perturbation of equal eigenvalues,
//!    its floor on tiny pivots and its split at negligible couplings.
//! 5. Back-transformation `E = Q Z` (2n³ flops, row-major `axpy`s).
//!
//! Accuracy (tests: Kirchhoff and SQL matrices of the cow's METIS patches, random
//! matrices up to n = 150, a grid Laplacian and block copies with exactly repeated
//! eigenvalues, Wilkinson's W21+, all-ones and low-rank matrices, tiny couplings,
//! identity, zero, entries of 1e±200): residuals `‖A e − λ e‖∞ ≤
//! 10⁻¹³‖A‖`, orthogonality `|EᵀE − I| ≤ 10⁻¹³` and eigenvalues within 10⁻¹² of
//! faer's. Speed: `cargo bench -p meshlap --bench core patch_bases`; the measured
//! figures against faer's solver are in BENCHMARKS.md.

/// Eigenvalues (ascending) and eigenvectors of the symmetric matrix whose **lower
/// triangle** is `a` (n×n, column-major; the upper triangle is not read). Returns
/// `None` if the QL iteration does not converge (30 sweeps per eigenvalue), or the
/// input or a result is not finite.
pub fn symmetric_evd(a: faer::MatRef<'_, f64>) -> Option<(Vec<f64>, faer::Mat<f64>)> {
    symmetric_evd_lowest(a, a.nrows())
}

/// As [`symmetric_evd`], but only the eigenvectors of the `count` smallest
/// eigenvalues are computed (n×count; all n eigenvalues are returned, ascending).
/// Each vector is computed exactly as [`symmetric_evd`] computes it, so the columns
/// are bit-identical to the first `count` columns of the whole decomposition; the
/// inverse iteration and back-transformation cost `O(n·count)` and `O(n²·count)`
/// instead of `O(n²)` and `O(n³)`. `count` is clamped to n.
pub fn symmetric_evd_lowest(
    a: faer::MatRef<'_, f64>,
    count: usize,
) -> Option<(Vec<f64>, faer::Mat<f64>)> {
    symmetric_evd_lowest_by(a, &|_| count)
}

/// As [`symmetric_evd_lowest`], with the number of eigenvectors chosen from the
/// eigenvalues: `count(λ)` gets all n eigenvalues (ascending, as returned) once they
/// are known, before any vector is computed (e.g. to extend a count to the end of an
/// eigenvalue cluster). Its answer is clamped to n.
pub fn symmetric_evd_lowest_by(
    a: faer::MatRef<'_, f64>,
    count: &dyn Fn(&[f64]) -> usize,
) -> Option<(Vec<f64>, faer::Mat<f64>)> {
    let n = a.nrows();
    if a.ncols() != n {
        return None;
    }
    if n == 0 {
        return Some((Vec::new(), faer::Mat::zeros(0, 0)));
    }
    let mut w = vec![0.0f64; n * n];
    for j in 0..n {
        for i in j..n {
            w[i + j * n] = a[(i, j)];
        }
    }
    let unscale = match scale_lower(&mut w, n) {
        Scaling::NonFinite => return None,
        Scaling::Zero => {
            let count = count(&vec![0.0; n]).min(n);
            return Some((
                vec![0.0; n],
                faer::Mat::from_fn(n, count, |i, j| f64::from(u8::from(i == j))),
            ));
        }
        Scaling::By(unscale) => unscale,
    };
    // The count sees the eigenvalues as returned: unscaled (exactly: a power of two).
    let unscaled_count = |lam: &[f64]| {
        let lam: Vec<f64> = lam.iter().map(|x| x * unscale).collect();
        count(&lam).min(n)
    };
    let (mut lam, z, count) = dispatch(&mut w, n, &unscaled_count)?;
    if z.iter().any(|x| !x.is_finite()) {
        return None;
    }
    lam.iter_mut().for_each(|x| *x *= unscale);
    if lam.iter().any(|x| !x.is_finite()) {
        return None;
    }
    Some((lam, faer::Mat::from_fn(n, count, |i, j| z[i * count + j])))
}

/// Steps 3–4 of the method on a symmetric tridiagonal matrix that another routine
/// produced (`d` its n diagonal entries, `e` its n − 1 off-diagonal ones, both scaled
/// so that their largest magnitude is of order 1): the `count` smallest eigenvalues
/// (clamped to n), ascending, and their eigenvectors, row-major n×count
/// (`z[i·count + j]` = component i of vector j), unit Euclidean norm. The eigenvalues
/// come from the QL iteration (all n, O(n²) dependent divisions) or, when `count` ≤
/// n / [`BISECTION_FRACTION`], from bisection on Sturm counts ([`lowest_by_bisection`],
/// [`BISECTION_LANES`] independent counts at a time); both to an absolute accuracy of
/// a few ε‖T‖. Runs on the build `crate::cpu::dispatch` picks, as [`symmetric_evd`]
/// does: the same bits on every CPU. `None` if the QL iteration does not converge,
/// an entry is not finite, or `d`, `e` do not have n and n − 1 entries (n ≥ 1).
pub(crate) fn tridiagonal_lowest(
    d: &[f64],
    e: &[f64],
    count: usize,
) -> Option<(Vec<f64>, Vec<f64>)> {
    struct Lowest<'a>(&'a [f64], &'a [f64], usize);
    impl crate::cpu::Kernel for Lowest<'_> {
        type Output = Option<(Vec<f64>, Vec<f64>)>;
        #[inline(always)]
        fn portable(self) -> Self::Output {
            let Lowest(d, e, count) = self;
            let n = d.len();
            let count = count.min(n);
            let lam = if count * BISECTION_FRACTION <= n {
                lowest_by_bisection(d, e, count)
            } else {
                let mut lam = ql_eigenvalues(d, e)?;
                lam.truncate(count);
                lam
            };
            let z = tridiagonal_vectors(d, e, &lam, count);
            Some((lam, z))
        }
    }
    let n = d.len();
    if n == 0 || e.len() + 1 != n || d.iter().chain(e).any(|x| !x.is_finite()) {
        return None;
    }
    crate::cpu::dispatch(Lowest(d, e, count))
}

/// [`tridiagonal_lowest`] bisects when at most one eigenvalue in this many is wanted.
const BISECTION_FRACTION: usize = 4;

/// Sturm counts [`lowest_by_bisection`] runs together (independent chains of
/// divisions the CPU overlaps; four AVX2 vectors).
const BISECTION_LANES: usize = 16;

/// The `count` smallest eigenvalues (ascending, count ≤ n) of the symmetric
/// tridiagonal (`d`, off-diagonal `e`, finite) by bisection (LAPACK `dstebz`): the
/// number of eigenvalues below x is the number of negative pivots of the LDLᵀ
/// factorisation of `T − xI` (`q₀ = d₀ − x`, `q_i = d_i − x − e²_{i−1}/q_{i−1}`, a
/// pivot smaller than `pivmin` in magnitude replaced by −`pivmin`: Kahan's
/// backward-stable count). Each eigenvalue's interval starts as Gershgorin's and
/// halves until it is narrower than `2ε max(|lo|, |hi|) + 2ε‖T‖∞`; the midpoint is
/// returned.
#[inline(always)]
fn lowest_by_bisection(d: &[f64], e: &[f64], count: usize) -> Vec<f64> {
    const L: usize = BISECTION_LANES;
    let n = d.len();
    let e2: Vec<f64> = e.iter().map(|x| x * x).collect();
    let tnorm = infinity_norm(d, e).max(f64::MIN_POSITIVE);
    let pivmin = f64::MIN_POSITIVE * e2.iter().fold(1.0f64, |a, &b| a.max(b));
    let (mut gl, mut gu) = (f64::INFINITY, f64::NEG_INFINITY);
    for i in 0..n {
        let r = if i > 0 { e[i - 1].abs() } else { 0.0 } + if i + 1 < n { e[i].abs() } else { 0.0 };
        gl = gl.min(d[i] - r);
        gu = gu.max(d[i] + r);
    }
    let atol = 2.0 * f64::EPSILON * tnorm;
    // Widen as dstebz does, so rounding in the counts cannot push an end inside.
    gl -= atol + 2.0 * f64::EPSILON * gl.abs();
    gu += atol + 2.0 * f64::EPSILON * gu.abs();
    let mut lam = vec![0.0f64; count];
    for j0 in (0..count).step_by(L) {
        let mut lo = [gl; L];
        let mut hi = [gu; L];
        // Lane l looks for eigenvalue j0 + l (the spare lanes of the last group
        // repeat the last index): λ_j ∈ [lo, hi) with count(lo) ≤ j < count(hi).
        let target: [u32; L] = std::array::from_fn(|l| (j0 + l).min(count - 1) as u32);
        // About 55 halvings reach the width; the cap only guards subnormal ‖T‖.
        for _ in 0..256 {
            let mut done = true;
            for l in 0..L {
                let w = 2.0 * f64::EPSILON * lo[l].abs().max(hi[l].abs()) + atol;
                done &= hi[l] - lo[l] <= w;
            }
            if done {
                break;
            }
            let x: [f64; L] = std::array::from_fn(|l| 0.5 * (lo[l] + hi[l]));
            let mut q = [0.0f64; L];
            let mut neg = [0u32; L];
            for l in 0..L {
                q[l] = d[0] - x[l];
            }
            for i in 0..n {
                if i > 0 {
                    for l in 0..L {
                        q[l] = (d[i] - x[l]) - e2[i - 1] / q[l];
                    }
                }
                for l in 0..L {
                    if q[l].abs() <= pivmin {
                        q[l] = -pivmin;
                    }
                    neg[l] += u32::from(q[l] < 0.0);
                }
            }
            for l in 0..L {
                if neg[l] > target[l] {
                    hi[l] = x[l];
                } else {
                    lo[l] = x[l];
                }
            }
        }
        for l in 0..L.min(count - j0) {
            lam[j0 + l] = 0.5 * (lo[l] + hi[l]);
        }
    }
    // Midpoints of nested intervals are ascending up to the tolerance; make it exact.
    for j in 1..count {
        if lam[j] < lam[j - 1] {
            lam[j] = lam[j - 1];
        }
    }
    lam
}

/// What [`scale_lower`] found.
pub(super) enum Scaling {
    /// An entry of the lower triangle is not finite.
    NonFinite,
    /// Every entry is zero (nothing scaled).
    Zero,
    /// Scaled; multiply the eigenvalues by this (a power of two) to undo it.
    By(f64),
}

/// Step 1 of the method on the column-major n×n `w` (`w[i + j·n]`): checks that its
/// lower triangle is finite, scales it by the exact power of two that brings
/// `max |w_ij|` into `[1, 2)` ([`power_of_two_scaling`]) and mirrors it into the
/// upper triangle (whose entries are not read).
pub(super) fn scale_lower(w: &mut [f64], n: usize) -> Scaling {
    // Branch-free over four lanes (so that it vectorises): `x·0` is ±0 for a finite
    // x and NaN otherwise, so the lanes' sums stay zero exactly when all are finite.
    let (mut amax, mut bad) = ([0.0f64; 4], [0.0f64; 4]);
    for j in 0..n {
        let col = &w[j * n + j..(j + 1) * n];
        let mut quads = col.chunks_exact(4);
        for q in &mut quads {
            for l in 0..4 {
                amax[l] = amax[l].max(q[l].abs());
                bad[l] += q[l] * 0.0;
            }
        }
        for (l, &x) in quads.remainder().iter().enumerate() {
            amax[l] = amax[l].max(x.abs());
            bad[l] += x * 0.0;
        }
    }
    if bad.iter().any(|&b| b != 0.0) {
        return Scaling::NonFinite;
    }
    let amax = amax.iter().fold(0.0f64, |m, &x| m.max(x));
    if amax == 0.0 {
        return Scaling::Zero;
    }
    let (scale, unscale) = power_of_two_scaling(amax);
    // Scaled column by column (exact: a power of two), then mirrored tile by tile
    // so that the strided writes of a tile's rows stay in a few cache lines.
    for j in 0..n {
        w[j * n + j..(j + 1) * n]
            .iter_mut()
            .for_each(|x| *x *= scale);
    }
    const TILE: usize = 8;
    for jb in (0..n).step_by(TILE) {
        for ib in (jb..n).step_by(TILE) {
            for j in jb..(jb + TILE).min(n) {
                for i in ib.max(j + 1)..(ib + TILE).min(n) {
                    w[j + i * n] = w[i + j * n];
                }
            }
        }
    }
    Scaling::By(unscale)
}

/// The exact scaling `(2^−e, 2^e)`, with e the binary exponent of `amax` clamped to
/// ±1000, that brings `amax` (positive, finite) into `[1, 2)`.
pub(crate) fn power_of_two_scaling(amax: f64) -> (f64, f64) {
    let exp = (((amax.to_bits() >> 52) & 0x7ff) as i32 - 1023).clamp(-1000, 1000);
    (pow2(-exp), pow2(exp))
}

/// `2^e` for |e| ≤ 1000, exactly.
pub(super) fn pow2(e: i32) -> f64 {
    f64::from_bits(((e + 1023) as u64) << 52)
}

/// [`evd`] on the build `crate::cpu::dispatch` picks: compiled with AVX2 + FMA (the
/// same operations, vectorised without changing a bit) or for the baseline target.
fn dispatch(
    w: &mut [f64],
    n: usize,
    count: &dyn Fn(&[f64]) -> usize,
) -> Option<(Vec<f64>, Vec<f64>, usize)> {
    struct Evd<'a>(&'a mut [f64], usize, &'a dyn Fn(&[f64]) -> usize);
    impl crate::cpu::Kernel for Evd<'_> {
        type Output = Option<(Vec<f64>, Vec<f64>, usize)>;
        #[inline(always)]
        fn portable(self) -> Self::Output {
            evd(self.0, self.1, self.2)
        }
    }
    crate::cpu::dispatch(Evd(w, n, count))
}

/// The decomposition of the full symmetric `w` (destroyed): all eigenvalues, the
/// eigenvectors of the `count(λ)` smallest (at most n) row-major (`z[i·count + j]` =
/// component i of vector j), and that count.
#[inline(always)]
fn evd(
    w: &mut [f64],
    n: usize,
    count: &dyn Fn(&[f64]) -> usize,
) -> Option<(Vec<f64>, Vec<f64>, usize)> {
    let mut d = vec![0.0; n];
    let mut e = vec![0.0; n];
    let mut tau = vec![0.0; n];
    tridiagonalize(w, n, &mut d, &mut e, &mut tau);
    let lam = ql_eigenvalues(&d, &e[..n - 1])?;
    let count = count(&lam).min(n);
    let mut z = tridiagonal_vectors(&d, &e[..n - 1], &lam, count);
    back_transform(&mut z, n, count, w, &tau);
    Some((lam, z, count))
}

/// `y += a·x`.
#[inline(always)]
pub(super) fn axpy(y: &mut [f64], a: f64, x: &[f64]) {
    for (y, &x) in y.iter_mut().zip(x) {
        *y = x.mul_add(a, *y);
    }
}

/// `b −= v·wj + w·vj` (one column of a symmetric rank-2 update).
#[inline(always)]
fn rank2(b: &mut [f64], v: &[f64], w: &[f64], vj: f64, wj: f64) {
    let (nv, nw) = (-vj, -wj);
    for ((b, &v), &w) in b.iter_mut().zip(v).zip(w) {
        *b = v.mul_add(nw, w.mul_add(nv, *b));
    }
}

/// The fused pass of [`tridiagonalize`]'s step `k` over the `m` trailing columns
/// (`cols`: columns k+1.. of the n×n column-major matrix): for each column j, rows
/// k.., `b −= pv·pw[j+1] + pw·pv[j+1]` ([`rank2`]), then `y += v[j]·b[1..]`
/// ([`axpy`]). [`FUSED_COLUMNS`] columns at a time, row by row, so that `pv`, `pw`
/// and `y` are loaded once per block and each column once: the same operations on
/// every entry, in the same order (the same bits as the two separate loops).
#[inline(always)]
fn update_and_multiply(
    cols: &mut [f64],
    n: usize,
    k: usize,
    pv: &[f64],
    pw: &[f64],
    v: &[f64],
    y: &mut [f64],
) {
    let m = v.len();
    let (pv0, pv) = (pv[0], &pv[1..m + 1]);
    let (pw0, pw) = (pw[0], &pw[1..m + 1]);
    let y = &mut y[..m];
    let mut blocks = cols.chunks_exact_mut(FUSED_COLUMNS * n);
    let mut j = 0;
    for block in &mut blocks {
        let mut cs: [&mut [f64]; FUSED_COLUMNS] = Default::default();
        for (c, col) in cs.iter_mut().zip(block.chunks_exact_mut(n)) {
            *c = &mut col[k..k + m + 1];
        }
        let nv: [f64; FUSED_COLUMNS] = std::array::from_fn(|c| -pv[j + c]);
        let nw: [f64; FUSED_COLUMNS] = std::array::from_fn(|c| -pw[j + c]);
        let vj: [f64; FUSED_COLUMNS] = std::array::from_fn(|c| v[j + c]);
        for c in 0..FUSED_COLUMNS {
            cs[c][0] = pv0.mul_add(nw[c], pw0.mul_add(nv[c], cs[c][0]));
        }
        for i in 0..m {
            let (a, b) = (pv[i], pw[i]);
            let mut acc = y[i];
            for c in 0..FUSED_COLUMNS {
                let x = a.mul_add(nw[c], b.mul_add(nv[c], cs[c][i + 1]));
                cs[c][i + 1] = x;
                acc = x.mul_add(vj[c], acc);
            }
            y[i] = acc;
        }
        j += FUSED_COLUMNS;
    }
    for (jj, col) in blocks.into_remainder().chunks_exact_mut(n).enumerate() {
        let col = &mut col[k..n];
        let jx = j + jj;
        rank2(col, &[pv0], &[pw0], pv[jx], pw[jx]);
        rank2(&mut col[1..], pv, pw, pv[jx], pw[jx]);
        axpy(y, v[jx], &col[1..]);
    }
}

/// Columns per block of [`update_and_multiply`].
const FUSED_COLUMNS: usize = 4;

/// Dot product in a fixed order: four interleaved partial sums, then the tail.
#[inline(always)]
pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let mut acc = [0.0f64; 4];
    let n4 = n / 4 * 4;
    let (a4, b4) = (&a[..n4], &b[..n4]);
    for (x, y) in a4.chunks_exact(4).zip(b4.chunks_exact(4)) {
        for l in 0..4 {
            acc[l] = x[l].mul_add(y[l], acc[l]);
        }
    }
    let mut s = (acc[0] + acc[1]) + (acc[2] + acc[3]);
    for i in n4..n {
        s = a[i].mul_add(b[i], s);
    }
    s
}

/// Householder tridiagonalisation of the full symmetric column-major `a` (n×n):
/// `d` the diagonal, `e[..n−1]` the off-diagonal of `T`; column k rows k+1.. of `a`
/// return `v_k` (`v_k[0] = 1`) with `H_k = I − τ_k v_k v_kᵀ` (`τ_k = 0`: identity),
/// `Q = H_0 H_1 ⋯ H_{n−2}`.
#[inline(always)]
pub(super) fn tridiagonalize(
    a: &mut [f64],
    n: usize,
    d: &mut [f64],
    e: &mut [f64],
    tau: &mut [f64],
) {
    // w of the pending rank-2 update (rows k.. at step k) and the next one.
    let mut w = vec![0.0f64; n];
    let mut y = vec![0.0f64; n];
    let mut pending = false;
    for k in 0..n - 1 {
        let m = n - k - 1;
        let (left, right) = a.split_at_mut(k * n);
        // The pending update is (v_{k−1}, w) over rows k.., length m + 1.
        let pv: &[f64] = if pending {
            &left[(k - 1) * n + k..k * n]
        } else {
            &[]
        };
        let pw = &w[..m + 1];
        let (ck, rest) = right.split_at_mut(n);
        if pending {
            rank2(&mut ck[k..n], pv, pw, pv[0], pw[0]);
        }
        d[k] = ck[k];
        let x = &mut ck[k + 1..n];
        // As LAPACK's dlarfg: a column far below the matrix's scale is scaled up by an
        // exact power of two first, so that the squares do not underflow and the
        // reflector stays orthogonal (v and τ do not depend on the scale).
        let xmax = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let (up, down) = if xmax < pow2(-400) {
            (pow2(500), pow2(-500))
        } else {
            (1.0, 1.0)
        };
        if up != 1.0 {
            x.iter_mut().for_each(|v| *v *= up);
        }
        let alpha = x[0];
        let sigma = dot(&x[1..], &x[1..]);
        let t = if sigma == 0.0 {
            e[k] = alpha * down;
            x[0] = 1.0;
            0.0
        } else {
            let norm = alpha.mul_add(alpha, sigma).sqrt();
            let beta = if alpha >= 0.0 { -norm } else { norm };
            let scal = 1.0 / (alpha - beta);
            x[0] = 1.0;
            x[1..].iter_mut().for_each(|v| *v *= scal);
            e[k] = beta * down;
            (beta - alpha) / beta
        };
        tau[k] = t;
        let v = &ck[k + 1..n];
        let yb = &mut y[..m];
        yb.iter_mut().for_each(|x| *x = 0.0);
        // One pass over the trailing columns: finish step k−1's update of column j,
        // then accumulate y = B v_k from it.
        if pending && t != 0.0 {
            update_and_multiply(&mut rest[..m * n], n, k, pv, pw, v, yb);
        } else {
            for j in 0..m {
                let col = &mut rest[j * n + k..(j + 1) * n];
                if pending {
                    rank2(col, pv, pw, pv[j + 1], pw[j + 1]);
                }
                if t != 0.0 {
                    axpy(yb, v[j], &col[1..]);
                }
            }
        }
        if t != 0.0 {
            // p = τ B v; w = p − ½τ (pᵀv) v.
            yb.iter_mut().for_each(|x| *x *= t);
            let c = -0.5 * t * dot(yb, v);
            axpy(yb, c, v);
            w[..m].copy_from_slice(yb);
            pending = true;
        } else {
            pending = false;
        }
    }
    // The last step (k = n − 2) has a one-entry column, so τ = 0 and nothing is
    // pending: its fused pass has already finished the last diagonal entry.
    d[n - 1] = a[(n - 1) * n + n - 1];
}

/// Eigenvalues of the symmetric tridiagonal matrix (`d`, off-diagonal `e`),
/// ascending, by the Pal–Walker–Kahan root-free QL iteration with Wilkinson shifts
/// (LAPACK `dsterf`, QL direction only) on the squared off-diagonal. The two
/// reciprocals of a step, `1/r` and `1/p` (`γ²/c = γ²·r/p`), are independent, so
/// they overlap, which makes it faster than the square-root QL (`tqli`) at the
/// patch sizes (n ≈ 100–150; figures in BENCHMARKS.md).
/// Deflation: `e_m² ≤ ε² max(|d_m| + |d_{m+1}|, ‖T‖∞)²`. `None` after 30 iterations
/// on one eigenvalue.
#[inline(always)]
pub(super) fn ql_eigenvalues(d: &[f64], e: &[f64]) -> Option<Vec<f64>> {
    let n = d.len();
    let mut d = d.to_vec();
    let mut e2: Vec<f64> = e
        .iter()
        .map(|x| x * x)
        .chain(std::iter::once(0.0))
        .collect();
    let tnorm = infinity_norm(&d, e);
    for l in 0..n {
        let mut iter = 0;
        loop {
            let m = split_point(&d, &e2, l, tnorm);
            if m == l {
                break;
            }
            iter += 1;
            if iter > 30 {
                return None;
            }
            // Wilkinson shift from the leading 2×2 block.
            let rte = e2[l].sqrt();
            let mut sigma = (d[l + 1] - d[l]) / (2.0 * rte);
            let r = sigma.mul_add(sigma, 1.0).sqrt();
            sigma = d[l] - rte / (sigma + if sigma >= 0.0 { r } else { -r });
            let (mut c, mut s) = (1.0f64, 0.0f64);
            let mut gamma = d[m] - sigma;
            let mut p = gamma * gamma;
            for i in (l..m).rev() {
                // e2[i] > 0 here (no deflation inside l..m), so r > 0.
                let bb = e2[i];
                let r = p + bb;
                if i + 1 != m {
                    e2[i + 1] = s * r;
                }
                let oldc = c;
                let (inv_r, inv_p) = (1.0 / r, 1.0 / p);
                c = p * inv_r;
                s = bb * inv_r;
                let oldgam = gamma;
                let alpha = d[i];
                gamma = c.mul_add(alpha - sigma, -(s * oldgam));
                d[i + 1] = oldgam + (alpha - gamma);
                p = if p != 0.0 {
                    (gamma * gamma) * (r * inv_p)
                } else {
                    oldc * bb
                };
            }
            e2[l] = s * p;
            d[l] = sigma + gamma;
        }
    }
    if d.iter().any(|x| !x.is_finite()) {
        return None;
    }
    d.sort_by(f64::total_cmp);
    Some(d)
}

/// The QL iteration's split point from row `l`: the first `m ≥ l` (`m + 1 < n`) whose
/// squared off-diagonal `e2[m]` is negligible, `e_m² ≤ ε² max(|d_m| + |d_{m+1}|,
/// ‖T‖∞)²`, else `n − 1` (`n = d.len()`, `e2` at least `n − 1` long, `l < n`). The
/// test is relative to the neighbouring diagonal or, as EISPACK's tql1, to ‖T‖: a
/// purely relative test never deflates a noise-level block that is still coupled to
/// O(1) eigenvalues (low-rank and graded matrices). Four rows are tested at a time
/// (independent tests, no chain of dependent branches); a test is a predicate, so
/// the split point is the one-row-at-a-time search's.
#[inline(always)]
fn split_point(d: &[f64], e2: &[f64], l: usize, tnorm: f64) -> usize {
    let n = d.len();
    let eps2 = f64::EPSILON * f64::EPSILON;
    let small = |m: usize| {
        let dd = (d[m].abs() + d[m + 1].abs()).max(tnorm);
        e2[m] <= eps2 * dd * dd
    };
    let mut m = l;
    while m + 4 < n {
        let hit = [small(m), small(m + 1), small(m + 2), small(m + 3)];
        if hit[0] | hit[1] | hit[2] | hit[3] {
            return m + hit.iter().take_while(|&&h| !h).count();
        }
        m += 4;
    }
    while m + 1 < n && !small(m) {
        m += 1;
    }
    m
}

/// One tridiagonal's state in [`ql_eigenvalues_many`]: the QL iteration of
/// [`ql_eigenvalues`] cut into sweeps, so that two can run interleaved.
struct QlState {
    d: Vec<f64>,
    e2: Vec<f64>,
    tnorm: f64,
    /// The eigenvalue being found, and the sweeps spent on it.
    l: usize,
    iter: u32,
}

/// One QL sweep in progress over rows `l..=m` of a [`QlState`]: the next row `i`
/// (descending; the sweep is over when `i < l`, i.e. `left == 0`) and the rotation
/// state.
struct QlSweep {
    l: usize,
    m: usize,
    i: usize,
    left: usize,
    sigma: f64,
    c: f64,
    s: f64,
    gamma: f64,
    p: f64,
}

impl QlState {
    #[inline(always)]
    fn new(d: &[f64], e: &[f64]) -> Self {
        let e2: Vec<f64> = e
            .iter()
            .map(|x| x * x)
            .chain(std::iter::once(0.0))
            .collect();
        Self {
            tnorm: infinity_norm(d, e),
            d: d.to_vec(),
            e2,
            l: 0,
            iter: 0,
        }
    }

    /// The next sweep ([`ql_eigenvalues`]' deflation test and Wilkinson shift), `Ok(None)`
    /// when every eigenvalue is found, `Err` after 30 sweeps on one eigenvalue.
    #[inline(always)]
    fn next_sweep(&mut self) -> Result<Option<QlSweep>, ()> {
        let n = self.d.len();
        let (d, e2) = (&self.d, &self.e2);
        while self.l < n {
            let l = self.l;
            let m = split_point(d, e2, l, self.tnorm);
            if m == l {
                self.l += 1;
                self.iter = 0;
                continue;
            }
            self.iter += 1;
            if self.iter > 30 {
                return Err(());
            }
            let rte = e2[l].sqrt();
            let mut sigma = (d[l + 1] - d[l]) / (2.0 * rte);
            let r = sigma.mul_add(sigma, 1.0).sqrt();
            sigma = d[l] - rte / (sigma + if sigma >= 0.0 { r } else { -r });
            let gamma = d[m] - sigma;
            return Ok(Some(QlSweep {
                l,
                m,
                i: m - 1,
                left: m - l,
                sigma,
                c: 1.0,
                s: 0.0,
                gamma,
                p: gamma * gamma,
            }));
        }
        Ok(None)
    }

    /// One row of the sweep (`w.left > 0`).
    #[inline(always)]
    fn step(&mut self, w: &mut QlSweep) {
        let i = w.i;
        let bb = self.e2[i];
        let r = w.p + bb;
        if i + 1 != w.m {
            self.e2[i + 1] = w.s * r;
        }
        let oldc = w.c;
        let (inv_r, inv_p) = (1.0 / r, 1.0 / w.p);
        w.c = w.p * inv_r;
        w.s = bb * inv_r;
        let oldgam = w.gamma;
        let alpha = self.d[i];
        w.gamma = w.c.mul_add(alpha - w.sigma, -(w.s * oldgam));
        self.d[i + 1] = oldgam + (alpha - w.gamma);
        w.p = if w.p != 0.0 {
            (w.gamma * w.gamma) * (r * inv_p)
        } else {
            oldc * bb
        };
        w.left -= 1;
        w.i = i.wrapping_sub(1);
    }

    #[inline(always)]
    fn finish(&mut self, w: &QlSweep) {
        self.e2[w.l] = w.s * w.p;
        self.d[w.l] = w.sigma + w.gamma;
    }

    #[inline(always)]
    fn result(self) -> Option<Vec<f64>> {
        let mut d = self.d;
        if d.iter().any(|x| !x.is_finite()) {
            return None;
        }
        d.sort_by(f64::total_cmp);
        Some(d)
    }
}

/// [`ql_eigenvalues`] of K tridiagonals (`(d, e)` each) at once, with the same bits:
/// each one's sweeps run exactly as alone, but the current sweeps of all K run
/// interleaved, row by row, so that the CPU overlaps their K chains of dependent
/// divisions (a sweep alone waits on its own chain).
#[inline(always)]
pub(super) fn ql_eigenvalues_many<const K: usize>(
    t: [(&[f64], &[f64]); K],
) -> [Option<Vec<f64>>; K] {
    let mut q: [QlState; K] = t.map(|(d, e)| QlState::new(d, e));
    let mut failed = [false; K];
    let mut sw: [Option<QlSweep>; K] = std::array::from_fn(|_| None);
    for k in 0..K {
        match q[k].next_sweep() {
            Ok(x) => sw[k] = x,
            Err(()) => failed[k] = true,
        }
    }
    loop {
        let mut any = false;
        for k in 0..K {
            any |= sw[k].is_some();
        }
        if !any {
            break;
        }
        // Rows of all running sweeps together while every one has rows left.
        let mut run = usize::MAX;
        for w in sw.iter().flatten() {
            run = run.min(w.left);
        }
        let mut done = false;
        #[cfg(target_arch = "x86_64")]
        if K.is_multiple_of(4) && crate::cpu::avx2_fma() {
            // SAFETY: `avx2_fma()` is only true when the CPU has AVX2 and FMA.
            unsafe { simd_ql::steps(&mut q, &mut sw, run) };
            done = true;
        }
        if !done {
            for _ in 0..run {
                for k in 0..K {
                    if let Some(w) = &mut sw[k] {
                        q[k].step(w);
                    }
                }
            }
        }
        // A finished sweep is closed and the next one started.
        for k in 0..K {
            if let Some(w) = &mut sw[k] {
                if w.left == 0 {
                    q[k].finish(w);
                    match q[k].next_sweep() {
                        Ok(x) => sw[k] = x,
                        Err(()) => {
                            failed[k] = true;
                            sw[k] = None;
                        }
                    }
                }
            }
        }
    }
    let mut out: [Option<Vec<f64>>; K] = std::array::from_fn(|_| None);
    for (k, st) in q.into_iter().enumerate() {
        if !failed[k] {
            out[k] = st.result();
        }
    }
    out
}

/// [`QlState::step`] with AVX2 + FMA intrinsics, four sweeps (of four matrices) as
/// the lanes of one vector and the groups of four interleaved: a sweep's rows are a
/// chain of two divisions and five dependent operations each, and four scalar
/// chains are limited by the scalar divider, four vector lanes are not. The rows'
/// entries are read and written per lane (each sweep is at its own row of its own
/// matrix); the arithmetic is the same IEEE operations per lane in the same order as
/// `step`, so the same bits (tested against sweeps run one matrix at a time).
#[cfg(target_arch = "x86_64")]
mod simd_ql {
    use super::simd::load;
    use super::{QlState, QlSweep};
    use std::arch::x86_64::*;

    /// `run` rows of every running sweep in `sw` (`q[k]`'s sweep `sw[k]`, each with
    /// at least `run` rows left; `q.len()` a multiple of 4).
    #[target_feature(enable = "avx2,fma")]
    pub(super) fn steps(q: &mut [QlState], sw: &mut [Option<QlSweep>], run: usize) {
        for (q, sw) in q.chunks_mut(8).zip(sw.chunks_mut(8)) {
            if q.len() == 8 {
                steps_g::<2>(q, sw, run);
            } else {
                steps_g::<1>(q, sw, run);
            }
        }
    }

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn steps_g<const G: usize>(q: &mut [QlState], sw: &mut [Option<QlSweep>], run: usize) {
        let sign = _mm256_set1_pd(-0.0);
        let one = _mm256_set1_pd(1.0);
        // An idle lane reads and writes nothing: it points at `spare` and never
        // stores (`active` false).
        let mut spare = [0.0f64; 2];
        let spare_ptr = spare.as_mut_ptr();
        let mut dp = [[spare_ptr; 4]; G];
        let mut ep = [[spare_ptr; 4]; G];
        let mut row = [[0usize; 4]; G];
        let mut last = [[usize::MAX; 4]; G];
        let mut active = [[false; 4]; G];
        let mut st = [[[0.0f64; 4]; 5]; G];
        for g in 0..G {
            for l in 0..4 {
                let k = 4 * g + l;
                if let Some(w) = &sw[k] {
                    dp[g][l] = q[k].d.as_mut_ptr();
                    ep[g][l] = q[k].e2.as_mut_ptr();
                    row[g][l] = w.i;
                    last[g][l] = w.m;
                    active[g][l] = true;
                    st[g][0][l] = w.sigma;
                    st[g][1][l] = w.c;
                    st[g][2][l] = w.s;
                    st[g][3][l] = w.gamma;
                    st[g][4][l] = w.p;
                }
            }
        }
        let mut sigma = [_mm256_setzero_pd(); G];
        let mut c = [_mm256_setzero_pd(); G];
        let mut s = [_mm256_setzero_pd(); G];
        let mut gamma = [_mm256_setzero_pd(); G];
        let mut p = [_mm256_setzero_pd(); G];
        for g in 0..G {
            sigma[g] = load(&st[g][0]);
            c[g] = load(&st[g][1]);
            s[g] = load(&st[g][2]);
            gamma[g] = load(&st[g][3]);
            p[g] = load(&st[g][4]);
        }
        let mut out = [0.0f64; 4];
        let mut out2 = [0.0f64; 4];
        for _ in 0..run {
            for g in 0..G {
                let mut bb = [0.0f64; 4];
                let mut alpha = [0.0f64; 4];
                for l in 0..4 {
                    if active[g][l] {
                        // SAFETY: the sweep's row i is inside its matrix (i < n).
                        unsafe {
                            bb[l] = *ep[g][l].add(row[g][l]);
                            alpha[l] = *dp[g][l].add(row[g][l]);
                        }
                    }
                }
                let (bb, alpha) = (load(&bb), load(&alpha));
                let r = _mm256_add_pd(p[g], bb);
                // e2[i + 1] = s·r (the previous s) unless i + 1 is the sweep's m.
                // SAFETY: `out` is four writable f64.
                unsafe { _mm256_storeu_pd(out.as_mut_ptr(), _mm256_mul_pd(s[g], r)) };
                let oldc = c[g];
                let inv_r = _mm256_div_pd(one, r);
                let inv_p = _mm256_div_pd(one, p[g]);
                c[g] = _mm256_mul_pd(p[g], inv_r);
                s[g] = _mm256_mul_pd(bb, inv_r);
                let oldgam = gamma[g];
                // c·(alpha − sigma) + (−(s·oldgam)), fused.
                gamma[g] = _mm256_fmadd_pd(
                    c[g],
                    _mm256_sub_pd(alpha, sigma[g]),
                    _mm256_xor_pd(_mm256_mul_pd(s[g], oldgam), sign),
                );
                let dnext = _mm256_add_pd(oldgam, _mm256_sub_pd(alpha, gamma[g]));
                // SAFETY: `out2` is four writable f64.
                unsafe { _mm256_storeu_pd(out2.as_mut_ptr(), dnext) };
                // p ≠ 0 (true for a NaN, as the scalar `!=`).
                let nonzero = _mm256_cmp_pd::<_CMP_NEQ_UQ>(p[g], _mm256_setzero_pd());
                p[g] = _mm256_blendv_pd(
                    _mm256_mul_pd(oldc, bb),
                    _mm256_mul_pd(_mm256_mul_pd(gamma[g], gamma[g]), _mm256_mul_pd(r, inv_p)),
                    nonzero,
                );
                for l in 0..4 {
                    if active[g][l] {
                        let i = row[g][l];
                        // SAFETY: rows i + 1 ≤ m < n of the sweep's matrix.
                        unsafe {
                            if i + 1 != last[g][l] {
                                *ep[g][l].add(i + 1) = out[l];
                            }
                            *dp[g][l].add(i + 1) = out2[l];
                        }
                        row[g][l] = i.wrapping_sub(1);
                    }
                }
            }
        }
        for g in 0..G {
            // SAFETY: four writable f64 each.
            unsafe {
                _mm256_storeu_pd(st[g][1].as_mut_ptr(), c[g]);
                _mm256_storeu_pd(st[g][2].as_mut_ptr(), s[g]);
                _mm256_storeu_pd(st[g][3].as_mut_ptr(), gamma[g]);
                _mm256_storeu_pd(st[g][4].as_mut_ptr(), p[g]);
            }
            for l in 0..4 {
                if let Some(w) = &mut sw[4 * g + l] {
                    w.c = st[g][1][l];
                    w.s = st[g][2][l];
                    w.gamma = st[g][3][l];
                    w.p = st[g][4][l];
                    w.i = row[g][l];
                    w.left -= run;
                }
            }
        }
    }
}

/// Eigenvectors computed together by [`tridiagonal_vectors`] (a *group*): their LU
/// factorisations and solves run interleaved in one loop, independent chains of
/// dependent divisions and FMAs that the CPU overlaps. Several groups are factored
/// in the same loop as well ([`TridiagonalLu::factor_many`]), and two consecutive
/// groups solved together ([`TridiagonalLu::solve_pair`]): with AVX2 a group's
/// chains are four lanes of one vector operation, which waits on its own latency (a
/// division and an FMA per row) without another group beside it.
const LANES: usize = 4;

/// LU factors of tridiagonal `T − λ_l I` for [`LANES`] shifts, with partial pivoting
/// (LAPACK `dgttrf`): unit lower multipliers `dl`, reciprocal pivots `dinv`, first
/// and second superdiagonals `du`, `du2`, row interchanges `swap` (all bits set where
/// rows i and i + 1 were interchanged, zero where not: a lane mask); entry `[i][l]`.
struct TridiagonalLu {
    dl: Vec<[f64; LANES]>,
    dinv: Vec<[f64; LANES]>,
    du: Vec<[f64; LANES]>,
    du2: Vec<[f64; LANES]>,
    swap: Vec<[u64; LANES]>,
}

impl TridiagonalLu {
    fn new(n: usize) -> Self {
        Self {
            dl: vec![[0.0; LANES]; n],
            dinv: vec![[0.0; LANES]; n],
            du: vec![[0.0; LANES]; n],
            du2: vec![[0.0; LANES]; n],
            swap: vec![[0; LANES]; n],
        }
    }

    /// Factors `T − λ_l I` for every lane; a pivot smaller than `tiny` in magnitude
    /// is replaced by `±tiny`. (The solver factors in batches, [`Self::factor_many`].)
    #[cfg(test)]
    fn factor(&mut self, d0: &[f64], e: &[f64], lam: [f64; LANES], tiny: f64) {
        Self::factor_many(&mut [self], &[lam], d0, e, tiny);
    }

    /// Factors `T − λ I` for the shifts of several groups (at most
    /// [`FACTOR_BATCH`]), their eliminations interleaved row by row (each one's bits
    /// are those it gets alone); a pivot smaller than `tiny` in magnitude is
    /// replaced by `±tiny`.
    #[inline(always)]
    fn factor_many(lus: &mut [&mut Self], lams: &[[f64; LANES]], d0: &[f64], e: &[f64], tiny: f64) {
        for (lu, &lam) in lus.iter_mut().zip(lams) {
            lu.prepare(d0, e, lam);
        }
        let mut done = false;
        #[cfg(target_arch = "x86_64")]
        if crate::cpu::avx2_fma() {
            // SAFETY: `avx2_fma()` is only true when the CPU has AVX2 and FMA.
            unsafe { simd::eliminate_all(lus, tiny) };
            done = true;
        }
        if !done {
            for i in 0..d0.len() - 1 {
                for lu in lus.iter_mut() {
                    lu.eliminate(i, tiny);
                }
            }
        }
        for lu in lus.iter_mut() {
            lu.finish(tiny);
        }
    }

    /// The factorisation's starting point: `dinv` holds `d − λ_l` (the pivots to
    /// come), `dl` and `du` the couplings, `du2` zero.
    #[inline(always)]
    fn prepare(&mut self, d0: &[f64], e: &[f64], lam: [f64; LANES]) {
        let n = d0.len();
        for (x, &v) in self.dinv.iter_mut().zip(d0) {
            for l in 0..LANES {
                x[l] = v - lam[l];
            }
        }
        for i in 0..n - 1 {
            self.dl[i] = [e[i]; LANES];
            self.du[i] = [e[i]; LANES];
            self.du2[i] = [0.0; LANES];
        }
    }

    /// Elimination step `i` (`i < n − 1`), pivoting on rows i and i + 1; a pivot
    /// below `tiny` is floored (the last one in [`Self::finish`]). The portable
    /// build's step (LLVM makes four scalar chains of it); `simd::eliminate` is the
    /// same per lane.
    #[inline(always)]
    fn eliminate(&mut self, i: usize, tiny: f64) {
        let n = self.dinv.len();
        let dd = &mut self.dinv;
        let next_du = if i + 2 < n {
            self.du[i + 1]
        } else {
            [0.0; LANES]
        };
        let mut du2 = [0.0; LANES];
        let mut ndu = next_du;
        for l in 0..LANES {
            let (a, b, c, d1) = (dd[i][l], self.dl[i][l], self.du[i][l], dd[i + 1][l]);
            let keep = a.abs() >= b.abs();
            let piv = if keep { a } else { b };
            // dlagts: a pivot below `tiny` (not only an exact zero) is floored, or
            // tiny pivots compound into an overflow.
            let piv = if piv.abs() < tiny {
                tiny.copysign(piv)
            } else {
                piv
            };
            let fact = (if keep { b } else { a }) / piv;
            dd[i][l] = piv;
            self.dl[i][l] = fact;
            self.du[i][l] = if keep { c } else { d1 };
            dd[i + 1][l] = fact.mul_add(-(if keep { c } else { d1 }), if keep { d1 } else { c });
            du2[l] = if keep { 0.0 } else { next_du[l] };
            ndu[l] = if keep { next_du[l] } else { -fact * next_du[l] };
            self.swap[i][l] = if keep { 0 } else { u64::MAX };
        }
        self.du2[i] = du2;
        if i + 2 < n {
            self.du[i + 1] = ndu;
        }
    }

    /// Floors the last pivot and inverts every pivot.
    #[inline(always)]
    fn finish(&mut self, tiny: f64) {
        let dd = &mut self.dinv;
        let n = dd.len();
        for l in 0..LANES {
            let p = dd[n - 1][l];
            if p.abs() < tiny {
                dd[n - 1][l] = tiny.copysign(p);
            }
        }
        dd[..n]
            .iter_mut()
            .for_each(|x| x.iter_mut().for_each(|x| *x = 1.0 / *x));
    }

    /// Solves `(T − λ_l I) x_l = b_l` in place for every lane (`b[i][l]`).
    #[inline(always)]
    fn solve(&self, b: &mut [[f64; LANES]]) {
        let n = b.len();
        let mut done = false;
        #[cfg(target_arch = "x86_64")]
        if crate::cpu::avx2_fma() {
            // SAFETY: `avx2_fma()` is only true when the CPU has AVX2 and FMA.
            unsafe { simd::forward_all(self, b, None) };
            done = true;
        }
        if !done {
            for i in 0..n - 1 {
                self.forward(b, i);
            }
        }
        self.last_rows(b);
        for i in (0..n.saturating_sub(2)).rev() {
            self.backward(b, i);
        }
    }

    /// [`Self::solve`] for two groups, row by row together: each one's bits are
    /// those of its own `solve`.
    #[inline(always)]
    fn solve_pair(a: &Self, xa: &mut [[f64; LANES]], b: &Self, xb: &mut [[f64; LANES]]) {
        let n = xa.len();
        let mut done = false;
        #[cfg(target_arch = "x86_64")]
        if crate::cpu::avx2_fma() {
            // SAFETY: `avx2_fma()` is only true when the CPU has AVX2 and FMA.
            unsafe { simd::forward_all(a, xa, Some((b, xb))) };
            done = true;
        }
        if !done {
            for i in 0..n - 1 {
                a.forward(xa, i);
                b.forward(xb, i);
            }
        }
        a.last_rows(xa);
        b.last_rows(xb);
        for i in (0..n.saturating_sub(2)).rev() {
            a.backward(xa, i);
            b.backward(xb, i);
        }
    }

    /// Forward substitution, row `i + 1` (with row i's interchange).
    #[inline(always)]
    fn forward(&self, b: &mut [[f64; LANES]], i: usize) {
        for l in 0..LANES {
            let (b0, b1, sw) = (b[i][l], b[i + 1][l], self.swap[i][l] != 0);
            let p = if sw { b1 } else { b0 };
            b[i][l] = p;
            b[i + 1][l] = self.dl[i][l].mul_add(-p, if sw { b0 } else { b1 });
        }
    }

    /// Back substitution, the last two rows.
    #[inline(always)]
    fn last_rows(&self, b: &mut [[f64; LANES]]) {
        let n = b.len();
        for l in 0..LANES {
            b[n - 1][l] *= self.dinv[n - 1][l];
            if n > 1 {
                b[n - 2][l] =
                    self.du[n - 2][l].mul_add(-b[n - 1][l], b[n - 2][l]) * self.dinv[n - 2][l];
            }
        }
    }

    /// Back substitution, row `i` (`i < n − 2`).
    #[inline(always)]
    fn backward(&self, b: &mut [[f64; LANES]], i: usize) {
        for l in 0..LANES {
            let r = self.du[i][l].mul_add(-b[i + 1][l], b[i][l]);
            b[i][l] = self.du2[i][l].mul_add(-b[i + 2][l], r) * self.dinv[i][l];
        }
    }
}

/// The row steps of [`TridiagonalLu`] with AVX2 + FMA intrinsics: the four lanes
/// of a group as one vector. LLVM leaves the portable steps' selects as four scalar
/// chains (a scalar division each); these are the same IEEE operations per lane in
/// the same order (compares, selects, `|x|`, sign copies, one division, one fused
/// multiply-add, one product), so the bits are those of the portable steps (tested,
/// and pinned by the codec's golden files on both builds).
#[cfg(target_arch = "x86_64")]
mod simd {
    use super::{TridiagonalLu, LANES};
    use std::arch::x86_64::*;

    const _: () = assert!(LANES == 4);

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    pub(super) fn load(x: &[f64; LANES]) -> __m256d {
        // SAFETY: `x` is four readable f64.
        unsafe { _mm256_loadu_pd(x.as_ptr()) }
    }

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn store(x: &mut [f64; LANES], v: __m256d) {
        // SAFETY: `x` is four writable f64.
        unsafe { _mm256_storeu_pd(x.as_mut_ptr(), v) }
    }

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn load_mask(x: &[u64; LANES]) -> __m256d {
        // SAFETY: `x` is four readable u64.
        unsafe { _mm256_castsi256_pd(_mm256_loadu_si256(x.as_ptr().cast())) }
    }

    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn store_mask(x: &mut [u64; LANES], v: __m256d) {
        // SAFETY: `x` is four writable u64.
        unsafe { _mm256_storeu_si256(x.as_mut_ptr().cast(), _mm256_castpd_si256(v)) }
    }

    /// One factorisation's arrays, borrowed apart (so that the row loop keeps their
    /// addresses in registers and knows they do not overlap).
    struct Rows<'a> {
        dinv: &'a mut [[f64; LANES]],
        dl: &'a mut [[f64; LANES]],
        du: &'a mut [[f64; LANES]],
        du2: &'a mut [[f64; LANES]],
        swap: &'a mut [[u64; LANES]],
    }

    /// [`TridiagonalLu::eliminate`] of row `i`, with `a = dinv[i]` and `c = du[i]`
    /// passed in registers (the previous row's results) instead of reloaded from
    /// the stores just made; returns the next row's `(a, c)`.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn eliminate(
        lu: &mut Rows<'_>,
        i: usize,
        tiny: f64,
        a: __m256d,
        c: __m256d,
    ) -> (__m256d, __m256d) {
        let n = lu.dinv.len();
        let sign = _mm256_set1_pd(-0.0);
        let b = load(&lu.dl[i]);
        let d1 = load(&lu.dinv[i + 1]);
        let more = i + 2 < n;
        let next_du = if more {
            load(&lu.du[i + 1])
        } else {
            _mm256_setzero_pd()
        };
        // keep = |a| ≥ |b| (false with a NaN, as the scalar `>=`).
        let keep =
            _mm256_cmp_pd::<_CMP_GE_OQ>(_mm256_andnot_pd(sign, a), _mm256_andnot_pd(sign, b));
        // blendv(x, y, m): y where m, else x.
        let piv = _mm256_blendv_pd(b, a, keep);
        let num = _mm256_blendv_pd(a, b, keep);
        let up = _mm256_blendv_pd(d1, c, keep);
        let low = _mm256_blendv_pd(c, d1, keep);
        let du2 = _mm256_andnot_pd(keep, next_du);
        // |piv| < tiny → tiny.copysign(piv).
        let tiny_v = _mm256_set1_pd(tiny);
        let small = _mm256_cmp_pd::<_CMP_LT_OQ>(_mm256_andnot_pd(sign, piv), tiny_v);
        let floored = _mm256_or_pd(_mm256_and_pd(sign, piv), _mm256_andnot_pd(sign, tiny_v));
        let piv = _mm256_blendv_pd(piv, floored, small);
        let fact = _mm256_div_pd(num, piv);
        // fact·(−up) + low, fused.
        let next = _mm256_fmadd_pd(fact, _mm256_xor_pd(up, sign), low);
        // keep ? next_du : (−fact)·next_du.
        let ndu = _mm256_blendv_pd(
            _mm256_mul_pd(_mm256_xor_pd(fact, sign), next_du),
            next_du,
            keep,
        );
        store(&mut lu.dinv[i], piv);
        store(&mut lu.dinv[i + 1], next);
        store(&mut lu.dl[i], fact);
        store(&mut lu.du[i], up);
        store(&mut lu.du2[i], du2);
        if more {
            store(&mut lu.du[i + 1], ndu);
        }
        // swap = !keep, as all-ones or zero lanes.
        let all = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
        store_mask(&mut lu.swap[i], _mm256_xor_pd(keep, all));
        (next, ndu)
    }

    /// Every elimination step of the `K` factorisations, interleaved row by row.
    #[target_feature(enable = "avx2,fma")]
    fn eliminate_k<const K: usize>(lus: &mut [&mut TridiagonalLu], tiny: f64) {
        let n = lus[0].dinv.len();
        let mut rows: [Option<Rows<'_>>; K] = [const { None }; K];
        for (r, lu) in rows.iter_mut().zip(lus.iter_mut()) {
            let lu = &mut **lu;
            *r = Some(Rows {
                dinv: &mut lu.dinv[..n],
                dl: &mut lu.dl[..n],
                du: &mut lu.du[..n],
                du2: &mut lu.du2[..n],
                swap: &mut lu.swap[..n],
            });
        }
        let mut rows = rows.map(|r| r.expect("K factorisations"));
        let mut a: [__m256d; K] = [_mm256_setzero_pd(); K];
        let mut c: [__m256d; K] = [_mm256_setzero_pd(); K];
        for k in 0..K {
            a[k] = load(&rows[k].dinv[0]);
            c[k] = load(&rows[k].du[0]);
        }
        for i in 0..n - 1 {
            for k in 0..K {
                (a[k], c[k]) = eliminate(&mut rows[k], i, tiny, a[k], c[k]);
            }
        }
    }

    /// Every elimination step of `lus` (at most [`super::FACTOR_BATCH`]), interleaved.
    #[target_feature(enable = "avx2,fma")]
    pub(super) fn eliminate_all(lus: &mut [&mut TridiagonalLu], tiny: f64) {
        match lus.len() {
            1 => eliminate_k::<1>(lus, tiny),
            2 => eliminate_k::<2>(lus, tiny),
            3 => eliminate_k::<3>(lus, tiny),
            4 => eliminate_k::<4>(lus, tiny),
            k => unreachable!("{k} factorisations at once"),
        }
    }

    /// [`TridiagonalLu::forward`] of row `i`.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn forward(lu: &TridiagonalLu, x: &mut [[f64; LANES]], i: usize) {
        let sign = _mm256_set1_pd(-0.0);
        let sw = load_mask(&lu.swap[i]);
        let b0 = load(&x[i]);
        let b1 = load(&x[i + 1]);
        let p = _mm256_blendv_pd(b0, b1, sw);
        let other = _mm256_blendv_pd(b1, b0, sw);
        store(&mut x[i], p);
        // dl·(−p) + other, fused.
        store(
            &mut x[i + 1],
            _mm256_fmadd_pd(load(&lu.dl[i]), _mm256_xor_pd(p, sign), other),
        );
    }

    /// Every forward step of `a` on `xa` (and of `b` on `xb`, interleaved).
    #[target_feature(enable = "avx2,fma")]
    pub(super) fn forward_all(
        a: &TridiagonalLu,
        xa: &mut [[f64; LANES]],
        mut b: Option<(&TridiagonalLu, &mut [[f64; LANES]])>,
    ) {
        for i in 0..xa.len() - 1 {
            forward(a, xa, i);
            if let Some((b, xb)) = b.as_mut() {
                forward(b, xb, i);
            }
        }
    }
}

/// Eigenvectors of the tridiagonal (`d`, `e`) for the `count` smallest of the
/// ascending eigenvalues `lam` (at least `count` of them), by inverse iteration (see the module documentation),
/// [`LANES`] at a time; row-major n×count. Vector j depends only on vectors < j.
#[inline(always)]
pub(super) fn tridiagonal_vectors(d: &[f64], e: &[f64], lam: &[f64], count: usize) -> Vec<f64> {
    let n = d.len();
    let zc = tridiagonal_vectors_by_column(d, e, lam, count);
    let mut z = vec![0.0f64; n * count];
    for j in 0..count {
        for i in 0..n {
            z[i * count + j] = zc[j * n + i];
        }
    }
    z
}

/// [`tridiagonal_vectors`] column-major (`z[j·n + i]` = component i of vector j):
/// the same bits.
///
/// Vectors go in groups of [`LANES`]: group g's two solves from its start, each
/// followed by the Gram–Schmidt of every lane against the finished vectors of its
/// cluster and the earlier lanes of the group. The groups are software-pipelined in
/// pairs — group g's second solve runs in the same loop as group g + 1's first, and
/// the factorisations go [`FACTOR_BATCH`] groups at a time — but every step still sees what it
/// saw group after group: group g + 1's first Gram–Schmidt comes after group g is
/// finished. The same bits as one group at a time (tested against that order).
#[inline(always)]
pub(super) fn tridiagonal_vectors_by_column(
    d: &[f64],
    e: &[f64],
    lam: &[f64],
    count: usize,
) -> Vec<f64> {
    let n = d.len();
    if count == 0 {
        return Vec::new();
    }
    if n == 1 {
        return vec![1.0];
    }
    let Setup {
        e,
        shift,
        first,
        tiny,
    } = Setup::new(d, e, lam, count);
    let e = &e[..];
    let groups = count.div_ceil(LANES);
    let js = |g: usize| group_vectors(g, count);
    // Group g's factors in `lu[g % FACTOR_SLOTS]` (no more slots than groups) and
    // its iterate in `x[g % 2]`.
    let mut lu: Vec<TridiagonalLu> = (0..groups.min(FACTOR_SLOTS))
        .map(|_| TridiagonalLu::new(n))
        .collect();
    let mut x: [Vec<[f64; LANES]>; 2] = std::array::from_fn(|_| vec![[0.0f64; LANES]; n]);
    let mut lane = vec![vec![0.0f64; n]; LANES];
    // Finished vectors, column-major (column j contiguous).
    // Filled in order, vector by vector (not zeroed first).
    let mut zc: Vec<f64> = Vec::with_capacity(n * count);
    let batches = BatchContext {
        d,
        e,
        shift: &shift,
        count,
        tiny,
    };
    batches.factor(&mut lu, 0);
    start(&mut x[0], js(0));
    lu[0].solve(&mut x[0]);
    orthonormalize(&mut x[0], js(0), &first, &zc, &mut lane);
    for g in 0..groups {
        let (xg, xh) = {
            let [x0, x1] = &mut x;
            if g % 2 == 0 {
                (x0, x1)
            } else {
                (x1, x0)
            }
        };
        let h = g + 1;
        if h < groups {
            if h % FACTOR_BATCH == 0 {
                batches.factor(&mut lu, h / FACTOR_BATCH);
            }
            start(xh, js(h));
            let (a, b) = (&lu[g % FACTOR_SLOTS], &lu[h % FACTOR_SLOTS]);
            TridiagonalLu::solve_pair(a, xg, b, xh);
        } else {
            lu[g % FACTOR_SLOTS].solve(xg);
        }
        orthonormalize(xg, js(g), &first, &zc, &mut lane);
        let j = js(g);
        for (l, v) in lane.iter().enumerate() {
            if l > 0 && j[l] == j[l - 1] {
                continue;
            }
            debug_assert_eq!(zc.len(), j[l] * n);
            zc.extend_from_slice(v);
        }
        if h < groups {
            orthonormalize(xh, js(h), &first, &zc, &mut lane);
        }
    }
    zc
}

/// The vectors of group g, [`LANES`] of them: an odd last group repeats its last
/// vector in the spare lanes (computed and discarded).
#[inline(always)]
fn group_vectors(g: usize, count: usize) -> [usize; LANES] {
    std::array::from_fn(|l| (g * LANES + l).min(count - 1))
}

/// Groups factored together by [`TridiagonalLu::factor_many`] (their eliminations
/// interleaved, so that the CPU overlaps their chains of divisions).
const FACTOR_BATCH: usize = 4;

/// Slots for the factors of [`tridiagonal_vectors_by_column`]: group g's in slot
/// g mod (FACTOR_BATCH + 1). Batch m (groups FACTOR_BATCH·m ..) is factored at the
/// step that first needs its first group, while the group before it is still in use.
const FACTOR_SLOTS: usize = FACTOR_BATCH + 1;

/// What [`BatchContext::factor`] reads.
struct BatchContext<'a> {
    d: &'a [f64],
    e: &'a [f64],
    shift: &'a [f64],
    count: usize,
    tiny: f64,
}

impl BatchContext<'_> {
    /// Factors the groups of batch `m` (those that exist) into their slots. (A
    /// method, not a closure: a closure is compiled without the kernel's CPU
    /// features.)
    #[inline(always)]
    fn factor(&self, lu: &mut [TridiagonalLu], m: usize) {
        let groups = self.count.div_ceil(LANES);
        let g0 = FACTOR_BATCH * m;
        let g1 = (g0 + FACTOR_BATCH).min(groups);
        let mut picked: Vec<Option<&mut TridiagonalLu>> = lu.iter_mut().map(Some).collect();
        let mut lus: Vec<&mut TridiagonalLu> = Vec::with_capacity(FACTOR_BATCH);
        let mut lams = [[0.0f64; LANES]; FACTOR_BATCH];
        for g in g0..g1 {
            lus.push(picked[g % FACTOR_SLOTS].take().expect("distinct slots"));
            let js = group_vectors(g, self.count);
            for l in 0..LANES {
                lams[g - g0][l] = self.shift[js[l]];
            }
        }
        TridiagonalLu::factor_many(&mut lus, &lams[..g1 - g0], self.d, self.e, self.tiny);
    }
}

/// What inverse iteration needs besides `d`: the couplings with negligible ones set
/// to zero, each vector's shift and the first vector of its cluster, and the pivot
/// floor.
struct Setup {
    e: Vec<f64>,
    shift: Vec<f64>,
    first: Vec<usize>,
    tiny: f64,
}

impl Setup {
    #[inline(always)]
    fn new(d: &[f64], e: &[f64], lam: &[f64], count: usize) -> Self {
        let tnorm = infinity_norm(d, e).max(f64::MIN_POSITIVE);
        // As dstein works per unreduced block: negligible couplings become exact zeros.
        let e: Vec<f64> = e
            .iter()
            .map(|&x| {
                if x.abs() <= f64::EPSILON * tnorm {
                    0.0
                } else {
                    x
                }
            })
            .collect();
        let ortol = 1e-3 * tnorm;
        let sep = 10.0 * f64::EPSILON * tnorm;
        let tiny = f64::EPSILON * tnorm;
        // Shifts and clusters first: vector j is orthogonalised against the vectors
        // first[j]..j (eigenvalues chained by gaps ≤ ortol).
        let mut shift = vec![0.0f64; count];
        let mut first = vec![0usize; count];
        for j in 0..count {
            if j == 0 || lam[j] - lam[j - 1] > ortol {
                first[j] = j;
                shift[j] = lam[j];
            } else {
                // dstein: separate (numerically) equal eigenvalues of one cluster.
                first[j] = first[j - 1];
                shift[j] = if lam[j] - shift[j - 1] < sep {
                    shift[j - 1] + sep
                } else {
                    lam[j]
                };
            }
        }
        Self {
            e,
            shift,
            first,
            tiny,
        }
    }
}

/// The fixed pseudo-random start in [−1, 1) of each lane's vector `js[l]` (a 64-bit
/// LCG seeded by the vector's index).
#[inline(always)]
fn start(x: &mut [[f64; LANES]], js: [usize; LANES]) {
    for (l, &j) in js.iter().enumerate() {
        let mut state = crate::rng::mix(j as u64);
        for xi in x.iter_mut() {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            // Below 2⁵³, so the conversion through i64 is exact (and the same value
            // as from u64, with one instruction instead of several).
            xi[l] = ((state >> 11) as i64) as f64 * (2.0 / (1u64 << 53) as f64) - 1.0;
        }
    }
}

/// Gram–Schmidt of each lane l of `x` (vector `js[l]`) against the finished vectors
/// of its cluster in `zc` (column-major, vectors below the group's first) and
/// against the group's earlier lanes of the same cluster, then normalised; the
/// results in `lane[l]` and back in `x`.
#[inline(always)]
fn orthonormalize(
    x: &mut [[f64; LANES]],
    js: [usize; LANES],
    first: &[usize],
    zc: &[f64],
    lane: &mut [Vec<f64>],
) {
    let n = x.len();
    let j0 = js[0];
    for l in 0..LANES {
        let (done, cur) = lane.split_at_mut(l);
        let v = &mut cur[0];
        for (vi, xi) in v.iter_mut().zip(x.iter()) {
            *vi = xi[l];
        }
        let j = js[l];
        for q in zc[first[j].min(j0) * n..j0 * n].chunks_exact(n) {
            let c = dot(q, v);
            axpy(v, -c, q);
        }
        // Earlier lanes of this group in the same cluster.
        for (m, q) in done.iter().enumerate() {
            if js[m] >= first[j] && js[m] < j {
                let c = dot(q, v);
                axpy(v, -c, q);
            }
        }
        let inv = 1.0 / dot(v, v).sqrt();
        v.iter_mut().for_each(|t| *t *= inv);
        for (xi, &vi) in x.iter_mut().zip(v.iter()) {
            xi[l] = vi;
        }
    }
}

/// `‖T‖∞` of the symmetric tridiagonal (`d`, off-diagonal `e`).
#[inline(always)]
fn infinity_norm(d: &[f64], e: &[f64]) -> f64 {
    let n = d.len();
    (0..n)
        .map(|i| {
            d[i].abs()
                + if i > 0 { e[i - 1].abs() } else { 0.0 }
                + if i + 1 < n { e[i].abs() } else { 0.0 }
        })
        .fold(0.0f64, f64::max)
}

/// `Z ← Q Z` for row-major `z` (n×count), with the reflectors left in `a`'s
/// columns by [`tridiagonalize`]: `H_k` acts on rows k+1.. . For each reflector (k
/// descending) `s = Zᵀv` (rows in order), then `Z −= τ v sᵀ`; the pass that applies
/// reflector k also accumulates the next reflector's `s` from each row just updated
/// (the rows that k does not touch are accumulated first), so every sum keeps its
/// order and Z is read once per reflector.
#[inline(always)]
fn back_transform(z: &mut [f64], n: usize, count: usize, a: &[f64], tau: &[f64]) {
    if count == 0 {
        return;
    }
    // The reflectors that act (τ ≠ 0), in order of application.
    let ks: Vec<usize> = (0..n - 1).rev().filter(|&k| tau[k] != 0.0).collect();
    let refl = |k: usize| &a[k * n + k + 1..(k + 1) * n];
    let mut s = vec![0.0f64; count];
    let mut s_next = vec![0.0f64; count];
    // s of the first reflector.
    if let Some(&k) = ks.first() {
        for (i, &vi) in refl(k).iter().enumerate() {
            let r = (k + 1 + i) * count;
            axpy(&mut s, vi, &z[r..r + count]);
        }
    }
    for (q, &k) in ks.iter().enumerate() {
        let (t, v) = (tau[k], refl(k));
        let next = ks.get(q + 1).copied();
        s_next.iter_mut().for_each(|x| *x = 0.0);
        if let Some(k2) = next {
            // Rows k2+1 ..= k: not touched by reflector k.
            let v2 = refl(k2);
            for r in k2 + 1..=k {
                axpy(&mut s_next, v2[r - k2 - 1], &z[r * count..(r + 1) * count]);
            }
        }
        for (i, &vi) in v.iter().enumerate() {
            let r = k + 1 + i;
            let row = &mut z[r * count..(r + 1) * count];
            axpy(row, -t * vi, &s);
            if let Some(k2) = next {
                axpy(&mut s_next, refl(k2)[r - k2 - 1], row);
            }
        }
        std::mem::swap(&mut s, &mut s_next);
    }
}

/// The one-pass-per-product form of [`back_transform`], to check its bits.
#[cfg(test)]
fn back_transform_reference(z: &mut [f64], n: usize, count: usize, a: &[f64], tau: &[f64]) {
    let mut s = vec![0.0f64; count];
    for k in (0..n - 1).rev() {
        let t = tau[k];
        if t == 0.0 {
            continue;
        }
        let v = &a[k * n + k + 1..(k + 1) * n];
        s.iter_mut().for_each(|x| *x = 0.0);
        for (i, &vi) in v.iter().enumerate() {
            let r = (k + 1 + i) * count;
            axpy(&mut s, vi, &z[r..r + count]);
        }
        for (i, &vi) in v.iter().enumerate() {
            let r = (k + 1 + i) * count;
            axpy(&mut z[r..r + count], -t * vi, &s);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectral::test_util::random_symmetric;
    use faer::Mat;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Max residual ‖A e_j − λ_j e_j‖∞ / ‖A‖ and max |EᵀE − I|.
    fn quality(a: &Mat<f64>, lam: &[f64], e: &Mat<f64>) -> (f64, f64) {
        let n = a.nrows();
        let anorm = (0..n)
            .map(|i| (0..n).map(|j| a[(i, j)].abs()).sum::<f64>())
            .fold(1e-300, f64::max);
        let ae = a * e;
        let mut res = 0.0f64;
        for j in 0..n {
            for i in 0..n {
                res = res.max((ae[(i, j)] - lam[j] * e[(i, j)]).abs() / anorm);
            }
        }
        let g = e.transpose() * e;
        let mut orth = 0.0f64;
        for j in 0..n {
            for i in 0..n {
                orth = orth.max((g[(i, j)] - if i == j { 1.0 } else { 0.0 }).abs());
            }
        }
        (res, orth)
    }

    fn faer_values(a: &Mat<f64>) -> Vec<f64> {
        let mut v: Vec<f64> = a
            .self_adjoint_eigenvalues(faer::Side::Lower)
            .unwrap()
            .into_iter()
            .collect();
        v.sort_by(f64::total_cmp);
        v
    }

    /// The fused, column-blocked pass gives the bits of the two separate loops
    /// (rank-2 update of each column, then `y += v[j]·column`), for every remainder
    /// of the trailing columns modulo the block and for entries of mixed scales.
    #[test]
    fn fused_pass_matches_separate_loops() {
        let mut rng = ChaCha8Rng::seed_from_u64(41);
        for n in 3..3 + 3 * FUSED_COLUMNS {
            for k in 0..n - 2 {
                let m = n - k - 1;
                let a: Vec<f64> = (0..n * n)
                    .map(|_| rng.gen_range(-1.0..1.0) * 10f64.powi(rng.gen_range(-3..4)))
                    .collect();
                let pv: Vec<f64> = (0..=m).map(|_| rng.gen_range(-1.0..1.0)).collect();
                let pw: Vec<f64> = (0..=m).map(|_| rng.gen_range(-1.0..1.0)).collect();
                let v: Vec<f64> = (0..m).map(|_| rng.gen_range(-1.0..1.0)).collect();
                let y0: Vec<f64> = (0..m).map(|_| rng.gen_range(-1.0..1.0)).collect();
                let (mut a1, mut y1) = (a.clone(), y0.clone());
                for j in 0..m {
                    let col = &mut a1[(k + 1 + j) * n + k..(k + 2 + j) * n];
                    rank2(col, &pv, &pw, pv[j + 1], pw[j + 1]);
                    axpy(&mut y1, v[j], &col[1..]);
                }
                let (mut a2, mut y2) = (a, y0);
                update_and_multiply(&mut a2[(k + 1) * n..], n, k, &pv, &pw, &v, &mut y2);
                let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&a1), bits(&a2), "n={n} k={k}");
                assert_eq!(bits(&y1), bits(&y2), "n={n} k={k}");
            }
        }
    }

    #[test]
    fn random_matrices_match_faer() {
        for (n, seed) in [(1, 1), (2, 2), (3, 3), (7, 4), (40, 5), (150, 6)] {
            let a = random_symmetric(n, seed);
            let (lam, e) = symmetric_evd(a.as_ref()).unwrap();
            let (res, orth) = quality(&a, &lam, &e);
            assert!(res < 1e-13 && orth < 1e-13, "n={n}: {res:e} {orth:e}");
            for (x, y) in lam.iter().zip(faer_values(&a)) {
                assert!((x - y).abs() < 1e-12 * n as f64, "n={n}: {x} vs {y}");
            }
            assert!(lam.windows(2).all(|p| p[0] <= p[1]));
        }
    }

    #[test]
    fn lowest_vectors_are_the_first_columns_bit_for_bit() {
        // A random matrix, and one with threefold eigenvalues (clusters cut by count).
        let b = random_symmetric(12, 7);
        let mut blocks = Mat::<f64>::zeros(36, 36);
        for c in 0..3 {
            for j in 0..12 {
                for i in 0..12 {
                    blocks[(12 * c + i, 12 * c + j)] = b[(i, j)];
                }
            }
        }
        for a in [random_symmetric(41, 11), blocks] {
            let n = a.nrows();
            let (lam, e) = symmetric_evd(a.as_ref()).unwrap();
            for count in [0, 1, 2, 5, 7, n - 1, n, n + 3] {
                let (lam_k, e_k) = symmetric_evd_lowest(a.as_ref(), count).unwrap();
                assert_eq!(lam_k, lam);
                assert_eq!(e_k.ncols(), count.min(n));
                for j in 0..e_k.ncols() {
                    for i in 0..n {
                        assert_eq!(e_k[(i, j)].to_bits(), e[(i, j)].to_bits(), "count {count}");
                    }
                }
            }
        }
        // A count chosen from the eigenvalues sees the returned eigenvalues (unscaled).
        let a = Mat::<f64>::from_fn(9, 9, |i, j| random_symmetric(9, 3)[(i, j)] * 1e-30);
        let seen = std::cell::RefCell::new(Vec::new());
        let (lam, e) = symmetric_evd_lowest_by(a.as_ref(), &|l| {
            seen.borrow_mut().extend_from_slice(l);
            4
        })
        .unwrap();
        assert_eq!(*seen.borrow(), lam);
        assert_eq!(e.ncols(), 4);
        let zero = Mat::<f64>::zeros(4, 4);
        let (lam, e) = symmetric_evd_lowest(zero.as_ref(), 2).unwrap();
        assert_eq!(
            (lam, e),
            (
                vec![0.0; 4],
                Mat::from_fn(4, 2, |i, j| f64::from(u8::from(i == j)))
            )
        );
    }

    #[test]
    fn repeated_eigenvalues_and_special_matrices() {
        // Three copies of one block: every eigenvalue threefold.
        let b = random_symmetric(12, 7);
        let n = 36;
        let mut a = Mat::<f64>::zeros(n, n);
        for c in 0..3 {
            for j in 0..12 {
                for i in 0..12 {
                    a[(12 * c + i, 12 * c + j)] = b[(i, j)];
                }
            }
        }
        // Grid Laplacian (many multiplicities), identity, diagonal, zero, scaled.
        let m = 6;
        let mut g = Mat::<f64>::zeros(m * m, m * m);
        for i in 0..m {
            for j in 0..m {
                for (di, dj) in [(1, 0), (0, 1)] {
                    if i + di < m && j + dj < m {
                        let (u, v) = (i * m + j, (i + di) * m + j + dj);
                        g[(u, v)] -= 1.0;
                        g[(v, u)] -= 1.0;
                        g[(u, u)] += 1.0;
                        g[(v, v)] += 1.0;
                    }
                }
            }
        }
        let diag = Mat::<f64>::from_fn(9, 9, |i, j| if i == j { (i % 3) as f64 } else { 0.0 });
        // Wilkinson's W21+: eigenvalue pairs that agree to ~1e-14 (inverse iteration's
        // hard case: the cluster Gram–Schmidt keeps the pair orthogonal).
        let wilkinson = Mat::<f64>::from_fn(21, 21, |i, j| {
            if i == j {
                (10.0 - i as f64).abs()
            } else if i.abs_diff(j) == 1 {
                1.0
            } else {
                0.0
            }
        });
        let r8 = random_symmetric(20, 8);
        let r9 = random_symmetric(20, 9);
        let big = Mat::<f64>::from_fn(20, 20, |i, j| r8[(i, j)] * 1e200);
        let small = Mat::<f64>::from_fn(20, 20, |i, j| r9[(i, j)] * 1e-200);
        // Found in review: rank-deficient inputs (underflowing reflectors, QL that
        // never deflated), tiny non-zero pivots.
        let ones13 = Mat::<f64>::from_fn(13, 13, |_, _| 1.0);
        let ones64 = Mat::<f64>::from_fn(64, 64, |_, _| 1.0);
        let gmat = random_symmetric(100, 12);
        let gsub = gmat.as_ref().subcols(0, 10);
        let low_rank = gsub * gsub.transpose();
        let tiny_coupling = Mat::<f64>::from_fn(2, 2, |i, j| match (i, j) {
            (0, 0) => 0.0,
            (1, 1) => 1.0,
            _ => 1e-300,
        });
        let clustered = Mat::<f64>::from_fn(100, 100, |i, j| {
            if i == j {
                (i % 3) as f64
            } else if i.abs_diff(j) == 1 {
                1e-20
            } else {
                0.0
            }
        });
        for a in [
            a,
            g,
            Mat::identity(10, 10),
            diag,
            wilkinson,
            ones13,
            ones64,
            low_rank,
            tiny_coupling,
            clustered,
            Mat::zeros(5, 5),
            big,
            small,
        ] {
            let (lam, e) = symmetric_evd(a.as_ref()).unwrap();
            let (res, orth) = quality(&a, &lam, &e);
            assert!(
                res < 1e-13 && orth < 1e-13,
                "n={}: {res:e} {orth:e}",
                a.nrows()
            );
            let f = faer_values(&a);
            let scale = f.iter().fold(1e-300f64, |m, x| m.max(x.abs()));
            for (x, y) in lam.iter().zip(f) {
                assert!((x - y).abs() <= 1e-12 * scale, "{x} vs {y}");
            }
        }
    }

    #[test]
    fn real_patches_match_faer() {
        // Kirchhoff and SQL operators of the cow's METIS patches (the codec's use),
        // patches of about 100 vertices; with boundary, irregular valences.
        use crate::mesh::topology::Topology;
        use crate::operator::{Operator, OperatorKind};
        use crate::partition::{partition, PartitionOptions};
        let path = format!("{}/../../tests/data/cow.obj", env!("CARGO_MANIFEST_DIR"));
        let m = crate::io::read_mesh(std::path::Path::new(&path), None)
            .unwrap()
            .mesh;
        let t = Topology::new(&m).unwrap();
        let part = partition(t.graph(), &PartitionOptions::new(100)).unwrap();
        for p in (0..part.n_patches()).step_by(3) {
            let sub = part.submesh(&m, p).mesh;
            let st = Topology::new(&sub).unwrap();
            for kind in [OperatorKind::Kirchhoff, OperatorKind::Sql] {
                let op = Operator::assemble(kind, &sub, &st, &Default::default()).unwrap();
                let a = op.matrix.to_dense();
                let (lam, e) = symmetric_evd(a.as_ref()).unwrap();
                let (res, orth) = quality(&a, &lam, &e);
                assert!(res < 1e-13 && orth < 1e-13, "patch {p}: {res:e} {orth:e}");
                let f = faer_values(&a);
                for (x, y) in lam.iter().zip(&f) {
                    assert!((x - y).abs() < 1e-12 * f[f.len() - 1], "{x} vs {y}");
                }
            }
        }
    }

    /// Tridiagonals with known or hard spectra: (d, e, name).
    fn hard_tridiagonals() -> Vec<(Vec<f64>, Vec<f64>, &'static str)> {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut out = Vec::new();
        for &n in &[1usize, 2, 3, 7, 40, 157, 300] {
            let d = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
            let e = (0..n - 1).map(|_| rng.gen_range(-1.0..1.0)).collect();
            out.push((d, e, "random"));
        }
        // 1-2-1 Toeplitz: λ_k = 2 − 2cos(kπ/(n + 1)).
        out.push((vec![2.0; 120], vec![-1.0; 119], "toeplitz"));
        // Wilkinson W₂₁⁺: pairs agreeing to many digits.
        let d = (0..21).map(|i: i32| f64::from((10 - i).abs())).collect();
        out.push((d, vec![1.0; 20], "wilkinson"));
        // Three identical blocks split by exact zeros: every eigenvalue triple.
        let mut d = Vec::new();
        let mut e = Vec::new();
        for b in 0..3 {
            if b > 0 {
                e.push(0.0);
            }
            d.extend([1.0, 0.5, 0.25, 2.0]);
            e.extend([0.3, -0.7, 0.1]);
        }
        out.push((d, e, "blocks"));
        // Graded, a zero eigenvalue (a path graph's Laplacian), and a constant diagonal
        // with negligible coupling.
        out.push((
            (0..50).map(|i| 2f64.powi(-i)).collect(),
            (0..49).map(|i| 2f64.powi(-i - 1)).collect(),
            "graded",
        ));
        let mut d = vec![2.0; 80];
        d[0] = 1.0;
        d[79] = 1.0;
        out.push((d, vec![-1.0; 79], "path laplacian"));
        out.push((vec![1.0; 60], vec![1e-20; 59], "tiny coupling"));
        out
    }

    /// Four and eight interleaved QL iterations (the AVX2 lanes where the CPU has
    /// them) give each matrix the bits it gets alone, on every mix of the hard
    /// tridiagonals (sweeps of different lengths, deflations, zero p).
    #[test]
    fn batched_ql_gives_each_ones_bits() {
        let t = hard_tridiagonals();
        fn check<const K: usize>(t: &[(Vec<f64>, Vec<f64>, &'static str)], offset: usize) {
            let pick: [usize; K] = std::array::from_fn(|k| (offset + 5 * k) % t.len());
            let got =
                ql_eigenvalues_many::<K>(pick.map(|i| (t[i].0.as_slice(), t[i].1.as_slice())));
            for (k, &i) in pick.iter().enumerate() {
                let alone = ql_eigenvalues(&t[i].0, &t[i].1);
                let same = match (&got[k], &alone) {
                    (Some(a), Some(b)) => a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()),
                    (None, None) => true,
                    _ => false,
                };
                assert!(same, "{} in a batch of {K} (offset {offset})", t[i].2);
            }
        }
        for offset in 0..t.len() {
            check::<4>(&t, offset);
            check::<8>(&t, offset);
            check::<12>(&t, offset);
        }
    }

    /// The four-at-a-time split point is the first negligible row a row-by-row search
    /// finds, from every start, with negligible rows at every position (none, one,
    /// several, next to the end) and tests that pass on the diagonal's or on ‖T‖'s
    /// scale.
    #[test]
    fn split_point_is_the_row_by_row_search() {
        fn by_row(d: &[f64], e2: &[f64], l: usize, tnorm: f64) -> usize {
            let eps2 = f64::EPSILON * f64::EPSILON;
            let mut m = l;
            while m + 1 < d.len() {
                let dd = (d[m].abs() + d[m + 1].abs()).max(tnorm);
                if e2[m] <= eps2 * dd * dd {
                    break;
                }
                m += 1;
            }
            m
        }
        let mut rng = ChaCha8Rng::seed_from_u64(77);
        let mut hits = 0;
        for case in 0..3000 {
            let n = 1 + case % 23;
            let d: Vec<f64> = (0..n)
                .map(|_| rng.gen_range(-1.0..1.0) * 10f64.powi(rng.gen_range(-3..4)))
                .collect();
            let rate = [0.0, 0.05, 0.3][case % 3];
            let e2: Vec<f64> = (0..n)
                .map(|_| {
                    if rng.gen_bool(rate) {
                        // At, just below and just above the threshold of a unit scale.
                        [0.0, 1e-40, 4.9e-32, 5.0e-32][rng.gen_range(0..4)]
                    } else {
                        rng.gen_range(1e-6..1.0)
                    }
                })
                .collect();
            let tnorm = [0.0, 1.0, 1e3][(case / 3) % 3];
            for l in 0..n {
                let want = by_row(&d, &e2, l, tnorm);
                assert_eq!(split_point(&d, &e2, l, tnorm), want, "case {case}, l {l}");
                hits += usize::from(want + 1 < n);
            }
        }
        assert!(hits > 1000, "too few negligible rows found: {hits}");
    }

    #[test]
    fn paired_ql_gives_each_ones_bits() {
        let t = hard_tridiagonals();
        for (i, (da, ea, na)) in t.iter().enumerate() {
            let (db, eb, nb) = &t[(i * 7 + 3) % t.len()];
            let [pa, pb] = ql_eigenvalues_many([(da, ea), (db, eb)]);
            let (sa, sb) = (ql_eigenvalues(da, ea), ql_eigenvalues(db, eb));
            let bits =
                |v: Option<Vec<f64>>| v.map(|v| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>());
            assert_eq!(bits(pa), bits(sa), "{na}");
            assert_eq!(bits(pb), bits(sb), "{nb}");
        }
    }

    #[test]
    fn bisection_matches_the_ql_eigenvalues() {
        for (d, e, name) in hard_tridiagonals() {
            let n = d.len();
            let ql = ql_eigenvalues(&d, &e).unwrap();
            let tnorm = infinity_norm(&d, &e);
            for count in [1, n / 4, n / 2, n] {
                let count = count.clamp(1, n);
                let bis = lowest_by_bisection(&d, &e, count);
                assert_eq!(bis.len(), count);
                for j in 0..count {
                    assert!(
                        (bis[j] - ql[j]).abs() <= 1e-13 * tnorm,
                        "{name} n={n} j={j}: bisection {} QL {}",
                        bis[j],
                        ql[j]
                    );
                }
                assert!(bis.windows(2).all(|w| w[0] <= w[1]), "{name}");
            }
            if name == "toeplitz" {
                for (k, &l) in ql.iter().enumerate() {
                    let exact =
                        2.0 - 2.0 * ((k + 1) as f64 * std::f64::consts::PI / (n + 1) as f64).cos();
                    assert!((l - exact).abs() < 1e-14, "{k}: {l} vs {exact}");
                }
            }
        }
    }

    #[test]
    fn tridiagonal_lowest_gives_orthonormal_eigenvectors_on_both_routes() {
        for (d, e, name) in hard_tridiagonals() {
            let n = d.len();
            let tnorm = infinity_norm(&d, &e);
            // n / 4 takes the bisection route, n / 2 and n the QL route.
            for count in [n / 4, n / 2, n] {
                let count = count.max(1);
                let (lam, z) = tridiagonal_lowest(&d, &e, count).unwrap();
                assert_eq!((lam.len(), z.len()), (count, n * count), "{name}");
                for j in 0..count {
                    let v = |i: usize| z[i * count + j];
                    let mut r = 0.0f64;
                    for i in 0..n {
                        let mut t = (d[i] - lam[j]) * v(i);
                        if i > 0 {
                            t += e[i - 1] * v(i - 1);
                        }
                        if i + 1 < n {
                            t += e[i] * v(i + 1);
                        }
                        r = r.max(t.abs());
                    }
                    assert!(
                        r <= 1e-12 * tnorm.max(1e-300),
                        "{name} n={n} j={j}: residual {r}"
                    );
                    for k in 0..=j {
                        let g: f64 = (0..n).map(|i| z[i * count + j] * z[i * count + k]).sum();
                        let want = if j == k { 1.0 } else { 0.0 };
                        assert!((g - want).abs() < 1e-12, "{name} n={n} ({j},{k}): {g}");
                    }
                }
            }
        }
        assert!(tridiagonal_lowest(&[1.0, f64::NAN], &[0.5], 1).is_none());
        assert!(tridiagonal_lowest(&[1.0, 2.0], &[f64::INFINITY], 1).is_none());
        assert!(tridiagonal_lowest(&[1.0, 2.0], &[], 1).is_none());
    }

    /// Inverse iteration one group at a time, each group's two solves and
    /// Gram–Schmidt passes before the next group starts: the order that
    /// [`tridiagonal_vectors_by_column`] pipelines.
    fn vectors_group_by_group(d: &[f64], e: &[f64], lam: &[f64], count: usize) -> Vec<f64> {
        let n = d.len();
        let Setup {
            e,
            shift,
            first,
            tiny,
        } = Setup::new(d, e, lam, count);
        let mut lu = TridiagonalLu::new(n);
        let mut x = vec![[0.0f64; LANES]; n];
        let mut lane = vec![vec![0.0f64; n]; LANES];
        let mut zc = Vec::new();
        for j0 in (0..count).step_by(LANES) {
            let js: [usize; LANES] = std::array::from_fn(|l| (j0 + l).min(count - 1));
            lu.factor(d, &e, js.map(|j| shift[j]), tiny);
            start(&mut x, js);
            for _ in 0..2 {
                lu.solve(&mut x);
                orthonormalize(&mut x, js, &first, &zc, &mut lane);
            }
            for (l, v) in lane.iter().enumerate() {
                if l == 0 || js[l] != js[l - 1] {
                    zc.extend_from_slice(v);
                }
            }
        }
        zc
    }

    /// The portable row steps, whatever the CPU: the reference for the AVX2 ones.
    fn factor_portable(lu: &mut TridiagonalLu, d: &[f64], e: &[f64], lam: [f64; LANES], tiny: f64) {
        lu.prepare(d, e, lam);
        for i in 0..d.len() - 1 {
            lu.eliminate(i, tiny);
        }
        lu.finish(tiny);
    }

    fn solve_portable(lu: &TridiagonalLu, b: &mut [[f64; LANES]]) {
        let n = b.len();
        for i in 0..n - 1 {
            lu.forward(b, i);
        }
        lu.last_rows(b);
        for i in (0..n.saturating_sub(2)).rev() {
            lu.backward(b, i);
        }
    }

    /// Bit-identical, or both NaN (which NaN an operation with two NaN operands
    /// returns depends on the operand order the compiler picks; the solver rejects
    /// non-finite input before it gets here).
    fn same_bits(a: &[[f64; LANES]], b: &[[f64; LANES]]) -> bool {
        a.iter()
            .flatten()
            .zip(b.iter().flatten())
            .all(|(x, y)| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()))
    }

    /// Factorisations (one to four interleaved) and solves (alone and in pairs) give
    /// the portable steps' bits, on the build this CPU runs — the AVX2 intrinsics
    /// where it has them — at shifts on eigenvalues (pivots floored at `tiny`),
    /// between them, and with a NaN shift.
    #[test]
    fn factor_and_solve_give_the_portable_bits() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut checked = 0;
        for (d, e, name) in hard_tridiagonals() {
            let n = d.len();
            if n < 2 {
                continue;
            }
            let lam = ql_eigenvalues(&d, &e).unwrap();
            let tiny = f64::EPSILON * infinity_norm(&d, &e).max(f64::MIN_POSITIVE);
            let shifts: Vec<[f64; LANES]> = vec![
                std::array::from_fn(|l| lam[l.min(n - 1)]),
                std::array::from_fn(|l| lam[(n - 1).saturating_sub(l)]),
                std::array::from_fn(|_| rng.gen_range(-3.0..3.0)),
                [0.0, lam[0], f64::NAN, lam[n / 2]],
            ];
            for k in 1..=FACTOR_BATCH {
                let lams: Vec<[f64; LANES]> = (0..k).map(|q| shifts[q % shifts.len()]).collect();
                let mut got: Vec<TridiagonalLu> = (0..k).map(|_| TridiagonalLu::new(n)).collect();
                let mut refs: Vec<&mut TridiagonalLu> = got.iter_mut().collect();
                TridiagonalLu::factor_many(&mut refs, &lams, &d, &e, tiny);
                for (q, lu) in got.iter().enumerate() {
                    let mut want = TridiagonalLu::new(n);
                    factor_portable(&mut want, &d, &e, lams[q], tiny);
                    assert!(
                        same_bits(&lu.dinv, &want.dinv)
                            && same_bits(&lu.dl, &want.dl)
                            && same_bits(&lu.du, &want.du)
                            && same_bits(&lu.du2, &want.du2)
                            && lu.swap == want.swap,
                        "{name} n={n}: factor {q} of {k}"
                    );
                    let rhs: Vec<[f64; LANES]> = (0..n)
                        .map(|_| std::array::from_fn(|_| rng.gen_range(-1.0..1.0)))
                        .collect();
                    let mut x = rhs.clone();
                    lu.solve(&mut x);
                    let mut y = rhs.clone();
                    solve_portable(&want, &mut y);
                    assert!(same_bits(&x, &y), "{name} n={n}: solve {q} of {k}");
                    let (mut xa, mut xb) =
                        (rhs.clone(), rhs.iter().rev().copied().collect::<Vec<_>>());
                    let mut yb = xb.clone();
                    TridiagonalLu::solve_pair(lu, &mut xa, &want, &mut xb);
                    solve_portable(&want, &mut yb);
                    assert!(
                        same_bits(&xa, &y) && same_bits(&xb, &yb),
                        "{name} n={n}: pair"
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 100, "{checked}");
    }

    #[test]
    fn pipelined_vectors_match_group_by_group() {
        let mut cases = hard_tridiagonals();
        // Nine identical blocks split by exact zeros: clusters of nine vectors that
        // span three groups, so a group's first Gram–Schmidt reads the vectors the
        // previous group has just finished.
        let (mut d, mut e) = (Vec::new(), Vec::new());
        for b in 0..9 {
            if b > 0 {
                e.push(0.0);
            }
            d.extend([1.0, 0.5, 0.25]);
            e.extend([0.3, -0.7]);
        }
        cases.push((d, e, "nine blocks"));
        let mut checked = 0;
        for (d, e, name) in cases {
            let n = d.len();
            if n < 2 {
                continue;
            }
            let lam = ql_eigenvalues(&d, &e).unwrap();
            let mut counts: Vec<usize> = (1..=n.min(27)).collect();
            counts.extend([n / 2, n - 1, n]);
            for count in counts {
                let count = count.max(1);
                let want = vectors_group_by_group(&d, &e, &lam, count);
                let got = tridiagonal_vectors_by_column(&d, &e, &lam, count);
                assert_eq!(got.len(), n * count, "{name} count {count}");
                assert!(
                    got.iter()
                        .zip(&want)
                        .all(|(a, b)| a.to_bits() == b.to_bits()),
                    "{name} n={n} count={count}: pipelined vectors differ"
                );
                checked += 1;
            }
        }
        assert!(checked > 100, "{checked}");
    }

    #[test]
    fn reads_the_lower_triangle_and_rejects_non_finite() {
        let mut a = random_symmetric(8, 10);
        let (l1, e1) = symmetric_evd(a.as_ref()).unwrap();
        a[(0, 5)] = 1e9; // upper triangle: ignored
        let (l2, e2) = symmetric_evd(a.as_ref()).unwrap();
        assert_eq!(l1, l2);
        assert_eq!(e1, e2);
        a[(5, 0)] = f64::NAN;
        assert!(symmetric_evd(a.as_ref()).is_none());
    }

    #[test]
    fn fused_back_transform_gives_the_reference_bits() {
        // Random reflectors (some τ = 0, as for an already tridiagonal column) applied
        // to random row-major Z of every count.
        let mut rng = ChaCha8Rng::seed_from_u64(21);
        for n in [1usize, 2, 3, 5, 8, 17, 40] {
            for count in [0usize, 1, 3, n] {
                let a: Vec<f64> = (0..n * n).map(|_| rng.gen_range(-1.0..1.0)).collect();
                let tau: Vec<f64> = (0..n)
                    .map(|k| {
                        if k % 3 == 1 {
                            0.0
                        } else {
                            rng.gen_range(0.5..1.5)
                        }
                    })
                    .collect();
                let z0: Vec<f64> = (0..n * count).map(|_| rng.gen_range(-1.0..1.0)).collect();
                let (mut z1, mut z2) = (z0.clone(), z0);
                back_transform(&mut z1, n, count, &a, &tau);
                back_transform_reference(&mut z2, n, count, &a, &tau);
                let bits = |z: &[f64]| z.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&z1), bits(&z2), "n {n} count {count}");
            }
        }
    }

    #[test]
    fn the_portable_path_gives_the_same_bits() {
        let a = random_symmetric(37, 11);
        let mut w1 = vec![0.0; 37 * 37];
        for j in 0..37 {
            for i in 0..37 {
                w1[i + 37 * j] = a[(i, j)] * 0.5;
            }
        }
        let mut w2 = w1.clone();
        assert_eq!(dispatch(&mut w1, 37, &|_| 37), evd(&mut w2, 37, &|_| 37));
    }
}
