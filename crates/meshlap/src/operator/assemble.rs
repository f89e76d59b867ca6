//! Sparse assembly helpers shared by the operators.
//!
//! Hand-written because every operator has a known pattern (the one-ring plus the
//! diagonal, or the two-ring for second-order operators): filling compressed columns
//! directly avoids the sort and the duplicate merge of a triplet build.

use crate::mesh::topology::Topology;
use crate::SparseMatrix;
use faer::sparse::{SparseColMat, SymbolicSparseColMat};
use rayon::prelude::*;

/// Per vertex, the sum of the edge weights `w` (in [`Topology::edges`] order) over its
/// one-ring edges: the diagonal of `D − W` or a row's normalising sum.
pub(crate) fn vertex_weight_sums(topo: &Topology, w: &[f64]) -> Vec<f64> {
    (0..topo.n_vertices())
        .map(|v| {
            topo.neighbor_edges(crate::VertexId(v as u32))
                .iter()
                .map(|&e| w[e as usize])
                .sum()
        })
        .collect()
}

/// An n×n matrix with the pattern of the one-ring plus the diagonal: entry (i, j) for
/// each edge (i, j) is `off(i, j, edge)`, entry (i, i) is `diag(i)`. Column j lists its
/// rows ascending (the neighbours of j, which are sorted, with j merged in).
pub(crate) fn one_ring_matrix(
    topo: &Topology,
    diag: impl Fn(usize) -> f64 + Sync,
    off: impl Fn(usize, usize, usize) -> f64 + Sync,
) -> SparseMatrix {
    let n = topo.n_vertices();
    let offsets = topo.adjacency_offsets();
    let col_ptr: Vec<usize> = (0..=n).map(|j| offsets[j] as usize + j).collect();
    let nnz = col_ptr[n];
    let mut row_idx = vec![0usize; nnz];
    let mut val = vec![0.0f64; nnz];
    // Columns are contiguous and disjoint: split the output into per-column chunks
    // in parallel blocks of columns.
    const BLOCK: usize = 4096;
    let blocks: Vec<(usize, usize)> = (0..n)
        .step_by(BLOCK)
        .map(|s| (s, (s + BLOCK).min(n)))
        .collect();
    let mut row_chunks = Vec::with_capacity(blocks.len());
    let mut val_chunks = Vec::with_capacity(blocks.len());
    {
        let (mut r, mut v) = (&mut row_idx[..], &mut val[..]);
        for &(s, e) in &blocks {
            let len = col_ptr[e] - col_ptr[s];
            let (ra, rb) = r.split_at_mut(len);
            let (va, vb) = v.split_at_mut(len);
            row_chunks.push(ra);
            val_chunks.push(va);
            r = rb;
            v = vb;
        }
    }
    blocks
        .par_iter()
        .zip(row_chunks.into_par_iter().zip(val_chunks.into_par_iter()))
        .for_each(|(&(s, e), (rows, vals))| {
            let mut p = 0;
            for j in s..e {
                let nb = topo.neighbors(crate::VertexId(j as u32));
                let ed = topo.neighbor_edges(crate::VertexId(j as u32));
                let mut placed = false;
                for (k, &i) in nb.iter().enumerate() {
                    let i = i as usize;
                    if !placed && i > j {
                        rows[p] = j;
                        vals[p] = diag(j);
                        p += 1;
                        placed = true;
                    }
                    rows[p] = i;
                    vals[p] = off(i, j, ed[k] as usize);
                    p += 1;
                }
                if !placed {
                    rows[p] = j;
                    vals[p] = diag(j);
                    p += 1;
                }
            }
        });
    SparseColMat::new(
        SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx),
        val,
    )
}

/// Column-combination product: column j of the result is `Σ_k c_jk · column(k)`, where
/// `coeffs(j)` lists the `(k, c_jk)` and `column(k)` lists `(row, value)` pairs. Uses a
/// dense accumulator per worker (Gustavson's algorithm); rows come out sorted.
pub(crate) fn combine_columns<C, V>(n: usize, coeffs: C, column: V) -> SparseMatrix
where
    C: Fn(usize, &mut Vec<(usize, f64)>) + Sync,
    V: Fn(usize, &mut Vec<(usize, f64)>) + Sync,
{
    const BLOCK: usize = 2048;
    let parts: Vec<(Vec<usize>, Vec<usize>, Vec<f64>)> = (0..n)
        .step_by(BLOCK)
        .collect::<Vec<_>>()
        .into_par_iter()
        .map(|s| {
            let e = (s + BLOCK).min(n);
            let mut acc = vec![0.0f64; n];
            let mut mark = vec![usize::MAX; n];
            let mut touched: Vec<usize> = Vec::new();
            let (mut cbuf, mut vbuf) = (Vec::new(), Vec::new());
            let (mut counts, mut rows, mut vals) = (Vec::new(), Vec::new(), Vec::new());
            for j in s..e {
                touched.clear();
                cbuf.clear();
                coeffs(j, &mut cbuf);
                for &(k, c) in &cbuf {
                    vbuf.clear();
                    column(k, &mut vbuf);
                    for &(i, v) in &vbuf {
                        if mark[i] != j {
                            mark[i] = j;
                            acc[i] = 0.0;
                            touched.push(i);
                        }
                        acc[i] += c * v;
                    }
                }
                touched.sort_unstable();
                counts.push(touched.len());
                for &i in &touched {
                    rows.push(i);
                    vals.push(acc[i]);
                }
            }
            (counts, rows, vals)
        })
        .collect();
    let mut col_ptr = Vec::with_capacity(n + 1);
    col_ptr.push(0usize);
    let total: usize = parts.iter().map(|p| p.1.len()).sum();
    let mut row_idx = Vec::with_capacity(total);
    let mut val = Vec::with_capacity(total);
    for (counts, rows, vals) in parts {
        for c in counts {
            let last = *col_ptr.last().unwrap_or(&0);
            col_ptr.push(last + c);
        }
        row_idx.extend(rows);
        val.extend(vals);
    }
    SparseColMat::new(
        SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx),
        val,
    )
}

/// Entries of column k of `one_ring_matrix(diag, off)` without assembling it.
pub(crate) fn one_ring_column(
    topo: &Topology,
    k: usize,
    diag: f64,
    off: impl Fn(usize) -> f64,
    out: &mut Vec<(usize, f64)>,
) {
    out.push((k, diag));
    for &i in topo.neighbors(crate::VertexId(k as u32)) {
        out.push((i as usize, off(i as usize)));
    }
}
