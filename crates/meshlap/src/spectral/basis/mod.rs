//! Dense eigenbasis of a mesh operator: the basis matrix `E` of the ED-transform
//! `x = E·X` (Zhang 2004, §2.3 eq. (2); Karni & Gotsman 2000), for n up to
//! [`DENSE_LIMIT`].
//!
//! **Sign convention.** Operators are positive semi-definite, `F = D − W`, as in the
//! paper (libigl/pmp use the negative), so eigenvalues are returned **ascending**:
//! `λ₁ ≤ λ₂ ≤ …` with the smoothest basis vector first.
//!
//! ## Paths ([`EigenPath`])
//! - **Symmetric** (KL, GL, SQL, SSTL): `F = U Λ Uᵀ` by faer's self-adjoint
//!   eigensolver; `E = U` is orthonormal and the transform is the projection
//!   `X = Eᵀx`.
//! - **Symmetrized** (TL by default; any operator with a positive diagonal
//!   symmetrizer `S`, `S·F` symmetric — see
//!   [`crate::operator::symmetrize::diagonal_symmetrizer`]; the cotangent operator
//!   `M⁻¹L` with its lumped mass `S = M`): `A = S^{1/2} F S^{-1/2}` is symmetric
//!   and similar to F (for the TL, `S = D` and `A` is the normalized graph Laplacian
//!   G: `T = D^{-1/2} G D^{1/2}`, Zhang §3). With `A = U Λ Uᵀ` the eigenvectors of F
//!   are `S^{-1/2} u_j`, which are S-orthogonal, so the coefficients are a
//!   **S-weighted projection** `X_j = g_j · e_jᵀ S x` — no general eigensolver and
//!   no dense solve.
//! - **General**: faer's real non-symmetric eigendecomposition of the dense F and a
//!   dense LU factorisation of `E` (partial pivoting); `X = E⁻¹x` by LU solves. Kept
//!   to reproduce the paper's Fig. 3 cost comparison (Matlab `eig` + `E\x`) and to
//!   cross-check the symmetrized path. Requires a real spectrum (within the cluster
//!   tolerance).
//!
//! ## Normalisation
//! With [`Normalization::Unit`] (default) every column of `E` has unit Euclidean
//! norm, as Matlab's `eig` returns them (the paper's experiments); then
//! `g_j = ‖S^{-1/2}u_j‖²`. With
//! [`Normalization::Weighted`] the columns are S-orthonormal (`EᵀSE = I`, as in
//! Vallet & Lévy 2008's manifold harmonics) and `g_j = 1`. For symmetric operators
//! both are the orthonormal `E = U`.
//!
//! ## Canonical, deterministic vectors
//! A decoder that recomputes the basis from the connectivity must obtain the same
//! vectors, so the eigensolver's arbitrary choices are removed by the crate's one
//! sign and cluster rule ([`super::sign`]), with clusters closer than
//! [`BasisOptions::cluster_tolerance`]; the symmetrized path passes `S^{-1/2}` as the
//! probe scale, so the rule reads `e·r_0 > 0` for a simple eigenvector `e` of F.
//!
//! The general path applies the same rule with the Euclidean inner product (an
//! orthonormal basis of `span(E_c)`), so simple eigenvectors agree between the
//! symmetrized and general paths; inside a cluster the general path's basis is
//! Euclidean-orthonormal while the symmetrized one is S-orthogonal (both span the same
//! eigenspace, so truncated reconstructions at cluster boundaries agree).
//!
//! **Thread independence.** The dense eigensolvers run with a fixed faer
//! parallelism ([`PARALLELISM_DEGREE`] tasks on the current rayon pool) rather than
//! the pool's size, so the arithmetic — and hence every bit of the result — does not
//! depend on `--threads`/`RAYON_NUM_THREADS` (tested). Results are deterministic for
//! a given build and CPU; a decoder on another CPU agrees to rounding (≈1e-12), which
//! the canonicalisation keeps from growing into sign flips or rotations.
//!
//! Hand-written parts: the canonicalisation and the similarity transform; faer does
//! every factorisation (no crate provides canonical eigenbases).

