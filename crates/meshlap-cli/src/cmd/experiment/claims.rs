//! `meshlap experiment claims`.

use super::{report_files, run_with_bar};
use crate::common::print_json;
use meshlap::experiment::claims::{self, ClaimsOptions};
use std::path::PathBuf;

/// The paper's §2–3 claims about the operators, measured on meshes.
///
/// Four tables (Markdown + CSV) and one chart:
/// - properties.md: every operator on every --mesh — symmetry, negative weights, zero
///   row sums, a doubly stochastic / variance-diminishing H = I − F/k, PSD, one zero
///   eigenvalue per component, λ_max against Gershgorin, GSML status (§2.2–2.5, §3);
/// - erratum.md: the SQL's boundary diagonal as printed versus corrected, on the
///   --boundary-mesh list (the printed sign leaves nonzero row sums);
/// - repair.md: negative SQL weights before and after greedy edge swapping (§3.7);
/// - limits.md and limits.png: repeated smoothing with the TL converges to the
///   valence-weighted centroid, with the KL (doubly stochastic) to the centroid (§2.2).
///
/// All results also go to claims.json.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Meshes for the property table (repeat the option).
    #[arg(long = "mesh", value_name = "MESH", default_values_t = ClaimsOptions::default().meshes)]
    pub meshes: Vec<String>,
    /// Meshes with boundary for the SQL erratum table.
    #[arg(long = "boundary-mesh", value_name = "MESH", default_values_t = ClaimsOptions::default().boundary_meshes)]
    pub boundary_meshes: Vec<String>,
    /// Meshes for the SQL repair table.
    #[arg(long = "repair-mesh", value_name = "MESH", default_values_t = ClaimsOptions::default().repair_meshes)]
    pub repair_meshes: Vec<String>,
    /// Mesh for the smoothing-limit run (irregular valences make the two centroids differ).
    #[arg(long, default_value_t = ClaimsOptions::default().limit_mesh)]
    pub limit_mesh: String,
    /// Smoothing steps of the limit run.
    #[arg(long, default_value_t = ClaimsOptions::default().steps)]
    pub steps: usize,
    /// Output directory (created if missing).
    #[arg(long, default_value = "claims")]
    pub out: PathBuf,
    /// Also print the JSON results on stdout.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let opts = ClaimsOptions {
        meshes: args.meshes.clone(),
        boundary_meshes: args.boundary_meshes.clone(),
        repair_meshes: args.repair_meshes.clone(),
        limit_mesh: args.limit_mesh.clone(),
        steps: args.steps,
    };
    let (results, out) = run_with_bar(&args.out, &[], |out, p| claims::run(&opts, out, p))?;
    if args.json {
        return print_json(&results);
    }
    for t in &results.tables {
        println!("{}", t.to_markdown());
    }
    report_files(&out);
    Ok(())
}
