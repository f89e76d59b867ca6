//! All eigenpairs of a real symmetric tridiagonal matrix, `T = Z Λ Zᵀ` (n×n, Λ
//! ascending, Z orthonormal), by divide and conquer in the manner of LAPACK's
//! `dstedc`: step 3 of [`crate::spectral::blocked_evd`] (the dense eigensolver of the
//! paper's Fig. 3 and of every dense ED transform).
//!
//! **Method** (Cuppen 1981; Gu & Eisenstat 1995; LAPACK `dstedc`, `dlaed0`–`dlaed6`;
//! Li 1993 for the secular equation):
//! 1. Split `T` where an off-diagonal entry is negligible
//!    (`|e_i| ≤ ε √|d_i| √|d_{i+1}|`, as `dstedc`) and scale each unreduced block by a
//!    power of two (exact) so that its largest entry is in `[1, 2)`.
//! 2. Tear a block in the middle: `T = diag(T₁, T₂) + β v vᵀ` with
//!    `v = e_{n₁} + sign(β) e_{n₁+1}` (the last diagonal entry of `T₁` and the first
//!    of `T₂` lose `|β|`). Solve the halves recursively (in parallel with
//!    `rayon::join` when `par` has more than one thread); blocks of at most [`LEAF`]
//!    rows are solved by the implicit QL algorithm with Wilkinson shifts, the
//!    rotations accumulated into the block of `Z` (`dsteqr`), through the CPU
//!    dispatch so that the rotations run in vector registers; each rotation's norm
//!    is `√(f² + g²)` in `dlartg`'s safe range, libm's `hypot` outside it.
//! 3. Merge (`dlaed1`): `diag(T₁, T₂) = Q D Qᵀ` with `Q = diag(Q₁, Q₂)`, so
//!    `T = Q (D + ρ z zᵀ) Qᵀ` with `z = Qᵀ v / √2` (the last row of `Q₁`, the first
//!    row of `Q₂`), `ρ = 2|β|`. Deflate (`dlaed2`): a component with `ρ|z_i| ≤ tol`
//!    leaves `d_i` an eigenvalue and `Q e_i` its eigenvector; two close `d_i, d_j` are
//!    made one by a Givens rotation of their columns of `Q` that zeroes `z_i`
//!    (`tol = 8ε max(|d|, |z|)`). The remaining columns are grouped by where they are
//!    nonzero (only in the top half, in both, only in the bottom half).
//! 4. Each of the k undeflated eigenvalues `λ_j` of `D + ρ z zᵀ` is the root in
//!    `(d_j, d_{j+1})` of the secular equation `1/ρ + Σ_i z_i² / (d_i − λ) = 0`,
//!    found by Li's middle way with two- and three-pole rational interpolation
//!    (`dlaed4`, `dlaed5`, `dlaed6`, after Gragg, Thornton & Warner), with the root held
//!    as origin (`d_j` or `d_{j+1}`) plus offset so that every `d_i − λ_j` is accurate.
//! 5. `ẑ` from the computed roots by Löwner's formula
//!    `ẑ_i² = −∏_j (d_i − λ_j) / ∏_{j≠i} (d_i − d_j)` (Gu & Eisenstat), so that the
//!    eigenvectors `(d_i − λ_j)⁻¹ ẑ_i` (normalised) of the rank-one update are
//!    orthogonal to working accuracy whatever the gaps (`dlaed3`).
//!
//!    Steps 4 and 5 divide once per pole and root, O(k²) divisions per merge: their
//!    loops (the kernels `PoleSums`, `Lowner` and `Normalise`) run through meshlap's
//!    CPU dispatch ([`crate::cpu`]) in four lanes. `Lowner` is left to LLVM, which
//!    vectorises it; `PoleSums` and `Normalise` are written with AVX2 intrinsics,
//!    since LLVM left their divisions scalar on both vector builds. The baseline
//!    x86-64 build divides one lane at a time. The same bits on every build.
//! 6. The undeflated eigenvectors of `T` are `Q` times those, as two matrix products
//!    (`faer::linalg::matmul::matmul` with `par`), each only over the rows of its half
//!    and the columns nonzero there; the deflated ones stay where they are, or move
//!    once into a column freed by an undeflated one.
//!
//! **Why by hand.** faer's `tridiagonal_self_adjoint_evd` is a divide and conquer of
//! the same family, but its merge forms the full n×n matrix of rank-one eigenvectors,
//! a zero column with a one for every deflated eigenvalue included, and multiplies the
//! whole block-diagonal `diag(Q₁, Q₂)` by it: the deflated columns and the zero blocks
//! cost as much as the rest, and LAPACK's merge skips both. The better home for this
//! merge is a contribution to faer.
//!
//! **Sign convention.** Any symmetric tridiagonal matrix is accepted; meshlap's
//! operators are positive semi-definite, `F = D − W` as in the paper (libigl and pmp
//! use the negative), so their tridiagonal forms have eigenvalues ≥ 0 and the first
//! column of `Z` belongs to the smoothest vector.
//!
//! References: J. J. M. Cuppen, *A divide and conquer method for the symmetric
//! tridiagonal eigenproblem*, Numer. Math. 36 (1981); M. Gu & S. C. Eisenstat, *A
//! divide-and-conquer algorithm for the symmetric tridiagonal eigenproblem*, SIAM J.
//! Matrix Anal. Appl. 16 (1995); R.-C. Li, *Solving secular equations stably and
//! efficiently*, LAPACK Working Note 89 (1993).

use faer::linalg::matmul::matmul;
use faer::prelude::{Reborrow, ReborrowMut};
use faer::{Accum, Mat, MatMut, MatRef, Par};

/// Blocks of at most this many rows are solved by the implicit QL algorithm.
/// LAPACK's default `SMLSIZ` for `dstedc` is 25; leaves of 64 made the divide and
/// conquer faster at n = 500–2903 (BENCHMARKS.md, "Spectra", forty-ninth session, on
/// an Intel Xeon): two levels fewer of merges, each with its secular equations,
/// Löwner products and matrix products, for QL sweeps on larger leaves. Under Miri
/// 8, and the two thresholds below 24 and 16 (RELIABILITY.md), so that matrices small
/// enough to interpret reach the merges and the parallel paths.
pub const LEAF: usize = if cfg!(miri) { 8 } else { 64 };

/// Below this block size the two halves are solved one after the other even when
/// `par` has several threads.
const PAR_SPLIT: usize = if cfg!(miri) { 24 } else { 192 };

/// Below this number of undeflated roots the secular equations are solved on one
/// thread.
const PAR_ROOTS: usize = if cfg!(miri) { 16 } else { 128 };

/// Iterations allowed per root of the secular equation (LAPACK's `MAXIT`).
const SECULAR_MAXIT: usize = 30;

/// Why [`tridiagonal_evd`] returned no decomposition.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TridiagonalEvdError {
    /// The off-diagonal does not have one entry fewer than the diagonal.
    ///
    /// Cause: the subdiagonal was passed with n entries (some routines, e.g. faer's,
    /// store a trailing zero) or cut short. Fix: pass `&offdiag[..n - 1]`.
    #[error("the off-diagonal has {offdiag} entries; a diagonal of {diag} needs {expected}")]
    ShapeMismatch {
        /// Diagonal entries.
        diag: usize,
        /// Off-diagonal entries given.
        offdiag: usize,
        /// Off-diagonal entries expected (`max(diag, 1) − 1`).
        expected: usize,
    },
    /// An entry is NaN or infinite.
    ///
    /// Cause: the matrix being reduced had a non-finite entry, or its reduction
    /// overflowed. Fix: check the operator (degenerate faces give infinite cotangent
    /// weights), or scale it.
    #[error("{part} entry #{index} is not finite ({value})")]
    NonFinite {
        /// `"diagonal"` or `"off-diagonal"`.
        part: &'static str,
        /// Index into that part.
        index: usize,
        /// The entry.
        value: f64,
    },
    /// An iteration did not converge: the implicit QL algorithm on a leaf block
    /// (30 sweeps per eigenvalue) or the secular equation of a merge (30 steps per
    /// root).
    ///
    /// Cause: should not happen on finite input; it points at a matrix whose
    /// entries span nearly the whole floating-point range. Fix: rescale the
    /// operator, or fall back to `faer::linalg::evd::tridiagonal_self_adjoint_evd`.
    #[error("the {stage} did not converge")]
    NoConvergence {
        /// `"implicit QL"` or `"secular equation"`.
        stage: &'static str,
    },
}

const QL_FAILED: TridiagonalEvdError = TridiagonalEvdError::NoConvergence {
    stage: "implicit QL",
};
const SECULAR_FAILED: TridiagonalEvdError = TridiagonalEvdError::NoConvergence {
    stage: "secular equation",
};

