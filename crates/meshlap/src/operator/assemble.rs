//! Sparse assembly shared by the operators: compressed sparse columns (CSC, faer's
//! `SparseColMat<usize, f64>`: 8-byte row indices and column pointers) filled directly
//! from the half-edge connectivity.
//!
//! Hand-written because every operator has a pattern known from the connectivity:
//!
//! - first-order operators (KL, TL, GL, SQL, SDL, cotan, mean-value): column j holds
//!   the diagonal and the neighbours of j, rows ascending — the sorted adjacency of
//!   [`Topology`] with j merged in, so `col_ptr[j] = adj_offsets[j] + j` is known
//!   before any value is computed ([`one_ring_columns`]);
//! - second-order operators (`TᵀT`, `T²`): column j holds the two-ring of j; a first
//!   parallel pass finds and sorts each column's rows, a second writes them and the
//!   values ([`two_ring_matrix`]).
//!
//! Both fill the final arrays in place, in parallel over blocks of columns (rayon),
//! with no triplet list, no global sort, no duplicate merge and no per-entry
//! allocation; the final arrays are not zeroed first (`mem::uninit_vec`: each entry
//! is written once). The geometric operators (cotan, mean-value) compute their per-face
//! values in parallel and write each half-edge's value to its own side of its edge
//! ([`per_face_edge_sides`]); the columns add an edge's two sides in face order: the
//! same sums as a sequential scatter over the faces, without one and without a pass
//! over the edges. While filling, every column is
//! checked to have strictly increasing rows below n; only then is the matrix handed
//! to faer without its sequential re-check (`new_unchecked`). A failed check (a broken [`Topology`] invariant, never
//! expected) falls back to faer's checked constructor.

use crate::mem::Scatter;
use crate::mesh::topology::{Topology, INVALID};
use crate::SparseMatrix;
use faer::sparse::{SparseColMat, SymbolicSparseColMat};
use rayon::prelude::*;
use std::mem::MaybeUninit;

/// Columns per parallel work item. Large enough to amortise scheduling, small enough
/// to balance two to a few dozen threads on 10⁵-vertex meshes.
const BLOCK: usize = 2048;

/// Per vertex, the sum of the edge weights `w` (in [`Topology::edges`] order) over its
/// one-ring edges: the diagonal of `D − W` or a row's normalising sum. Summed in the
/// order of [`Topology::neighbor_edges`] (the same bits on any thread count).
pub(crate) fn vertex_weight_sums(topo: &Topology, w: &[f64]) -> Vec<f64> {
    (0..topo.n_vertices())
        .into_par_iter()
        .with_min_len(BLOCK)
        .map(|v| {
            topo.neighbor_edges(crate::VertexId(v as u32))
                .iter()
                .map(|&e| w[e as usize])
                .sum()
        })
        .collect()
}

/// Where each half-edge's value goes in an array of two sides per undirected edge
/// (`2·e` and `2·e + 1`, [`Topology::edges`] order; see [`per_face_edge_sides`]).
#[derive(Clone, Copy)]
pub(crate) struct EdgeSideSlots<'a> {
    twins: &'a [u32],
    he_edge: &'a [u32],
    counts: &'a [u32],
}

impl<'a> EdgeSideSlots<'a> {
    pub(crate) fn new(topo: &'a Topology) -> Self {
        Self {
            twins: topo.twins(),
            he_edge: topo.half_edge_edges(),
            counts: topo.edge_face_counts(),
        }
    }

    /// Writes the value `v` of half-edge `h` to its side of its edge: on an edge of
    /// two faces (twins) the side is the half-edge's rank among the two, a boundary
    /// edge's only half-edge writes `[v, zero]`, and a non-manifold edge's half-edges
    /// write nothing.
    ///
    /// # Safety
    /// `sides` holds two slots per edge, and each half-edge is written at most once
    /// while it lives: then every slot has one writer.
    #[inline(always)]
    pub(crate) unsafe fn write<T: Copy>(&self, sides: &Scatter<'_, T>, h: usize, v: T, zero: T) {
        let (tw, e) = (self.twins[h], self.he_edge[h] as usize);
        // SAFETY: by the caller's contract, see the doc.
        unsafe {
            if tw != INVALID {
                sides.write(2 * e + usize::from(h as u32 > tw), v);
            } else if self.counts[e] == 1 {
                sides.write(2 * e, v);
                sides.write(2 * e + 1, zero);
            }
        }
    }
}

/// Where a geometric operator's per-face kernel puts each face's values: three values
/// `T`, one per half-edge `3f + m` (from corner m to corner m + 1), and three values
/// `U`, one per corner m. Faces are put in order, each once.
pub(crate) trait FaceSink<T, U> {
    /// The values of the next face.
    fn put(&mut self, edge_values: [T; 3], corner_values: [U; 3]);
}

/// Collects the faces' values in order (the non-manifold edges' recomputation, the
/// cotan's mass alone, tests).
impl<T, U> FaceSink<T, U> for Vec<([T; 3], [U; 3])> {
    #[inline(always)]
    fn put(&mut self, edge_values: [T; 3], corner_values: [U; 3]) {
        self.push((edge_values, corner_values));
    }
}

/// A geometric operator's per-face values (cotan, mean-value), for
/// [`per_face_edge_sides`]: generic over the sink, so that the kernel writes each
/// face's values straight to their slots (the sink's `put` inlined into the kernel,
/// in the same build) instead of through a buffer of every face's values.
pub(crate) trait FaceValues<T, U>: Sync {
    /// The error of a face that has no values (a degenerate triangle, say).
    type Error: Send;
    /// Puts the values of the faces `range` into `sink`, in order; or returns the
    /// error of the range's first failing face, the faces before it put.
    fn put_faces<S: FaceSink<T, U>>(
        &self,
        range: std::ops::Range<usize>,
        sink: &mut S,
    ) -> Result<(), Self::Error>;
}

/// [`FaceValues`] from a closure that pushes the values of a range of faces onto a
/// vector, then handed to the sink: the tests' values.
#[cfg(test)]
pub(crate) struct Collected<F>(pub(crate) F);

#[cfg(test)]
impl<T, U, E, F> FaceValues<T, U> for Collected<F>
where
    T: Copy,
    U: Copy,
    E: Send,
    F: Fn(std::ops::Range<usize>, &mut Vec<([T; 3], [U; 3])>) -> Result<(), E> + Sync,
{
    type Error = E;
    fn put_faces<S: FaceSink<T, U>>(
        &self,
        range: std::ops::Range<usize>,
        sink: &mut S,
    ) -> Result<(), E> {
        let mut buf = Vec::with_capacity(range.len());
        let result = (self.0)(range, &mut buf);
        for (e, c) in buf {
            sink.put(e, c);
        }
        result
    }
}

/// [`per_face_edge_sides`]' sink for one chunk of faces: each face's corner values to
/// its three slots of the chunk's part of the corner array, its half-edge values to
/// their sides ([`EdgeSideSlots::write`]).
struct SlotSink<'s, 'a, T, U> {
    slots: EdgeSideSlots<'a>,
    sides: &'s Scatter<'a, T>,
    /// The chunk's corner slots, three per face from `first`.
    corners: &'s mut [MaybeUninit<U>],
    first: usize,
    /// The next face to be put.
    next: usize,
    zero: T,
}

impl<T: Copy, U> FaceSink<T, U> for SlotSink<'_, '_, T, U> {
    #[inline(always)]
    fn put(&mut self, edge_values: [T; 3], corner_values: [U; 3]) {
        let f = self.next;
        let q = 3 * (f - self.first);
        // Bounds-checked: a kernel that put more faces than its range panics here,
        // before any half-edge outside the chunk is written.
        for (s, v) in self.corners[q..q + 3].iter_mut().zip(corner_values) {
            s.write(v);
        }
        for (m, v) in edge_values.into_iter().enumerate() {
            // SAFETY: `sides` has two slots per edge, and each half-edge of the
            // chunk's faces is written once: face f is put once (`next` only grows,
            // and the slice above bounds it by the chunk's end).
            unsafe { self.slots.write(self.sides, 3 * f + m, v, self.zero) };
        }
        self.next = f + 1;
    }
}

/// [`per_face_edge_sides`]' result: two sides per edge and the corners' values.
pub(crate) type SidesAndCorners<T, U> = (Vec<[T; 2]>, Vec<U>);

