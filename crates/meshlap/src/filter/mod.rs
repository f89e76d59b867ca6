//! Mesh filters built on an operator F (sign convention `F = D − W`, so `−F·x` is the
//! Laplacian vector pointing towards the neighbours): every filter is a function of
//! F applied to the n×3 positions, `x' = h(F) x`, with frequency response h(γ) on F's
//! eigenvalues γ.
//!
//! | filter | h(γ) | reference |
//! |---|---|---|
//! | [`Filter::Implicit`] | `(1 + λγ)⁻ᴺ` (N solves of `(I + λF)x' = x`) | Desbrun et al. 1999; Zhang 2004 §4.10 |
//! | [`Filter::Explicit`] | `(1 − λγ)ᴺ` (Laplacian smoothing) | Taubin 1995 |
//! | [`Filter::Taubin`] | `((1 − λγ)(1 − μγ))ᴺ`, μ < −λ < 0 | Taubin 1995 |
//! | [`Filter::Butterworth`] | `1 / (1 + (γ/γ_PB)^{2s})` | Zhang & Fiume 2003 |
//! | [`Filter::Ideal`] | `[γ ≤ γ_PB]` through the dense ED transform | Zhang 2004 §2.6 |
//!
//! The Butterworth filter is factored over the 2s roots `r_k = e^{iπ(2k+1)/(2s)}` of
//! `r^{2s} = −1`: pairing conjugate roots gives
//! `1 + (γ/c)^{2s} = Π_{k<s} (1 − 2cos θ_k γ/c + γ²/c²)`, θ_k = π(2k+1)/(2s), so the
//! filter is s sparse solves with `Q_k = I − (2cos θ_k/c)F + F²/c²` — SPD for a
//! symmetric F (Cholesky, one symbolic analysis for all k), LU otherwise.

use crate::analysis::properties::diagonal_symmetrizer;
use crate::mesh::TriMesh;
use crate::solve::{
    self, cg::Preconditioner, direct::CholeskySolver, direct::LuSolver, CsrMatrix, Info, Params,
    SolveError, SparseOperator,
};
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

/// Linear solver of the implicit filter.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SolverKind {
    /// Conjugate gradients (symmetric F).
    Cg,
    /// Jacobi-preconditioned CG (symmetric F).
    Pcg,
    /// Bi-conjugate gradients (any F).
    Bicg,
    /// CG on the symmetrised system `S(I + λF)x = Sb`, S a positive diagonal with `S·F`
    /// symmetric (found from the entries; for the Tutte Laplacian S = D, giving the
    /// paper's `(D + λK)x = Db`, "CG (TL)").
    CgSym,
    /// faer's BiCGSTAB (any F).
    Bicgstab,
    /// Sparse Cholesky (symmetric F).
    Cholesky,
    /// Sparse LU (any F).
    Lu,
}

impl std::str::FromStr for SolverKind {
    type Err = FilterError;
    fn from_str(s: &str) -> Result<Self, FilterError> {
        Ok(match s {
            "cg" => SolverKind::Cg,
            "pcg" => SolverKind::Pcg,
            "bicg" => SolverKind::Bicg,
            "cg-sym" => SolverKind::CgSym,
            "bicgstab" => SolverKind::Bicgstab,
            "cholesky" => SolverKind::Cholesky,
            "lu" => SolverKind::Lu,
            _ => {
                return Err(FilterError::InvalidParameter(format!(
                    "unknown solver `{s}` (cg, pcg, bicg, cg-sym, bicgstab, cholesky, lu)"
                )))
            }
        })
    }
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

/// Rescaling after filtering, as pmp and libigl offer.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Preserve {
    /// No rescaling.
    #[default]
    None,
    /// Scale about the centroid to the input's enclosed volume (signed volume of the
    /// triangles about the centroid; meaningful for closed meshes).
    Volume,
    /// Scale uniformly to the input's bounding-box diagonal and re-centre on its
    /// bounding-box centre.
    BBox,
}

