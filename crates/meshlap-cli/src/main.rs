//! `meshlap`: command-line front end of the meshlap library. Thin by design: parse
//! arguments, call the library, print. Errors print one line on stderr and exit 1;
//! usage errors exit 2.

/// `println!` for the commands' output: writes to stdout and stops the process
/// quietly (exit 0) when the reader has gone away (`meshlap … | head`), like other
/// Unix filters, instead of panicking on the broken pipe; any other write error is
/// one line on stderr and exit 1. Shadows the prelude's macro in every module below.
macro_rules! println {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if let Err(e) = writeln!(std::io::stdout().lock(), $($arg)*) {
            $crate::stdout_failed(&e);
        }
    }};
}

/// `print!` with the same handling of a closed stdout as [`println!`].
#[allow(unused_macros)]
macro_rules! print {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if let Err(e) = write!(std::io::stdout().lock(), $($arg)*) {
            $crate::stdout_failed(&e);
        }
    }};
}

mod cmd;
mod common;

use clap::{Parser, Subcommand};

/// Discrete mesh Laplacians for digital geometry processing (after Zhang 2004).
///
/// Every MESH argument is a file (OBJ, OFF, PLY, STL; format from the extension,
/// `--format` to override) or a generated mesh `builtin:NAME[:ARGS]`:
/// tetrahedron, octahedron, icosahedron, icosphere:N, torus:U:V, grid:N, cube:N,
/// step:N. Meshes are cleaned on input (unreferenced vertices, faces with a repeated
/// vertex and duplicate faces are dropped and counted).
///
/// Operators follow the paper's sign convention F = D − W (positive semi-definite);
/// libigl and pmp use the negative.
#[derive(Parser, Debug)]
#[command(name = "meshlap", version, propagate_version = true)]
struct Cli {
    /// Worker threads (default: all cores).
    #[arg(long, global = true)]
    threads: Option<usize>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    Info(cmd::info::Args),
    Convert(cmd::convert::Args),
    Clean(cmd::clean::Args),
    Operator(cmd::operator::Args),
    Iterate(cmd::iterate::Args),
    RepairSql(cmd::repair::Args),
    Partition(cmd::partition::Args),
    Smooth(cmd::smooth::Args),
    Compress(cmd::compress::Args),
    Compare(cmd::compare::Args),
    Decompress(cmd::decompress::Args),
    Spectrum(cmd::spectrum::Args),
    Project(cmd::project::Args),
    Compaction(cmd::compaction::Args),
    Render(cmd::render::Args),
    Descriptors(cmd::descriptors::Args),
    Experiment(cmd::experiment::Args),
    Watermark(cmd::watermark::Args),
}

fn main() {
    // Freed work matrices are reused instead of page-faulted in again (see the doc).
    meshlap::keep_freed_memory();
    let cli = Cli::parse();
    // The pool's threads get the main thread's usual stack (8 MiB, reserved, not
    // committed), since the command runs on one of them. A pool can only be built
    // once; ignore a second attempt.
    let _ = rayon::ThreadPoolBuilder::new()
        .num_threads(cli.threads.map_or(0, |t| t.max(1)))
        .stack_size(8 << 20)
        .build_global();
    // The command runs on a worker of the pool, as the Python package's calls do:
    // every parallel pass it makes is then shared out by work stealing, instead of
    // being handed to the pool while the main thread sleeps until it ends
    // (BENCHMARKS.md, "Connectivity").
    let run = || match &cli.command {
        Command::Info(a) => cmd::info::run(a),
        Command::Convert(a) => cmd::convert::run(a),
        Command::Clean(a) => cmd::clean::run(a),
        Command::Operator(a) => cmd::operator::run(a),
        Command::Iterate(a) => cmd::iterate::run(a),
        Command::RepairSql(a) => cmd::repair::run(a),
        Command::Partition(a) => cmd::partition::run(a),
        Command::Smooth(a) => cmd::smooth::run(a),
        Command::Compress(a) => cmd::compress::run(a),
        Command::Compare(a) => cmd::compare::run(a),
        Command::Decompress(a) => cmd::decompress::run(a),
        Command::Spectrum(a) => cmd::spectrum::run(a),
        Command::Project(a) => cmd::project::run(a),
        Command::Compaction(a) => cmd::compaction::run(a),
        Command::Render(a) => cmd::render::run(a),
        Command::Descriptors(a) => cmd::descriptors::run(a),
        Command::Experiment(a) => cmd::experiment::run(a),
        Command::Watermark(a) => cmd::watermark::run(a),
    };
    let result = meshlap::par::on_worker(run);
    if let Err(e) = result {
        if broken_pipe(&e) {
            std::process::exit(0);
        }
        let msg = e.to_string().replace('\n', " ");
        eprintln!("meshlap: error: {msg}");
        std::process::exit(1);
    }
}

/// True when an `io::Error` of kind `BrokenPipe` is anywhere in the error's chain:
/// the reader of our output went away, which is not a failure of the command.
fn broken_pipe(e: &(dyn std::error::Error + 'static)) -> bool {
    let mut cur = Some(e);
    while let Some(err) = cur {
        if err
            .downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
        {
            return true;
        }
        cur = err.source();
    }
    false
}

/// Handles a failed write to stdout (see [`println!`]).
fn stdout_failed(e: &std::io::Error) -> ! {
    if broken_pipe(e) {
        std::process::exit(0);
    }
    eprintln!("meshlap: error: cannot write to standard output: {e}");
    std::process::exit(1);
}
