//! `A_σ = M^{1/2} (K − σM)^{-1} M^{1/2}` as a block operator: the hand-written
//! interleaved supernodal solves with faer's LDLᵀ factors (AVX2 where available).

use super::mass::Metric;
use crate::spectral::krylov_schur::BlockOperator;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::reborrow::ReborrowMut;
use faer::sparse::linalg::cholesky::{LdltRef, SymbolicCholesky};
use faer::{Conj, MatMut, MatRef, Par};

/// `A_σ = M^{1/2} (K − σM)^{-1} M^{1/2}` (symmetric) as a block operator.
///
/// The solves with faer's LDLᵀ factors are done here by hand, on an *interleaved*
/// right-hand side (row-major n×c: the c values of one row are contiguous), walking
/// the supernodes column by column: each factor entry is loaded once and used for c
/// multiply-adds on contiguous memory, which the compiler vectorises. faer's own
/// supernodal solve works on column-major right-hand sides with a small dense product
/// per supernode, which is slow on mesh Laplacians (many small supernodes; figures in
/// BENCHMARKS.md, "Partial spectra and partitioning"). The
/// right-hand sides are split between the rayon threads (faer's parallel solve
/// spin-waits) — or, when the elimination tree splits into two independent forests
/// of similar cost ([`TreeSplit`], as METIS' nested dissection gives on large
/// meshes), each thread solves one forest for all the right-hand sides and the top of
/// the tree follows on one thread: each factor entry is then read once per block
/// instead of once per thread (half the factor bytes per block; the solves also wait
/// on scattered right-hand-side rows, so the gain is smaller than that — figures in
/// BENCHMARKS.md). A simplicial factorization (tiny matrices) falls back to faer.
///
/// For a sparse (non-diagonal) `M = C Cᵀ` the operator is `Cᵀ (K − σM)⁻¹ C`: the
/// products with `C` and `Cᵀ` wrap the solves, which then run unscaled.
pub(super) struct ShiftInvert<'a> {
    pub(super) symbolic: &'a SymbolicCholesky<usize>,
    pub(super) values: Vec<f64>,
    /// `M` and its factor.
    pub(super) metric: &'a Metric,
    /// `√m` for a diagonal `M`; ones for a sparse `M` (see [`ShiftInvert::scale_of`]).
    pub(super) msqrt: &'a [f64],
    /// The elimination tree's split, if it has one worth using ([`TreeSplit::of`]).
    pub(super) split: Option<TreeSplit>,
    /// The split solve's interleaved right-hand side (n·W values), kept from call to
    /// call: on a million-vertex mesh it is 64 MB, above glibc's mmap threshold, so
    /// a fresh one per block was page-faulted and cleared every time.
    pub(super) scratch: std::sync::Mutex<Vec<f64>>,
}

/// Supernodal factors of at least this dimension are solved forest by forest when
/// their elimination tree splits well ([`TreeSplit::of`]): the dimensions from which
/// the LDLᵀ uses nested dissection, whose tree splits into halves. Smaller factors
/// (AMD-ordered, a few megabytes) stay in the caches, where splitting the
/// right-hand sides between the threads costs nothing and the split's serial top
/// made the bunny's partial spectrum slightly slower (BENCHMARKS.md).
pub(super) const TREE_SPLIT_MIN_DIM: usize = super::ordering::NESTED_DISSECTION_FROM;

