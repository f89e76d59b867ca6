//! `meshlap smooth`.

use crate::common::{one_of, print_json, spinner, MeshInOut};
use meshlap::filter::{
    apply, ButterworthOptions, Filter, FilterError, FilterKind, FilterReport, FilterSettings,
    Preserve, SolverKind, TaubinOptions, DEFAULT_DENSE_LIMIT,
};
use meshlap::io::{write_mesh, WriteOptions};
use meshlap::operator::{Operator, OperatorKind};
use meshlap::solve::{Params, SolveInfo, Stopping};
use serde::Serialize;

/// Smooth (low-pass filter) a mesh with a Laplacian operator F and write the result.
///
/// Filters, by their response on an eigenvalue γ of F (operators use the paper's sign
/// F = D − W, so larger γ is higher frequency):
///   implicit     (1 + λγ)^−N   solves a sparse system per step (the paper's §4.10)
///   explicit     (1 − λγ)^N    Laplacian smoothing (shrinks)
///   taubin       ((1 − λγ)(1 − μγ))^N, 1/λ + 1/μ = kpb (does not shrink)
///   butterworth  1 / (1 + (γ/passband)^(2·order))
///   ideal        keeps γ ≤ passband exactly (dense eigendecomposition, small meshes)
///
/// Implicit fairing solvers: auto (the default) picks cg for a symmetric operator and
/// bicg otherwise; cg and pcg (Jacobi) and cholesky need a symmetric operator (kl,
/// sql, sstl, gl, cotan); bicg, bicgstab and lu take any; cg-sym solves the
/// symmetrized system S(I + λF)x = Sb — for the Tutte Laplacian the paper's
/// "CG (TL)", (D + λK)x = Db. The SQL with negative weights may make the system
/// indefinite: that is reported as an error (run `meshlap repair-sql` first).
///
/// Non-manifold edges and vertices and inconsistently oriented faces are kept as they
/// are (the output has the input's faces); every operator but the SQL is defined on
/// them (the cotangent weight of an edge sums over all its faces), and the SQL
/// refuses a non-manifold edge in one line naming it.
///
/// `--json` prints iterations per coordinate column, residuals, timings and volumes.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub io: MeshInOut,
    /// Filter to apply.
    #[arg(long, default_value_t = FilterKind::Implicit,
          value_parser = one_of::<FilterKind>(FilterKind::ALL.map(FilterKind::name)))]
    pub filter: FilterKind,
    /// Shorthand for `--filter implicit`.
    #[arg(long, conflicts_with = "filter")]
    pub implicit: bool,
    /// Operator F: kirchhoff (kl), tutte (tl), graph (gl), sql, sstl, tutte2, sdl,
    /// cotan, mean-value.
    #[arg(long, short = 'k', default_value_t = FilterSettings::DEFAULT_OPERATOR)]
    pub operator: OperatorKind,
    /// λ: implicit (default 30, the paper's Table 1), explicit and taubin (default 0.5;
    /// keep λ·γ_max < 2 for stability: λ ≤ 1 for the TL).
    #[arg(long)]
    pub lambda: Option<f64>,
    /// Linear solver of implicit fairing (auto: cg for a symmetric operator, bicg
    /// otherwise).
    #[arg(long, default_value_t = SolverKind::Auto,
          value_parser = one_of::<SolverKind>(SolverKind::ALL.map(SolverKind::name)))]
    pub solver: SolverKind,
    /// Stopping criterion of the iterative solvers: weak (the paper's: the update of
    /// each coordinate column is below tol × its size), weak-vertex (the same per
    /// vertex), strong (‖Bx − b‖ < tol·‖b‖).
    #[arg(long = "stop", default_value_t = Params::default().stopping,
          value_parser = one_of::<Stopping>(Stopping::ALL.map(Stopping::name)))]
    pub stop: Stopping,
    /// Tolerance ε of the stopping criterion.
    #[arg(long, default_value_t = Params::default().tolerance)]
    pub tol: f64,
    /// Iteration cap of the iterative solvers.
    #[arg(long, default_value_t = Params::default().max_iterations)]
    pub max_iterations: usize,
    /// Steps: implicit solves (default 1), explicit steps (default 10), Taubin pairs
    /// (default 10).
    #[arg(long, short = 'n')]
    pub steps: Option<usize>,
    /// Taubin pass-band k_PB = 1/λ + 1/μ (0 < kpb < 1/λ).
    #[arg(long, default_value_t = TaubinOptions::default().k_pb)]
    pub kpb: f64,
    /// Butterworth order s.
    #[arg(long, default_value_t = ButterworthOptions::DEFAULT_ORDER)]
    pub order: usize,
    /// Pass-band γ_PB of the Butterworth and ideal filters (an eigenvalue of F).
    #[arg(long)]
    pub passband: Option<f64>,
    /// Rescale afterwards: volume (enclosed volume, closed meshes), bbox (bounding
    /// box) or none.
    #[arg(long, default_value_t = Preserve::None,
          value_parser = one_of::<Preserve>(Preserve::ALL.map(Preserve::name)))]
    pub preserve: Preserve,
    /// Largest mesh for the dense ideal filter.
    #[arg(long, default_value_t = DEFAULT_DENSE_LIMIT)]
    pub dense_limit: usize,
    /// Print machine-readable JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct SmoothJson<'a> {
    filter: FilterKind,
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
    /// Per solve: iterations and residuals per column, relative-residual history, the
    /// BiCG plateau or the factorization.
    solves: &'a [SolveInfo],
    output: String,
}