/// Eigenvalues (ascending) and orthonormal eigenvectors (n×n, column j for `λ_j`) of
/// the symmetric tridiagonal matrix with diagonal `diag` (n entries) and off-diagonal
/// `offdiag` (n − 1 entries, `T[i+1, i] = T[i, i+1] = offdiag[i]`). `par` is the
/// parallelism of the merge's products, of the secular equations and of the
/// recursion. Never panics; an error for a shape mismatch, a non-finite entry or
/// (should not happen) an iteration that does not converge.
pub fn tridiagonal_evd(
    diag: &[f64],
    offdiag: &[f64],
    par: Par,
) -> Result<(Vec<f64>, Mat<f64>), TridiagonalEvdError> {
    let n = diag.len();
    let expected = n.saturating_sub(1);
    if offdiag.len() != expected {
        return Err(TridiagonalEvdError::ShapeMismatch {
            diag: n,
            offdiag: offdiag.len(),
            expected,
        });
    }
    for (part, xs) in [("diagonal", diag), ("off-diagonal", offdiag)] {
        if let Some(index) = xs.iter().position(|x| !x.is_finite()) {
            return Err(TridiagonalEvdError::NonFinite {
                part,
                index,
                value: xs[index],
            });
        }
    }
    let mut d = diag.to_vec();
    let mut e = offdiag.to_vec();
    let mut z = Mat::<f64>::zeros(n, n);
    // Unreduced blocks [start, end).
    let mut blocks = Vec::new();
    let mut start = 0;
    for i in 0..n {
        let split =
            i + 1 == n || e[i].abs() <= f64::EPSILON * d[i].abs().sqrt() * d[i + 1].abs().sqrt();
        if split {
            if i + 1 < n {
                e[i] = 0.0;
            }
            blocks.push((start, i + 1));
            start = i + 1;
        }
    }
    let largest = blocks.iter().map(|&(s, t)| t - s).max().unwrap_or(0);
    let (mut q2, mut sbuf, mut indxq) = if largest > LEAF {
        (
            vec![0.0f64; largest * largest],
            vec![0.0f64; largest * largest],
            vec![0usize; largest],
        )
    } else {
        (Vec::new(), Vec::new(), Vec::new())
    };
    for &(s, t) in &blocks {
        let m = t - s;
        let mut qb = z.as_mut().submatrix_mut(s, s, m, m);
        if m == 1 {
            qb[(0, 0)] = 1.0;
            continue;
        }
        let db = &mut d[s..t];
        let eb = &mut e[s..t - 1];
        let amax = db
            .iter()
            .chain(eb.iter())
            .fold(0.0f64, |a, x| a.max(x.abs()));
        // amax > 0: an unreduced block has a nonzero off-diagonal entry.
        let (scale, unscale) = super::dense_evd::power_of_two_scaling(amax);
        db.iter_mut().chain(eb.iter_mut()).for_each(|x| *x *= scale);
        if m <= LEAF {
            leaf(db, eb, qb)?;
        } else {
            divide_and_conquer(
                db,
                eb,
                qb,
                &mut indxq[..m],
                &mut q2[..m * m],
                &mut sbuf[..m * m],
                par,
            )?;
        }
        db.iter_mut().for_each(|x| *x *= unscale);
    }
    let mut perm: Vec<usize> = (0..n).collect();
    perm.sort_by(|&a, &b| d[a].total_cmp(&d[b]));
    let lam: Vec<f64> = perm.iter().map(|&p| d[p]).collect();
    permute_columns(z.as_mut(), &perm);
    if lam.iter().any(|x| !x.is_finite()) {
        return Err(SECULAR_FAILED);
    }
    Ok((lam, z))
}

/// Column j of `q` ← old column `perm[j]` (n×n, columns contiguous), in place: each
/// cycle of the permutation through one spare column.
fn permute_columns(mut q: MatMut<'_, f64>, perm: &[usize]) {
    let n = perm.len();
    let mut done = vec![false; n];
    let mut spare = vec![0.0f64; q.nrows()];
    for start in 0..n {
        if done[start] || perm[start] == start {
            continue;
        }
        spare.copy_from_slice(col(q.rb(), start));
        let mut j = start;
        loop {
            done[j] = true;
            let p = perm[j];
            if p == start {
                col_mut(q.rb_mut(), j).copy_from_slice(&spare);
                break;
            }
            let (dst, src) = q.rb_mut().two_cols_mut(j, p);
            dst.try_as_col_major_mut()
                .expect("contiguous")
                .as_slice_mut()
                .copy_from_slice(src.rb().try_as_col_major().expect("contiguous").as_slice());
            j = p;
        }
    }
}

/// Splits a thread budget between the two halves of a recursion.
fn split_par(par: Par) -> (Par, Par) {
    let t = par.degree();
    let mk = |t: usize| if t <= 1 { Par::Seq } else { Par::rayon(t) };
    (mk(t / 2), mk(t - t / 2))
}

/// `dlaed0` (recursively): the eigenpairs of the unreduced block `(d, e)` (m and
/// m − 1 entries, scaled to `max ≤ 2`) into `q` (m×m, zero on entry, columns
/// contiguous). On return `d[i]` is the eigenvalue of column i of `q`, and
/// `d[indxq[0]] ≤ d[indxq[1]] ≤ …`. `q2` and `sbuf` are workspaces of m² entries.
fn divide_and_conquer(
    d: &mut [f64],
    e: &[f64],
    mut q: MatMut<'_, f64>,
    indxq: &mut [usize],
    q2: &mut [f64],
    sbuf: &mut [f64],
    par: Par,
) -> Result<(), TridiagonalEvdError> {
    let m = d.len();
    if m <= LEAF {
        leaf(d, e, q)?;
        indxq.iter_mut().enumerate().for_each(|(i, x)| *x = i);
        return Ok(());
    }
    let n1 = m / 2;
    let n2 = m - n1;
    let beta = e[n1 - 1];
    d[n1 - 1] -= beta.abs();
    d[n1] -= beta.abs();
    {
        let (d0, d1) = d.split_at_mut(n1);
        let (e0, e1) = (&e[..n1 - 1], &e[n1..]);
        let (q0, _, _, q1) = q.rb_mut().split_at_mut(n1, n1);
        let (i0, i1) = indxq.split_at_mut(n1);
        let (w0, w1) = q2.split_at_mut(n1 * n1);
        let w1 = &mut w1[..n2 * n2];
        let (s0, s1) = sbuf.split_at_mut(n1 * n1);
        let s1 = &mut s1[..n2 * n2];
        if par.degree() > 1 && m >= PAR_SPLIT {
            let (p0, p1) = split_par(par);
            let (r0, r1) = rayon::join(
                || divide_and_conquer(d0, e0, q0, i0, w0, s0, p0),
                || divide_and_conquer(d1, e1, q1, i1, w1, s1, p1),
            );
            r0?;
            r1?;
        } else {
            divide_and_conquer(d0, e0, q0, i0, w0, s0, Par::Seq)?;
            divide_and_conquer(d1, e1, q1, i1, w1, s1, Par::Seq)?;
        }
    }
    merge(d, q, indxq, beta, n1, q2, sbuf, par)
}

/// The contiguous column `j` of `q`.
fn col(q: MatRef<'_, f64>, j: usize) -> &[f64] {
    q.col(j)
        .try_as_col_major()
        .expect("columns are contiguous")
        .as_slice()
}

/// The contiguous column `j` of `q`, mutable.
fn col_mut(q: MatMut<'_, f64>, j: usize) -> &mut [f64] {
    q.col_mut(j)
        .try_as_col_major_mut()
        .expect("columns are contiguous")
        .as_slice_mut()
}