/// A split of a supernodal factor's elimination tree (supernodes in faer's
/// topological order: children before parents) into two independent forests, the
/// supernodes `0..a` and `a..b`, and the rest `b..` (their common ancestors, the top
/// separators of a nested dissection). No supernode of `0..a` has a row in the
/// columns of `a..b` (the rows of a column of `L` are ancestors of it in the tree,
/// and every ancestor outside `0..a` is at `b` or above), and none of `a..b` has a
/// row below its own columns, so the two forests touch disjoint rows except those
/// of `b..`.
///
/// The forward solve then runs the forests in parallel, each adding its updates of
/// the rows of `b..` into a zeroed buffer of its own; the rows of `b..` get
/// `(x + buffer₀) + buffer₁`, the top is solved on one thread, and the backward solve
/// runs the forests in parallel again (they only read the top's rows). The same
/// arithmetic on any number of threads (one thread runs the forests in turn); it
/// differs from the unsplit solve only in the order the top rows' updates are summed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct TreeSplit {
    a: usize,
    b: usize,
}

impl TreeSplit {
    /// The split minimising `max(cost(0..a), cost(a..b)) + cost(b..)` (cost: the
    /// factor entries of the supernodes), or `None` when the factor is simplicial,
    /// below `min_dim`, or no split saves a fifth of the cost of an unsplit solve.
    /// O(s log s) for s supernodes.
    pub(super) fn of(symbolic: &SymbolicCholesky<usize>, min_dim: usize) -> Option<Self> {
        use faer::sparse::linalg::cholesky::SymbolicCholeskyRaw;
        use std::cmp::Reverse;
        let SymbolicCholeskyRaw::Supernodal(sym) = symbolic.raw() else {
            return None;
        };
        let ns = sym.n_supernodes();
        if sym.nrows() < min_dim || ns < 3 {
            return None;
        }
        let begin = sym.supernode_begin();
        let end = sym.supernode_end();
        let owner = |row: usize| begin.partition_point(|&b| b <= row) - 1;
        let mut prefix = Vec::with_capacity(ns + 1);
        prefix.push(0usize);
        let mut parent = Vec::with_capacity(ns);
        for s in 0..ns {
            let w = end[s] - begin[s];
            let pattern = sym.supernode(s).pattern();
            prefix.push(prefix[s] + w * (w + pattern.len()));
            parent.push(pattern.first().map(|&r| owner(r)));
        }
        let total = prefix[ns];
        // Parents (≥ a) of the supernodes below a, smallest first.
        let mut heap = std::collections::BinaryHeap::new();
        let mut best: Option<(usize, Self)> = None;
        for a in 1..ns {
            if let Some(p) = parent[a - 1] {
                heap.push(Reverse(p));
            }
            while heap.peek().is_some_and(|&Reverse(p)| p < a) {
                heap.pop();
            }
            let b = heap.peek().map_or(ns, |&Reverse(p)| p);
            let cost = (prefix[a]).max(prefix[b] - prefix[a]) + (total - prefix[b]);
            if b > a && best.is_none_or(|(c, _)| cost < c) {
                best = Some((cost, Self { a, b }));
            }
        }
        best.filter(|&(c, _)| 5 * c <= 4 * total).map(|(_, s)| s)
    }
}

impl ShiftInvert<'_> {
    /// The row scaling the solves apply on both sides: `√m` for a diagonal `M`, ones
    /// (kept in `ones`) for a sparse one.
    pub(super) fn scale_of<'a>(metric: &'a Metric, ones: &'a mut Vec<f64>) -> &'a [f64] {
        match metric.diagonal_sqrt() {
            Some(s) => s,
            None => {
                *ones = vec![1.0; metric.dim()];
                ones
            }
        }
    }
}

