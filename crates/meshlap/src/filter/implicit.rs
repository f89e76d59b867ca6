//! Implicit fairing (Desbrun et al. 1999; Zhang 2004 §4.10, eq. 6): the rational
//! low-pass `(1 + λγ)⁻¹` applied by solving `B(F) x = (I + λF) x = b`, with b the n×3
//! row-major block of the positions.
//!
//! Sign convention: F is one of [`crate::operator`]'s operators, `F = D − W` (positive
//! semi-definite), so `I + λF` is positive definite for λ > 0 and symmetric exactly
//! when F is (KL, SQL without negative weights, SSTL, GL, cotangent stiffness).
//!
//! [`ImplicitSolver`] is the reusable solver: it assembles the system once for an
//! operator and a solver kind, keeps everything the kind needs across solves (the
//! CSR matrix, its transpose for BiCG, the symmetrised system for `cg-sym`, the
//! Cholesky or LU factorisation) and, on [`ImplicitSolver::set_lambda`], refactors
//! reusing the symbolic analysis. [`implicit_fairing`] is the one-shot function.
//!
//! Systems per solver kind:
//! - `cg`, `pcg`, `cholesky`: `(I + λF)x = b`, F must be symmetric (checked: a
//!   non-symmetric F is an error, never a silent wrong answer);
//! - `bicg`, `bicgstab`, `lu`: `(I + λF)x = b`, any F;
//! - `cg-sym`: `S(I + λF)x = Sb` with S a positive diagonal making `S·F` symmetric
//!   ([`diagonal_symmetrizer`]), scaled so the off-diagonal entries of `S·F` have mean
//!   magnitude 1. For the Tutte Laplacian `T = D⁻¹K` this gives S = D and the paper's
//!   `(D + λK)x = Db` ("CG (TL)" of Table 1). Same solution as the unsymmetrised
//!   system, SPD, so CG applies.
//!
//! The SQL with negative weights can make `I + λS` indefinite: CG reports
//! [`SolveError::NotPositiveDefinite`] on a non-positive curvature and Cholesky on a
//! non-positive pivot.

use super::FilterError;
use crate::analysis::properties::{asymmetry, diagonal_symmetrizer};
use crate::solve::{
    self,
    cg::Preconditioner,
    direct::{CholeskySolver, LuSolver},
    CsrMatrix, Info, LinearOperator, Params, SolveError, SparseOperator,
};
use crate::SparseMatrix;
use serde::Serialize;
use std::time::Instant;

/// Linear solver of the implicit filter.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SolverKind {
    /// Conjugate gradients (symmetric F).
    Cg,
    /// Jacobi-preconditioned CG (symmetric F).
    Pcg,
    /// Bi-conjugate gradients (any F).
    Bicg,
    /// CG on the symmetrised system `S(I + λF)x = Sb` (the paper's "CG (TL)").
    CgSym,
    /// faer's BiCGSTAB (any F; stops on the strong criterion only).
    Bicgstab,
    /// Sparse Cholesky (symmetric F).
    Cholesky,
    /// Sparse LU (any F).
    Lu,
}

impl SolverKind {
    /// Every kind.
    pub const ALL: [SolverKind; 7] = [
        SolverKind::Cg,
        SolverKind::Pcg,
        SolverKind::Bicg,
        SolverKind::CgSym,
        SolverKind::Bicgstab,
        SolverKind::Cholesky,
        SolverKind::Lu,
    ];

    /// Name as accepted on the command line.
    pub fn name(self) -> &'static str {
        match self {
            SolverKind::Cg => "cg",
            SolverKind::Pcg => "pcg",
            SolverKind::Bicg => "bicg",
            SolverKind::CgSym => "cg-sym",
            SolverKind::Bicgstab => "bicgstab",
            SolverKind::Cholesky => "cholesky",
            SolverKind::Lu => "lu",
        }
    }

    /// True for the kinds that need a symmetric F.
    pub fn needs_symmetric(self) -> bool {
        matches!(
            self,
            SolverKind::Cg | SolverKind::Pcg | SolverKind::Cholesky
        )
    }

    /// True for the direct solvers.
    pub fn is_direct(self) -> bool {
        matches!(self, SolverKind::Cholesky | SolverKind::Lu)
    }
}

