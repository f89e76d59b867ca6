//! `meshlap experiment compression`.

use crate::common::print_json;
use indicatif::{ProgressBar, ProgressStyle};
use meshlap::experiment::compression::{self, RdOptions};
use meshlap::experiment::Outputs;
use meshlap::input::{self, OpenOptions};
use meshlap::operator::OperatorKind;
use std::path::PathBuf;

/// Rate–distortion curves of JPEG-like spectral compression (Karni–Gotsman 2000;
/// Zhang 2004 §4.9) per combinatorial operator — SSTL, SQL, TL, KL and GL — on each
/// MESH: fixed quantisation, keep ratio swept, so the basis' energy compaction drives
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
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "sstl,sql,tutte,kirchhoff,graph"
    )]
    pub operators: Vec<OperatorKind>,
    /// Keep ratios swept, comma separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "0.05,0.1,0.2,0.3,0.5,0.7,1"
    )]
    pub keep_ratios: Vec<f64>,
    /// Quantisation bits (step = diagonal · 2^-bits).
    #[arg(long, default_value_t = 12.0)]
    pub bits: f64,
    /// Patch size in vertices.
    #[arg(long, default_value_t = 300)]
    pub patch_size: usize,
    /// Surface samples per mesh for the Metro distance.
    #[arg(long, default_value_t = 50_000)]
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
    let inputs = args
        .meshes
        .iter()
        .map(|m| input::open(m, &OpenOptions::default()))
        .collect::<meshlap::Result<Vec<_>>>()?;
    let opts = RdOptions {
        operators: args.operators.clone(),
        keep_ratios: args.keep_ratios.clone(),
        bits: args.bits,
        patch_size: args.patch_size,
        samples: args.samples,
    };
    let total = inputs.len() * opts.operators.len() * opts.keep_ratios.len();
    let bar = ProgressBar::new(total as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut points = compression::rate_distortion(&inputs, &opts, |msg| {
        bar.set_message(msg.to_string());
        bar.inc(1);
    })?;
    bar.finish_and_clear();
    if let Some(p) = &args.draco {
        let text = std::fs::read_to_string(p).map_err(|e| {
            meshlap::Error::InvalidArgument(format!("cannot read {}: {e}", p.display()))
        })?;
        let names: Vec<String> = points.iter().map(|p| p.mesh.clone()).collect();
        let draco = compression::draco_points(&text)?;
        points.extend(draco.into_iter().filter(|d| names.contains(&d.mesh)));
    }
    let mut out = Outputs::new(&args.out)?;
    compression::write(&mut out, &points)?;
    if args.json {
        return print_json(&points);
    }
    print!("{}", compression::table(&points).to_markdown());
    for (m, order) in compression::operator_order(&points) {
        let s: Vec<&str> = order.iter().map(|(c, _)| c.as_str()).collect();
        println!("{m}: {}", s.join(" < "));
    }
    eprintln!(
        "wrote {} files to {}",
        out.written().len(),
        args.out.display()
    );
    Ok(())
}
