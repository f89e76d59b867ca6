//! `meshlap experiment fairing`.

use crate::common::print_json;
use meshlap::experiment::fairing::{fairing_table, write_outputs, FairingOptions};
use meshlap::experiment::Outputs;
use meshlap::input::{open, OpenOptions};
use meshlap::solve::{Params, Stopping};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// The paper's Table 1 (§4.10): implicit fairing (I + λF)x = b of each mesh with CG on
/// the SQL system, CG on the symmetrised Tutte system (D + λK)x = Db ("CG (TL)") and
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
    #[arg(long, value_delimiter = ',', default_value = "30,100")]
    pub lambda: Vec<f64>,
    /// Output directory (created if missing).
    #[arg(long, default_value = "fairing-experiment")]
    pub out: PathBuf,
    /// Timed runs per solve (the median is reported).
    #[arg(long, default_value_t = 3)]
    pub repeat: usize,
    /// Remove the SQL's negative weights by edge swaps before the CG (SQL) solves.
    #[arg(long)]
    pub repair_sql: bool,
    /// Stopping criterion: weak (the paper's), weak-vertex or strong.
    #[arg(long = "stop", default_value = "weak", value_parser = ["weak", "weak-vertex", "strong"])]
    pub stop: String,
    /// Tolerance ε of the stopping criterion.
    #[arg(long, default_value_t = 1e-5)]
    pub tol: f64,
    /// Print the tables as JSON instead of Markdown.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct Settings<'a> {
    lambdas: &'a [f64],
    stop: Stopping,
    tolerance: f64,
    threads: usize,
    repeat: usize,
}

fn mesh_name(spec: &str) -> String {
    if meshlap::input::is_builtin(spec) {
        spec.trim_start_matches("builtin:").replace(':', "-")
    } else {
        Path::new(spec)
            .file_stem()
            .map_or(spec.to_string(), |s| s.to_string_lossy().into_owned())
    }
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let bad = |m: String| meshlap::Error::InvalidArgument(m);
    if args.lambda.is_empty() || args.lambda.iter().any(|l| !(*l > 0.0 && l.is_finite())) {
        return Err(bad(format!(
            "--lambda needs positive values, got {:?}",
            args.lambda
        )));
    }
    if !(args.tol > 0.0 && args.tol.is_finite()) {
        return Err(bad(format!("--tol must be positive, got {}", args.tol)));
    }
    let stopping: Stopping = args
        .stop
        .parse()
        .map_err(meshlap::solve::SolveError::from)?;
    let opts = FairingOptions {
        lambdas: args.lambda.clone(),
        params: Params {
            tolerance: args.tol,
            stopping,
            ..Default::default()
        },
        repeat: args.repeat.max(1),
        repair_sql: args.repair_sql,
    };
    let mut out = Outputs::new(&args.out)?;
    let bar = indicatif::ProgressBar::new((args.meshes.len() * args.lambda.len() * 4) as u64);
    if !std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let mut tables = Vec::new();
    for spec in &args.meshes {
        let name = mesh_name(spec);
        bar.set_message(format!("{name}: loading"));
        let input = open(spec, &OpenOptions::default())?;
        let progress = |what: &str| {
            bar.set_message(format!("{name}: {what}"));
            if !what.starts_with("repairing") {
                bar.inc(1);
            }
        };
        tables.push(fairing_table(
            &name,
            &input.mesh,
            &input.topology,
            &opts,
            &progress,
        )?);
    }
    bar.finish_and_clear();
    let settings = Settings {
        lambdas: &args.lambda,
        stop: stopping,
        tolerance: args.tol,
        threads: rayon::current_num_threads(),
        repeat: opts.repeat,
    };
    let tabs = write_outputs(&mut out, &tables, &args.lambda, &settings)?;
    if args.json {
        #[derive(Serialize)]
        struct Json<'a> {
            #[serde(flatten)]
            settings: Settings<'a>,
            tables: &'a [meshlap::experiment::fairing::FairingTable],
            files: Vec<String>,
        }
        return print_json(&Json {
            settings,
            tables: &tables,
            files: out
                .written()
                .iter()
                .map(|p| p.display().to_string())
                .collect(),
        });
    }
    println!(
        "weak criterion: {}, ε = {}, {} threads, median of {} solves\n",
        args.stop,
        args.tol,
        rayon::current_num_threads(),
        opts.repeat
    );
    for t in &tabs {
        println!("{}", t.to_markdown());
    }
    for f in out.written() {
        println!("wrote {}", f.display());
    }
    Ok(())
}