/// The geometric operators' per-face pass (cotan, mean-value): per face f three values
/// `T` per half-edge `3f + m` (to be summed per undirected edge) and three values `U`
/// per corner (kept per slot `3f + m`), computed in parallel over chunks of faces:
/// `values.put_faces(faces, sink)` puts the values of a range of faces, in order, or
/// returns the error of the range's first failing face. The sink writes each face's
/// values straight to their slots, with no per-chunk buffer of every face's values
/// (BENCHMARKS.md, "Operator assembly").
///
/// Returns the per-corner values and, per undirected edge e ([`Topology::edges`]
/// order), two sides `[a, b]` with `add(add(zero, a), b)` = `zero` folded with `add`
/// over e's half-edges in ascending order, i.e. face order — the same sum as a
/// sequential pass over the faces adding each half-edge's value into a zeroed
/// per-edge array, on any number of threads. The caller folds the sides where it
/// reads them (no pass over the edges):
///
/// - an edge of two faces (its half-edges twins): `[value of the lower half-edge,
///   value of the higher]`, each written by its own face (a scatter to distinct
///   slots: a face's half-edge knows its side from its twin, read in half-edge order);
/// - a boundary edge: `[value, zero]`;
/// - a non-manifold edge (three faces or more, rare): `[fold, zero]`, the fold by one
///   sequential pass over all half-edges, which recomputes those edges' faces.
///
/// (The scatter and its twin look-ups are a small part of the cotan's time: writing
/// every value in half-edge order instead, which would leave the columns two gathers
/// per edge, could save at most that part; see BENCHMARKS.md, "Operator assembly".)
///
/// `zero` must be an identity of `add` on every folded value, as `0.0` is for `f64`
/// sums that start at `+0.0` (they are never `−0.0`).
///
/// Or the error of the first failing face (the lowest index), whichever thread met it.
pub(crate) fn per_face_edge_sides<T, U, V>(
    topo: &Topology,
    zero: T,
    add: impl Fn(T, T) -> T,
    values: &V,
) -> Result<SidesAndCorners<T, U>, V::Error>
where
    T: Copy + Send + Sync,
    U: Copy + Send + Sync,
    V: FaceValues<T, U>,
{
    const CHUNK: usize = 1024;
    let n_faces = topo.n_faces();
    let (he_edge, counts) = (topo.half_edge_edges(), topo.edge_face_counts());
    let side_slots = EdgeSideSlots::new(topo);
    let mut corners = crate::mem::uninit_vec::<U>(3 * n_faces);
    let mut sides = crate::mem::uninit_vec::<[T; 2]>(topo.n_edges());
    let first_bad = {
        // SAFETY: `sides` is borrowed mutably for the scatter's life and used by no
        // one else; `MaybeUninit<[T; 2]>` has the layout of two consecutive `T`.
        let scatter = unsafe {
            crate::mem::Scatter::from_raw_parts(sides.as_mut_ptr().cast::<T>(), 2 * sides.len())
        };
        corners
            .par_chunks_mut(3 * CHUNK)
            .enumerate()
            .map(|(c, slots)| {
                let faces = c * CHUNK..c * CHUNK + slots.len() / 3;
                let mut sink = SlotSink {
                    slots: side_slots,
                    sides: &scatter,
                    corners: slots,
                    first: faces.start,
                    next: faces.start,
                    zero,
                };
                if let Err(err) = values.put_faces(faces.clone(), &mut sink) {
                    return Some((c, err));
                }
                assert_eq!(sink.next, faces.end, "per-face values missing");
                None
            })
            .flatten()
            .min_by_key(|&(c, _)| c)
    };
    if let Some((_, err)) = first_bad {
        return Err(err);
    }
    if topo.non_manifold_edges().next().is_some() {
        for e in topo.non_manifold_edges() {
            sides[e.idx()].write([zero, zero]);
        }
        let mut one = Vec::with_capacity(1);
        for h in 0..3 * n_faces {
            let e = he_edge[h] as usize;
            if counts[e] > 2 {
                one.clear();
                values.put_faces(h / 3..h / 3 + 1, &mut one)?;
                let v = one[0].0[h % 3];
                // SAFETY: written just above.
                let [acc, _] = unsafe { sides[e].assume_init() };
                sides[e].write([add(acc, v), zero]);
            }
        }
    }
    // SAFETY: no face failed, so every chunk put each of its faces once (the
    // assertion above), writing its three corner slots, and the chunks cover all
    // 3 · n_faces; every edge's two sides were written (above: by its two twins, by
    // its boundary half-edge, or as a non-manifold edge).
    unsafe {
        Ok((
            crate::mem::assume_init_vec(sides),
            crate::mem::assume_init_vec(corners),
        ))
    }
}

/// Splits an adjacency-sized buffer `per_entry` (one element per entry of
/// [`Topology::adjacency`]) and an n-sized one `per_vertex` at blocks of [`BLOCK`]
/// vertices, for a pass over the vertices in parallel: item b is `(first vertex, the
/// block's entries, the block's vertices)`.
pub(crate) fn vertex_blocks<'a, T, U>(
    topo: &Topology,
    per_entry: &'a mut [T],
    per_vertex: &'a mut [U],
) -> Vec<(usize, &'a mut [T], &'a mut [U])> {
    let offsets = topo.adjacency_offsets();
    let at = |v: usize| offsets[v] as usize;
    split_blocks(topo.n_vertices(), at, per_entry, |v| v, per_vertex)
        .into_iter()
        .map(|(s, _, a, b)| (s, a, b))
        .collect()
}

/// Splits `a` and `b` at blocks of [`BLOCK`] items of `0..n`: block `[s, e)` gets
/// `a[a_at(s)..a_at(e)]` and `b[b_at(s)..b_at(e)]` (`a_at` and `b_at` non-decreasing
/// from 0, ending at the slices' lengths). Each item is `(s, e, a's part, b's part)`.
fn split_blocks<'a, A, B>(
    n: usize,
    a_at: impl Fn(usize) -> usize,
    a: &'a mut [A],
    b_at: impl Fn(usize) -> usize,
    b: &'a mut [B],
) -> Vec<(usize, usize, &'a mut [A], &'a mut [B])> {
    let mut out = Vec::with_capacity(n.div_ceil(BLOCK));
    let (mut a, mut b) = (a, b);
    for s in (0..n).step_by(BLOCK) {
        let e = (s + BLOCK).min(n);
        let (a0, a1) = std::mem::take(&mut a).split_at_mut(a_at(e) - a_at(s));
        let (b0, b1) = std::mem::take(&mut b).split_at_mut(b_at(e) - b_at(s));
        out.push((s, e, a0, b0));
        (a, b) = (a1, b1);
    }
    out
}

/// Rows and values of one block of columns, not yet written.
type BlockOut<'a> = (
    usize,
    usize,
    &'a mut [MaybeUninit<usize>],
    &'a mut [MaybeUninit<f64>],
);

/// Splits the (unwritten) value and row arrays of a CSC matrix at block boundaries of
/// `BLOCK` columns: item b is `(first column, end column, rows, values)` of block b.
fn column_blocks<'a>(
    col_ptr: &[usize],
    row_idx: &'a mut [MaybeUninit<usize>],
    val: &'a mut [MaybeUninit<f64>],
) -> Vec<BlockOut<'a>> {
    let at = |j: usize| col_ptr[j];
    split_blocks(col_ptr.len() - 1, at, row_idx, at, val)
}

/// Wraps filled CSC arrays as a faer matrix. `sorted` says every column was verified
/// (while it was written) to list strictly increasing rows below `n`, and `col_ptr`
/// was built as a running sum ending at `row_idx.len()`.
///
/// # Safety
/// Every element of `row_idx` and `val` has been written.
unsafe fn finish(
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<MaybeUninit<usize>>,
    val: Vec<MaybeUninit<f64>>,
    sorted: bool,
) -> SparseMatrix {
    // SAFETY: the caller guarantees every element was written.
    let (row_idx, val) = unsafe {
        (
            crate::mem::assume_init_vec(row_idx),
            crate::mem::assume_init_vec(val),
        )
    };
    debug_assert!(col_ptr.len() == n + 1 && col_ptr[n] == row_idx.len());
    debug_assert!(col_ptr.windows(2).all(|w| w[0] <= w[1]));
    let symbolic = if sorted && !cfg!(debug_assertions) {
        // SAFETY: faer's invariants of a sorted CSC matrix: `col_ptr` has n + 1
        // non-decreasing entries ending at `row_idx.len()` (a running sum of the column
        // lengths, by construction), and each column's rows are strictly increasing and
        // below n — verified entry by entry while the column was written (`sorted`).
        // Debug builds take the checked path below instead.
        unsafe { SymbolicSparseColMat::new_unchecked(n, n, col_ptr, None, row_idx) }
    } else {
        SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx)
    };
    SparseColMat::new(symbolic, val)
}

