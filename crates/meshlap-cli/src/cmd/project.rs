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
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub mesh: MeshArgs,
    #[command(flatten)]
    pub basis: BasisArgs,
    /// Coefficients kept: a count m (1 ≤ m ≤ n) or a percentage of n such as 10%.
    #[arg(long, short = 'm', value_name = "m|P%")]
    pub keep: String,
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

pub fn run(args: &Args) -> meshlap::Result<()> {
    let input = args.mesh.open()?;
    let n = input.mesh.n_vertices();
    let keep = parse_keep(&args.keep, n)?;
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
