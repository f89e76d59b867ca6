//! `meshlap experiment …`: reproductions of the paper's experiments, one file per
//! experiment (siblings add their own variants here).

pub mod eigen_cost;

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
    EigenCost(eigen_cost::Args),
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    match &args.command {
        Experiment::EigenCost(a) => eigen_cost::run(a),
    }
}