/// How many of the (sorted) neighbours `nb` are below `j`: where `j` goes among them.
/// Counted branch-free (a binary search over the handful of neighbours mispredicts).
#[inline]
fn count_below(nb: &[u32], j: usize) -> usize {
    nb.iter().map(|&i| usize::from((i as usize) < j)).sum()
}

/// Lanes of [`one_ring_columns`]' AVX2 path: columns of up to 7 neighbours (most
/// vertices of a triangle mesh) are written as 8 rows and 8 values at once.
const ONE_RING_LANES: usize = 8;

/// Column pointers of the one-ring pattern: `adj_offsets[j] + j` (j's neighbours and
/// the diagonal before column j).
fn one_ring_col_ptr(topo: &Topology) -> Vec<usize> {
    topo.adjacency_offsets()
        .iter()
        .enumerate()
        .map(|(j, &o)| o as usize + j)
        .collect()
}

/// An n×n matrix with the pattern of the one-ring plus the diagonal, rows ascending in
/// every column. `column(j, off)` writes the off-diagonal entries of column j into `off`
/// (one per neighbour, in the order of [`Topology::neighbors`], entry `k` for
/// neighbour `neighbors(j)[k]` via edge `neighbor_edges(j)[k]`) and returns the
/// diagonal entry; the diagonal is then merged into place. `column` must write every
/// entry of `off`: it arrives holding an earlier column's values, not zeros.
///
/// The merge of a column with fewer than 8 neighbours (98–99 % of the vertices of the
/// scanned test meshes) runs in AVX2 registers where the CPU has them
/// ([`x86::one_ring_rows`], [`x86::one_ring_values`]): the scalar loop's branch at the
/// diagonal's position, a different position in every column, mispredicts about
/// once per column. The same rows, values and checks; BENCHMARKS.md ("Operator
/// assembly") has the gain.
pub(crate) fn one_ring_columns(
    topo: &Topology,
    column: impl Fn(usize, &mut [f64]) -> f64 + Sync,
) -> SparseMatrix {
    let n = topo.n_vertices();
    let col_ptr = one_ring_col_ptr(topo);
    let nnz = col_ptr[n];
    let mut row_idx = crate::mem::uninit_vec::<usize>(nnz);
    let mut val = crate::mem::uninit_vec::<f64>(nnz);
    #[cfg(target_arch = "x86_64")]
    let (adj, offsets, lanes) = (
        topo.adjacency(),
        topo.adjacency_offsets(),
        crate::cpu::avx2_fma(),
    );
    let sorted = column_blocks(&col_ptr, &mut row_idx, &mut val)
        .into_par_iter()
        .map(|(s, e, rows, vals)| {
            let mut ok = true;
            // `buf[0]` a pad, `buf[1..=d]` the column's off-diagonal values. Grown to
            // the largest degree met (and at least 8 lanes after the pad), never
            // cleared: `column` writes every entry of its slice (no memset per column).
            let mut buf = Vec::new();
            let mut p = 0;
            for j in s..e {
                let nb = topo.neighbors(crate::VertexId(j as u32));
                let d = nb.len();
                if buf.len() < d + ONE_RING_LANES + 1 {
                    buf.resize(d + ONE_RING_LANES + 1, 0.0);
                }
                let diag = column(j, &mut buf[1..=d]);
                #[cfg(target_arch = "x86_64")]
                if lanes
                    && d < ONE_RING_LANES
                    && offsets[j] as usize + ONE_RING_LANES <= adj.len()
                    && p + ONE_RING_LANES <= rows.len()
                {
                    // SAFETY: `lanes` says the CPU has AVX2 (and the portable build
                    // is not forced); the 8 neighbours read from j's offset and the
                    // 9 values of `buf` are in bounds (checked just above, and `buf`
                    // holds d + 9 ≥ 9), and the 8 rows and values written from p
                    // are in the block's slices (`p + 8 ≤ rows.len()`, and `vals`
                    // has the length of `rows`).
                    let good = unsafe {
                        let (split, good) = x86::one_ring_rows(
                            adj.as_ptr().add(offsets[j] as usize),
                            d,
                            j as u32,
                            n,
                            rows.as_mut_ptr().add(p).cast(),
                        );
                        x86::one_ring_values(
                            buf.as_ptr(),
                            split,
                            diag,
                            vals.as_mut_ptr().add(p).cast(),
                        );
                        good
                    };
                    ok &= good;
                    p += d + 1;
                    continue;
                }
                let off = &buf[1..=d];
                // Rows: neighbours below j, j, neighbours above j.
                let split = count_below(nb, j);
                let mut prev: Option<usize> = None;
                for (k, &i) in nb.iter().enumerate() {
                    if k == split {
                        rows[p].write(j);
                        vals[p].write(diag);
                        ok &= prev.is_none_or(|q| q < j);
                        prev = Some(j);
                        p += 1;
                    }
                    let i = i as usize;
                    rows[p].write(i);
                    vals[p].write(off[k]);
                    ok &= prev.is_none_or(|q| q < i) && i < n;
                    prev = Some(i);
                    p += 1;
                }
                if split == nb.len() {
                    rows[p].write(j);
                    vals[p].write(diag);
                    ok &= prev.is_none_or(|q| q < j);
                    p += 1;
                }
            }
            // Column j has exactly its neighbours and the diagonal: `col_ptr` counts
            // the same (`adjacency_offsets`), so the block's slices are full.
            assert_eq!(p, rows.len(), "one-ring block not filled");
            ok
        })
        .reduce(|| true, |a, b| a && b);
    // SAFETY: every block wrote each of its `col_ptr[e] - col_ptr[s]` positions (the
    // assertion above), and the blocks cover [0, nnz): a column written in lanes also
    // writes up to 7 positions past its end, inside its block, and the columns after
    // it, written later, overwrite them with their own.
    unsafe { finish(n, col_ptr, row_idx, val, sorted) }
}

/// [`one_ring_columns`] with per-entry closures: entry (i, j) for each edge (i, j) is
/// `off(i, j, edge)`, entry (i, i) is `diag(i)`.
pub(crate) fn one_ring_matrix(
    topo: &Topology,
    diag: impl Fn(usize) -> f64 + Sync,
    off: impl Fn(usize, usize, usize) -> f64 + Sync,
) -> SparseMatrix {
    one_ring_columns(topo, |j, out| {
        let v = crate::VertexId(j as u32);
        for ((o, &i), &e) in out
            .iter_mut()
            .zip(topo.neighbors(v))
            .zip(topo.neighbor_edges(v))
        {
            *o = off(i as usize, j, e as usize);
        }
        diag(j)
    })
}

/// Order in which [`two_ring_matrix`] sums the contributions `c_jk · entry(k, i)` of
/// the one-ring columns k of column j. Fixed so that results are reproducible (and,
/// for `TᵀT`, exactly symmetric).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum RingOrder {
    /// k ascending with j merged in among its neighbours.
    Ascending,
    /// j first, then its neighbours ascending.
    DiagonalFirst,
}