impl std::fmt::Display for SolverKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for SolverKind {
    type Err = FilterError;
    fn from_str(s: &str) -> Result<Self, FilterError> {
        SolverKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| {
                FilterError::InvalidParameter(format!(
                    "unknown solver `{s}` (cg, pcg, bicg, cg-sym, bicgstab, cholesky, lu)"
                ))
            })
    }
}

/// True when `f` is symmetric up to rounding (`max |F_ij − F_ji| ≤ 1e-12·max |F_ij|`).
pub fn is_symmetric(f: &SparseMatrix) -> bool {
    let scale = (0..f.ncols())
        .flat_map(|j| f.val_of_col(j).iter())
        .fold(0.0f64, |a, v| a.max(v.abs()));
    asymmetry(f) <= 1e-12 * scale
}

/// The positive diagonal S making `S·F` symmetric, scaled so that the off-diagonal
/// entries of `S·F` have mean magnitude 1 (S = D for the Tutte Laplacian). The ratios
/// found by [`diagonal_symmetrizer`] carry rounding from products along paths; when
/// every scaled entry is within 1e-9 (relative) of an integer — the degrees, for the
/// TL — the integers are used, so that `S·F` is exactly the Kirchhoff operator.
pub fn symmetrizer(f: &SparseMatrix) -> Option<Vec<f64>> {
    let mut s = diagonal_symmetrizer(f)?;
    let (mut sum, mut count) = (0.0, 0usize);
    for j in 0..f.ncols() {
        for (&i, &v) in f.row_idx_of_col_raw(j).iter().zip(f.val_of_col(j)) {
            if i != j && v != 0.0 {
                sum += (s[i] * v).abs();
                count += 1;
            }
        }
    }
    if count > 0 && sum > 0.0 {
        let c = count as f64 / sum;
        s.iter_mut().for_each(|v| *v *= c);
    }
    if s.iter()
        .all(|v| (v - v.round()).abs() <= 1e-9 * v.abs() && v.round() >= 1.0)
    {
        s.iter_mut().for_each(|v| *v = v.round());
    }
    Some(s)
}

enum Prepared {
    Cg(SparseOperator, Preconditioner),
    Bicg(SparseOperator),
    CgSym { op: SparseOperator, s: Vec<f64> },
    Bicgstab(SparseMatrix),
    Cholesky(SparseOperator, CholeskySolver),
    Lu(SparseOperator, Box<LuSolver>),
}

/// Reusable solver of `(I + λF) x = b` (see the module documentation).
pub struct ImplicitSolver {
    f: CsrMatrix,
    kind: SolverKind,
    lambda: f64,
    /// Symmetriser for `cg-sym`.
    s: Option<Vec<f64>>,
    prepared: Prepared,
}

fn check_lambda(lambda: f64) -> Result<(), FilterError> {
    if lambda > 0.0 && lambda.is_finite() {
        Ok(())
    } else {
        Err(FilterError::InvalidParameter(format!(
            "λ must be positive and finite, got {lambda}"
        )))
    }
}

impl ImplicitSolver {
    /// Prepares the system `(I + λF)` for `kind`: checks that F suits the kind, builds
    /// the matrices and, for the direct kinds, factors. F is n×n with `F = D − W`.
    pub fn new(f: &SparseMatrix, lambda: f64, kind: SolverKind) -> Result<Self, FilterError> {
        check_lambda(lambda)?;
        if f.nrows() != f.ncols() {
            return Err(FilterError::InvalidParameter(format!(
                "operator is {}×{}, not square",
                f.nrows(),
                f.ncols()
            )));
        }
        if kind.needs_symmetric() && !is_symmetric(f) {
            return Err(FilterError::InvalidParameter(format!(
                "solver {kind} needs a symmetric operator; this one is not (use bicg, cg-sym, bicgstab or lu)"
            )));
        }
        let s = if kind == SolverKind::CgSym {
            Some(symmetrizer(f).ok_or_else(|| {
                FilterError::Spectrum(
                    "cg-sym needs an operator with a positive diagonal symmetrizer (TL, SDL, mean-value, or any symmetric one)".into(),
                )
            })?)
        } else {
            None
        };
        let f = CsrMatrix::from_csc(f);
        let prepared = Self::prepare(&f, lambda, kind, s.as_deref())?;
        Ok(ImplicitSolver {
            f,
            kind,
            lambda,
            s,
            prepared,
        })
    }

