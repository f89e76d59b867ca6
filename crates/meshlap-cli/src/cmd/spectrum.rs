//! `meshlap spectrum`.

use crate::common::{print_json, MeshArgs};
use indicatif::{ProgressBar, ProgressStyle};
use meshlap::input::Input;
use meshlap::operator::cotan::MassKind;
use meshlap::operator::sql::BoundaryDiagonal;
use meshlap::operator::{Operator, OperatorKind};
use meshlap::spectral::partial::PartialParams;
use meshlap::spectral::{
    smallest, BasisOptions, DenseSolver, EigenPath, Normalization, SmallestParams, SmallestPath,
    SpectralError,
};
use serde::Serialize;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// The mesh, operator and eigensolver options shared by `spectrum`, `project` and
/// `compaction`.
#[derive(clap::Args, Debug, Clone)]
pub struct BasisArgs {
    #[command(flatten)]
    pub mesh: MeshArgs,
    /// Operator kind: kirchhoff (kl), tutte (tl), graph (gl), sql, sstl, cotan (with its
    /// lumped mass: L v = λ M v), or any other from `meshlap operator --help`.
    #[arg(long, short)]
    pub kind: OperatorKind,
    /// Eigensolver: auto (symmetric operators directly; the TL and other operators
    /// with a positive diagonal symmetrizer through their symmetric similar matrix,
    /// e.g. the TL through the GL), symmetric, symmetrized, or general (non-symmetric
    /// eigendecomposition plus a dense LU solve for the coefficients, as Matlab's
    /// eig + E\x in the paper's Fig. 3).
    #[arg(long, default_value_t = BasisOptions::default().path)]
    pub path: EigenPath,
    /// Dense symmetric eigensolver: faer (parallel divide and conquer) or
    /// reproducible (sequential, the same bits on every CPU, faster for n below a
    /// few hundred; the codec's patch solver).
    #[arg(long, default_value_t = BasisOptions::default().dense_solver)]
    pub dense_solver: DenseSolver,
    /// Basis scaling: unit (unit-length eigenvectors, as Matlab's eig) or weighted
    /// (orthonormal in the symmetrizer's / mass matrix's inner product).
    #[arg(long, value_enum, default_value_t = Normalization::default())]
    pub normalization: Normalization,
    /// SQL boundary diagonal: zero-row-sum (correct) or printed (the paper's erratum).
    #[arg(long, value_enum, default_value_t = BoundaryDiagonal::default())]
    pub sql_diagonal: BoundaryDiagonal,
    /// Mass matrix of the cotangent operator: voronoi or barycentric.
    #[arg(long, value_enum, default_value_t = MassKind::default())]
    pub mass: MassKind,
}

impl BasisArgs {
    /// Assembles the operator on `input`.
    pub fn operator(&self, input: &Input) -> meshlap::Result<Operator> {
        let opts = super::operator::options(self.sql_diagonal, self.mass);
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
            normalization: self.normalization,
            dense_solver: self.dense_solver,
            ..Default::default()
        }
    }
}