/// The off-diagonal entries `entry(k, i)`, i ∈ N(k), of the one-ring columns k that
/// [`two_ring_matrix`] combines: one value per column k (`v[k]`: the rows of the Tutte
/// Laplacian, as `TᵀT` reads them) or one per row i (`v[i]`: its columns, as `T²`
/// reads them). With one value per column, the product `c_jk · v[k]` is formed once
/// per k instead of once per entry: the same product, so the same bits.
#[derive(Clone, Copy, Debug)]
pub(crate) enum RingEntries<'a> {
    /// `entry(k, i) = v[k]`.
    PerColumn(&'a [f64]),
    /// `entry(k, i) = v[i]`.
    PerRow(&'a [f64]),
}

/// An n×n second-order matrix with the two-ring pattern: column j is
/// `Σ_k coeff(j, k) · column_k` over k ∈ {j} ∪ N(j) (in `order`), where `column_k` has
/// the entries `entry(k, k) = diag(k)` and `entry(k, i)` for i ∈ N(k) (`off`). Each
/// entry is `0 + Σ_k coeff(j, k)·entry(k, i)` summed in `order` — the same bits as a
/// dense accumulator (Gustavson) visiting the same k in the same order.
///
/// Two parallel passes over blocks of columns. The first finds each column's distinct
/// rows and sorts them ([`RingRows`]: per-worker stamps drop the duplicates, a rank
/// sort in AVX2 registers orders the ~19 rows). The rows go to the block's list (4
/// bytes each) and the running sum of the column lengths gives the column pointers.
/// The second pass copies each block's rows into the final array and sums the values
/// in a per-worker dense accumulator of n entries, read out (and zeroed) in the rows'
/// order, adding each `coeff(j, k)·column_k` with [`add_column`]. (A first pass that
/// also summed the values, into per-block buffers for the second to copy, took about
/// as long as the two passes before that copy; a first pass that also stored each
/// candidate's rank, so that the second adds into the column's own values instead of
/// the accumulator, was slower: the second pass is bound by its additions and writes,
/// not by the accumulator. See BENCHMARKS.md, "Operator assembly".) Both
/// passes read the neighbour lists of j's neighbours, in an order no hardware
/// prefetcher follows, so each asks for them a few columns ahead ([`prefetch_rings`]);
/// the second pass also asks for the accumulator's entries at those neighbours (its
/// rows cluster around them).
pub(crate) fn two_ring_matrix(
    topo: &Topology,
    order: RingOrder,
    coeff: impl Fn(usize, usize) -> f64 + Sync,
    diag: impl Fn(usize) -> f64 + Sync,
    off: RingEntries<'_>,
) -> SparseMatrix {
    let n = topo.n_vertices();
    let nbr = |k: usize| topo.neighbors(crate::VertexId(k as u32));
    // Pass 1: each block's sorted distinct rows, and the column lengths.
    let mut counts = vec![0usize; n];
    // A few work items per thread, each with its own n-entry stamps.
    let min_len = n.div_ceil(BLOCK) / (4 * rayon::current_num_threads()) + 1;
    let blocks: Vec<Vec<u32>> = counts
        .par_chunks_mut(BLOCK)
        .enumerate()
        .with_min_len(min_len)
        .map_init(
            // `vec![0; n]` is a zeroed allocation: where it gets fresh pages from the
            // system, only those a job's rows touch are faulted in.
            || (vec![0u32; n], Vec::new()),
            |(stamps, list), (b, counts)| {
                crate::cpu::dispatch(RingRows {
                    topo,
                    first: b * BLOCK,
                    counts,
                    stamps,
                    list,
                })
            },
        )
        .collect();
    let mut col_ptr = Vec::with_capacity(n + 1);
    col_ptr.push(0usize);
    let mut acc = 0usize;
    for c in counts {
        acc += c;
        col_ptr.push(acc);
    }
    let nnz = col_ptr[n];
    let mut row_idx = crate::mem::uninit_vec::<usize>(nnz);
    let mut val = crate::mem::uninit_vec::<f64>(nnz);
    // Pass 2: rows and values.
    column_blocks(&col_ptr, &mut row_idx, &mut val)
        .into_par_iter()
        .zip(blocks.into_par_iter())
        .with_min_len(min_len)
        .for_each_init(
            || vec![0.0f64; n],
            |acc, ((s, e, rows, vals), found)| {
                // The block's rows were counted into `col_ptr` from the same lists.
                assert_eq!(found.len(), rows.len(), "two-ring block length");
                let mut p0 = 0;
                for j in s..e {
                    prefetch_rings(topo, j);
                    if j + RING_AHEAD < n {
                        for &k in nbr(j + RING_AHEAD) {
                            crate::mem::prefetch(&acc[k as usize]);
                        }
                    }
                    let nb = nbr(j);
                    let split = match order {
                        RingOrder::Ascending => count_below(nb, j),
                        RingOrder::DiagonalFirst => 0,
                    };
                    let add = |acc: &mut [f64], k: usize| {
                        add_column(acc, k, nbr(k), coeff(j, k), diag(k), off);
                    };
                    nb[..split].iter().for_each(|&k| add(acc, k as usize));
                    add(acc, j);
                    nb[split..].iter().for_each(|&k| add(acc, k as usize));
                    let len = col_ptr[j + 1] - col_ptr[j];
                    let (r, v) = (&mut rows[p0..p0 + len], &mut vals[p0..p0 + len]);
                    for ((&i, ri), vi) in found[p0..p0 + len].iter().zip(r).zip(v) {
                        let i = i as usize;
                        ri.write(i);
                        vi.write(std::mem::take(&mut acc[i]));
                    }
                    p0 += len;
                }
            },
        );
    // SAFETY: each block's slices have the length of its row list (asserted), and
    // every column wrote all `len` of its rows and values; the columns cover [0, nnz).
    // `RingRows` lists each column's rows distinct, ascending and below n (debug
    // builds check that again in `finish`).
    unsafe { finish(n, col_ptr, row_idx, val, true) }
}

/// Pass 1 of [`two_ring_matrix`] over the block of columns `first..first +
/// counts.len()`: each column's rows `{j} ∪ ⋃_{k ∈ N(j)} N(k)` (which holds N(j): every
/// edge (i, j) is an edge of a face (i, j, k), so i ∈ N(k) for k ∈ N(j)), distinct and
/// ascending (so below n: each indexed the n stamps), appended to the returned list;
/// their number goes to `counts`.
///
/// Duplicates are dropped with per-worker stamps (`stamps[i]` = 1 + the last column
/// that listed i; n entries, 0 at first, never cleared: a worker sees each column
/// once). Each candidate writes its stamp and its slot in `list` unconditionally, and
/// only a row not yet stamped advances the count, so the loop has no data-dependent
/// branch. The column's ~19 distinct rows are then sorted: by rank in AVX2 registers
/// where the CPU has it and there are at most 32 ([`x86::sort_distinct_32`]), else by
/// [`sort_distinct`].
struct RingRows<'a> {
    topo: &'a Topology,
    first: usize,
    counts: &'a mut [usize],
    stamps: &'a mut [u32],
    list: &'a mut Vec<u32>,
}

impl crate::cpu::Kernel for RingRows<'_> {
    type Output = Vec<u32>;
    #[inline(always)]
    fn portable(self) -> Vec<u32> {
        self.run::<false>()
    }
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn avx2_fma(self) -> Vec<u32> {
        self.run::<true>()
    }
}

impl RingRows<'_> {
    #[inline(always)]
    fn run<const AVX2: bool>(self) -> Vec<u32> {
        let RingRows {
            topo,
            first,
            counts,
            stamps,
            list,
        } = self;
        let nbr = |k: usize| topo.neighbors(crate::VertexId(k as u32));
        let columns = counts.len();
        let mut rows: Vec<u32> = Vec::new();
        for (c, j) in counts.iter_mut().zip(first..) {
            prefetch_rings(topo, j);
            let nb = nbr(j);
            let bound = 1 + nb.iter().map(|&k| nbr(k as usize).len()).sum::<usize>();
            // Room for the candidates and 32 pads after the distinct rows.
            if list.len() < bound + 32 {
                list.resize(bound + 32, 0u32);
            }
            // Stamp j + 1: vertex ids are u32, so j + 1 ≤ u32::MAX.
            let jj = j as u32 + 1;
            let mut m = 0;
            let mut visit = |i: u32| {
                let old = stamps[i as usize];
                stamps[i as usize] = jj;
                list[m] = i;
                m += usize::from(old != jj);
            };
            visit(j as u32);
            for &k in nb {
                nbr(k as usize).iter().for_each(|&i| visit(i));
            }
            *c = m;
            if rows.is_empty() {
                // Room for every column's rows, if they were up to half as many again
                // as the first's: rarely regrown (pages never written cost nothing).
                rows.reserve((m + m / 2 + 8) * columns);
            }
            #[cfg(target_arch = "x86_64")]
            if AVX2 && m <= 32 {
                let padded: &mut [u32; 32] = (&mut list[m..m + 32]).try_into().unwrap();
                padded.fill(u32::MAX);
                let mut sorted = [0u32; 32];
                x86::sort_distinct_32(&list[..m + 32], m, &mut sorted);
                // All 32 copied (a fixed-length copy, no call), the first m kept.
                rows.reserve(32);
                let before = rows.len();
                for (s, &x) in rows.spare_capacity_mut().iter_mut().zip(&sorted) {
                    s.write(x);
                }
                // SAFETY: the first m ≤ 32 spare elements were written just above.
                unsafe { rows.set_len(before + m) };
                continue;
            }
            let found = &mut list[..m];
            sort_distinct(found);
            rows.extend_from_slice(found);
        }
        rows
    }
}

/// How many columns ahead [`prefetch_rings`] asks for the neighbour lists.
const RING_AHEAD: usize = 8;

