//! `meshlap smooth`.

use crate::common::{print_json, spinner, MeshArgs};
use meshlap::filter::{apply, Filter, FilterOptions, FilterReport, Preserve, SolverKind};
use meshlap::io::{write_mesh, WriteOptions};
use meshlap::operator::{Operator, OperatorKind};
use meshlap::solve::{Params, Stopping};
use serde::Serialize;
use std::path::PathBuf;

/// Which filter `smooth` applies.
#[derive(Copy, Clone, Debug, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum FilterName {
    /// Implicit fairing: N solves of (I + λF)x' = x (Desbrun 1999; Zhang 2004 §4.10).
    Implicit,
    /// Explicit Laplacian smoothing x' = (I − λF)ᴺx.
    Explicit,
    /// Taubin λ|μ smoothing (non-shrinking), pass-band --kpb.
    Taubin,
    /// Butterworth low-pass of order --order and pass-band --passband (Zhang & Fiume 2003).
    Butterworth,
    /// Ideal low-pass through the dense eigendecomposition (small meshes only).
    Ideal,
}

/// Smooth (low-pass filter) a mesh with a Laplacian operator F and write the result.
///
/// Filters, by their response on an eigenvalue γ of F (operators use the paper's sign
/// F = D − W, so larger γ is higher frequency):
///   implicit     (1 + λγ)^−N   solves a sparse system per step (the paper's §4.10)
///   explicit     (1 − λγ)^N    Laplacian smoothing (shrinks)
///   taubin       ((1 − λγ)(1 − μγ))^N, 1/λ + 1/μ = kpb (does not shrink)
///   butterworth  1 / (1 + (γ/passband)^(2·order))
///   ideal        keeps γ ≤ passband exactly (dense eigendecomposition, ≤ 3000 vertices)
///
/// Implicit fairing solvers: cg and pcg (Jacobi) and cholesky need a symmetric
/// operator (kl, sql, sstl, gl, cotan); bicg, bicgstab and lu take any; cg-sym solves
/// the symmetrised system S(I + λF)x = Sb — for the Tutte Laplacian the paper's
/// "CG (TL)", (D + λK)x = Db. The SQL with negative weights may make the system
/// indefinite: that is reported as an error (run `meshlap repair-sql` first).
///
/// `--json` prints iterations per coordinate column, residuals, timings and volumes.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub mesh: MeshArgs,
    /// Output mesh (same connectivity, filtered positions).
    #[arg(long, short)]
    pub output: PathBuf,
    /// Filter to apply.
    #[arg(long, value_enum, default_value_t = FilterName::Implicit)]
    pub filter: FilterName,
    /// Shorthand for `--filter implicit`.
    #[arg(long, conflicts_with = "filter")]
    pub implicit: bool,
    /// Operator F: kirchhoff (kl), tutte (tl), graph (gl), sql, sstl, tutte2, sdl,
    /// cotan, mean-value.
    #[arg(long, short = 'k', default_value = "tutte")]
    pub operator: OperatorKind,
    /// λ: implicit (default 30, the paper's Table 1), explicit and taubin (default 0.5;
    /// keep λ·γ_max < 2 for stability: λ ≤ 1 for the TL).
    #[arg(long)]
    pub lambda: Option<f64>,
    /// Linear solver of implicit fairing (default: cg for a symmetric operator, bicg
    /// otherwise).
    #[arg(long, value_parser = ["cg", "pcg", "bicg", "cg-sym", "bicgstab", "cholesky", "lu"])]
    pub solver: Option<String>,
    /// Stopping criterion of the iterative solvers: weak (the paper's: the update of
    /// each coordinate column is below tol × its size), weak-vertex (the same per
    /// vertex), strong (‖Bx − b‖ < tol·‖b‖).
    #[arg(long = "stop", default_value = "weak", value_parser = ["weak", "weak-vertex", "strong"])]
    pub stop: String,
    /// Tolerance ε of the stopping criterion.
    #[arg(long, default_value_t = 1e-5)]
    pub tol: f64,
    /// Iteration cap of the iterative solvers.
    #[arg(long, default_value_t = 10_000)]
    pub max_iterations: usize,
    /// Steps: implicit solves (default 1), explicit steps (default 10), Taubin pairs
    /// (default 10).
    #[arg(long, short = 'n')]
    pub steps: Option<usize>,
    /// Taubin pass-band k_PB = 1/λ + 1/μ (0 < kpb < 1/λ).
    #[arg(long, default_value_t = 0.1)]
    pub kpb: f64,
    /// Butterworth order s.
    #[arg(long, default_value_t = 2)]
    pub order: usize,
    /// Pass-band γ_PB of the Butterworth and ideal filters (an eigenvalue of F).
    #[arg(long)]
    pub passband: Option<f64>,
    /// Rescale afterwards: volume (enclosed volume, closed meshes), bbox (bounding
    /// box) or none.
    #[arg(long, default_value = "none")]
    pub preserve: Preserve,
    /// Largest mesh for the dense ideal filter.
    #[arg(long, default_value_t = meshlap::filter::DEFAULT_DENSE_LIMIT)]
    pub dense_limit: usize,
    /// Print machine-readable JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct SmoothJson<'a> {
    filter: FilterName,
    operator: OperatorKind,
    vertices: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    lambda: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    solver: Option<SolverKind>,
    #[serde(skip_serializing_if = "Option::is_none")]
    stop: Option<Stopping>,
    #[serde(skip_serializing_if = "Option::is_none")]
    tolerance: Option<f64>,
    preserve: Preserve,
    iterations: &'a [usize],
    residuals: &'a [f64],
    solve_seconds: f64,
    seconds: f64,
    volume_before: f64,
    volume_after: f64,
    /// Per solve: iterations and residuals per column, relative-residual history and
    /// BiCG plateau.
    solves: &'a [meshlap::solve::Info],
    output: String,
}