/// What [`apply`] did.
#[derive(Clone, Debug, Default, Serialize)]
pub struct FilterReport {
    /// Solver information per solve (implicit filter and Butterworth factors).
    pub solves: Vec<Info>,
    /// Iterations per column of the last solve (iterative solvers).
    pub iterations: Vec<usize>,
    /// Seconds spent in linear solves.
    pub solve_seconds: f64,
    /// Final relative residuals of the last solve.
    pub residuals: Vec<f64>,
    /// Total seconds.
    pub seconds: f64,
    /// Enclosed volume before and after (signed, about the centroid).
    pub volume_before: f64,
    /// See `volume_before`.
    pub volume_after: f64,
}

/// Options of [`apply`].
#[derive(Clone, Copy, Debug, Default)]
pub struct FilterOptions {
    /// Iterative-solver parameters (tolerance, stopping criterion, cap).
    pub params: Params,
    /// Rescaling afterwards.
    pub preserve: Preserve,
    /// Largest n for the dense ideal filter (default 5000 when 0).
    pub dense_limit: usize,
}

fn flat(p: &[[f64; 3]]) -> Vec<f64> {
    p.iter().flat_map(|v| v.iter().copied()).collect()
}
fn unflat(x: &[f64]) -> Vec<[f64; 3]> {
    x.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}

/// Filters `mesh`'s positions with operator `f` (n×n). Returns the new positions and a
/// report.
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
    let positive = |v: f64, name: &str| {
        if v > 0.0 && v.is_finite() {
            Ok(())
        } else {
            Err(FilterError::InvalidParameter(format!(
                "{name} must be positive, got {v}"
            )))
        }
    };
    match *filter {
        Filter::Implicit {
            lambda,
            steps,
            solver,
        } => {
            positive(lambda, "λ")?;
            implicit(
                f,
                lambda,
                steps.max(1),
                solver,
                &opts.params,
                &mut x,
                &mut report,
            )?;
        }
        Filter::Explicit { lambda, steps } => {
            positive(lambda, "λ")?;
            let a = CsrMatrix::from_csc(f);
            polynomial_steps(&a, &mut x, &vec![lambda; steps]);
        }
        Filter::Taubin {
            lambda,
            k_pb,
            steps,
        } => {
            positive(lambda, "λ")?;
            positive(k_pb, "k_PB")?;
            if k_pb >= 1.0 / lambda {
                return Err(FilterError::InvalidParameter(format!(
                    "Taubin needs k_PB < 1/λ = {}",
                    1.0 / lambda
                )));
            }
            let mu = 1.0 / (k_pb - 1.0 / lambda);
            let a = CsrMatrix::from_csc(f);
            let seq: Vec<f64> = (0..steps).flat_map(|_| [lambda, mu]).collect();
            polynomial_steps(&a, &mut x, &seq);
        }
        Filter::Butterworth { order, passband } => {
            positive(passband, "γ_PB")?;
            if order == 0 {
                return Err(FilterError::InvalidParameter(
                    "Butterworth order must be ≥ 1".into(),
                ));
            }
            butterworth(f, order, passband, &mut x, &mut report)?;
        }
        Filter::Ideal { passband } => {
            let limit = if opts.dense_limit == 0 {
                5000
            } else {
                opts.dense_limit
            };
            if n > limit {
                return Err(FilterError::TooLarge { n, limit });
            }
            x = ideal(f, passband, &x)?;
        }
    }
    let mut out = unflat(&x);
    match opts.preserve {
        Preserve::None => {}
        Preserve::Volume => {
            let v = volume(&out, &mesh.faces);
            if v.abs() > 0.0 && report.volume_before.abs() > 0.0 {
                let s = (report.volume_before / v).abs().cbrt();
                let c = centroid(&out);
                for p in &mut out {
                    for k in 0..3 {
                        p[k] = c[k] + s * (p[k] - c[k]);
                    }
                }
            }
        }
        Preserve::BBox => {
            let before = TriMesh::new(mesh.positions.clone(), vec![]);
            let after = TriMesh::new(out.clone(), vec![]);
            let (d0, d1) = (before.bbox_diagonal(), after.bbox_diagonal());
            if let (Some((l0, h0)), Some((l1, h1))) = (before.bounding_box(), after.bounding_box())
            {
                let s = if d1 > 0.0 { d0 / d1 } else { 1.0 };
                for p in &mut out {
                    for k in 0..3 {
                        let c0 = 0.5 * (l0[k] + h0[k]);
                        let c1 = 0.5 * (l1[k] + h1[k]);
                        p[k] = c0 + s * (p[k] - c1);
                    }
                }
            }
        }
    }
    report.volume_after = volume(&out, &mesh.faces);
    report.seconds = start.elapsed().as_secs_f64();
    if let Some(last) = report.solves.last() {
        report.iterations = last.iterations.clone();
        report.residuals = last.residuals.clone();
    }
    report.solve_seconds = report.solves.iter().map(|i| i.seconds).sum();
    Ok((out, report))
}