/// `dlaed1`–`dlaed3`: merges the solved halves `q = diag(Q₁, Q₂)` (n₁ and n − n₁
/// rows; `d` their eigenvalues, each half sorted through `indxq`, local to the half)
/// across the tear `β`. On return `q` holds the eigenvectors of the whole block, `d`
/// the eigenvalues (undeflated first), `indxq` their ascending order.
#[allow(clippy::too_many_arguments)]
fn merge(
    d: &mut [f64],
    mut q: MatMut<'_, f64>,
    indxq: &mut [usize],
    beta: f64,
    n1: usize,
    q2: &mut [f64],
    sbuf: &mut [f64],
    par: Par,
) -> Result<(), TridiagonalEvdError> {
    let n = d.len();
    let n2 = n - n1;
    // z = Qᵀ v / √2, ρ = 2|β|.
    let mut z = vec![0.0f64; n];
    for (j, zj) in z.iter_mut().enumerate() {
        let r = if j < n1 { n1 - 1 } else { n1 };
        *zj = q[(r, j)];
    }
    if beta < 0.0 {
        z[n1..].iter_mut().for_each(|x| *x = -*x);
    }
    z.iter_mut()
        .for_each(|x| *x *= std::f64::consts::FRAC_1_SQRT_2);
    let rho = (2.0 * beta).abs();
    // The merged ascending order of d.
    indxq[n1..].iter_mut().for_each(|x| *x += n1);
    let indx = merge_sorted(d, &indxq[..n1], &indxq[n1..]);
    let zmax = z.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    let dmax = d.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    let tol = 8.0 * f64::EPSILON * dmax.max(zmax);
    if rho * zmax <= tol {
        indxq.copy_from_slice(&indx);
        return Ok(());
    }

    // dlaed2: deflation. coltyp 1: nonzero only in the top n1 rows, 2: in both, 3:
    // only in the bottom, 4: deflated.
    let mut coltyp: Vec<u8> = (0..n).map(|i| if i < n1 { 1 } else { 3 }).collect();
    let mut dlamda = Vec::with_capacity(n);
    let mut w = Vec::with_capacity(n);
    let mut indxp = vec![0usize; n];
    let mut k = 0usize;
    let mut k2 = n;
    let mut prev: Option<usize> = None;
    for &nj in &indx {
        if rho * z[nj].abs() <= tol {
            k2 -= 1;
            coltyp[nj] = 4;
            indxp[k2] = nj;
            continue;
        }
        let Some(pj) = prev else {
            prev = Some(nj);
            continue;
        };
        let tau = z[nj].hypot(z[pj]);
        let t = d[nj] - d[pj];
        let c = z[nj] / tau;
        let s = -z[pj] / tau;
        if (t * c * s).abs() <= tol {
            // Close pair: rotate z[pj] into z[nj].
            z[nj] = tau;
            z[pj] = 0.0;
            if coltyp[nj] != coltyp[pj] {
                coltyp[nj] = 2;
            }
            coltyp[pj] = 4;
            {
                let (x, y) = q.rb_mut().two_cols_mut(pj, nj);
                let x = x.try_as_col_major_mut().expect("contiguous").as_slice_mut();
                let y = y.try_as_col_major_mut().expect("contiguous").as_slice_mut();
                for (a, b) in x.iter_mut().zip(y.iter_mut()) {
                    let (xa, yb) = (*a, *b);
                    *a = c * xa + s * yb;
                    *b = c * yb - s * xa;
                }
            }
            let t = d[pj] * c * c + d[nj] * s * s;
            d[nj] = d[pj] * s * s + d[nj] * c * c;
            d[pj] = t;
            k2 -= 1;
            let mut i = 1;
            loop {
                if k2 + i < n && d[pj] < d[indxp[k2 + i]] {
                    indxp[k2 + i - 1] = indxp[k2 + i];
                    indxp[k2 + i] = pj;
                    i += 1;
                } else {
                    indxp[k2 + i - 1] = pj;
                    break;
                }
            }
        } else {
            dlamda.push(d[pj]);
            w.push(z[pj]);
            indxp[k] = pj;
            k += 1;
        }
        prev = Some(nj);
    }
    if let Some(pj) = prev {
        dlamda.push(d[pj]);
        w.push(z[pj]);
        indxp[k] = pj;
        k += 1;
    }
    debug_assert_eq!(k, k2);

    // Group the columns by type (in indxp order within a type).
    let mut ctot = [0usize; 4];
    for &c in &coltyp {
        ctot[c as usize - 1] += 1;
    }
    let mut psm = [0, ctot[0], ctot[0] + ctot[1], ctot[0] + ctot[1] + ctot[2]];
    let mut grouped = vec![0usize; n];
    let mut indxc = vec![0usize; n];
    for (j, &js) in indxp.iter().enumerate() {
        let ct = coltyp[js] as usize - 1;
        grouped[psm[ct]] = js;
        indxc[psm[ct]] = j;
        psm[ct] += 1;
    }
    let n12 = ctot[0] + ctot[1];
    let n23 = ctot[1] + ctot[2];
    let (qtop, rest) = q2.split_at_mut(n1 * n12);
    let qbot = &mut rest[..n2 * n23];
    for (i, &js) in grouped[..k].iter().enumerate() {
        let src = col(q.rb(), js);
        let ct = coltyp[js];
        if ct == 1 || ct == 2 {
            qtop[i * n1..(i + 1) * n1].copy_from_slice(&src[..n1]);
        }
        if ct == 2 || ct == 3 {
            let ib = i - ctot[0];
            qbot[ib * n2..(ib + 1) * n2].copy_from_slice(&src[n1..]);
        }
    }
    // The deflated eigenvectors go to columns k..n. Those already there stay (unlike
    // `dlaed2`, which copies every one out and back); each one left of k moves into a
    // column ≥ k freed by an undeflated one (copied to `q2` above).
    let mut dtail = vec![0.0f64; n - k];
    let mut free = grouped[..k].iter().copied().filter(|&js| js >= k);
    for &js in &grouped[k..] {
        if js >= k {
            dtail[js - k] = d[js];
        } else {
            let slot = free.next().expect("as many free columns as movers");
            let (src, dst) = q.rb_mut().two_cols_mut(js, slot);
            dst.try_as_col_major_mut()
                .expect("contiguous")
                .as_slice_mut()
                .copy_from_slice(src.rb().try_as_col_major().expect("contiguous").as_slice());
            dtail[slot - k] = d[js];
        }
    }
    d[k..].copy_from_slice(&dtail);

    // dlaed3: the roots, ẑ by Löwner's formula, the eigenvectors of D + ρ ẑ ẑᵀ.
    let s = &mut sbuf[..k * k];
    let mut lam = vec![0.0f64; k];
    let solve = |(j, (col, lam)): (usize, (&mut [f64], &mut f64))| -> Result<(), ()> {
        *lam = secular_root(j, &dlamda, &w, col, rho)?;
        Ok(())
    };
    let ok = if par.degree() > 1 && k >= PAR_ROOTS {
        use rayon::prelude::*;
        s.par_chunks_mut(k)
            .zip(lam.par_iter_mut())
            .enumerate()
            .map(solve)
            .collect::<Result<Vec<()>, ()>>()
    } else {
        s.chunks_mut(k)
            .zip(lam.iter_mut())
            .enumerate()
            .map(solve)
            .collect::<Result<Vec<()>, ()>>()
    };
    ok.map_err(|()| SECULAR_FAILED)?;
    if k == 1 {
        s[0] = 1.0;
    } else if k == 2 {
        for c in s.chunks_mut(2) {
            let v = [c[0], c[1]];
            c[0] = v[indxc[0]];
            c[1] = v[indxc[1]];
        }
    } else {
        let mut what: Vec<f64> = (0..k).map(|i| s[i * k + i]).collect();
        crate::cpu::dispatch(Lowner {
            s,
            dlamda: &dlamda,
            what: &mut what,
        });
        for (wh, wi) in what.iter_mut().zip(&w) {
            *wh = (-*wh).sqrt().copysign(*wi);
        }
        let normalise = |c: &mut [f64], v: &mut Vec<f64>| {
            v.resize(k, 0.0);
            crate::cpu::dispatch(Normalise {
                what: &what,
                c,
                v,
                order: &indxc[..k],
            });
        };
        if par.degree() > 1 && k >= PAR_ROOTS {
            use rayon::prelude::*;
            s.par_chunks_mut(k)
                .for_each_with(Vec::new(), |v, c| normalise(c, v));
        } else {
            let mut v = Vec::new();
            s.chunks_mut(k).for_each(|c| normalise(c, &mut v));
        }
    }
    let s = MatRef::from_column_major_slice(&*s, k, k);
    let (top, bot) = q.rb_mut().split_at_row_mut(n1);
    let (top, _) = top.split_at_col_mut(k);
    let (bot, _) = bot.split_at_col_mut(k);
    for (mut dst, src, rows, inner, r0) in
        [(top, &*qtop, n1, n12, 0), (bot, &*qbot, n2, n23, ctot[0])]
    {
        if inner == 0 {
            dst.fill(0.0);
        } else {
            matmul(
                dst,
                Accum::Replace,
                MatRef::from_column_major_slice(src, rows, inner),
                s.subrows(r0, inner),
                1.0,
                par,
            );
        }
    }
    d[..k].copy_from_slice(&lam);
    indxq.iter_mut().enumerate().for_each(|(i, x)| *x = i);
    indxq.sort_by(|&a, &b| d[a].total_cmp(&d[b]));
    Ok(())
}

/// Löwner's products of `dlaed3`: `ŵ_i ← ŵ_i ∏_{j≠i} (d_i − λ_j) / (d_i − d_j)`,
/// where `d` are the undeflated poles (`dlamda`), column j of `s` (k×k,
/// column-major) holds `d_i − λ_j` for the j-th root `λ_j` of the secular equation,
/// and `ŵ_i` starts as `d_i − λ_i`; the caller then takes `ẑ_i = ±√(−ŵ_i)`. Each
/// `ŵ_i` takes its factors in the order of j, so the loops over i vectorise with the
/// same bits on every build ([`crate::cpu::dispatch`]).
struct Lowner<'a> {
    s: &'a [f64],
    dlamda: &'a [f64],
    what: &'a mut [f64],
}

impl crate::cpu::Kernel for Lowner<'_> {
    type Output = ();

    #[inline(always)]
    fn portable(self) {
        let k = self.dlamda.len();
        for j in 0..k {
            let c = &self.s[j * k..(j + 1) * k];
            let dj = self.dlamda[j];
            let (w0, w1) = self.what.split_at_mut(j);
            for ((wi, ci), li) in w0.iter_mut().zip(&c[..j]).zip(&self.dlamda[..j]) {
                *wi *= ci / (li - dj);
            }
            for ((wi, ci), li) in w1[1..]
                .iter_mut()
                .zip(&c[j + 1..])
                .zip(&self.dlamda[j + 1..])
            {
                *wi *= ci / (li - dj);
            }
        }
    }
}

/// One eigenvector of `D + ρ ẑ ẑᵀ` (`dlaed3`) from its column `c`, which holds
/// `d_i − λ` for its root λ: `v_i = ẑ_i / (d_i − λ)`, normalised, written back into
/// `c` in the order `order` (`c_j ← v_{order_j} / ‖v‖`, the grouped columns of `Q`).
/// The norm is summed in four lanes, so that the divisions and the sum vectorise
/// ([`crate::cpu::dispatch`]); `v` is k entries of workspace.
struct Normalise<'a> {
    what: &'a [f64],
    c: &'a mut [f64],
    v: &'a mut [f64],
    order: &'a [usize],
}

impl crate::cpu::Kernel for Normalise<'_> {
    type Output = ();

    #[inline(always)]
    fn portable(self) {
        let mut lanes = [0.0f64; 4];
        let k4 = self.what.len() / 4 * 4;
        for ((vc, wc), cc) in self.v[..k4]
            .chunks_exact_mut(4)
            .zip(self.what[..k4].chunks_exact(4))
            .zip(self.c[..k4].chunks_exact(4))
        {
            for l in 0..4 {
                let x = wc[l] / cc[l];
                vc[l] = x;
                lanes[l] += x * x;
            }
        }
        normalise_tail(self, k4, lanes);
    }

    /// The same lanes and the same operations as [`Self::portable`], in AVX2
    /// registers: LLVM leaves the portable loop's divisions scalar (`vdivsd`) in both
    /// vector builds.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn avx2_fma(self) {
        use std::arch::x86_64::*;
        let k4 = self.what.len() / 4 * 4;
        let (what, c) = (&self.what[..k4], &self.c[..k4]);
        let v = &mut self.v[..k4];
        let mut lanes = [0.0f64; 4];
        // SAFETY: every access is at i..i + 4 with i + 4 <= k4, the length of what, c
        // and v here; the caller is compiled with AVX2.
        unsafe {
            let mut acc = _mm256_setzero_pd();
            let mut i = 0;
            while i < k4 {
                let x = _mm256_div_pd(
                    _mm256_loadu_pd(what.as_ptr().add(i)),
                    _mm256_loadu_pd(c.as_ptr().add(i)),
                );
                _mm256_storeu_pd(v.as_mut_ptr().add(i), x);
                acc = _mm256_add_pd(acc, _mm256_mul_pd(x, x));
                i += 4;
            }
            _mm256_storeu_pd(lanes.as_mut_ptr(), acc);
        }
        normalise_tail(self, k4, lanes);
    }
}

/// The end of both builds of [`Normalise`]: the entries past the last group of four
/// (`k4..`) added into lane 0, the lanes summed pairwise, and the normalised vector
/// written back in the given order.
#[inline(always)]
fn normalise_tail(k: Normalise<'_>, k4: usize, mut lanes: [f64; 4]) {
    let Normalise { what, c, v, order } = k;
    for i in k4..what.len() {
        let x = what[i] / c[i];
        v[i] = x;
        lanes[0] += x * x;
    }
    let inv = 1.0 / ((lanes[0] + lanes[1]) + (lanes[2] + lanes[3])).sqrt();
    for (ci, &ii) in c.iter_mut().zip(order) {
        *ci = v[ii] * inv;
    }
}

