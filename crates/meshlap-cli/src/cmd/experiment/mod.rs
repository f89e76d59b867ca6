//! `meshlap experiment …`: reproductions of the paper's experiments, one file per
//! experiment. Each parses its arguments into the library's options struct (whose
//! `Default` gives the defaults shown in `--help`), calls the library's `run` with a
//! progress bar, and prints the tables.

pub mod all;
pub mod claims;
pub mod compression;
pub mod eigen_cost;
pub mod fairing;
pub mod figures;
pub mod watermark;

use clap::Subcommand;
use indicatif::{ProgressBar, ProgressStyle};
use meshlap::experiment::{ExperimentError, Outputs, Progress};
use std::path::Path;

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
    Watermark(watermark::Args),
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    match &args.command {
        Experiment::All(a) => all::run(a),
        Experiment::Claims(a) => claims::run(a),
        Experiment::Compression(a) => compression::run(a),
        Experiment::EigenCost(a) => eigen_cost::run(a),
        Experiment::Figures(a) => figures::run(a),
        Experiment::Fairing(a) => fairing::run(a),
        Experiment::Watermark(a) => watermark::run(a),
    }
}

/// A progress bar on stderr driven by the library's progress events (hidden when
/// stderr is not a terminal).
pub struct Bar(ProgressBar);

impl Bar {
    pub fn new() -> Self {
        let bar = ProgressBar::new(0);
        if !std::io::IsTerminal::is_terminal(&std::io::stderr()) {
            bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
        }
        Bar(bar)
    }

    /// Shows one event: a phase with a known number of steps is a bar, one without a
    /// spinner; steps advance the bar; notes only change the message.
    pub fn show(&self, event: Progress) {
        let b = &self.0;
        match event {
            Progress::Experiment { title } if b.is_hidden() => eprintln!("== {title}"),
            Progress::Experiment { title } => b.println(format!("== {title}")),
            Progress::Start { phase, total } => {
                let template = if total > 0 {
                    "{bar:30} {pos}/{len} {msg} [{elapsed}]"
                } else {
                    "{spinner} {msg} [{elapsed}]"
                };
                if let Ok(style) = ProgressStyle::with_template(template) {
                    b.set_style(style);
                }
                b.set_length(total as u64);
                b.set_position(0);
                b.set_message(phase);
            }
            Progress::Step { label } => {
                b.set_message(label);
                b.inc(1);
            }
            Progress::Note { label } => b.set_message(label),
        }
    }

    pub fn finish(&self) {
        self.0.finish_and_clear();
    }
}

/// The library's error with the command-line flag of a rejected option: `flags` maps
/// options-struct fields to flags; other fields `foo_bar` are `--foo-bar`.
pub fn with_flags(e: ExperimentError, flags: &[(&str, &str)]) -> meshlap::Error {
    match e {
        ExperimentError::InvalidOption { option, reason } => {
            let flag = flags
                .iter()
                .find(|f| f.0 == option)
                .map_or_else(|| format!("--{}", option.replace('_', "-")), |f| f.1.into());
            meshlap::Error::InvalidArgument(format!("{flag} {reason}"))
        }
        e => e.into(),
    }
}

/// Runs `experiment` into the output directory `dir` under a progress bar.
pub fn run_with_bar<T>(
    dir: &Path,
    flags: &[(&str, &str)],
    experiment: impl FnOnce(&mut Outputs, &mut dyn FnMut(Progress)) -> Result<T, ExperimentError>,
) -> meshlap::Result<(T, Outputs)> {
    let mut out = Outputs::new(dir)?;
    let bar = Bar::new();
    let result = experiment(&mut out, &mut |p| bar.show(p));
    bar.finish();
    Ok((result.map_err(|e| with_flags(e, flags))?, out))
}

/// The closing line of a command: how many files went where.
pub fn report_files(out: &Outputs) {
    eprintln!(
        "wrote {} files to {}",
        out.written().len(),
        out.dir().display()
    );
}
