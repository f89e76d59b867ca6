//! `meshlap iterate`.

use crate::common::{print_json, MeshArgs};
use meshlap::analysis::smoothing::{iterate, IterateOptions, SmoothingStep};
use meshlap::io::{write_mesh, WriteOptions};
use meshlap::operator::{Operator, OperatorKind};
use serde::Serialize;
use std::path::PathBuf;

/// Apply the smoothing matrix H = I − F/k repeatedly and report, per step, the
/// variance σ²(Hᵖx) and the largest distance of a vertex to the input's centroid and
/// to its valence-weighted centroid Σ dᵢxᵢ / Σ dᵢ. Measures the paper's §2 claims:
/// Laplacian smoothing with the TL converges to the valence-weighted centroid, a
/// doubly stochastic H (KL, SQL without negative weights) to the centroid without ever
/// increasing the variance.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub mesh: MeshArgs,
    /// Operator kind (see `meshlap operator --help`).
    #[arg(long, short)]
    pub kind: OperatorKind,
    /// Number of applications of H.
    #[arg(long, short = 'p', default_value_t = IterateOptions::default().steps)]
    pub steps: usize,
    /// The k of H = I − F/k (default: max(max F_ii, Gershgorin bound / 2), admissible).
    #[arg(long)]
    pub k: Option<f64>,
    /// Print every N-th step in text mode.
    #[arg(long, default_value_t = 10)]
    pub every: usize,
    /// Write the smoothed mesh.
    #[arg(long, short)]
    pub output: Option<PathBuf>,
    /// Print machine-readable JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct IterateJson<'a> {
    kind: OperatorKind,
    k: f64,
    steps: &'a [SmoothingStep],
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let input = args.mesh.open()?;
    let op = Operator::on_input(args.kind, &input)?;
    let opts = IterateOptions {
        k: args.k,
        steps: args.steps,
    };
    let run = iterate(
        &op.matrix,
        &input.mesh.positions,
        &input.topology.degrees(),
        &opts,
    )?;
    if let Some(path) = &args.output {
        let mut m = input.mesh.clone();
        m.positions = run.positions;
        write_mesh(path, &m, &WriteOptions::default())?;
    }
    let (k, steps) = (run.k, run.steps);
    if args.json {
        return print_json(&IterateJson {
            kind: args.kind,
            k,
            steps: &steps,
        });
    }
    println!("H = I − F/k with F = {} and k = {k:.6}", args.kind);
    println!(
        "{:>6}  {:>14}  {:>14}  {:>14}",
        "step", "variance", "to centroid", "to weighted"
    );
    for s in steps
        .iter()
        .filter(|s| s.step % args.every.max(1) == 0 || s.step == args.steps)
    {
        println!(
            "{:>6}  {:>14.6e}  {:>14.6e}  {:>14.6e}",
            s.step, s.variance, s.distance_to_centroid, s.distance_to_weighted_centroid
        );
    }
    Ok(())
}
