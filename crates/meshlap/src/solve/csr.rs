//! Compressed sparse row matrix with `u32` column indices and the blocked kernels the
//! Krylov solvers spend their time in.
//!
//! Hand-written because the solvers apply the matrix to an n×3 **row-major** block (the
//! three coordinates of a vertex are adjacent), reading each matrix entry once for all
//! three columns, with 4-byte indices: a CG iteration is bound by memory bandwidth, and
//! this layout reads 12 bytes per nonzero instead of faer's column-by-column product
//! over 16-byte `usize` indices three times.

use super::op::{residual_chunks, residual_rows, ResidualSums};
use super::{Fused, MAX_COLUMNS};
use crate::SparseMatrix;
use rayon::prelude::*;
use std::ops::Range;

/// Rows per parallel task.
pub(crate) const CHUNK: usize = 4096;

/// An n×m CSR matrix (`f64` values, `u32` column indices).
#[derive(Clone, Debug, PartialEq)]
pub struct CsrMatrix {
    nrows: usize,
    ncols: usize,
    row_ptr: Vec<usize>,
    col: Vec<u32>,
    val: Vec<f64>,
}

impl CsrMatrix {
    /// Converts a CSC matrix to CSR (a transpose of the storage, O(nnz)).
    pub fn from_csc(m: &SparseMatrix) -> Self {
        let (ptr, col, val) = transpose_storage(
            m.nrows(),
            m.ncols(),
            |j| m.symbolic().col_range(j),
            |p| m.symbolic().row_idx()[p],
            m.val(),
            |j| j as u32,
        );
        Self::from_parts(m.nrows(), m.ncols(), ptr, col, val)
    }

    /// The transpose `Aᵀ` as CSR (a transpose of the storage, O(nnz); each row's
    /// columns ascending).
    pub fn transpose(&self) -> CsrMatrix {
        let (ptr, col, val) = self.by_columns(|i| i as u32);
        Self::from_parts(self.ncols, self.nrows, ptr, col, val)
    }

    /// The entries compressed by columns (rows ascending in each), row indices as
    /// `index` makes them.
    fn by_columns<T: Copy + Default + Send + Sync>(
        &self,
        index: impl Fn(usize) -> T,
    ) -> (Vec<usize>, Vec<T>, Vec<f64>) {
        transpose_storage(
            self.ncols,
            self.nrows,
            |i| self.row_range(i),
            |p| self.col[p] as usize,
            &self.val,
            index,
        )
    }

    /// The CSR of the transpose of a CSC matrix: the CSC arrays read as rows.
    pub fn transpose_of_csc(m: &SparseMatrix) -> Self {
        let (nr, nc) = (m.nrows(), m.ncols());
        let row_ptr: Vec<usize> = (0..=nc).map(|j| m.col_ptr()[j]).collect();
        let mut col = Vec::with_capacity(m.compute_nnz());
        let mut val = Vec::with_capacity(m.compute_nnz());
        for j in 0..nc {
            col.extend(m.row_idx_of_col_raw(j).iter().map(|&i| i as u32));
            val.extend_from_slice(m.val_of_col(j));
        }
        Self::from_parts(nc, nr, row_ptr, col, val)
    }

    fn from_parts(
        nrows: usize,
        ncols: usize,
        row_ptr: Vec<usize>,
        col: Vec<u32>,
        val: Vec<f64>,
    ) -> Self {
        CsrMatrix {
            nrows,
            ncols,
            row_ptr,
            col,
            val,
        }
    }

    fn row_range(&self, i: usize) -> Range<usize> {
        self.row_ptr[i]..self.row_ptr[i + 1]
    }

    /// Rows.
    pub fn nrows(&self) -> usize {
        self.nrows
    }
    /// Columns.
    pub fn ncols(&self) -> usize {
        self.ncols
    }
    /// Stored entries.
    pub fn nnz(&self) -> usize {
        self.val.len()
    }
    /// Bytes one product streams from the matrix (values, indices, row pointers).
    pub fn bytes(&self) -> usize {
        self.val.len() * 12 + self.row_ptr.len() * 8
    }

    /// The diagonal (0 where not stored).
    pub fn diagonal(&self) -> Vec<f64> {
        (0..self.nrows)
            .map(|i| {
                self.row_range(i)
                    .find(|&p| self.col[p] as usize == i)
                    .map_or(0.0, |p| self.val[p])
            })
            .collect()
    }