pub use super::sign::probe;
use super::sign::{canonicalize, clusters, orthonormalize};
use super::SpectralError;
use crate::operator::symmetrize::{asymmetry, diagonal_symmetrizer, symmetrized_dense, Scaling};
use crate::operator::Operator;
use crate::SparseMatrix;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::evd::{self, ComputeEigenvectors};
use faer::linalg::solvers::PartialPivLu;
use faer::{Mat, MatRef, Par};
use serde::Serialize;

/// Largest n the dense paths accept (an n×n `f64` basis is 8n² bytes: 200 MB here).
pub const DENSE_LIMIT: usize = 5000;

/// Number of parallel tasks faer splits the dense factorisations into, fixed so the
/// result does not depend on the rayon pool size (see the module documentation).
pub const PARALLELISM_DEGREE: usize = 2;

/// Which eigendecomposition computes the basis.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum EigenPath {
    /// Symmetric when F is symmetric, symmetrized when it has a positive diagonal
    /// symmetrizer (or a mass matrix), otherwise an error (choose `General`).
    #[default]
    Auto,
    /// faer's self-adjoint eigensolver on F (F must be symmetric).
    Symmetric,
    /// Self-adjoint eigensolver on `S^{1/2} F S^{-1/2}` (the TL through the GL).
    Symmetrized,
    /// Non-symmetric eigendecomposition plus a dense LU of E.
    General,
}

impl EigenPath {
    /// Name used on the command line and in JSON.
    pub fn name(self) -> &'static str {
        match self {
            EigenPath::Auto => "auto",
            EigenPath::Symmetric => "symmetric",
            EigenPath::Symmetrized => "symmetrized",
            EigenPath::General => "general",
        }
    }
}

impl std::fmt::Display for EigenPath {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for EigenPath {
    type Err = SpectralError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s.to_ascii_lowercase().as_str() {
            "auto" => EigenPath::Auto,
            "symmetric" | "sym" => EigenPath::Symmetric,
            "symmetrized" | "similarity" => EigenPath::Symmetrized,
            "general" | "nonsymmetric" => EigenPath::General,
            _ => return Err(SpectralError::UnknownPath(s.to_string())),
        })
    }
}

/// Column scaling of the basis matrix E.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Normalization {
    /// Unit Euclidean norm per column (Matlab's `eig`, the paper's experiments).
    #[default]
    Unit,
    /// S-orthonormal columns, `EᵀSE = I` (manifold-harmonics convention).
    Weighted,
}

impl std::str::FromStr for Normalization {
    type Err = SpectralError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s.to_ascii_lowercase().as_str() {
            "unit" => Normalization::Unit,
            "weighted" => Normalization::Weighted,
            _ => {
                return Err(SpectralError::InvalidArgument(format!(
                    "unknown normalization {s:?} (unit or weighted)"
                )))
            }
        })
    }
}

/// The dense symmetric eigensolver of the symmetric and symmetrized paths.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum DenseSolver {
    /// [`crate::spectral::blocked_evd`]: LAPACK's blocked tridiagonalisation
    /// (`dsytrd`), faer's tridiagonal divide and conquer and a blocked
    /// back-transformation, parallel. Faster than faer's own as n grows (BENCHMARKS.md).
    #[default]
    Blocked,
    /// faer's own `self_adjoint_evd` (unblocked tridiagonalisation, divide and
    /// conquer), parallel: the reference the blocked solver is checked against.
    Faer,
    /// [`crate::spectral::dense_evd`]: sequential, the same bits on every CPU, and
    /// faster than faer for n up to a few hundred (the codec's patches).
    Reproducible,
}

impl DenseSolver {
    /// Name used on the command line and in JSON.
    pub fn name(self) -> &'static str {
        match self {
            DenseSolver::Blocked => "blocked",
            DenseSolver::Faer => "faer",
            DenseSolver::Reproducible => "reproducible",
        }
    }
}

impl std::fmt::Display for DenseSolver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for DenseSolver {
    type Err = SpectralError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s.to_ascii_lowercase().as_str() {
            "blocked" => DenseSolver::Blocked,
            "faer" => DenseSolver::Faer,
            "reproducible" => DenseSolver::Reproducible,
            _ => {
                return Err(SpectralError::InvalidArgument(format!(
                    "unknown dense solver {s:?} (blocked, faer or reproducible)"
                )))
            }
        })
    }
}

