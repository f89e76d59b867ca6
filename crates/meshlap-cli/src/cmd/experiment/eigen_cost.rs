//! `meshlap experiment eigen-cost`.

use crate::common::print_json;
use indicatif::{ProgressBar, ProgressStyle};
use meshlap::experiment::eigen_cost::{
    compaction, compaction_models, cost, CompactionOrder, CompactionRow, CostRow,
    COMPACTION_OPERATORS, COST_OPERATORS,
};
use meshlap::experiment::Outputs;
use meshlap::input::{self, Input, OpenOptions};
use serde::Serialize;
use std::path::PathBuf;

/// The paper's Fig. 3 and §4.9 energy-compaction comparison.
///
/// Cost: the time to eigendecompose the KL, the TL (through its GL similarity, and
/// by the general non-symmetric eigensolver plus the dense LU of E that the paper's
/// Matlab eig + E\x needs), the GL, SQL and SSTL on patches of growing size n, grown
/// by breadth-first search from vertex 0 of each MESH (induced faces); also the time
/// for the spectral coefficients (projection versus LU solve).
///
/// Compaction: the transform efficiency of SSTL, SQL, TL and KL (centred geometry) on
/// smooth models (a patch of the first MESH, builtin:icosphere:3) and on models with
/// sharp transitions (builtin:cube:8, builtin:step:20). The paper's order on smooth
/// models is SSTL > SQL > TL > KL, often reversed on the sharp ones.
///
/// Writes to --out: eigen_cost.md/.csv, eigen_cost_<mesh>.png, compaction.md/.csv,
/// compaction_<model>.png and eigen_cost.json.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Meshes to cut patches from (files or builtin:…); repeat the option.
    #[arg(
        long = "mesh",
        value_name = "MESH",
        default_value = "builtin:icosphere:5"
    )]
    pub meshes: Vec<String>,
    /// Patch sizes n (vertices), comma separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "100,200,400,800,1200,1600"
    )]
    pub sizes: Vec<usize>,
    /// Timing repetitions per measurement (median reported).
    #[arg(long, default_value_t = 1)]
    pub repeat: usize,
    /// Vertices of the smooth-model patch in the compaction comparison.
    #[arg(long, default_value_t = 1000)]
    pub compaction_size: usize,
    /// Output directory (created if missing).
    #[arg(long, default_value = "eigen-cost")]
    pub out: PathBuf,
    /// Also print the JSON results on stdout.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct Results<'a> {
    cost: &'a [CostRow],
    compaction: &'a [CompactionRow],
    compaction_order: &'a CompactionOrder,
}

fn bar(len: usize) -> ProgressBar {
    let b = ProgressBar::new(len as u64);
    b.set_style(ProgressStyle::with_template("{bar:30} {pos}/{len} {msg} [{elapsed}]").unwrap());
    b
}

/// File-name-safe version of a mesh or model name.
fn slug(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect::<String>()
        .trim_matches('_')
        .to_string()
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let limit = meshlap::spectral::DENSE_LIMIT;
    if args.sizes.is_empty() || args.sizes.iter().any(|&n| !(4..=limit).contains(&n)) {
        return Err(meshlap::Error::InvalidArgument(format!(
            "--sizes must be between 4 and {limit}"
        )));
    }
    if !(4..=limit).contains(&args.compaction_size) {
        return Err(meshlap::Error::InvalidArgument(format!(
            "--compaction-size must be between 4 and {limit}"
        )));
    }
    let meshes: Vec<Input> = args
        .meshes
        .iter()
        .map(|m| input::open(m, &OpenOptions::default()))
        .collect::<meshlap::Result<_>>()?;
    let mut out = Outputs::new(&args.out)?;

    let pb = bar(meshes.len() * args.sizes.len() * COST_OPERATORS.len());
    let (cost_rows, cost_table, cost_charts) = cost(&meshes, &args.sizes, args.repeat, |m| {
        pb.set_message(m.to_string());
        pb.inc(1);
    })?;
    pb.finish_and_clear();
    out.table("eigen_cost", &cost_table)?;
    for (mesh, chart) in &cost_charts {
        out.chart(&format!("eigen_cost_{}.png", slug(mesh)), chart)?;
    }

    let models = compaction_models(meshes.first(), args.compaction_size)?;
    let pb = bar(models.len() * COMPACTION_OPERATORS.len());
    let (comp_rows, order, comp_table, comp_charts) = compaction(&models, |m| {
        pb.set_message(m.to_string());
        pb.inc(1);
    })?;
    pb.finish_and_clear();
    out.table("compaction", &comp_table)?;
    for (model, chart) in &comp_charts {
        out.chart(&format!("compaction_{}.png", slug(model)), chart)?;
    }
    let results = Results {
        cost: &cost_rows,
        compaction: &comp_rows,
        compaction_order: &order,
    };
    out.json("eigen_cost.json", &results)?;
    if args.json {
        return print_json(&results);
    }
    println!("{}", cost_table.to_markdown());
    println!("{}", comp_table.to_markdown());
    println!(
        "wrote {} files to {}",
        out.written().len(),
        args.out.display()
    );
    Ok(())
}
