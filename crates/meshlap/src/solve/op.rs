//! What a solver may ask of an operator, as traits (faer's `LinOp` / `BiLinOp` shape):
//! [`LinOp`] applies `A` to an n×k row-major block, [`BiLinOp`] also applies `Aᵀ`
//! (BiCG needs it: an operator without a transpose cannot be passed to BiCG at all, a
//! compile-time fact rather than a run-time error), and [`Diagonal`] hands out the
//! diagonal for the [`Jacobi`] preconditioner.
//!
//! Implementations: [`CsrMatrix`] (`LinOp + Diagonal`), [`CsrWithTranspose`] (a matrix
//! stored with its transpose: `BiLinOp + Diagonal`), [`CsrWithSymmetrizer`] (a matrix
//! with a diagonal S making `S·A` symmetric, so `Aᵀ = S A S⁻¹` and no transpose is
//! stored: `BiLinOp + Diagonal`) and [`FnOperator`] (matrix-free, `LinOp` only). The
//! operators of [`crate::operator`] use the sign `F = D − W` (positive semi-definite);
//! the systems solved here are `M + λF`.

use super::csr::{Layout, PairedCsr, Reduce, CHUNK};
use super::krylov::{col_dots, col_norms2};
use super::{CsrMatrix, InputError, MAX_COLUMNS};
use crate::par::FoldInOrder;
use rayon::prelude::*;

/// Reductions fused into a product `y = A x`: `dot[c] = Σ_i w[i,c]·y[i,c]` and
/// `norm2[c] = Σ_i y[i,c]²`, per column c (CG's `pᵀAp`, BiCG's `p̃ᵀAp` and `‖Ap‖²`).
#[derive(Debug)]
pub struct Fused<'a> {
    /// The n×k block `w` (row-major, like `y`).
    pub w: &'a [f64],
    /// Output: k dot products.
    pub dot: &'a mut [f64],
    /// Output: k squared column norms of `y`.
    pub norm2: &'a mut [f64],
}

impl<'a> Fused<'a> {
    /// The reductions against `w`, written to `dot` and `norm2`.
    pub fn new(w: &'a [f64], dot: &'a mut [f64], norm2: &'a mut [f64]) -> Self {
        Fused { w, dot, norm2 }
    }
}

/// Per-column sums of a residual pass `r = b − A x` ([`LinOp::residual`]) over n×k
/// blocks, with row weights `d` (all 1 when none are given) and `z = diag(d)·r`:
/// `rr[c] = ‖r_c‖²`, `bb[c] = ‖b_c‖²`, `rz[c] = r_cᵀz_c` (CG's `rᵀM⁻¹r`, BiCG's first
/// ρ) and `zz[c] = ‖z_c‖²`. Entries at and beyond k are 0.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ResidualSums {
    /// `‖r_c‖²`.
    pub rr: [f64; MAX_COLUMNS],
    /// `‖b_c‖²`.
    pub bb: [f64; MAX_COLUMNS],
    /// `r_cᵀ z_c = Σ_i d_i r_ic²`.
    pub rz: [f64; MAX_COLUMNS],
    /// `‖z_c‖² = Σ_i d_i² r_ic²`.
    pub zz: [f64; MAX_COLUMNS],
}

impl ResidualSums {
    /// The sums of two row ranges.
    fn add(mut self, o: Self) -> Self {
        for c in 0..MAX_COLUMNS {
            self.rr[c] += o.rr[c];
            self.bb[c] += o.bb[c];
            self.rz[c] += o.rz[c];
            self.zz[c] += o.zz[c];
        }
        self
    }

    /// `‖b_c − A x_c‖ / ‖b_c‖` per column (the absolute residual for a zero `b_c`).
    pub fn relative(&self, k: usize) -> Vec<f64> {
        (0..k)
            .map(|c| {
                let (r, b) = (self.rr[c], self.bb[c]);
                if b > 0.0 {
                    (r / b).sqrt()
                } else {
                    r.sqrt()
                }
            })
            .collect()
    }
}

/// Completes a residual pass over a run of rows: `r` holds `A x` on entry and `b − A x`
/// on return; `z = diag(d)·r` is written when given; the run's sums. `d` has one
/// weight per row of the run.
pub(crate) fn residual_rows(
    b: &[f64],
    r: &mut [f64],
    mut z: Option<&mut [f64]>,
    d: Option<&[f64]>,
    k: usize,
) -> ResidualSums {
    super::krylov::with_columns!(k, K => {
        let mut s = ResidualSums::default();
        for row in 0..r.len() / K {
            let di = d.map_or(1.0, |d| d[row]);
            for c in 0..K {
                let j = row * K + c;
                let (bv, rv) = (b[j], b[j] - r[j]);
                r[j] = rv;
                let zv = rv * di;
                if let Some(z) = z.as_deref_mut() {
                    z[j] = zv;
                }
                s.rr[c] += rv * rv;
                s.bb[c] += bv * bv;
                s.rz[c] += rv * zv;
                s.zz[c] += zv * zv;
            }
        }
        s
    })
}

/// Runs `rows(first_row, b, r, z, d)` over chunks of [`CHUNK`] rows in parallel and
/// adds up the sums; `z` and `d` as in [`LinOp::residual`].
pub(crate) fn residual_chunks(
    b: &[f64],
    r: &mut [f64],
    z: Option<&mut [f64]>,
    d: Option<&[f64]>,
    k: usize,
    rows: impl Fn(usize, &[f64], &mut [f64], Option<&mut [f64]>, Option<&[f64]>) -> ResidualSums + Sync,
) -> ResidualSums {
    let len = CHUNK * k;
    let chunks = r.len().div_ceil(len);
    let zs: Vec<Option<&mut [f64]>> = match z {
        Some(z) => z.chunks_mut(len).map(Some).collect(),
        None => (0..chunks).map(|_| None).collect(),
    };
    r.par_chunks_mut(len)
        .zip(b.par_chunks(len))
        .zip(zs)
        .enumerate()
        .map(|(blk, ((rs, bs), zs))| {
            let first = blk * CHUNK;
            let ds = d.map(|d| &d[first..first + rs.len() / k]);
            rows(first, bs, rs, zs, ds)
        })
        .fold_in_order(ResidualSums::default(), ResidualSums::add)
}

