//! The one sign (and cluster-basis) rule for eigenvectors, shared by the dense path
//! ([`super::basis`]) and the partial path ([`super::partial`]).
//!
//! Eigensolvers return each eigenvector up to sign, and each repeated eigenvalue's
//! eigenspace up to an orthogonal rotation. A decoder that recomputes a basis, a test
//! that compares two solvers, and a user who plots eigenvector 7 all need one
//! answer, so both paths apply this rule to their vectors `e` (columns of `E`, in the
//! operator's own coordinates — sign convention `F = D − W`, positive semi-definite):
//!
//! 1. Eigenvalues (ascending) are grouped into *clusters*: consecutive eigenvalues
//!    closer than `rel_tol · max(1, max|λ|)` form one (numerically) repeated
//!    eigenvalue.
//! 2. Fixed probe vectors `r_0, r_1, …` ([`probe`]):
//!    `r_q[i] = 2·(splitmix64(0x6d65_7368_6c61_7021 ⊕ (q << 32) ⊕ i) >> 11)·2⁻⁵³ − 1`,
//!    uniform in [−1, 1), depending only on the vertex index i and the position q
//!    inside the cluster.
//! 3. A **simple eigenvector** gets the sign with `e·r_0 ≥ 0` (an exact ±1 factor).
//!    A cluster of k columns `V_c` (orthonormal in the solver's inner product) becomes
//!    `V_c·Q`, where `V_cᵀ·P = Q·R` (Gram–Schmidt, positive diagonal) and
//!    `P[i][q] = r_q[i]·scale[i]`. Any other orthonormal basis `V_c·O` of the same
//!    eigenspace gives the same `V_c·Q`, so the result depends only on the eigenspace.
//!
//! `scale` maps the solver's coordinates to the operator's: the dense symmetrized path
//! works on `u = S^{1/2} e` and passes `S^{-1/2}`, so that `u·(S^{-1/2} r) = e·r`; the
//! partial path works on `e` itself and passes `None`.
//!
//! Plain loops in index order, not faer's CPU-dispatched kernels, so that a
//! bit-reproducible decomposition stays bit-reproducible (the codec relies on it).

use faer::Mat;

/// Probe vector entry `r_q[i]`, uniform in [−1, 1) (see the module documentation).
pub fn probe(i: usize, q: usize) -> f64 {
    let z = crate::rng::mix(0x6d65_7368_6c61_7021u64 ^ ((q as u64) << 32) ^ (i as u64));
    2.0 * crate::rng::unit(z) - 1.0
}

/// Groups ascending eigenvalues into clusters `(start, len)` by consecutive gaps
/// `> rel_tol · max(1, max|λ|)`.
pub(crate) fn clusters(eigenvalues: &[f64], rel_tol: f64) -> Vec<(usize, usize)> {
    let big = eigenvalues.iter().fold(1.0f64, |a, v| a.max(v.abs()));
    let tol = rel_tol * big;
    let mut out = Vec::new();
    let mut start = 0;
    for j in 1..=eigenvalues.len() {
        if j == eigenvalues.len() || eigenvalues[j] - eigenvalues[j - 1] > tol {
            out.push((start, j - start));
            start = j;
        }
    }
    out
}

/// Gram–Schmidt (modified, applied twice) on the columns of `a` in place; returns
/// false when a column is numerically dependent on the previous ones.
pub(crate) fn orthonormalize(a: &mut Mat<f64>) -> bool {
    let (n, k) = (a.nrows(), a.ncols());
    let mut ok = true;
    for j in 0..k {
        let norm0 = col_norm(a, j);
        for _ in 0..2 {
            for p in 0..j {
                let d: f64 = (0..n).map(|i| a[(i, p)] * a[(i, j)]).sum();
                for i in 0..n {
                    let v = a[(i, p)];
                    a[(i, j)] -= d * v;
                }
            }
        }
        let norm = col_norm(a, j);
        if norm.is_nan() || norm <= 1e-8 * norm0 || norm == 0.0 {
            ok = false;
        }
        let inv = if norm > 0.0 { 1.0 / norm } else { 0.0 };
        for i in 0..n {
            a[(i, j)] *= inv;
        }
    }
    ok
}