    fn prepare(
        f: &CsrMatrix,
        lambda: f64,
        kind: SolverKind,
        s: Option<&[f64]>,
    ) -> Result<Prepared, FilterError> {
        let ones = vec![1.0; f.nrows()];
        let b = f.shifted(&ones, lambda);
        Ok(match kind {
            SolverKind::Cg => Prepared::Cg(SparseOperator::from_csr(b, None), Preconditioner::None),
            SolverKind::Pcg => {
                Prepared::Cg(SparseOperator::from_csr(b, None), Preconditioner::Jacobi)
            }
            SolverKind::Bicg => {
                let bt = CsrMatrix::transpose_of_csc(&b.to_csc());
                Prepared::Bicg(SparseOperator::from_csr(b, Some(bt)))
            }
            SolverKind::CgSym => {
                let s = s.expect("symmetrizer computed in new");
                // S(I + λF) = S + λ·S·F, symmetrised to remove rounding asymmetry.
                let sf = f.scale_rows(s);
                let sym = sf.add(0.5, &CsrMatrix::transpose_of_csc(&sf.to_csc()), 0.5);
                Prepared::CgSym {
                    op: SparseOperator::from_csr(sym.shifted(s, lambda), None),
                    s: s.to_vec(),
                }
            }
            SolverKind::Bicgstab => Prepared::Bicgstab(b.to_csc()),
            SolverKind::Cholesky => {
                let chol = CholeskySolver::new(&b.to_csc())?;
                Prepared::Cholesky(SparseOperator::from_csr(b, None), chol)
            }
            SolverKind::Lu => {
                let lu = Box::new(LuSolver::new(&b.to_csc())?);
                Prepared::Lu(SparseOperator::from_csr(b, None), lu)
            }
        })
    }

    /// Changes λ; the direct kinds refactor reusing their symbolic analysis.
    pub fn set_lambda(&mut self, lambda: f64) -> Result<(), FilterError> {
        check_lambda(lambda)?;
        // The direct kinds refactor in place with their symbolic analysis; a failed
        // refactorisation leaves the solver as it was.
        match &mut self.prepared {
            Prepared::Cholesky(op, chol) => {
                let b = self.f.shifted(&vec![1.0; self.f.nrows()], lambda);
                chol.refactor(&b.to_csc())?;
                *op = SparseOperator::from_csr(b, None);
            }
            Prepared::Lu(op, lu) => {
                let b = self.f.shifted(&vec![1.0; self.f.nrows()], lambda);
                lu.refactor(&b.to_csc())?;
                *op = SparseOperator::from_csr(b, None);
            }
            _ => {
                self.prepared = Self::prepare(&self.f, lambda, self.kind, self.s.as_deref())?;
            }
        }
        self.lambda = lambda;
        Ok(())
    }

    /// λ.
    pub fn lambda(&self) -> f64 {
        self.lambda
    }
    /// The solver kind.
    pub fn kind(&self) -> SolverKind {
        self.kind
    }
    /// n.
    pub fn dim(&self) -> usize {
        self.f.nrows()
    }

    /// The matrix the solver actually works on (`I + λF`, or `S(I + λF)` for `cg-sym`),
    /// as CSR.
    pub fn system_matrix(&self) -> CsrMatrix {
        match &self.prepared {
            Prepared::Cg(op, _)
            | Prepared::Bicg(op)
            | Prepared::CgSym { op, .. }
            | Prepared::Cholesky(op, _)
            | Prepared::Lu(op, _) => op.matrix().clone(),
            Prepared::Bicgstab(a) => CsrMatrix::from_csc(a),
        }
    }