    /// Rows `start..start + ys.len()/k` of `y = A x` (n×k row-major blocks) into `ys`,
    /// adding `Σ w·y` and `Σ y²` of those rows to `acc` per column when `w` is given.
    /// Three columns (a mesh's coordinates) take [`Self::rows3`].
    #[inline(always)]
    fn product_rows(
        &self,
        x: &[f64],
        start: usize,
        ys: &mut [f64],
        k: usize,
        w: Option<&[f64]>,
        acc: &mut ([f64; MAX_COLUMNS], [f64; MAX_COLUMNS]),
    ) {
        if k == 3 && x.len() >= 3 * self.ncols {
            return self.rows3(x, start, ys, w, acc);
        }
        let nr = ys.len() / k;
        for r in 0..nr {
            let i = start + r;
            let (s, e) = (self.row_ptr[i], self.row_ptr[i + 1]);
            for c in 0..k {
                let mut a = 0.0;
                for p in s..e {
                    a += self.val[p] * x[self.col[p] as usize * k + c];
                }
                ys[k * r + c] = a;
            }
            if let Some(w) = w {
                for c in 0..k {
                    let yv = ys[k * r + c];
                    acc.0[c] += w[k * i + c] * yv;
                    acc.1[c] += yv * yv;
                }
            }
        }
    }

    /// [`Self::product_rows`] for k = 3: each entry read once for the three columns,
    /// the gathers from `x` without bounds checks (the caller checks
    /// `x.len() ≥ 3·ncols`; every stored column index is below ncols by construction).
    #[inline(always)]
    fn rows3(
        &self,
        x: &[f64],
        start: usize,
        ys: &mut [f64],
        w: Option<&[f64]>,
        acc: &mut ([f64; MAX_COLUMNS], [f64; MAX_COLUMNS]),
    ) {
        let nr = ys.len() / 3;
        let rp = &self.row_ptr[start..start + nr + 1];
        let (col, val) = (&self.col[..], &self.val[..]);
        for r in 0..nr {
            let (s, e) = (rp[r], rp[r + 1]);
            let (mut a0, mut a1, mut a2) = (0.0, 0.0, 0.0);
            for (&v, &c) in val[s..e].iter().zip(&col[s..e]) {
                let j = 3 * c as usize;
                // SAFETY: c < ncols (an invariant of every constructor) and
                // x.len() ≥ 3·ncols, so j + 2 < x.len().
                unsafe {
                    a0 += v * *x.get_unchecked(j);
                    a1 += v * *x.get_unchecked(j + 1);
                    a2 += v * *x.get_unchecked(j + 2);
                }
            }
            ys[3 * r] = a0;
            ys[3 * r + 1] = a1;
            ys[3 * r + 2] = a2;
            if let Some(w) = w {
                let i = start + r;
                let yv = [a0, a1, a2];
                for c in 0..3 {
                    acc.0[c] += w[3 * i + c] * yv[c];
                    acc.1[c] += yv[c] * yv[c];
                }
            }
        }
    }

    /// `y = A x` for an n×k row-major block, in parallel over row chunks, with the
    /// reductions of `fused` in the same pass (at most [`MAX_COLUMNS`] columns then).
    pub(crate) fn product(&self, x: &[f64], y: &mut [f64], k: usize, fused: Option<Fused<'_>>) {
        if k == 0 {
            return;
        }
        let zero = || ([0.0; MAX_COLUMNS], [0.0; MAX_COLUMNS]);
        match fused {
            None => y
                .par_chunks_mut(CHUNK * k)
                .enumerate()
                .for_each(|(b, ys)| self.product_rows(x, b * CHUNK, ys, k, None, &mut zero())),
            Some(Fused { w, dot, norm2 }) => {
                let total = y
                    .par_chunks_mut(CHUNK * k)
                    .enumerate()
                    .map(|(b, ys)| {
                        let mut acc = zero();
                        self.product_rows(x, b * CHUNK, ys, k, Some(w), &mut acc);
                        acc
                    })
                    .reduce(zero, |a, b| {
                        (
                            std::array::from_fn(|c| a.0[c] + b.0[c]),
                            std::array::from_fn(|c| a.1[c] + b.1[c]),
                        )
                    });
                dot[..k].copy_from_slice(&total.0[..k]);
                norm2[..k].copy_from_slice(&total.1[..k]);
            }
        }
    }

    /// [`LinOp::residual`](super::LinOp::residual) in one parallel pass: each chunk of
    /// [`CHUNK`] rows computes its rows of `A x` into `r` and completes them into
    /// `b − A x` (with `z` and the sums) while they are still in cache.
    pub(crate) fn residual_pass(
        &self,
        b: &[f64],
        x: &[f64],
        r: &mut [f64],
        k: usize,
        d: Option<&[f64]>,
        z: Option<&mut [f64]>,
    ) -> ResidualSums {
        residual_chunks(b, r, z, d, k, |first, bs, rs, zs, ds| {
            let mut acc = ([0.0; MAX_COLUMNS], [0.0; MAX_COLUMNS]);
            self.product_rows(x, first, rs, k, None, &mut acc);
            residual_rows(bs, rs, zs, ds, k)
        })
    }

