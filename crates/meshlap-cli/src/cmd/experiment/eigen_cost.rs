//! `meshlap experiment eigen-cost`.

use super::run_with_bar;
use crate::common::print_json;
use meshlap::experiment::eigen_cost::{self, EigenCostOptions};
use std::path::PathBuf;

/// The paper's Fig. 3 and §4.9 energy-compaction comparison.
///
/// Cost: the time to eigendecompose the KL, the TL (through its GL similarity, and
/// by the general non-symmetric eigensolver plus the dense LU of E that the paper's
/// Matlab eig + E\x needs), the GL, SQL and SSTL on patches of growing size n, grown
/// by breadth-first search from vertex 0 of each MESH (induced faces); also the time
/// for the spectral coefficients (projection versus LU solve).
///
/// Compaction: the transform efficiency of SSTL, SQL, TL and KL (centered geometry) on
/// smooth models (a patch of the first MESH, builtin:icosphere:3) and on models with
/// sharp transitions (builtin:cube:8, builtin:step:20). The paper's order on smooth
/// models is SSTL > SQL > TL > KL, often reversed on the sharp ones.
///
/// Writes to --out: eigen_cost.md/.csv, eigen_cost_<mesh>.png, compaction.md/.csv,
/// compaction_<model>.png and eigen_cost.json.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Meshes to cut patches from (files or builtin:…); repeat the option.
    #[arg(long = "mesh", value_name = "MESH", default_values_t = EigenCostOptions::default().meshes)]
    pub meshes: Vec<String>,
    /// Patch sizes n (vertices), comma separated.
    #[arg(long, value_delimiter = ',', default_values_t = EigenCostOptions::default().sizes)]
    pub sizes: Vec<usize>,
    /// Timing repetitions per measurement (median reported).
    #[arg(long, default_value_t = EigenCostOptions::default().repeat)]
    pub repeat: usize,
    /// Vertices of the smooth-model patch in the compaction comparison.
    #[arg(long, default_value_t = EigenCostOptions::default().compaction_size)]
    pub compaction_size: usize,
    /// Output directory (created if missing).
    #[arg(long, default_value = "eigen-cost")]
    pub out: PathBuf,
    /// Also print the JSON results on stdout.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let opts = EigenCostOptions {
        meshes: args.meshes.clone(),
        sizes: args.sizes.clone(),
        repeat: args.repeat,
        compaction_size: args.compaction_size,
    };
    let (results, out) = run_with_bar(&args.out, &[], |out, p| eigen_cost::run(&opts, out, p))?;
    if args.json {
        return print_json(&results);
    }
    for t in &results.tables {
        println!("{}", t.to_markdown());
    }
    println!(
        "wrote {} files to {}",
        out.written().len(),
        args.out.display()
    );
    Ok(())
}
