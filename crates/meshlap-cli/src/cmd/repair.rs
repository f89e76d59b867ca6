//! `meshlap repair-sql`.

use crate::common::{print_json, MeshArgs};
use meshlap::analysis::repair::{repair_sql, RepairOptions};
use meshlap::io::{write_mesh, WriteOptions};
use std::path::PathBuf;

/// Remove the negative weights of the symmetric quasi-Laplacian (SQL) by greedy edge
/// swapping (Zhang 2004 §3.7): repeatedly flip the edge with the most negative weight
/// when the flip is legal and raises the smallest weight around it. Reports the counts
/// before and after, the flips made and the weights left.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub mesh: MeshArgs,
    /// Output mesh with the flipped connectivity.
    #[arg(long, short)]
    pub output: PathBuf,
    /// Refuse flips whose two new triangles meet at more than this angle (degrees)
    /// between their normals, or that fold over.
    #[arg(long, value_name = "DEGREES")]
    pub max_dihedral: Option<f64>,
    /// Print machine-readable JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let input = args.mesh.open()?;
    let opts = RepairOptions {
        max_dihedral_degrees: args.max_dihedral,
        ..Default::default()
    };
    let (mesh, report) = repair_sql(&input.mesh, &opts)?;
    write_mesh(&args.output, &mesh, &WriteOptions::default())?;
    if args.json {
        return print_json(&report);
    }
    println!(
        "negative SQL weights: {} before (most negative {:.6}), {} after",
        report.negative_before, report.min_weight_before, report.negative_after
    );
    println!(
        "flips: {} made, {} tried and rejected",
        report.flips, report.rejected
    );
    for w in report.remaining.iter().take(10) {
        println!("  left: W({}, {}) = {:.6}", w.i, w.j, w.weight);
    }
    println!("wrote {}", args.output.display());
    Ok(())
}
