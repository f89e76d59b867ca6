//! The pieces every blocked Krylov solver of this module shares: argument checks, the
//! initial residual, per-column reductions, the stopping test and the [`Workspace`]
//! that keeps the n×k buffers between solves.
//!
//! Blocks are n×k row-major (entry (i, c) at `i·k + c`); parallel passes run over
//! chunks of [`CHUNK`] rows and reduce up to [`MAX_COLUMNS`] columns at once.

use super::csr::CHUNK;
use super::{Info, InputError, LinOp, Params, ResidualSums, Stopping, MAX_COLUMNS};
use crate::par::FoldInOrder;
use rayon::prelude::*;
use std::time::Instant;

/// Values of `f64` in a 4 KiB page.
const PAGE: usize = 512;

/// Buffers of the iterative solvers, kept between solves so that a repeated solve
/// (a stateful solver such as [`crate::filter::ImplicitSolver`]) allocates nothing.
///
/// A solver takes the blocks it needs from the workspace; their contents on entry are
/// unspecified (each solver initializes what it reads).
#[derive(Clone, Debug, Default)]
pub struct Workspace {
    data: Vec<f64>,
}

impl Workspace {
    /// An empty workspace; it grows on first use.
    pub fn new() -> Self {
        Self::default()
    }

    /// Values held (for memory accounting).
    pub fn len(&self) -> usize {
        self.data.len()
    }

    /// True before the first solve.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// `M` disjoint blocks of `len` values. A fresh allocation is zeroed lazily by the
    /// allocator, so the solver's first parallel pass touches its pages; a large one
    /// is advised to use transparent huge pages ([`crate::mem::zeroed_vec`]: 512 times
    /// fewer page faults on that first touch, and fewer TLB misses after).
    ///
    /// Blocks start a whole number of 4 KiB pages apart, as separate large allocations
    /// do: entries of two blocks share their page offset only at the same index, so a
    /// load in a fused pass never matches the page offset of a store just issued to a
    /// nearby index of another block (4K aliasing, which the CPU treats as a possible
    /// dependency and waits on).
    pub(crate) fn blocks<const M: usize>(&mut self, len: usize) -> [&mut [f64]; M] {
        if len == 0 {
            return std::array::from_fn(|_| <&mut [f64]>::default());
        }
        let stride = len.next_multiple_of(PAGE);
        let need = M * stride;
        if self.data.len() < need {
            self.data = Vec::new(); // the old buffer goes before the new one comes
            self.data = crate::mem::zeroed_vec(0.0, need);
        }
        let mut chunks = self.data[..need].chunks_exact_mut(stride);
        std::array::from_fn(|_| chunks.next().map_or(&mut [][..], |c| &mut c[..len]))
    }
}

/// Checks the arguments shared by every iterative solver: the n×k right-hand side
/// and initial guess, the column count and the parameters.
pub(crate) fn check(
    op: &(impl LinOp + ?Sized),
    b: &[f64],
    x: &[f64],
    k: usize,
    params: &Params,
) -> Result<(), InputError> {
    check_sizes(op.dim(), b, x, k)?;
    params.validate()
}

/// Checks that `b` and `x` are n×k blocks with 1 ≤ k ≤ [`MAX_COLUMNS`].
pub(crate) fn check_sizes(n: usize, b: &[f64], x: &[f64], k: usize) -> Result<(), InputError> {
    if k == 0 || k > MAX_COLUMNS {
        return Err(InputError::Columns { k });
    }
    if b.len() != n * k {
        return Err(InputError::RightHandSide { n, k, len: b.len() });
    }
    if x.len() != b.len() {
        return Err(InputError::InitialGuess {
            len: x.len(),
            want: b.len(),
        });
    }
    Ok(())
}

/// Completes `info` at the end of a solve: the residuals of `x` recomputed from
/// scratch (`‖b_c − A x_c‖/‖b_c‖`, one fused pass into `scratch`, an n×k work block
/// the solver no longer needs) and the seconds since `start`.
pub(crate) fn finish(
    info: &mut Info,
    op: &(impl LinOp + ?Sized),
    x: &[f64],
    b: &[f64],
    k: usize,
    start: Instant,
    scratch: &mut [f64],
) -> Result<(), InputError> {
    info.residuals = op.residual(b, x, scratch, k, None, None)?.relative(k);
    info.seconds = start.elapsed().as_secs_f64();
    Ok(())
}

