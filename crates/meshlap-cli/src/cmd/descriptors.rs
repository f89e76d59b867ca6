//! `meshlap descriptors`.

use crate::common::{print_json, MeshArgs};
use meshlap::operator::{Operator, OperatorKind};
use meshlap::spectral::descriptors::{descriptors, DescriptorParams};
use serde::Serialize;
use std::path::PathBuf;

/// Per-vertex spectral shape descriptors: the heat kernel signature (Sun, Ovsjanikov &
/// Guibas 2009), HKS(x, t) = Σ exp(−λᵢt) φᵢ(x)², at times log-spaced over
/// [4 ln10/λ_max, 4 ln10/λ₁], and the wave kernel signature (Aubry, Schlickewei &
/// Cremers 2011) at log-energies from log λ₁ + 2σ to log λ_max − 2σ, σ = 7δ. The
/// eigenpairs (F = D − W, positive semi-definite; the cotangent operator with its
/// lumped mass) are the k smallest, by the shift-invert partial solver. Writes an n×C
/// float64 .npy: the HKS columns, then the WKS columns.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub mesh: MeshArgs,
    /// Operator kind (cotan, kirchhoff, sql, …; see `meshlap operator --help`).
    /// (`-k` is the number of eigenpairs here.)
    #[arg(long)]
    pub kind: OperatorKind,
    /// HKS columns (times).
    #[arg(long, default_value_t = DescriptorParams::default().hks)]
    pub hks: usize,
    /// WKS columns (energies).
    #[arg(long, default_value_t = DescriptorParams::default().wks)]
    pub wks: usize,
    /// Eigenpairs used (at most n).
    #[arg(short = 'k', long, default_value_t = DescriptorParams::default().eigenpairs)]
    pub eigenpairs: usize,
    /// Output .npy file (n × (hks + wks), float64).
    #[arg(short, long, value_name = "OUT.npy")]
    pub output: PathBuf,
    /// Print machine-readable JSON (times, energies, sigma, eigenvalues).
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct DescriptorsJson<'a> {
    kind: OperatorKind,
    vertices: usize,
    columns: usize,
    times: &'a [f64],
    energies: &'a [f64],
    sigma: f64,
    eigenvalues: &'a [f64],
    output: String,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let input = args.mesh.open()?;
    let op = Operator::on_input(args.kind, &input)?;
    let params = DescriptorParams {
        eigenpairs: args.eigenpairs,
        hks: args.hks,
        wks: args.wks,
    };
    let d = descriptors(&op, &params)?;
    meshlap::io::write_npy(&args.output, d.values.as_ref())?;
    if args.json {
        return print_json(&DescriptorsJson {
            kind: args.kind,
            vertices: d.values.nrows(),
            columns: d.values.ncols(),
            times: &d.times,
            energies: &d.energies,
            sigma: d.sigma,
            eigenvalues: &d.eigenvalues,
            output: args.output.display().to_string(),
        });
    }
    println!(
        "{} HKS and {} WKS columns of the {} operator ({} eigenpairs, λ up to {:.6e}); wrote {}",
        d.times.len(),
        d.energies.len(),
        args.kind,
        d.eigenvalues.len(),
        d.eigenvalues.last().copied().unwrap_or(0.0),
        args.output.display()
    );
    Ok(())
}
