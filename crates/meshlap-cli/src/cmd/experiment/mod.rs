//! `meshlap experiment …`: reproductions of the paper's experiments, one file per
//! experiment (siblings add their own variants here).

pub mod compression;

use clap::Subcommand;

/// Reproduce the paper's experiments and write tables (Markdown, JSON) and plots.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(subcommand)]
    pub command: Experiment,
}

/// The experiments.
#[derive(Subcommand, Debug)]
pub enum Experiment {
    Compression(compression::Args),
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    match &args.command {
        Experiment::Compression(a) => compression::run(a),
    }
}