/// Merges two index lists, each ascending in `d`, into one (`dlamrg`).
fn merge_sorted(d: &[f64], a: &[usize], b: &[usize]) -> Vec<usize> {
    let mut out = Vec::with_capacity(a.len() + b.len());
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        if d[a[i]] <= d[b[j]] {
            out.push(a[i]);
            i += 1;
        } else {
            out.push(b[j]);
            j += 1;
        }
    }
    out.extend_from_slice(&a[i..]);
    out.extend_from_slice(&b[j..]);
    out
}

/// `dsteqr` for a leaf: the eigenpairs of the tridiagonal `(d, e)` (m, m − 1
/// entries) by the implicit QL algorithm with Wilkinson shifts (Golub & Van Loan
/// §8.3; the `tqli` form), the rotations accumulated into `q` (m×m, set to the
/// identity here). On return `d` is ascending and column i of `q` its eigenvector.
///
/// Runs through [`crate::cpu::dispatch`], so that the rotations' loop over the rows
/// runs in the widest vector build the CPU has (each row's rotation is the same two
/// products and one sum or difference on every build: the same bits).
fn leaf(d: &mut [f64], e: &[f64], q: MatMut<'_, f64>) -> Result<(), TridiagonalEvdError> {
    crate::cpu::dispatch(Leaf { d, e, q })
}

/// The arguments of [`leaf`], as a kernel of [`crate::cpu::dispatch`].
struct Leaf<'a, 'b> {
    d: &'a mut [f64],
    e: &'a [f64],
    q: MatMut<'b, f64>,
}

impl crate::cpu::Kernel for Leaf<'_, '_> {
    type Output = Result<(), TridiagonalEvdError>;

    #[inline(always)]
    fn portable(self) -> Result<(), TridiagonalEvdError> {
        let Leaf { d, e, q } = self;
        leaf_ql(d, e, q)
    }
}

/// The body of [`leaf`].
#[inline(always)]
fn leaf_ql(d: &mut [f64], e: &[f64], mut q: MatMut<'_, f64>) -> Result<(), TridiagonalEvdError> {
    let m = d.len();
    q.fill(0.0);
    for i in 0..m {
        q[(i, i)] = 1.0;
    }
    let mut e: Vec<f64> = e.iter().copied().chain(std::iter::once(0.0)).collect();
    let mut budget = 30 * m;
    for l in 0..m {
        loop {
            let mut mm = l;
            while mm + 1 < m {
                let dd = d[mm].abs() + d[mm + 1].abs();
                if e[mm].abs() <= f64::EPSILON * dd || e[mm].abs() < f64::MIN_POSITIVE {
                    break;
                }
                mm += 1;
            }
            if mm == l {
                break;
            }
            if budget == 0 {
                return Err(QL_FAILED);
            }
            budget -= 1;
            let mut g = (d[l + 1] - d[l]) / (2.0 * e[l]);
            let mut r = rotation_norm(g, 1.0);
            g = d[mm] - d[l] + e[l] / (g + r.copysign(g));
            let (mut s, mut c, mut p) = (1.0f64, 1.0f64, 0.0f64);
            let mut i = mm;
            let mut underflow = false;
            while i > l {
                i -= 1;
                let f = s * e[i];
                let b = c * e[i];
                r = rotation_norm(f, g);
                e[i + 1] = r;
                if r == 0.0 {
                    d[i + 1] -= p;
                    e[mm] = 0.0;
                    underflow = true;
                    break;
                }
                s = f / r;
                c = g / r;
                g = d[i + 1] - p;
                r = (d[i] - g) * s + 2.0 * c * b;
                p = s * r;
                d[i + 1] = g + p;
                g = c * r - b;
                let (x, y) = q.rb_mut().two_cols_mut(i, i + 1);
                let x = x.try_as_col_major_mut().expect("contiguous").as_slice_mut();
                let y = y.try_as_col_major_mut().expect("contiguous").as_slice_mut();
                for (a, b) in x.iter_mut().zip(y.iter_mut()) {
                    let f = *b;
                    *b = s * *a + c * f;
                    *a = c * *a - s * f;
                }
            }
            if underflow {
                continue;
            }
            d[l] -= p;
            e[l] = g;
            e[mm] = 0.0;
        }
    }
    if d.iter().any(|x| !x.is_finite()) {
        return Err(QL_FAILED);
    }
    // Selection sort, ascending, with the columns.
    for i in 0..m {
        let mut kmin = i;
        for j in i + 1..m {
            if d[j] < d[kmin] {
                kmin = j;
            }
        }
        if kmin != i {
            d.swap(i, kmin);
            let (x, y) = q.rb_mut().two_cols_mut(i, kmin);
            let x = x.try_as_col_major_mut().expect("contiguous").as_slice_mut();
            let y = y.try_as_col_major_mut().expect("contiguous").as_slice_mut();
            x.swap_with_slice(y);
        }
    }
    Ok(())
}

/// `√(f² + g²)`, as LAPACK's `dlartg` forms it: directly where `|f|` and `|g|` are
/// both in `(√safmin, √(safmax/2))`, so that neither square overflows or underflows
/// and the sum cannot overflow (within two ulps of `hypot`, which the tests check;
/// the same bits on every build: no fused operations), else by `f64::hypot`. libm's
/// `hypot` is a call on the leaf's critical path, once per rotation.
#[inline(always)]
fn rotation_norm(f: f64, g: f64) -> f64 {
    /// `√f64::MIN_POSITIVE`.
    const RT_MIN: f64 = 1.4916681462400413e-154;
    /// `√(f64::MAX / 2)`.
    const RT_MAX: f64 = 9.480751908109176e153;
    let (af, ag) = (f.abs(), g.abs());
    if af > RT_MIN && af < RT_MAX && ag > RT_MIN && ag < RT_MAX {
        (f * f + g * g).sqrt()
    } else {
        f.hypot(g)
    }
}