/// Options of [`EigenBasis::compute`].
#[derive(Copy, Clone, Debug)]
pub struct BasisOptions {
    /// Which eigendecomposition.
    pub path: EigenPath,
    /// Column scaling.
    pub normalization: Normalization,
    /// Relative gap below which consecutive eigenvalues form one cluster.
    pub cluster_tolerance: f64,
    /// The dense symmetric eigensolver (symmetric and symmetrized paths; the general
    /// path always uses faer's non-symmetric solver).
    pub dense_solver: DenseSolver,
}

impl BasisOptions {
    /// The default [`BasisOptions::cluster_tolerance`].
    pub const DEFAULT_CLUSTER_TOLERANCE: f64 = 1e-10;
}

impl Default for BasisOptions {
    fn default() -> Self {
        Self {
            path: EigenPath::Auto,
            normalization: Normalization::Unit,
            cluster_tolerance: Self::DEFAULT_CLUSTER_TOLERANCE,
            dense_solver: DenseSolver::Blocked,
        }
    }
}

/// A full dense eigenbasis `E` (n×n, column-major, column j ↔ `eigenvalues[j]`,
/// ascending) with what the forward transform needs.
#[derive(Clone, Debug)]
pub struct EigenBasis {
    path: EigenPath,
    normalization: Normalization,
    eigenvalues: Vec<f64>,
    vectors: Mat<f64>,
    /// `S` of the S-weighted projection (None: identity).
    weights: Option<Vec<f64>>,
    /// `g_j` of `X_j = g_j e_jᵀ S x`.
    coefficient_scale: Vec<f64>,
    /// General path: LU of E.
    lu: Option<PartialPivLu<f64>>,
    /// `(start, len)` of each eigenvalue cluster.
    clusters: Vec<(usize, usize)>,
    max_imaginary: f64,
}

impl EigenBasis {
    /// The eigenbasis of an assembled operator: `op.matrix` (F = D − W), or
    /// `M⁻¹L` for the cotangent operator with its lumped mass `op.mass`.
    pub fn compute(op: &Operator, opts: &BasisOptions) -> Result<Self, SpectralError> {
        Self::from_matrix(&op.matrix, op.mass.as_deref(), opts)
    }

    /// The first columns of [`EigenBasis::compute`]'s basis: the eigenvectors of the
    /// `count` smallest eigenvalues, `count` extended to the end of its eigenvalue
    /// cluster ([`EigenBasis::clusters`]: the canonical vectors of a cluster depend on
    /// the whole cluster), so n×k with `count ≤ k ≤ n` (k = 0 for `count = 0`).
    /// With [`DenseSolver::Reproducible`] on the symmetric and symmetrized paths the
    /// columns, eigenvalues (the first k) and coefficient scales are bit-identical to
    /// the full basis' first k, and the inverse iteration and back-transformation
    /// cost `O(n·k)` and `O(n²·k)` instead of `O(n²)` and `O(n³)` (the
    /// tridiagonalization and the eigenvalues are computed in full either way);
    /// otherwise the full basis is returned.
    pub fn compute_lowest(
        op: &Operator,
        opts: &BasisOptions,
        count: usize,
    ) -> Result<Self, SpectralError> {
        Self::from_matrix_lowest(&op.matrix, op.mass.as_deref(), opts, count)
    }

    /// The eigenbasis of `F = M⁻¹·f` (`M = diag(mass)`, identity when `None`); `f`
    /// is n×n in the `D − W` sign convention. With a mass, `f` must be symmetric and
    /// the symmetrized path decomposes `M^{-1/2} f M^{-1/2}`.
    pub fn from_matrix(
        f: &SparseMatrix,
        mass: Option<&[f64]>,
        opts: &BasisOptions,
    ) -> Result<Self, SpectralError> {
        Self::from_matrix_lowest(f, mass, opts, usize::MAX)
    }

