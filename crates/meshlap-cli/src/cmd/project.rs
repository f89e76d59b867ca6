//! `meshlap project`.

use super::spectrum::BasisArgs;
use crate::common::{print_json, MeshArgs};
use meshlap::io::{write_mesh, WriteOptions};
use meshlap::operator::OperatorKind;
use meshlap::spectral::{
    compaction::energy_compaction, forward, inverse, mat_to_positions, positions_to_mat, EigenPath,
};
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
    pub mesh: MeshArgs,
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
    path: EigenPath,
    vertices: usize,
    keep: usize,
    /// Fraction of the coefficient energy in the kept coefficients.
    energy_kept: f64,
    /// ‖x − x⁽ᵐ⁾‖_F / ‖x‖_F.
    relative_error: f64,
    /// Largest vertex displacement divided by the bounding-box diagonal.
    max_displacement: f64,
    seconds: f64,
}

/// Parses `m` or `P%` against n.
pub fn parse_keep(s: &str, n: usize) -> meshlap::Result<usize> {
    let bad = || {
        meshlap::Error::InvalidArgument(format!(
            "--keep must be a count in 1..={n} or a percentage like 10%, got `{s}`"
        ))
    };
    let m = if let Some(p) = s.strip_suffix('%') {
        let p: f64 = p.trim().parse().map_err(|_| bad())?;
        if !(p > 0.0 && p <= 100.0) {
            return Err(bad());
        }
        ((p / 100.0 * n as f64).round() as usize).max(1)
    } else {
        s.trim().parse().map_err(|_| bad())?
    };
    if m == 0 || m > n {
        return Err(bad());
    }
    Ok(m)
}

#[derive(Serialize)]
struct PatchJson<'a> {
    source: &'a str,
    kind: OperatorKind,
    vertices: usize,
    patch_size: usize,
    keep_fraction: f64,
    partition: &'a meshlap::partition::PartitionStats,
    relative_error: f64,
    max_displacement: f64,
    seconds: f64,
}

/// `‖x − y‖_F / ‖x‖_F` and `max_i ‖x_i − y_i‖`.
fn errors(x: &[[f64; 3]], y: &[[f64; 3]]) -> (f64, f64) {
    let (mut err2, mut norm2, mut maxd) = (0.0f64, 0.0f64, 0.0f64);
    for (a, b) in x.iter().zip(y) {
        let d2: f64 = (0..3).map(|c| (a[c] - b[c]).powi(2)).sum();
        err2 += d2;
        norm2 += a.iter().map(|v| v * v).sum::<f64>();
        maxd = maxd.max(d2.sqrt());
    }
    let rel = if norm2 > 0.0 {
        (err2 / norm2).sqrt()
    } else {
        0.0
    };
    (rel, maxd)
}

fn run_patches(
    args: &Args,
    input: &meshlap::input::Input,
    keep: usize,
    p: usize,
) -> meshlap::Result<()> {
    use meshlap::partition::{partition_mesh, PartitionOptions};
    use meshlap::spectral::patchwise::patchwise_reconstruction;
    let n = input.mesh.n_vertices();
    let t = std::time::Instant::now();
    let part = partition_mesh(&input.mesh, &input.topology, &PartitionOptions::new(p))?;
    let fraction = keep as f64 / n as f64;
    let bar = indicatif::ProgressBar::new(part.n_patches() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} patches [{elapsed}]")
            .expect("static template"),
    );
    let positions =
        patchwise_reconstruction(&input.mesh, &part, args.basis.kind, fraction, &|done, _| {
            bar.set_position(done as u64)
        })?;
    bar.finish_and_clear();
    let seconds = t.elapsed().as_secs_f64();
    let mut out = input.mesh.clone();
    out.positions = positions;
    write_mesh(&args.output, &out, &WriteOptions::default())?;
    let (relative_error, maxd) = errors(&input.mesh.positions, &out.positions);
    let report = PatchJson {
        source: &input.source,
        kind: args.basis.kind,
        vertices: n,
        patch_size: p,
        keep_fraction: fraction,
        partition: part.stats(),
        relative_error,
        max_displacement: maxd / input.mesh.bbox_diagonal().max(f64::MIN_POSITIVE),
        seconds,
    };
    if args.json {
        return print_json(&report);
    }
    let st = part.stats();
    println!(
        "{} patches (sizes {}–{}, edge cut {}), kept {:.2}% of each patch's {} coefficients: relative error {:.3e}, max displacement {:.3e} × bbox diagonal, {:.2} s; wrote {}",
        st.patches,
        st.min_size,
        st.max_size,
        st.edge_cut,
        100.0 * fraction,
        report.kind,
        relative_error,
        report.max_displacement,
        seconds,
        args.output.display()
    );
    Ok(())
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let input = args.mesh.open()?;
    let n = input.mesh.n_vertices();
    let keep = parse_keep(&args.keep, n)?;
    if let Some(p) = args.patch_size {
        return run_patches(args, &input, keep, p);
    }
    let op = args.basis.operator(&input)?;
    let (basis, seconds) = args.basis.basis(&op)?;
    let x = positions_to_mat(&input.mesh.positions);
    let coeffs = forward(&basis, x.as_ref()).map_err(meshlap::Error::from)?;
    let y = inverse(&basis, coeffs.as_ref().subrows(0, keep))?;
    let mut out = input.mesh.clone();
    out.positions = mat_to_positions(y.as_ref())?;
    write_mesh(&args.output, &out, &WriteOptions::default())?;

    let energy_kept = energy_compaction(coeffs.as_ref()).total[keep - 1];
    let (mut err2, mut norm2, mut maxd) = (0.0f64, 0.0f64, 0.0f64);
    for i in 0..n {
        let mut d2 = 0.0;
        for c in 0..3 {
            d2 += (x[(i, c)] - y[(i, c)]).powi(2);
            norm2 += x[(i, c)].powi(2);
        }
        err2 += d2;
        maxd = maxd.max(d2.sqrt());
    }
    let report = ProjectJson {
        source: &input.source,
        kind: args.basis.kind,
        path: basis.path(),
        vertices: n,
        keep,
        energy_kept,
        relative_error: if norm2 > 0.0 {
            (err2 / norm2).sqrt()
        } else {
            0.0
        },
        max_displacement: maxd / input.mesh.bbox_diagonal().max(f64::MIN_POSITIVE),
        seconds,
    };
    if args.json {
        return print_json(&report);
    }
    println!(
        "kept {keep} of {n} {} coefficients ({} path): {:.4}% of the energy; relative error {:.3e}, max displacement {:.3e} × bbox diagonal; wrote {}",
        report.kind,
        report.path,
        100.0 * report.energy_kept,
        report.relative_error,
        report.max_displacement,
        args.output.display()
    );
    Ok(())
}
