//! Mesh filters built on an operator F (sign convention `F = D − W`, so `−F·x` is the
//! Laplacian vector pointing towards the neighbors): every filter is a function of
//! F applied to the n×3 positions, `x' = h(F) x`, with frequency response h(γ) on F's
//! eigenvalues γ (Zhang 2004 §2.6, §4.10).
//!
//! | filter | h(γ) | module | reference |
//! |---|---|---|---|
//! | [`Filter::Implicit`] | `(1 + λγ)⁻ᴺ` (N solves of `(I + λF)x' = x`) | [`implicit`] | Desbrun et al. 1999; Zhang 2004 §4.10 |
//! | [`Filter::Explicit`] | `(1 − λγ)ᴺ` (Laplacian smoothing) | [`polynomial`] | Taubin 1995 |
//! | [`Filter::Taubin`] | `((1 − λγ)(1 − μγ))ᴺ`, μ < −λ < 0 | [`polynomial`] | Taubin 1995 |
//! | [`Filter::Butterworth`] | `1 / (1 + (γ/γ_PB)^{2s})` | [`butterworth`] | Zhang & Fiume 2003 |
//! | [`Filter::Ideal`] | `[γ ≤ γ_PB]` through the dense ED transform | [`ideal`] | Zhang 2004 §2.6 |
//!
//! The library owns every default and rule: [`Filter::new`] builds a filter from the
//! optional [`FilterSettings`] a front end collects, [`apply`] runs it on a mesh
//! (choosing the solver of implicit fairing from the operator when asked,
//! [`SolverKind::Auto`]) and rescales afterwards ([`preserve`]). The stateful solver
//! of implicit fairing is [`ImplicitSolver`]; the paper's Table 1 (CG vs BiCG) is
//! [`crate::experiment::fairing`].

pub mod butterworth;
pub mod ideal;
pub mod implicit;
mod options;
pub mod polynomial;
pub mod preserve;

pub use implicit::{implicit_fairing, ImplicitSolver, SolverKind};
pub use options::{
    ButterworthOptions, ExplicitOptions, Filter, FilterKind, FilterSettings, IdealOptions,
    ImplicitOptions, TaubinOptions, DEFAULT_DENSE_LIMIT,
};
pub use preserve::{volume, Preserve};

use crate::mesh::TriMesh;
use crate::solve::{CsrMatrix, SolveError, SolveInfo};
use crate::SparseMatrix;
use serde::Serialize;
use std::time::Instant;