    /// [`EigenBasis::from_matrix`] limited as [`EigenBasis::compute_lowest`] is.
    pub fn from_matrix_lowest(
        f: &SparseMatrix,
        mass: Option<&[f64]>,
        opts: &BasisOptions,
        count: usize,
    ) -> Result<Self, SpectralError> {
        let n = f.nrows();
        if n == 0 || f.ncols() != n {
            return Err(SpectralError::Empty);
        }
        if n > DENSE_LIMIT {
            return Err(SpectralError::TooLarge {
                n,
                limit: DENSE_LIMIT,
            });
        }
        if !(opts.cluster_tolerance >= 0.0 && opts.cluster_tolerance < 1e-2) {
            return Err(SpectralError::InvalidArgument(format!(
                "cluster tolerance must be in [0, 1e-2), got {}",
                opts.cluster_tolerance
            )));
        }
        if let Some((i, _)) = f.val().iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(SpectralError::NonFinite { index: i });
        }
        let scale = f
            .val()
            .iter()
            .fold(0.0f64, |a, v| a.max(v.abs()))
            .max(1e-300);
        let symmetric = asymmetry(f) <= 1e-12 * scale;
        if let Some(m) = mass {
            super::partial::check_mass(m, n)?;
            if !symmetric {
                return Err(SpectralError::NotSymmetric);
            }
        }
        let weights: Option<Vec<f64>> = match mass {
            Some(m) => Some(m.to_vec()),
            None if symmetric => None,
            None => diagonal_symmetrizer(f).map(|mut s| {
                // Only defined up to scale per component: normalise to mean 1.
                let mean = s.iter().sum::<f64>() / n as f64;
                s.iter_mut().for_each(|x| *x /= mean);
                s
            }),
        };
        let path = match opts.path {
            EigenPath::Auto => match (&weights, symmetric) {
                (None, true) => EigenPath::Symmetric,
                (Some(_), _) => EigenPath::Symmetrized,
                (None, false) => return Err(SpectralError::NotSymmetrizable),
            },
            EigenPath::Symmetric if !symmetric || mass.is_some() => {
                return Err(SpectralError::NotSymmetric)
            }
            EigenPath::Symmetrized if weights.is_none() && !symmetric => {
                return Err(SpectralError::NotSymmetrizable)
            }
            p => p,
        };
        match path {
            EigenPath::General => general(f, mass, opts),
            _ => symmetrized(f, weights, mass.is_some(), path, opts, count),
        }
    }

    /// Builds a basis from precomputed parts, e.g. a partial spectrum: `vectors`
    /// (n×k, k ≤ n, column j ↔ `eigenvalues[j]`, ascending) must be orthonormal
    /// (`weights = None`) or S-orthogonal with `g_j = 1/(e_jᵀ S e_j)` derived here.
    /// No canonicalisation is applied.
    pub fn from_parts(
        eigenvalues: Vec<f64>,
        vectors: Mat<f64>,
        weights: Option<Vec<f64>>,
    ) -> Result<Self, SpectralError> {
        let (n, k) = (vectors.nrows(), vectors.ncols());
        if eigenvalues.len() != k {
            return Err(SpectralError::ShapeMismatch {
                what: "eigenvalues",
                expected: k,
                got: eigenvalues.len(),
            });
        }
        if k > n || n == 0 {
            return Err(SpectralError::Empty);
        }
        if let Some(w) = &weights {
            if w.len() != n {
                return Err(SpectralError::ShapeMismatch {
                    what: "weights",
                    expected: n,
                    got: w.len(),
                });
            }
        }
        if eigenvalues.iter().any(|v| !v.is_finite()) || eigenvalues.windows(2).any(|p| p[0] > p[1])
        {
            return Err(SpectralError::InvalidArgument(
                "eigenvalues must be finite and ascending".into(),
            ));
        }
        let coefficient_scale = (0..k)
            .map(|j| {
                let s: f64 = (0..n)
                    .map(|i| vectors[(i, j)].powi(2) * weights.as_ref().map_or(1.0, |w| w[i]))
                    .sum();
                1.0 / s
            })
            .collect();
        let clusters = clusters(&eigenvalues, BasisOptions::default().cluster_tolerance);
        Ok(Self {
            path: if weights.is_some() {
                EigenPath::Symmetrized
            } else {
                EigenPath::Symmetric
            },
            normalization: Normalization::Unit,
            eigenvalues,
            vectors,
            weights,
            coefficient_scale,
            lu: None,
            clusters,
            max_imaginary: 0.0,
        })
    }

    /// Number of vertices n (rows of E).
    pub fn n(&self) -> usize {
        self.vectors.nrows()
    }

    /// Number of basis vectors (n for a full basis).
    pub fn len(&self) -> usize {
        self.vectors.ncols()
    }

    /// True when the basis has no vectors (never for [`EigenBasis::compute`]'s;
    /// [`EigenBasis::compute_lowest`] with a count of 0).
    pub fn is_empty(&self) -> bool {
        self.vectors.ncols() == 0
    }

    /// The path that computed the basis (never `Auto`).
    pub fn path(&self) -> EigenPath {
        self.path
    }

    /// The column scaling.
    pub fn normalization(&self) -> Normalization {
        self.normalization
    }

    /// Eigenvalues, ascending.
    pub fn eigenvalues(&self) -> &[f64] {
        &self.eigenvalues
    }

    /// The basis matrix E, n×k, column j the eigenvector of `eigenvalues()[j]`.
    pub fn vectors(&self) -> MatRef<'_, f64> {
        self.vectors.as_ref()
    }

    /// The diagonal `S` of the weighted projection (None for symmetric operators and
    /// the general path).
    pub fn weights(&self) -> Option<&[f64]> {
        self.weights.as_deref()
    }

    /// `g_j` in `X_j = g_j·e_jᵀ S x` (projection paths; all ones for orthonormal E).
    pub fn coefficient_scale(&self) -> &[f64] {
        &self.coefficient_scale
    }

    /// The LU factorisation of E (general path only).
    pub fn lu(&self) -> Option<&PartialPivLu<f64>> {
        self.lu.as_ref()
    }

    /// Eigenvalue clusters as `(first index, size)`; sizes > 1 are numerically
    /// repeated eigenvalues.
    pub fn clusters(&self) -> &[(usize, usize)] {
        &self.clusters
    }

    /// Largest |imaginary part| met by the general path (0 for the others).
    pub fn max_imaginary(&self) -> f64 {
        self.max_imaginary
    }

    /// `max_j ‖F e_j − λ_j e_j‖₂ / ‖e_j‖₂` for `F = M⁻¹f` (pass the matrix and mass
    /// the basis was computed from). O(nnz·k).
    pub fn max_residual(&self, f: &SparseMatrix, mass: Option<&[f64]>) -> f64 {
        self.max_residual_first(f, mass, self.len())
    }

    /// [`Self::max_residual`] over the first `k` basis vectors only.
    pub fn max_residual_first(&self, f: &SparseMatrix, mass: Option<&[f64]>, k: usize) -> f64 {
        let n = self.n();
        let mut worst = 0.0f64;
        let mut y = vec![0.0; n];
        for j in 0..k.min(self.len()) {
            let e = self.vectors.col(j);
            y.iter_mut().for_each(|v| *v = 0.0);
            for c in 0..n {
                let ec = e[c];
                if ec == 0.0 {
                    continue;
                }
                for (&i, &v) in f.row_idx_of_col_raw(c).iter().zip(f.val_of_col(c)) {
                    y[i] += v * ec;
                }
            }
            let lam = self.eigenvalues[j];
            let mut r2 = 0.0;
            let mut e2 = 0.0;
            for i in 0..n {
                let fe = mass.map_or(y[i], |m| y[i] / m[i]);
                r2 += (fe - lam * e[i]).powi(2);
                e2 += e[i] * e[i];
            }
            worst = worst.max((r2 / e2).sqrt());
        }
        worst
    }

    /// For the projection paths, `max |g_i^{1/2} g_j^{1/2} e_iᵀ S e_j − δ_ij|` (0 for
    /// an exactly orthonormal basis in its inner product); `None` for the general
    /// path, whose basis is not orthogonal. O(n·k²).
    pub fn orthonormality_error(&self) -> Option<f64> {
        self.orthonormality_error_first(self.len())
    }

    /// [`Self::orthonormality_error`] among the first `k` basis vectors only, O(n·k²).
    pub fn orthonormality_error_first(&self, k: usize) -> Option<f64> {
        if self.path == EigenPath::General {
            return None;
        }
        let mut b = self
            .vectors
            .as_ref()
            .subcols(0, k.min(self.len()))
            .to_owned();
        for j in 0..b.ncols() {
            let g = self.coefficient_scale[j].sqrt();
            for i in 0..b.nrows() {
                let w = self.weights.as_ref().map_or(1.0, |w| w[i].sqrt());
                b[(i, j)] *= g * w;
            }
        }
        let gram = b.transpose() * &b;
        let mut worst = 0.0f64;
        for j in 0..gram.ncols() {
            for i in 0..gram.nrows() {
                let d = if i == j { 1.0 } else { 0.0 };
                worst = worst.max((gram[(i, j)] - d).abs());
            }
        }
        Some(worst)
    }
}

