//! The paper's Table 1 (Zhang 2004 §4.10): implicit fairing `(I + λF)x = b` of a
//! mesh's n×3 positions with three solver/system pairs, at several λ, with the weak
//! stopping criterion ε = 1e-5:
//!
//! - **CG (SQL)**: CG on `(I + λS)x = b`, S the symmetric quasi-Laplacian;
//! - **CG (TL)**: CG on the symmetrized Tutte system `(D + λK)x = Db`;
//! - **BiCG (TL)**: BiCG on `(I + λT)x = b`.
//!
//! Every result is compared with the direct solution of the same system (sparse
//! Cholesky of `I + λS`, and of `D + λK` for both TL systems — they have the same
//! solution), so the paper's remark that the weak criterion stops BiCG on a residual
//! "plateau" is measured: `error` is the largest vertex displacement from the direct
//! solution over the bounding-box diagonal. The BiCG plateau detector of
//! [`crate::solve::bicg()`] is reported too.
//!
//! The SQL can have negative weights (Zhang §3.7), and then `I + λS` may be
//! indefinite. They are counted; with [`FairingOptions::repair_sql`] they are first
//! removed by edge swaps ([`crate::analysis::repair`]; the CG (SQL) rows then run on
//! the swapped connectivity); a CG or Cholesky failure is recorded in the row
//! (`failure`), never hidden.
//!
//! Times are wall-clock seconds of the solve alone (systems assembled beforehand),
//! the median of [`FairingOptions::repeat`] runs, each from the initial guess x⁰ = b.
//! [`run`] makes the tables of every mesh of [`FairingOptions::meshes`] and writes
//! them. Operators use the sign `F = D − W`.

use super::meshes::{open, shared, DEFAULT_MESH_DIR};
use super::{sig, ExperimentError, Outputs, Progress, ProgressFn, Table};
use crate::analysis::repair::{repair_sql, RepairOptions};
use crate::filter::implicit::{symmetrizer, ImplicitSolver, SolverKind};
use crate::filter::FilterError;
use crate::mesh::{topology::Topology, TriMesh};
use crate::operator::{sql::sql, tutte::tutte};
use crate::plot::{Chart, Scale, Series};
use crate::solve::{direct::CholeskySolver, Params, SolveError, SolveInfo, Stopping};
use serde::Serialize;
use std::path::Path;

/// Options of [`run`] and [`fairing_table`].
#[derive(Clone, Debug)]
pub struct FairingOptions {
    /// Meshes of [`run`] (files or `builtin:` specs); the paper used cow, horse, bunny
    /// and Igea.
    pub meshes: Vec<String>,
    /// The λ values (paper: 30 and 100), positive.
    pub lambdas: Vec<f64>,
    /// Iterative-solver parameters (paper: weak criterion, ε = 1e-5).
    pub params: Params,
    /// Timed runs per solve; the median is reported (0 counts as 1).
    pub repeat: usize,
    /// Remove the SQL's negative weights by edge swaps first.
    pub repair_sql: bool,
}

default_is_paper!(FairingOptions);

impl FairingOptions {
    /// The paper's settings with its models (cow, horse, bunny, Igea) read from `dir`.
    pub fn paper(dir: &Path) -> Self {
        FairingOptions {
            meshes: ["cow.obj", "horse.ply", "stanford-bunny.obj", "igea.ply"]
                .iter()
                .map(|m| shared(dir, m))
                .collect(),
            lambdas: vec![30.0, 100.0],
            params: Params::default(),
            repeat: 3,
            repair_sql: false,
        }
    }

    /// The cow only ([`DEFAULT_MESH_DIR`]), one timed run.
    pub fn quick() -> Self {
        Self::quick_in(Path::new(DEFAULT_MESH_DIR))
    }

    /// The cow only, read from `dir`, one timed run.
    pub fn quick_in(dir: &Path) -> Self {
        FairingOptions {
            meshes: vec![shared(dir, "cow.obj")],
            repeat: 1,
            ..Self::paper(dir)
        }
    }