/// Checks the arguments of [`LinOp::residual`] for an n×n operator: 1 ≤ k ≤
/// [`MAX_COLUMNS`], `b`, `x`, `r` (and `z`) of n·k values, `d` of n.
pub fn check_residual(
    n: usize,
    b: &[f64],
    x: &[f64],
    r: &[f64],
    k: usize,
    d: Option<&[f64]>,
    z: Option<&[f64]>,
) -> Result<(), InputError> {
    super::krylov::check_sizes(n, b, x, k)?;
    let blocks = [
        ("residual", Some(r.len())),
        ("scaled residual", z.map(<[f64]>::len)),
    ];
    for (what, len) in blocks {
        match len {
            Some(len) if len != n * k => {
                return Err(InputError::Block {
                    what,
                    len,
                    want: n * k,
                });
            }
            _ => {}
        }
    }
    match d {
        Some(d) if d.len() != n => Err(InputError::Block {
            what: "row weights",
            len: d.len(),
            want: n,
        }),
        _ => Ok(()),
    }
}

/// A square linear operator applied to n×k blocks stored row-major (entry (i, c) at
/// index `i·k + c`).
pub trait LinOp: Sync {
    /// n.
    fn dim(&self) -> usize;
    /// `y = A x` for the n×k blocks `x` and `y` (n·k values each).
    ///
    /// # Panics
    /// A matrix kernel may panic when `x` or `y` does not hold n·k values: it is the
    /// innermost loop of every solver, which checks the sizes once before it starts
    /// ([`check_residual`] checks them for a direct caller). k = 0 does nothing.
    fn apply(&self, x: &[f64], y: &mut [f64], k: usize);
    /// `y = A x` and the reductions of `fused`; the default makes a second pass over
    /// `y`, a matrix kernel fuses them into the product.
    fn apply_fused(&self, x: &[f64], y: &mut [f64], k: usize, fused: Fused<'_>) {
        self.apply(x, y, k);
        fused.dot[..k].copy_from_slice(&col_dots(fused.w, y, k));
        fused.norm2[..k].copy_from_slice(&col_norms2(y, k));
    }
    /// The residual `r = b − A x` of the n×k blocks and its [`ResidualSums`] (row
    /// weights `d`, n values, all 1 when `None`), writing `z = diag(d)·r` to `z` when
    /// given: everything a Krylov solver needs before its first iteration, or to
    /// report its final residuals. The default applies `A` and makes one more pass;
    /// a matrix kernel does it all in one pass over the matrix and the blocks.
    ///
    /// # Errors
    /// [`InputError`] when k is 0 or above [`MAX_COLUMNS`] (the sums hold at most
    /// that many columns), or when a block or `d` has the wrong length
    /// ([`check_residual`]); nothing is written then.
    fn residual(
        &self,
        b: &[f64],
        x: &[f64],
        r: &mut [f64],
        k: usize,
        d: Option<&[f64]>,
        z: Option<&mut [f64]>,
    ) -> Result<ResidualSums, InputError> {
        check_residual(self.dim(), b, x, r, k, d, z.as_deref())?;
        self.apply(x, r, k);
        Ok(residual_chunks(b, r, z, d, k, |_, b, r, z, d| {
            residual_rows(b, r, z, d, k)
        }))
    }
}

/// An operator that can also apply its transpose (bi-conjugate gradients need it).
pub trait BiLinOp: LinOp {
    /// `y = Aᵀ x` for the n×k blocks `x` and `y`.
    fn apply_transpose(&self, x: &[f64], y: &mut [f64], k: usize);

    /// A positive diagonal `S` (n values) with `S·A` symmetric, that is `Aᵀ = S A S⁻¹`,
    /// when the operator has one: for the Tutte system `I + λT` with `T = D⁻¹K`, S is
    /// the degree matrix D. BiCG then keeps its shadow vectors scaled by `S⁻¹` and
    /// multiplies them by A, in the same pass as p ([`Self::apply_both`]), instead of
    /// multiplying by Aᵀ. `None` (the default): BiCG uses [`Self::apply_transpose`].
    fn symmetrizer(&self) -> Option<&[f64]> {
        None
    }

    /// BiCG's two products on one n×2k block `pp` (row-major) whose row i is
    /// `[p_i | p̃_i]`: writes the rows `[(Ap)_i | (Aᵀp̃)_i]` to `qq` (n×2k),
    /// `dot[c] = p̃_cᵀ(Ap)_c` and `norm2[c] = ‖(Ap)_c‖²` for c < k (k ≤
    /// [`MAX_COLUMNS`]). With a [`Self::symmetrizer`] S the right half holds
    /// `p̂ = S⁻¹p̃` and receives `A p̂ = S⁻¹Aᵀp̃`, and `dot[c] = Σ_i s_i p̂_ic (Ap)_ic`
    /// (the same `p̃ᵀAp`). The default copies the halves into blocks of their own and
    /// back; the matrix types read the interleaved rows in place (one gather of row j
    /// brings both halves).
    fn apply_both(&self, pp: &[f64], qq: &mut [f64], k: usize, dot: &mut [f64], norm2: &mut [f64]) {
        apply_both_separately(self, pp, qq, k, dot, norm2)
    }
}

