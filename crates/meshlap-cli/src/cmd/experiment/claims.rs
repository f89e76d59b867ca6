//! `meshlap experiment claims`.

use crate::common::print_json;
use indicatif::{ProgressBar, ProgressStyle};
use meshlap::analysis::properties::PropertyOptions;
use meshlap::analysis::repair::RepairOptions;
use meshlap::experiment::claims::{erratum, limits, properties, repair};
use meshlap::experiment::Outputs;
use meshlap::input::{self, Input, OpenOptions};
use meshlap::operator::OperatorKind;
use serde::Serialize;
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
    #[arg(
        long = "mesh",
        value_name = "MESH",
        default_values = ["../shared/data/meshes/cow.obj", "../shared/data/meshes/woody.obj", "builtin:grid:12", "builtin:icosahedron"]
    )]
    pub meshes: Vec<String>,
    /// Meshes with boundary for the SQL erratum table.
    #[arg(
        long = "boundary-mesh",
        value_name = "MESH",
        default_values = ["../shared/data/meshes/teapot.obj", "../shared/data/meshes/stanford-bunny.obj", "builtin:grid:12"]
    )]
    pub boundary_meshes: Vec<String>,
    /// Meshes for the SQL repair table.
    #[arg(
        long = "repair-mesh",
        value_name = "MESH",
        default_values = ["../shared/data/meshes/cow.obj", "../shared/data/meshes/teapot.obj", "../shared/data/meshes/horse.ply"]
    )]
    pub repair_meshes: Vec<String>,
    /// Mesh for the smoothing-limit run (irregular valences make the two centroids differ).
    #[arg(long, default_value = "../shared/data/meshes/woody.obj")]
    pub limit_mesh: String,
    /// Smoothing steps of the limit run.
    #[arg(long, default_value_t = 20000)]
    pub steps: usize,
    /// Output directory (created if missing).
    #[arg(long, default_value = "claims")]
    pub out: PathBuf,
    /// Also print the JSON results on stdout.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct Results<'a> {
    properties: &'a [meshlap::experiment::claims::PropertyRow],
    erratum: &'a [meshlap::experiment::claims::ErratumRow],
    repair: &'a [meshlap::experiment::claims::RepairRow],
    limits: &'a [meshlap::experiment::claims::LimitRow],
}

fn open_all(specs: &[String]) -> meshlap::Result<Vec<Input>> {
    specs
        .iter()
        .map(|s| input::open(s, &OpenOptions::default()))
        .collect()
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let mut out = Outputs::new(&args.out)?;
    let bar = ProgressBar::new_spinner();
    bar.set_style(
        ProgressStyle::with_template("{spinner} {msg} [{elapsed}]").expect("static template"),
    );

    bar.set_message("properties");
    let meshes = open_all(&args.meshes)?;
    let (prop_rows, prop_table) = properties(
        &meshes,
        &OperatorKind::ALL,
        &PropertyOptions::default(),
        |m| bar.set_message(format!("properties: {m}")),
    );
    out.table("properties", &prop_table)?;

    bar.set_message("SQL erratum");
    let (err_rows, err_table) = erratum(&open_all(&args.boundary_meshes)?)?;
    out.table("erratum", &err_table)?;

    bar.set_message("SQL repair");
    let (rep_rows, rep_table) = repair(&open_all(&args.repair_meshes)?, &RepairOptions::default())?;
    out.table("repair", &rep_table)?;

    bar.set_message("smoothing limits");
    let limit_input = input::open(&args.limit_mesh, &OpenOptions::default())?;
    let (lim_rows, lim_table, chart) = limits(
        &limit_input,
        &[
            OperatorKind::Tutte,
            OperatorKind::Kirchhoff,
            OperatorKind::Sql,
        ],
        args.steps,
        (args.steps / 200).max(1),
    )?;
    out.table("limits", &lim_table)?;
    out.chart("limits.png", &chart)?;
    bar.finish_and_clear();

    let results = Results {
        properties: &prop_rows,
        erratum: &err_rows,
        repair: &rep_rows,
        limits: &lim_rows,
    };
    out.json("claims.json", &results)?;
    if args.json {
        return print_json(&results);
    }
    for t in [&prop_table, &err_table, &rep_table, &lim_table] {
        println!("{}", t.to_markdown());
    }
    eprintln!(
        "wrote {} files to {}",
        out.written().len(),
        out.dir().display()
    );
    Ok(())
}