/// Euclidean norm of column `j`, summed in index order (the same bits on every CPU).
fn col_norm(a: &Mat<f64>, j: usize) -> f64 {
    (0..a.nrows())
        .map(|i| a[(i, j)] * a[(i, j)])
        .fold(0.0, |s, x| s + x)
        .sqrt()
}

/// Canonical vectors: a simple eigenvector gets the sign with `e·r_0 ≥ 0` (an exact
/// ±1 factor); a cluster's columns `V_c` (orthonormal, n×k) become `V_c·Q` where
/// `V_cᵀ·P = Q·R` with `P[i][q] = probe(i, q)·probe_scale[i]`. Plain loops in index
/// order, not faer's CPU-dispatched kernels, so that a bit-reproducible
/// decomposition stays bit-reproducible.
///
/// `clusters` are disjoint and ascending (as [`clusters`] returns them); columns
/// outside every cluster are left alone. The clusters are independent, so they are
/// processed in parallel on the current rayon pool, each by the same sequential
/// arithmetic: the result does not depend on the thread count. O(n·Σk²) flops (O(n²)
/// for a simple spectrum), one pass over each column.
pub(crate) fn canonicalize(
    v: &mut Mat<f64>,
    clusters: &[(usize, usize)],
    probe_scale: Option<&[f64]>,
) {
    use rayon::prelude::*;
    let n = v.nrows();
    let kmax = clusters.iter().map(|c| c.1).max().unwrap_or(0);
    let probes: Vec<Vec<f64>> = (0..kmax)
        .into_par_iter()
        .map(|q| {
            (0..n)
                .map(|i| probe(i, q) * probe_scale.map_or(1.0, |s| s[i]))
                .collect()
        })
        .collect();
    // One disjoint block of columns per cluster.
    let mut blocks = Vec::with_capacity(clusters.len());
    let mut rest = v.as_mut();
    let mut offset = 0;
    for &(start, k) in clusters {
        assert!(start >= offset, "clusters must be disjoint and ascending");
        let (block, tail) = rest.split_at_col_mut(start - offset).1.split_at_col_mut(k);
        blocks.push(block);
        rest = tail;
        offset = start + k;
    }
    blocks
        .into_par_iter()
        .with_min_len(8)
        .for_each(|block| canonicalize_cluster(block, &probes));
}

/// [`canonicalize`] on one cluster's columns (n×k, contiguous columns).
fn canonicalize_cluster(mut v: faer::MatMut<'_, f64>, probes: &[Vec<f64>]) {
    let (n, k) = (v.nrows(), v.ncols());
    let dot = |x: &[f64], r: &[f64]| -> f64 {
        x.iter().zip(r).map(|(a, b)| a * b).fold(0.0, |s, x| s + x)
    };
    if k == 1 {
        let col = v.col_mut(0).try_as_col_major_mut().unwrap().as_slice_mut();
        if dot(col, &probes[0]) < 0.0 {
            col.iter_mut().for_each(|x| *x = -*x);
        }
        return;
    }
    let mut c = Mat::from_fn(k, k, |p, q| {
        dot(
            v.as_ref().col(p).try_as_col_major().unwrap().as_slice(),
            &probes[q],
        )
    });
    orthonormalize(&mut c);
    let mut row = vec![0.0; k];
    for i in 0..n {
        for (q, r) in row.iter_mut().enumerate() {
            *r = (0..k)
                .map(|p| v[(i, p)] * c[(p, q)])
                .fold(0.0, |s, x| s + x);
        }
        for (q, &r) in row.iter().enumerate() {
            v[(i, q)] = r;
        }
    }
}