impl ShiftInvert<'_> {
    fn solve_cols(&self, out: MatMut<'_, f64>, threads: usize) {
        if let Some(split) = self.split {
            // Two threads per group of columns (each forest on one).
            if threads >= 4 && out.ncols() > 1 {
                let half = out.ncols() / 2;
                let (a, b) = out.split_at_col_mut(half);
                rayon::join(
                    || self.solve_cols(a, threads / 2),
                    || self.solve_cols(b, threads - threads / 2),
                );
            } else {
                self.solve_split(split, out);
            }
            return;
        }
        if threads <= 1 || out.ncols() <= 1 {
            self.solve_seq(out);
            return;
        }
        let half = out.ncols() / 2;
        let (a, b) = out.split_at_col_mut(half);
        rayon::join(
            || self.solve_cols(a, threads / 2),
            || self.solve_cols(b, threads - threads / 2),
        );
    }

    /// `out ← M^{1/2} (K − σM)^{-1} M^{1/2} out` on one thread.
    fn solve_seq(&self, mut out: MatMut<'_, f64>) {
        use faer::sparse::linalg::cholesky::SymbolicCholeskyRaw;
        let n = out.nrows();
        let c = out.ncols();
        let ms = self.msqrt;
        let SymbolicCholeskyRaw::Supernodal(sym) = self.symbolic.raw() else {
            for j in 0..c {
                for i in 0..n {
                    out[(i, j)] *= ms[i];
                }
            }
            let mut buf = MemBuffer::new(
                self.symbolic
                    .solve_in_place_scratch::<f64>(c.max(1), Par::Seq),
            );
            LdltRef::new(self.symbolic, &self.values).solve_in_place_with_conj(
                Conj::No,
                out.rb_mut(),
                Par::Seq,
                MemStack::new(&mut buf),
            );
            for j in 0..c {
                for i in 0..n {
                    out[(i, j)] *= ms[i];
                }
            }
            return;
        };
        for (j0, w) in column_groups(c) {
            let cols = out.rb_mut().subcols_mut(j0, w);
            match w {
                16 => self.solve_dispatch::<16>(sym, cols),
                8 => self.solve_dispatch::<8>(sym, cols),
                4 => self.solve_dispatch::<4>(sym, cols),
                _ => self.solve_dispatch::<1>(sym, cols),
            }
        }
    }

    /// [`Self::solve_fixed`] compiled for AVX2 + FMA when [`crate::cpu::avx2_fma`]
    /// allows it (the CPU has them and `MESHLAP_PORTABLE` is not set; the default
    /// x86-64 target has only SSE2; faer dispatches the same way at run time).
    fn solve_dispatch<const W: usize>(
        &self,
        sym: &faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky<usize>,
        out: MatMut<'_, f64>,
    ) {
        #[cfg(target_arch = "x86_64")]
        {
            #[target_feature(enable = "avx2,fma")]
            fn avx2<const W: usize>(
                this: &ShiftInvert<'_>,
                sym: &faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky<usize>,
                out: MatMut<'_, f64>,
            ) {
                this.solve_fixed::<W>(sym, out)
            }
            if crate::cpu::avx2_fma() {
                // SAFETY: `avx2_fma()` is only true when the CPU has AVX2 and FMA.
                unsafe { avx2::<W>(self, sym, out) };
                return;
            }
        }
        self.solve_fixed::<W>(sym, out)
    }

    /// The supernodal solve on `W` interleaved columns (see the type's documentation).
    #[inline(always)]
    fn solve_fixed<const W: usize>(
        &self,
        sym: &faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky<usize>,
        mut out: MatMut<'_, f64>,
    ) {
        let n = out.nrows();
        let ms = self.msqrt;
        let perm = self.symbolic.perm();
        let fwd = |i: usize| perm.map_or(i, |p| p.arrays().0[i]);
        // Gather into the permuted, interleaved x (row i of x = row fwd(i) of b).
        let mut x: Vec<[f64; W]> = (0..n)
            .map(|i| {
                let f = fwd(i);
                std::array::from_fn(|j| out[(f, j)] * ms[f])
            })
            .collect();
        // L y = b with z = D⁻¹ y, then Lᵀ x = z, over all supernodes (no top rows).
        let ns = sym.n_supernodes();
        for step in [RangeStep::Forward(&mut []), RangeStep::Backward(&[])] {
            crate::cpu::Kernel::portable(Range {
                sym,
                values: &self.values,
                s0: 0,
                s1: ns,
                x: &mut x,
                off: 0,
                top_from: n,
                step,
            });
        }
        // Scatter back: row fwd(i) of the result is row i of x.
        for (i, row) in x.iter().enumerate() {
            let f = fwd(i);
            for (j, &v) in row.iter().enumerate() {
                out[(f, j)] = v * ms[f];
            }
        }
    }
}

