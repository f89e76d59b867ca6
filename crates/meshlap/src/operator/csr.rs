//! An operator's n×n matrix as compressed rows: the layout of `scipy.sparse.csr_array`
//! (and of Eigen's `RowMajor` sparse matrices), which the Python package returns.
//!
//! The library assembles every operator as compressed columns ([`SparseMatrix`], faer's
//! CSC). The CSC arrays of a matrix are the CSR arrays of its transpose, so an operator
//! that is exactly symmetric (every off-diagonal pair written from one value, as
//! [`super::OperatorKind::is_symmetric`] promises) is its own CSR without a copy; any
//! other matrix is transposed by a counting sort, O(nnz), in parallel over blocks of
//! columns. Signs are the operator's own: `F = D − W`, positive semi-definite (libigl
//! and pmp-library use the negative).

use crate::mem::Scatter;
use crate::SparseMatrix;
use rayon::prelude::*;
use std::ops::Range;

/// An nrows × ncols matrix in compressed rows: row i's entries are
/// `col[row_ptr[i]..row_ptr[i + 1]]` (ascending, no duplicates) with the values
/// `val[row_ptr[i]..row_ptr[i + 1]]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Csr {
    /// Rows.
    pub nrows: usize,
    /// Columns.
    pub ncols: usize,
    /// Row starts (nrows + 1), the last the number of entries.
    pub row_ptr: Vec<usize>,
    /// Column of each entry (nnz), ascending within a row.
    pub col: Vec<usize>,
    /// Value of each entry (nnz).
    pub val: Vec<f64>,
}

/// Fewest entries per parallel block of columns.
const MIN_BLOCK_ENTRIES: usize = 1 << 16;

/// The compressed rows of `m` (nrows × ncols, taken by value). With `symmetric`, the
/// caller guarantees `m` equals its transpose exactly (the same pattern and bits), and
/// its CSC arrays are moved into the result unchanged; otherwise (or when `m` is not
/// compact) the entries are transposed, each row's columns ascending. The same
/// result on any number of threads.
pub fn csr_of(m: SparseMatrix, symmetric: bool) -> Csr {
    let (nrows, ncols) = (m.nrows(), m.ncols());
    if symmetric && nrows == ncols && m.symbolic().col_nnz().is_none() {
        let (symbolic, val) = m.into_parts();
        let (_, _, col_ptr, _, row_idx) = symbolic.into_parts();
        return Csr {
            nrows,
            ncols,
            row_ptr: col_ptr,
            col: row_idx,
            val,
        };
    }
    transpose(&m)
}

/// The counting-sort transpose of `m`'s storage ([`transpose_storage`]).
fn transpose(m: &SparseMatrix) -> Csr {
    transpose_in_blocks(m, None)
}

/// [`transpose`] with `parts` blocks of columns (`None`: [`transpose_storage`]'s
/// choice).
fn transpose_in_blocks(m: &SparseMatrix, parts: Option<usize>) -> Csr {
    let symbolic = m.symbolic();
    let (row_ptr, col, val) = transpose_storage(
        m.nrows(),
        m.ncols(),
        |j| symbolic.col_range(j),
        |p| symbolic.row_idx()[p],
        m.val(),
        |j| j,
        parts,
    );
    Csr {
        nrows: m.nrows(),
        ncols: m.ncols(),
        row_ptr,
        col,
        val,
    }
}

/// The counting-sort transpose of compressed storage: `n_outer` lists (entries
/// `range(o)`, inner index `inner(p)` and value `val[p]` of entry p) over `n_inner`
/// inner positions become `n_inner` lists over the outer positions, each ascending
/// (the outer index as `index` makes it). Returns the pointers (`n_inner + 1`), the
/// indices and the values. CSC to CSR, or CSR to CSC.
///
/// In parallel over `parts` blocks of outer lists (clamped to 1 ..= `n_outer`; `None`:
/// two per thread, each of at least 2¹⁶ entries) with about equal entries each: every block counts its entries per inner position, a
/// prefix over positions and blocks gives every block its first slot in each list,
/// and the blocks scatter their entries in outer order, so each list comes out
/// ascending. The same result for any `parts` and thread count. Shared by the
/// operators' CSR ([`Operator::into_csr`](super::Operator::into_csr)) and the solvers'
/// (`solve::CsrMatrix`).
pub(crate) fn transpose_storage<T: Copy + Default + Send + Sync>(
    n_inner: usize,
    n_outer: usize,
    range: impl Fn(usize) -> Range<usize> + Sync,
    inner: impl Fn(usize) -> usize + Sync,
    val: &[f64],
    index: impl Fn(usize) -> T + Sync,
    parts: Option<usize>,
) -> (Vec<usize>, Vec<T>, Vec<f64>) {
    let blocks = outer_blocks(n_outer, &range, parts);
    let mut fill: Vec<Vec<usize>> = blocks
        .par_iter()
        .map(|outer| {
            let mut count = vec![0usize; n_inner];
            for o in outer.clone() {
                for p in range(o) {
                    count[inner(p)] += 1;
                }
            }
            count
        })
        .collect();
    let mut ptr = vec![0usize; n_inner + 1];
    let mut at = 0usize;
    for (i, start) in ptr[..n_inner].iter_mut().enumerate() {
        *start = at;
        for f in fill.iter_mut() {
            let c = f[i];
            f[i] = at;
            at += c;
        }
    }
    ptr[n_inner] = at;
    let mut idx = crate::mem::zeroed_vec(T::default(), at);
    let mut out = crate::mem::zeroed_vec(0.0f64, at);
    {
        let (is, vs) = (Scatter::new(&mut idx), Scatter::new(&mut out));
        blocks
            .into_par_iter()
            .zip(&mut fill)
            .for_each(|(outer, fill)| {
                for o in outer {
                    let x = index(o);
                    for p in range(o) {
                        let i = inner(p);
                        let q = fill[i];
                        fill[i] += 1;
                        // SAFETY: every entry gets its own slot: the blocks' slots in a
                        // list are disjoint ranges and each counter only grows within
                        // its own.
                        unsafe {
                            is.write(q, x);
                            vs.write(q, val[p]);
                        }
                    }
                }
            });
    }
    (ptr, idx, out)
}

