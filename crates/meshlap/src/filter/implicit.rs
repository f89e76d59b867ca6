//! Implicit fairing (Desbrun et al. 1999; Zhang 2004 §4.10, eq. 6): the rational
//! low-pass `(1 + λγ)⁻¹` applied by solving `B(F) x = (I + λF) x = b`, with b the n×3
//! row-major block of the positions.
//!
//! Sign convention: F is one of [`crate::operator`]'s operators, `F = D − W` (positive
//! semi-definite), so `I + λF` is positive definite for λ > 0 and symmetric exactly
//! when F is (KL, SQL without negative weights, SSTL, GL, cotangent stiffness).
//!
//! [`ImplicitSolver`] is the stateful solver and the one route to every solver kind
//! (geometry-central's pattern): it assembles the system once for an operator and a
//! solver kind and keeps everything the kind needs across solves — the CSR matrix, its
//! transpose for BiCG (or, when F has a symmetrizer S, S itself: `Aᵀ = S A S⁻¹`, so
//! BiCG multiplies by A twice in one pass and stores no transpose), the Jacobi
//! preconditioner, the symmetrized system for `cg-sym`, the Cholesky or LU
//! factorization, and the iterative solvers' buffers. On
//! [`ImplicitSolver::set_lambda`] the direct kinds refactor numerically, reusing the
//! symbolic analysis. [`implicit_fairing`] is the one-shot function.
//!
//! Systems per solver kind:
//! - `cg`, `pcg`, `cholesky`: `(I + λF)x = b`, F must be symmetric (checked: a
//!   non-symmetric F is an error, never a silent wrong answer);
//! - `bicg`, `bicgstab`, `lu`: `(I + λF)x = b`, any F;
//! - `cg-sym`: `S(I + λF)x = Sb` with S a positive diagonal making `S·F` symmetric
//!   ([`symmetrizer`]), scaled so the off-diagonal entries of `S·F` have mean
//!   magnitude 1. For the Tutte Laplacian `T = D⁻¹K` this gives S = D and the paper's
//!   `(D + λK)x = Db` ("CG (TL)" of Table 1). Same solution as the unsymmetrized
//!   system, SPD, so CG applies;
//! - `auto` (the default): `cg` for a symmetric F, `bicg` otherwise.
//!
//! The SQL with negative weights can make `I + λS` indefinite: CG reports
//! [`crate::solve::CgError::NotPositiveDefinite`] on a non-positive curvature and
//! Cholesky [`crate::solve::DirectError::NotPositiveDefinite`] on a non-positive pivot.

use super::options::{positive, ImplicitOptions};
use super::{FilterError, FilterKind};
pub use crate::operator::symmetrize::{is_symmetric, symmetrizer};
use crate::solve::{
    bicg, bicgstab, cg, check_sizes, relative_residuals, CholeskySolver, CsrMatrix,
    CsrWithSymmetrizer, CsrWithTranspose, DirectError, DirectInfo, Info, InputError, Jacobi, LinOp,
    LuSolver, Params, SolveError, SolveInfo, Workspace,
};
use crate::SparseMatrix;
use rayon::prelude::*;
use std::time::Instant;

/// Linear solver of the implicit filter.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub enum SolverKind {
    /// Chosen from the operator: CG for a symmetric F, BiCG otherwise.
    #[default]
    Auto,
    /// Conjugate gradients (symmetric F).
    Cg,
    /// Jacobi-preconditioned CG (symmetric F).
    Pcg,
    /// Bi-conjugate gradients (any F).
    Bicg,
    /// CG on the symmetrized system `S(I + λF)x = Sb` (the paper's "CG (TL)").
    CgSym,
    /// BiCGSTAB (any F).
    Bicgstab,
    /// Sparse Cholesky (symmetric F).
    Cholesky,
    /// Sparse LU (any F).
    Lu,
}

crate::names::option_names!(SolverKind, FilterError, |s| FilterError::UnknownName {
    what: "solver",
    got: s.to_string(),
}, {
    Auto => "auto",
    Cg => "cg",
    Pcg => "pcg",
    Bicg => "bicg",
    CgSym => "cg-sym",
    Bicgstab => "bicgstab",
    Cholesky => "cholesky",
    Lu => "lu",
});

