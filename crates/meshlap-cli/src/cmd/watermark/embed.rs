//! `meshlap watermark embed`.

use crate::common::{print_json, MeshInOut};
use meshlap::io::{write_mesh, WriteOptions};
use meshlap::operator::OperatorKind;
use meshlap::watermark::{embed, EmbedParams, LayoutParams, Message};

/// A 64-bit key: decimal, or hexadecimal with a `0x` prefix.
pub fn parse_key(s: &str) -> Result<u64, String> {
    let r = match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(h) => u64::from_str_radix(h, 16),
        None => s.parse::<u64>(),
    };
    r.map_err(|e| format!("a key is a 64-bit number (decimal or 0x-hex): {e}"))
}

/// The layout flags shared by embed and detect (detection must repeat embedding's).
#[derive(clap::Args, Debug, Clone)]
pub struct LayoutArgs {
    /// Operator of the patch bases (F = D − W): kirchhoff (the papers'), sql, sstl,
    /// tutte.
    #[arg(long, default_value_t = LayoutParams::default().operator,
          value_parser = crate::common::one_of::<OperatorKind>(["kirchhoff", "sql", "sstl", "tutte"]))]
    pub operator: OperatorKind,
    /// Target vertices per patch (default: about 36 patches of at least 1,000
    /// vertices; detection computes the same from the original).
    #[arg(long)]
    pub patch_size: Option<usize>,
    /// Low-frequency eigenvectors per patch carrying the mark (DC skipped).
    #[arg(long, default_value_t = LayoutParams::default().band)]
    pub band: usize,
    /// Coefficients per bit (default: every available coefficient).
    #[arg(long)]
    pub chip_rate: Option<usize>,
}

impl LayoutArgs {
    pub fn params(&self) -> LayoutParams {
        LayoutParams {
            operator: self.operator,
            patch_size: self.patch_size,
            band: self.band,
            chip_rate: self.chip_rate,
        }
    }
}

/// Embed a watermark: spread each message bit by the key's ±1 chips over low-frequency
/// coefficients of the patch-wise ED-transform (Ohbuchi et al. 2001/2002). The output
/// has the input's connectivity and vertex order.
///
/// `--json` prints bits, patches, coefficients_per_bit, mrms (RMS displacement ÷
/// bounding-box diagonal), max_displacement, msdm2 and seconds.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub io: MeshInOut,
    /// Secret key (64-bit; decimal or 0x-hex).
    #[arg(long, value_parser = parse_key)]
    pub key: u64,
    /// Message in hex (16 digits = 64 bits; other lengths allowed).
    #[arg(long)]
    pub message: String,
    /// Strength: the RMS displacement ÷ bounding-box diagonal (the MRMS).
    #[arg(long, default_value_t = meshlap::watermark::embed::DEFAULT_STRENGTH)]
    pub strength: f64,
    #[command(flatten)]
    pub layout: LayoutArgs,
    /// Skip the MSDM2 measurement (the report's msdm2 is then null; `seconds` then
    /// times the embedding alone).
    #[arg(long)]
    pub no_msdm2: bool,
    /// Print machine-readable JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let message =
        Message::from_hex(&args.message).map_err(meshlap::watermark::WatermarkError::from)?;
    let input = args.io.mesh.open()?;
    let params = EmbedParams {
        key: args.key,
        message,
        strength: args.strength,
        layout: args.layout.params(),
        measure_msdm2: !args.no_msdm2,
    };
    let (marked, report) = embed(&input.mesh, &params)?;
    write_mesh(&args.io.output, &marked, &WriteOptions::default())?;
    if args.json {
        return print_json(&report);
    }
    println!(
        "embedded {} bits in {} patches, {} coefficients per bit (α = {:.3e})",
        report.bits, report.patches, report.coefficients_per_bit, report.alpha
    );
    println!(
        "MRMS {:.3e} of the diagonal, max displacement {:.3e}{}",
        report.mrms,
        report.max_displacement,
        report
            .msdm2
            .map_or(String::new(), |m| format!(", MSDM2 {m:.4}"))
    );
    println!(
        "wrote {} ({:.2} s)",
        args.io.output.display(),
        report.seconds
    );
    Ok(())
}