fn parallelism() -> Par {
    Par::rayon(PARALLELISM_DEGREE)
}

/// Eigenvalues (all, ascending) and eigenvectors of the dense symmetric `a`: with the
/// reproducible solver those of the `count` smallest eigenvalues, `count` extended to
/// the end of its cluster (relative gap `cluster_tolerance`); with the blocked solver
/// or faer's, all. `a` is consumed (the blocked solver reduces it in place).
fn dense_symmetric(
    a: Mat<f64>,
    par: Par,
    solver: DenseSolver,
    count: usize,
    cluster_tolerance: f64,
) -> Result<(Vec<f64>, Mat<f64>), SpectralError> {
    if solver == DenseSolver::Reproducible {
        let through_cluster = |lam: &[f64]| -> usize {
            let count = count.min(lam.len());
            if count == 0 || count == lam.len() {
                return count;
            }
            clusters(lam, cluster_tolerance)
                .into_iter()
                .map(|(start, len)| start + len)
                .find(|&end| end >= count)
                .unwrap_or(lam.len())
        };
        return super::dense_evd::symmetric_evd_lowest_by(a.as_ref(), &through_cluster).ok_or(
            SpectralError::NoConvergence {
                path: "symmetric (reproducible solver)",
            },
        );
    }
    if solver == DenseSolver::Blocked {
        return super::blocked_evd::symmetric_evd_owned(a, par).ok_or(
            SpectralError::NoConvergence {
                path: "symmetric (blocked solver)",
            },
        );
    }
    let n = a.nrows();
    let mut u = Mat::<f64>::zeros(n, n);
    let mut s = faer::diag::Diag::<f64>::zeros(n);
    let mut mem = MemBuffer::new(evd::self_adjoint_evd_scratch::<f64>(
        n,
        ComputeEigenvectors::Yes,
        par,
        Default::default(),
    ));
    evd::self_adjoint_evd(
        a.as_ref(),
        s.as_mut(),
        Some(u.as_mut()),
        par,
        MemStack::new(&mut mem),
        Default::default(),
    )
    .map_err(|_| SpectralError::NoConvergence { path: "symmetric" })?;
    let lam: Vec<f64> = (0..n).map(|i| s[i]).collect();
    Ok((lam, u))
}