    fn validate(&self) -> Result<(), ExperimentError> {
        if self.lambdas.is_empty() || self.lambdas.iter().any(|l| !(*l > 0.0 && l.is_finite())) {
            return Err(ExperimentError::invalid(
                "lambdas",
                format!("needs positive values, got {:?}", self.lambdas),
            ));
        }
        let tol = self.params.tolerance;
        if !(tol > 0.0 && tol.is_finite()) {
            return Err(ExperimentError::invalid(
                "tolerance",
                format!("must be positive, got {tol}"),
            ));
        }
        Ok(())
    }
}

/// The settings a run used (the head of `table1.json`).
#[derive(Clone, Debug, Serialize)]
pub struct FairingSettings {
    /// λ values.
    pub lambdas: Vec<f64>,
    /// Stopping criterion.
    pub stop: Stopping,
    /// Its ε.
    pub tolerance: f64,
    /// Worker threads.
    pub threads: usize,
    /// Timed runs per solve.
    pub repeat: usize,
}

/// What [`run`] measured (serialized as `table1.json`).
#[derive(Clone, Debug, Serialize)]
pub struct FairingResults {
    /// The settings.
    #[serde(flatten)]
    pub settings: FairingSettings,
    /// One table per mesh.
    pub tables: Vec<FairingTable>,
    /// One Markdown table per λ.
    #[serde(skip)]
    pub markdown: Vec<Table>,
}

/// Table name of a mesh: the file stem, or the builtin spec with `-` for `:`.
pub fn mesh_name(spec: &str) -> String {
    if crate::input::is_builtin(spec) {
        spec.trim_start_matches("builtin:").replace(':', "-")
    } else {
        Path::new(spec)
            .file_stem()
            .map_or(spec.to_string(), |s| s.to_string_lossy().into_owned())
    }
}

/// Table 1 for every mesh of `opts`: writes `table1-lambdaL.md/.csv` per λ,
/// `convergence-MESH-lambdaL.png` per mesh and λ, and `table1.json` to `out`. Four
/// [`Progress::Step`]s per mesh and λ (the direct solutions, then each method).
pub fn run(
    opts: &FairingOptions,
    out: &mut Outputs,
    progress: &mut ProgressFn,
) -> Result<FairingResults, ExperimentError> {
    opts.validate()?;
    progress(Progress::start(
        "implicit fairing",
        opts.meshes.len() * opts.lambdas.len() * 4,
    ));
    let mut tables = Vec::new();
    for spec in &opts.meshes {
        let name = mesh_name(spec);
        progress(Progress::note(format!("{name}: loading")));
        let input = open(spec)?;
        tables.push(fairing_table(
            &name,
            &input.mesh,
            &input.topology,
            opts,
            progress,
        )?);
    }
    let settings = FairingSettings {
        lambdas: opts.lambdas.clone(),
        stop: opts.params.stopping,
        tolerance: opts.params.tolerance,
        threads: rayon::current_num_threads(),
        repeat: opts.repeat.max(1),
    };
    let markdown = write_outputs(out, &tables, &opts.lambdas, &settings)?;
    Ok(FairingResults {
        settings,
        tables,
        markdown,
    })
}

/// The solver/system pairs of Table 1.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// CG on `(I + λS)x = b`.
    CgSql,
    /// CG on `(D + λK)x = Db`.
    CgTl,
    /// BiCG on `(I + λT)x = b`.
    BicgTl,
}

impl Method {
    /// The three, in the paper's column order.
    pub const ALL: [Method; 3] = [Method::CgSql, Method::CgTl, Method::BicgTl];
    /// The paper's column heading.
    pub fn label(self) -> &'static str {
        match self {
            Method::CgSql => "CG (SQL)",
            Method::CgTl => "CG (TL)",
            Method::BicgTl => "BiCG (TL)",
        }
    }
}