impl SolverKind {
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

    /// The kind that runs for operator `f`: [`SolverKind::Auto`] becomes CG for a
    /// symmetric F and BiCG otherwise; the other kinds stay.
    pub fn resolve(self, f: &SparseMatrix) -> SolverKind {
        match self {
            SolverKind::Auto if is_symmetric(f) => SolverKind::Cg,
            SolverKind::Auto => SolverKind::Bicg,
            kind => kind,
        }
    }
}

enum Prepared {
    /// CG or PCG on `I + λF`.
    Cg {
        a: CsrMatrix,
        jacobi: Option<Jacobi>,
    },
    /// BiCG on `I + λF` and its transpose (F without a symmetrizer).
    Bicg(CsrWithTranspose),
    /// BiCG on `I + λF` with a symmetrizer S of F (`S(I + λF)` symmetric): no
    /// transpose; both products in one pass over the matrix.
    BicgSym(CsrWithSymmetrizer),
    /// CG on `S(I + λF)`; `I + λF` kept for the residuals of the original system.
    CgSym {
        a: CsrMatrix,
        original: CsrMatrix,
        s: Vec<f64>,
    },
    /// BiCGSTAB on `I + λF`.
    Bicgstab(CsrMatrix),
    /// `I + λF` and its Cholesky factorization.
    Cholesky(CsrMatrix, CholeskySolver),
    /// `I + λF` and its LU factorization.
    Lu(CsrMatrix, Box<LuSolver>),
}

/// Stateful solver of `(I + λF) x = b` for n×3 blocks (see the module documentation).
pub struct ImplicitSolver {
    f: CsrMatrix,
    kind: SolverKind,
    lambda: f64,
    prepared: Prepared,
    workspace: Workspace,
}

fn direct(e: DirectError) -> FilterError {
    FilterError::Solve(e.into())
}

impl ImplicitSolver {
    /// Prepares the system `I + λF` for `kind` ([`SolverKind::Auto`] is resolved
    /// here): checks that F (n×n, `F = D − W`) suits the kind, builds the matrices and,
    /// for the direct kinds, factors.
    ///
    /// # Errors
    /// λ not positive and finite; F not square; a kind needing a symmetric F given a
    /// non-symmetric one ([`FilterError::NeedsSymmetric`]); `cg-sym` without a
    /// symmetrizer; a failed factorization (an indefinite `I + λS` for Cholesky).
    pub fn new(f: &SparseMatrix, lambda: f64, kind: SolverKind) -> Result<Self, FilterError> {
        positive(lambda, "λ")?;
        if f.nrows() != f.ncols() {
            return Err(FilterError::OperatorSize {
                rows: f.nrows(),
                cols: f.ncols(),
                n: f.nrows(),
            });
        }
        let kind = kind.resolve(f);
        if kind.needs_symmetric() && !is_symmetric(f) {
            return Err(FilterError::NeedsSymmetric { solver: kind });
        }
        let s = match kind {
            SolverKind::CgSym => {
                Some(symmetrizer(f).ok_or(FilterError::NoSymmetrizer { what: "cg-sym" })?)
            }
            // BiCG uses a symmetrizer when F has one (`Aᵀ = S A S⁻¹`: no transpose).
            SolverKind::Bicg => symmetrizer(f),
            _ => None,
        };
        let f = CsrMatrix::from_csc(f);
        let prepared = Self::prepare(&f, lambda, kind, s)?;
        Ok(ImplicitSolver {
            f,
            kind,
            lambda,
            prepared,
            workspace: Workspace::new(),
        })
    }