/// The library's error, with the command-line hint for fixing it where there is one.
fn with_hint(e: FilterError) -> meshlap::Error {
    let hint = match &e {
        FilterError::MissingPassband { .. } => "pass --passband",
        FilterError::NeedsSymmetric { .. } => "use --solver bicg, cg-sym, bicgstab or lu",
        FilterError::TooLarge { .. } => "raise --dense-limit or use --filter butterworth",
        FilterError::Solve(s) if s.is_not_positive_definite() => {
            "an SQL with negative weights can cause this: run `meshlap repair-sql` first, or use --solver lu or bicg"
        }
        _ => return e.into(),
    };
    meshlap::Error::InvalidArgument(format!("{e}; {hint}"))
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let kind = if args.implicit {
        FilterKind::Implicit
    } else {
        args.filter
    };
    let settings = FilterSettings {
        lambda: args.lambda,
        steps: args.steps,
        solver: Some(args.solver),
        params: Some(Params {
            tolerance: args.tol,
            stopping: args.stop,
            max_iterations: args.max_iterations,
            ..Default::default()
        }),
        k_pb: Some(args.kpb),
        order: Some(args.order),
        passband: args.passband,
        dense_limit: Some(args.dense_limit),
    };
    let filter = Filter::new(kind, &settings).map_err(with_hint)?;
    let input = args.io.mesh.open()?;
    let op = Operator::on_input(args.operator, &input)?;
    let bar = spinner(format!("{kind} filtering"));
    let result = apply(&input.mesh, &op.matrix, &filter, args.preserve);
    bar.finish_and_clear();
    let (positions, report) = result.map_err(with_hint)?;
    let mut mesh = input.mesh.clone();
    mesh.positions = positions;
    write_mesh(&args.io.output, &mesh, &WriteOptions::default())?;
    if args.json {
        let iterative = report.solver.is_some_and(|s| !s.is_direct());
        return print_json(&SmoothJson {
            filter: kind,
            operator: args.operator,
            vertices: mesh.n_vertices(),
            lambda: filter.lambda(),
            solver: report.solver,
            stop: iterative.then_some(args.stop),
            tolerance: iterative.then_some(args.tol),
            preserve: args.preserve,
            iterations: &report.iterations,
            residuals: &report.residuals,
            solve_seconds: report.solve_seconds,
            seconds: report.seconds,
            volume_before: report.volume_before,
            volume_after: report.volume_after,
            solves: &report.solves,
            output: args.io.output.display().to_string(),
        });
    }
    print_text(args, kind, &report);
    Ok(())
}

fn print_text(args: &Args, kind: FilterKind, r: &FilterReport) {
    let what = match r.solver {
        Some(s) => format!("{kind} with {s}"),
        None => kind.to_string(),
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
            .filter_map(SolveInfo::plateau_at)
            .flat_map(|p| p.iter().flatten())
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
    println!("wrote {}", args.io.output.display());
}