/// `dlaed4`: the `i`-th (0-based) eigenvalue `λ` of `diag(d) + ρ z zᵀ` (d strictly
/// ascending, `‖z‖ = 1`, no `z_j` zero, ρ > 0), the root of the secular equation in
/// `(d_i, d_{i+1})` (`(d_{k−1}, d_{k−1} + ρ)` for the last). `delta` (k entries)
/// receives `d_j − λ` for k ≥ 3 (accurate: computed from the nearer pole), the
/// normalised eigenvector for k = 2 (`dlaed5`) and `1` for k = 1. `Err` after
/// [`SECULAR_MAXIT`] steps.
#[allow(clippy::many_single_char_names)]
fn secular_root(i: usize, d: &[f64], z: &[f64], delta: &mut [f64], rho: f64) -> Result<f64, ()> {
    let n = d.len();
    if n == 1 {
        delta[0] = 1.0;
        return Ok(d[0] + rho * z[0] * z[0]);
    }
    if n == 2 {
        return Ok(secular_two(i, d, z, delta, rho));
    }
    let eps = f64::EPSILON;
    let rhoinv = 1.0 / rho;
    let sq = |x: f64| x * x;

    if i == n - 1 {
        // The last root, in (d[n−1], d[n−1] + ρ).
        let ii = n - 2;
        let midpt = rho / 2.0;
        // δ_j = (d_j − d_i) − ρ/2 and ψ = Σ_{j<n−2} z_j²/δ_j.
        let (psi, _, _) = pole_sums(
            &d[..n - 2],
            &z[..n - 2],
            &mut delta[..n - 2],
            d[i],
            midpt,
            0.0,
            0.0,
        );
        for j in n - 2..n {
            delta[j] = (d[j] - d[i]) - midpt;
        }
        let c = rhoinv + psi;
        let w = c + z[ii] * z[ii] / delta[ii] + z[n - 1] * z[n - 1] / delta[n - 1];
        let del = d[n - 1] - d[n - 2];
        let quad = |c: f64| {
            let a = -c * del + z[n - 2] * z[n - 2] + z[n - 1] * z[n - 1];
            let b = z[n - 1] * z[n - 1] * del;
            if a < 0.0 {
                2.0 * b / ((a * a + 4.0 * b * c).sqrt() - a)
            } else {
                (a + (a * a + 4.0 * b * c).sqrt()) / (2.0 * c)
            }
        };
        let (mut tau, mut dltlb, mut dltub);
        if w <= 0.0 {
            let temp =
                z[n - 2] * z[n - 2] / (d[n - 1] - d[n - 2] + rho) + z[n - 1] * z[n - 1] / rho;
            tau = if c <= temp { rho } else { quad(c) };
            dltlb = midpt;
            dltub = rho;
        } else {
            tau = quad(c);
            dltlb = 0.0;
            dltub = midpt;
        }
        // ψ over j < n−1 (with its derivative and error bound), φ the last term.
        let eval = |tau: f64, delta: &mut [f64]| {
            let (psi, dpsi, erretm) = pole_sums(
                &d[..=ii],
                &z[..=ii],
                &mut delta[..=ii],
                d[i],
                tau,
                (n - 1) as f64,
                -1.0,
            );
            delta[n - 1] = (d[n - 1] - d[i]) - tau;
            let erretm = erretm.abs();
            let t = z[n - 1] / delta[n - 1];
            let phi = z[n - 1] * t;
            let dphi = t * t;
            let erretm = 8.0 * (-phi - psi) + erretm - phi + rhoinv + tau.abs() * (dpsi + dphi);
            (rhoinv + phi + psi, dpsi, dphi, erretm)
        };
        let (mut w, mut dpsi, mut dphi, mut erretm) = eval(tau, delta);
        for iter in 0..SECULAR_MAXIT {
            if w.abs() <= eps * erretm {
                return Ok(d[i] + tau);
            }
            if w <= 0.0 {
                dltlb = dltlb.max(tau);
            } else {
                dltub = dltub.min(tau);
            }
            let (dm, dn) = (delta[n - 2], delta[n - 1]);
            let mut c = w - dm * dpsi - dn * dphi;
            let a = (dm + dn) * w - dm * dn * (dpsi + dphi);
            let b = dm * dn * w;
            if iter == 0 && c < 0.0 {
                c = c.abs();
            }
            let mut eta = if c == 0.0 {
                dltub - tau
            } else if a >= 0.0 {
                (a + (a * a - 4.0 * b * c).abs().sqrt()) / (2.0 * c)
            } else {
                2.0 * b / (a - (a * a - 4.0 * b * c).abs().sqrt())
            };
            if w * eta > 0.0 {
                eta = -w / (dpsi + dphi);
            }
            eta = inside_bracket(tau, eta, w, dltlb, dltub);
            tau += eta;
            (w, dpsi, dphi, erretm) = eval(tau, delta);
        }
        return Err(());
    }

    // An interior root, in (d[i], d[i+1]).
    let ip1 = i + 1;
    let del = d[ip1] - d[i];
    let midpt = del / 2.0;
    // δ_j = (d_j − d_i) − del/2, ψ = Σ_{j<i} z_j²/δ_j and φ = Σ_{j>i+1} z_j²/δ_j.
    let (psi, _, _) = pole_sums(&d[..i], &z[..i], &mut delta[..i], d[i], midpt, 0.0, 0.0);
    let (phi, _, _) = pole_sums(
        &d[i + 2..],
        &z[i + 2..],
        &mut delta[i + 2..],
        d[i],
        midpt,
        0.0,
        0.0,
    );
    for j in i..i + 2 {
        delta[j] = (d[j] - d[i]) - midpt;
    }
    let c = rhoinv + psi + phi;
    let w = c + z[i] * z[i] / delta[i] + z[ip1] * z[ip1] / delta[ip1];
    let orgati = w > 0.0;
    let (mut tau, mut dltlb, mut dltub);
    if orgati {
        // d[i] < λ < (d[i] + d[i+1]) / 2: origin d[i].
        let a = c * del + z[i] * z[i] + z[ip1] * z[ip1];
        let b = z[i] * z[i] * del;
        tau = if a > 0.0 {
            2.0 * b / (a + (a * a - 4.0 * b * c).abs().sqrt())
        } else {
            (a - (a * a - 4.0 * b * c).abs().sqrt()) / (2.0 * c)
        };
        dltlb = 0.0;
        dltub = midpt;
    } else {
        // (d[i] + d[i+1]) / 2 ≤ λ < d[i+1]: origin d[i+1].
        let a = c * del - z[i] * z[i] - z[ip1] * z[ip1];
        let b = z[ip1] * z[ip1] * del;
        tau = if a < 0.0 {
            2.0 * b / (a - (a * a + 4.0 * b * c).abs().sqrt())
        } else {
            -(a + (a * a + 4.0 * b * c).abs().sqrt()) / (2.0 * c)
        };
        dltlb = -midpt;
        dltub = 0.0;
    }
    let origin = if orgati { d[i] } else { d[ip1] };
    let ii = if orgati { i } else { ip1 };
    // ψ over j < ii, φ over j > ii, their derivatives, w without the ii term, and
    // the running error bound.
    let eval = |tau: f64, delta: &mut [f64]| {
        let (psi, dpsi, e0) = pole_sums(
            &d[..ii],
            &z[..ii],
            &mut delta[..ii],
            origin,
            tau,
            ii as f64,
            -1.0,
        );
        delta[ii] = (d[ii] - origin) - tau;
        let (phi, dphi, e1) = pole_sums(
            &d[ii + 1..],
            &z[ii + 1..],
            &mut delta[ii + 1..],
            origin,
            tau,
            1.0,
            1.0,
        );
        let erretm = e0.abs() + e1;
        (psi, dpsi, phi, dphi, erretm)
    };
    let (mut psi, mut dpsi, mut phi, mut dphi, mut erretm) = eval(tau, delta);
    let mut w = rhoinv + phi + psi;
    let mut swtch3 = if orgati { w < 0.0 } else { w > 0.0 };
    if ii == 0 || ii == n - 1 {
        swtch3 = false;
    }
    let finish =
        |psi: f64, dpsi: f64, phi: f64, dphi: f64, erretm: f64, tau: f64, delta: &[f64]| {
            let t = z[ii] / delta[ii];
            let dw = dpsi + dphi + t * t;
            let t = z[ii] * t;
            let w = rhoinv + phi + psi + t;
            let erretm = 8.0 * (phi - psi) + erretm + 2.0 * rhoinv + 3.0 * t.abs() + tau.abs() * dw;
            (w, dw, erretm)
        };
    let (w0, dw0, erretm0) = finish(psi, dpsi, phi, dphi, erretm, tau, delta);
    w = w0;
    let mut dw = dw0;
    erretm = erretm0;
    let mut swtch = false;
    for iter in 0..SECULAR_MAXIT {
        if w.abs() <= eps * erretm {
            return Ok(origin + tau);
        }
        if w <= 0.0 {
            dltlb = dltlb.max(tau);
        } else {
            dltub = dltub.min(tau);
        }
        let niter = iter + 2;
        let mut eta;
        if !swtch3 {
            let c = if !swtch {
                if orgati {
                    w - delta[ip1] * dw - (d[i] - d[ip1]) * sq(z[i] / delta[i])
                } else {
                    w - delta[i] * dw - (d[ip1] - d[i]) * sq(z[ip1] / delta[ip1])
                }
            } else {
                let t = sq(z[ii] / delta[ii]);
                if orgati {
                    dpsi += t;
                } else {
                    dphi += t;
                }
                w - delta[i] * dpsi - delta[ip1] * dphi
            };
            let mut a = (delta[i] + delta[ip1]) * w - delta[i] * delta[ip1] * dw;
            let b = delta[i] * delta[ip1] * w;
            if c == 0.0 {
                if a == 0.0 {
                    a = if !swtch {
                        if orgati {
                            z[i] * z[i] + delta[ip1] * delta[ip1] * (dpsi + dphi)
                        } else {
                            z[ip1] * z[ip1] + delta[i] * delta[i] * (dpsi + dphi)
                        }
                    } else {
                        delta[i] * delta[i] * dpsi + delta[ip1] * delta[ip1] * dphi
                    };
                }
                eta = b / a;
            } else if a <= 0.0 {
                eta = (a - (a * a - 4.0 * b * c).abs().sqrt()) / (2.0 * c);
            } else {
                eta = 2.0 * b / (a + (a * a - 4.0 * b * c).abs().sqrt());
            }
        } else {
            // Interpolation with the three nearest poles.
            let (iim1, iip1) = (ii - 1, ii + 1);
            let temp = rhoinv + psi + phi;
            let (c, zz0, zz2);
            if swtch {
                c = temp - delta[iim1] * dpsi - delta[iip1] * dphi;
                zz0 = delta[iim1] * delta[iim1] * dpsi;
                zz2 = delta[iip1] * delta[iip1] * dphi;
            } else if orgati {
                let t1 = sq(z[iim1] / delta[iim1]);
                c = temp - delta[iip1] * (dpsi + dphi) - (d[iim1] - d[iip1]) * t1;
                zz0 = z[iim1] * z[iim1];
                zz2 = delta[iip1] * delta[iip1] * ((dpsi - t1) + dphi);
            } else {
                let t1 = sq(z[iip1] / delta[iip1]);
                c = temp - delta[iim1] * (dpsi + dphi) - (d[iip1] - d[iim1]) * t1;
                zz0 = delta[iim1] * delta[iim1] * (dpsi + (dphi - t1));
                zz2 = z[iip1] * z[iip1];
            }
            let zz = [zz0, z[ii] * z[ii], zz2];
            let dd = [delta[iim1], delta[ii], delta[iip1]];
            eta = three_poles(niter, orgati, c, &dd, &zz, w)?;
        }
        if w * eta >= 0.0 {
            eta = -w / dw;
        }
        eta = inside_bracket(tau, eta, w, dltlb, dltub);
        tau += eta;
        let prew = w;
        (psi, dpsi, phi, dphi, erretm) = eval(tau, delta);
        (w, dw, erretm) = finish(psi, dpsi, phi, dphi, erretm, tau, delta);
        if iter == 0 {
            swtch = if orgati {
                -w > prew.abs() / 10.0
            } else {
                w > prew.abs() / 10.0
            };
        } else if w * prew > 0.0 && w.abs() > prew.abs() / 10.0 {
            swtch = !swtch;
        }
    }
    Err(())
}

/// One pass over a run of poles: `δ_j = (d_j − origin) − τ` into `delta`, and the
/// sums `Σ z_j²/δ_j`, `Σ (z_j/δ_j)²` and `Σ w_j z_j²/δ_j` with weights
/// `w_j = w₀ + step·j`. With `w_j` the number of `dlaed4`'s partial sums that contain
/// term j, the last is the sum of those partial sums (its error bound `ERRETM`; all
/// terms of a run have one sign). Four lanes, so that the divisions vectorise: through
/// [`crate::cpu::dispatch`], since the baseline x86-64 build (SSE2) divides one lane
/// at a time here; the same bits on every build.
#[inline]
fn pole_sums(
    d: &[f64],
    z: &[f64],
    delta: &mut [f64],
    origin: f64,
    tau: f64,
    w0: f64,
    step: f64,
) -> (f64, f64, f64) {
    crate::cpu::dispatch(PoleSums {
        d,
        z,
        delta,
        origin,
        tau,
        w0,
        step,
    })
}

/// The arguments of [`pole_sums`], as a kernel of [`crate::cpu::dispatch`].
struct PoleSums<'a> {
    d: &'a [f64],
    z: &'a [f64],
    delta: &'a mut [f64],
    origin: f64,
    tau: f64,
    w0: f64,
    step: f64,
}