    fn prepare(
        f: &CsrMatrix,
        lambda: f64,
        kind: SolverKind,
        s: Option<Vec<f64>>,
    ) -> Result<Prepared, FilterError> {
        let b = f.shifted(&vec![1.0; f.nrows()], lambda);
        Ok(match (kind, s) {
            (SolverKind::CgSym, Some(s)) => {
                // S(I + λF) = S + λ·S·F, symmetrized to remove rounding asymmetry.
                let sf = f.scale_rows(&s);
                let sym = sf.add(0.5, &sf.transpose(), 0.5);
                Prepared::CgSym {
                    a: sym.shifted(&s, lambda),
                    original: b,
                    s,
                }
            }
            (SolverKind::CgSym, None) => return Err(FilterError::NoSymmetrizer { what: "cg-sym" }),
            (SolverKind::Cg | SolverKind::Auto, _) => Prepared::Cg { a: b, jacobi: None },
            (SolverKind::Pcg, _) => {
                let jacobi = Jacobi::new(&b).map_err(|e| FilterError::Solve(e.into()))?;
                Prepared::Cg {
                    a: b,
                    jacobi: Some(jacobi),
                }
            }
            (SolverKind::Bicg, Some(s)) => Prepared::BicgSym(
                CsrWithSymmetrizer::checked_by_caller(b, s)
                    .map_err(|e| FilterError::Solve(e.into()))?,
            ),
            (SolverKind::Bicg, None) => Prepared::Bicg(CsrWithTranspose::new(b)),
            (SolverKind::Bicgstab, _) => Prepared::Bicgstab(b),
            (SolverKind::Cholesky, _) => {
                let chol = CholeskySolver::new(&b.to_csc()).map_err(direct)?;
                Prepared::Cholesky(b, chol)
            }
            (SolverKind::Lu, _) => {
                let lu = Box::new(LuSolver::new(&b.to_csc()).map_err(direct)?);
                Prepared::Lu(b, lu)
            }
        })
    }

    /// Changes λ; the direct kinds refactor numerically, reusing their symbolic
    /// analysis. A failed refactorization leaves the solver as it was.
    pub fn set_lambda(&mut self, lambda: f64) -> Result<(), FilterError> {
        positive(lambda, "λ")?;
        let shifted = |f: &CsrMatrix| f.shifted(&vec![1.0; f.nrows()], lambda);
        match &mut self.prepared {
            Prepared::Cholesky(a, chol) => {
                let b = shifted(&self.f);
                chol.refactor(&b.to_csc()).map_err(direct)?;
                *a = b;
            }
            Prepared::Lu(a, lu) => {
                let b = shifted(&self.f);
                lu.refactor(&b.to_csc()).map_err(direct)?;
                *a = b;
            }
            _ => {
                let s = match &self.prepared {
                    Prepared::CgSym { s, .. } => Some(s.clone()),
                    Prepared::BicgSym(op) => Some(op.symmetrizer().to_vec()),
                    _ => None,
                };
                self.prepared = Self::prepare(&self.f, lambda, self.kind, s)?;
            }
        }
        self.lambda = lambda;
        Ok(())
    }

    /// λ.
    pub fn lambda(&self) -> f64 {
        self.lambda
    }
    /// The solver kind that runs (never [`SolverKind::Auto`]).
    pub fn kind(&self) -> SolverKind {
        self.kind
    }
    /// n.
    pub fn dim(&self) -> usize {
        self.f.nrows()
    }

    /// The matrix the solver works on (`I + λF`, or `S(I + λF)` for `cg-sym`), as CSR.
    pub fn system_matrix(&self) -> &CsrMatrix {
        match &self.prepared {
            Prepared::Cg { a, .. }
            | Prepared::CgSym { a, .. }
            | Prepared::Bicgstab(a)
            | Prepared::Cholesky(a, _)
            | Prepared::Lu(a, _) => a,
            Prepared::Bicg(op) => op.matrix(),
            Prepared::BicgSym(op) => op.matrix(),
        }
    }

    /// The factorization of a direct kind (times and fill).
    pub fn factorization(&self) -> Option<DirectInfo> {
        match &self.prepared {
            Prepared::Cholesky(_, c) => Some(c.info()),
            Prepared::Lu(_, l) => Some(l.info()),
            _ => None,
        }
    }

    /// Solves `(I + λF) x = b` for the n×3 row-major block `b`, starting from `x`
    /// (iterative kinds; the direct ones overwrite it). The residuals reported are those
    /// of the unsymmetrized system `‖(I + λF)x − b‖/‖b‖` per column, whichever system
    /// the kind solves; `params` apply to the iterative kinds.
    pub fn solve(
        &mut self,
        b: &[f64],
        x: &mut [f64],
        params: &Params,
    ) -> Result<SolveInfo, FilterError> {
        let input = |e: InputError| FilterError::Solve(e.into());
        check_sizes(self.dim(), b, x, 3).map_err(input)?;
        params.validate().map_err(input)?;
        Ok(self.run(b, x, params)?)
    }