/// Before column j of a two-ring pass: prefetches the adjacency offsets of the
/// neighbours of column `j + 2·RING_AHEAD` and the neighbour lists of those of column
/// `j + RING_AHEAD` (their offsets are in cache by then). Hints only: no effect on any
/// value.
#[inline(always)]
fn prefetch_rings(topo: &Topology, j: usize) {
    let (off, adj) = (topo.adjacency_offsets(), topo.adjacency());
    let n = off.len() - 1;
    if j + 2 * RING_AHEAD < n {
        for &k in topo.neighbors(crate::VertexId((j + 2 * RING_AHEAD) as u32)) {
            crate::mem::prefetch(&off[k as usize]);
        }
    }
    if j + RING_AHEAD < n {
        for &k in topo.neighbors(crate::VertexId((j + RING_AHEAD) as u32)) {
            if let Some(x) = adj.get(off[k as usize] as usize) {
                crate::mem::prefetch(x);
            }
        }
    }
}

/// Adds `c · column_k` (entries `dk` at row k, `off` at the rows `nb_k` = N(k)) into
/// the dense accumulator of [`two_ring_matrix`]'s second pass.
#[inline(always)]
fn add_column(acc: &mut [f64], k: usize, nb_k: &[u32], c: f64, dk: f64, off: RingEntries<'_>) {
    acc[k] += c * dk;
    match off {
        RingEntries::PerColumn(v) => {
            let ck = c * v[k];
            for &i in nb_k {
                acc[i as usize] += ck;
            }
        }
        RingEntries::PerRow(v) => {
            for &i in nb_k {
                let i = i as usize;
                acc[i] += c * v[i];
            }
        }
    }
}

/// Up to this many distinct rows of a two-ring column are sorted by rank on the
/// portable build (see [`sort_distinct`]; the AVX2 build ranks up to 32 in registers,
/// [`x86::sort_distinct_32`]); a triangle mesh's column has about 19.
const RANK_SORT_MAX: usize = 32;

/// Sorts `a`, whose elements are distinct, ascending. Up to [`RANK_SORT_MAX`] elements
/// each goes to its rank — the number of elements below it, counted branch-free over a
/// padded copy of 8 or [`RANK_SORT_MAX`] (the compares vectorise) — instead of the
/// comparison sort's unpredictable branches; longer slices use `sort_unstable`.
fn sort_distinct(a: &mut [u32]) {
    match a.len() {
        0..=8 => rank_sort::<8>(a),
        9..=RANK_SORT_MAX => rank_sort::<RANK_SORT_MAX>(a),
        _ => a.sort_unstable(),
    }
}

/// [`sort_distinct`] by rank over a padded copy of `W` elements (`a.len() ≤ W`).
#[inline]
fn rank_sort<const W: usize>(a: &mut [u32]) {
    let m = a.len();
    debug_assert!(m <= W);
    // Compared as i32 after flipping the top bit (the same order as u32: SSE2 has
    // only signed 32-bit compares). Pads of u32::MAX (i32::MAX flipped) are never below
    // an element (the rows are below n ≤ u32::MAX).
    const FLIP: u32 = 1 << 31;
    let mut pad = [i32::MAX; W];
    for (p, &x) in pad.iter_mut().zip(a.iter()) {
        *p = (x ^ FLIP) as i32;
    }
    let width = m.next_multiple_of(8).min(W);
    let mut out = [0u32; W];
    for &x in &pad[..m] {
        let rank: u32 = pad[..width].iter().map(|&y| u32::from(y < x)).sum();
        out[rank as usize] = (x as u32) ^ FLIP;
    }
    // Distinct elements have distinct ranks 0..m, so `out[..m]` is `a` sorted.
    a.copy_from_slice(&out[..m]);
}

/// The AVX2 kernels of the assembly.
#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::x86_64::*;

    /// The rows of a one-ring column j with `d` < 8 neighbours, read as 8 lanes from
    /// `nb` (sorted): `nb[..split]`, j, `nb[split..d]` as 8 `usize` at `dst` (the lanes
    /// past d are left over from the read). Returns `split` (the neighbours below j)
    /// and whether the d + 1 rows are strictly increasing and below `n` — the checks
    /// of [`super::one_ring_columns`]' scalar loop, all without a branch.
    ///
    /// # Safety
    /// The CPU has AVX2; `nb` is valid for 8 reads and `dst` for 8 writes. (And
    /// `d < 8`, `n ≥ 1`: a column exists.)
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn one_ring_rows(
        nb: *const u32,
        d: usize,
        j: u32,
        n: usize,
        dst: *mut usize,
    ) -> (usize, bool) {
        /// `a < b` per lane, unsigned: a signed compare after flipping the top bits.
        #[inline]
        #[target_feature(enable = "avx2")]
        fn lt(a: __m256i, b: __m256i) -> __m256i {
            let flip = _mm256_set1_epi32(i32::MIN);
            _mm256_cmpgt_epi32(_mm256_xor_si256(b, flip), _mm256_xor_si256(a, flip))
        }
        let lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        // SAFETY: by the caller's contract (8 reads from `nb`).
        let v = unsafe { _mm256_loadu_si256(nb.cast()) };
        let jv = _mm256_set1_epi32(j as i32);
        let neighbour = _mm256_cmpgt_epi32(_mm256_set1_epi32(d as i32), lane);
        let below = _mm256_and_si256(lt(v, jv), neighbour);
        let split = (_mm256_movemask_ps(_mm256_castsi256_ps(below)) as u32).count_ones() as usize;
        // Lane t takes nb[t] before the split, j at it, nb[t − 1] after it.
        let sv = _mm256_set1_epi32(split as i32);
        let from = _mm256_add_epi32(lane, _mm256_cmpgt_epi32(lane, sv));
        let out = _mm256_blendv_epi8(
            _mm256_permutevar8x32_epi32(v, from),
            jv,
            _mm256_cmpeq_epi32(lane, sv),
        );
        // Rows t < t + 1 for t < d, and every row t ≤ d below n (n ≤ u32::MAX + 1:
        // compared as n − 1 ≥ row).
        let next = _mm256_permutevar8x32_epi32(out, _mm256_setr_epi32(1, 2, 3, 4, 5, 6, 7, 7));
        let unordered = _mm256_andnot_si256(lt(out, next), neighbour);
        let last = _mm256_set1_epi32((n - 1) as u32 as i32);
        let row = _mm256_cmpgt_epi32(_mm256_set1_epi32(d as i32 + 1), lane);
        let too_big = _mm256_and_si256(lt(last, out), row);
        let bad = _mm256_or_si256(unordered, too_big);
        let ok = _mm256_testz_si256(bad, bad) == 1;
        // SAFETY: by the caller's contract (8 writes to `dst`).
        unsafe {
            _mm256_storeu_si256(
                dst.cast(),
                _mm256_cvtepu32_epi64(_mm256_castsi256_si128(out)),
            );
            _mm256_storeu_si256(
                dst.add(4).cast(),
                _mm256_cvtepu32_epi64(_mm256_extracti128_si256(out, 1)),
            );
        }
        (split, ok)
    }

    /// The values of that column: `buf[1..]` holds its off-diagonal values (`buf[0]` a
    /// pad), written as 8 `f64` at `dst` with `diag` merged in at lane `split`: lane t
    /// takes `buf[1 + t]` before it, `buf[t]` after it. The values themselves, not
    /// recomputed: the same bits as the scalar loop.
    ///
    /// # Safety
    /// The CPU has AVX2; `buf` is valid for 9 reads and `dst` for 8 writes.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn one_ring_values(buf: *const f64, split: usize, diag: f64, dst: *mut f64) {
        let sv = _mm256_set1_epi64x(split as i64);
        let dv = _mm256_set1_pd(diag);
        for (h, lane) in [
            _mm256_setr_epi64x(0, 1, 2, 3),
            _mm256_setr_epi64x(4, 5, 6, 7),
        ]
        .into_iter()
        .enumerate()
        {
            // SAFETY: by the caller's contract (reads of buf[4h..4h + 5], writes of
            // dst[4h..4h + 4]).
            unsafe {
                let own = _mm256_loadu_pd(buf.add(1 + 4 * h));
                let shifted = _mm256_loadu_pd(buf.add(4 * h));
                let after = _mm256_castsi256_pd(_mm256_cmpgt_epi64(lane, sv));
                let at = _mm256_castsi256_pd(_mm256_cmpeq_epi64(lane, sv));
                let x = _mm256_blendv_pd(_mm256_blendv_pd(own, shifted, after), dv, at);
                _mm256_storeu_pd(dst.add(4 * h), x);
            }
        }
    }

    /// Writes the distinct elements `a[..m]` (m ≤ 32) ascending to `out[..m]`, where
    /// `a[m..32]` are pads of `u32::MAX`: each element goes to its rank, the number of
    /// elements below it, counted for all 32 lanes at once (per element, one broadcast
    /// and four compares). The same result as [`super::sort_distinct`]; only called
    /// from the AVX2 build ([`crate::cpu::dispatch`]).
    #[inline(always)]
    pub(super) fn sort_distinct_32(a: &[u32], m: usize, out: &mut [u32; 32]) {
        // Compared as i32 after flipping the top bit (AVX2 has only signed compares).
        // The pads are ranked but never read, and never counted as below an element
        // (only the m elements are broadcast).
        let pad: &[u32; 32] = a[..32].try_into().unwrap();
        assert!(m <= 32);
        let mut rank = [0u32; 32];
        // SAFETY: the caller runs in the AVX2 build (`RingRows::avx2_fma`, entered by
        // `cpu::dispatch` only on a CPU with AVX2); the loads and stores cover the
        // 32-entry arrays `pad` and `rank` exactly.
        unsafe {
            let flip = _mm256_set1_epi32(i32::MIN);
            let p = pad.as_ptr().cast::<__m256i>();
            // No closures here: one would be compiled without AVX2.
            let x = [
                _mm256_xor_si256(_mm256_loadu_si256(p), flip),
                _mm256_xor_si256(_mm256_loadu_si256(p.add(1)), flip),
                _mm256_xor_si256(_mm256_loadu_si256(p.add(2)), flip),
                _mm256_xor_si256(_mm256_loadu_si256(p.add(3)), flip),
            ];
            let mut r = [_mm256_setzero_si256(); 4];
            for &y in &a[..m] {
                let y = _mm256_set1_epi32((y ^ (1 << 31)) as i32);
                for v in 0..4 {
                    // −1 in every lane above y.
                    r[v] = _mm256_sub_epi32(r[v], _mm256_cmpgt_epi32(x[v], y));
                }
            }
            let q = rank.as_mut_ptr().cast::<__m256i>();
            for (v, r) in r.iter().enumerate() {
                _mm256_storeu_si256(q.add(v), *r);
            }
        }
        // Distinct elements have distinct ranks 0..m.
        for (&x, &r) in a[..m].iter().zip(&rank) {
            out[r as usize] = x;
        }
    }
}

