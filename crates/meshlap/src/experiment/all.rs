//! Every experiment of the paper in one call, each with its paper settings (or its
//! quick ones) and the shared models read from one directory, into subdirectories of
//! one output directory, with a `README.md` indexing them and the time each took.

use super::claims::ClaimsOptions;
use super::compression::CompressionOptions;
use super::eigen_cost::EigenCostOptions;
use super::fairing::FairingOptions;
use super::figures::FiguresOptions;
use super::meshes::DEFAULT_MESH_DIR;
use super::{ExperimentError, Outputs, Progress, ProgressFn};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Options of [`run`].
#[derive(Clone, Debug, PartialEq)]
pub struct AllOptions {
    /// Output directory (created if missing); each experiment writes into a
    /// subdirectory.
    pub out: PathBuf,
    /// Directory of the shared test meshes (cow.obj, horse.ply, stanford-bunny.obj,
    /// igea.ply, …).
    pub meshes: PathBuf,
    /// Run each experiment with its `quick` settings.
    pub quick: bool,
}

impl Default for AllOptions {
    /// `experiments/` from the meshes in [`DEFAULT_MESH_DIR`], full settings.
    fn default() -> Self {
        AllOptions {
            out: PathBuf::from("experiments"),
            meshes: PathBuf::from(DEFAULT_MESH_DIR),
            quick: false,
        }
    }
}

impl AllOptions {
    /// The quick settings of every experiment, into `experiments/`.
    pub fn quick() -> Self {
        AllOptions {
            quick: true,
            ..Self::default()
        }
    }
}

/// One experiment [`run`] did.
#[derive(Clone, Debug)]
pub struct Done {
    /// Its title in the index.
    pub title: &'static str,
    /// Its subdirectory.
    pub dir: &'static str,
    /// Wall-clock seconds it took.
    pub seconds: f64,
}

/// The options of each experiment for [`AllOptions`].
struct Plan {
    claims: ClaimsOptions,
    figures: FiguresOptions,
    eigen_cost: EigenCostOptions,
    fairing: FairingOptions,
    compression: CompressionOptions,
}

impl Plan {
    fn new(opts: &AllOptions) -> Plan {
        let dir = opts.meshes.as_path();
        if opts.quick {
            Plan {
                claims: ClaimsOptions::quick_in(dir),
                figures: FiguresOptions::quick(),
                eigen_cost: EigenCostOptions::quick(),
                fairing: FairingOptions::quick_in(dir),
                compression: CompressionOptions::quick(),
            }
        } else {
            Plan {
                claims: ClaimsOptions::paper(dir),
                figures: FiguresOptions::paper(dir),
                eigen_cost: EigenCostOptions::paper(dir),
                fairing: FairingOptions::paper(dir),
                compression: CompressionOptions::paper(dir),
            }
        }
    }
}

/// Runs claims, figures, eigen-cost, fairing, compression and watermark (always its
/// quick settings) into
/// `opts.out/{claims,figures,eigen-cost,fairing,compression,watermark}` and writes
/// `opts.out/README.md`; a [`Progress::Experiment`] precedes each.
pub fn run(opts: &AllOptions, progress: &mut ProgressFn) -> Result<Vec<Done>, ExperimentError> {
    let plan = Plan::new(opts);
    let mut done = Vec::new();
    let mut step =
        |title: &'static str,
         dir: &'static str,
         f: &mut dyn FnMut(&mut Outputs, &mut ProgressFn) -> Result<(), ExperimentError>|
         -> Result<(), ExperimentError> {
            progress(Progress::Experiment {
                title: title.to_string(),
            });
            let t = Instant::now();
            let mut out = Outputs::new(&opts.out.join(dir))?;
            f(&mut out, progress)?;
            done.push(Done {
                title,
                dir,
                seconds: t.elapsed().as_secs_f64(),
            });
            Ok(())
        };
    step(
        "§2–3 claims: operator properties, SQL erratum, SQL repair, smoothing limits",
        "claims",
        &mut |out, p| super::claims::run(&plan.claims, out, p).map(drop),
    )?;
    step(
        "Figs. 1 and 4: GL vs GSML reconstructions, KL artifacts",
        "figures",
        &mut |out, p| super::figures::run(&plan.figures, out, p).map(drop),
    )?;
    step(
        "Fig. 3 and §4.9: cost of the ED transforms, energy compaction",
        "eigen-cost",
        &mut |out, p| super::eigen_cost::run(&plan.eigen_cost, out, p).map(drop),
    )?;
    step(
        "Table 1: implicit fairing with CG and BiCG",
        "fairing",
        &mut |out, p| super::fairing::run(&plan.fairing, out, p).map(drop),
    )?;
    step(
        "§4.9: spectral compression per operator",
        "compression",
        &mut |out, p| super::compression::run(&plan.compression, out, p).map(drop),
    )?;
    step(
        "§4.9: spectral watermarking under the benchmark attacks (quick settings)",
        "watermark",
        &mut |out, p| {
            // Always the quick settings: the full run (bunny, horse, Igea, four
            // operators) is `meshlap experiment watermark`.
            super::watermark::run(&super::watermark::WatermarkOptions::quick(), out, p).map(drop)
        },
    )?;
    write_index(opts, &done)?;
    Ok(done)
}

/// `README.md`: how it was produced, and a link and the time per experiment.
fn write_index(opts: &AllOptions, done: &[Done]) -> Result<(), ExperimentError> {
    let mut lines = vec![
        "# meshlap: the experiments of Zhang 2004".to_string(),
        String::new(),
        format!(
            "Produced by `meshlap experiment all --out {}{}`.",
            opts.out.display(),
            if opts.quick { " --quick" } else { "" }
        ),
        String::new(),
    ];
    lines.extend(
        done.iter()
            .map(|d| format!("- [{}]({}/) — {:.1} s", d.title, d.dir, d.seconds)),
    );
    let text = lines.join("\n") + "\n";
    crate::io::write_atomic(&index_path(&opts.out), |w| w.write_all(text.as_bytes()))?;
    Ok(())
}

/// The index file of an output directory.
pub fn index_path(out: &Path) -> PathBuf {
    out.join("README.md")
}
