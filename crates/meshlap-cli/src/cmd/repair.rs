//! `meshlap repair-sql`.

use crate::common::{one_of, print_json, MeshInOut};
use meshlap::analysis::repair::{repair_sql, RepairError, RepairMethod, RepairOptions};
use meshlap::io::{write_mesh, WriteOptions};
use meshlap::mesh::MeshError;

/// Remove the negative weights of the symmetric quasi-Laplacian (SQL) by greedy edge
/// swapping (Zhang 2004 §3.7): repeatedly flip the edge with the most negative weight
/// when the flip is legal and raises the smallest weight around it. With `--method
/// split` or `swap-split`, split a high-degree endpoint instead (the progressive-mesh
/// vertex split the paper names as the alternative; new vertices are appended).
/// Reports the counts before and after, the flips and splits made and the weights left.
///
/// A negative weight W_ij = 1/d_i + 1/d_j − (1/d_k + 1/d_l)/2 (k, l opposite the edge)
/// appears where i and j have much higher degrees than k and l; such weights keep the
/// SQL from being a GSML and its smoothing matrix from being doubly stochastic.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub io: MeshInOut,
    /// Refuse flips whose two new triangles meet at more than this angle (degrees, in
    /// (0, 180]) between their normals, or that fold over.
    #[arg(long, value_name = "DEGREES")]
    pub max_dihedral: Option<f64>,
    /// swap: greedy edge swapping (vertices unchanged); split: vertex splits only;
    /// swap-split: swap, and split an endpoint where no swap of the edge helps.
    #[arg(long, default_value_t = RepairMethod::default(),
          value_parser = one_of::<RepairMethod>(RepairMethod::ALL.map(RepairMethod::name)))]
    pub method: RepairMethod,
    /// Print machine-readable JSON (keys: method, negative_before, min_weight_before,
    /// flips, splits, vertices_added, rejected, negative_after, min_weight_after,
    /// remaining).
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let input = args.io.mesh.open()?;
    let opts = RepairOptions {
        max_dihedral_degrees: args.max_dihedral,
        method: args.method,
        ..Default::default()
    };
    let (mesh, report) = repair_sql(&input.mesh, &opts).map_err(|e| match e {
        RepairError::Mesh(MeshError::NonManifoldEdge { .. }) => meshlap::Error::InvalidArgument(
            format!("{e}; run `meshlap clean --split-nonmanifold` first"),
        ),
        e => e.into(),
    })?;
    write_mesh(&args.io.output, &mesh, &WriteOptions::default())?;
    if args.json {
        return print_json(&report);
    }
    println!(
        "negative SQL weights: {} before (most negative {:.6}), {} after",
        report.negative_before, report.min_weight_before, report.negative_after
    );
    println!(
        "edits: {} flips, {} vertex splits ({} vertices added); {} times no edit helped",
        report.flips, report.splits, report.vertices_added, report.rejected
    );
    for w in report.remaining.iter().take(10) {
        println!("  left: W({}, {}) = {:.6}", w.i, w.j, w.weight);
    }
    println!("wrote {}", args.io.output.display());
    Ok(())
}