#[cfg(test)]
pub(crate) mod reference {
    //! The previous assembly (one-ring fill with faer's checked constructor; two-ring
    //! by a Gustavson column-combination product), kept to test the new one against
    //! entry by entry.
    use super::*;

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
}

#[cfg(test)]
mod tests {
    //! The in-place assembly against the previous one ([`reference`]), entry by entry
    //! and bit for bit (same pattern, same row order, same values) on generated meshes
    //! and the real meshes of `tests/data` (closed, with boundary, non-manifold).
    use super::*;
    use crate::mesh::{topology::Topology, TriMesh, VertexId};
    use crate::operator::cotan::{cotan, MassKind};
    use crate::operator::sql::{sql, sql_diagonal, sql_edge_weights, BoundaryDiagonal};
    use crate::operator::{degrees_checked, test_util, Operator, OperatorKind, OperatorOptions};

    /// The k of column j in `order`, into `out`.
    fn ring_ks(topo: &Topology, j: usize, order: RingOrder, out: &mut Vec<u32>) {
        let nb = topo.neighbors(crate::VertexId(j as u32));
        out.clear();
        out.resize(nb.len() + 1, 0);
        let split = match order {
            RingOrder::Ascending => count_below(nb, j),
            RingOrder::DiagonalFirst => 0,
        };
        let (lo, rest) = out.split_at_mut(split);
        lo.copy_from_slice(&nb[..split]);
        rest[0] = j as u32;
        rest[1..].copy_from_slice(&nb[split..]);
    }

