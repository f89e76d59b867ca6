//! Finishing: eigenvectors in the operator's coordinates with canonical signs,
//! Rayleigh-quotient eigenvalues and residuals.

use super::mass::{symmetric_mul, Metric};
use super::{BandInfo, PartialInfo, PartialSpectrum};
use crate::spectral::basis::BasisOptions;
use crate::spectral::sign::{canonicalize, clusters};
use crate::SparseMatrix;
use faer::{Col, Mat};

/// Relative gap below which returned eigenvalues form one cluster for the sign rule:
/// the dense path's default.
const CLUSTER_TOLERANCE: f64 = BasisOptions::DEFAULT_CLUSTER_TOLERANCE;

/// Converts `w` to `v = C⁻ᵀ w` (`M^{-1/2} w` for a diagonal `M`), fixes the signs by
/// the crate's one rule, and recomputes each λ as a Rayleigh quotient with its residual.
pub(super) fn finish(
    k: &SparseMatrix,
    metric: &Metric,
    pairs: Vec<(f64, Col<f64>)>,
    bands: Vec<BandInfo>,
    dense: bool,
) -> PartialSpectrum {
    use rayon::prelude::*;
    let info = PartialInfo { bands, dense };
    let (n, m) = (metric.dim(), pairs.len());
    // v = C⁻ᵀ w / ‖w‖ (M^{-1/2} w / ‖w‖ for a diagonal M, per pair in parallel).
    let mut eigenvectors = crate::mem::zeroed_mat(n, m);
    eigenvectors
        .par_col_chunks_mut(1)
        .zip(pairs.par_iter())
        .for_each(|(col, (_, w))| {
            let nw = crate::spectral::thin_products::col_norm2(w.as_ref());
            let col = col.col_mut(0).iter_mut().enumerate();
            match metric.diagonal_sqrt() {
                Some(msqrt) => col.for_each(|(i, e)| *e = w[i] / nw / msqrt[i]),
                None => col.for_each(|(i, e)| *e = w[i] / nw),
            }
        });
    if metric.diagonal_sqrt().is_none() {
        metric.solve_ct(eigenvectors.as_mut());
    }
    // The crate's one sign and cluster rule, on the operator's coordinates v (the
    // M-orthonormal basis of a cluster stays M-orthonormal under its rotation).
    let approx: Vec<f64> = pairs.iter().map(|p| p.0).collect();
    drop(pairs);
    canonicalize(
        &mut eigenvectors,
        &clusters(&approx, CLUSTER_TOLERANCE),
        None,
    );
    match metric.diagonal_sqrt() {
        Some(msqrt) => finish_diagonal(k, msqrt, eigenvectors, info),
        None => finish_sparse_mass(k, metric, eigenvectors, info),
    }
}

/// The eigenvalues and residuals of [`finish`] for a diagonal `M`, on interleaved
/// chunks of 8 vectors.
fn finish_diagonal(
    k: &SparseMatrix,
    msqrt: &[f64],
    eigenvectors: Mat<f64>,
    info: PartialInfo,
) -> PartialSpectrum {
    use rayon::prelude::*;
    let n = msqrt.len();
    let m = eigenvectors.ncols();
    // K V by rows (K is symmetric: row i of K V gathers over column i of K), on
    // interleaved chunks of 8 vectors; then the Rayleigh quotients and residuals.
    // The two interleaved n×8 buffers are allocated once for all chunks: at a million
    // vertices each is 64 MB, above the allocator's mmap threshold, so new ones per
    // chunk were fresh pages to fault in every time (BENCHMARKS.md, "Partial spectra
    // and partitioning", forty-seventh session).
    let mut eigenvalues = vec![0.0f64; m];
    let mut residuals = vec![0.0f64; m];
    const CW: usize = 8;
    let mut vt = crate::mem::zeroed_vec([0.0f64; CW], n);
    let mut kvt = crate::mem::zeroed_vec([0.0f64; CW], n);
    let mut j0 = 0;
    while j0 < m {
        let w = CW.min(m - j0);
        vt.par_iter_mut().enumerate().for_each(|(i, row)| {
            *row = std::array::from_fn(|t| {
                if t < w {
                    eigenvectors[(i, j0 + t)]
                } else {
                    0.0
                }
            })
        });
        let vt = &vt;
        kvt.par_iter_mut().enumerate().for_each(|(i, acc)| {
            *acc = [0.0f64; CW];
            for (&r, &a) in k.row_idx_of_col_raw(i).iter().zip(k.val_of_col(i)) {
                let x = &vt[r];
                for t in 0..CW {
                    acc[t] += a * x[t];
                }
            }
        });
        let kvt = &kvt;
        // Σ v·Kv and Σ v²m per vector, then Σ ((Kv − λMv)/√m)², each summed over
        // fixed row blocks in parallel and the block sums added in order: the same
        // bits on every run and thread count (a rayon fold groups rows by how the
        // work was stolen, which changed the last bit of λ from run to run).
        let vkv_vmv = ordered_block_sums(n, |i, a: &mut [f64; 2 * CW]| {
            let mi = msqrt[i] * msqrt[i];
            for t in 0..CW {
                a[t] += vt[i][t] * kvt[i][t];
                a[CW + t] += vt[i][t] * vt[i][t] * mi;
            }
        });
        let (vkv, vmv) = vkv_vmv.split_at(CW);
        let lambda: [f64; CW] =
            std::array::from_fn(|t| if vmv[t] > 0.0 { vkv[t] / vmv[t] } else { 0.0 });
        let rr = ordered_block_sums(n, |i, a: &mut [f64; CW]| {
            let mi = msqrt[i] * msqrt[i];
            for t in 0..CW {
                let r = (kvt[i][t] - lambda[t] * mi * vt[i][t]) / msqrt[i];
                a[t] += r * r;
            }
        });
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
        info,
    }
}

