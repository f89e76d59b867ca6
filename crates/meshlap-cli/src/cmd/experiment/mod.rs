//! `meshlap experiment …`: reproductions of the paper's experiments, one file per
//! experiment (siblings add their own variants here).

pub mod all;
pub mod claims;
pub mod compression;
pub mod eigen_cost;
pub mod fairing;
pub mod figures;

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
    All(all::Args),
    Claims(claims::Args),
    Compression(compression::Args),
    EigenCost(eigen_cost::Args),
    Figures(figures::Args),
    Fairing(fairing::Args),
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    match &args.command {
        Experiment::All(a) => all::run(a),
        Experiment::Claims(a) => claims::run(a),
        Experiment::Compression(a) => compression::run(a),
        Experiment::EigenCost(a) => eigen_cost::run(a),
        Experiment::Figures(a) => figures::run(a),
        Experiment::Fairing(a) => fairing::run(a),
    }
}