/// [`BiLinOp::apply_both`] through blocks of their own: the halves of `pp` copied
/// out, two products, the results copied into `qq`.
fn apply_both_separately(
    op: &(impl BiLinOp + ?Sized),
    pp: &[f64],
    qq: &mut [f64],
    k: usize,
    dot: &mut [f64],
    norm2: &mut [f64],
) {
    let n = op.dim();
    let half = |b: &[f64], h: usize| -> Vec<f64> {
        (0..n * k)
            .map(|j| b[(j / k) * 2 * k + h * k + j % k])
            .collect()
    };
    let (p, pt) = (half(pp, 0), half(pp, 1));
    let (mut q, mut qt) = (vec![0.0; n * k], vec![0.0; n * k]);
    match op.symmetrizer() {
        Some(s) => {
            op.apply(&p, &mut q, k);
            op.apply(&pt, &mut qt, k);
            let (d, q2) = weighted_sums(s, &pt, &q, k);
            dot[..k].copy_from_slice(&d[..k]);
            norm2[..k].copy_from_slice(&q2[..k]);
        }
        None => {
            op.apply_fused(&p, &mut q, k, Fused::new(&pt, dot, norm2));
            op.apply_transpose(&pt, &mut qt, k);
        }
    }
    for j in 0..n * k {
        let (i, c) = (j / k, j % k);
        qq[i * 2 * k + c] = q[j];
        qq[i * 2 * k + k + c] = qt[j];
    }
}

/// `(Σ_i s_i w_ic y_ic, Σ_i y_ic²)` per column of n×k blocks (k ≤ [`MAX_COLUMNS`]).
fn weighted_sums(
    s: &[f64],
    w: &[f64],
    y: &[f64],
    k: usize,
) -> ([f64; MAX_COLUMNS], [f64; MAX_COLUMNS]) {
    let mut acc = ([0.0; MAX_COLUMNS], [0.0; MAX_COLUMNS]);
    for ((yr, wr), si) in y.chunks(k).zip(w.chunks(k)).zip(s) {
        for c in 0..k {
            acc.0[c] += si * wr[c] * yr[c];
            acc.1[c] += yr[c] * yr[c];
        }
    }
    acc
}

/// The sums of two row ranges of a pair of per-column reductions.
pub(crate) fn add_pairs(
    a: ([f64; MAX_COLUMNS], [f64; MAX_COLUMNS]),
    b: ([f64; MAX_COLUMNS], [f64; MAX_COLUMNS]),
) -> ([f64; MAX_COLUMNS], [f64; MAX_COLUMNS]) {
    (
        std::array::from_fn(|c| a.0[c] + b.0[c]),
        std::array::from_fn(|c| a.1[c] + b.1[c]),
    )
}

/// An operator that knows its diagonal (for [`Jacobi`] preconditioning).
pub trait Diagonal {
    /// The n diagonal entries (0 where none is stored).
    fn diagonal(&self) -> Vec<f64>;
}

impl LinOp for CsrMatrix {
    fn dim(&self) -> usize {
        self.nrows()
    }
    fn apply(&self, x: &[f64], y: &mut [f64], k: usize) {
        self.product(x, y, k, None)
    }
    fn apply_fused(&self, x: &[f64], y: &mut [f64], k: usize, fused: Fused<'_>) {
        self.product(x, y, k, Some(fused))
    }
    fn residual(
        &self,
        b: &[f64],
        x: &[f64],
        r: &mut [f64],
        k: usize,
        d: Option<&[f64]>,
        z: Option<&mut [f64]>,
    ) -> Result<ResidualSums, InputError> {
        check_residual(self.dim(), b, x, r, k, d, z.as_deref())?;
        if self.ncols() != self.nrows() {
            return Err(InputError::Block {
                what: "operator's column count",
                len: self.ncols(),
                want: self.nrows(),
            });
        }
        Ok(self.residual_pass(b, x, r, k, d, z))
    }
}

impl Diagonal for CsrMatrix {
    fn diagonal(&self) -> Vec<f64> {
        CsrMatrix::diagonal(self)
    }
}

/// A square CSR matrix stored together with its transpose, so that both products
/// stream row by row: the [`BiLinOp`] of BiCG for a matrix without a symmetrizer.
/// The transpose is kept merged with A over the union of their patterns (row i: the
/// pairs `(a_ij, a_ji)`), so that BiCG's two products are one pass
/// ([`BiLinOp::apply_both`]).
#[derive(Clone, Debug, PartialEq)]
pub struct CsrWithTranspose {
    a: CsrMatrix,
    t: Transposed,
}

/// How [`CsrWithTranspose`] keeps `Aᵀ`.
#[derive(Clone, Debug, PartialEq)]
enum Transposed {
    /// Merged with A (a square A).
    Paired(PairedCsr),
    /// On its own (a rectangular A: no solver takes it, but the products work).
    Separate(CsrMatrix),
}

impl CsrWithTranspose {
    /// Stores `a` and its transpose (O(nnz)): for a square `a`, merged with `a` over the
    /// union of their patterns, found directly from `a` when its pattern is symmetric
    /// (every mesh operator's is) and by way of the transpose otherwise.
    pub fn new(a: CsrMatrix) -> Self {
        let t = match PairedCsr::mirrored(&a) {
            Some(paired) => Transposed::Paired(paired),
            None if a.nrows() == a.ncols() => {
                Transposed::Paired(PairedCsr::new(&a, &a.transpose()))
            }
            None => Transposed::Separate(a.transpose()),
        };
        CsrWithTranspose { a, t }
    }
    /// The matrix `A`.
    pub fn matrix(&self) -> &CsrMatrix {
        &self.a
    }
    /// The matrix, dropping the transpose.
    pub fn into_matrix(self) -> CsrMatrix {
        self.a
    }
}

