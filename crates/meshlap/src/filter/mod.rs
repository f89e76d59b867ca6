//! Mesh filters built on an operator F (sign convention `F = D − W`, so `−F·x` is the
//! Laplacian vector pointing towards the neighbours): every filter is a function of
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
//! [`apply`] runs one of them on a mesh and rescales afterwards ([`preserve`]); the
//! paper's Table 1 (CG vs BiCG for implicit fairing) is [`crate::experiment::fairing`].

pub mod butterworth;
pub mod ideal;
pub mod implicit;
pub mod polynomial;
pub mod preserve;

pub use implicit::{implicit_fairing, ImplicitSolver, SolverKind};
pub use preserve::{volume, Preserve};

use crate::mesh::TriMesh;
use crate::solve::{CsrMatrix, Info, Params, SolveError};
use crate::SparseMatrix;
use serde::Serialize;
use std::time::Instant;

/// Errors of the filters.
#[derive(Debug, thiserror::Error)]
pub enum FilterError {
    /// A linear solve failed.
    #[error(transparent)]
    Solve(#[from] SolveError),
    /// A parameter is out of range.
    #[error("{0}")]
    InvalidParameter(String),
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
    /// The operator has no real spectrum the filter can use.
    #[error("{0}")]
    Spectrum(String),
}

/// Which filter; see the module documentation.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum Filter {
    /// `N` implicit steps `(I + λF)x' = x`.
    Implicit {
        /// λ > 0.
        lambda: f64,
        /// Steps N ≥ 1.
        steps: usize,
        /// The solver.
        solver: SolverKind,
    },
    /// `N` explicit steps `x' = (I − λF)x`.
    Explicit {
        /// λ > 0.
        lambda: f64,
        /// Steps.
        steps: usize,
    },
    /// `N` Taubin λ|μ pairs with pass-band `k_PB = 1/λ + 1/μ`.
    Taubin {
        /// λ > 0.
        lambda: f64,
        /// Pass-band frequency `k_PB` (0 < k_PB < 1/λ).
        k_pb: f64,
        /// Pairs.
        steps: usize,
    },
    /// Butterworth low-pass of order `order` and pass-band `passband`.
    Butterworth {
        /// Order s ≥ 1.
        order: usize,
        /// γ_PB > 0.
        passband: f64,
    },
    /// Ideal low-pass: keep the ED components with eigenvalue ≤ `passband`.
    Ideal {
        /// γ_PB.
        passband: f64,
    },
}

/// Default size limit of the dense ideal filter: a 3000×3000 eigendecomposition
/// needs about 150 MB and some seconds (the paper's cow, 2,903 vertices, fits).
pub const DEFAULT_DENSE_LIMIT: usize = 3000;

/// What [`apply`] did.
#[derive(Clone, Debug, Default, Serialize)]
pub struct FilterReport {
    /// Solver information per solve (implicit steps, Butterworth factors).
    pub solves: Vec<Info>,
    /// Iterations per coordinate column, summed over the solves (0 for direct ones).
    pub iterations: Vec<usize>,
    /// Seconds spent in linear solves.
    pub solve_seconds: f64,
    /// Final relative residuals `‖Bx − b‖/‖b‖` per column of the last solve.
    pub residuals: Vec<f64>,
    /// Total seconds (assembly of the systems, factorisations, solves, rescaling).
    pub seconds: f64,
    /// Enclosed volume before (signed).
    pub volume_before: f64,
    /// Enclosed volume after filtering and rescaling.
    pub volume_after: f64,
}

/// Options of [`apply`].
#[derive(Clone, Copy, Debug, Default)]
pub struct FilterOptions {
    /// Iterative-solver parameters (tolerance, stopping criterion, cap).
    pub params: Params,
    /// Rescaling afterwards.
    pub preserve: Preserve,
    /// Largest n for the dense ideal filter ([`DEFAULT_DENSE_LIMIT`] when 0).
    pub dense_limit: usize,
}

fn flat(p: &[[f64; 3]]) -> Vec<f64> {
    p.iter().flat_map(|v| v.iter().copied()).collect()
}
fn unflat(x: &[f64]) -> Vec<[f64; 3]> {
    x.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}

fn positive(v: f64, name: &str) -> Result<(), FilterError> {
    if v > 0.0 && v.is_finite() {
        Ok(())
    } else {
        Err(FilterError::InvalidParameter(format!(
            "{name} must be positive and finite, got {v}"
        )))
    }
}