/// `Σ_i f(i)` over `0..n` for array-valued terms (`f` adds term i into its
/// accumulator): rows in fixed blocks of [`SUM_BLOCK`], the blocks in parallel, the
/// block sums added in block order — deterministic whatever the thread count.
fn ordered_block_sums<const W: usize>(
    n: usize,
    f: impl Fn(usize, &mut [f64; W]) + Sync,
) -> [f64; W] {
    use rayon::prelude::*;
    let blocks: Vec<[f64; W]> = (0..n.div_ceil(SUM_BLOCK))
        .into_par_iter()
        .map(|b| {
            let mut acc = [0.0f64; W];
            for i in b * SUM_BLOCK..((b + 1) * SUM_BLOCK).min(n) {
                f(i, &mut acc);
            }
            acc
        })
        .collect();
    let mut total = [0.0f64; W];
    for b in &blocks {
        for t in 0..W {
            total[t] += b[t];
        }
    }
    total
}

/// Rows per block of [`ordered_block_sums`].
const SUM_BLOCK: usize = 4096;

/// The eigenvalues and residuals of [`finish`] for a sparse `M = C Cᵀ`: per pair `λ = vᵀKv / vᵀMv` and the residual `‖C⁻¹(Kv − λMv)‖ / √(vᵀMv)`.
fn finish_sparse_mass(
    k: &SparseMatrix,
    metric: &Metric,
    eigenvectors: Mat<f64>,
    info: PartialInfo,
) -> PartialSpectrum {
    use faer::reborrow::ReborrowMut;
    use rayon::prelude::*;
    let (n, m) = (metric.dim(), eigenvectors.ncols());
    let per_pair: Vec<(f64, Vec<f64>, f64)> = (0..m)
        .into_par_iter()
        .map(|j| {
            let v: Vec<f64> = eigenvectors.col(j).iter().copied().collect();
            let kv = symmetric_mul(k, &v);
            let mv = metric.mul_m(&v);
            let vkv: f64 = v.iter().zip(&kv).map(|(a, b)| a * b).sum();
            let vmv: f64 = v.iter().zip(&mv).map(|(a, b)| a * b).sum();
            let lambda = if vmv > 0.0 { vkv / vmv } else { 0.0 };
            let r: Vec<f64> = kv.iter().zip(&mv).map(|(a, b)| a - lambda * b).collect();
            (lambda, r, vmv)
        })
        .collect();
    let mut r = Mat::from_fn(n, m, |i, j| per_pair[j].1[i]);
    metric.solve_c(r.rb_mut());
    let eigenvalues = per_pair.iter().map(|p| p.0).collect();
    let residuals = (0..m)
        .map(|j| crate::spectral::thin_products::col_norm2(r.col(j)) / per_pair[j].2.sqrt())
        .collect();
    PartialSpectrum {
        eigenvalues,
        eigenvectors,
        residuals,
        info,
    }
}
