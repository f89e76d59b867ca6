//! Compressed sparse row matrix with `u32` column indices and the blocked kernels the
//! Krylov solvers spend their time in.
//!
//! Hand-written because the solvers apply the matrix to an n×3 **row-major** block (the
//! three coordinates of a vertex are adjacent), reading each matrix entry once for all
//! three columns, with 4-byte indices: a CG iteration is bound by memory bandwidth, and
//! this layout reads 12 bytes per nonzero instead of faer's column-by-column product
//! over 16-byte `usize` indices three times. For BiCG, `PairedCsr` keeps A and Aᵀ
//! over one pattern (the pair `(a_ij, a_ji)` per entry) so that both products are one
//! pass over interleaved `[p | p̃]` rows; no sparse crate offers that layout.

use super::op::{residual_chunks, residual_rows, ResidualSums};
use super::{Fused, MAX_COLUMNS};
use crate::par::FoldInOrder;
use crate::SparseMatrix;
use rayon::prelude::*;
use std::ops::Range;

/// Rows per parallel task (under Miri 64, so that the small systems it can interpret
/// still split into several; RELIABILITY.md).
pub(crate) const CHUNK: usize = if cfg!(miri) { 64 } else { 4096 };

/// Where the entries of an n×k block lie in a row-major array: entry (i, c) at
/// `i·stride + offset + c`. A block of its own is [`Layout::dense`]; BiCG keeps two
/// n×k blocks side by side in one n×2k block ([`Layout::half`]), so that a gather of
/// row j reads both from one place.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Layout {
    pub(crate) stride: usize,
    pub(crate) offset: usize,
}

impl Layout {
    /// An n×k block of its own.
    pub(crate) const fn dense(k: usize) -> Self {
        Layout {
            stride: k,
            offset: 0,
        }
    }
    /// The left (`half` = 0) or right (1) n×k half of an n×2k block.
    pub(crate) const fn half(k: usize, half: usize) -> Self {
        Layout {
            stride: 2 * k,
            offset: half * k,
        }
    }
}

/// Reductions fused into a product `y = A x`, per column c < k:
/// `Σ_i weight_i·w(i, c)·y(i, c)` (weights 1 when `None`) and `Σ_i y(i, c)²`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Reduce<'a> {
    pub(crate) w: &'a [f64],
    pub(crate) at: Layout,
    pub(crate) weights: Option<&'a [f64]>,
}

