//! `meshlap experiment watermark`.

use super::{report_files, run_with_bar};
use crate::common::print_json;
use meshlap::experiment::watermark::{self, WatermarkOptions};
use meshlap::operator::OperatorKind;
use std::path::PathBuf;

/// Spectral watermarking (Ohbuchi et al. 2001/2002) under the attacks of the 3D mesh
/// watermarking benchmark (Wang, Lavoué, Denis, Baskurt 2010): on each MESH and per
/// operator, embed a 64-bit message, measure its distortion (MRMS, MSDM2), run every
/// attack at the benchmark's strengths (noise 0.05–0.5 %, smoothing 5–50, quantization
/// 11–7 bits, similarity, simplification 10–70 %, three subdivisions, cropping
/// 10–50 %) and detect; check false positives on unmarked meshes and wrong keys.
/// Writes watermark.md/.csv/.json (BER per attack and level), watermark_summary.*,
/// charts of BER against strength and a picture per mesh (original, marked,
/// displacement) to --out.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Meshes (files or builtin:…).
    #[arg(required = true)]
    pub meshes: Vec<String>,
    /// Operators, comma separated (kirchhoff, sql, sstl, tutte).
    #[arg(long, value_delimiter = ',', default_values_t = WatermarkOptions::default().operators)]
    pub operators: Vec<OperatorKind>,
    /// Embedding strength: RMS displacement ÷ bounding-box diagonal (the MRMS).
    #[arg(long, default_value_t = WatermarkOptions::default().strength)]
    pub strength: f64,
    /// Target vertices per patch (default: about 36 patches of at least 1,000
    /// vertices).
    #[arg(long)]
    pub patch_size: Option<usize>,
    /// Low-frequency eigenvectors per patch carrying the mark (DC skipped).
    #[arg(long, default_value_t = WatermarkOptions::default().layout.band)]
    pub band: usize,
    /// Coefficients per bit (default: every available coefficient).
    #[arg(long)]
    pub chip_rate: Option<usize>,
    /// Wrong keys tried per marked mesh.
    #[arg(long, default_value_t = WatermarkOptions::default().wrong_keys)]
    pub wrong_keys: usize,
    /// Skip the pictures.
    #[arg(long)]
    pub no_pictures: bool,
    /// Output directory (created if missing).
    #[arg(long, default_value = "watermark")]
    pub out: PathBuf,
    /// Also print the JSON results on stdout.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let opts = WatermarkOptions {
        meshes: args.meshes.clone(),
        operators: args.operators.clone(),
        wrong_keys: args.wrong_keys,
        strength: args.strength,
        layout: meshlap::watermark::LayoutParams {
            patch_size: args.patch_size,
            band: args.band,
            chip_rate: args.chip_rate,
            ..WatermarkOptions::default().layout
        },
        pictures: !args.no_pictures,
        ..WatermarkOptions::default()
    };
    let (results, out) = run_with_bar(&args.out, &[], |out, p| watermark::run(&opts, out, p))?;
    if args.json {
        return print_json(&results.attacks);
    }
    print!(
        "{}",
        watermark::summary_table(&results.summaries).to_markdown()
    );
    print!("{}", watermark::table(&results.attacks).to_markdown());
    report_files(&out);
    Ok(())
}