/// Errors of the filters. The parameter errors name the rule broken; the fix is a
/// parameter within it.
#[derive(Debug, thiserror::Error)]
pub enum FilterError {
    /// A linear solve failed (see [`SolveError`] for causes).
    #[error(transparent)]
    Solve(#[from] SolveError),
    /// A parameter that must be positive and finite is not.
    #[error("{name} must be positive and finite, got {value}")]
    NotPositive {
        /// The parameter.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// A parameter that must be a number ≥ 0 is not.
    #[error("{name} must be a number ≥ 0, got {value}")]
    NotNonNegative {
        /// The parameter.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// Zero steps.
    #[error("the {filter} filter needs at least one step")]
    NoSteps {
        /// The filter.
        filter: FilterKind,
    },
    /// Taubin's pass-band must lie in (0, 1/λ) so that μ < −λ.
    #[error("Taubin needs 0 < k_PB < 1/λ = {limit}, got k_PB = {k_pb}")]
    TaubinPassband {
        /// The pass-band given.
        k_pb: f64,
        /// 1/λ.
        limit: f64,
    },
    /// The Butterworth order is 0.
    #[error("the Butterworth order must be at least 1")]
    ZeroOrder,
    /// The Butterworth and ideal filters have no default pass-band.
    #[error("the {filter} filter needs a pass-band γ_PB (an eigenvalue of the operator)")]
    MissingPassband {
        /// The filter.
        filter: FilterKind,
    },
    /// The operator does not fit the mesh.
    #[error("the operator is {rows}×{cols} for {n} vertices")]
    OperatorSize {
        /// Rows.
        rows: usize,
        /// Columns.
        cols: usize,
        /// Vertices.
        n: usize,
    },
    /// The positions do not fit the operator.
    #[error("{len} coordinates for an operator on {n} vertices")]
    Positions {
        /// Coordinates given.
        len: usize,
        /// n.
        n: usize,
    },
    /// The solver needs a symmetric operator (CG, PCG, Cholesky); use one for
    /// non-symmetric systems (BiCG, CG on the symmetrized system, BiCGSTAB, LU).
    #[error("solver {solver} needs a symmetric operator; this one is not")]
    NeedsSymmetric {
        /// The solver asked for.
        solver: SolverKind,
    },
    /// No positive diagonal S makes `S·F` symmetric.
    #[error("{what} needs an operator with a positive diagonal symmetrizer (TL, SDL, mean-value, or any symmetric one)")]
    NoSymmetrizer {
        /// Which computation.
        what: &'static str,
    },
    /// The dense ED transform is limited to small meshes.
    #[error(
        "the ideal low-pass needs a dense eigendecomposition; n = {n} is above the limit {limit}"
    )]
    TooLarge {
        /// Mesh size.
        n: usize,
        /// The limit.
        limit: usize,
    },
    /// The dense symmetric eigensolver did not converge.
    #[error("the dense eigendecomposition of the ideal low-pass did not converge")]
    EigenNoConvergence,
    /// Not the name of a filter, solver or rescaling.
    #[error("unknown {what} `{got}`")]
    UnknownName {
        /// What was named.
        what: &'static str,
        /// The name given.
        got: String,
    },
}

impl FilterError {
    /// What the solver did before it stopped at the iteration cap, if that is why the
    /// filter failed ([`SolveError::unconverged`]).
    pub fn unconverged(&self) -> Option<SolveInfo> {
        match self {
            FilterError::Solve(e) => e.unconverged(),
            _ => None,
        }
    }
}

/// What [`apply`] did.
#[derive(Clone, Debug, Default, Serialize)]
pub struct FilterReport {
    /// The solver implicit fairing used ([`SolverKind::Auto`] resolved).
    pub solver: Option<SolverKind>,
    /// Solver information per solve (implicit steps, Butterworth factors).
    pub solves: Vec<SolveInfo>,
    /// Iterations per coordinate column, summed over the solves (0 for direct ones).
    pub iterations: Vec<usize>,
    /// Seconds spent in linear solves.
    pub solve_seconds: f64,
    /// Final relative residuals `‖Bx − b‖/‖b‖` per column of the last solve.
    pub residuals: Vec<f64>,
    /// Total seconds (assembly of the systems, factorizations, solves, rescaling).
    pub seconds: f64,
    /// Enclosed volume before (signed).
    pub volume_before: f64,
    /// Enclosed volume after filtering and rescaling.
    pub volume_after: f64,
}

fn flat(p: &[[f64; 3]]) -> Vec<f64> {
    p.iter().flat_map(|v| v.iter().copied()).collect()
}
fn unflat(x: &[f64]) -> Vec<[f64; 3]> {
    x.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}

/// Filters `mesh`'s positions with the n×n operator `f` (`F = D − W`, n the vertex
/// count) and rescales as `preserve` says. Returns the new positions (same vertex
/// order) and a report.
pub fn apply(
    mesh: &TriMesh,
    f: &SparseMatrix,
    filter: &Filter,
    preserve: Preserve,
) -> Result<(Vec<[f64; 3]>, FilterReport), FilterError> {
    let start = Instant::now();
    let n = mesh.n_vertices();
    if f.nrows() != n || f.ncols() != n {
        return Err(FilterError::OperatorSize {
            rows: f.nrows(),
            cols: f.ncols(),
            n,
        });
    }
    filter.validate()?;
    let mut report = FilterReport {
        volume_before: volume(&mesh.positions, &mesh.faces),
        ..Default::default()
    };
    let mut x = flat(&mesh.positions);
    match filter {
        Filter::Implicit(o) => {
            let mut solver = ImplicitSolver::new(f, o.lambda, o.solver)?;
            report.solver = Some(solver.kind());
            report.solves = solver.fair(&mut x, o.steps, &o.params)?;
        }
        Filter::Explicit(o) => polynomial::explicit(&CsrMatrix::from_csc(f), &mut x, o)?,
        Filter::Taubin(o) => polynomial::taubin(&CsrMatrix::from_csc(f), &mut x, o)?,
        Filter::Butterworth(o) => report.solves = butterworth::butterworth(f, &mut x, o)?,
        Filter::Ideal(o) => x = ideal::ideal_lowpass(f, &x, o)?,
    }
    let mut out = unflat(&x);
    preserve::rescale(mesh, &mut out, preserve);
    report.volume_after = volume(&out, &mesh.faces);
    report.seconds = start.elapsed().as_secs_f64();
    let cols = report.solves.first().map_or(0, |i| i.iterations().len());
    report.iterations = (0..cols)
        .map(|c| report.solves.iter().map(|i| i.iterations()[c]).sum())
        .collect();
    if let Some(last) = report.solves.last() {
        report.residuals = last.residuals().to_vec();
    }
    report.solve_seconds = report.solves.iter().map(SolveInfo::seconds).sum();
    Ok((out, report))
}

#[cfg(test)]
pub(crate) mod test_util {
    use crate::mesh::{builtin, topology::Topology, TriMesh};