    /// `A·B` (Gustavson's algorithm), for small polynomial filters such as F².
    pub fn matmul(&self, b: &CsrMatrix) -> CsrMatrix {
        let mut row_ptr = vec![0usize; self.nrows + 1];
        let mut col = Vec::new();
        let mut val = Vec::new();
        let mut acc = vec![0.0; b.ncols];
        let mut mark = vec![usize::MAX; b.ncols];
        let mut touched = Vec::new();
        for i in 0..self.nrows {
            touched.clear();
            for p in self.row_range(i) {
                let (k, a) = (self.col[p] as usize, self.val[p]);
                for q in b.row_ptr[k]..b.row_ptr[k + 1] {
                    let j = b.col[q] as usize;
                    if mark[j] != i {
                        mark[j] = i;
                        acc[j] = 0.0;
                        touched.push(j);
                    }
                    acc[j] += a * b.val[q];
                }
            }
            touched.sort_unstable();
            for &j in &touched {
                col.push(j as u32);
                val.push(acc[j]);
            }
            row_ptr[i + 1] = col.len();
        }
        Self::from_parts(self.nrows, b.ncols, row_ptr, col, val)
    }

    /// `α·I + β·A` (square A; the diagonal is added to the pattern where missing).
    pub fn shifted(&self, alpha: &[f64], beta: f64) -> CsrMatrix {
        let mut row_ptr = vec![0usize; self.nrows + 1];
        let mut col = crate::mem::advised_capacity::<u32>(self.nnz() + self.nrows);
        let mut val = crate::mem::advised_capacity::<f64>(self.nnz() + self.nrows);
        for i in 0..self.nrows {
            let mut placed = false;
            for p in self.row_range(i) {
                let j = self.col[p] as usize;
                if !placed && j > i {
                    col.push(i as u32);
                    val.push(alpha[i]);
                    placed = true;
                }
                if j == i {
                    col.push(i as u32);
                    val.push(alpha[i] + beta * self.val[p]);
                    placed = true;
                } else {
                    col.push(j as u32);
                    val.push(beta * self.val[p]);
                }
            }
            if !placed {
                col.push(i as u32);
                val.push(alpha[i]);
            }
            row_ptr[i + 1] = col.len();
        }
        Self::from_parts(self.nrows, self.ncols, row_ptr, col, val)
    }

    /// `diag(s)·A` (row i scaled by `s[i]`).
    pub fn scale_rows(&self, s: &[f64]) -> CsrMatrix {
        let mut out = self.clone();
        for i in 0..self.nrows {
            for p in self.row_range(i) {
                out.val[p] *= s[i];
            }
        }
        out
    }

    /// Linear combination `a·A + b·B` of two matrices of equal shape.
    pub fn add(&self, a: f64, other: &CsrMatrix, b: f64) -> CsrMatrix {
        let mut row_ptr = vec![0usize; self.nrows + 1];
        let (mut col, mut val) = (Vec::new(), Vec::new());
        for i in 0..self.nrows {
            let (mut p, pe) = (self.row_ptr[i], self.row_ptr[i + 1]);
            let (mut q, qe) = (other.row_ptr[i], other.row_ptr[i + 1]);
            while p < pe || q < qe {
                let jp = if p < pe { self.col[p] } else { u32::MAX };
                let jq = if q < qe { other.col[q] } else { u32::MAX };
                if jp == jq {
                    col.push(jp);
                    val.push(a * self.val[p] + b * other.val[q]);
                    p += 1;
                    q += 1;
                } else if jp < jq {
                    col.push(jp);
                    val.push(a * self.val[p]);
                    p += 1;
                } else {
                    col.push(jq);
                    val.push(b * other.val[q]);
                    q += 1;
                }
            }
            row_ptr[i + 1] = col.len();
        }
        Self::from_parts(self.nrows, self.ncols, row_ptr, col, val)
    }

    /// Converts back to faer's CSC (for the direct solvers).
    pub fn to_csc(&self) -> SparseMatrix {
        let (col_ptr, row_idx, vals) = self.by_columns(|i| i);
        faer::sparse::SparseColMat::new(
            faer::sparse::SymbolicSparseColMat::new_checked(
                self.nrows, self.ncols, col_ptr, None, row_idx,
            ),
            vals,
        )
    }
}

