//! The mass matrix `M` of `K v = λ M v` and a factor `C` with `M = C Cᵀ`, through which
//! the generalized problem becomes the symmetric `C⁻¹ K C⁻ᵀ w = λ w`, `w = Cᵀ v`.
//!
//! - identity or a positive diagonal (lumped mass, diagonal symmetrizer):
//!   `C = diag(√m)`;
//! - a sparse symmetric positive definite `M` (a consistent finite-element mass
//!   matrix, say): `C = Pᵀ L` from faer's simplicial sparse Cholesky `P M Pᵀ = L Lᵀ`
//!   (AMD ordering). Simplicial, because the products with `L` and `Lᵀ` and the
//!   triangular solves below read its columns directly.

use super::check_mass;
use crate::spectral::SpectralError;
use crate::SparseMatrix;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{LltError, LltRegularization};
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholeskyRaw, SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::{MatMut, MatRef, Side};

/// The mass matrix `M` of the generalized problem `K v = λ M v`.
#[derive(Clone, Copy, Debug)]
pub enum Mass<'a> {
    /// `M = I`: the ordinary problem `K v = λ v`.
    Identity,
    /// `M = diag(m)`, every entry positive and finite (n entries).
    Lumped(&'a [f64]),
    /// A sparse symmetric positive definite n×n `M` (both triangles stored; the lower
    /// one is read), e.g. a consistent finite-element mass matrix.
    Sparse(&'a SparseMatrix),
}

impl<'a> From<Option<&'a [f64]>> for Mass<'a> {
    fn from(m: Option<&'a [f64]>) -> Self {
        m.map_or(Mass::Identity, Mass::Lumped)
    }
}

/// `M` with its factor `C` (`M = C Cᵀ`).
pub(crate) enum Metric {
    /// `M = diag(m)`, `C = diag(√m)`.
    Diagonal {
        /// `m`.
        m: Vec<f64>,
        /// `√m`.
        sqrt: Vec<f64>,
    },
    /// Sparse `M = Pᵀ L Lᵀ P`, `C = Pᵀ L`.
    Factor(SparseFactor),
}

/// A sparse `M = Pᵀ L Lᵀ P` and its Cholesky factor (`(P x)_i = x_{fwd[i]}`).
pub(crate) struct SparseFactor {
    /// `M` (both triangles).
    m: SparseMatrix,
    /// Column pointers of `L` (lower, n×n).
    col_ptr: Vec<usize>,
    /// Row indices of `L`.
    row_idx: Vec<usize>,
    /// Values of `L`.
    val: Vec<f64>,
    /// Position of each column's diagonal in `val`.
    diag: Vec<usize>,
    /// The fill-reducing permutation.
    fwd: Vec<usize>,
}

impl Metric {
    /// Checks `mass` against n and factors it.
    pub(super) fn new(mass: Mass<'_>, n: usize) -> Result<Self, SpectralError> {
        match mass {
            Mass::Identity => Ok(Self::diagonal(vec![1.0; n])),
            Mass::Lumped(m) => {
                check_mass(m, n)?;
                Ok(Self::diagonal(m.to_vec()))
            }
            Mass::Sparse(m) => Self::factor(m, n),
        }
    }

    fn diagonal(m: Vec<f64>) -> Self {
        let sqrt = m.iter().map(|x| x.sqrt()).collect();
        Self::Diagonal { m, sqrt }
    }