/// The groups `(first column, width)` in which the solves take c columns: as many
/// groups of 16 as fit, then one of 8, one of 4, then single columns.
///
/// A Krylov–Schur block has 8 columns; the refinement's b columns ([`super::polish`])
/// go by 16, which reads each factor entry once per 16 right-hand sides instead of
/// once per 8 and takes less time per column on both orderings' factors; groups of
/// 32 were no faster than 16 (BENCHMARKS.md, "Partial spectra and partitioning",
/// forty-seventh session).
fn column_groups(c: usize) -> impl Iterator<Item = (usize, usize)> {
    let mut j0 = 0;
    std::iter::from_fn(move || {
        let left = c - j0;
        let w = match left {
            0 => return None,
            16.. => 16,
            8.. => 8,
            4.. => 4,
            _ => 1,
        };
        j0 += w;
        Some((j0 - w, w))
    })
}

type Supernodal = faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky<usize>;

/// One step of a split solve over the supernodes `s0..s1`, whose own rows (and the
/// rows they update below `top_from`) lie in `x`, which holds rows `off..`; rows at
/// `top_from` and above are in `top` (see [`TreeSplit`]).
enum RangeStep<'a, const W: usize> {
    /// `L y = b` and `z = D⁻¹ y` over the range, the updates of the top rows
    /// subtracted into `top`.
    Forward(&'a mut [[f64; W]]),
    /// `Lᵀ x = z` over the range, the top rows read from `top`.
    Backward(&'a [[f64; W]]),
}

struct Range<'a, const W: usize> {
    sym: &'a Supernodal,
    values: &'a [f64],
    s0: usize,
    s1: usize,
    x: &'a mut [[f64; W]],
    off: usize,
    top_from: usize,
    step: RangeStep<'a, W>,
}

impl<const W: usize> crate::cpu::Kernel for Range<'_, W> {
    type Output = ();
    #[inline(always)]
    fn portable(self) {
        use faer::sparse::linalg::cholesky::supernodal::SupernodalLdltRef;
        let l = SupernodalLdltRef::new(self.sym, self.values);
        let (x, off, top_from) = (self.x, self.off, self.top_from);
        match self.step {
            RangeStep::Forward(top) => {
                for sn in self.s0..self.s1 {
                    let node = l.supernode(sn);
                    let val = node.val();
                    let start = node.start() - off;
                    let pattern = node.pattern();
                    let cut = pattern.partition_point(|&r| r < top_from);
                    let w = val.ncols();
                    for j in 0..w {
                        let xj = x[start + j];
                        let col = val
                            .col(j)
                            .try_as_col_major()
                            .expect("contiguous supernode")
                            .as_slice();
                        for (row, &lij) in
                            x[start + j + 1..start + w].iter_mut().zip(&col[j + 1..w])
                        {
                            for t in 0..W {
                                row[t] -= lij * xj[t];
                            }
                        }
                        let (below, above) = col[w..].split_at(cut);
                        for (&pi, &lij) in pattern[..cut].iter().zip(below) {
                            let row = &mut x[pi - off];
                            for t in 0..W {
                                row[t] -= lij * xj[t];
                            }
                        }
                        for (&pi, &lij) in pattern[cut..].iter().zip(above) {
                            let row = &mut top[pi - top_from];
                            for t in 0..W {
                                row[t] -= lij * xj[t];
                            }
                        }
                    }
                    for j in 0..w {
                        let inv = 1.0 / val[(j, j)];
                        for v in x[start + j].iter_mut() {
                            *v *= inv;
                        }
                    }
                }
            }
            RangeStep::Backward(top) => {
                for sn in (self.s0..self.s1).rev() {
                    let node = l.supernode(sn);
                    let val = node.val();
                    let start = node.start() - off;
                    let pattern = node.pattern();
                    let cut = pattern.partition_point(|&r| r < top_from);
                    let w = val.ncols();
                    for j in (0..w).rev() {
                        let mut acc = [0.0f64; W];
                        let col = val
                            .col(j)
                            .try_as_col_major()
                            .expect("contiguous supernode")
                            .as_slice();
                        for (row, &lij) in x[start + j + 1..start + w].iter().zip(&col[j + 1..w]) {
                            for t in 0..W {
                                acc[t] += lij * row[t];
                            }
                        }
                        let (below, above) = col[w..].split_at(cut);
                        for (&pi, &lij) in pattern[..cut].iter().zip(below) {
                            let row = &x[pi - off];
                            for t in 0..W {
                                acc[t] += lij * row[t];
                            }
                        }
                        for (&pi, &lij) in pattern[cut..].iter().zip(above) {
                            let row = &top[pi - top_from];
                            for t in 0..W {
                                acc[t] += lij * row[t];
                            }
                        }
                        let row = &mut x[start + j];
                        for t in 0..W {
                            row[t] -= acc[t];
                        }
                    }
                }
            }
        }
    }
}

