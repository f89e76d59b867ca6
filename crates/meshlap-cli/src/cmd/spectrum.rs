//! `meshlap spectrum`.

use crate::common::{print_json, MeshArgs};
use indicatif::{ProgressBar, ProgressStyle};
use meshlap::input::Input;
use meshlap::operator::{Operator, OperatorKind};
use meshlap::spectral::{BasisOptions, DenseSolver, EigenBasis, EigenPath, Normalization};
use serde::Serialize;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Operator and eigensolver options shared by `spectrum`, `project` and
/// `compaction`.
#[derive(clap::Args, Debug, Clone)]
pub struct BasisArgs {
    /// Operator kind: kirchhoff (kl), tutte (tl), graph (gl), sql, sstl, cotan (with its
    /// lumped mass: L v = λ M v), or any other from `meshlap operator --help`.
    #[arg(long, short)]
    pub kind: OperatorKind,
    /// Eigensolver: auto (symmetric operators directly; the TL and other operators
    /// with a positive diagonal symmetrizer through their symmetric similar matrix,
    /// e.g. the TL through the GL), symmetric, symmetrized, or general (non-symmetric
    /// eigendecomposition plus a dense LU solve for the coefficients, as Matlab's
    /// eig + E\x in the paper's Fig. 3).
    #[arg(long, default_value = "auto")]
    pub path: EigenPath,
    /// Dense symmetric eigensolver: faer (parallel divide and conquer) or
    /// reproducible (sequential, the same bits on every CPU, faster for n below a
    /// few hundred; the codec's patch solver).
    #[arg(long, default_value = "faer")]
    pub dense_solver: DenseSolver,
    /// Basis scaling: unit (unit-length eigenvectors, as Matlab's eig) or weighted
    /// (orthonormal in the symmetrizer's / mass matrix's inner product).
    #[arg(long, default_value = "unit", value_parser = ["unit", "weighted"])]
    pub normalization: String,
    /// SQL boundary diagonal: zero-row-sum (correct) or printed (the paper's erratum).
    #[arg(long, default_value = "zero-row-sum", value_parser = ["zero-row-sum", "printed"])]
    pub sql_diagonal: String,
    /// Mass matrix of the cotangent operator: voronoi or barycentric.
    #[arg(long, default_value = "voronoi", value_parser = ["voronoi", "barycentric"])]
    pub mass: String,
}

impl BasisArgs {
    /// Assembles the operator on `input`.
    pub fn operator(&self, input: &Input) -> meshlap::Result<Operator> {
        let opts = super::operator::options(&self.sql_diagonal, &self.mass);
        Ok(Operator::assemble(
            self.kind,
            &input.mesh,
            &input.topology,
            &opts,
        )?)
    }

    /// The basis options.
    pub fn options(&self) -> BasisOptions {
        BasisOptions {
            path: self.path,
            normalization: if self.normalization == "weighted" {
                Normalization::Weighted
            } else {
                Normalization::Unit
            },
            dense_solver: self.dense_solver,
            ..Default::default()
        }
    }

    /// Computes the dense basis under a spinner (stderr, hidden when not a TTY);
    /// returns it with the seconds taken.
    pub fn basis(&self, op: &Operator) -> meshlap::Result<(EigenBasis, f64)> {
        let n = op.matrix.nrows();
        let bar = ProgressBar::new_spinner();
        bar.set_style(ProgressStyle::with_template("{spinner} {msg} [{elapsed}]").unwrap());
        bar.set_message(format!("eigendecomposing the {n}×{n} {} operator", op.kind));
        if n > 300 {
            bar.enable_steady_tick(Duration::from_millis(120));
        }
        let t = Instant::now();
        let basis = EigenBasis::compute(op, &self.options());
        let secs = t.elapsed().as_secs_f64();
        bar.finish_and_clear();
        Ok((basis?, secs))
    }
}