impl crate::cpu::Kernel for PoleSums<'_> {
    type Output = (f64, f64, f64);

    #[inline(always)]
    fn portable(self) -> (f64, f64, f64) {
        let (origin, tau, step) = (self.origin, self.tau, self.step);
        let (mut s, mut ds, mut e) = ([0.0f64; 4], [0.0f64; 4], [0.0f64; 4]);
        let w0 = self.w0;
        let mut wl = [w0, w0 + step, w0 + 2.0 * step, w0 + 3.0 * step];
        let n4 = self.d.len() / 4 * 4;
        for ((dc, zc), delc) in self.d[..n4]
            .chunks_exact(4)
            .zip(self.z[..n4].chunks_exact(4))
            .zip(self.delta[..n4].chunks_exact_mut(4))
        {
            for l in 0..4 {
                let dl = (dc[l] - origin) - tau;
                delc[l] = dl;
                let t = zc[l] / dl;
                let u = zc[l] * t;
                s[l] += u;
                ds[l] += t * t;
                e[l] += wl[l] * u;
                wl[l] += 4.0 * step;
            }
        }
        pole_sums_tail(self, n4, s, ds, e)
    }

    /// The same lanes and the same operations as [`Self::portable`], in AVX2
    /// registers: LLVM leaves the portable loop's four divisions scalar (`vdivsd`) in
    /// both vector builds.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn avx2_fma(self) -> (f64, f64, f64) {
        use std::arch::x86_64::*;
        let (origin, tau, w0, step) = (self.origin, self.tau, self.w0, self.step);
        let n4 = self.d.len() / 4 * 4;
        let (d, z) = (&self.d[..n4], &self.z[..n4]);
        let delta = &mut self.delta[..n4];
        let (mut s, mut ds, mut e) = ([0.0f64; 4], [0.0f64; 4], [0.0f64; 4]);
        // SAFETY: every access is at j..j + 4 with j + 4 <= n4, the length of d, z and
        // delta here; the caller is compiled with AVX2.
        unsafe {
            let (vo, vt) = (_mm256_set1_pd(origin), _mm256_set1_pd(tau));
            let mut wl = _mm256_setr_pd(w0, w0 + step, w0 + 2.0 * step, w0 + 3.0 * step);
            let w4 = _mm256_set1_pd(4.0 * step);
            let (mut vs, mut vds, mut ve) = (
                _mm256_setzero_pd(),
                _mm256_setzero_pd(),
                _mm256_setzero_pd(),
            );
            let mut j = 0;
            while j < n4 {
                let dv = _mm256_loadu_pd(d.as_ptr().add(j));
                let zv = _mm256_loadu_pd(z.as_ptr().add(j));
                let dl = _mm256_sub_pd(_mm256_sub_pd(dv, vo), vt);
                _mm256_storeu_pd(delta.as_mut_ptr().add(j), dl);
                let t = _mm256_div_pd(zv, dl);
                let u = _mm256_mul_pd(zv, t);
                vs = _mm256_add_pd(vs, u);
                vds = _mm256_add_pd(vds, _mm256_mul_pd(t, t));
                ve = _mm256_add_pd(ve, _mm256_mul_pd(wl, u));
                wl = _mm256_add_pd(wl, w4);
                j += 4;
            }
            _mm256_storeu_pd(s.as_mut_ptr(), vs);
            _mm256_storeu_pd(ds.as_mut_ptr(), vds);
            _mm256_storeu_pd(e.as_mut_ptr(), ve);
        }
        pole_sums_tail(self, n4, s, ds, e)
    }
}

/// The end of both builds of [`PoleSums`]: the poles past the last group of four
/// (`n4..`) added into lane 0, then the lanes summed pairwise.
#[inline(always)]
fn pole_sums_tail(
    k: PoleSums<'_>,
    n4: usize,
    mut s: [f64; 4],
    mut ds: [f64; 4],
    mut e: [f64; 4],
) -> (f64, f64, f64) {
    let PoleSums {
        d,
        z,
        delta,
        origin,
        tau,
        w0,
        step,
    } = k;
    for j in n4..d.len() {
        let dl = (d[j] - origin) - tau;
        delta[j] = dl;
        let t = z[j] / dl;
        let u = z[j] * t;
        s[0] += u;
        ds[0] += t * t;
        e[0] += (w0 + step * j as f64) * u;
    }
    (
        (s[0] + s[1]) + (s[2] + s[3]),
        (ds[0] + ds[1]) + (ds[2] + ds[3]),
        (e[0] + e[1]) + (e[2] + e[3]),
    )
}

/// `dlaed5`: the `i`-th eigenvalue of `diag(d) + ρ z zᵀ` for two entries; `delta`
/// receives its normalised eigenvector.
fn secular_two(i: usize, d: &[f64], z: &[f64], delta: &mut [f64], rho: f64) -> f64 {
    let del = d[1] - d[0];
    let lam;
    if i == 0 {
        let w = 1.0 + 2.0 * rho * (z[1] * z[1] - z[0] * z[0]) / del;
        if w > 0.0 {
            let b = del + rho * (z[0] * z[0] + z[1] * z[1]);
            let c = rho * z[0] * z[0] * del;
            let tau = 2.0 * c / (b + (b * b - 4.0 * c).abs().sqrt());
            lam = d[0] + tau;
            delta[0] = -z[0] / tau;
            delta[1] = z[1] / (del - tau);
        } else {
            let b = -del + rho * (z[0] * z[0] + z[1] * z[1]);
            let c = rho * z[1] * z[1] * del;
            let tau = if b > 0.0 {
                -2.0 * c / (b + (b * b + 4.0 * c).sqrt())
            } else {
                (b - (b * b + 4.0 * c).sqrt()) / 2.0
            };
            lam = d[1] + tau;
            delta[0] = -z[0] / (del + tau);
            delta[1] = -z[1] / tau;
        }
    } else {
        let b = -del + rho * (z[0] * z[0] + z[1] * z[1]);
        let c = rho * z[1] * z[1] * del;
        let tau = if b > 0.0 {
            (b + (b * b + 4.0 * c).sqrt()) / 2.0
        } else {
            2.0 * c / (-b + (b * b + 4.0 * c).sqrt())
        };
        lam = d[1] + tau;
        delta[0] = -z[0] / (del + tau);
        delta[1] = -z[1] / tau;
    }
    let nrm = delta[0].hypot(delta[1]);
    delta[0] /= nrm;
    delta[1] /= nrm;
    lam
}

/// `dlaed6`: one step's root `τ` of the three-pole rational model
/// `f(x) = ρ + Σ_{i<3} z_i / (d_i − x)` with `f(0) = finit`, in the interval between
/// the two poles next to 0 (Gragg, Thornton & Warner's cubically convergent
/// iteration; scaled when a pole is too close for `1/(d_i − τ)³`).
fn three_poles(
    kniter: usize,
    orgati: bool,
    rho: f64,
    d: &[f64; 3],
    z: &[f64; 3],
    finit: f64,
) -> Result<f64, ()> {
    let (mut lbd, mut ubd) = if orgati { (d[1], d[2]) } else { (d[0], d[1]) };
    if finit < 0.0 {
        lbd = 0.0;
    } else {
        ubd = 0.0;
    }
    let mut tau = 0.0f64;
    if kniter == 2 {
        let (mut a, mut b, mut c);
        if orgati {
            let temp = (d[2] - d[1]) / 2.0;
            c = rho + z[0] / ((d[0] - d[1]) - temp);
            a = c * (d[1] + d[2]) + z[1] + z[2];
            b = c * d[1] * d[2] + z[1] * d[2] + z[2] * d[1];
        } else {
            let temp = (d[0] - d[1]) / 2.0;
            c = rho + z[2] / ((d[2] - d[1]) - temp);
            a = c * (d[0] + d[1]) + z[0] + z[1];
            b = c * d[0] * d[1] + z[0] * d[1] + z[1] * d[0];
        }
        let temp = a.abs().max(b.abs()).max(c.abs());
        a /= temp;
        b /= temp;
        c /= temp;
        tau = if c == 0.0 {
            b / a
        } else if a <= 0.0 {
            (a - (a * a - 4.0 * b * c).abs().sqrt()) / (2.0 * c)
        } else {
            2.0 * b / (a + (a * a - 4.0 * b * c).abs().sqrt())
        };
        if tau < lbd || tau > ubd {
            tau = (lbd + ubd) / 2.0;
        }
        if d[0] == tau || d[1] == tau || d[2] == tau {
            tau = 0.0;
        } else {
            let temp = finit
                + tau * z[0] / (d[0] * (d[0] - tau))
                + tau * z[1] / (d[1] * (d[1] - tau))
                + tau * z[2] / (d[2] * (d[2] - tau));
            if temp <= 0.0 {
                lbd = tau;
            } else {
                ubd = tau;
            }
            if finit.abs() <= temp.abs() {
                tau = 0.0;
            }
        }
    }
    // 2^−340 ≈ safmin^(1/3): scale so that 1/(d_i − τ)³ cannot overflow.
    let small1 = f64::powi(2.0, -340);
    let sminv1 = f64::powi(2.0, 340);
    let small2 = small1 * small1;
    let sminv2 = sminv1 * sminv1;
    let temp = if orgati {
        (d[1] - tau).abs().min((d[2] - tau).abs())
    } else {
        (d[0] - tau).abs().min((d[1] - tau).abs())
    };
    let (mut ds, mut zs) = (*d, *z);
    let mut sclinv = 1.0;
    if temp <= small1 {
        let (sclfac, inv) = if temp <= small2 {
            (sminv2, small2)
        } else {
            (sminv1, small1)
        };
        sclinv = inv;
        for i in 0..3 {
            ds[i] = d[i] * sclfac;
            zs[i] = z[i] * sclfac;
        }
        tau *= sclfac;
        lbd *= sclfac;
        ubd *= sclfac;
    }
    let mut fc = 0.0;
    let mut df = 0.0;
    let mut ddf = 0.0;
    for i in 0..3 {
        let temp = 1.0 / (ds[i] - tau);
        let t1 = zs[i] * temp;
        let t2 = t1 * temp;
        let t3 = t2 * temp;
        fc += t1 / ds[i];
        df += t2;
        ddf += t3;
    }
    let mut f = finit + tau * fc;
    if f.abs() <= 0.0 {
        return Ok(tau * sclinv);
    }
    if f <= 0.0 {
        lbd = tau;
    } else {
        ubd = tau;
    }
    for _ in 2..=40 {
        let (t1, t2) = if orgati {
            (ds[1] - tau, ds[2] - tau)
        } else {
            (ds[0] - tau, ds[1] - tau)
        };
        let mut a = (t1 + t2) * f - t1 * t2 * df;
        let mut b = t1 * t2 * f;
        let mut c = f - (t1 + t2) * df + t1 * t2 * ddf;
        let temp = a.abs().max(b.abs()).max(c.abs());
        a /= temp;
        b /= temp;
        c /= temp;
        let mut eta = if c == 0.0 {
            b / a
        } else if a <= 0.0 {
            (a - (a * a - 4.0 * b * c).abs().sqrt()) / (2.0 * c)
        } else {
            2.0 * b / (a + (a * a - 4.0 * b * c).abs().sqrt())
        };
        if f * eta >= 0.0 {
            eta = -f / df;
        }
        tau += eta;
        if tau < lbd || tau > ubd {
            tau = (lbd + ubd) / 2.0;
        }
        fc = 0.0;
        let mut erretm = 0.0;
        df = 0.0;
        ddf = 0.0;
        for i in 0..3 {
            let temp = 1.0 / (ds[i] - tau);
            let t1 = zs[i] * temp;
            let t2 = t1 * temp;
            let t3 = t2 * temp;
            let t4 = t1 / ds[i];
            fc += t4;
            erretm += t4.abs();
            df += t2;
            ddf += t3;
        }
        f = finit + tau * fc;
        let erretm = 8.0 * (finit.abs() + tau.abs() * erretm) + tau.abs() * df;
        if f.abs() <= f64::EPSILON * erretm {
            return Ok(tau * sclinv);
        }
        if f <= 0.0 {
            lbd = tau;
        } else {
            ubd = tau;
        }
    }
    Err(())
}