impl ShiftInvert<'_> {
    /// `out ← M^{1/2} (K − σM)^{-1} M^{1/2} out` forest by forest (see [`TreeSplit`]),
    /// in groups of at most 16 interleaved columns ([`column_groups`]).
    fn solve_split(&self, split: TreeSplit, mut out: MatMut<'_, f64>) {
        use faer::sparse::linalg::cholesky::SymbolicCholeskyRaw;
        let SymbolicCholeskyRaw::Supernodal(sym) = self.symbolic.raw() else {
            unreachable!("a tree split exists only for supernodal factors");
        };
        let c = out.ncols();
        for (j0, w) in column_groups(c) {
            let cols = out.rb_mut().subcols_mut(j0, w);
            match w {
                16 => self.solve_split_fixed::<16>(sym, split, cols),
                8 => self.solve_split_fixed::<8>(sym, split, cols),
                4 => self.solve_split_fixed::<4>(sym, split, cols),
                _ => self.solve_split_fixed::<1>(sym, split, cols),
            }
        }
    }

    fn solve_split_fixed<const W: usize>(
        &self,
        sym: &Supernodal,
        split: TreeSplit,
        out: MatMut<'_, f64>,
    ) {
        use rayon::prelude::*;
        let n = out.nrows();
        let ns = sym.n_supernodes();
        let ms = self.msqrt;
        let values = &self.values[..];
        let (fwd, inv) = match self.symbolic.perm() {
            Some(p) => {
                let (f, i) = p.arrays();
                (Some(f), Some(i))
            }
            None => (None, None),
        };
        let begin = sym.supernode_begin();
        let ra = begin[split.a];
        let rb = if split.b < ns { begin[split.b] } else { n };
        // Gather into the permuted, interleaved x (row i of x = row fwd(i) of b), in
        // the kept buffer (a fresh one if another group of columns holds it).
        let mut kept = self.scratch.try_lock().ok();
        let mut own = Vec::new();
        let buf: &mut Vec<f64> = kept.as_deref_mut().unwrap_or(&mut own);
        if buf.len() < n * W {
            buf.resize(n * W, 0.0);
        }
        let flat = &mut buf[..n * W];
        // SAFETY: `[f64; W]` has the size of W `f64`s and their alignment, and `flat`
        // holds n·W of them: n rows, borrowed from `flat` for this call only.
        let x: &mut [[f64; W]] =
            unsafe { std::slice::from_raw_parts_mut(flat.as_mut_ptr().cast::<[f64; W]>(), n) };
        let src = out.as_ref();
        const ROWS: usize = 4096;
        x.par_chunks_mut(ROWS).enumerate().for_each(|(c, rows)| {
            for (q, row) in rows.iter_mut().enumerate() {
                let f = fwd.map_or(c * ROWS + q, |p| p[c * ROWS + q]);
                *row = std::array::from_fn(|j| src[(f, j)] * ms[f]);
            }
        });
        let mut top0 = vec![[0.0f64; W]; n - rb];
        let mut top1 = vec![[0.0f64; W]; n - rb];
        solve_forests(
            sym,
            values,
            split,
            (ra, rb),
            &mut x[..rb],
            [RangeStep::Forward(&mut top0), RangeStep::Forward(&mut top1)],
        );
        // The top: both forests' updates, then its own solves on one thread.
        let (low, xt) = x.split_at_mut(rb);
        for ((row, u0), u1) in xt.iter_mut().zip(&top0).zip(&top1) {
            for t in 0..W {
                row[t] = (row[t] + u0[t]) + u1[t];
            }
        }
        drop((top0, top1));
        for step in [RangeStep::Forward(&mut []), RangeStep::Backward(&[])] {
            crate::cpu::dispatch(Range {
                sym,
                values,
                s0: split.b,
                s1: ns,
                x: &mut *xt,
                off: rb,
                top_from: n,
                step,
            });
        }
        let xt: &[[f64; W]] = xt;
        solve_forests(
            sym,
            values,
            split,
            (ra, rb),
            low,
            [RangeStep::Backward(xt), RangeStep::Backward(xt)],
        );
        // Scatter back, a column per task: row r of the result is row inv(r) of x.
        let x = &*x;
        let mut cols: Vec<MatMut<'_, f64>> = Vec::with_capacity(W);
        let mut rest = out;
        for _ in 0..W {
            let (head, tail) = rest.split_at_col_mut(1);
            cols.push(head);
            rest = tail;
        }
        cols.into_par_iter().enumerate().for_each(|(j, mut col)| {
            for r in 0..n {
                let i = inv.map_or(r, |p| p[r]);
                col[(r, 0)] = x[i][j] * ms[r];
            }
        });
    }
}