    fn factor(m: &SparseMatrix, n: usize) -> Result<Self, SpectralError> {
        if m.nrows() != n || m.ncols() != n {
            return Err(SpectralError::ShapeMismatch {
                what: "mass matrix rows and columns",
                expected: n,
                got: if m.nrows() != n { m.nrows() } else { m.ncols() },
            });
        }
        if let Some(index) = m.val().iter().position(|v| !v.is_finite()) {
            return Err(SpectralError::NonFinite { index });
        }
        check_symmetric("M", m)?;
        // A diagonal M (stored sparse) takes the cheap path.
        let mut d = vec![0.0; n];
        let mut off = false;
        for j in 0..n {
            for (&i, &v) in m.row_idx_of_col_raw(j).iter().zip(m.val_of_col(j)) {
                if i == j {
                    d[j] += v;
                } else if v != 0.0 {
                    off = true;
                }
            }
        }
        if !off {
            check_mass(&d, n)?;
            return Ok(Self::diagonal(d));
        }
        let symbolic = factorize_symbolic_cholesky(
            m.symbolic(),
            Side::Lower,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams {
                supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SIMPLICIAL,
                ..Default::default()
            },
        )
        .map_err(SpectralError::SymbolicFactorization)?;
        let mut val = vec![0.0f64; symbolic.len_val()];
        let par = faer::Par::Seq;
        let req = symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default());
        let mut buf = MemBuffer::new(req);
        symbolic
            .factorize_numeric_llt(
                &mut val,
                m.as_ref(),
                Side::Lower,
                LltRegularization::default(),
                par,
                MemStack::new(&mut buf),
                Default::default(),
            )
            .map_err(|source| SpectralError::MassNotPositiveDefinite { source })?;
        let SymbolicCholeskyRaw::Simplicial(s) = symbolic.raw() else {
            unreachable!("the simplicial factorization was forced")
        };
        let col_ptr = s.col_ptr().to_vec();
        let row_idx = s.row_idx().to_vec();
        let mut diag = Vec::with_capacity(n);
        for j in 0..n {
            let p = (col_ptr[j]..col_ptr[j + 1]).find(|&p| row_idx[p] == j);
            match p {
                Some(p) if val[p].is_finite() && val[p] > 0.0 => diag.push(p),
                _ => {
                    return Err(SpectralError::MassNotPositiveDefinite {
                        source: LltError::NonPositivePivot { index: j },
                    })
                }
            }
        }
        let fwd = match symbolic.perm() {
            Some(p) => p.arrays().0.to_vec(),
            None => (0..n).collect(),
        };
        Ok(Self::Factor(SparseFactor {
            m: m.clone(),
            col_ptr,
            row_idx,
            val,
            diag,
            fwd,
        }))
    }

    /// n.
    pub(super) fn dim(&self) -> usize {
        match self {
            Self::Diagonal { m, .. } => m.len(),
            Self::Factor(f) => f.fwd.len(),
        }
    }

    /// `M_jj`.
    pub(super) fn diag(&self, j: usize) -> f64 {
        match self {
            Self::Diagonal { m, .. } => m[j],
            Self::Factor(f) => {
                f.m.row_idx_of_col_raw(j)
                    .iter()
                    .zip(f.m.val_of_col(j))
                    .filter(|(&i, _)| i == j)
                    .map(|(_, &v)| v)
                    .sum()
            }
        }
    }

    /// The entries `(i, j, M_ij)` of `M` (the diagonal only for a diagonal `M`).
    pub(super) fn entries(&self) -> Vec<(usize, usize, f64)> {
        match self {
            Self::Diagonal { m, .. } => m.iter().enumerate().map(|(j, &v)| (j, j, v)).collect(),
            Self::Factor(f) => (0..f.m.ncols())
                .flat_map(|j| {
                    f.m.row_idx_of_col_raw(j)
                        .iter()
                        .zip(f.m.val_of_col(j))
                        .map(move |(&i, &v)| (i, j, v))
                })
                .collect(),
        }
    }

    /// `√m` for a diagonal `M`; `None` for a sparse one.
    pub(super) fn diagonal_sqrt(&self) -> Option<&[f64]> {
        match self {
            Self::Diagonal { sqrt, .. } => Some(sqrt),
            Self::Factor(_) => None,
        }
    }

    /// `x ← C x` (each column).
    pub(super) fn mul_c(&self, x: MatMut<'_, f64>) {
        self.each_col(
            x,
            |r| r,
            |f, col, tmp| {
                // tmp = L col; col = Pᵀ tmp.
                tmp.iter_mut().for_each(|t| *t = 0.0);
                for (j, &xj) in col.iter().enumerate() {
                    for p in f.col_ptr[j]..f.col_ptr[j + 1] {
                        tmp[f.row_idx[p]] += f.val[p] * xj;
                    }
                }
                f.unpermute(tmp, col);
            },
        );
    }

    /// `x ← Cᵀ x` (each column).
    pub(super) fn mul_ct(&self, x: MatMut<'_, f64>) {
        self.each_col(
            x,
            |r| r,
            |f, col, tmp| {
                // tmp = P col; col = Lᵀ tmp.
                f.permute(col, tmp);
                for (j, c) in col.iter_mut().enumerate() {
                    *c = (f.col_ptr[j]..f.col_ptr[j + 1])
                        .map(|p| f.val[p] * tmp[f.row_idx[p]])
                        .sum();
                }
            },
        );
    }

    /// `x ← C⁻¹ x` (each column).
    pub(super) fn solve_c(&self, x: MatMut<'_, f64>) {
        self.each_col(
            x,
            |r| 1.0 / r,
            |f, col, tmp| {
                // tmp = P col; L y = tmp (forward, by columns).
                f.permute(col, tmp);
                for j in 0..tmp.len() {
                    let yj = tmp[j] / f.val[f.diag[j]];
                    tmp[j] = yj;
                    for p in f.col_ptr[j]..f.col_ptr[j + 1] {
                        if p != f.diag[j] {
                            tmp[f.row_idx[p]] -= f.val[p] * yj;
                        }
                    }
                }
                col.copy_from_slice(tmp);
            },
        );
    }

    /// `x ← C⁻ᵀ x` (each column).
    pub(super) fn solve_ct(&self, x: MatMut<'_, f64>) {
        self.each_col(
            x,
            |r| 1.0 / r,
            |f, col, tmp| {
                // Lᵀ y = col (backward, dot products down the columns); col = Pᵀ y.
                tmp.copy_from_slice(col);
                for j in (0..tmp.len()).rev() {
                    let mut acc = tmp[j];
                    for p in f.col_ptr[j]..f.col_ptr[j + 1] {
                        if p != f.diag[j] {
                            acc -= f.val[p] * tmp[f.row_idx[p]];
                        }
                    }
                    tmp[j] = acc / f.val[f.diag[j]];
                }
                f.unpermute(tmp, col);
            },
        );
    }

    /// `M x` for one vector.
    pub(super) fn mul_m(&self, x: &[f64]) -> Vec<f64> {
        match self {
            Self::Diagonal { m, .. } => m.iter().zip(x).map(|(a, b)| a * b).collect(),
            Self::Factor(f) => symmetric_mul(&f.m, x),
        }
    }

    /// Runs `f` on each column of `x` (contiguous copies, in parallel) for a sparse
    /// `M`; for a diagonal one multiplies row i by `scale(√m_i)` instead.
    fn each_col(
        &self,
        mut x: MatMut<'_, f64>,
        scale: impl Fn(f64) -> f64,
        f: impl Fn(&SparseFactor, &mut [f64], &mut [f64]) + Sync,
    ) {
        use rayon::prelude::*;
        let n = x.nrows();
        let factor = match self {
            Self::Diagonal { sqrt, .. } => {
                let s: Vec<f64> = sqrt.iter().map(|&r| scale(r)).collect();
                for j in 0..x.ncols() {
                    for (v, &si) in x.as_mut().col_mut(j).iter_mut().zip(&s) {
                        *v *= si;
                    }
                }
                return;
            }
            Self::Factor(factor) => factor,
        };
        let mut cols: Vec<Vec<f64>> = (0..x.ncols())
            .map(|j| x.rb().col(j).iter().copied().collect())
            .collect();
        cols.par_iter_mut().for_each(|c| {
            let mut tmp = vec![0.0; n];
            f(factor, c, &mut tmp);
        });
        for (j, c) in cols.iter().enumerate() {
            for i in 0..n {
                x[(i, j)] = c[i];
            }
        }
    }
}