/// Eigenvalues (ascending) and eigenvectors of a mesh operator by a full dense
/// eigendecomposition (n ≤ 5000; above it the k smallest by shift-invert, with
/// --count k): the basis of the ED-transform x = E·X of Zhang
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
    pub basis: BasisArgs,
    /// Report only the k smallest eigenpairs (default: all n).
    #[arg(long, value_name = "k")]
    pub count: Option<usize>,
    /// Write the eigenvectors as an n×k float64 NumPy array (column j ↔ eigenvalue j).
    #[arg(long, value_name = "FILE.npy")]
    pub vectors: Option<PathBuf>,
    /// Shift-invert path: Ritz tolerance relative to each pair's |μ| = 1/|λ − σ|.
    #[arg(long, default_value_t = PartialParams::new(1).tolerance, allow_negative_numbers = true)]
    pub tol: f64,
    /// Shift-invert path: eigenpairs computed per shift (the band size b); the
    /// Krylov basis holds about 2.5 b vectors of length n.
    #[arg(long, default_value_t = PartialParams::new(1).band_size, value_name = "b")]
    pub band_size: usize,
    /// Shift-invert path: vectors per block of the block Krylov–Schur iteration (p,
    /// 1 ≤ p ≤ b): solves run on p right-hand sides at once, and eigenvalues of
    /// multiplicity up to p are found from one start.
    #[arg(long, default_value_t = PartialParams::new(1).block_size, value_name = "p")]
    pub block_size: usize,
    /// Shift-invert path: skip the refinement of each band (one subspace-iteration
    /// step and a Rayleigh–Ritz step with the operator; residuals about 20x lower).
    #[arg(long)]
    pub no_refine: bool,
    /// Print machine-readable JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct SpectrumJson<'a> {
    source: &'a str,
    kind: OperatorKind,
    path: String,
    vertices: usize,
    count: usize,
    eigenvalues: &'a [f64],
    /// Sizes of the eigenvalue clusters among the reported ones, in order.
    multiplicities: &'a [usize],
    #[serde(skip_serializing_if = "Option::is_none")]
    residuals: Option<&'a [f64]>,
    max_residual: f64,
    orthonormality_error: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    bands: Option<usize>,
    /// Bands whose Krylov–Schur run stopped at its accuracy floor.
    #[serde(skip_serializing_if = "Option::is_none")]
    stagnated_bands: Option<usize>,
    seconds: f64,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let input = args.basis.mesh.open()?;
    let n = input.mesh.n_vertices();
    let op = args.basis.operator(&input)?;
    let defaults = SmallestParams::default();
    let params = SmallestParams {
        basis: args.basis.options(),
        partial: PartialParams {
            tolerance: args.tol,
            band_size: args.band_size,
            block_size: args.block_size,
            refine: !args.no_refine,
            ..defaults.partial
        },
        ..defaults
    };
    let bar = if n > params.dense_limit {
        let bar = ProgressBar::new(args.count.unwrap_or(n) as u64);
        bar.set_style(
            ProgressStyle::with_template(
                "{spinner} shift-invert bands {pos}/{len} eigenpairs {elapsed}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar
    } else {
        let bar = ProgressBar::new_spinner();
        bar.set_style(ProgressStyle::with_template("{spinner} {msg} [{elapsed}]").unwrap());
        bar.set_message(format!("eigendecomposing the {n}×{n} {} operator", op.kind));
        if n > 300 {
            bar.enable_steady_tick(Duration::from_millis(120));
        }
        bar
    };
    let t = Instant::now();
    let result = smallest(&op, args.count, &params, &mut |found, _| {
        bar.set_position(found as u64)
    });
    bar.finish_and_clear();
    let seconds = t.elapsed().as_secs_f64();
    let sp = result.map_err(|e| match e {
        SpectralError::TooMany { count, n } => meshlap::Error::InvalidArgument(format!(
            "--count must be in 1..={n} for this mesh, got {count}"
        )),
        SpectralError::TooLarge { n, limit } => meshlap::Error::InvalidArgument(format!(
            "n = {n} vertices exceeds the dense eigensolver's limit of {limit}; ask for the k smallest with --count k (shift-invert partial spectrum)"
        )),
        e => e.into(),
    })?;
    let count = sp.eigenvalues.len();
    if let Some(path) = &args.vectors {
        meshlap::io::write_npy(path, sp.eigenvectors.as_ref())?;
    }
    let info = &sp.info;
    let partial = info.path == SmallestPath::ShiftInvert;
    let stagnated = info.bands.iter().filter(|b| b.stagnated).count();
    if args.json {
        return print_json(&SpectrumJson {
            source: &input.source,
            kind: args.basis.kind,
            path: info.path.to_string(),
            vertices: n,
            count,
            eigenvalues: &sp.eigenvalues,
            multiplicities: &info.multiplicities,
            residuals: sp.residuals.as_deref(),
            max_residual: info.max_residual,
            orthonormality_error: info.orthonormality_error,
            bands: partial.then_some(info.bands.len()),
            stagnated_bands: partial.then_some(stagnated),
            seconds,
        });
    }
    let bands = match (partial, stagnated) {
        (false, _) => String::new(),
        (true, 0) => format!(" ({} bands)", info.bands.len()),
        (true, s) => format!(
            " ({} bands, {s} stopped at their accuracy floor, up to 10x above --tol)",
            info.bands.len()
        ),
    };
    println!(
        "{} operator of {} ({n} vertices), {} path{bands}, {seconds:.3} s",
        args.basis.kind, input.source, info.path
    );
    match info.orthonormality_error {
        _ if partial => println!("max residual ‖Fe − λe‖ = {:.3e}", info.max_residual),
        e => println!(
            "max residual ‖Fe − λe‖ = {:.3e}; orthonormality error = {}",
            info.max_residual,
            e.map_or("n/a (general path)".into(), |e| format!("{e:.3e}"))
        ),
    }
    println!(
        "{:>6}  {:>22}  {:>5}  {:>10}",
        "j", "eigenvalue", "mult", "residual"
    );
    let mut j = 0;
    for &m in &info.multiplicities {
        for t in 0..m {
            let mult = if t == 0 { m.to_string() } else { String::new() };
            let res = sp
                .residuals
                .as_ref()
                .map_or(String::new(), |r| format!("{:.2e}", r[j]));
            println!(
                "{j:>6}  {:>22.15e}  {mult:>5}  {res:>10}",
                sp.eigenvalues[j]
            );
            j += 1;
        }
    }
    Ok(())
}
