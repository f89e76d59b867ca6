//! `meshlap experiment fairing`.

use super::run_with_bar;
use crate::common::print_json;
use meshlap::experiment::fairing::{self, FairingOptions};
use meshlap::solve::{Params, Stopping};
use serde::Serialize;
use std::path::PathBuf;

/// Stopping criterion of the iterative solvers.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stop {
    /// The paper's: per coordinate column, ‖xⁿ − xⁿ⁻¹‖ < ε‖xⁿ⁻¹‖.
    Weak,
    /// The weak criterion per vertex; all columns stop together.
    WeakVertex,
    /// ‖Bx − b‖ < ε‖b‖ per column.
    Strong,
}

impl From<Stop> for Stopping {
    fn from(s: Stop) -> Self {
        match s {
            Stop::Weak => Stopping::Weak,
            Stop::WeakVertex => Stopping::WeakVertex,
            Stop::Strong => Stopping::Strong,
        }
    }
}

/// The paper's Table 1 (§4.10): implicit fairing (I + λF)x = b of each mesh with CG on
/// the SQL system, CG on the symmetrized Tutte system (D + λK)x = Db ("CG (TL)") and
/// BiCG on the Tutte system, at each λ, with the paper's weak stopping criterion
/// (ε = 1e-5). Reports per mesh n, the solve time (median of --repeat runs, systems
/// assembled beforehand) and iterations (the most over the x, y, z columns), each
/// result's error against the direct (sparse Cholesky) solution — so BiCG stopping on
/// a residual plateau shows — and the paper's own figures for its models.
///
/// Writes DIR/table1-lambdaL.md and .csv per λ, DIR/table1.json and one convergence
/// plot per mesh and λ, DIR/convergence-MESH-lambdaL.png (relative residual per
/// iteration). The SQL's
/// negative weights are counted; --repair-sql removes them by edge swaps first (the
/// CG (SQL) rows then run on the swapped connectivity); a solver failure (e.g. an
/// indefinite SQL system) is reported in the table, not hidden.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Meshes (files or builtin:NAME[:ARGS]); the paper used cow, horse, bunny, Igea.
    #[arg(required = true)]
    pub meshes: Vec<String>,
    /// λ values, comma-separated (the paper: 30,100).
    #[arg(long, value_delimiter = ',', default_values_t = FairingOptions::default().lambdas)]
    pub lambda: Vec<f64>,
    /// Output directory (created if missing).
    #[arg(long, default_value = "fairing-experiment")]
    pub out: PathBuf,
    /// Timed runs per solve (the median is reported).
    #[arg(long, default_value_t = FairingOptions::default().repeat)]
    pub repeat: usize,
    /// Remove the SQL's negative weights by edge swaps before the CG (SQL) solves.
    #[arg(long)]
    pub repair_sql: bool,
    /// Stopping criterion: weak (the paper's), weak-vertex or strong.
    #[arg(long = "stop", value_enum, default_value_t = Stop::Weak)]
    pub stop: Stop,
    /// Tolerance ε of the stopping criterion.
    #[arg(long, default_value_t = Params::default().tolerance)]
    pub tol: f64,
    /// Print the tables as JSON instead of Markdown.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let opts = FairingOptions {
        meshes: args.meshes.clone(),
        lambdas: args.lambda.clone(),
        params: Params {
            tolerance: args.tol,
            stopping: args.stop.into(),
            ..Default::default()
        },
        repeat: args.repeat,
        repair_sql: args.repair_sql,
    };
    let flags = [("lambdas", "--lambda"), ("tolerance", "--tol")];
    let (results, out) = run_with_bar(&args.out, &flags, |out, p| fairing::run(&opts, out, p))?;
    if args.json {
        #[derive(Serialize)]
        struct Json<'a> {
            #[serde(flatten)]
            results: &'a fairing::FairingResults,
            files: Vec<String>,
        }
        return print_json(&Json {
            results: &results,
            files: out
                .written()
                .iter()
                .map(|p| p.display().to_string())
                .collect(),
        });
    }
    let s = &results.settings;
    let stop = clap::ValueEnum::to_possible_value(&args.stop)
        .map_or_else(String::new, |v| v.get_name().to_string());
    println!(
        "weak criterion: {stop}, ε = {}, {} threads, median of {} solves\n",
        s.tolerance, s.threads, s.repeat
    );
    for t in &results.markdown {
        println!("{}", t.to_markdown());
    }
    for f in out.written() {
        println!("wrote {}", f.display());
    }
    Ok(())
}