/// Filters `mesh`'s positions with operator `f` (n×n, `F = D − W`). Returns the new
/// positions (same vertex order) and a report.
pub fn apply(
    mesh: &TriMesh,
    f: &SparseMatrix,
    filter: &Filter,
    opts: &FilterOptions,
) -> Result<(Vec<[f64; 3]>, FilterReport), FilterError> {
    let start = Instant::now();
    let n = mesh.n_vertices();
    if f.nrows() != n || f.ncols() != n {
        return Err(FilterError::InvalidParameter(format!(
            "operator is {}×{} for {n} vertices",
            f.nrows(),
            f.ncols()
        )));
    }
    let mut report = FilterReport {
        volume_before: volume(&mesh.positions, &mesh.faces),
        ..Default::default()
    };
    let mut x = flat(&mesh.positions);
    match *filter {
        Filter::Implicit {
            lambda,
            steps,
            solver,
        } => {
            report.solves = implicit_fairing(f, &mut x, lambda, steps, solver, &opts.params)?;
        }
        Filter::Explicit { lambda, steps } => {
            positive(lambda, "λ")?;
            polynomial::explicit(&CsrMatrix::from_csc(f), &mut x, lambda, steps);
        }
        Filter::Taubin {
            lambda,
            k_pb,
            steps,
        } => {
            polynomial::taubin(&CsrMatrix::from_csc(f), &mut x, lambda, k_pb, steps)?;
        }
        Filter::Butterworth { order, passband } => {
            report.solves = butterworth::butterworth(f, &mut x, order, passband)?;
        }
        Filter::Ideal { passband } => {
            let limit = if opts.dense_limit == 0 {
                DEFAULT_DENSE_LIMIT
            } else {
                opts.dense_limit
            };
            if n > limit {
                return Err(FilterError::TooLarge { n, limit });
            }
            x = ideal::ideal_lowpass(f, &x, passband)?;
        }
    }
    let mut out = unflat(&x);
    preserve::rescale(mesh, &mut out, opts.preserve);
    report.volume_after = volume(&out, &mesh.faces);
    report.seconds = start.elapsed().as_secs_f64();
    let cols = report.solves.first().map_or(0, |i| i.iterations.len());
    report.iterations = (0..cols)
        .map(|c| report.solves.iter().map(|i| i.iterations[c]).sum())
        .collect();
    if let Some(last) = report.solves.last() {
        report.residuals = last.residuals.clone();
    }
    report.solve_seconds = report.solves.iter().map(|i| i.seconds).sum();
    Ok((out, report))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{builtin, topology::Topology};
    use crate::operator::{kirchhoff::kirchhoff, tutte::tutte};

    fn sphere() -> (TriMesh, Topology) {
        let mut m = builtin::icosphere(2).unwrap();
        for (i, p) in m.positions.iter_mut().enumerate() {
            let s = 1.0 + 0.05 * ((i * 7919) % 13) as f64 / 13.0;
            *p = p.map(|c| c * s);
        }
        let t = Topology::new(&m).unwrap();
        (m, t)
    }

    #[test]
    fn report_sums_iterations_and_keeps_the_last_residuals() {
        let (m, t) = sphere();
        let f = kirchhoff(&t);
        let (_, r) = apply(
            &m,
            &f,
            &Filter::Implicit {
                lambda: 2.0,
                steps: 3,
                solver: SolverKind::Cg,
            },
            &FilterOptions::default(),
        )
        .unwrap();
        assert_eq!(r.solves.len(), 3);
        for c in 0..3 {
            let sum: usize = r.solves.iter().map(|i| i.iterations[c]).sum();
            assert_eq!(r.iterations[c], sum);
            assert!(r.iterations[c] > 0);
        }
        assert_eq!(r.residuals, r.solves[2].residuals);
        assert!(r.volume_after.abs() < r.volume_before.abs());
    }

    #[test]
    fn preserve_volume_restores_the_volume() {
        let (m, t) = sphere();
        let v0 = volume(&m.positions, &m.faces);
        let o = FilterOptions {
            preserve: Preserve::Volume,
            ..Default::default()
        };
        let (out, r) = apply(
            &m,
            &kirchhoff(&t),
            &Filter::Explicit {
                lambda: 0.05,
                steps: 10,
            },
            &o,
        )
        .unwrap();
        assert!((volume(&out, &m.faces) - v0).abs() < 1e-12 * v0.abs());
        assert!((r.volume_after - v0).abs() < 1e-12);
    }

    #[test]
    fn bad_parameters_are_errors() {
        let (m, t) = sphere();
        let f = tutte(&t).unwrap();
        let o = FilterOptions::default();
        let bad = [
            Filter::Explicit {
                lambda: -1.0,
                steps: 1,
            },
            Filter::Taubin {
                lambda: 0.5,
                k_pb: 3.0,
                steps: 1,
            },
            Filter::Butterworth {
                order: 0,
                passband: 0.1,
            },
            Filter::Implicit {
                lambda: 1.0,
                steps: 0,
                solver: SolverKind::Lu,
            },
        ];
        for b in bad {
            assert!(apply(&m, &f, &b, &o).is_err(), "{b:?}");
        }
        let small = FilterOptions {
            dense_limit: 10,
            ..Default::default()
        };
        assert!(matches!(
            apply(&m, &f, &Filter::Ideal { passband: 0.1 }, &small),
            Err(FilterError::TooLarge { .. })
        ));
        let wrong = kirchhoff(&Topology::new(&builtin::icosahedron()).unwrap());
        assert!(apply(&m, &wrong, &Filter::Ideal { passband: 0.1 }, &o).is_err());
    }
}