/// `‖b_c‖` per column from the sums of a residual pass, at least the smallest
/// positive float (relative residuals of a zero column are absolute ones).
pub(crate) fn norms_of_b(sums: &ResidualSums, k: usize) -> Vec<f64> {
    sums.bb[..k]
        .iter()
        .map(|v| v.sqrt().max(f64::MIN_POSITIVE))
        .collect()
}

/// `dst = src`, in parallel (the first touch of fresh workspace pages is spread over
/// the threads, like the passes that follow).
pub(crate) fn copy(dst: &mut [f64], src: &[f64]) {
    dst.par_chunks_mut(CHUNK)
        .zip(src.par_chunks(CHUNK))
        .for_each(|(d, s)| d.copy_from_slice(s));
}

/// `x = 0`, in parallel (see [`copy`]).
pub(crate) fn zero(x: &mut [f64]) {
    x.par_chunks_mut(CHUNK).for_each(|c| c.fill(0.0));
}

/// Relative size below which a quantity a Krylov recurrence divides by counts as
/// vanished.
const BREAKDOWN: f64 = 1e-15;

/// Whether `v`, a quantity a recurrence divides by, vanished relative to `scale` (the
/// product of the norms of its factors).
pub(crate) fn vanished(v: f64, scale: f64) -> bool {
    v == 0.0 || v.abs() <= BREAKDOWN * scale
}

/// One entry of the update `x ← x + dx`, accumulating what the weak criteria read:
/// the old `x²` into its column's sum `xx` and its vertex's sum `x2`, and `dx²` into
/// its vertex's sum `dx2`.
#[inline(always)]
pub(crate) fn advance(x: &mut f64, dx: f64, xx: &mut f64, x2: &mut f64, dx2: &mut f64) {
    let xo = *x;
    *xx += xo * xo;
    *x2 += xo * xo;
    *dx2 += dx * dx;
    *x = xo + dx;
}

/// Evaluates `$body` with `$K` a constant equal to `$k` (1 ..= [`MAX_COLUMNS`]; any
/// other count is a run-time value): the passes over n×k blocks are written once,
/// with their column loops `0..K`, and compiled once per column count. With K known,
/// each column loop is unrolled and the per-column sums of a pass stay in registers;
/// with k read at run time they live in memory, and every entry's additions wait on a
/// store and a load of the same sum (measured in BENCHMARKS.md, "Implicit fairing
/// solvers and the paper's Table 1"). The arithmetic, and so the result, is the same
/// either way.
macro_rules! with_columns {
    ($k:expr, $K:ident => $body:expr) => {
        $crate::solve::krylov::with_columns!(@arms $k, $K, $body, [1 2 3 4 5 6 7 8])
    };
    (@arms $k:expr, $K:ident, $body:expr, [$($n:literal)*]) => {
        match $k {
            $($n => {
                const $K: usize = $n;
                $body
            })*
            k => {
                // Other counts (the solvers never pass them; a caller of
                // `LinOp::residual` may): the same body with k read at run time.
                #[allow(non_snake_case)]
                let $K: usize = k;
                $body
            }
        }
    };
}
// The arms above list 1 ..= MAX_COLUMNS.
const _: () = assert!(MAX_COLUMNS == 8);
pub(crate) use with_columns;

/// Which of the (at most [`MAX_COLUMNS`]) columns are still iterating.
pub(crate) type Active = [bool; MAX_COLUMNS];

/// The first `k` columns active.
pub(crate) fn all_active(k: usize) -> Active {
    std::array::from_fn(|c| c < k)
}

/// The columns active in `active` (a copy: the loop body may retire its column).
pub(crate) fn live(active: Active) -> impl Iterator<Item = usize> {
    (0..MAX_COLUMNS).filter(move |&c| active[c])
}

/// Per-column sums of one parallel pass: `N` quantities per column, and the number of
/// vertices whose update is not yet below ε (the weak-vertex criterion).
#[derive(Clone, Copy)]
pub(crate) struct Sums<const N: usize> {
    pub v: [[f64; MAX_COLUMNS]; N],
    pub moving: usize,
}

impl<const N: usize> Default for Sums<N> {
    fn default() -> Self {
        Sums {
            v: [[0.0; MAX_COLUMNS]; N],
            moving: 0,
        }
    }
}

impl<const N: usize> Sums<N> {
    /// The sums of two chunks.
    pub fn add(mut self, o: Self) -> Self {
        for q in 0..N {
            for c in 0..MAX_COLUMNS {
                self.v[q][c] += o.v[q][c];
            }
        }
        self.moving += o.moving;
        self
    }
}