    fn run(&mut self, b: &[f64], x: &mut [f64], params: &Params) -> Result<SolveInfo, SolveError> {
        let k = 3;
        let ws = &mut self.workspace;
        Ok(match &self.prepared {
            Prepared::Cg { a, jacobi } => {
                SolveInfo::Iterative(cg(a, b, x, k, params, jacobi.as_ref(), ws)?)
            }
            Prepared::Bicg(op) => SolveInfo::Bicg(bicg(op, b, x, k, &(*params).into(), None, ws)?),
            Prepared::BicgSym(op) => {
                SolveInfo::Bicg(bicg(op, b, x, k, &(*params).into(), None, ws)?)
            }
            Prepared::CgSym { a, original, s } => {
                // The solve's time includes forming Sb and the final residuals of the
                // original system.
                let start = Instant::now();
                let sb: Vec<f64> = b
                    .par_iter()
                    .enumerate()
                    .map(|(j, v)| v * s[j / k])
                    .collect();
                let mut info = cg(a, &sb, x, k, params, None, ws)?;
                // Residuals of the original system, comparable with BiCG's; a work
                // block of the finished solve is the scratch.
                let [scratch] = ws.blocks::<1>(b.len());
                info.residuals = original.residual(b, x, scratch, k, None, None)?.relative(k);
                info.seconds = start.elapsed().as_secs_f64();
                SolveInfo::Iterative(info)
            }
            Prepared::Bicgstab(a) => SolveInfo::Iterative(bicgstab(a, b, x, k, params, ws)?),
            Prepared::Cholesky(a, c) => direct_solve(a, b, x, k, |x| c.solve_in_place(x, k))?,
            Prepared::Lu(a, l) => direct_solve(a, b, x, k, |x| l.solve_in_place(x, k))?,
        })
    }

    /// `steps` solves `(I + λF) x⁽ᵗ⁺¹⁾ = x⁽ᵗ⁾` from the n×3 row-major positions `x`
    /// (overwritten), each starting from the previous positions; the record of each.
    pub fn fair(
        &mut self,
        x: &mut [f64],
        steps: usize,
        params: &Params,
    ) -> Result<Vec<SolveInfo>, FilterError> {
        if steps == 0 {
            return Err(FilterError::NoSteps {
                filter: FilterKind::Implicit,
            });
        }
        let mut b = x.to_vec();
        let mut infos = Vec::with_capacity(steps);
        for _ in 0..steps {
            b.copy_from_slice(x);
            infos.push(self.solve(&b, x, params)?);
        }
        Ok(infos)
    }
}

fn direct_solve(
    a: &CsrMatrix,
    b: &[f64],
    x: &mut [f64],
    k: usize,
    solve: impl FnOnce(&mut [f64]) -> Result<DirectInfo, DirectError>,
) -> Result<SolveInfo, SolveError> {
    x.copy_from_slice(b);
    let factorization = solve(x)?;
    Ok(SolveInfo::Direct {
        info: Info {
            iterations: vec![0; k],
            residuals: relative_residuals(a, x, b, k)?,
            history: vec![Vec::new(); k],
            seconds: factorization.solve_seconds,
        },
        factorization,
    })
}