/// One step over both forests of `split` in parallel: `steps[0]` over the supernodes
/// `0..a` (rows `0..ra` of `low`), `steps[1]` over `a..b` (rows `ra..rb`); `low`
/// holds rows `0..rb`, and rows from `rb` on are the top's (see [`TreeSplit`]).
fn solve_forests<const W: usize>(
    sym: &Supernodal,
    values: &[f64],
    split: TreeSplit,
    (ra, rb): (usize, usize),
    low: &mut [[f64; W]],
    steps: [RangeStep<'_, W>; 2],
) {
    let (x0, x1) = low.split_at_mut(ra);
    let [step0, step1] = steps;
    let range = |s0, s1, x, off, step| Range {
        sym,
        values,
        s0,
        s1,
        x,
        off,
        top_from: rb,
        step,
    };
    let (r0, r1) = (
        range(0, split.a, x0, 0, step0),
        range(split.a, split.b, x1, ra, step1),
    );
    rayon::join(|| crate::cpu::dispatch(r0), || crate::cpu::dispatch(r1));
}

impl BlockOperator for ShiftInvert<'_> {
    fn dim(&self) -> usize {
        self.msqrt.len()
    }
    fn apply_block(&self, x: MatRef<'_, f64>, mut out: MatMut<'_, f64>) {
        out.copy_from(x);
        let sparse_mass = self.metric.diagonal_sqrt().is_none();
        if sparse_mass {
            self.metric.mul_c(out.rb_mut());
        }
        self.solve_cols(out.rb_mut(), rayon::current_num_threads());
        if sparse_mass {
            self.metric.mul_ct(out.rb_mut());
        }
    }
}