/// The stopping test of [`Stopping`], per column, with ε from [`Params`].
pub(crate) struct Criterion {
    stopping: Stopping,
    eps: f64,
    eps2: f64,
}

impl Criterion {
    pub fn new(params: &Params) -> Self {
        Criterion {
            stopping: params.stopping,
            eps: params.tolerance,
            eps2: params.tolerance * params.tolerance,
        }
    }

    /// 1 when the weak-vertex criterion is in use and a vertex whose update has
    /// squared length `dx2`, from a position of squared length `x2`, is still moving;
    /// else 0 (the count is only read by that criterion).
    pub fn moving(&self, dx2: f64, x2: f64) -> usize {
        usize::from(self.stopping == Stopping::WeakVertex && dx2 >= self.eps2 * x2 && dx2 > 0.0)
    }

    /// Whether a column has converged: `step2` = ‖x⁽ⁿ⁾ − x⁽ⁿ⁻¹⁾‖², `xx` = ‖x⁽ⁿ⁻¹⁾‖²,
    /// `moving` the vertex count of the pass, `rr` = ‖r⁽ⁿ⁾‖², `bnorm` = ‖b‖.
    pub fn done(&self, step2: f64, xx: f64, moving: usize, rr: f64, bnorm: f64) -> bool {
        match self.stopping {
            Stopping::Weak => step2 < self.eps2 * xx,
            Stopping::WeakVertex => moving == 0,
            Stopping::Strong => rr.sqrt() < self.eps * bnorm,
        }
    }
}

/// Sums of a reduction over row chunks of one or two blocks, per column.
fn reduce_columns(
    x: &[f64],
    y: Option<&[f64]>,
    k: usize,
    f: impl Fn(f64, f64) -> f64 + Sync,
) -> Vec<f64> {
    let len = CHUNK * k;
    let parts = x
        .par_chunks(len)
        .enumerate()
        .map(|(blk, a)| {
            let b = y.map(|y| &y[blk * len..blk * len + a.len()]);
            let mut acc = [0.0; MAX_COLUMNS];
            for (i, row) in a.chunks_exact(k).enumerate() {
                for c in 0..k {
                    acc[c] += f(row[c], b.map_or(row[c], |b| b[i * k + c]));
                }
            }
            acc
        })
        .fold_in_order([0.0; MAX_COLUMNS], |a, b| {
            std::array::from_fn(|c| a[c] + b[c])
        });
    parts[..k].to_vec()
}

/// Per-column squared norms of an n×k block.
pub(crate) fn col_norms2(x: &[f64], k: usize) -> Vec<f64> {
    reduce_columns(x, None, k, |a, _| a * a)
}

/// Per-column dot products of two n×k blocks.
pub(crate) fn col_dots(x: &[f64], y: &[f64], k: usize) -> Vec<f64> {
    reduce_columns(x, Some(y), k, |a, b| a * b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn workspace_blocks_are_disjoint_and_reused() {
        let mut ws = Workspace::new();
        assert!(ws.is_empty());
        let [a, b, c] = ws.blocks::<3>(4);
        a.fill(1.0);
        b.fill(2.0);
        c.fill(3.0);
        assert_eq!(ws.len(), 3 * PAGE);
        let [a, b] = ws.blocks::<2>(5);
        assert_eq!((a.len(), b.len()), (5, 5));
        assert_eq!(a[..4], [1.0; 4]);
        assert_eq!(ws.len(), 3 * PAGE, "a smaller request reuses the buffer");
        // Blocks start whole pages apart.
        let [a, b] = ws.blocks::<2>(700);
        let gap = b.as_ptr() as usize - a.as_ptr() as usize;
        assert_eq!(gap % 4096, 0);
        let [e] = ws.blocks::<1>(0);
        assert!(e.is_empty());
    }

    #[test]
    fn column_reductions() {
        let x: Vec<f64> = (0..3 * 5000).map(|i| (i % 7) as f64).collect();
        let y: Vec<f64> = (0..3 * 5000).map(|i| (i % 3) as f64 - 1.0).collect();
        let n2 = col_norms2(&x, 3);
        let d = col_dots(&x, &y, 3);
        for c in 0..3 {
            let want: f64 = (0..5000).map(|i| x[3 * i + c] * x[3 * i + c]).sum();
            let want_d: f64 = (0..5000).map(|i| x[3 * i + c] * y[3 * i + c]).sum();
            assert_eq!(n2[c], want);
            assert_eq!(d[c], want_d);
        }
    }
}