fn symmetrized(
    f: &SparseMatrix,
    weights: Option<Vec<f64>>,
    is_mass: bool,
    path: EigenPath,
    opts: &BasisOptions,
    count: usize,
) -> Result<EigenBasis, SpectralError> {
    let path = if weights.is_none() {
        EigenPath::Symmetric
    } else {
        path
    };
    // With a mass, F = M⁻¹f and S = M give M^{-1/2} f M^{-1/2}; with a symmetrizer,
    // S^{1/2} F S^{-1/2}.
    let a = match (&weights, is_mass) {
        (None, _) => f.to_dense(),
        (Some(s), true) => symmetrized_dense(f, Scaling::Congruence(s)),
        (Some(s), false) => symmetrized_dense(f, Scaling::Similarity(s)),
    };
    let (mut lam, mut u) = dense_symmetric(
        a,
        parallelism(),
        opts.dense_solver,
        count,
        opts.cluster_tolerance,
    )?;
    let mut cl = clusters(&lam, opts.cluster_tolerance);
    // A partial basis (k < n vectors, k at a cluster's end): its eigenvalues and
    // clusters.
    let k = u.ncols();
    lam.truncate(k);
    cl.retain(|&(start, _)| start < k);
    let inv_sqrt: Option<Vec<f64>> = weights
        .as_ref()
        .map(|s| s.iter().map(|x| 1.0 / x.sqrt()).collect());
    // Probes S^{-1/2} r so that simple eigenvectors satisfy e·r_0 > 0 for e = S^{-1/2}u.
    canonicalize(&mut u, &cl, inv_sqrt.as_deref());
    let mut scale = vec![1.0; k];
    if let Some(is) = &inv_sqrt {
        // e_j = S^{-1/2} u_j, and with unit normalisation e_j/‖e_j‖ and g_j = ‖e_j‖²:
        // one pass per column, columns in parallel (per-column arithmetic, so the
        // result does not depend on the thread count).
        use rayon::prelude::*;
        let unit = opts.normalization == Normalization::Unit;
        u.as_mut()
            .par_col_chunks_mut(1)
            .zip(scale.par_iter_mut())
            .with_min_len(8)
            .for_each(|(col, g)| {
                let col = col
                    .col_mut(0)
                    .try_as_col_major_mut()
                    .unwrap()
                    .as_slice_mut();
                let mut c2 = 0.0;
                for (x, &s) in col.iter_mut().zip(is) {
                    let e = *x * s;
                    *x = e;
                    c2 += e * e;
                }
                if unit {
                    let inv = 1.0 / c2.sqrt();
                    col.iter_mut().for_each(|x| *x *= inv);
                    *g = c2;
                }
            });
    }
    Ok(EigenBasis {
        path,
        normalization: opts.normalization,
        eigenvalues: lam,
        vectors: u,
        weights,
        coefficient_scale: scale,
        lu: None,
        clusters: cl,
        max_imaginary: 0.0,
    })
}

