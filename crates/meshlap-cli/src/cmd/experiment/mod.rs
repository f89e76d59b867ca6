//! `meshlap experiment VARIANT ...`: reproduce the paper's experiments, one file per
//! variant.

pub mod fairing;

/// Reproduce an experiment of Zhang (2004): tables (Markdown and JSON) and plots (PNG).
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(subcommand)]
    pub variant: Variant,
}

#[derive(clap::Subcommand, Debug)]
pub enum Variant {
    Fairing(fairing::Args),
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    match &args.variant {
        Variant::Fairing(a) => fairing::run(a),
    }
}
