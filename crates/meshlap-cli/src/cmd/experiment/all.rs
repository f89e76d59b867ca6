//! `meshlap experiment all`: every experiment of the paper in one command.

use super::Bar;
use meshlap::experiment::all::{self, AllOptions};
use std::path::PathBuf;

/// Run every experiment of the paper, each with its defaults, into one directory.
///
/// DIR/claims (§2–3 properties, SQL erratum, repair, smoothing limits), DIR/figures
/// (Figs. 1 and 4), DIR/eigen-cost (Fig. 3 and §4.9 energy compaction), DIR/fairing
/// (Table 1 on cow, horse, bunny, Igea), DIR/compression (§4.9 rate–distortion per
/// operator), DIR/watermark (spectral watermarking under the benchmark attacks, always
/// its quick settings), and DIR/README.md indexing the results. The paper's meshes are read from
/// --meshes (default ../shared/data/meshes, i.e. run from the repository root).
/// --quick uses small meshes and sizes (a few minutes on 2 cores).
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Output directory (created if missing).
    #[arg(long, default_value_os_t = AllOptions::default().out)]
    pub out: PathBuf,
    /// Directory with the shared test meshes (cow.obj, horse.ply, stanford-bunny.obj, igea.ply, …).
    #[arg(long, default_value_os_t = AllOptions::default().meshes)]
    pub meshes: PathBuf,
    /// Small meshes and sizes only.
    #[arg(long)]
    pub quick: bool,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let opts = AllOptions {
        out: args.out.clone(),
        meshes: args.meshes.clone(),
        quick: args.quick,
    };
    let bar = Bar::new();
    let result = all::run(&opts, &mut |p| bar.show(p));
    bar.finish();
    result?;
    eprintln!("wrote {}", all::index_path(&args.out).display());
    Ok(())
}
