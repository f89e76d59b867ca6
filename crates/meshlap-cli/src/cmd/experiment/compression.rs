//! `meshlap experiment compression`.

use super::{report_files, run_with_bar};
use crate::common::print_json;
use meshlap::experiment::compression::{self, CompressionOptions};
use meshlap::operator::OperatorKind;
use std::path::PathBuf;

/// Rate–distortion curves of JPEG-like spectral compression (Karni–Gotsman 2000;
/// Zhang 2004 §4.9) per combinatorial operator — SSTL, SQL, TL, KL and GL — on each
/// MESH: fixed quantization, keep ratio swept, so the basis' energy compaction drives
/// the error. The paper expects SSTL best, then SQL, on smooth models, and the order
/// reversed on models with sharp transitions (builtin:cube, builtin:step). Draco's
/// points (from `bench/compression.py --json-out FILE`) are added with --draco.
/// Writes compression.md/.csv/.json and PNG charts (vertex and Metro RMS against bits
/// per vertex) to --out.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Meshes (files or builtin:…).
    #[arg(required = true)]
    pub meshes: Vec<String>,
    /// Operators, comma separated.
    #[arg(long, value_delimiter = ',', default_values_t = CompressionOptions::default().operators)]
    pub operators: Vec<OperatorKind>,
    /// Keep ratios swept, comma separated.
    #[arg(long, value_delimiter = ',', default_values_t = CompressionOptions::default().keep_ratios)]
    pub keep_ratios: Vec<f64>,
    /// Quantization bits (step = diagonal · 2^-bits).
    #[arg(long, default_value_t = CompressionOptions::default().bits)]
    pub bits: f64,
    /// Patch size in vertices.
    #[arg(long, default_value_t = CompressionOptions::default().patch_size)]
    pub patch_size: usize,
    /// Surface samples per mesh for the Metro distance.
    #[arg(long, default_value_t = CompressionOptions::default().samples)]
    pub samples: usize,
    /// Draco points: the JSON written by bench/compression.py --json-out.
    #[arg(long)]
    pub draco: Option<PathBuf>,
    /// Output directory (created if missing).
    #[arg(long, default_value = "compression")]
    pub out: PathBuf,
    /// Also print the JSON results on stdout.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let opts = CompressionOptions {
        meshes: args.meshes.clone(),
        operators: args.operators.clone(),
        keep_ratios: args.keep_ratios.clone(),
        bits: args.bits,
        patch_size: args.patch_size,
        samples: args.samples,
        draco: args.draco.clone(),
    };
    let (results, out) = run_with_bar(&args.out, &[], |out, p| compression::run(&opts, out, p))?;
    if args.json {
        return print_json(&results.points);
    }
    print!("{}", results.table.to_markdown());
    for (m, order) in &results.order {
        let s: Vec<&str> = order.iter().map(|(c, _)| c.as_str()).collect();
        println!("{m}: {}", s.join(" < "));
    }
    report_files(&out);
    Ok(())
}
