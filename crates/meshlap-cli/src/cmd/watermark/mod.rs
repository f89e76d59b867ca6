//! `meshlap watermark …`: spectral watermarking (Ohbuchi et al. 2001/2002).

pub mod detect;
pub mod embed;

use clap::Subcommand;

/// Spectral mesh watermarking: embed, detect (and attack) a keyed bit string in the
/// low-frequency patch spectra of a combinatorial Laplacian (F = D − W).
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(subcommand)]
    pub command: Watermark,
}

/// The watermarking subcommands.
#[derive(Subcommand, Debug)]
pub enum Watermark {
    Embed(embed::Args),
    Detect(detect::Args),
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    match &args.command {
        Watermark::Embed(a) => embed::run(a),
        Watermark::Detect(a) => detect::run(a),
    }
}
