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
/// spin-waits). A simplicial factorization (tiny matrices) falls back to faer.
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
        let mut j0 = 0;
        while j0 < c {
            let left = c - j0;
            let w = if left >= 8 {
                8
            } else if left >= 4 {
                4
            } else {
                1
            };
            let cols = out.rb_mut().subcols_mut(j0, w);
            match w {
                8 => self.solve_dispatch::<8>(sym, cols),
                4 => self.solve_dispatch::<4>(sym, cols),
                _ => self.solve_dispatch::<1>(sym, cols),
            }
            j0 += w;
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
        use faer::sparse::linalg::cholesky::supernodal::SupernodalLdltRef;
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
        let l = SupernodalLdltRef::new(sym, &self.values);
        let nsup = sym.n_supernodes();
        // Forward: L y = b, L unit lower, column-oriented scatter.
        for sn in 0..nsup {
            let node = l.supernode(sn);
            let val = node.val();
            let start = node.start();
            let pattern = node.pattern();
            let w = val.ncols();
            for j in 0..w {
                let xj = x[start + j];
                let col = val
                    .col(j)
                    .try_as_col_major()
                    .expect("contiguous supernode")
                    .as_slice();
                for (row, &lij) in x[start + j + 1..start + w].iter_mut().zip(&col[j + 1..w]) {
                    for t in 0..W {
                        row[t] -= lij * xj[t];
                    }
                }
                for (&pi, &lij) in pattern.iter().zip(&col[w..]) {
                    debug_assert!(pi < n);
                    // SAFETY: supernode patterns hold row indices below n (faer's
                    // symbolic factorization of an n×n matrix).
                    let row = unsafe { x.get_unchecked_mut(pi) };
                    for t in 0..W {
                        row[t] -= lij * xj[t];
                    }
                }
            }
        }
        // Diagonal: z = D⁻¹ y.
        for sn in 0..nsup {
            let node = l.supernode(sn);
            let val = node.val();
            let start = node.start();
            for j in 0..val.ncols() {
                let inv = 1.0 / val[(j, j)];
                for v in x[start + j].iter_mut() {
                    *v *= inv;
                }
            }
        }
        // Backward: Lᵀ x = z, column-oriented gather (dot products).
        for sn in (0..nsup).rev() {
            let node = l.supernode(sn);
            let val = node.val();
            let start = node.start();
            let pattern = node.pattern();
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
                for (&pi, &lij) in pattern.iter().zip(&col[w..]) {
                    debug_assert!(pi < n);
                    // SAFETY: as in the forward pass.
                    let row = unsafe { x.get_unchecked(pi) };
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
        // Scatter back: row fwd(i) of the result is row i of x.
        for (i, row) in x.iter().enumerate() {
            let f = fwd(i);
            for (j, &v) in row.iter().enumerate() {
                out[(f, j)] = v * ms[f];
            }
        }
    }
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