    /// Solves `(I + λF) x = b` for the n×3 row-major block `b`, starting from `x`
    /// (iterative kinds; the direct ones overwrite it). `Info::residuals` are the
    /// relative residuals of the unsymmetrised system `‖(I + λF)x − b‖/‖b‖` per column.
    pub fn solve(&self, b: &[f64], x: &mut [f64], params: &Params) -> Result<Info, SolveError> {
        let n = self.dim();
        if b.len() != 3 * n || x.len() != 3 * n {
            return Err(SolveError::Dimension(format!(
                "the system has {n} vertices; right-hand side and initial guess need {} values each, got {} and {}",
                3 * n,
                b.len(),
                x.len()
            )));
        }
        let k = 3;
        match &self.prepared {
            Prepared::Cg(op, pre) => solve::cg::cg(op, b, x, k, params, *pre),
            Prepared::Bicg(op) => solve::bicg::bicg(op, b, x, k, params, Preconditioner::None),
            Prepared::CgSym { op, s } => {
                let sb: Vec<f64> = b.iter().enumerate().map(|(j, v)| v * s[j / k]).collect();
                let mut info = solve::cg::cg(op, &sb, x, k, params, Preconditioner::None)?;
                // Report residuals of the original system, comparable with BiCG's.
                let ones = vec![1.0; n];
                let orig = SparseOperator::from_csr(self.f.shifted(&ones, self.lambda), None);
                info.residuals = solve::relative_residuals(&orig, x, b, k);
                Ok(info)
            }
            Prepared::Bicgstab(a) => solve::bicgstab::bicgstab(a, b, x, k, params),
            Prepared::Cholesky(op, c) => direct_info(op, b, x, k, |x| c.solve_in_place(x, k)),
            Prepared::Lu(op, l) => direct_info(op, b, x, k, |x| l.solve_in_place(x, k)),
        }
    }
}

fn direct_info(
    op: &dyn LinearOperator,
    b: &[f64],
    x: &mut [f64],
    k: usize,
    solve: impl FnOnce(&mut [f64]) -> Result<(), SolveError>,
) -> Result<Info, SolveError> {
    let t = Instant::now();
    x.copy_from_slice(b);
    solve(x)?;
    let seconds = t.elapsed().as_secs_f64();
    Ok(Info {
        iterations: vec![0; k],
        residuals: solve::relative_residuals(op, x, b, k),
        history: vec![Vec::new(); k],
        plateau_at: vec![None; k],
        seconds,
    })
}