/// Per-column sums of a fused product: (`Σ weight·w·y`, `Σ y²`).
pub(crate) type Acc = ([f64; MAX_COLUMNS], [f64; MAX_COLUMNS]);

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
    /// Converts a CSC matrix to CSR: a counting-sort transpose of the storage,
    /// O(nnz), in parallel over blocks of columns.
    pub fn from_csc(m: &SparseMatrix) -> Self {
        let (ptr, col, val) = crate::operator::csr::transpose_storage(
            m.nrows(),
            m.ncols(),
            |j| m.symbolic().col_range(j),
            |p| m.symbolic().row_idx()[p],
            m.val(),
            |j| j as u32,
            None,
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
        index: impl Fn(usize) -> T + Sync,
    ) -> (Vec<usize>, Vec<T>, Vec<f64>) {
        crate::operator::csr::transpose_storage(
            self.ncols,
            self.nrows,
            |i| self.row_range(i),
            |p| self.col[p] as usize,
            &self.val,
            index,
            None,
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

    /// The arrays a product walks.
    pub(crate) fn rows(&self) -> Rows<'_, f64> {
        Rows::new(self.ncols, &self.row_ptr, &self.col, &self.val)
    }

    /// Row i's stored entries `(column, value)`, columns ascending.
    pub fn row_entries(&self, i: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        self.row_range(i)
            .map(|p| (self.col[p] as usize, self.val[p]))
    }

    /// Entry (i, j), `None` where not stored (a binary search of row i).
    pub fn entry(&self, i: usize, j: usize) -> Option<f64> {
        let r = self.row_range(i);
        let at = self.col[r.clone()].binary_search(&(j as u32)).ok()?;
        Some(self.val[r.start + at])
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

    /// `y = A x` for the `M·k` columns of x laid out as `xl` into y laid out as `yl`
    /// (n rows each), in parallel over row chunks, with the reductions of `red` over
    /// the first k columns in the same pass (k ≤ [`MAX_COLUMNS`] then). Returns the
    /// sums (0 without `red`). See [`product_with`].
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn product_with<const M: usize>(
        &self,
        x: &[f64],
        xl: Layout,
        y: &mut [f64],
        yl: Layout,
        k: usize,
        red: Option<Reduce<'_>>,
    ) -> Acc {
        product_with::<M, f64>(self.rows(), x, xl, y, yl, k, red)
    }

    /// `y = A x` for an n×k row-major block, in parallel over row chunks, with the
    /// reductions of `fused` in the same pass (at most [`MAX_COLUMNS`] columns then).
    pub(crate) fn product(&self, x: &[f64], y: &mut [f64], k: usize, fused: Option<Fused<'_>>) {
        let dense = Layout::dense(k);
        match fused {
            None => {
                self.product_with::<1>(x, dense, y, dense, k, None);
            }
            Some(Fused { w, dot, norm2 }) => {
                let red = Reduce {
                    w,
                    at: dense,
                    weights: None,
                };
                let (d, q) = self.product_with::<1>(x, dense, y, dense, k, Some(red));
                dot[..k].copy_from_slice(&d[..k]);
                norm2[..k].copy_from_slice(&q[..k]);
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
        // The kernel's gathers are unchecked: every x index must be in bounds.
        assert!(x.len() >= self.ncols * k, "x is shorter than ncols·k");
        residual_chunks(b, r, z, d, k, |first, bs, rs, zs, ds| {
            let mut acc = ([0.0; MAX_COLUMNS], [0.0; MAX_COLUMNS]);
            let dense = Layout::dense(k);
            product_rows::<1, f64>(self.rows(), x, dense, first, rs, dense, k, None, &mut acc);
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

/// The arrays a product walks: row pointers, column indices (every one below
/// ncols) and values of an n×ncols matrix; a value is one number or a pair
/// ([`Values`]).
#[derive(Clone, Copy)]
pub(crate) struct Rows<'a, T> {
    pub(crate) ncols: usize,
    pub(crate) row_ptr: &'a [usize],
    pub(crate) col: &'a [u32],
    pub(crate) val: &'a [T],
}

impl<'a, T> Rows<'a, T> {
    pub(crate) fn new(ncols: usize, row_ptr: &'a [usize], col: &'a [u32], val: &'a [T]) -> Self {
        Rows {
            ncols,
            row_ptr,
            col,
            val,
        }
    }
}

/// The stored value of an entry: one number for both halves of a product over two
/// blocks side by side, or a pair (A's and Aᵀ's entry of [`PairedCsr`]).
pub(crate) trait Values: Copy + Send + Sync {
    /// The values for the left and the right half.
    fn halves(self) -> (f64, f64);
}

impl Values for f64 {
    #[inline(always)]
    fn halves(self) -> (f64, f64) {
        (self, self)
    }
}

impl Values for (f64, f64) {
    #[inline(always)]
    fn halves(self) -> (f64, f64) {
        self
    }
}

/// Rows `start..` of `y = A x` into `ys`, the chunk of y's array that holds them:
/// entry (i, c) of x at `xl`, of y at `yl` (relative to the chunk), for the `M·k`
/// columns c < M·k. An entry's value applies to both halves, or its pair's first to
/// the first k columns and its second to the next k (M = 2: two n×k blocks side by
/// side, each index read once for both, and one gather of row j bringing both
/// halves). With `red`, adds `weight_i·w(i, c)·y(i, c)` and `y(i, c)²` of the first k
/// columns to `acc`. Up to [`MAX_COLUMNS`] columns per block the count is a
/// compile-time constant (`with_columns`): the sums stay in registers and the gathers
/// have no bounds checks (the caller, [`product_with`], checks the lengths once).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn product_rows<const M: usize, T: Values>(
    rows: Rows<'_, T>,
    x: &[f64],
    xl: Layout,
    start: usize,
    ys: &mut [f64],
    yl: Layout,
    k: usize,
    red: Option<Reduce<'_>>,
    acc: &mut Acc,
) {
    let nr = ys.len() / yl.stride;
    let (rp, col, val) = (rows.row_ptr, rows.col, rows.val);
    let pick = |v: (f64, f64), c: usize| if c < k { v.0 } else { v.1 };
    if k > MAX_COLUMNS {
        // More columns than the solvers take (a direct `apply`): k read at run time.
        for r in 0..nr {
            let i = start + r;
            for c in 0..M * k {
                let mut a = 0.0;
                for p in rp[i]..rp[i + 1] {
                    a += pick(val[p].halves(), c) * x[col[p] as usize * xl.stride + xl.offset + c];
                }
                ys[r * yl.stride + yl.offset + c] = a;
            }
        }
        return;
    }
    super::krylov::with_columns!(k, K => {
        let whole = Layout::dense(M * K);
        if xl == whole
            && yl == whole
            && red.is_none_or(|r| r.at.stride == M * K && (r.at.offset == 0 || r.at.offset == K))
        {
            // The solvers' cases, with the strides known at compile time.
            dense_rows::<M, T>(rows, x, start, ys, K, red, acc);
            return;
        }
        for r in 0..nr {
            let i = start + r;
            let mut a = [0.0; 2 * MAX_COLUMNS];
            let (s, e) = (rp[i], rp[i + 1]);
            for (&v, &jc) in val[s..e].iter().zip(&col[s..e]) {
                let (v, j) = (v.halves(), jc as usize * xl.stride + xl.offset);
                for c in 0..M * K {
                    let v = if c < K { v.0 } else { v.1 };
                    // SAFETY: jc < ncols (an invariant of every constructor), and
                    // product_with checked x.len() ≥ ncols·xl.stride and
                    // xl.offset + M·k ≤ xl.stride, so j + c < x.len().
                    unsafe {
                        a[c] += v * *x.get_unchecked(j + c);
                    }
                }
            }
            let y0 = r * yl.stride + yl.offset;
            ys[y0..y0 + M * K].copy_from_slice(&a[..M * K]);
            if let Some(Reduce { w, at, weights }) = red {
                let wi = weights.map_or(1.0, |s| s[i]);
                let w0 = i * at.stride + at.offset;
                for c in 0..K {
                    acc.0[c] += wi * w[w0 + c] * a[c];
                    acc.1[c] += a[c] * a[c];
                }
            }
        }
    })
}

/// [`product_rows`] when x and y are blocks of their own (`Layout::dense(M·k)`: one
/// n×k block, or two side by side as one n×2k block) and the reductions read the
/// left or right n×k half of an n×(M·k) block: the solvers' products (CG, the
/// residual, BiCG over `[p | p̃]`). The same operations in the same order, so the same
/// bits, with the strides constants once inlined into a `with_columns` arm (the
/// generic loop computes every index from run-time strides, which costs measurably:
/// BENCHMARKS.md, "What limits the product").
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn dense_rows<const M: usize, T: Values>(
    rows: Rows<'_, T>,
    x: &[f64],
    start: usize,
    ys: &mut [f64],
    k: usize,
    red: Option<Reduce<'_>>,
    acc: &mut Acc,
) {
    let (rp, col, val) = (rows.row_ptr, rows.col, rows.val);
    let mk = M * k;
    for r in 0..ys.len() / mk {
        let i = start + r;
        let mut a = [0.0; 2 * MAX_COLUMNS];
        let (s, e) = (rp[i], rp[i + 1]);
        for (&v, &jc) in val[s..e].iter().zip(&col[s..e]) {
            let (v, j) = (v.halves(), jc as usize * mk);
            for (c, ac) in a.iter_mut().enumerate().take(mk) {
                let v = if c < k { v.0 } else { v.1 };
                // SAFETY: jc < ncols (an invariant of every constructor), and the
                // callers checked x.len() ≥ ncols·M·k, so j + c < x.len().
                unsafe {
                    *ac += v * *x.get_unchecked(j + c);
                }
            }
        }
        ys[r * mk..r * mk + mk].copy_from_slice(&a[..mk]);
        if let Some(Reduce { w, at, weights }) = red {
            let wi = weights.map_or(1.0, |s| s[i]);
            let w = &w[i * mk + at.offset..i * mk + at.offset + k];
            for c in 0..k {
                acc.0[c] += wi * w[c] * a[c];
                acc.1[c] += a[c] * a[c];
            }
        }
    }
}

/// `y = A x` over the arrays `rows` ([`product_rows`]), in parallel over chunks of
/// [`CHUNK`] rows; the sums of `red`.
///
/// # Panics
/// When x or y is too short for n rows of its layout, or a layout's columns do not
/// fit in its stride (the solvers' blocks always fit).
#[allow(clippy::too_many_arguments)]
pub(crate) fn product_with<const M: usize, T: Values>(
    rows: Rows<'_, T>,
    x: &[f64],
    xl: Layout,
    y: &mut [f64],
    yl: Layout,
    k: usize,
    red: Option<Reduce<'_>>,
) -> Acc {
    let zero = || ([0.0; MAX_COLUMNS], [0.0; MAX_COLUMNS]);
    let nrows = rows.row_ptr.len() - 1;
    if k == 0 {
        return zero();
    }
    assert!(xl.offset + M * k <= xl.stride && x.len() >= rows.ncols * xl.stride);
    assert!(yl.offset + M * k <= yl.stride && y.len() == nrows * yl.stride);
    if let Some(r) = red {
        assert!(k <= MAX_COLUMNS && r.at.offset + k <= r.at.stride);
        assert!(r.w.len() >= nrows * r.at.stride);
        assert!(r.weights.is_none_or(|s| s.len() >= nrows));
    }
    let chunks = y.par_chunks_mut(CHUNK * yl.stride).enumerate();
    match red {
        None => {
            chunks.for_each(|(b, ys)| {
                product_rows::<M, T>(rows, x, xl, b * CHUNK, ys, yl, k, None, &mut zero())
            });
            zero()
        }
        Some(red) => chunks
            .map(|(b, ys)| {
                let mut acc = zero();
                product_rows::<M, T>(rows, x, xl, b * CHUNK, ys, yl, k, Some(red), &mut acc);
                acc
            })
            .fold_in_order(zero(), super::op::add_pairs),
    }
}

/// A square matrix and its transpose over the union of their patterns: row i holds,
/// for every j where `a_ij` or `a_ji` is stored, the pair `(a_ij, a_ji)` (0 for the
/// one that is not). BiCG's two products `Ap` and `Aᵀp̃` are then one pass over one
/// pattern, each gather of row j reading `[p_j | p̃_j]` from one place.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct PairedCsr {
    ncols: usize,
    row_ptr: Vec<usize>,
    col: Vec<u32>,
    val: Vec<(f64, f64)>,
}

impl PairedCsr {
    /// Merges each row of `a` with the same row of `at` (= Aᵀ; both with ascending
    /// columns), O(nnz).
    pub(crate) fn new(a: &CsrMatrix, at: &CsrMatrix) -> Self {
        let n = a.nrows;
        // Row i's merged columns and value pairs, written when `out` is given; the
        // row's length.
        type RowOut<'a> = (&'a mut [u32], &'a mut [(f64, f64)]);
        let merged = |i: usize, mut out: Option<RowOut<'_>>| -> usize {
            let (ra, rt) = (a.row_range(i), at.row_range(i));
            let (mut p, mut q, mut m) = (ra.start, rt.start, 0);
            while p < ra.end || q < rt.end {
                let ja = if p < ra.end { a.col[p] } else { u32::MAX };
                let jt = if q < rt.end { at.col[q] } else { u32::MAX };
                let j = ja.min(jt);
                let va = if ja == j { a.val[p] } else { 0.0 };
                let vt = if jt == j { at.val[q] } else { 0.0 };
                p += usize::from(ja == j);
                q += usize::from(jt == j);
                if let Some((c, v)) = out.as_mut() {
                    c[m] = j;
                    v[m] = (va, vt);
                }
                m += 1;
            }
            m
        };
        let counts: Vec<usize> = (0..n).into_par_iter().map(|i| merged(i, None)).collect();
        let mut row_ptr = Vec::with_capacity(n + 1);
        row_ptr.push(0);
        for c in &counts {
            row_ptr.push(row_ptr.last().copied().unwrap_or(0) + c);
        }
        let total = row_ptr[n];
        let mut col = vec![0u32; total];
        let mut val = vec![(0.0, 0.0); total];
        // Split the output arrays at the row boundaries and fill the rows in parallel.
        let mut parts = Vec::with_capacity(n);
        let (mut cs, mut vs) = (&mut col[..], &mut val[..]);
        for c in &counts {
            let (c0, c1) = std::mem::take(&mut cs).split_at_mut(*c);
            let (v0, v1) = std::mem::take(&mut vs).split_at_mut(*c);
            parts.push((c0, v0));
            cs = c1;
            vs = v1;
        }
        parts.into_par_iter().enumerate().for_each(|(i, (c, v))| {
            merged(i, Some((c, v)));
        });
        PairedCsr {
            ncols: a.ncols,
            row_ptr,
            col,
            val,
        }
    }

    /// The same matrix as [`PairedCsr::new`]`(a, aᵀ)` when the pattern of `a` is
    /// symmetric (every stored `a_ij` has a stored `a_ji`), built without forming the
    /// transpose: the union of the patterns is then a's own, and each pair's second
    /// value is found in row j (its columns ascending: a scan of a short row, a binary
    /// search of a long one). `None` if `a` is not square or its pattern is not
    /// symmetric. O(nnz · log d), d the longest row.
    pub(crate) fn mirrored(a: &CsrMatrix) -> Option<Self> {
        /// Rows per parallel work item.
        const ROWS: usize = 1024;
        let n = a.nrows;
        if a.ncols != n {
            return None;
        }
        // Written once, in parallel, when the pattern is symmetric (no zeroing pass).
        let mut val = crate::mem::uninit_vec::<(f64, f64)>(a.col.len());
        // Split the pairs at block boundaries of ROWS rows.
        let mut blocks = Vec::with_capacity(n.div_ceil(ROWS));
        let mut rest = &mut val[..];
        for s in (0..n).step_by(ROWS) {
            let e = (s + ROWS).min(n);
            let (head, tail) = std::mem::take(&mut rest).split_at_mut(a.row_ptr[e] - a.row_ptr[s]);
            blocks.push((s, e, head));
            rest = tail;
        }
        let symmetric = blocks
            .into_par_iter()
            .map(|(s, e, out)| {
                let base = a.row_ptr[s];
                for i in s..e {
                    for p in a.row_range(i) {
                        let j = a.col[p] as usize;
                        let mirror = a.row_range(j);
                        let cols = &a.col[mirror.clone()];
                        // Mesh rows are short, where a linear scan beats a binary
                        // search; a long row (a fan's hub) is searched by halves.
                        let found = if cols.len() <= 32 {
                            cols.iter().position(|&c| c as usize == i)
                        } else {
                            cols.binary_search(&(i as u32)).ok()
                        };
                        let Some(q) = found else {
                            return false;
                        };
                        out[p - base].write((a.val[p], a.val[mirror.start + q]));
                    }
                }
                true
            })
            .reduce(|| true, |x, y| x && y);
        symmetric.then(|| PairedCsr {
            ncols: n,
            row_ptr: a.row_ptr.clone(),
            col: a.col.clone(),
            // SAFETY: the blocks cover every entry, and with the pattern symmetric every
            // block wrote each of its entries (a block returns false, writing no more,
            // only when an entry has no mirror).
            val: unsafe { crate::mem::assume_init_vec(val) },
        })
    }

    fn rows(&self) -> Rows<'_, (f64, f64)> {
        Rows::new(self.ncols, &self.row_ptr, &self.col, &self.val)
    }

    /// [`product_with`] with both halves: the left n×k half of `x` (n×2k, layout
    /// `xl`) times A, the right half times Aᵀ, into y's halves; the sums of `red`.
    pub(crate) fn product_both(
        &self,
        x: &[f64],
        xl: Layout,
        y: &mut [f64],
        yl: Layout,
        k: usize,
        red: Option<Reduce<'_>>,
    ) -> Acc {
        product_with::<2, (f64, f64)>(self.rows(), x, xl, y, yl, k, red)
    }

    /// `y = Aᵀ x` for n×k row-major blocks (the second values of the pattern).
    pub(crate) fn transpose_product(&self, x: &[f64], y: &mut [f64], k: usize) {
        /// An entry's pair read for its second value (Aᵀ's entry).
        #[repr(transparent)]
        #[derive(Clone, Copy)]
        struct Second((f64, f64));
        impl Values for Second {
            #[inline(always)]
            fn halves(self) -> (f64, f64) {
                (self.0 .1, self.0 .1)
            }
        }
        // SAFETY: `Second` is `repr(transparent)` over `(f64, f64)`: the same layout,
        // so the slice may be read as one of `Second`.
        let val: &[Second] =
            unsafe { std::slice::from_raw_parts(self.val.as_ptr().cast(), self.val.len()) };
        let rows = Rows::new(self.ncols, &self.row_ptr, &self.col, val);
        let dense = Layout::dense(k);
        product_with::<1, Second>(rows, x, dense, y, dense, k, None);
    }
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

    /// The parallel storage transpose (several blocks from 2¹⁷ entries on): the same
    /// CSR on 1 to 3 threads, every entry of the CSC in its row, and `(Aᵀ)ᵀ = A`.
    #[test]
    fn from_csc_in_parallel_is_the_csc_by_rows() {
        let m = builtin::icosphere(6).unwrap();
        let f = crate::operator::tutte::tutte(&Topology::new(&m).unwrap()).unwrap();
        assert!(f.compute_nnz() > 1 << 18);
        let pool = |t: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .unwrap()
        };
        let a = pool(1).install(|| CsrMatrix::from_csc(&f));
        for t in [2, 3] {
            assert_eq!(
                pool(t).install(|| CsrMatrix::from_csc(&f)),
                a,
                "{t} threads"
            );
        }
        let mut entries = 0;
        for j in 0..f.ncols() {
            for (&i, &v) in f.row_idx_of_col_raw(j).iter().zip(f.val_of_col(j)) {
                let r = a.row_range(i);
                let k = a.col[r.clone()].binary_search(&(j as u32)).unwrap();
                assert_eq!(a.val[r.start + k].to_bits(), v.to_bits());
                entries += 1;
            }
        }
        assert_eq!(entries, a.val.len());
        assert_eq!(pool(3).install(|| a.transpose().transpose()), a);
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

    enum Kind {
        Tutte,
        Sql,
    }

    /// `I + 30 F` (CSR) of the operator F of `builtin::icosphere(level)`.
    fn icosphere_system(level: usize, kind: Kind) -> CsrMatrix {
        let t = Topology::new(&builtin::icosphere(level).unwrap()).unwrap();
        let f = match kind {
            Kind::Tutte => crate::operator::tutte::tutte(&t).unwrap(),
            Kind::Sql => crate::operator::sql::sql(&t, Default::default()).unwrap(),
        };
        CsrMatrix::from_csc(&f).shifted(&vec![1.0; f.nrows()], 30.0)
    }

    #[test]
    fn the_three_column_kernel_equals_three_single_column_products() {
        // A larger mesh operator (several parallel chunks; under Miri a small one,
        // with its smaller chunks), k = 3 against k = 1 per column: the same
        // products in the same order, so the same bits.
        let a = icosphere_system(if cfg!(miri) { 2 } else { 5 }, Kind::Tutte);
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
    fn the_dense_fast_path_equals_the_strided_loop_bit_for_bit() {
        // `dense_rows` (x and y blocks of their own, no row weights) against the
        // generic loop on the same numbers laid out with a stride of k + 1 (which the
        // fast path does not take): the same y and the same sums, to the bit, for
        // every column count, with and without the fused reductions.
        let a = icosphere_system(if cfg!(miri) { 2 } else { 4 }, Kind::Sql);
        let n = a.nrows();
        for k in [1, 2, 3, 4, 8] {
            let x: Vec<f64> = (0..k * n).map(|i| (i as f64 * 0.37).sin()).collect();
            let w: Vec<f64> = (0..k * n).map(|i| (i as f64 * 0.11).cos()).collect();
            let pad = |v: &[f64]| -> Vec<f64> {
                v.chunks(k)
                    .flat_map(|r| std::iter::once(-7.0).chain(r.iter().copied()))
                    .collect()
            };
            let (xs, ws) = (pad(&x), pad(&w));
            let (dense, strided) = (
                Layout::dense(k),
                Layout {
                    stride: k + 1,
                    offset: 1,
                },
            );
            for fused in [false, true] {
                let run = |xv: &[f64], xl: Layout, wv: &[f64], yl: Layout| {
                    let mut y = vec![0.0; yl.stride * n];
                    let red = fused.then_some(Reduce {
                        w: wv,
                        at: xl,
                        weights: None,
                    });
                    let mut acc = ([0.0; MAX_COLUMNS], [0.0; MAX_COLUMNS]);
                    product_rows::<1, f64>(a.rows(), xv, xl, 0, &mut y, yl, k, red, &mut acc);
                    let y: Vec<u64> = y
                        .chunks(yl.stride)
                        .flat_map(|r| r[yl.offset..yl.offset + k].iter().map(|v| v.to_bits()))
                        .collect();
                    let bits = |s: &[f64; MAX_COLUMNS]| s.map(f64::to_bits);
                    (y, bits(&acc.0), bits(&acc.1))
                };
                let fast = run(&x, dense, &w, dense);
                assert_eq!(
                    fast,
                    run(&xs, strided, &ws, dense),
                    "k = {k}, fused {fused}"
                );
                assert_eq!(fast, run(&x, dense, &w, strided), "k = {k}, fused {fused}");
                assert!(fast.0.iter().any(|&b| b != 0));
            }
        }
    }

    #[test]
    fn the_dense_fast_path_of_two_halves_equals_the_strided_loop_bit_for_bit() {
        // BiCG's products: two n×k blocks side by side (M = 2), one value for both
        // halves (the symmetrizer) or a pair (A and Aᵀ), the sums over the right half
        // with and without row weights. The fast path against the generic loop on a
        // stride of 2k + 1: the same bits.
        let a = icosphere_system(if cfg!(miri) { 2 } else { 4 }, Kind::Tutte);
        let n = a.nrows();
        let pairs: Vec<(f64, f64)> = a.val.iter().map(|&v| (v, 0.5 * v - 0.1)).collect();
        let s: Vec<f64> = (0..n).map(|i| 1.0 + (i % 7) as f64).collect();
        #[allow(clippy::too_many_arguments)]
        fn run<T: Values>(
            rows: Rows<'_, T>,
            xv: &[f64],
            xl: Layout,
            wv: &[f64],
            at: Layout,
            weights: Option<&[f64]>,
            n: usize,
            k: usize,
        ) -> (Vec<u64>, [u64; MAX_COLUMNS], [u64; MAX_COLUMNS]) {
            let yl = xl;
            let mut y = vec![0.0; yl.stride * n];
            let red = Some(Reduce { w: wv, at, weights });
            let mut acc = ([0.0; MAX_COLUMNS], [0.0; MAX_COLUMNS]);
            product_rows::<2, T>(rows, xv, xl, 0, &mut y, yl, k, red, &mut acc);
            let y = y
                .chunks(yl.stride)
                .flat_map(|r| r[yl.offset..yl.offset + 2 * k].iter().map(|v| v.to_bits()))
                .collect();
            (y, acc.0.map(f64::to_bits), acc.1.map(f64::to_bits))
        }
        for k in [1, 3, 4] {
            let x: Vec<f64> = (0..2 * k * n).map(|i| (i as f64 * 0.37).sin()).collect();
            let xs: Vec<f64> = x
                .chunks(2 * k)
                .flat_map(|r| std::iter::once(-7.0).chain(r.iter().copied()))
                .collect();
            let (whole, strided) = (
                Layout::dense(2 * k),
                Layout {
                    stride: 2 * k + 1,
                    offset: 1,
                },
            );
            let right = Layout {
                stride: 2 * k + 1,
                offset: 1 + k,
            };
            for weights in [None, Some(&s[..])] {
                let single = a.rows();
                let paired = Rows::new(a.ncols, &a.row_ptr, &a.col, &pairs);
                let fast = run(single, &x, whole, &x, Layout::half(k, 1), weights, n, k);
                let slow = run(single, &xs, strided, &xs, right, weights, n, k);
                assert_eq!(fast, slow, "k = {k}, one value");
                let fast = run(paired, &x, whole, &x, Layout::half(k, 1), weights, n, k);
                let slow = run(paired, &xs, strided, &xs, right, weights, n, k);
                assert_eq!(fast, slow, "k = {k}, pairs");
                assert!(fast.0.iter().any(|&b| b != 0));
            }
        }
    }

    #[test]
    fn mirrored_equals_the_merge_with_the_transpose() {
        // Mesh operators (symmetric patterns, several blocks of rows for icosphere 5).
        for m in [builtin::cube(3).unwrap(), builtin::icosphere(5).unwrap()] {
            let f = crate::operator::tutte::tutte(&Topology::new(&m).unwrap()).unwrap();
            let a = CsrMatrix::from_csc(&f).shifted(&vec![1.0; f.nrows()], 30.0);
            let want = PairedCsr::new(&a, &a.transpose());
            assert_eq!(PairedCsr::mirrored(&a), Some(want));
        }
        // A star of 100 leaves: the hub's row is searched by halves.
        let n = 101;
        let mut row_ptr = vec![0, n];
        let mut col: Vec<u32> = (0..n as u32).collect();
        for i in 1..n {
            col.extend([0, i as u32]);
            row_ptr.push(row_ptr[i] + 2);
        }
        let val: Vec<f64> = (0..col.len()).map(|p| 1.0 + p as f64 * 0.25).collect();
        let star = CsrMatrix::from_parts(n, n, row_ptr.clone(), col.clone(), val.clone());
        let want = PairedCsr::new(&star, &star.transpose());
        assert_eq!(PairedCsr::mirrored(&star), Some(want));
        // Not symmetric: leaf 7 loses its entry (7, 0), so (0, 7) has no mirror.
        let p = row_ptr[7];
        let mut col2 = col.clone();
        let mut val2 = val.clone();
        col2.remove(p);
        val2.remove(p);
        let ptr2: Vec<usize> = row_ptr
            .iter()
            .map(|&q| if q > p { q - 1 } else { q })
            .collect();
        let lopsided = CsrMatrix::from_parts(n, n, ptr2, col2, val2);
        assert_eq!(PairedCsr::mirrored(&lopsided), None);
        // Rectangular: no pairs.
        let wide = CsrMatrix::from_parts(1, 2, vec![0, 2], vec![0, 1], vec![1.0, 2.0]);
        assert_eq!(PairedCsr::mirrored(&wide), None);
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