/// `LinOp` of a type that stores its matrix as `self.a`: every method forwards to the
/// matrix's kernels.
macro_rules! linop_of_matrix {
    ($t:ty) => {
        impl LinOp for $t {
            fn dim(&self) -> usize {
                self.a.nrows()
            }
            fn apply(&self, x: &[f64], y: &mut [f64], k: usize) {
                self.a.product(x, y, k, None)
            }
            fn apply_fused(&self, x: &[f64], y: &mut [f64], k: usize, fused: Fused<'_>) {
                self.a.product(x, y, k, Some(fused))
            }
            fn residual(
                &self,
                b: &[f64],
                x: &[f64],
                r: &mut [f64],
                k: usize,
                d: Option<&[f64]>,
                z: Option<&mut [f64]>,
            ) -> Result<ResidualSums, InputError> {
                self.a.residual(b, x, r, k, d, z)
            }
        }
    };
}

linop_of_matrix!(CsrWithTranspose);

impl BiLinOp for CsrWithTranspose {
    fn apply_transpose(&self, x: &[f64], y: &mut [f64], k: usize) {
        match &self.t {
            Transposed::Paired(p) => p.transpose_product(x, y, k),
            Transposed::Separate(at) => at.product(x, y, k, None),
        }
    }
    /// One pass over the merged pattern: A on the left half (with the sums), Aᵀ on
    /// the right.
    fn apply_both(&self, pp: &[f64], qq: &mut [f64], k: usize, dot: &mut [f64], norm2: &mut [f64]) {
        let Transposed::Paired(paired) = &self.t else {
            return apply_both_separately(self, pp, qq, k, dot, norm2);
        };
        let whole = Layout::dense(2 * k);
        let red = Reduce {
            w: pp,
            at: Layout::half(k, 1),
            weights: None,
        };
        let (d, q) = paired.product_both(pp, whole, qq, whole, k, Some(red));
        dot[..k].copy_from_slice(&d[..k]);
        norm2[..k].copy_from_slice(&q[..k]);
    }
}

impl Diagonal for CsrWithTranspose {
    fn diagonal(&self) -> Vec<f64> {
        self.a.diagonal()
    }
}

/// A CSR matrix `A` (n×n) stored with a positive diagonal `S` such that `S·A` is
/// symmetric, so that `Aᵀ = S A S⁻¹`: the [`BiLinOp`] of BiCG for a system similar to
/// a symmetric one, such as the Tutte system `I + λT` (`T = D⁻¹K`, sign `F = D − W`,
/// S = D: `D(I + λT) = D + λK`). BiCG multiplies by A only, twice in one pass over
/// the matrix ([`BiLinOp::apply_both`]); no transpose is stored.
#[derive(Clone, Debug, PartialEq)]
pub struct CsrWithSymmetrizer {
    a: CsrMatrix,
    s: Vec<f64>,
}

impl CsrWithSymmetrizer {
    /// Relative tolerance of the check `s_i a_ij = s_j a_ji`.
    pub const TOLERANCE: f64 = 1e-8;

    /// Stores `a` with its symmetrizer `s` after checking both (O(nnz log d), d the
    /// longest row).
    ///
    /// # Errors
    /// [`InputError::Block`] when `s` does not have n values or `a` is not square;
    /// [`InputError::Symmetrizer`] for an entry of `s` that is not positive and
    /// finite; [`InputError::NotSymmetrizable`] for an entry with `s_i a_ij ≠ s_j a_ji`
    /// beyond [`Self::TOLERANCE`] (relative), or stored on one side of the diagonal
    /// only. For an operator of [`crate::operator`], [`crate::operator::symmetrize::symmetrizer`]
    /// finds s when it exists.
    pub fn new(a: CsrMatrix, s: Vec<f64>) -> Result<Self, InputError> {
        let n = a.nrows();
        if a.ncols() != n || s.len() != n {
            return Err(InputError::Block {
                what: "symmetrizer",
                len: s.len(),
                want: a.ncols().max(n),
            });
        }
        if let Some(row) = s.iter().position(|v| !(v.is_finite() && *v > 0.0)) {
            return Err(InputError::Symmetrizer { row, value: s[row] });
        }
        let bad = (0..n).into_par_iter().find_map_any(|i| {
            a.row_entries(i).find_map(|(j, v)| {
                let left = s[i] * v;
                let right = s[j] * a.entry(j, i).unwrap_or(0.0);
                ((left - right).abs() > Self::TOLERANCE * (left.abs() + right.abs()))
                    .then_some((i, j))
            })
        });
        match bad {
            Some((row, col)) => Err(InputError::NotSymmetrizable { row, col }),
            None => Ok(CsrWithSymmetrizer { a, s }),
        }
    }
    /// Stores `a` with `s` without the check of [`Self::new`], for a symmetrizer the
    /// caller has already checked against the matrix (`ImplicitSolver` takes s from
    /// [`crate::operator::symmetrize::symmetrizer`], which checks every stored entry
    /// of F; `S(I + λF)` is then symmetric too). Lengths are still checked.
    pub(crate) fn checked_by_caller(a: CsrMatrix, s: Vec<f64>) -> Result<Self, InputError> {
        if a.ncols() != a.nrows() || s.len() != a.nrows() {
            return Err(InputError::Block {
                what: "symmetrizer",
                len: s.len(),
                want: a.nrows(),
            });
        }
        Ok(CsrWithSymmetrizer { a, s })
    }
    /// The matrix `A`.
    pub fn matrix(&self) -> &CsrMatrix {
        &self.a
    }
    /// The symmetrizer `S` (n values).
    pub fn symmetrizer(&self) -> &[f64] {
        &self.s
    }
}

linop_of_matrix!(CsrWithSymmetrizer);