    fn cases() -> Vec<(String, TriMesh, Topology)> {
        let mut out: Vec<(String, TriMesh, Topology)> = test_util::meshes()
            .into_iter()
            .map(|(name, m)| {
                let t = test_util::topo(&m);
                (name.to_string(), m, t)
            })
            .collect();
        // A fan of three faces on one edge (non-manifold) plus an isolated-free strip.
        let nm = TriMesh::new(
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.5, 1.0, 0.0],
                [0.5, -1.0, 0.0],
                [0.5, 0.0, 1.0],
                [1.5, 1.0, 0.2],
            ],
            vec![[0, 1, 2], [1, 0, 3], [0, 1, 4], [1, 5, 2]],
        );
        let t = test_util::topo(&nm);
        out.push(("non-manifold fan".into(), nm, t));
        // The real meshes are too slow to interpret: under Miri (RELIABILITY.md) only
        // the generated ones and the spread fan below.
        if !cfg!(miri) {
            for name in [
                "cow.obj",
                "teapot.obj",
                "woody.obj",
                "beetle.obj",
                "suzanne.obj",
            ] {
                let path = format!("{}/../../tests/data/{name}", env!("CARGO_MANIFEST_DIR"));
                let input =
                    crate::input::open(&path, &crate::input::OpenOptions::default()).unwrap();
                out.push((name.to_string(), input.mesh, input.topology));
            }
            // The cow with its vertices in a random (seeded) order: two-ring rows spread
            // far apart, in no order the candidates' lists share.
            {
                use rand::seq::SliceRandom;
                use rand::SeedableRng;
                let cow = out.iter().find(|c| c.0 == "cow.obj").unwrap().1.clone();
                let mut perm: Vec<u32> = (0..cow.n_vertices() as u32).collect();
                perm.shuffle(&mut rand_chacha::ChaCha8Rng::seed_from_u64(17));
                let mut positions = vec![[0.0; 3]; cow.n_vertices()];
                for (v, &p) in perm.iter().enumerate() {
                    positions[p as usize] = cow.positions[v];
                }
                let faces = cow
                    .faces
                    .iter()
                    .map(|f| f.map(|v| perm[v as usize]))
                    .collect();
                let m = TriMesh::new(positions, faces);
                let t = test_util::topo(&m);
                out.push(("shuffled cow".into(), m, t));
            }
        }
        // A closed fan of 120 triangles whose vertices are spread over 10,007 ids (the
        // rest isolated; 257 under Miri): the centre's column has 121 rows, more than
        // either rank sort takes (32).
        {
            let n = if cfg!(miri) { 257u32 } else { 10_007 };
            let id = |k: u32| (k * 83) % n;
            let mut positions = vec![[0.0; 3]; n as usize];
            let rim = 120u32;
            for k in 0..rim {
                let a = std::f64::consts::TAU * k as f64 / rim as f64;
                positions[id(k + 1) as usize] = [a.cos(), a.sin(), 0.1 * (k % 3) as f64];
            }
            let faces = (0..rim)
                .map(|k| [id(0), id(k + 1), id((k + 1) % rim + 1)])
                .collect();
            let m = TriMesh::new(positions, faces);
            let t = test_util::topo(&m);
            out.push(("spread fan".into(), m, t));
        }
        out
    }

    /// Same dimensions, column pointers, row indices and value bits.
    fn assert_identical(name: &str, what: &str, got: &SparseMatrix, want: &SparseMatrix) {
        assert_eq!(got.nrows(), want.nrows(), "{name} {what}");
        assert_eq!(got.ncols(), want.ncols(), "{name} {what}");
        assert_eq!(
            got.symbolic().col_ptr(),
            want.symbolic().col_ptr(),
            "{name} {what}: column pointers"
        );
        assert_eq!(
            got.symbolic().row_idx(),
            want.symbolic().row_idx(),
            "{name} {what}: row indices"
        );
        let bits = |m: &SparseMatrix| m.val().iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert!(bits(got) == bits(want), "{name} {what}: values differ");
    }

    /// The previous SQL: edge weights and diagonal as arrays, then the one-ring fill.
    fn sql_reference(topo: &Topology, convention: BoundaryDiagonal) -> SparseMatrix {
        let d = degrees_checked(topo).unwrap();
        let w = sql_edge_weights(topo, &d).unwrap();
        let diag = sql_diagonal(topo, &d, convention);
        reference::one_ring_matrix(topo, |i| diag[i], |_, _, e| -w[e])
    }

    /// The previous cotangent stiffness: sequential face loop into edge weights.
    fn cotan_reference(mesh: &TriMesh, topo: &Topology) -> SparseMatrix {
        use crate::operator::geometry::{cross, dot, norm, sub};
        let mut w = vec![0.0f64; topo.n_edges()];
        let p = |v: u32| mesh.positions[v as usize];
        for (f, t) in topo.faces().iter().enumerate() {
            let [a, b, c] = t.map(p);
            let area2 = norm(cross(sub(b, a), sub(c, a)));
            for k in 0..3 {
                let o = t[k];
                let (u, v) = (sub(p(t[(k + 1) % 3]), p(o)), sub(p(t[(k + 2) % 3]), p(o)));
                let h = (3 * f + (k + 1) % 3) as u32;
                w[topo.half_edge_edge(h).idx()] += 0.5 * (dot(u, v) / area2);
            }
        }
        let diag: Vec<f64> = (0..topo.n_vertices())
            .map(|v| {
                topo.neighbor_edges(VertexId(v as u32))
                    .iter()
                    .map(|&e| w[e as usize])
                    .sum()
            })
            .collect();
        reference::one_ring_matrix(topo, |i| diag[i], |_, _, e| -w[e])
    }

    #[test]
    fn one_ring_fill_equals_previous_assembly() {
        for (name, _, t) in cases() {
            let deg = t.degrees();
            let diag = |i: usize| deg[i] as f64 + 0.25;
            let off = |i: usize, j: usize, e: usize| -((i * 7 + j * 3 + e) as f64);
            assert_identical(
                &name,
                "one-ring",
                &one_ring_matrix(&t, diag, off),
                &reference::one_ring_matrix(&t, diag, off),
            );
        }
    }

    /// The AVX2 lanes of `one_ring_columns` against the scalar merge: every degree
    /// below 8, j below, among and above its neighbours (vertex ids up to
    /// `u32::MAX − 1`, the flip's edge case), and the checks: unsorted neighbours, a
    /// duplicate, or a row not below n make the column fail.
    #[test]
    #[cfg(target_arch = "x86_64")]
    fn one_ring_lanes_match_the_scalar_merge() {
        use rand::{Rng, SeedableRng};
        if !crate::cpu::avx2_fma() {
            return;
        }
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(37);
        let lanes = |nb: &[u32], j: u32, n: usize, off: &[f64], diag: f64| {
            let mut src = [0u32; 8];
            src[..nb.len()].copy_from_slice(nb);
            let mut buf = [0.0f64; 9];
            buf[1..=off.len()].copy_from_slice(off);
            let (mut rows, mut vals) = ([0usize; 8], [0.0f64; 8]);
            // SAFETY: AVX2 checked above; 8 and 9 reads, 8 writes, all in bounds.
            let (split, ok) = unsafe {
                let (split, ok) =
                    x86::one_ring_rows(src.as_ptr(), nb.len(), j, n, rows.as_mut_ptr());
                x86::one_ring_values(buf.as_ptr(), split, diag, vals.as_mut_ptr());
                (split, ok)
            };
            (
                split,
                ok,
                rows[..=nb.len()].to_vec(),
                vals[..=nb.len()].to_vec(),
            )
        };
        for round in 0..4000 {
            let d = round % 8;
            let high = round % 3 == 0;
            let top = if high { u32::MAX - 1 } else { 64 };
            let mut nb: Vec<u32> = Vec::new();
            while nb.len() < d + 1 {
                let x = if high && nb.is_empty() {
                    top
                } else {
                    rng.gen_range(0..=top)
                };
                if !nb.contains(&x) {
                    nb.push(x);
                }
            }
            // One of the d + 1 distinct ids is j, the others its neighbours, sorted.
            let j = nb.swap_remove(rng.gen_range(0..=d));
            nb.sort_unstable();
            let n = top as usize + 1;
            let off: Vec<f64> = (0..d).map(|_| rng.gen_range(-1.0..1.0)).collect();
            let diag = rng.gen_range(-1.0..1.0);
            let split = count_below(&nb, j as usize);
            let mut want_rows: Vec<usize> = nb.iter().map(|&i| i as usize).collect();
            want_rows.insert(split, j as usize);
            let mut want_vals = off.clone();
            want_vals.insert(split, diag);
            let (got_split, ok, rows, vals) = lanes(&nb, j, n, &off, diag);
            assert!(ok, "{nb:?} {j}");
            assert_eq!((got_split, &rows), (split, &want_rows), "{nb:?} {j}");
            assert!(vals
                .iter()
                .zip(&want_vals)
                .all(|(a, b)| a.to_bits() == b.to_bits()));
            // The checks.
            // (n ≥ 1 wherever a column exists.)
            let last = *want_rows.last().unwrap();
            if last > 0 {
                assert!(!lanes(&nb, j, last, &off, diag).1, "row = n: {nb:?} {j}");
            }
            if d >= 2 {
                let mut swapped = nb.clone();
                swapped.swap(0, d - 1);
                assert!(!lanes(&swapped, j, n, &off, diag).1, "unsorted {swapped:?}");
                let mut dup = nb.clone();
                dup[1] = dup[0];
                assert!(!lanes(&dup, j, n, &off, diag).1, "duplicate {dup:?}");
            }
        }
    }

    #[test]
    fn sort_distinct_sorts_by_rank_and_by_comparison() {
        use rand::{seq::SliceRandom, Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(17);
        for m in 0..=2 * RANK_SORT_MAX {
            for high in [false, true] {
                // Distinct values, some with the top bit set (the flip's edge case),
                // one of them u32::MAX − 1, the largest row a mesh can have.
                let mut a: Vec<u32> = Vec::new();
                while a.len() < m {
                    let x = if high && a.is_empty() {
                        u32::MAX - 1
                    } else if high {
                        rng.gen_range(0..u32::MAX - 1)
                    } else {
                        rng.gen_range(0..200)
                    };
                    if !a.contains(&x) {
                        a.push(x);
                    }
                }
                a.shuffle(&mut rng);
                let mut want = a.clone();
                want.sort_unstable();
                #[cfg(target_arch = "x86_64")]
                if m <= 32 && crate::cpu::avx2_fma() {
                    let mut out = [0u32; 32];
                    let mut padded = [u32::MAX; 32];
                    padded[..m].copy_from_slice(&a);
                    x86::sort_distinct_32(&padded, m, &mut out);
                    assert_eq!(out[..m], want[..], "AVX2, m = {m}, high = {high}");
                }
                sort_distinct(&mut a);
                assert_eq!(a, want, "m = {m}, high = {high}");
            }
        }
    }

    #[test]
    fn two_ring_rows_equal_on_the_portable_and_avx2_builds() {
        use crate::cpu::Kernel;
        for (name, _, t) in cases() {
            let n = t.n_vertices();
            let run = |avx2: bool| {
                let mut counts = vec![0usize; n];
                let (mut stamps, mut list) = (vec![0u32; n], Vec::new());
                let k = RingRows {
                    topo: &t,
                    first: 0,
                    counts: &mut counts,
                    stamps: &mut stamps,
                    list: &mut list,
                };
                let rows = if avx2 {
                    crate::cpu::dispatch(k)
                } else {
                    k.portable()
                };
                (rows, counts)
            };
            let portable = run(false);
            // The rows of each column: {j}, N(j) and N(k) for k ∈ N(j), sorted.
            let mut p = 0;
            for (j, &c) in portable.1.iter().enumerate() {
                let mut want = vec![j as u32];
                for &k in t.neighbors(VertexId(j as u32)) {
                    want.push(k);
                    want.extend_from_slice(t.neighbors(VertexId(k)));
                }
                want.sort_unstable();
                want.dedup();
                assert_eq!(portable.0[p..p + c], want[..], "{name}, column {j}");
                p += c;
            }
            assert_eq!(p, portable.0.len(), "{name}");
            assert_eq!(run(true), portable, "{name}");
        }
    }

    #[test]
    fn two_ring_fill_equals_gustavson_product() {
        for (name, _, t) in cases() {
            let n = t.n_vertices();
            // Arbitrary, asymmetric coefficients: every (j, k) and (k, i) distinct.
            let coeff = |j: usize, k: usize| 1.0 + (j as f64) / (n as f64) - 0.5 * (k as f64);
            let diag = |k: usize| 0.25 - (k as f64) * 0.7 + 1.0 / 3.0;
            let v: Vec<f64> = (0..n)
                .map(|k| 0.25 + (k as f64) * 1e-3 - 1.0 / 7.0)
                .collect();
            for off in [RingEntries::PerColumn(&v), RingEntries::PerRow(&v)] {
                let entry = |k: usize, i: usize| match (i == k, off) {
                    (true, _) => diag(k),
                    (false, RingEntries::PerColumn(v)) => v[k],
                    (false, RingEntries::PerRow(v)) => v[i],
                };
                for order in [RingOrder::Ascending, RingOrder::DiagonalFirst] {
                    let got = two_ring_matrix(&t, order, coeff, diag, off);
                    let want = reference::combine_columns(
                        n,
                        |j, out| {
                            let mut ks = Vec::new();
                            ring_ks(&t, j, order, &mut ks);
                            out.extend(ks.into_iter().map(|k| (k as usize, coeff(j, k as usize))));
                        },
                        |k, out| {
                            out.push((k, entry(k, k)));
                            for &i in t.neighbors(VertexId(k as u32)) {
                                out.push((i as usize, entry(k, i as usize)));
                            }
                        },
                    );
                    let what = match off {
                        RingEntries::PerColumn(_) => "per column",
                        RingEntries::PerRow(_) => "per row",
                    };
                    assert_identical(&name, &format!("two-ring {order:?} {what}"), &got, &want);
                }
            }
        }
    }

    #[test]
    fn operators_equal_previous_assembly_bit_for_bit() {
        for (name, m, t) in cases() {
            if name == "spread fan" {
                continue; // isolated vertices: no Tutte weights
            }
            let d = degrees_checked(&t).unwrap();
            // SSTL and T² exactly as they were built before (Gustavson).
            let sstl_ref = reference::combine_columns(
                t.n_vertices(),
                |j, out| {
                    let nb = t.neighbors(VertexId(j as u32));
                    let split = nb.partition_point(|&k| (k as usize) < j);
                    out.extend(
                        nb[..split]
                            .iter()
                            .map(|&k| (k as usize, -1.0 / d[k as usize])),
                    );
                    out.push((j, 1.0));
                    out.extend(
                        nb[split..]
                            .iter()
                            .map(|&k| (k as usize, -1.0 / d[k as usize])),
                    );
                },
                |k, out| reference::one_ring_column(&t, k, 1.0, |_| -1.0 / d[k], out),
            );
            let t2_ref = reference::combine_columns(
                t.n_vertices(),
                |j, out| {
                    out.push((j, 1.0));
                    for &k in t.neighbors(VertexId(j as u32)) {
                        out.push((k as usize, -1.0 / d[k as usize]));
                    }
                },
                |k, out| reference::one_ring_column(&t, k, 1.0, |i| -1.0 / d[i], out),
            );
            let tutte_ref = reference::one_ring_matrix(&t, |_| 1.0, |i, _, _| -1.0 / d[i]);
            let op = |kind: OperatorKind| {
                Operator::assemble(kind, &m, &t, &OperatorOptions::default())
                    .unwrap()
                    .matrix
            };
            assert_identical(&name, "sstl", &op(OperatorKind::Sstl), &sstl_ref);
            assert_identical(&name, "tutte2", &op(OperatorKind::Tutte2), &t2_ref);
            assert_identical(&name, "tutte", &op(OperatorKind::Tutte), &tutte_ref);
            if t.non_manifold_edges().next().is_none() {
                for c in [BoundaryDiagonal::ZeroRowSum, BoundaryDiagonal::AsPrinted] {
                    assert_identical(&name, "sql", &sql(&t, c).unwrap(), &sql_reference(&t, c));
                }
            } else {
                // Refused as before, naming the first non-manifold edge.
                let e = t.non_manifold_edges().next().unwrap();
                let [a, b] = t.edge(e);
                let err = sql(&t, BoundaryDiagonal::ZeroRowSum).unwrap_err();
                assert!(
                    err.to_string().contains(&format!("edge ({a}, {b})")),
                    "{name}: {err}"
                );
            }
            let geometric = m.faces.iter().all(|f| {
                let [a, b, c] = f.map(|v| m.positions[v as usize]);
                let area2 = crate::operator::geometry::norm(crate::operator::geometry::cross(
                    crate::operator::geometry::sub(b, a),
                    crate::operator::geometry::sub(c, a),
                ));
                crate::operator::cotan::is_proper_triangle(area2, [a, b, c])
            });
            if geometric {
                for threads in [1, 3] {
                    let pool = rayon::ThreadPoolBuilder::new()
                        .num_threads(threads)
                        .build()
                        .unwrap();
                    let (l, _) = pool.install(|| cotan(&m, &t, MassKind::Voronoi).unwrap());
                    assert_identical(&name, "cotan", &l, &cotan_reference(&m, &t));
                    let f = pool.install(|| crate::operator::mean_value::mean_value(&m, &t));
                    let want = mean_value_reference(&m, &t);
                    assert_identical(&name, "mean-value", &f.unwrap(), &want);
                }
            }
        }
    }

    /// The mean-value assembly as a sequential face loop adding each corner's
    /// `tan(θ/2)/‖e‖` into per-edge directed weights (`tan(θ/2)` as the root of the
    /// ratio of the squared norms of Kahan's form, each row scaled by the reciprocal of
    /// its sum, as the parallel assembly computes them).
    fn mean_value_reference(mesh: &TriMesh, topo: &Topology) -> SparseMatrix {
        use crate::operator::geometry::{add, dot, norm, scale, sub};
        let mut w = vec![[0.0f64; 2]; topo.n_edges()];
        let p = |v: u32| mesh.positions[v as usize];
        for (f, t) in topo.faces().iter().enumerate() {
            for k in 0..3 {
                let (i, j, l) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
                let (u, v) = (sub(p(j), p(i)), sub(p(l), p(i)));
                let (lu, lv) = (norm(u), norm(v));
                let (du, dv) = (scale(u, lv), scale(v, lu));
                let (plus, minus) = (add(du, dv), sub(du, dv));
                let half_tan = (dot(minus, minus) / dot(plus, plus)).sqrt();
                for (h, len) in [(3 * f + k, lu), (3 * f + (k + 2) % 3, lv)] {
                    let e = topo.half_edge_edge(h as u32).idx();
                    let dir = usize::from(topo.edge(crate::mesh::EdgeId(e as u32))[0] != i);
                    w[e][dir] += half_tan / len;
                }
            }
        }
        let dir = |e: usize, from: usize| usize::from(topo.edges()[e][0] != from as u32);
        let sums: Vec<f64> = (0..topo.n_vertices())
            .map(|v| {
                topo.neighbor_edges(VertexId(v as u32))
                    .iter()
                    .map(|&e| w[e as usize][dir(e as usize, v)])
                    .sum()
            })
            .collect();
        reference::one_ring_matrix(topo, |_| 1.0, |i, _, e| -w[e][dir(e, i)] * (1.0 / sums[i]))
    }

    #[test]
    fn edge_sides_sum_as_a_sequential_face_loop() {
        for (name, _, t) in cases() {
            // A value per half-edge over many magnitudes and both signs (−0.0
            // included), so that a non-manifold edge's sum depends on its order.
            let v = |h: usize| {
                let x = (h as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
                match x % 7 {
                    0 => -0.0,
                    k => {
                        (x >> 11) as f64
                            * 2f64.powi(k as i32 * 9 - 80)
                            * if x.is_multiple_of(2) { 1.0 } else { -1.0 }
                    }
                }
            };
            let mut want = vec![0.0f64; t.n_edges()];
            for h in 0..3 * t.n_faces() {
                want[t.half_edge_edge(h as u32).idx()] += v(h);
            }
            for threads in [1, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let (sides, corners) = pool
                    .install(|| {
                        per_face_edge_sides(
                            &t,
                            0.0f64,
                            |a, b| a + b,
                            &Collected(|faces: std::ops::Range<usize>, out: &mut Vec<_>| {
                                out.extend(faces.map(|f| {
                                    (
                                        std::array::from_fn(|m| v(3 * f + m)),
                                        std::array::from_fn(|m| (3 * f + m) as u32),
                                    )
                                }));
                                Ok::<_, ()>(())
                            }),
                        )
                    })
                    .unwrap();
                let got: Vec<u64> = sides
                    .iter()
                    .map(|&[a, b]| (0.0 + a + b).to_bits())
                    .collect();
                let want: Vec<u64> = want.iter().map(|x| x.to_bits()).collect();
                assert!(got == want, "{name}, {threads} threads");
                assert!(
                    corners.iter().enumerate().all(|(h, &c)| c as usize == h),
                    "{name}"
                );
            }
        }
    }

    #[test]
    fn edge_sides_report_the_first_failing_face() {
        let (_, _, t) = cases().into_iter().find(|c| c.0 == "cow.obj").unwrap();
        for threads in [1, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let got = pool.install(|| {
                per_face_edge_sides(
                    &t,
                    0.0f64,
                    |a, b| a + b,
                    &Collected(|faces: std::ops::Range<usize>, out: &mut Vec<_>| {
                        for f in faces {
                            if f == 4000 || f == 1500 || f == 1501 {
                                return Err(f);
                            }
                            out.push(([1.0; 3], [(); 3]));
                        }
                        Ok(())
                    }),
                )
            });
            assert_eq!(got.err(), Some(1500), "{threads} threads");
        }
    }
}