/// `x ← (I − t F) x` for each t of `seq`.
fn polynomial_steps(a: &CsrMatrix, x: &mut [f64], seq: &[f64]) {
    let mut y = vec![0.0; x.len()];
    for &t in seq {
        a.apply(x, &mut y, 3);
        for (xi, yi) in x.iter_mut().zip(&y) {
            *xi -= t * yi;
        }
    }
}

fn implicit(
    f: &SparseMatrix,
    lambda: f64,
    steps: usize,
    solver: SolverKind,
    params: &Params,
    x: &mut [f64],
    report: &mut FilterReport,
) -> Result<(), FilterError> {
    let b_mat = solve::shifted_system(f, None, lambda);
    let mut chol = None;
    let mut lu = None;
    for _ in 0..steps {
        let b = x.to_vec();
        let info = match solver {
            SolverKind::Cg | SolverKind::Pcg => {
                let op = SparseOperator::from_csr(b_mat.clone(), None);
                let pre = if solver == SolverKind::Pcg {
                    Preconditioner::Jacobi
                } else {
                    Preconditioner::None
                };
                solve::cg::cg(&op, &b, x, 3, params, pre)?
            }
            SolverKind::Bicg => {
                let csc = b_mat.to_csc();
                let op = SparseOperator::new(&csc, true);
                solve::bicg::bicg(&op, &b, x, 3, params, Preconditioner::None)?
            }
            SolverKind::CgSym => {
                let s = diagonal_symmetrizer(f).ok_or_else(|| {
                    FilterError::Spectrum("cg-sym needs an operator with a diagonal symmetrizer (TL, T², SDL, or any symmetric one)".into())
                })?;
                let sym = CsrMatrix::from_csc(&scale_rows(&b_mat.to_csc(), &s));
                let sb: Vec<f64> = b.iter().enumerate().map(|(j, v)| v * s[j / 3]).collect();
                let op = SparseOperator::from_csr(sym, None);
                solve::cg::cg(&op, &sb, x, 3, params, Preconditioner::None)?
            }
            SolverKind::Bicgstab => solve::bicgstab::bicgstab(&b_mat.to_csc(), &b, x, 3, params)?,
            SolverKind::Cholesky | SolverKind::Lu => {
                let t = Instant::now();
                if solver == SolverKind::Cholesky {
                    if chol.is_none() {
                        chol = Some(CholeskySolver::new(&b_mat.to_csc())?);
                    }
                    x.copy_from_slice(&b);
                    chol.as_ref().map(|c| c.solve_in_place(x, 3)).transpose()?;
                } else {
                    if lu.is_none() {
                        lu = Some(LuSolver::new(&b_mat.to_csc())?);
                    }
                    x.copy_from_slice(&b);
                    lu.as_ref().map(|c| c.solve_in_place(x, 3)).transpose()?;
                }
                let op = SparseOperator::from_csr(b_mat.clone(), None);
                Info {
                    iterations: vec![0; 3],
                    residuals: solve::relative_residuals(&op, x, &b, 3),
                    seconds: t.elapsed().as_secs_f64(),
                    plateau_at: vec![None; 3],
                    ..Default::default()
                }
            }
        };
        report.solves.push(info);
    }
    Ok(())
}