impl BiLinOp for CsrWithSymmetrizer {
    /// `y = S A S⁻¹ x` (two scalings around one product; BiCG does not call it).
    fn apply_transpose(&self, x: &[f64], y: &mut [f64], k: usize) {
        if k == 0 {
            return;
        }
        let s = &self.s;
        let scaled: Vec<f64> = x
            .par_iter()
            .enumerate()
            .map(|(j, v)| v / s[j / k])
            .collect();
        self.a.product(&scaled, y, k, None);
        y.par_iter_mut()
            .enumerate()
            .for_each(|(j, v)| *v *= s[j / k]);
    }
    fn symmetrizer(&self) -> Option<&[f64]> {
        Some(&self.s)
    }
    /// One pass over A for both halves (the n×2k block as 2k columns).
    fn apply_both(&self, pp: &[f64], qq: &mut [f64], k: usize, dot: &mut [f64], norm2: &mut [f64]) {
        let whole = Layout::dense(2 * k);
        let red = Reduce {
            w: pp,
            at: Layout::half(k, 1),
            weights: Some(&self.s),
        };
        let (d, q) = self.a.product_with::<2>(pp, whole, qq, whole, k, Some(red));
        dot[..k].copy_from_slice(&d[..k]);
        norm2[..k].copy_from_slice(&q[..k]);
    }
}

impl Diagonal for CsrWithSymmetrizer {
    fn diagonal(&self) -> Vec<f64> {
        self.a.diagonal()
    }
}

/// A matrix-free operator from a closure `(x, y, k)` computing `y = A x`.
pub struct FnOperator<F: Fn(&[f64], &mut [f64], usize) + Sync> {
    /// n.
    pub dim: usize,
    /// `y = A x`.
    pub apply: F,
}

impl<F: Fn(&[f64], &mut [f64], usize) + Sync> LinOp for FnOperator<F> {
    fn dim(&self) -> usize {
        self.dim
    }
    fn apply(&self, x: &[f64], y: &mut [f64], k: usize) {
        (self.apply)(x, y, k)
    }
}

/// The Jacobi preconditioner `M = diag(A)`: the solvers multiply residuals by `M⁻¹`.
///
/// Built once per matrix and kept (see [`crate::filter::ImplicitSolver`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Jacobi {
    diagonal: Vec<f64>,
    inverse: Vec<f64>,
}

impl Jacobi {
    /// The preconditioner of `op`'s diagonal.
    ///
    /// # Errors
    /// [`InputError::SingularDiagonal`] for a zero or non-finite diagonal entry, which
    /// Jacobi would divide by. (CG further needs every entry positive and reports a
    /// non-positive one as not positive definite.)
    pub fn new(op: &(impl Diagonal + ?Sized)) -> Result<Self, InputError> {
        Self::from_diagonal(op.diagonal())
    }

    /// The preconditioner of a given diagonal; errors as [`Jacobi::new`].
    pub fn from_diagonal(diagonal: Vec<f64>) -> Result<Self, InputError> {
        if let Some(row) = diagonal.iter().position(|v| *v == 0.0 || !v.is_finite()) {
            return Err(InputError::SingularDiagonal {
                row,
                value: diagonal[row],
            });
        }
        let inverse = diagonal.iter().map(|v| 1.0 / v).collect();
        Ok(Jacobi { diagonal, inverse })
    }

    /// The diagonal `M`.
    pub fn diagonal(&self) -> &[f64] {
        &self.diagonal
    }

    /// `M⁻¹`, one entry per row.
    pub fn inverse(&self) -> &[f64] {
        &self.inverse
    }