/// One solve of Table 1.
#[derive(Clone, Debug, Serialize)]
pub struct Run {
    /// Which solver and system.
    pub method: Method,
    /// λ.
    pub lambda: f64,
    /// Median solve seconds.
    pub seconds: f64,
    /// Iterations per coordinate column.
    pub iterations: Vec<usize>,
    /// Relative residuals `‖(I + λF)x − b‖/‖b‖` per column at the stop.
    pub residuals: Vec<f64>,
    /// Largest vertex distance to the direct solution over the bounding-box diagonal.
    pub error: Option<f64>,
    /// BiCG: first iteration of a detected plateau, per column.
    pub plateau_at: Vec<Option<usize>>,
    /// Relative residual per iteration, per column (for the convergence plot).
    pub history: Vec<Vec<f64>>,
    /// Why the solve failed (e.g. not positive definite), if it did.
    pub failure: Option<String>,
}

/// Table 1 for one mesh.
#[derive(Clone, Debug, Serialize)]
pub struct FairingTable {
    /// Mesh name (file stem).
    pub name: String,
    /// Vertices.
    pub n: usize,
    /// Negative SQL weights (edges) of the input connectivity.
    pub sql_negative_weights: usize,
    /// Edge swaps made by the repair (when requested).
    pub sql_repair_flips: Option<usize>,
    /// Negative SQL weights left after the repair.
    pub sql_negative_after_repair: Option<usize>,
    /// The solves, per λ in the order of [`Method::ALL`].
    pub runs: Vec<Run>,
    /// The paper's figures for this model, if it is one of the paper's.
    pub paper: Option<PaperRow>,
}

/// A row of the paper's Table 1: seconds and iterations at λ = 30, iterations at 100.
#[derive(Copy, Clone, Debug, Serialize)]
pub struct PaperRow {
    /// Model.
    pub model: &'static str,
    /// Paper's vertex count.
    pub vertices: &'static str,
    /// CG (SQL), λ = 30: seconds, iterations.
    pub cg_30: (f64, usize),
    /// CG (TL), λ = 30.
    pub cg_tl_30: (f64, usize),
    /// BiCG (TL), λ = 30.
    pub bicg_30: (f64, usize),
    /// CG (SQL), λ = 100: iterations.
    pub cg_100: usize,
    /// BiCG (TL), λ = 100: iterations.
    pub bicg_100: usize,
}

/// A [`PaperRow`] from its cells, in the paper's column order.
const fn row(
    model: &'static str,
    vertices: &'static str,
    cg_30: (f64, usize),
    cg_tl_30: (f64, usize),
    bicg_30: (f64, usize),
    (cg_100, bicg_100): (usize, usize),
) -> PaperRow {
    PaperRow {
        model,
        vertices,
        cg_30,
        cg_tl_30,
        bicg_30,
        cg_100,
        bicg_100,
    }
}

/// The paper's Table 1 (seconds on its 2003 machine, \[iterations\]).
pub const PAPER_TABLE1: [PaperRow; 7] = [
    row("cow", "3K", (0.56, 15), (1.38, 37), (0.99, 15), (24, 30)),
    row("horse", "20K", (0.97, 15), (2.21, 34), (1.81, 15), (28, 30)),
    row("cube", "25K", (1.04, 12), (1.78, 21), (1.33, 9), (17, 17)),
    row("bunny", "36K", (1.67, 14), (3.66, 31), (3.75, 18), (24, 28)),
    row(
        "teeth",
        "116K",
        (4.60, 12),
        (12.65, 31),
        (9.94, 14),
        (21, 24),
    ),
    row(
        "igea",
        "134K",
        (4.91, 11),
        (13.07, 29),
        (9.18, 12),
        (16, 14),
    ),
    row(
        "isis",
        "187K",
        (9.03, 15),
        (23.56, 33),
        (11.27, 10),
        (22, 18),
    ),
];