/// `parts` contiguous ranges covering `0..n_outer` with about equal entries each
/// (`range(o).len()` entries in list o), `parts` clamped to 1 ..= `n_outer`; `None`:
/// two per thread, each of at least [`MIN_BLOCK_ENTRIES`].
fn outer_blocks(
    n_outer: usize,
    range: &impl Fn(usize) -> Range<usize>,
    parts: Option<usize>,
) -> Vec<Range<usize>> {
    let ends: Vec<usize> = (0..n_outer)
        .map(|o| range(o).len())
        .scan(0usize, |s, c| {
            *s += c;
            Some(*s)
        })
        .collect();
    let total = ends.last().copied().unwrap_or(0);
    let parts = parts
        .unwrap_or((2 * rayon::current_num_threads()).min(total / MIN_BLOCK_ENTRIES))
        .clamp(1, n_outer.max(1));
    let mut blocks = Vec::with_capacity(parts);
    let mut start = 0usize;
    for p in 1..=parts {
        let end = if p == parts {
            n_outer
        } else {
            // The first list whose running count reaches p/parts of the entries.
            ends.partition_point(|&e| e < p * total / parts).max(start)
        };
        blocks.push(start..end);
        start = end;
    }
    blocks
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;
    use crate::mesh::topology::Topology;
    use crate::operator::{Operator, OperatorKind, OperatorOptions};

    /// A reference CSR: every entry read from the CSC by (row, column) order.
    fn reference(m: &SparseMatrix) -> Csr {
        let mut entries: Vec<(usize, usize, f64)> = Vec::new();
        for j in 0..m.ncols() {
            for (&i, &v) in m.row_idx_of_col_raw(j).iter().zip(m.val_of_col(j)) {
                entries.push((i, j, v));
            }
        }
        entries.sort_by_key(|&(i, j, _)| (i, j));
        let mut row_ptr = vec![0usize; m.nrows() + 1];
        for &(i, _, _) in &entries {
            row_ptr[i + 1] += 1;
        }
        for i in 0..m.nrows() {
            row_ptr[i + 1] += row_ptr[i];
        }
        Csr {
            nrows: m.nrows(),
            ncols: m.ncols(),
            row_ptr,
            col: entries.iter().map(|e| e.1).collect(),
            val: entries.iter().map(|e| e.2).collect(),
        }
    }

    /// Every operator, on a closed mesh and one with boundary: the transpose in 1 to 7
    /// blocks of columns, and the default split on 1 to 3 threads, equal the sorted
    /// reference bit for bit; for the symmetric kinds the moved CSC arrays equal it
    /// too (which needs exact symmetry).
    #[test]
    fn every_operator_equals_the_sorted_reference() {
        for mesh in [builtin::icosphere(3).unwrap(), builtin::grid(12).unwrap()] {
            let topo = Topology::new(&mesh).unwrap();
            for kind in OperatorKind::ALL {
                let op =
                    Operator::assemble(kind, &mesh, &topo, &OperatorOptions::default()).unwrap();
                check_operator(op);
            }
        }
    }

    fn check_operator(op: Operator) {
        let kind = op.kind;
        let want = reference(&op.matrix);
        for parts in 1..=7 {
            assert_eq!(
                transpose_in_blocks(&op.matrix, Some(parts)),
                want,
                "{kind}, {parts}"
            );
        }
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let got = pool.install(|| transpose(&op.matrix));
            assert_eq!(got, want, "{kind}, {threads} threads");
        }
        assert_eq!(op.into_csr(), want, "{kind}");
    }

    /// Rectangular and empty matrices, and a non-symmetric one passed as such.
    #[test]
    fn rectangular_empty_and_non_symmetric() {
        let m = SparseMatrix::try_new_from_triplets(
            3,
            5,
            &[
                faer::sparse::Triplet::new(2, 0, 1.0),
                faer::sparse::Triplet::new(0, 4, -2.0),
                faer::sparse::Triplet::new(2, 3, 3.5),
                faer::sparse::Triplet::new(1, 1, 4.0),
            ],
        )
        .unwrap();
        let got = csr_of(m.clone(), false);
        assert_eq!(got, reference(&m));
        assert_eq!(got.row_ptr, vec![0, 1, 2, 4]);
        assert_eq!(got.col, vec![4, 1, 0, 3]);
        assert_eq!(got.val, vec![-2.0, 4.0, 1.0, 3.5]);
        let empty = SparseMatrix::try_new_from_triplets(4, 4, &[]).unwrap();
        let e = csr_of(empty, false);
        assert_eq!(e.row_ptr, vec![0; 5]);
        assert!(e.col.is_empty() && e.val.is_empty());
    }
}