    /// Checks that the preconditioner fits an n×n operator.
    pub(crate) fn check(&self, n: usize) -> Result<(), InputError> {
        if self.inverse.len() == n {
            Ok(())
        } else {
            Err(InputError::Preconditioner {
                n,
                got: self.inverse.len(),
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lower_bidiagonal(n: usize) -> CsrMatrix {
        let mut trip = Vec::new();
        for i in 0..n {
            trip.push(faer::sparse::Triplet::new(i, i, 2.0 + i as f64));
            if i > 0 {
                trip.push(faer::sparse::Triplet::new(i, i - 1, -1.0 - 0.1 * i as f64));
            }
        }
        CsrMatrix::from_csc(&crate::SparseMatrix::try_new_from_triplets(n, n, &trip).unwrap())
    }

    #[test]
    fn residual_pass_is_the_same_at_every_column_count() {
        // Each column count compiles its own pass (`with_columns`); all of them must
        // give b − Ax and the sums of a plain computation.
        let n = 9;
        let a = lower_bidiagonal(n);
        let d: Vec<f64> = (0..n).map(|i| 0.5 + i as f64).collect();
        for k in 1..=MAX_COLUMNS {
            let x: Vec<f64> = (0..n * k).map(|i| (i as f64 * 0.3).cos()).collect();
            let b: Vec<f64> = (0..n * k).map(|i| (i as f64 * 0.7).sin()).collect();
            let (mut r, mut z, mut ax) = (vec![0.0; n * k], vec![0.0; n * k], vec![0.0; n * k]);
            let s = a
                .residual(&b, &x, &mut r, k, Some(&d), Some(&mut z))
                .unwrap();
            a.apply(&x, &mut ax, k);
            for c in 0..k {
                let (mut rr, mut bb, mut rz, mut zz) = (0.0, 0.0, 0.0, 0.0);
                for i in 0..n {
                    let j = i * k + c;
                    let rv = b[j] - ax[j];
                    assert_eq!(r[j], rv, "k = {k}");
                    assert_eq!(z[j], rv * d[i], "k = {k}");
                    rr += rv * rv;
                    bb += b[j] * b[j];
                    rz += rv * rv * d[i];
                    zz += rv * d[i] * rv * d[i];
                }
                for (got, want) in [(s.rr[c], rr), (s.bb[c], bb), (s.rz[c], rz), (s.zz[c], zz)] {
                    assert!((got - want).abs() <= 1e-14 * want.abs().max(1.0), "k = {k}");
                }
            }
        }
    }

    #[test]
    fn residual_reports_bad_sizes_instead_of_panicking() {
        let n = 5;
        let a = lower_bidiagonal(n);
        let generic = FnOperator {
            dim: n,
            apply: |x: &[f64], y: &mut [f64], k| a.apply(x, y, k),
        };
        let ops: [&dyn LinOp; 2] = [&a, &generic];
        for op in ops {
            // Column counts the sums cannot hold.
            for k in [0, MAX_COLUMNS + 1] {
                let (b, x, mut r) = (vec![1.0; n * k], vec![0.0; n * k], vec![7.0; n * k]);
                let got = op.residual(&b, &x, &mut r, k, None, None);
                assert_eq!(got, Err(InputError::Columns { k }));
                assert!(r.iter().all(|&v| v == 7.0), "nothing written");
                assert_eq!(
                    super::super::relative_residuals(op, &x, &b, k),
                    Err(InputError::Columns { k })
                );
            }
            // Blocks and weights of the wrong length.
            let k = 2;
            let (b, x) = (vec![1.0; n * k], vec![0.0; n * k]);
            let (mut r, mut short) = (vec![0.0; n * k], vec![0.0; n * k - 1]);
            let d = vec![1.0; n + 1];
            let block = |what, len, want| Err(InputError::Block { what, len, want });
            assert_eq!(
                op.residual(&b, &x, &mut short, k, None, None),
                block("residual", n * k - 1, n * k)
            );
            let mut z = vec![0.0; 3];
            assert_eq!(
                op.residual(&b, &x, &mut r, k, None, Some(&mut z)),
                block("scaled residual", 3, n * k)
            );
            assert_eq!(
                op.residual(&b, &x, &mut r, k, Some(&d), None),
                block("row weights", n + 1, n)
            );
            assert!(matches!(
                op.residual(&b[1..], &x, &mut r, k, None, None),
                Err(InputError::RightHandSide { .. })
            ));
            assert!(matches!(
                op.residual(&b, &x[1..], &mut r, k, None, None),
                Err(InputError::InitialGuess { .. })
            ));
            assert!(op.residual(&b, &x, &mut r, k, None, None).is_ok());
        }
        // A product over no columns does nothing.
        a.apply(&[], &mut [], 0);
    }

    /// A non-symmetric tridiagonal n×n matrix with a symmetrizer: `a_ij = c_ij / s_i`
    /// for a symmetric c.
    fn similar_to_symmetric(n: usize) -> (CsrMatrix, Vec<f64>) {
        let s: Vec<f64> = (0..n).map(|i| 1.0 + (i % 4) as f64).collect();
        let mut trip = Vec::new();
        for i in 0..n {
            trip.push(faer::sparse::Triplet::new(i, i, (4.0 + i as f64) / s[i]));
            if i + 1 < n {
                let c = -1.0 - 0.1 * i as f64;
                trip.push(faer::sparse::Triplet::new(i, i + 1, c / s[i]));
                trip.push(faer::sparse::Triplet::new(i + 1, i, c / s[i + 1]));
            }
        }
        let m = crate::SparseMatrix::try_new_from_triplets(n, n, &trip).unwrap();
        (CsrMatrix::from_csc(&m), s)
    }

    #[test]
    fn a_symmetrizer_is_checked() {
        let (a, s) = similar_to_symmetric(6);
        assert!(CsrWithSymmetrizer::new(a.clone(), s.clone()).is_ok());
        assert!(matches!(
            CsrWithSymmetrizer::new(a.clone(), s[1..].to_vec()),
            Err(InputError::Block { .. })
        ));
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let mut t = s.clone();
            t[2] = bad;
            assert!(matches!(
                CsrWithSymmetrizer::new(a.clone(), t),
                Err(InputError::Symmetrizer { row: 2, .. })
            ));
        }
        // Scaling one entry of s breaks the symmetry of its two off-diagonal pairs.
        let mut t = s.clone();
        t[3] *= 1.5;
        assert!(matches!(
            CsrWithSymmetrizer::new(a.clone(), t),
            Err(InputError::NotSymmetrizable { .. })
        ));
        // An entry stored on one side of the diagonal only.
        assert!(matches!(
            CsrWithSymmetrizer::new(lower_bidiagonal(6), vec![1.0; 6]),
            Err(InputError::NotSymmetrizable { .. })
        ));
    }

    /// `[a | b]` row by row: an n×2k block from two n×k blocks.
    fn interleave(a: &[f64], b: &[f64], k: usize) -> Vec<f64> {
        a.chunks(k)
            .zip(b.chunks(k))
            .flat_map(|(u, v)| u.iter().chain(v).copied())
            .collect()
    }

    /// A BiLinOp with the trait's default `apply_both` over the given operator's
    /// products.
    struct Defaults<'a, T: BiLinOp>(&'a T);
    impl<T: BiLinOp> LinOp for Defaults<'_, T> {
        fn dim(&self) -> usize {
            self.0.dim()
        }
        fn apply(&self, x: &[f64], y: &mut [f64], k: usize) {
            self.0.apply(x, y, k)
        }
    }
    impl<T: BiLinOp> BiLinOp for Defaults<'_, T> {
        fn apply_transpose(&self, x: &[f64], y: &mut [f64], k: usize) {
            self.0.apply_transpose(x, y, k)
        }
        fn symmetrizer(&self) -> Option<&[f64]> {
            self.0.symmetrizer()
        }
    }