fn general(
    f: &SparseMatrix,
    mass: Option<&[f64]>,
    opts: &BasisOptions,
) -> Result<EigenBasis, SpectralError> {
    let n = f.nrows();
    let mut a = f.to_dense();
    if let Some(m) = mass {
        for j in 0..n {
            for i in 0..n {
                a[(i, j)] /= m[i];
            }
        }
    }
    let par = parallelism();
    let mut u = Mat::<f64>::zeros(n, n);
    let mut s_re = faer::diag::Diag::<f64>::zeros(n);
    let mut s_im = faer::diag::Diag::<f64>::zeros(n);
    let mut mem = MemBuffer::new(evd::evd_scratch::<f64>(
        n,
        ComputeEigenvectors::No,
        ComputeEigenvectors::Yes,
        par,
        Default::default(),
    ));
    evd::evd_real(
        a.as_ref(),
        s_re.as_mut(),
        s_im.as_mut(),
        None,
        Some(u.as_mut()),
        par,
        MemStack::new(&mut mem),
        Default::default(),
    )
    .map_err(|_| SpectralError::NoConvergence { path: "general" })?;
    drop(a);
    let max_imaginary = (0..n).map(|i| s_im[i].abs()).fold(0.0, f64::max);
    let big = (0..n).map(|i| s_re[i].abs()).fold(1.0f64, f64::max);
    // Complex pairs are stored as (Re v, Im v) column pairs: a real basis of the
    // pair's invariant subspace, which lies inside one cluster when |Im λ| is tiny.
    if max_imaginary > opts.cluster_tolerance.max(1e-12) * big {
        return Err(SpectralError::ComplexSpectrum { max_imaginary });
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&x, &y| s_re[x].total_cmp(&s_re[y]));
    let lam: Vec<f64> = order.iter().map(|&j| s_re[j]).collect();
    let mut e = Mat::from_fn(n, n, |i, j| u[(i, order[j])]);
    drop(u);
    let cl = clusters(&lam, opts.cluster_tolerance);
    // Euclidean-orthonormal basis of each cluster's span, then the probe rule.
    for &(start, k) in &cl {
        let mut block = e.as_ref().subcols(start, k).to_owned();
        if !orthonormalize(&mut block) {
            return Err(SpectralError::SingularBasis);
        }
        e.as_mut().subcols_mut(start, k).copy_from(&block);
    }
    canonicalize(&mut e, &cl, None);
    let lu = e.partial_piv_lu();
    // A singular E (defective operator) shows as a tiny pivot.
    let uu = lu.U();
    let (mut pmin, mut pmax) = (f64::INFINITY, 0.0f64);
    for i in 0..n {
        pmin = pmin.min(uu[(i, i)].abs());
        pmax = pmax.max(uu[(i, i)].abs());
    }
    if pmin.is_nan() || pmin <= 1e-13 * pmax {
        return Err(SpectralError::SingularBasis);
    }
    Ok(EigenBasis {
        path: EigenPath::General,
        normalization: Normalization::Unit,
        eigenvalues: lam,
        vectors: e,
        weights: None,
        coefficient_scale: vec![1.0; n],
        lu: Some(lu),
        clusters: cl,
        max_imaginary,
    })
}

#[cfg(test)]
mod tests;
