//! `meshlap watermark detect`.

use super::embed::{parse_key, LayoutArgs};
use crate::common::{print_json, MeshArgs};
use meshlap::input::{open, OpenOptions};
use meshlap::watermark::{detect, DetectParams, Message, WatermarkError, Weighting};

/// Detect a watermark (non-blind): register the suspect to the original (similarity),
/// resample it onto the original's connectivity if it differs, correlate its
/// spectral residual with the key's chips. The message is printed only when the
/// probability that an unmarked mesh or a wrong key correlates as strongly is at most
/// --max-false-positive; otherwise "no watermark found" with that probability.
///
/// The layout flags (--operator, --patch-size, --band, --chip-rate) must be those of
/// the embedding.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The suspect mesh.
    #[command(flatten)]
    pub suspect: MeshArgs,
    /// The original (unmarked) mesh.
    #[arg(long)]
    pub original: String,
    /// Secret key (64-bit; decimal or 0x-hex).
    #[arg(long, value_parser = parse_key)]
    pub key: u64,
    /// Message length in bits.
    #[arg(long, default_value_t = DetectParams::default().bits)]
    pub bits: usize,
    /// Expected message (hex): report bit_errors and ber.
    #[arg(long)]
    pub expect: Option<String>,
    /// Largest false-positive probability at which the mark counts as found.
    #[arg(long, default_value_t = DetectParams::default().max_false_positive)]
    pub max_false_positive: f64,
    /// Weighting of the residuals before the correlation: auto (patch-axis for a
    /// suspect with the original's connectivity, patch for a resampled one),
    /// patch-axis (one weight per patch and axis) or patch (one per patch).
    #[arg(long, default_value_t = DetectParams::default().weighting,
          value_parser = crate::common::one_of::<Weighting>(Weighting::ALL.map(Weighting::name)))]
    pub weighting: Weighting,
    #[command(flatten)]
    pub layout: LayoutArgs,
    /// Print machine-readable JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let expect = args
        .expect
        .as_deref()
        .map(Message::from_hex)
        .transpose()
        .map_err(WatermarkError::from)?;
    let suspect = args.suspect.open()?;
    let original = open(&args.original, &OpenOptions::default())?;
    let params = DetectParams {
        layout: args.layout.params(),
        expect,
        max_false_positive: args.max_false_positive,
        weighting: args.weighting,
        ..DetectParams::new(args.key, args.bits)
    };
    let r = detect(&suspect.mesh, &original.mesh, &params)?;
    if args.json {
        return print_json(&r);
    }
    let g = &r.registration;
    println!(
        "registration ({}): scale {:.6}, rotation {:.3}°, RMS residual {:.3e}{}",
        g.method,
        g.scale,
        g.rotation_degrees,
        g.rms_residual,
        if r.resampled { "; resampled" } else { "" }
    );
    match &r.message {
        Some(m) => println!(
            "watermark found: {m} (false-positive probability ≤ 1e{:.1})",
            r.false_positive_log10
        ),
        None => println!(
            "no watermark found (false-positive probability bound {:.3e} > {:.1e})",
            r.false_positive_probability, args.max_false_positive
        ),
    }
    let min = r
        .correlations
        .iter()
        .map(|c| c.abs())
        .fold(f64::INFINITY, f64::min);
    println!("weakest bit correlation |ρ| = {min:.3}");
    if let (Some(e), Some(b)) = (r.bit_errors, r.ber) {
        println!("bit errors against --expect: {e} (BER {b:.4})");
    }
    Ok(())
}