/// The paper's row for a mesh name (matched on the name containing the model's).
pub fn paper_row(name: &str) -> Option<PaperRow> {
    let lower = name.to_ascii_lowercase();
    PAPER_TABLE1.into_iter().find(|r| lower.contains(r.model))
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        0.0
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn flat(p: &[[f64; 3]]) -> Vec<f64> {
    p.iter().flat_map(|v| v.iter().copied()).collect()
}

/// Largest vertex distance between two n×3 blocks over `scale`.
fn max_vertex_distance(a: &[f64], b: &[f64], scale: f64) -> f64 {
    a.chunks_exact(3)
        .zip(b.chunks_exact(3))
        .map(|(p, q)| {
            ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
        })
        .fold(0.0, f64::max)
        / scale
}

/// Times `solver` on `b` (median of `repeat`), returning the last solution and info.
fn timed(
    solver: &mut ImplicitSolver,
    b: &[f64],
    params: &Params,
    repeat: usize,
) -> Result<(Vec<f64>, SolveInfo, f64), FilterError> {
    let mut times = Vec::with_capacity(repeat.max(1));
    let mut last = None;
    for _ in 0..repeat.max(1) {
        let mut x = b.to_vec();
        let info = solver.solve(b, &mut x, params)?;
        times.push(info.seconds());
        last = Some((x, info));
    }
    let (x, info) = last.expect("at least one run");
    Ok((x, info, median(times)))
}

/// A run with what `info` recorded (BiCG's plateau, none for the other solvers).
fn recorded(method: Method, lambda: f64, seconds: f64, info: &SolveInfo) -> Run {
    let k = info.iterations().len();
    Run {
        method,
        lambda,
        seconds,
        iterations: info.iterations().to_vec(),
        residuals: info.residuals().to_vec(),
        error: None,
        plateau_at: info
            .plateau_at()
            .map_or_else(|| vec![None; k], <[_]>::to_vec),
        history: info.history().to_vec(),
        failure: None,
    }
}

fn failed(method: Method, lambda: f64, e: impl std::fmt::Display) -> Run {
    Run {
        method,
        lambda,
        seconds: f64::NAN,
        iterations: vec![],
        residuals: vec![],
        error: None,
        plateau_at: vec![],
        history: vec![],
        failure: Some(e.to_string()),
    }
}

/// Runs Table 1 on one mesh (cleaned, with its connectivity): a [`Progress::Step`]
/// before the direct solutions and before each method at each λ, a
/// [`Progress::Note`] before the SQL repair. `opts.meshes` is not read.
pub fn fairing_table(
    name: &str,
    mesh: &TriMesh,
    topo: &Topology,
    opts: &FairingOptions,
    progress: &mut ProgressFn,
) -> Result<FairingTable, ExperimentError> {
    table_of(name, mesh, topo, opts, progress).map_err(|e| ExperimentError::input(name, e))
}

fn table_of(
    name: &str,
    mesh: &TriMesh,
    topo: &Topology,
    opts: &FairingOptions,
    progress: &mut ProgressFn,
) -> crate::Result<FairingTable> {
    let n = mesh.n_vertices();
    let b = flat(&mesh.positions);
    let scale = mesh.bbox_diagonal().max(f64::MIN_POSITIVE);
    let tl = tutte(topo)?;
    let s_in = sql(topo, Default::default())?;
    let negatives = |s: &crate::SparseMatrix| {
        (0..s.ncols())
            .map(|j| {
                s.row_idx_of_col_raw(j)
                    .iter()
                    .zip(s.val_of_col(j))
                    .filter(|(&i, &v)| i > j && v > 0.0)
                    .count()
            })
            .sum::<usize>()
    };
    let mut table = FairingTable {
        name: name.to_string(),
        n,
        sql_negative_weights: negatives(&s_in),
        sql_repair_flips: None,
        sql_negative_after_repair: None,
        runs: Vec::new(),
        paper: paper_row(name),
    };
    let s = if opts.repair_sql && table.sql_negative_weights > 0 {
        progress(Progress::note(format!(
            "{name}: repairing SQL negative weights"
        )));
        let (fixed, report) = repair_sql(mesh, &RepairOptions::default())?;
        table.sql_repair_flips = Some(report.flips);
        table.sql_negative_after_repair = Some(report.negative_after);
        sql(&Topology::new(&fixed)?, Default::default())?
    } else {
        s_in
    };
    let s_tl = symmetrizer(&tl).ok_or_else(|| {
        crate::Error::InvalidArgument("the Tutte Laplacian has no diagonal symmetrizer".into())
    })?;
    for &lambda in &opts.lambdas {
        // Direct references.
        progress(Progress::step(format!(
            "{name}: λ = {lambda}: direct solutions"
        )));
        let mut cg_sql = ImplicitSolver::new(&s, lambda, SolverKind::Cg);
        let want_sql = cg_sql.as_ref().ok().and_then(|solver| {
            let chol = CholeskySolver::new(&solver.system_matrix().to_csc()).ok()?;
            let mut x = b.clone();
            chol.solve_in_place(&mut x, 3).ok()?;
            Some(x)
        });
        let mut cg_tl = ImplicitSolver::new(&tl, lambda, SolverKind::CgSym)?;
        let want_tl = {
            let chol =
                CholeskySolver::new(&cg_tl.system_matrix().to_csc()).map_err(SolveError::from)?;
            let mut x: Vec<f64> = b.iter().enumerate().map(|(j, v)| v * s_tl[j / 3]).collect();
            chol.solve_in_place(&mut x, 3).map_err(SolveError::from)?;
            x
        };
        let mut bicg = ImplicitSolver::new(&tl, lambda, SolverKind::Bicg)?;
        for method in Method::ALL {
            progress(Progress::step(format!(
                "{name}: λ = {lambda}: {}",
                method.label()
            )));
            let (solver, want) = match method {
                Method::CgSql => match &mut cg_sql {
                    Ok(s) => (s, want_sql.as_deref()),
                    Err(e) => {
                        table.runs.push(failed(method, lambda, e));
                        continue;
                    }
                },
                Method::CgTl => (&mut cg_tl, Some(want_tl.as_slice())),
                Method::BicgTl => (&mut bicg, Some(want_tl.as_slice())),
            };
            match timed(solver, &b, &opts.params, opts.repeat) {
                Ok((x, info, seconds)) => table.runs.push(Run {
                    error: want.map(|w| max_vertex_distance(&x, w, scale)),
                    failure: None,
                    ..recorded(method, lambda, seconds, &info)
                }),
                Err(e) => table.runs.push(match e.unconverged() {
                    Some(info) => Run {
                        failure: Some("no convergence within the cap".into()),
                        ..recorded(method, lambda, f64::NAN, &info)
                    },
                    None => failed(method, lambda, e),
                }),
            }
        }
    }
    Ok(table)
}

fn cell(r: Option<&Run>) -> String {
    match r {
        None => "–".into(),
        Some(r) if r.failure.is_some() && r.iterations.is_empty() => "failed".into(),
        Some(r) => {
            let it = r.iterations.iter().max().copied().unwrap_or(0);
            let mut s = format!("{:.4} [{it}]", r.seconds);
            if r.failure.is_some() {
                s.push_str(" (no conv.)");
            }
            s
        }
    }
}

fn find(t: &FairingTable, m: Method, l: f64) -> Option<&Run> {
    t.runs.iter().find(|r| r.method == m && r.lambda == l)
}

/// One [`Table`] per λ: our seconds [max iterations over the columns] with each
/// result's error against the direct solution, the first BiCG plateau and the paper's
/// figures; notes list negative SQL weights and failures.
pub fn tables(results: &[FairingTable], lambdas: &[f64]) -> Vec<Table> {
    lambdas
        .iter()
        .map(|&l| {
            let mut table = Table::new(
                format!("Implicit fairing, λ = {l}: seconds [iterations]; err = max vertex distance to the direct solution / bbox diagonal"),
                &[
                    "mesh", "n", "CG (SQL)", "err", "CG (TL)", "err", "BiCG (TL)", "err",
                    "BiCG plateau at", "paper CG", "paper CG (TL)", "paper BiCG",
                ],
            );
            for t in results {
                let (cs, ct, bi) = (
                    find(t, Method::CgSql, l),
                    find(t, Method::CgTl, l),
                    find(t, Method::BicgTl, l),
                );
                let err = |r: Option<&Run>| sig(r.and_then(|r| r.error), 2);
                let plateau = bi
                    .and_then(|r| r.plateau_at.iter().flatten().min().copied())
                    .map_or("none".to_string(), |p| p.to_string());
                let paper = |f: &dyn Fn(&PaperRow) -> String| t.paper.as_ref().map_or("–".into(), f);
                let (p1, p2, p3) = if l == 30.0 {
                    (
                        paper(&|p| format!("{} [{}]", p.cg_30.0, p.cg_30.1)),
                        paper(&|p| format!("{} [{}]", p.cg_tl_30.0, p.cg_tl_30.1)),
                        paper(&|p| format!("{} [{}]", p.bicg_30.0, p.bicg_30.1)),
                    )
                } else if l == 100.0 {
                    (
                        paper(&|p| format!("[{}]", p.cg_100)),
                        "–".into(),
                        paper(&|p| format!("[{}]", p.bicg_100)),
                    )
                } else {
                    ("–".into(), "–".into(), "–".into())
                };
                table.push(vec![
                    t.name.clone(),
                    t.n.to_string(),
                    cell(cs),
                    err(cs),
                    cell(ct),
                    err(ct),
                    cell(bi),
                    err(bi),
                    plateau,
                    p1,
                    p2,
                    p3,
                ]);
                if t.sql_negative_weights > 0 {
                    table.notes.push(match (t.sql_repair_flips, t.sql_negative_after_repair) {
                        (Some(f), Some(a)) => format!(
                            "{}: {} negative SQL weights, repaired by {f} edge swaps ({a} left)",
                            t.name, t.sql_negative_weights
                        ),
                        _ => format!(
                            "{}: {} negative SQL weights (not repaired)",
                            t.name, t.sql_negative_weights
                        ),
                    });
                }
                for r in t.runs.iter().filter(|r| r.failure.is_some() && r.lambda == l) {
                    table.notes.push(format!(
                        "{} {}: {}",
                        t.name,
                        r.method.label(),
                        r.failure.as_deref().unwrap_or("")
                    ));
                }
            }
            table
        })
        .collect()
}

/// Writes `table1-lambdaL.md`/`.csv` per λ, `table1.json` (`extra` and the results)
/// and `convergence-MESH-lambdaL.png` per mesh and λ.
pub fn write_outputs<T: Serialize>(
    out: &mut Outputs,
    results: &[FairingTable],
    lambdas: &[f64],
    extra: &T,
) -> Result<Vec<Table>, ExperimentError> {
    #[derive(Serialize)]
    struct Json<'a, T: Serialize> {
        #[serde(flatten)]
        extra: &'a T,
        tables: &'a [FairingTable],
    }
    let tabs = tables(results, lambdas);
    for (t, l) in tabs.iter().zip(lambdas) {
        out.table(&format!("table1-lambda{l}"), t)?;
    }
    for r in results {
        for &l in lambdas {
            out.chart(
                &format!("convergence-{}-lambda{l}.png", r.name),
                &convergence_chart(r, l),
            )?;
        }
    }
    out.json(
        "table1.json",
        &Json {
            extra,
            tables: results,
        },
    )?;
    Ok(tabs)
}