/// `diag(s)·A`.
fn scale_rows(a: &SparseMatrix, s: &[f64]) -> SparseMatrix {
    let mut m = a.clone();
    for j in 0..m.ncols() {
        let rows: Vec<usize> = m.row_idx_of_col_raw(j).to_vec();
        for (v, i) in m.val_of_col_mut(j).iter_mut().zip(rows) {
            *v *= s[i];
        }
    }
    m
}

fn butterworth(
    f: &SparseMatrix,
    order: usize,
    c: f64,
    x: &mut [f64],
    report: &mut FilterReport,
) -> Result<(), FilterError> {
    let a = CsrMatrix::from_csc(f);
    let a2 = a.matmul(&a);
    let symmetric = crate::analysis::properties::asymmetry(f) == 0.0;
    let ones = vec![1.0; f.nrows()];
    let mut chol: Option<CholeskySolver> = None;
    let mut lu: Option<LuSolver> = None;
    for k in 0..order {
        let theta = std::f64::consts::PI * (2 * k + 1) as f64 / (2 * order) as f64;
        // Q = I − (2cos θ/c) F + F²/c²
        let q = a2
            .add(1.0 / (c * c), &a, -2.0 * theta.cos() / c)
            .shifted(&ones, 1.0);
        let q = q.to_csc();
        let t = Instant::now();
        let b = x.to_vec();
        if symmetric {
            match &mut chol {
                Some(s) => s.refactor(&q)?,
                None => chol = Some(CholeskySolver::new(&q)?),
            }
            chol.as_ref().map(|s| s.solve_in_place(x, 3)).transpose()?;
        } else {
            match &mut lu {
                Some(s) => s.refactor(&q)?,
                None => lu = Some(LuSolver::new(&q)?),
            }
            lu.as_ref().map(|s| s.solve_in_place(x, 3)).transpose()?;
        }
        let op = SparseOperator::new(&q, false);
        report.solves.push(Info {
            iterations: vec![0; 3],
            residuals: solve::relative_residuals(&op, x, &b, 3),
            seconds: t.elapsed().as_secs_f64(),
            plateau_at: vec![None; 3],
            ..Default::default()
        });
    }
    Ok(())
}

/// Ideal low-pass through the dense ED transform: for symmetric F an orthogonal
/// projection; otherwise through the similarity `S^{1/2} F S^{-1/2}` given by a
/// diagonal symmetrizer (the TL's `D^{-1/2}` path).
fn ideal(f: &SparseMatrix, passband: f64, x: &[f64]) -> Result<Vec<f64>, FilterError> {
    let n = f.nrows();
    let s = diagonal_symmetrizer(f).ok_or_else(|| {
        FilterError::Spectrum("the ideal filter needs a symmetric or symmetrizable operator".into())
    })?;
    let r: Vec<f64> = s.iter().map(|v| v.sqrt()).collect();
    let mut d = f.to_dense();
    for j in 0..n {
        for i in 0..n {
            d[(i, j)] *= r[i] / r[j];
        }
    }
    for j in 0..n {
        for i in 0..j {
            let a = 0.5 * (d[(i, j)] + d[(j, i)]);
            d[(i, j)] = a;
            d[(j, i)] = a;
        }
    }
    let evd = d
        .self_adjoint_eigen(faer::Side::Lower)
        .map_err(|e| FilterError::Spectrum(format!("eigendecomposition failed: {e:?}")))?;
    let u = evd.U();
    let lam = evd.S();
    let mut out = vec![0.0; 3 * n];
    for m in 0..n {
        if lam[m] > passband {
            continue;
        }
        for c in 0..3 {
            // coefficient X = uᵀ S^{1/2} x; reconstruction S^{-1/2} u X
            let coef: f64 = (0..n).map(|i| u[(i, m)] * r[i] * x[3 * i + c]).sum();
            for i in 0..n {
                out[3 * i + c] += u[(i, m)] * coef / r[i];
            }
        }
    }
    Ok(out)
}