/// `dlaed4`'s safeguard: the step `eta` from `tau` if it stays inside the bracket
/// `[lo, hi]` of the root's offset, else half the way to the end the secular
/// function's sign `w` points to.
fn inside_bracket(tau: f64, eta: f64, w: f64, lo: f64, hi: f64) -> f64 {
    let next = tau + eta;
    if next > hi || next < lo {
        if w < 0.0 {
            (hi - tau) / 2.0
        } else {
            (lo - tau) / 2.0
        }
    } else {
        eta
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;

    /// faer's divide and conquer on the same matrix.
    fn faer_evd(d: &[f64], e: &[f64]) -> (Vec<f64>, Mat<f64>) {
        use faer::dyn_stack::{MemBuffer, MemStack};
        use faer::linalg::evd::{self, ComputeEigenvectors};
        let n = d.len();
        let mut sub = e.to_vec();
        sub.push(0.0);
        let mut z = Mat::<f64>::zeros(n, n);
        let mut s = faer::diag::Diag::<f64>::zeros(n);
        let mut mem = MemBuffer::new(evd::self_adjoint_evd_scratch::<f64>(
            n,
            ComputeEigenvectors::Yes,
            Par::Seq,
            Default::default(),
        ));
        evd::tridiagonal_self_adjoint_evd(
            faer::ColRef::from_slice(d).as_diagonal(),
            faer::ColRef::from_slice(&sub).as_diagonal(),
            s.as_mut(),
            Some(z.as_mut()),
            Par::Seq,
            MemStack::new(&mut mem),
            Default::default(),
        )
        .unwrap();
        ((0..n).map(|i| s[i]).collect(), z)
    }

    /// `max |T|` (entrywise), the scale of the tolerances.
    fn tnorm(d: &[f64], e: &[f64]) -> f64 {
        d.iter().chain(e).fold(0.0f64, |a, x| a.max(x.abs()))
    }

    /// Residual `max_j ‖T z_j − λ_j z_j‖₂ / ‖T‖` and orthogonality `max |ZᵀZ − I|`.
    fn errors(d: &[f64], e: &[f64], lam: &[f64], z: MatRef<'_, f64>) -> (f64, f64) {
        let n = d.len();
        let t = tnorm(d, e).max(f64::MIN_POSITIVE);
        let mut res = 0.0f64;
        for j in 0..n {
            let c = z.col(j);
            let mut s = 0.0;
            for i in 0..n {
                // Scaled by 1/‖T‖ term by term: no overflow near f64::MAX.
                let mut tz = d[i] / t * c[i] - lam[j] / t * c[i];
                if i > 0 {
                    tz += e[i - 1] / t * c[i - 1];
                }
                if i + 1 < n {
                    tz += e[i] / t * c[i + 1];
                }
                s += tz * tz;
            }
            res = res.max(s.sqrt());
        }
        let mut g = Mat::<f64>::zeros(n, n);
        matmul(g.as_mut(), Accum::Replace, z.transpose(), z, 1.0, Par::Seq);
        let mut orth = 0.0f64;
        for j in 0..n {
            for i in 0..n {
                let id = if i == j { 1.0 } else { 0.0 };
                orth = orth.max((g[(i, j)] - id).abs());
            }
        }
        (res, orth)
    }

    /// Runs the solver and checks ascending order, residual and orthogonality
    /// (≤ 1e-14·max(n, 10)), and the eigenvalues against faer's (≤ 1e-13·‖T‖).
    #[track_caller]
    fn check(d: &[f64], e: &[f64], par: Par) -> (Vec<f64>, Mat<f64>) {
        let n = d.len();
        let (lam, z) = tridiagonal_evd(d, e, par).unwrap();
        assert_eq!(lam.len(), n);
        assert_eq!((z.nrows(), z.ncols()), (n, n));
        assert!(lam.windows(2).all(|w| w[0] <= w[1]), "not ascending");
        let (res, orth) = errors(d, e, &lam, z.as_ref());
        let tol = 1e-14 * (n.max(10) as f64);
        assert!(res <= tol, "n = {n}: residual {res:e} > {tol:e}");
        assert!(orth <= tol, "n = {n}: ‖ZᵀZ − I‖ = {orth:e} > {tol:e}");
        if n > 0 {
            let (lf, _) = faer_evd(d, e);
            let t = tnorm(d, e);
            let dev = lam
                .iter()
                .zip(&lf)
                .fold(0.0f64, |a, (x, y)| a.max((x - y).abs()));
            assert!(
                dev <= 1e-13 * t.max(f64::MIN_POSITIVE),
                "n = {n}: eigenvalues off faer's by {dev:e} (‖T‖ = {t:e})"
            );
        }
        (lam, z)
    }

    fn random(n: usize, seed: u64) -> (Vec<f64>, Vec<f64>) {
        let mut r = SplitMix64::new(seed);
        let d = (0..n).map(|_| r.next_signed()).collect();
        let e = (0..n.saturating_sub(1)).map(|_| r.next_signed()).collect();
        (d, e)
    }

    fn wilkinson(m: usize) -> (Vec<f64>, Vec<f64>) {
        let h = (m / 2) as f64;
        let d = (0..m).map(|i| (i as f64 - h).abs()).collect();
        (d, vec![1.0; m - 1])
    }

    #[test]
    fn random_tridiagonals_match_faer() {
        let sizes: Vec<usize> = (1..=60)
            .chain([64, 77, 100, 127, 128, 200, 255, 300])
            .collect();
        for &n in &sizes {
            let (d, e) = random(n, 1000 + n as u64);
            check(&d, &e, Par::Seq);
        }
    }

    #[test]
    fn parallel_matches_sequential() {
        let (d, e) = random(if cfg!(miri) { 40 } else { 700 }, 7);
        let (l1, z1) = check(&d, &e, Par::Seq);
        let (l2, z2) = check(&d, &e, Par::rayon(2));
        for j in 0..d.len() {
            assert!((l1[j] - l2[j]).abs() <= 1e-14 * 4.0);
            // Same vector up to sign (the spectrum is simple).
            let dot: f64 = (0..d.len()).map(|i| z1[(i, j)] * z2[(i, j)]).sum();
            assert!(
                (dot.abs() - 1.0).abs() < 1e-10,
                "column {j}: |dot| = {}",
                dot.abs()
            );
        }
    }

    #[test]
    fn small_and_degenerate_sizes() {
        assert_eq!(tridiagonal_evd(&[], &[], Par::Seq).unwrap().0.len(), 0);
        let (l, z) = tridiagonal_evd(&[3.5], &[], Par::Seq).unwrap();
        assert_eq!(l, vec![3.5]);
        assert_eq!(z[(0, 0)], 1.0);
        let (l, _) = check(&[2.0, 2.0], &[1.0], Par::Seq);
        assert!((l[0] - 1.0).abs() < 1e-15 && (l[1] - 3.0).abs() < 1e-15);
        check(&[1.0, 1.0], &[0.0], Par::Seq);
        check(&[0.0; 40], &[0.0; 39], Par::Seq);
        check(
            &[1.0000000000000002, 1.0000000000000002],
            &[7.216449660063518e-16],
            Par::Seq,
        );
        // Tiny and huge scales.
        let (d, e) = random(90, 3);
        for s in [1e-300, 1e-160, 1e160, 1e300] {
            let ds: Vec<f64> = d.iter().map(|x| x * s).collect();
            let es: Vec<f64> = e.iter().map(|x| x * s).collect();
            check(&ds, &es, Par::Seq);
        }
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        use TridiagonalEvdError as E;
        assert!(matches!(
            tridiagonal_evd(&[1.0, 2.0], &[], Par::Seq),
            Err(E::ShapeMismatch { .. })
        ));
        assert!(matches!(
            tridiagonal_evd(&[1.0, 2.0], &[1.0, 0.0], Par::Seq),
            Err(E::ShapeMismatch { .. })
        ));
        assert!(matches!(
            tridiagonal_evd(&[], &[1.0], Par::Seq),
            Err(E::ShapeMismatch { .. })
        ));
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let mut d = vec![1.0; 50];
            d[17] = bad;
            assert!(matches!(
                tridiagonal_evd(&d, &[0.5; 49], Par::Seq),
                Err(E::NonFinite {
                    part: "diagonal",
                    index: 17,
                    ..
                })
            ));
            let mut e = vec![0.5; 49];
            e[48] = bad;
            assert!(matches!(
                tridiagonal_evd(&[1.0; 50], &e, Par::Seq),
                Err(E::NonFinite {
                    part: "off-diagonal",
                    index: 48,
                    ..
                })
            ));
        }
        // Finite but extreme: entries near the overflow threshold.
        let d: Vec<f64> = (0..60)
            .map(|i| if i % 2 == 0 { f64::MAX } else { -f64::MAX })
            .collect();
        let e = vec![f64::MAX; 59];
        let _ = tridiagonal_evd(&d, &e, Par::Seq);
    }

    #[test]
    fn wilkinson_matrices_deflate() {
        for m in [21, 41, 101, 201] {
            let (d, e) = wilkinson(m);
            check(&d, &e, Par::Seq);
        }
        // Glued Wilkinson W21+: copies of W21 joined by a small off-diagonal.
        for glue in [1e-3, 1e-8, 1e-14] {
            let (w, we) = wilkinson(21);
            let (mut d, mut e) = (Vec::new(), Vec::new());
            for b in 0..10 {
                if b > 0 {
                    e.push(glue);
                }
                d.extend_from_slice(&w);
                e.extend_from_slice(&we);
            }
            check(&d, &e, Par::Seq);
        }
    }

    #[test]
    fn equal_diagonal_and_tiny_offdiagonal() {
        for n in [30, 120, 257] {
            check(&vec![1.0; n], &vec![1e-14; n - 1], Par::Seq);
            check(&vec![1.0; n], &vec![1e-300; n - 1], Par::Seq);
            let d: Vec<f64> = (0..n).map(|i| 1.0 + i as f64).collect();
            check(&d, &vec![1e-20; n - 1], Par::Seq);
        }
    }

    #[test]
    fn split_matrices() {
        let (d, mut e) = random(250, 11);
        for i in (0..249).step_by(7) {
            e[i] = 0.0;
        }
        e[100..140].iter_mut().for_each(|x| *x = 0.0);
        check(&d, &e, Par::Seq);
        // One big unreduced block and singletons.
        let (d, mut e) = random(200, 12);
        e[0] = 0.0;
        e[198] = 0.0;
        check(&d, &e, Par::Seq);
    }

    #[test]
    fn toeplitz_121_closed_form() {
        for n in [5, 26, 64, 150, 333] {
            let d = vec![2.0; n];
            let e = vec![-1.0; n - 1];
            let (lam, _) = check(&d, &e, Par::Seq);
            for (k, l) in lam.iter().enumerate() {
                let x = (k + 1) as f64 * std::f64::consts::PI / (n + 1) as f64;
                let exact = 2.0 - 2.0 * x.cos();
                assert!(
                    (l - exact).abs() <= 1e-14 * 8.0,
                    "n = {n}, k = {k}: {l} vs {exact}"
                );
            }
        }
    }

    #[test]
    fn clustered_eigenvalues() {
        let mut r = SplitMix64::new(5);
        let n = 240;
        // Diagonal in three tight clusters, small coupling: clusters of eigenvalues.
        let d: Vec<f64> = (0..n)
            .map(|i| [0.0, 1.0, 1.0 + 1e-9][i % 3] + 1e-12 * r.next_signed())
            .collect();
        let e: Vec<f64> = (0..n - 1).map(|_| 1e-7 * r.next_signed()).collect();
        check(&d, &e, Par::Seq);
        // A graded matrix.
        let d: Vec<f64> = (0..n).map(|i| 0.5f64.powi((i / 4) as i32)).collect();
        let e: Vec<f64> = (0..n - 1)
            .map(|i| 0.5f64.powi((i / 4) as i32 + 1))
            .collect();
        check(&d, &e, Par::Seq);
        // Many exactly repeated eigenvalues: a direct sum of equal blocks, glued weakly.
        let (b, be) = random(30, 99);
        let (mut d, mut e) = (Vec::new(), Vec::new());
        for k in 0..8 {
            if k > 0 {
                e.push(1e-15);
            }
            d.extend_from_slice(&b);
            e.extend_from_slice(&be);
        }
        check(&d, &e, Par::Seq);
    }

    #[test]
    fn large_random_and_laplacian_like() {
        let n = if cfg!(debug_assertions) { 500 } else { 2000 };
        let (d, e) = random(n, 2024);
        check(&d, &e, Par::Seq);
        // A path-graph Laplacian with random positive weights (PSD, F = D − W).
        let mut r = SplitMix64::new(8);
        let wts: Vec<f64> = (0..n - 1).map(|_| 0.1 + r.next_f64()).collect();
        let d: Vec<f64> = (0..n)
            .map(|i| if i > 0 { wts[i - 1] } else { 0.0 } + wts.get(i).copied().unwrap_or(0.0))
            .collect();
        let e: Vec<f64> = wts.iter().map(|w| -w).collect();
        let (lam, _) = check(&d, &e, Par::Seq);
        assert!(lam[0].abs() < 1e-12 && lam[0] >= -1e-12);
    }

    /// The dispatched kernels of the secular equation, of `dlaed3` and of the leaves'
    /// QL iteration (the build `crate::cpu::dispatch` picks on this CPU) give the bits
    /// of their portable build, on runs of every length modulo the four lanes and of
    /// both signs.
    #[test]
    fn dispatched_kernels_match_their_portable_build() {
        use crate::cpu::{dispatch, Kernel};
        let mut r = SplitMix64::new(41);
        // Under Miri (RELIABILITY.md) without the two largest: the leaves' QL is cubic.
        let sizes: &[usize] = if cfg!(miri) {
            &[1, 2, 3, 4, 5, 7, 8, 9, 31]
        } else {
            &[1, 2, 3, 4, 5, 7, 8, 9, 31, 64, 130]
        };
        for &k in sizes {
            let mut d: Vec<f64> = (0..k).map(|_| r.next_signed() * 4.0).collect();
            d.sort_by(f64::total_cmp);
            let z: Vec<f64> = (0..k).map(|_| r.next_signed()).collect();
            for (origin, tau, w0, step) in [(d[0], 1e-3, k as f64, -1.0), (-0.5, 0.25, 1.0, 1.0)] {
                let (mut dp, mut dd) = (vec![0.0; k], vec![0.0; k]);
                let p = PoleSums {
                    d: &d,
                    z: &z,
                    delta: &mut dp,
                    origin,
                    tau,
                    w0,
                    step,
                }
                .portable();
                let q = dispatch(PoleSums {
                    d: &d,
                    z: &z,
                    delta: &mut dd,
                    origin,
                    tau,
                    w0,
                    step,
                });
                assert_eq!(
                    [p.0, p.1, p.2].map(f64::to_bits),
                    [q.0, q.1, q.2].map(f64::to_bits)
                );
                assert!(dp.iter().zip(&dd).all(|(a, b)| a.to_bits() == b.to_bits()));
            }
            let s: Vec<f64> = (0..k * k).map(|_| r.next_signed() + 2.0).collect();
            let lam: Vec<f64> = (0..k).map(|i| i as f64 + r.next_f64() * 0.5).collect();
            let w0: Vec<f64> = (0..k).map(|_| r.next_signed()).collect();
            let (mut wp, mut wd) = (w0.clone(), w0.clone());
            Lowner {
                s: &s,
                dlamda: &lam,
                what: &mut wp,
            }
            .portable();
            dispatch(Lowner {
                s: &s,
                dlamda: &lam,
                what: &mut wd,
            });
            assert!(wp.iter().zip(&wd).all(|(a, b)| a.to_bits() == b.to_bits()));
            let order: Vec<usize> = (0..k).rev().collect();
            let (mut cp, mut cd) = (s[..k].to_vec(), s[..k].to_vec());
            let (mut vp, mut vd) = (vec![0.0; k], vec![0.0; k]);
            Normalise {
                what: &w0,
                c: &mut cp,
                v: &mut vp,
                order: &order,
            }
            .portable();
            dispatch(Normalise {
                what: &w0,
                c: &mut cd,
                v: &mut vd,
                order: &order,
            });
            assert!(cp.iter().zip(&cd).all(|(a, b)| a.to_bits() == b.to_bits()));
            // And it is `ẑ_i / δ_i`, normalised, in the given order.
            let v: Vec<f64> = (0..k).map(|i| w0[i] / s[i]).collect();
            let vn = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            for (j, &i) in order.iter().enumerate() {
                assert!((cp[j] - v[i] / vn).abs() <= 1e-15 * (1.0 + v[i].abs() / vn));
            }
            // The leaves' QL iteration.
            let (dl, el) = random(k, 7 + k as u64);
            let (mut dp, mut dd) = (dl.clone(), dl.clone());
            let (mut qp, mut qd) = (Mat::<f64>::zeros(k, k), Mat::<f64>::zeros(k, k));
            Leaf {
                d: &mut dp,
                e: &el,
                q: qp.as_mut(),
            }
            .portable()
            .unwrap();
            dispatch(Leaf {
                d: &mut dd,
                e: &el,
                q: qd.as_mut(),
            })
            .unwrap();
            assert!(dp.iter().zip(&dd).all(|(a, b)| a.to_bits() == b.to_bits()));
            for j in 0..k {
                for i in 0..k {
                    assert_eq!(qp[(i, j)].to_bits(), qd[(i, j)].to_bits());
                }
            }
        }
    }

    #[test]
    fn rotation_norm_is_hypot_to_rounding_and_safe_at_the_extremes() {
        // The safe range's ends are √safmin and √(safmax/2).
        assert_eq!(
            1.4916681462400413e-154f64.to_bits(),
            f64::MIN_POSITIVE.sqrt().to_bits()
        );
        assert_eq!(
            9.480751908109176e153f64.to_bits(),
            (f64::MAX / 2.0).sqrt().to_bits()
        );
        let mut rng = SplitMix64::new(5);
        for _ in 0..100_000 {
            // Magnitudes over 10^±20 around random scales, signs random.
            let scale = 10f64.powi(rng.below(41) as i32 - 20);
            let (f, g) = (rng.next_signed() * scale, rng.next_signed() * scale * 1e3);
            let (got, want) = (rotation_norm(f, g), f.hypot(g));
            assert!((got - want).abs() <= 2.0 * f64::EPSILON * want, "{f} {g}");
        }
        // Outside the safe range: libm's hypot, which neither overflows nor flushes.
        for (f, g) in [
            (1e300, 1e300),
            (1e-300, 1e-300),
            (0.0, 3.0),
            (-4.0, 0.0),
            (0.0, 0.0),
            (5e-324, 5e-324),
            (1e200, 1.0),
        ] {
            assert_eq!(
                rotation_norm(f, g).to_bits(),
                f.hypot(g).to_bits(),
                "{f} {g}"
            );
        }
        assert!(rotation_norm(1e300, 1e300).is_finite());
        assert!(rotation_norm(1e-300, 1e-300) > 0.0);
    }
}