/// One-shot implicit fairing with `opts` (λ, steps, solver, iterative parameters) of
/// the n×3 row-major positions `x` (overwritten) under the n×n operator `f`
/// (`F = D − W`): an [`ImplicitSolver`] run for `opts.steps` solves. Returns the
/// record of every solve.
pub fn implicit_fairing(
    f: &SparseMatrix,
    x: &mut [f64],
    opts: &ImplicitOptions,
) -> Result<Vec<SolveInfo>, FilterError> {
    if opts.steps == 0 {
        return Err(FilterError::NoSteps {
            filter: FilterKind::Implicit,
        });
    }
    ImplicitSolver::new(f, opts.lambda, opts.solver)?.fair(x, opts.steps, &opts.params)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::test_util::{bumpy_sphere, positions};
    use crate::mesh::topology::Topology;
    use crate::operator::{kirchhoff::kirchhoff, sql::sql, tutte::tutte};
    use crate::solve::{test_util::max_diff, Stopping};

    fn strong() -> Params {
        Params {
            stopping: Stopping::Strong,
            tolerance: 1e-11,
            ..Default::default()
        }
    }

    fn setup() -> (Vec<f64>, Topology) {
        let (m, t) = bumpy_sphere();
        (positions(&m), t)
    }

    fn fair(f: &SparseMatrix, x: &mut [f64], lambda: f64, steps: usize, solver: SolverKind) {
        let opts = ImplicitOptions {
            lambda,
            steps,
            solver,
            params: strong(),
        };
        implicit_fairing(f, x, &opts).unwrap_or_else(|e| panic!("{solver}: {e}"));
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
        assert_eq!(*got, want);
    }

    #[test]
    fn every_solver_agrees_with_the_direct_one() {
        use SolverKind::*;
        let (x0, t) = setup();
        let tl = tutte(&t).unwrap();
        let s = sql(&t, Default::default()).unwrap();
        let cases = [
            (&tl, Lu, [Auto, Bicg, CgSym, Bicgstab]),
            (&s, Cholesky, [Auto, Cg, Pcg, Lu]),
        ];
        for (f, reference, kinds) in cases {
            let mut want = x0.clone();
            fair(f, &mut want, 5.0, 2, reference);
            for kind in kinds {
                let mut x = x0.clone();
                fair(f, &mut x, 5.0, 2, kind);
                assert!(max_diff(&x, &want) < 1e-8, "{kind}");
            }
        }
    }

    #[test]
    fn auto_resolves_from_the_operator() {
        let (_, t) = setup();
        let s = sql(&t, Default::default()).unwrap();
        let tl = tutte(&t).unwrap();
        assert_eq!(SolverKind::Auto.resolve(&s), SolverKind::Cg);
        assert_eq!(SolverKind::Auto.resolve(&tl), SolverKind::Bicg);
        assert_eq!(SolverKind::Lu.resolve(&s), SolverKind::Lu);
        let solver = ImplicitSolver::new(&tl, 1.0, SolverKind::Auto).unwrap();
        assert_eq!(solver.kind(), SolverKind::Bicg);
    }

    #[test]
    fn symmetric_solvers_refuse_a_non_symmetric_operator() {
        let (_, t) = setup();
        let tl = tutte(&t).unwrap();
        for kind in [SolverKind::Cg, SolverKind::Pcg, SolverKind::Cholesky] {
            let e = ImplicitSolver::new(&tl, 1.0, kind)
                .err()
                .expect("must fail");
            assert!(matches!(e, FilterError::NeedsSymmetric { solver } if solver == kind));
            assert!(e.to_string().contains("symmetric"), "{e}");
        }
        assert!(ImplicitSolver::new(&tl, -1.0, SolverKind::Lu).is_err());
        assert!(ImplicitSolver::new(&tl, f64::NAN, SolverKind::Lu).is_err());
    }

    #[test]
    fn set_lambda_refactors_and_matches_a_fresh_solver() {
        let (x0, t) = setup();
        let s = sql(&t, Default::default()).unwrap();
        let tl = tutte(&t).unwrap();
        let cases = [
            (&s, SolverKind::Cholesky),
            (&s, SolverKind::Lu),
            (&s, SolverKind::Cg),
            (&s, SolverKind::Pcg),
            (&tl, SolverKind::CgSym),
            (&tl, SolverKind::Bicg),
        ];
        for (f, kind) in cases {
            let mut reused = ImplicitSolver::new(f, 3.0, kind).unwrap();
            let symbolic = reused.factorization().map(|i| i.symbolic_seconds);
            reused.set_lambda(40.0).unwrap();
            assert_eq!(reused.lambda(), 40.0);
            assert_eq!(
                reused.factorization().map(|i| i.symbolic_seconds),
                symbolic,
                "{kind}: the symbolic analysis is kept"
            );
            let mut fresh = ImplicitSolver::new(f, 40.0, kind).unwrap();
            assert_eq!(reused.system_matrix(), fresh.system_matrix());
            let (mut a, mut b) = (x0.clone(), x0.clone());
            reused.solve(&x0, &mut a, &strong()).unwrap();
            fresh.solve(&x0, &mut b, &strong()).unwrap();
            assert!(max_diff(&a, &b) < 1e-9, "{kind}");
        }
        let mut solver = ImplicitSolver::new(&s, 3.0, SolverKind::Cg).unwrap();
        assert!(solver.set_lambda(0.0).is_err());
        assert_eq!(solver.lambda(), 3.0);
    }

    #[test]
    fn repeated_solves_reuse_the_buffers_and_agree() {
        let (x0, t) = setup();
        let tl = tutte(&t).unwrap();
        for kind in [SolverKind::Bicg, SolverKind::Bicgstab, SolverKind::CgSym] {
            let mut solver = ImplicitSolver::new(&tl, 30.0, kind).unwrap();
            let mut runs = Vec::new();
            for _ in 0..2 {
                let mut x = x0.clone();
                let info = solver.solve(&x0, &mut x, &Params::default()).unwrap();
                runs.push((x, info.iterations().to_vec()));
            }
            assert!(!solver.workspace.is_empty());
            assert_eq!(runs[0], runs[1], "{kind}");
        }
    }

    #[test]
    fn reports_carry_what_each_solver_knows() {
        let (x0, t) = setup();
        let s = sql(&t, Default::default()).unwrap();
        let tl = tutte(&t).unwrap();
        let run = |f: &SparseMatrix, kind| {
            let mut solver = ImplicitSolver::new(f, 10.0, kind).unwrap();
            let mut x = x0.clone();
            solver.solve(&x0, &mut x, &Params::default()).unwrap()
        };
        let bicg = run(&tl, SolverKind::Bicg);
        assert_eq!(bicg.plateau_at().map(<[_]>::len), Some(3));
        let json = serde_json::to_value(&bicg).unwrap();
        assert!(json.get("plateau_at").is_some() && json.get("iterations").is_some());
        let cg = run(&s, SolverKind::Cg);
        assert!(cg.plateau_at().is_none() && cg.factorization().is_none());
        let json = serde_json::to_value(&cg).unwrap();
        assert!(json.get("plateau_at").is_none() && json.get("history").is_some());
        let chol = run(&s, SolverKind::Cholesky);
        let f = chol
            .factorization()
            .expect("a direct solve reports its factorization");
        assert!(f.factor_nnz.unwrap() > 0 && f.numeric_seconds > 0.0);
        assert_eq!(chol.iterations(), &[0, 0, 0]);
        assert!(chol.residuals().iter().all(|&r| r < 1e-12));
        let json = serde_json::to_value(&chol).unwrap();
        assert!(json["factorization"]["factor_nnz"].as_u64().unwrap() > 0);
    }

    #[test]
    fn wrong_sizes_are_errors() {
        let (x0, t) = setup();
        let mut s = ImplicitSolver::new(&kirchhoff(&t), 1.0, SolverKind::Cg).unwrap();
        let mut x = vec![0.0; 5];
        assert!(matches!(
            s.solve(&x0, &mut x, &Params::default()),
            Err(FilterError::Solve(SolveError::Input(
                InputError::InitialGuess { .. }
            )))
        ));
        let mut y = x0.clone();
        let zero = ImplicitOptions {
            steps: 0,
            ..Default::default()
        };
        assert!(matches!(
            implicit_fairing(&kirchhoff(&t), &mut y, &zero),
            Err(FilterError::NoSteps { .. })
        ));
    }

    #[test]
    fn an_indefinite_system_is_reported_as_such() {
        // diag(1, 1, -50, 1, ...) as F: I + λF has a negative diagonal entry.
        let n = 12;
        let d: Vec<f64> = (0..n).map(|i| if i == 2 { -50.0 } else { 1.0 }).collect();
        let f = crate::solve::test_util::diagonal(&d).to_csc();
        let b: Vec<f64> = (0..3 * n).map(|i| 1.0 + i as f64).collect();
        for kind in [SolverKind::Cg, SolverKind::Pcg, SolverKind::Cholesky] {
            let result = ImplicitSolver::new(&f, 1.0, kind).and_then(|mut s| {
                let mut x = b.clone();
                s.solve(&b, &mut x, &Params::default())
            });
            match result {
                Err(FilterError::Solve(e)) => assert!(e.is_not_positive_definite(), "{kind}: {e}"),
                other => panic!("{kind}: {other:?}"),
            }
        }
    }
}