use faer::reborrow::Reborrow;

impl SparseFactor {
    /// `out = P x`.
    fn permute(&self, x: &[f64], out: &mut [f64]) {
        for (o, &f) in out.iter_mut().zip(&self.fwd) {
            *o = x[f];
        }
    }

    /// `out = Pᵀ y`.
    fn unpermute(&self, y: &[f64], out: &mut [f64]) {
        for (&yi, &f) in y.iter().zip(&self.fwd) {
            out[f] = yi;
        }
    }
}

/// `K x` for a symmetric `K` stored by columns (row i of `K x` gathers column i).
pub(super) fn symmetric_mul(k: &SparseMatrix, x: &[f64]) -> Vec<f64> {
    (0..k.ncols())
        .map(|i| {
            k.row_idx_of_col_raw(i)
                .iter()
                .zip(k.val_of_col(i))
                .map(|(&r, &a)| a * x[r])
                .sum()
        })
        .collect()
}

/// `Y = K X` (n×b) for a symmetric `K` (n×n) stored by columns: row i of `Y` gathers
/// column i of `K`, so this is `Kᵀ X`, which equals `K X` up to the rounding
/// asymmetry [`check_symmetric`] allows.
///
/// The rows go in fixed blocks over the rayon threads, and each block takes the
/// columns of `X` eight at a time: every entry of `K` is read once per eight columns.
/// faer's `sparse_dense_matmul` walks the whole of `K` once per column of `X`, which
/// for a band's refinement (b = 200) on a million-vertex mesh streams `K` (112 MB)
/// 200 times. Each entry of `Y` is summed over column i of `K` in its stored order,
/// whatever the thread count.
///
/// # Panics
/// If the shapes disagree or a column of `X` is not contiguous (a caller's bug: the
/// refinement passes columns of its own column-major work matrix).
pub(super) fn symmetric_mul_block(k: &SparseMatrix, x: MatRef<'_, f64>, y: MatMut<'_, f64>) {
    use rayon::prelude::*;
    const ROWS: usize = 2048;
    let (n, b) = (x.nrows(), x.ncols());
    assert!(
        k.nrows() == n && k.ncols() == n && y.nrows() == n && y.ncols() == b,
        "symmetric_mul_block: shapes differ"
    );
    let cols: Vec<&[f64]> = (0..b)
        .map(|j| {
            x.col(j)
                .try_as_col_major()
                .expect("symmetric_mul_block: X has unit row stride")
                .as_slice()
        })
        .collect();
    y.par_row_chunks_mut(ROWS)
        .enumerate()
        .for_each(|(blk, mut out)| {
            let i0 = blk * ROWS;
            let mut j0 = 0;
            while j0 < b {
                let w = (b - j0).min(8);
                let xs = &cols[j0..j0 + w];
                for q in 0..out.nrows() {
                    let i = i0 + q;
                    let mut acc = [0.0f64; 8];
                    let entries = k.row_idx_of_col_raw(i).iter().zip(k.val_of_col(i));
                    if let Ok(xs) = <&[&[f64]; 8]>::try_from(xs) {
                        for (&r, &a) in entries {
                            for t in 0..8 {
                                acc[t] += a * xs[t][r];
                            }
                        }
                    } else {
                        for (&r, &a) in entries {
                            for (t, c) in xs.iter().enumerate() {
                                acc[t] += a * c[r];
                            }
                        }
                    }
                    for (t, &v) in acc[..w].iter().enumerate() {
                        out[(q, j0 + t)] = v;
                    }
                }
                j0 += w;
            }
        });
}

/// Refuses a matrix whose asymmetry `max |A − Aᵀ|` exceeds `10⁻¹⁰ max |A|`.
pub(crate) fn check_symmetric(what: &'static str, a: &SparseMatrix) -> Result<(), SpectralError> {
    let asymmetry = crate::operator::symmetrize::asymmetry(a);
    let scale = a.val().iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if asymmetry > 1e-10 * scale.max(f64::MIN_POSITIVE) {
        return Err(SpectralError::NotSymmetricMatrix {
            what,
            asymmetry,
            scale,
        });
    }
    Ok(())
}