fn invalid(msg: String) -> meshlap::Error {
    meshlap::Error::InvalidArgument(msg)
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let name = if args.implicit {
        FilterName::Implicit
    } else {
        args.filter
    };
    if !(args.tol > 0.0 && args.tol.is_finite()) {
        return Err(invalid(format!("--tol must be positive, got {}", args.tol)));
    }
    let input = args.mesh.open()?;
    let op = Operator::assemble(
        args.operator,
        &input.mesh,
        &input.topology,
        &Default::default(),
    )?;
    let stopping: Stopping = args.stop.parse()?;
    let params = Params {
        tolerance: args.tol,
        stopping,
        max_iterations: args.max_iterations,
        ..Default::default()
    };
    let passband = || {
        args.passband
            .ok_or_else(|| invalid(format!("--filter {name:?} needs --passband").to_lowercase()))
    };
    let mut solver_used = None;
    let filter = match name {
        FilterName::Implicit => {
            let solver = match &args.solver {
                Some(s) => s.parse()?,
                None if meshlap::filter::implicit::is_symmetric(&op.matrix) => SolverKind::Cg,
                None => SolverKind::Bicg,
            };
            solver_used = Some(solver);
            Filter::Implicit {
                lambda: args.lambda.unwrap_or(30.0),
                steps: args.steps.unwrap_or(1),
                solver,
            }
        }
        FilterName::Explicit => Filter::Explicit {
            lambda: args.lambda.unwrap_or(0.5),
            steps: args.steps.unwrap_or(10),
        },
        FilterName::Taubin => Filter::Taubin {
            lambda: args.lambda.unwrap_or(0.5),
            k_pb: args.kpb,
            steps: args.steps.unwrap_or(10),
        },
        FilterName::Butterworth => Filter::Butterworth {
            order: args.order,
            passband: passband()?,
        },
        FilterName::Ideal => Filter::Ideal {
            passband: passband()?,
        },
    };
    let opts = FilterOptions {
        params,
        preserve: args.preserve,
        dense_limit: args.dense_limit,
    };
    let bar = spinner(format!("{name:?} filtering").to_lowercase());
    let result = apply(&input.mesh, &op.matrix, &filter, &opts);
    bar.finish_and_clear();
    let (positions, report) = result?;
    let mut mesh = input.mesh.clone();
    mesh.positions = positions;
    write_mesh(&args.output, &mesh, &WriteOptions::default())?;
    let (lambda, iterative) = match filter {
        Filter::Implicit { lambda, solver, .. } => (Some(lambda), !solver.is_direct()),
        Filter::Explicit { lambda, .. } | Filter::Taubin { lambda, .. } => (Some(lambda), false),
        _ => (None, false),
    };
    if args.json {
        return print_json(&SmoothJson {
            filter: name,
            operator: args.operator,
            vertices: mesh.n_vertices(),
            lambda,
            solver: solver_used,
            stop: iterative.then_some(stopping),
            tolerance: iterative.then_some(args.tol),
            preserve: args.preserve,
            iterations: &report.iterations,
            residuals: &report.residuals,
            solve_seconds: report.solve_seconds,
            seconds: report.seconds,
            volume_before: report.volume_before,
            volume_after: report.volume_after,
            solves: &report.solves,
            output: args.output.display().to_string(),
        });
    }
    print_text(args, name, solver_used, &report);
    Ok(())
}

fn print_text(args: &Args, name: FilterName, solver: Option<SolverKind>, r: &FilterReport) {
    let what = match solver {
        Some(s) => format!("{name:?} with {s}").to_lowercase(),
        None => format!("{name:?}").to_lowercase(),
    };
    println!("{what} on F = {}", args.operator);
    if !r.solves.is_empty() {
        println!(
            "solves: {}, iterations per column (x, y, z): {:?}, final relative residuals: {}",
            r.solves.len(),
            r.iterations,
            r.residuals
                .iter()
                .map(|v| format!("{v:.3e}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
        if let Some(p) = r
            .solves
            .iter()
            .flat_map(|i| i.plateau_at.iter().flatten())
            .min()
        {
            println!("BiCG plateau first seen at iteration {p}");
        }
        println!("solve time: {:.4} s", r.solve_seconds);
    }
    println!(
        "volume: {:.6e} → {:.6e}; total {:.4} s",
        r.volume_before, r.volume_after, r.seconds
    );
    println!("wrote {}", args.output.display());
}
