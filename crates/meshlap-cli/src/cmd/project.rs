//! `meshlap project`.

use super::spectrum::BasisArgs;
use crate::common::print_json;
use meshlap::io::{write_mesh, WriteOptions};
use meshlap::operator::OperatorKind;
use meshlap::spectral::project::{project, Keep, KeepError, ProjectParams};
use meshlap::spectral::EigenPath;
use serde::Serialize;
use std::path::PathBuf;

/// JPEG-like spectral compression of the geometry (Zhang 2004 Fig. 1; Karni &
/// Gotsman 2000): transform the vertex positions with the operator's ED-transform,
/// keep the first m coefficients (lowest frequencies) and write the reconstruction
/// x⁽ᵐ⁾ = e₁X₁ + … + e_mX_m with the original connectivity. With a GSML (KL, TL, SQL,
/// SSTL) x⁽ᵐ⁾ gets smoother as m shrinks; with the GL it does not (its lowest
/// eigenvector is not constant), as the paper's Fig. 1 shows.
///
/// Whole-mesh, dense (n ≤ 5000).
///
/// Non-manifold edges and vertices and inconsistently oriented faces are kept as they
/// are (the output has the input's faces); every operator but the SQL is defined on
/// them, and the SQL refuses a non-manifold edge in one line naming it.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub basis: BasisArgs,
    /// Coefficients kept: a count m (1 ≤ m ≤ n) or a percentage of n such as 10%.
    #[arg(long, short = 'm', value_name = "m|P%")]
    pub keep: String,
    /// Transform patch by patch: split the mesh into connected patches of about P
    /// vertices (METIS) and keep the same fraction m/n of each patch's coefficients
    /// (Karni–Gotsman's piece-wise scheme, as the paper does for large meshes).
    /// Patches run in parallel.
    #[arg(long, value_name = "P")]
    pub patch_size: Option<usize>,
    /// Output mesh (format from the extension).
    #[arg(long, short)]
    pub output: PathBuf,
    /// Print machine-readable JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct ProjectJson<'a> {
    source: &'a str,
    kind: OperatorKind,
    #[serde(skip_serializing_if = "Option::is_none")]
    path: Option<EigenPath>,
    vertices: usize,
    keep: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    patch_size: Option<usize>,
    keep_fraction: f64,
    /// Fraction of the coefficient energy in the kept coefficients (whole mesh).
    #[serde(skip_serializing_if = "Option::is_none")]
    energy_kept: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    partition: Option<&'a meshlap::partition::PartitionStats>,
    /// ‖x − x⁽ᵐ⁾‖_F / ‖x‖_F.
    relative_error: f64,
    /// Largest vertex displacement divided by the bounding-box diagonal.
    max_displacement: f64,
    seconds: f64,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let input = args.basis.mesh.open()?;
    let n = input.mesh.n_vertices();
    // The library's message names the value; the hint names the flag.
    let hint = |e: KeepError| meshlap::Error::InvalidArgument(format!("--{e}"));
    let keep: Keep = args.keep.parse().map_err(hint)?;
    keep.resolve(n).map_err(hint)?;
    let params = ProjectParams {
        operator: super::operator::options(args.basis.sql_diagonal, args.basis.mass),
        basis: args.basis.options(),
        patch_size: args.patch_size,
    };
    let bar = indicatif::ProgressBar::new(0);
    if args.patch_size.is_some() {
        bar.set_style(
            indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} patches [{elapsed}]")
                .expect("static template"),
        );
    } else {
        bar.set_style(
            indicatif::ProgressStyle::with_template("{spinner} projecting [{elapsed}]")
                .expect("static template"),
        );
        bar.enable_steady_tick(std::time::Duration::from_millis(120));
    }
    let t = std::time::Instant::now();
    let result = project(
        &input.mesh,
        &input.topology,
        args.basis.kind,
        keep,
        &params,
        &|done, total| {
            bar.set_length(total as u64);
            bar.set_position(done as u64)
        },
    );
    bar.finish_and_clear();
    let seconds = t.elapsed().as_secs_f64();
    let pr = result?;
    let mut out = input.mesh.clone();
    out.positions = pr.positions;
    write_mesh(&args.output, &out, &WriteOptions::default())?;
    let info = &pr.info;
    if args.json {
        return print_json(&ProjectJson {
            source: &input.source,
            kind: args.basis.kind,
            path: info.path,
            vertices: n,
            keep: info.keep,
            patch_size: args.patch_size,
            keep_fraction: info.keep_fraction,
            energy_kept: info.energy_kept,
            partition: info.partition.as_ref(),
            relative_error: info.errors.relative,
            max_displacement: info.errors.max,
            seconds,
        });
    }
    match (&info.partition, info.path, info.energy_kept) {
        (Some(st), _, _) => println!(
            "{} patches (sizes {}–{}, edge cut {}), kept {:.2}% of each patch's {} coefficients: relative error {:.3e}, max displacement {:.3e} × bbox diagonal, {:.2} s; wrote {}",
            st.patches,
            st.min_size,
            st.max_size,
            st.edge_cut,
            100.0 * info.keep_fraction,
            args.basis.kind,
            info.errors.relative,
            info.errors.max,
            seconds,
            args.output.display()
        ),
        (None, path, energy) => println!(
            "kept {} of {n} {} coefficients ({} path): {:.4}% of the energy; relative error {:.3e}, max displacement {:.3e} × bbox diagonal; wrote {}",
            info.keep,
            args.basis.kind,
            path.map_or("dense".to_string(), |p| p.to_string()),
            100.0 * energy.unwrap_or(f64::NAN),
            info.errors.relative,
            info.errors.max,
            args.output.display()
        ),
    }
    Ok(())
}