/// One-shot implicit fairing: `steps` solves `(I + λF) x⁽ᵗ⁺¹⁾ = x⁽ᵗ⁾` from the n×3
/// row-major positions `x` (overwritten), each starting from the previous positions.
/// Returns the solver information of every step.
pub fn implicit_fairing(
    f: &SparseMatrix,
    x: &mut [f64],
    lambda: f64,
    steps: usize,
    kind: SolverKind,
    params: &Params,
) -> Result<Vec<Info>, FilterError> {
    if steps == 0 {
        return Err(FilterError::InvalidParameter(
            "implicit fairing needs at least one step".into(),
        ));
    }
    let solver = ImplicitSolver::new(f, lambda, kind)?;
    let mut infos = Vec::with_capacity(steps);
    for _ in 0..steps {
        let b = x.to_vec();
        infos.push(solver.solve(&b, x, params)?);
    }
    Ok(infos)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{builtin, topology::Topology};
    use crate::operator::{kirchhoff::kirchhoff, sql::sql, tutte::tutte};
    use crate::solve::Stopping;

    fn strong() -> Params {
        Params {
            stopping: Stopping::Strong,
            tolerance: 1e-11,
            ..Default::default()
        }
    }

    fn max_diff(a: &[f64], b: &[f64]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
    }

    fn setup() -> (Vec<f64>, Topology) {
        let m = builtin::icosphere(2).unwrap();
        let t = Topology::new(&m).unwrap();
        let x = m
            .positions
            .iter()
            .enumerate()
            .flat_map(|(i, p)| {
                let s = 1.0 + 0.05 * ((i * 7919) % 13) as f64 / 13.0;
                p.map(|c| c * s)
            })
            .collect();
        (x, t)
    }

    #[test]
    fn symmetrizer_of_the_tutte_laplacian_is_the_degree_matrix() {
        let (_, t) = setup();
        let s = symmetrizer(&tutte(&t).unwrap()).unwrap();
        for (si, d) in s.iter().zip(t.degrees()) {
            assert_eq!(*si, d as f64);
        }
        // and the cg-sym system is then exactly D + λK
        let solver = ImplicitSolver::new(&tutte(&t).unwrap(), 7.0, SolverKind::CgSym).unwrap();
        let d: Vec<f64> = t.degrees().iter().map(|&v| v as f64).collect();
        let want = CsrMatrix::from_csc(&kirchhoff(&t)).shifted(&d, 7.0);
        let got = solver.system_matrix();
        assert_eq!(got.nnz(), want.nnz());
        assert_eq!(got, want);
    }

    #[test]
    fn every_solver_agrees_with_the_direct_one() {
        let (x0, t) = setup();
        let tl = tutte(&t).unwrap();
        let mut want = x0.clone();
        implicit_fairing(&tl, &mut want, 5.0, 2, SolverKind::Lu, &strong()).unwrap();
        for kind in [SolverKind::Bicg, SolverKind::CgSym, SolverKind::Bicgstab] {
            let mut x = x0.clone();
            implicit_fairing(&tl, &mut x, 5.0, 2, kind, &strong()).unwrap();
            assert!(max_diff(&x, &want) < 1e-8, "{kind}");
        }
        let s = sql(&t, Default::default()).unwrap();
        let mut want = x0.clone();
        implicit_fairing(&s, &mut want, 5.0, 2, SolverKind::Cholesky, &strong()).unwrap();
        for kind in [SolverKind::Cg, SolverKind::Pcg, SolverKind::Lu] {
            let mut x = x0.clone();
            implicit_fairing(&s, &mut x, 5.0, 2, kind, &strong()).unwrap();
            assert!(max_diff(&x, &want) < 1e-8, "{kind}");
        }
    }

    #[test]
    fn symmetric_solvers_refuse_a_non_symmetric_operator() {
        let (_, t) = setup();
        let tl = tutte(&t).unwrap();
        for kind in [SolverKind::Cg, SolverKind::Pcg, SolverKind::Cholesky] {
            let e = ImplicitSolver::new(&tl, 1.0, kind)
                .err()
                .expect("must fail");
            assert!(e.to_string().contains("symmetric"), "{e}");
        }
        assert!(ImplicitSolver::new(&tl, -1.0, SolverKind::Lu).is_err());
        assert!(ImplicitSolver::new(&tl, f64::NAN, SolverKind::Lu).is_err());
    }

    #[test]
    fn set_lambda_refactors_and_matches_a_fresh_solver() {
        let (x0, t) = setup();
        let s = sql(&t, Default::default()).unwrap();
        for kind in [SolverKind::Cholesky, SolverKind::Lu, SolverKind::Cg] {
            let mut reused = ImplicitSolver::new(&s, 3.0, kind).unwrap();
            reused.set_lambda(40.0).unwrap();
            assert_eq!(reused.lambda(), 40.0);
            let fresh = ImplicitSolver::new(&s, 40.0, kind).unwrap();
            let (mut a, mut b) = (x0.clone(), x0.clone());
            reused.solve(&x0, &mut a, &strong()).unwrap();
            fresh.solve(&x0, &mut b, &strong()).unwrap();
            assert!(max_diff(&a, &b) < 1e-9, "{kind}");
        }
    }

    #[test]
    fn wrong_sizes_are_errors() {
        let (x0, t) = setup();
        let s = ImplicitSolver::new(&kirchhoff(&t), 1.0, SolverKind::Cg).unwrap();
        let mut x = vec![0.0; 5];
        assert!(matches!(
            s.solve(&x0, &mut x, &Params::default()),
            Err(SolveError::Dimension(_))
        ));
        let mut y = x0.clone();
        assert!(implicit_fairing(
            &kirchhoff(&t),
            &mut y,
            1.0,
            0,
            SolverKind::Cg,
            &Params::default()
        )
        .is_err());
    }
}
