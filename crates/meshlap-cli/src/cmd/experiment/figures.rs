//! `meshlap experiment figures`.

use super::{report_files, run_with_bar};
use crate::common::print_json;
use meshlap::experiment::figures::{self, FiguresOptions};
use std::path::PathBuf;

/// The paper's Figs. 1 and 4, re-made as rendered PNG panels.
///
/// Fig. 1 (fig1_<model>.png): each model, its JPEG-like truncated reconstruction with the
/// normalized graph Laplacian (GL) and with the SQL and TL at the same number m of
/// coefficients. The GL's are not smooth versions of the mesh (its lowest eigenvector is
/// not constant); the GSMLs' are. Fig. 4 (fig4_4_8_sphere.png): KL, SQL and SSTL
/// reconstructions of the paper's sphere with 4-8 connectivity (builtin:sphere48:12);
/// the KL shows artifacts at the degree-4 vertices. Errors of every
/// reconstruction in figures.md/.csv and figures.json.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The mesh of Fig. 1 beside builtin:icosphere:3 (dense ED: at most 5,000 vertices).
    #[arg(long, default_value_t = FiguresOptions::default().mesh)]
    pub mesh: String,
    /// Fraction of the coefficients kept in Fig. 1.
    #[arg(long, default_value_t = FiguresOptions::default().keep_fraction)]
    pub keep_fraction: f64,
    /// Coefficients kept in Fig. 4.
    #[arg(long, default_value_t = FiguresOptions::default().fig4_keep)]
    pub fig4_keep: usize,
    /// Picture size of each cell, pixels.
    #[arg(long, default_value_t = FiguresOptions::default().size)]
    pub size: u32,
    /// Output directory (created if missing).
    #[arg(long, default_value = "figures")]
    pub out: PathBuf,
    /// Also print the JSON results on stdout.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let opts = FiguresOptions {
        mesh: args.mesh.clone(),
        keep_fraction: args.keep_fraction,
        fig4_keep: args.fig4_keep,
        size: args.size,
    };
    let (results, out) = run_with_bar(&args.out, &[], |out, p| figures::run(&opts, out, p))?;
    if args.json {
        return print_json(&results);
    }
    println!("{}", results.table.to_markdown());
    report_files(&out);
    Ok(())
}