/// Convergence chart of one mesh at one λ: relative residual per iteration of each
/// method (the largest over the three coordinate columns still iterating).
pub fn convergence_chart(t: &FairingTable, lambda: f64) -> Chart {
    let series = t
        .runs
        .iter()
        .filter(|r| r.lambda == lambda && !r.history.is_empty())
        .map(|r| {
            let len = r.history.iter().map(Vec::len).max().unwrap_or(0);
            let pts = (0..len)
                .map(|i| {
                    let v = r
                        .history
                        .iter()
                        .filter_map(|h| h.get(i))
                        .fold(0.0f64, |a, &b| a.max(b));
                    (i as f64, v)
                })
                .collect();
            Series::new(r.method.label(), pts)
        })
        .collect();
    Chart::new(
        format!(
            "{} (n = {}), λ = {lambda}: implicit fairing convergence",
            t.name, t.n
        ),
        "iteration",
        "relative residual ||Bx - b|| / ||b|| (max over x, y, z)",
    )
    .with_scales(Scale::Linear, Scale::Log)
    .with_series(series)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;

    #[test]
    fn table_on_a_small_mesh_is_complete_and_accurate() {
        let m = builtin::icosphere(3).unwrap();
        let t = Topology::new(&m).unwrap();
        let opts = FairingOptions {
            lambdas: vec![30.0],
            repeat: 1,
            ..Default::default()
        };
        let tab = fairing_table("icosphere", &m, &t, &opts, &mut |_| {}).unwrap();
        assert_eq!(tab.runs.len(), 3);
        assert!(tab.paper.is_none());
        for r in &tab.runs {
            assert!(r.failure.is_none(), "{r:?}");
            assert_eq!(r.iterations.len(), 3);
            assert!(r.iterations.iter().all(|&i| i > 0));
            // weak criterion ε = 1e-5: close to the direct solution, not exact
            let e = r.error.unwrap();
            assert!(e < 1e-3 && e > 0.0, "{:?}: {e}", r.method);
            assert_eq!(r.history.len(), 3);
        }
        let tabs = tables(std::slice::from_ref(&tab), &[30.0]);
        assert_eq!(tabs.len(), 1);
        assert_eq!(
            tabs[0].rows[0][..2],
            ["icosphere".to_string(), "642".to_string()]
        );
        assert_eq!(tabs[0].rows[0].len(), tabs[0].header.len());
        let chart = convergence_chart(&tab, 30.0);
        assert_eq!(chart.series.len(), 3);
        assert!(chart.render_rgb().is_ok());
    }

    #[test]
    fn paper_rows_are_found_by_name() {
        assert_eq!(paper_row("stanford-bunny").unwrap().cg_30.1, 14);
        assert_eq!(paper_row("Igea").unwrap().bicg_100, 14);
        assert!(paper_row("teapot").is_none());
    }

    #[test]
    fn repair_option_removes_the_cow_sql_negative_weights_first() {
        let path = format!("{}/../../tests/data/cow.obj", env!("CARGO_MANIFEST_DIR"));
        let input = crate::input::open(&path, &Default::default()).unwrap();
        let opts = FairingOptions {
            lambdas: vec![30.0],
            repeat: 1,
            repair_sql: true,
            ..Default::default()
        };
        let tab = fairing_table("cow", &input.mesh, &input.topology, &opts, &mut |_| {}).unwrap();
        assert_eq!(tab.sql_negative_weights, 7);
        assert!(tab.sql_repair_flips.unwrap() > 0);
        assert!(tab.sql_negative_after_repair.unwrap() < 7);
        assert!(tab.runs.iter().all(|r| r.failure.is_none()));
        assert_eq!(tab.paper.unwrap().cg_30, (0.56, 15));
        let notes = &tables(&[tab], &[30.0])[0].notes;
        assert!(notes[0].contains("repaired by"), "{notes:?}");
    }
}