    #[test]
    fn both_products_on_interleaved_rows_match_separate_products() {
        // More rows than one parallel chunk, every column count; the symmetrized and
        // the transposed operator, each against plain products and the trait default.
        let n = CHUNK + 77;
        let (a, s) = similar_to_symmetric(n);
        let sym = CsrWithSymmetrizer::new(a.clone(), s.clone()).unwrap();
        let trans = CsrWithTranspose::new(a.clone());
        let at = a.transpose();
        for k in 1..=MAX_COLUMNS {
            let p: Vec<f64> = (0..n * k).map(|i| (i as f64 * 0.37).sin()).collect();
            let pt: Vec<f64> = (0..n * k).map(|i| (i as f64 * 0.11).cos()).collect();
            let pp = interleave(&p, &pt, k);
            let (mut q, mut qt, mut qh) = (vec![0.0; n * k], vec![0.0; n * k], vec![0.0; n * k]);
            a.apply(&p, &mut q, k);
            at.apply(&pt, &mut qt, k);
            a.apply(&pt, &mut qh, k);
            let want_q2: Vec<f64> = (0..k)
                .map(|c| (0..n).map(|i| q[i * k + c].powi(2)).sum())
                .collect();
            let dot = |w: &dyn Fn(usize) -> f64, c: usize| -> f64 {
                (0..n).map(|i| w(i) * pt[i * k + c] * q[i * k + c]).sum()
            };
            let cases: [(&dyn BiLinOp, &Vec<f64>, Vec<f64>); 4] = [
                (&sym, &qh, (0..k).map(|c| dot(&|i| s[i], c)).collect()),
                (
                    &Defaults(&sym),
                    &qh,
                    (0..k).map(|c| dot(&|i| s[i], c)).collect(),
                ),
                (&trans, &qt, (0..k).map(|c| dot(&|_| 1.0, c)).collect()),
                (
                    &Defaults(&trans),
                    &qt,
                    (0..k).map(|c| dot(&|_| 1.0, c)).collect(),
                ),
            ];
            for (which, (op, right, want_dot)) in cases.into_iter().enumerate() {
                let mut qq = vec![0.0; 2 * n * k];
                let (mut d, mut q2) = ([0.0; MAX_COLUMNS], [0.0; MAX_COLUMNS]);
                op.apply_both(&pp, &mut qq, k, &mut d, &mut q2);
                assert_eq!(
                    qq,
                    interleave(&q, right, k),
                    "k = {k}, case {which}: same bits"
                );
                for c in 0..k {
                    let tol = 1e-12 * want_dot[c].abs().max(1.0);
                    assert!((d[c] - want_dot[c]).abs() <= tol, "k = {k}, case {which}");
                    assert!((q2[c] - want_q2[c]).abs() <= 1e-12 * want_q2[c], "k = {k}");
                }
                assert!(d[k..].iter().all(|&v| v == 0.0));
            }
        }
        // Aᵀx = S A S⁻¹ x, against the dense transpose of a small matrix.
        let (n, k) = (50, 2);
        let (a, s) = similar_to_symmetric(n);
        let op = CsrWithSymmetrizer::new(a.clone(), s).unwrap();
        let dense = a.to_csc().to_dense();
        let x: Vec<f64> = (0..n * k).map(|i| (i as f64 * 0.3).cos()).collect();
        let mut yt = vec![0.0; n * k];
        op.apply_transpose(&x, &mut yt, k);
        for i in 0..n {
            for c in 0..k {
                let want: f64 = (0..n).map(|j| dense[(j, i)] * x[j * k + c]).sum();
                assert!((yt[i * k + c] - want).abs() < 1e-12, "row {i}");
            }
        }
    }

    #[test]
    fn both_products_over_a_non_symmetric_pattern_and_a_rectangular_transpose() {
        // A lower bidiagonal A: the merged pattern holds explicit zeros for Aᵀ's
        // entries above the diagonal and A's below.
        let n = 2 * CHUNK + 5;
        let a = lower_bidiagonal(n);
        let op = CsrWithTranspose::new(a.clone());
        let at = a.transpose();
        for k in [1, 3, MAX_COLUMNS] {
            let p: Vec<f64> = (0..n * k).map(|i| (i as f64 * 0.37).sin()).collect();
            let pt: Vec<f64> = (0..n * k).map(|i| (i as f64 * 0.11).cos()).collect();
            let (mut q, mut qt) = (vec![0.0; n * k], vec![0.0; n * k]);
            a.apply(&p, &mut q, k);
            at.apply(&pt, &mut qt, k);
            let mut qq = vec![0.0; 2 * n * k];
            let (mut d, mut q2) = ([0.0; MAX_COLUMNS], [0.0; MAX_COLUMNS]);
            op.apply_both(&interleave(&p, &pt, k), &mut qq, k, &mut d, &mut q2);
            assert_eq!(qq, interleave(&q, &qt, k), "k = {k}");
            let mut y = vec![0.0; n * k];
            op.apply_transpose(&pt, &mut y, k);
            assert_eq!(y, qt);
            for c in 0..k {
                let want: f64 = (0..n).map(|i| pt[i * k + c] * q[i * k + c]).sum();
                assert!((d[c] - want).abs() <= 1e-12 * want.abs().max(1.0));
            }
        }
        // A 3×2 matrix: the transpose kept on its own.
        let trip = [
            faer::sparse::Triplet::new(0, 0, 1.0),
            faer::sparse::Triplet::new(2, 1, 2.0),
        ];
        let m = crate::SparseMatrix::try_new_from_triplets(3, 2, &trip).unwrap();
        let op = CsrWithTranspose::new(CsrMatrix::from_csc(&m));
        let mut y = vec![0.0; 2];
        op.apply_transpose(&[1.0, 5.0, 3.0], &mut y, 1);
        assert_eq!(y, [1.0, 6.0]);
    }