    /// A level-2 icosphere with every vertex pushed out by up to 5%: noise to remove.
    pub fn bumpy_sphere() -> (TriMesh, Topology) {
        let mut m = builtin::icosphere(2).unwrap();
        for (i, p) in m.positions.iter_mut().enumerate() {
            let s = 1.0 + 0.05 * ((i * 7919) % 13) as f64 / 13.0;
            *p = p.map(|c| c * s);
        }
        let t = Topology::new(&m).unwrap();
        (m, t)
    }

    /// The n×3 row-major positions.
    pub fn positions(m: &TriMesh) -> Vec<f64> {
        super::flat(&m.positions)
    }
}

#[cfg(test)]
mod tests {
    use super::test_util::bumpy_sphere;
    use super::*;
    use crate::mesh::{builtin, topology::Topology};
    use crate::operator::{kirchhoff::kirchhoff, tutte::tutte};

    fn implicit(lambda: f64, steps: usize, solver: SolverKind) -> Filter {
        Filter::Implicit(ImplicitOptions {
            lambda,
            steps,
            solver,
            ..Default::default()
        })
    }

    #[test]
    fn report_sums_iterations_and_keeps_the_last_residuals() {
        let (m, t) = bumpy_sphere();
        let f = kirchhoff(&t);
        let (_, r) = apply(&m, &f, &implicit(2.0, 3, SolverKind::Cg), Preserve::None).unwrap();
        assert_eq!(r.solves.len(), 3);
        for c in 0..3 {
            let sum: usize = r.solves.iter().map(|i| i.iterations()[c]).sum();
            assert_eq!(r.iterations[c], sum);
            assert!(r.iterations[c] > 0);
        }
        assert_eq!(r.residuals, r.solves[2].residuals());
        assert!(r.volume_after.abs() < r.volume_before.abs());
    }

    #[test]
    fn auto_picks_cg_for_a_symmetric_operator_and_bicg_otherwise() {
        let (m, t) = bumpy_sphere();
        let auto = implicit(5.0, 1, SolverKind::Auto);
        let (_, r) = apply(&m, &kirchhoff(&t), &auto, Preserve::None).unwrap();
        assert_eq!(r.solver, Some(SolverKind::Cg));
        assert!(matches!(r.solves[0], SolveInfo::Iterative(_)));
        let (x, r) = apply(&m, &tutte(&t).unwrap(), &auto, Preserve::None).unwrap();
        assert_eq!(r.solver, Some(SolverKind::Bicg));
        assert!(r.solves[0].plateau_at().is_some());
        let (y, _) = apply(
            &m,
            &tutte(&t).unwrap(),
            &implicit(5.0, 1, SolverKind::Bicg),
            Preserve::None,
        )
        .unwrap();
        assert_eq!(x, y);
        // Filters without a linear solve report no solver.
        let explicit = Filter::Explicit(ExplicitOptions::default());
        let (_, r) = apply(&m, &tutte(&t).unwrap(), &explicit, Preserve::None).unwrap();
        assert_eq!((r.solver, r.solves.len()), (None, 0));
    }

    #[test]
    fn preserve_volume_restores_the_volume() {
        let (m, t) = bumpy_sphere();
        let v0 = volume(&m.positions, &m.faces);
        let filter = Filter::Explicit(ExplicitOptions {
            lambda: 0.05,
            steps: 10,
        });
        let (out, r) = apply(&m, &kirchhoff(&t), &filter, Preserve::Volume).unwrap();
        assert!((volume(&out, &m.faces) - v0).abs() < 1e-12 * v0.abs());
        assert!((r.volume_after - v0).abs() < 1e-12);
    }

    #[test]
    fn bad_parameters_are_errors() {
        let (m, t) = bumpy_sphere();
        let f = tutte(&t).unwrap();
        let bad = [
            Filter::Explicit(ExplicitOptions {
                lambda: -1.0,
                steps: 1,
            }),
            Filter::Taubin(TaubinOptions {
                lambda: 0.5,
                k_pb: 3.0,
                steps: 1,
            }),
            Filter::Butterworth(ButterworthOptions {
                order: 0,
                passband: 0.1,
            }),
            implicit(1.0, 0, SolverKind::Lu),
        ];
        for b in bad {
            assert!(apply(&m, &f, &b, Preserve::None).is_err(), "{b:?}");
        }
        let small = Filter::Ideal(IdealOptions {
            passband: 0.1,
            dense_limit: 10,
        });
        assert!(matches!(
            apply(&m, &f, &small, Preserve::None),
            Err(FilterError::TooLarge { .. })
        ));
        let wrong = kirchhoff(&Topology::new(&builtin::icosahedron()).unwrap());
        let ideal = Filter::Ideal(IdealOptions::new(0.1));
        assert!(matches!(
            apply(&m, &wrong, &ideal, Preserve::None),
            Err(FilterError::OperatorSize { .. })
        ));
    }
}