/// Counting-sort transposition of compressed storage: `n_outer` lists (entries
/// `range(o)`, inner index `inner(p)` and value `val[p]` of entry p) over `n_inner`
/// inner positions become `n_inner` lists over the outer positions, each ascending.
/// Returns the pointers, the indices (as `index` makes them) and the values.
fn transpose_storage<T: Copy + Default + Send + Sync>(
    n_inner: usize,
    n_outer: usize,
    range: impl Fn(usize) -> Range<usize>,
    inner: impl Fn(usize) -> usize,
    val: &[f64],
    index: impl Fn(usize) -> T,
) -> (Vec<usize>, Vec<T>, Vec<f64>) {
    let mut ptr = vec![0usize; n_inner + 1];
    for o in 0..n_outer {
        for p in range(o) {
            ptr[inner(p) + 1] += 1;
        }
    }
    for i in 0..n_inner {
        ptr[i + 1] += ptr[i];
    }
    let nnz = ptr[n_inner];
    let mut fill = ptr.clone();
    let mut idx = crate::mem::zeroed_vec(T::default(), nnz);
    let mut out = crate::mem::zeroed_vec(0.0, nnz);
    for o in 0..n_outer {
        for p in range(o) {
            let i = inner(p);
            let q = fill[i];
            fill[i] += 1;
            idx[q] = index(o);
            out[q] = val[p];
        }
    }
    (ptr, idx, out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{builtin, topology::Topology};
    use crate::solve::LinOp;

    /// The Tutte Laplacian of a cube (non-symmetric), as faer's CSC and as CSR.
    fn tutte() -> (SparseMatrix, CsrMatrix) {
        let m = builtin::cube(3).unwrap();
        let f = crate::operator::tutte::tutte(&Topology::new(&m).unwrap()).unwrap();
        let a = CsrMatrix::from_csc(&f);
        (f, a)
    }

    #[test]
    fn blocked_product_matches_faer() {
        let (f, a) = tutte();
        let n = f.nrows();
        for k in [1usize, 2, 3] {
            let x: Vec<f64> = (0..n * k).map(|i| (i as f64 * 0.37).sin()).collect();
            let mut y = vec![0.0; n * k];
            a.apply(&x, &mut y, k);
            let xm = faer::Mat::from_fn(n, k, |i, c| x[i * k + c]);
            let ym = &f * &xm;
            for i in 0..n {
                for c in 0..k {
                    assert!((y[i * k + c] - ym[(i, c)]).abs() < 1e-14);
                }
            }
        }
        let at = CsrMatrix::transpose_of_csc(&f);
        let ft = f.to_dense().transpose().to_owned();
        let back = at.to_csc().to_dense();
        assert!((&back - &ft).norm_max() == 0.0);
        assert_eq!(a.to_csc().to_dense(), f.to_dense());
        let sq = a.matmul(&a).to_csc().to_dense();
        assert!((&sq - &f.to_dense() * &f.to_dense()).norm_max() < 1e-14);
        let sum = a.add(2.0, &at, -1.0).to_csc().to_dense();
        assert!((&sum - (f.to_dense() * 2.0 - &ft)).norm_max() < 1e-14);
    }

    #[test]
    fn the_three_column_kernel_equals_three_single_column_products() {
        // A larger mesh operator (several parallel chunks), k = 3 against k = 1 per
        // column: the same products in the same order, so the same bits.
        let m = builtin::icosphere(5).unwrap();
        let f = crate::operator::tutte::tutte(&Topology::new(&m).unwrap()).unwrap();
        let a = CsrMatrix::from_csc(&f).shifted(&vec![1.0; f.nrows()], 30.0);
        let n = a.nrows();
        let x: Vec<f64> = (0..3 * n).map(|i| (i as f64 * 0.37).sin()).collect();
        let mut y = vec![0.0; 3 * n];
        let (mut dot, mut norm2) = ([0.0; MAX_COLUMNS], [0.0; MAX_COLUMNS]);
        a.apply_fused(&x, &mut y, 3, Fused::new(&x, &mut dot, &mut norm2));
        for c in 0..3 {
            let xc: Vec<f64> = (0..n).map(|i| x[3 * i + c]).collect();
            let mut yc = vec![0.0; n];
            a.apply(&xc, &mut yc, 1);
            for i in 0..n {
                assert_eq!(yc[i], y[3 * i + c]);
            }
            let d: f64 = (0..n).map(|i| xc[i] * yc[i]).sum();
            let q: f64 = yc.iter().map(|v| v * v).sum();
            assert!((dot[c] - d).abs() < 1e-12 * d.abs() && (norm2[c] - q).abs() < 1e-12 * q);
        }
    }

    #[test]
    fn transpose_equals_the_transpose_of_the_csc() {
        let (f, a) = tutte();
        // Same entries in the same order as reading faer's CSC as rows.
        assert_eq!(a.transpose(), CsrMatrix::transpose_of_csc(&f));
        assert_eq!(a.transpose().transpose(), a);
        let shifted = a.shifted(&vec![2.0; a.nrows()], 0.5);
        assert_eq!(
            shifted.transpose(),
            CsrMatrix::transpose_of_csc(&shifted.to_csc())
        );
    }
}