    #[test]
    fn transpose_capability_applies_the_transpose() {
        let a = lower_bidiagonal(7);
        let op = CsrWithTranspose::new(a.clone());
        let dense = a.to_csc().to_dense();
        let x: Vec<f64> = (0..14).map(|i| (i as f64 * 0.3).cos()).collect();
        let (mut y, mut yt) = (vec![0.0; 14], vec![0.0; 14]);
        op.apply(&x, &mut y, 2);
        op.apply_transpose(&x, &mut yt, 2);
        for i in 0..7 {
            for c in 0..2 {
                let want: f64 = (0..7).map(|j| dense[(i, j)] * x[2 * j + c]).sum();
                let want_t: f64 = (0..7).map(|j| dense[(j, i)] * x[2 * j + c]).sum();
                assert!((y[2 * i + c] - want).abs() < 1e-14);
                assert!((yt[2 * i + c] - want_t).abs() < 1e-14);
            }
        }
        assert_eq!(op.diagonal(), a.diagonal());
    }

    #[test]
    fn default_fused_reductions_match_the_matrix_kernel() {
        let a = lower_bidiagonal(9);
        let f = FnOperator {
            dim: 9,
            apply: |x: &[f64], y: &mut [f64], k| a.apply(x, y, k),
        };
        let x: Vec<f64> = (0..27).map(|i| (i as f64).sin()).collect();
        let w: Vec<f64> = (0..27).map(|i| 1.0 + i as f64).collect();
        let (mut y1, mut y2) = (vec![0.0; 27], vec![0.0; 27]);
        let (mut d1, mut d2, mut n1, mut n2) = ([0.0; 3], [0.0; 3], [0.0; 3], [0.0; 3]);
        let fused = |dot, norm2| Fused { w: &w, dot, norm2 };
        a.apply_fused(&x, &mut y1, 3, fused(&mut d1, &mut n1));
        f.apply_fused(&x, &mut y2, 3, fused(&mut d2, &mut n2));
        assert_eq!(y1, y2);
        for c in 0..3 {
            assert!((d1[c] - d2[c]).abs() < 1e-12 * d1[c].abs().max(1.0));
            assert!((n1[c] - n2[c]).abs() < 1e-12 * n1[c]);
        }
    }

    #[test]
    fn the_fused_residual_pass_matches_separate_passes() {
        // More rows than one parallel chunk, so that chunks and their sums are joined.
        let (n, k) = (2 * CHUNK + 123, 3);
        let a = lower_bidiagonal(n);
        let generic = FnOperator {
            dim: n,
            apply: |x: &[f64], y: &mut [f64], k| a.apply(x, y, k),
        };
        let x: Vec<f64> = (0..n * k).map(|i| (i as f64 * 0.7).sin()).collect();
        let b: Vec<f64> = (0..n * k).map(|i| (i as f64 * 0.3).cos() * 5.0).collect();
        let d: Vec<f64> = (0..n).map(|i| 0.5 + (i % 5) as f64).collect();
        let mut ax = vec![0.0; n * k];
        a.apply(&x, &mut ax, k);
        let close = |u: f64, v: f64| (u - v).abs() <= 1e-12 * u.abs().max(v.abs());
        for weights in [None, Some(&d[..])] {
            let (mut r1, mut z1) = (vec![0.0; n * k], vec![0.0; n * k]);
            let (mut r2, mut z2) = (vec![0.0; n * k], vec![0.0; n * k]);
            let s1 = a
                .residual(&b, &x, &mut r1, k, weights, Some(&mut z1))
                .unwrap();
            let s2 = generic
                .residual(&b, &x, &mut r2, k, weights, Some(&mut z2))
                .unwrap();
            assert_eq!((&r1, &z1), (&r2, &z2), "same entries, bit for bit");
            let mut r3 = vec![0.0; n * k];
            let s3 = a.residual(&b, &x, &mut r3, k, weights, None).unwrap();
            assert_eq!(r3, r1);
            for j in 0..n * k {
                assert_eq!(r1[j], b[j] - ax[j]);
                assert_eq!(z1[j], r1[j] * weights.map_or(1.0, |d| d[j / k]));
            }
            let rr = col_norms2(&r1, k);
            let bb = col_norms2(&b, k);
            let rz = col_dots(&r1, &z1, k);
            let zz = col_norms2(&z1, k);
            for s in [s1, s2, s3] {
                for c in 0..k {
                    assert!(close(s.rr[c], rr[c]) && close(s.bb[c], bb[c]));
                    assert!(close(s.rz[c], rz[c]) && close(s.zz[c], zz[c]));
                }
                assert!(s.rr[k..].iter().all(|&v| v == 0.0));
            }
            let rel = s1.relative(k);
            for c in 0..k {
                assert!(close(rel[c], (rr[c] / bb[c]).sqrt()));
            }
        }
        // A zero right-hand side column reports the absolute residual.
        let mut s = ResidualSums::default();
        s.rr[0] = 4.0;
        assert_eq!(s.relative(1), vec![2.0]);
    }

    #[test]
    fn jacobi_refuses_a_zero_diagonal() {
        assert!(matches!(
            Jacobi::from_diagonal(vec![1.0, 0.0, 2.0]),
            Err(InputError::SingularDiagonal { row: 1, .. })
        ));
        assert!(Jacobi::from_diagonal(vec![1.0, f64::NAN]).is_err());
        let j = Jacobi::new(&lower_bidiagonal(3)).unwrap();
        assert_eq!(j.inverse(), &[0.5, 1.0 / 3.0, 0.25]);
        assert!(j.check(4).is_err() && j.check(3).is_ok());
    }
}
