//! `meshlap watermark …`: spectral mesh watermarking (Ohbuchi et al. 2001/2002) and
//! the attacks of the watermarking benchmark (Wang et al., SMI 2010).

pub mod attack;

use clap::Subcommand;

/// Spectral mesh watermarking and the benchmark's attacks.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(subcommand)]
    pub command: Watermark,
}

/// The watermarking commands.
#[derive(Subcommand, Debug)]
pub enum Watermark {
    Attack(attack::Args),
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    match &args.command {
        Watermark::Attack(a) => attack::run(a),
    }
}
