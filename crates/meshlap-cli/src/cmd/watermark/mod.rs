//! `meshlap watermark …`: spectral mesh watermarking (Ohbuchi et al. 2001/2002) and
//! the attacks of the watermarking benchmark (Wang et al., SMI 2010).

pub mod attack;
pub mod detect;
pub mod embed;

use clap::Subcommand;

/// Spectral mesh watermarking: embed and detect a keyed bit string in the
/// low-frequency patch spectra of a combinatorial Laplacian (F = D − W), and the
/// benchmark's attacks.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(subcommand)]
    pub command: Watermark,
}

/// The watermarking commands.
#[derive(Subcommand, Debug)]
pub enum Watermark {
    Embed(embed::Args),
    Detect(detect::Args),
    Attack(attack::Args),
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    match &args.command {
        Watermark::Embed(a) => embed::run(a),
        Watermark::Detect(a) => detect::run(a),
        Watermark::Attack(a) => attack::run(a),
    }
}