fn centroid(p: &[[f64; 3]]) -> [f64; 3] {
    let mut c = [0.0; 3];
    for v in p {
        for k in 0..3 {
            c[k] += v[k];
        }
    }
    c.map(|s| s / p.len().max(1) as f64)
}

/// Signed volume enclosed by the triangles, measured about the centroid.
pub fn volume(p: &[[f64; 3]], faces: &[[u32; 3]]) -> f64 {
    let c = centroid(p);
    faces
        .iter()
        .map(|f| {
            let [a, b, d] = f.map(|v| {
                let q = p[v as usize];
                [q[0] - c[0], q[1] - c[1], q[2] - c[2]]
            });
            (a[0] * (b[1] * d[2] - b[2] * d[1]) - a[1] * (b[0] * d[2] - b[2] * d[0])
                + a[2] * (b[0] * d[1] - b[1] * d[0]))
                / 6.0
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{builtin, topology::Topology};
    use crate::operator::{kirchhoff::kirchhoff, sql::sql, tutte::tutte};

    fn sphere() -> (TriMesh, Topology) {
        let mut m = builtin::icosphere(2).unwrap();
        // make it bumpy so filters have something to remove
        for (i, p) in m.positions.iter_mut().enumerate() {
            let s = 1.0 + 0.05 * ((i * 7919) % 13) as f64 / 13.0;
            *p = p.map(|c| c * s);
        }
        let t = Topology::new(&m).unwrap();
        (m, t)
    }

    #[test]
    fn butterworth_response_matches_the_analytic_filter() {
        let (m, t) = sphere();
        let f = sql(&t, Default::default()).unwrap();
        let evd = f.to_dense().self_adjoint_eigen(faer::Side::Lower).unwrap();
        let n = m.n_vertices();
        let (order, pb) = (3usize, 0.4);
        for idx in [1usize, 20, 60, n - 1] {
            let gamma = evd.S()[idx];
            let e: Vec<[f64; 3]> = (0..n).map(|i| [evd.U()[(i, idx)], 0.0, 0.0]).collect();
            let mm = TriMesh::new(e.clone(), m.faces.clone());
            let (out, _) = apply(
                &mm,
                &f,
                &Filter::Butterworth {
                    order,
                    passband: pb,
                },
                &FilterOptions::default(),
            )
            .unwrap();
            let h = 1.0 / (1.0 + (gamma / pb).powi(2 * order as i32));
            for i in 0..n {
                assert!((out[i][0] - h * e[i][0]).abs() < 1e-10, "γ={gamma}");
            }
        }
    }

    #[test]
    fn implicit_solvers_agree() {
        let (m, t) = sphere();
        let f = tutte(&t).unwrap();
        let params = Params {
            stopping: solve::Stopping::Strong,
            tolerance: 1e-11,
            ..Default::default()
        };
        let opts = FilterOptions {
            params,
            ..Default::default()
        };
        let run = |solver| {
            apply(
                &m,
                &f,
                &Filter::Implicit {
                    lambda: 5.0,
                    steps: 1,
                    solver,
                },
                &opts,
            )
            .unwrap()
            .0
        };
        let want = run(SolverKind::Lu);
        for s in [SolverKind::Bicg, SolverKind::CgSym, SolverKind::Bicgstab] {
            let got = run(s);
            let err = got
                .iter()
                .zip(&want)
                .flat_map(|(a, b)| (0..3).map(move |k| (a[k] - b[k]).abs()))
                .fold(0.0, f64::max);
            assert!(err < 1e-8, "{s:?}: {err}");
        }
        let fs = sql(&t, Default::default()).unwrap();
        let runs = |solver| {
            apply(
                &m,
                &fs,
                &Filter::Implicit {
                    lambda: 5.0,
                    steps: 2,
                    solver,
                },
                &opts,
            )
            .unwrap()
            .0
        };
        let want = runs(SolverKind::Cholesky);
        for s in [SolverKind::Cg, SolverKind::Pcg] {
            let got = runs(s);
            let err = got
                .iter()
                .zip(&want)
                .flat_map(|(a, b)| (0..3).map(move |k| (a[k] - b[k]).abs()))
                .fold(0.0, f64::max);
            assert!(err < 1e-8, "{s:?}: {err}");
        }
    }

    #[test]
    fn taubin_shrinks_less_than_laplacian_smoothing() {
        let (m, t) = sphere();
        let f = tutte(&t).unwrap();
        let o = FilterOptions::default();
        let v0 = volume(&m.positions, &m.faces);
        let (lap, _) = apply(
            &m,
            &f,
            &Filter::Explicit {
                lambda: 0.5,
                steps: 20,
            },
            &o,
        )
        .unwrap();
        let (tau, _) = apply(
            &m,
            &f,
            &Filter::Taubin {
                lambda: 0.5,
                k_pb: 0.1,
                steps: 10,
            },
            &o,
        )
        .unwrap();
        let (vl, vt) = (volume(&lap, &m.faces), volume(&tau, &m.faces));
        assert!(vl < 0.95 * v0, "{vl} {v0}");
        assert!(
            (vt - v0).abs() < (vl - v0).abs() / 4.0,
            "taubin {vt}, laplacian {vl}, input {v0}"
        );
    }

    #[test]
    fn preserve_volume_and_ideal_filter() {
        let (m, t) = sphere();
        let f = kirchhoff(&t);
        let v0 = volume(&m.positions, &m.faces);
        let o = FilterOptions {
            preserve: Preserve::Volume,
            ..Default::default()
        };
        let (out, r) = apply(
            &m,
            &f,
            &Filter::Explicit {
                lambda: 0.05,
                steps: 10,
            },
            &o,
        )
        .unwrap();
        assert!((volume(&out, &m.faces) - v0).abs() < 1e-12 * v0.abs());
        assert!((r.volume_after - v0).abs() < 1e-12);
        // ideal filter with a pass-band above λ_max is the identity; at 0 it keeps the centroid
        let (same, _) = apply(
            &m,
            &f,
            &Filter::Ideal { passband: 1e9 },
            &FilterOptions::default(),
        )
        .unwrap();
        for (a, b) in same.iter().zip(&m.positions) {
            for k in 0..3 {
                assert!((a[k] - b[k]).abs() < 1e-10);
            }
        }
        let (flat0, _) = apply(
            &m,
            &tutte(&t).unwrap(),
            &Filter::Ideal { passband: 1e-9 },
            &FilterOptions::default(),
        )
        .unwrap();
        assert!(flat0
            .windows(2)
            .all(|w| (0..3).all(|k| (w[0][k] - w[1][k]).abs() < 1e-10)));
    }

    #[test]
    fn bad_parameters_are_errors() {
        let (m, t) = sphere();
        let f = tutte(&t).unwrap();
        let o = FilterOptions::default();
        assert!(apply(
            &m,
            &f,
            &Filter::Explicit {
                lambda: -1.0,
                steps: 1
            },
            &o
        )
        .is_err());
        assert!(apply(
            &m,
            &f,
            &Filter::Taubin {
                lambda: 0.5,
                k_pb: 3.0,
                steps: 1
            },
            &o
        )
        .is_err());
        assert!(apply(
            &m,
            &f,
            &Filter::Butterworth {
                order: 0,
                passband: 0.1
            },
            &o
        )
        .is_err());
    }
}