/// Eigenvalues (ascending) and eigenvectors of a mesh operator by a full dense
/// eigendecomposition (n ≤ 5000): the basis of the ED-transform x = E·X of Zhang
/// (2004) §2.3. Operators use the paper's sign convention F = D − W (positive
/// semi-definite), so the smoothest eigenvector comes first.
///
/// Eigenvectors are canonical and deterministic: repeated eigenvalues (e.g. on
/// builtin:icosphere) get a fixed basis of their eigenspace and every vector a fixed
/// sign, so a decoder recomputing the basis from the connectivity gets the same
/// vectors whatever the thread count.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub mesh: MeshArgs,
    #[command(flatten)]
    pub basis: BasisArgs,
    /// Report only the k smallest eigenpairs (default: all n).
    #[arg(long, value_name = "k")]
    pub count: Option<usize>,
    /// Write the eigenvectors as an n×k float64 NumPy array (column j ↔ eigenvalue j).
    #[arg(long, value_name = "FILE.npy")]
    pub vectors: Option<PathBuf>,
    /// Print machine-readable JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct SpectrumJson<'a> {
    source: &'a str,
    kind: OperatorKind,
    path: EigenPath,
    vertices: usize,
    count: usize,
    eigenvalues: &'a [f64],
    /// Sizes of the eigenvalue clusters among the reported ones, in order.
    multiplicities: Vec<usize>,
    max_residual: f64,
    orthonormality_error: Option<f64>,
    seconds: f64,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let input = args.mesh.open()?;
    let n = input.mesh.n_vertices();
    let count = match args.count {
        None => n,
        Some(k) if k >= 1 && k <= n => k,
        Some(k) => {
            return Err(meshlap::Error::InvalidArgument(format!(
                "--count must be in 1..={n} for this mesh, got {k}"
            )))
        }
    };
    if n > meshlap::spectral::DENSE_LIMIT {
        if args.count.is_none() {
            return Err(meshlap::Error::InvalidArgument(format!(
                "n = {n} vertices exceeds the dense eigensolver's limit of {}; ask for the k smallest with --count k (shift-invert partial spectrum)",
                meshlap::spectral::DENSE_LIMIT
            )));
        }
        return run_partial(args, &input, count);
    }
    let op = args.basis.operator(&input)?;
    let (basis, seconds) = args.basis.basis(&op)?;
    if let Some(path) = &args.vectors {
        meshlap::io::write_npy(path, basis.vectors().subcols(0, count))?;
    }
    let eigenvalues = &basis.eigenvalues()[..count];
    let multiplicities: Vec<usize> = basis
        .clusters()
        .iter()
        .filter(|c| c.0 < count)
        .map(|c| c.1.min(count - c.0))
        .collect();
    let max_residual = basis.max_residual_first(&op.matrix, op.mass.as_deref(), count);
    let orthonormality_error = basis.orthonormality_error_first(count);
    if args.json {
        return print_json(&SpectrumJson {
            source: &input.source,
            kind: args.basis.kind,
            path: basis.path(),
            vertices: n,
            count,
            eigenvalues,
            multiplicities,
            max_residual,
            orthonormality_error,
            seconds,
        });
    }
    println!(
        "{} operator of {} ({n} vertices), {} path, {seconds:.3} s",
        args.basis.kind,
        input.source,
        basis.path()
    );
    println!(
        "max residual ‖Fe − λe‖ = {max_residual:.3e}; orthonormality error = {}",
        orthonormality_error.map_or("n/a (general path)".into(), |e| format!("{e:.3e}"))
    );
    println!("{:>6}  {:>22}  {:>5}", "j", "eigenvalue", "mult");
    for &(start, k) in basis.clusters() {
        let end = (start + k).min(count);
        for (j, lam) in eigenvalues.iter().enumerate().take(end).skip(start) {
            let mult = if j == start {
                k.to_string()
            } else {
                String::new()
            };
            println!("{j:>6}  {lam:>22.15e}  {mult:>5}");
        }
    }
    Ok(())
}

#[derive(Serialize)]
struct PartialJson<'a> {
    source: &'a str,
    kind: OperatorKind,
    path: &'static str,
    vertices: usize,
    count: usize,
    eigenvalues: &'a [f64],
    residuals: &'a [f64],
    max_residual: f64,
    bands: usize,
    seconds: f64,
}

/// Large meshes: the k smallest eigenpairs by banded shift-invert block Krylov–Schur
/// (`meshlap::spectral::partial`), with a progress bar over the pairs found.
fn run_partial(args: &Args, input: &Input, count: usize) -> meshlap::Result<()> {
    use meshlap::spectral::partial::{operator_partial_spectrum, PartialOptions};
    let op = args.basis.operator(input)?;
    let bar = ProgressBar::new(count as u64);
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} shift-invert bands {pos}/{len} eigenpairs {elapsed}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let t = Instant::now();
    let ps = operator_partial_spectrum(&op, true, &PartialOptions::new(count), &mut |found, _| {
        bar.set_position(found as u64)
    })?;
    bar.finish_and_clear();
    let seconds = t.elapsed().as_secs_f64();
    if let Some(path) = &args.vectors {
        meshlap::io::write_npy(path, ps.eigenvectors.as_ref())?;
    }
    let max_residual = ps.residuals.iter().fold(0.0f64, |a, &b| a.max(b));
    if args.json {
        return print_json(&PartialJson {
            source: &input.source,
            kind: args.basis.kind,
            path: "shift-invert",
            vertices: input.mesh.n_vertices(),
            count,
            eigenvalues: &ps.eigenvalues,
            residuals: &ps.residuals,
            max_residual,
            bands: ps.bands.len(),
            seconds,
        });
    }
    println!(
        "{} operator of {} ({} vertices), shift-invert path ({} bands), {seconds:.3} s",
        args.basis.kind,
        input.source,
        input.mesh.n_vertices(),
        ps.bands.len()
    );
    println!("max residual ‖Fe − λe‖ = {max_residual:.3e}");
    println!("{:>6}  {:>22}  {:>10}", "j", "eigenvalue", "residual");
    for (j, (lam, r)) in ps.eigenvalues.iter().zip(&ps.residuals).enumerate() {
        println!("{j:>6}  {lam:>22.15e}  {r:>10.2e}");
    }
    Ok(())
}
