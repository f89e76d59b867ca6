//! `meshlap operator`.

use crate::common::{opt, print_json, MeshArgs};
use meshlap::analysis::operator_report::operator_report;
use meshlap::analysis::properties::PropertyOptions;
use meshlap::operator::{
    cotan::MassKind, sql::BoundaryDiagonal, Operator, OperatorKind, OperatorOptions,
};
use std::path::PathBuf;

/// Assemble a Laplacian operator and report its matrix-theoretic properties, each
/// measured on the matrix: symmetry, negative weights, irreducibility, row and column
/// sums, the smoothing matrix H = I − F/k (nonnegative, row- or doubly stochastic,
/// variance diminishing), positive semi-definiteness, GSML status with the failing
/// condition named, and the spectrum against its Gershgorin bounds.
///
/// Kinds: kirchhoff (kl), tutte (tl), graph (gl), sql, sstl, tutte2 (t2), sdl, cotan,
/// mean-value (mv). Sign convention F = D − W (positive semi-definite).
///
/// On non-manifold meshes every kind but the SQL is assembled from its definition
/// (graph operators from the distinct neighbours; the cotangent and mean-value weights
/// sum over every face at an edge or vertex); the SQL needs the two vertices opposite
/// an edge and refuses a non-manifold edge, naming it.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub mesh: MeshArgs,
    /// Operator kind (d_i = vertex degree, A = adjacency, N(i) = one-ring):
    ///   kirchhoff, kl   K = diag(d) − A (graph Laplacian, symmetric)
    ///   tutte, tl       T = I − D⁻¹A (uniform "umbrella" Laplacian, row-normalised)
    ///   graph, gl       G = I − D^{-1/2} A D^{-1/2} (normalized graph Laplacian)
    ///   sql             Zhang's symmetric quasi-Laplacian S = D − W,
    ///                   W_ij = 1/d_i + 1/d_j − (1/d_k + 1/d_l)/2 (k, l opposite ij)
    ///   sstl            second-order symmetric Tutte Laplacian J = TᵀT (two-ring)
    ///   tutte2, t2      T² (non-symmetric, for comparison)
    ///   sdl             scale-dependent Laplacian (inverse edge lengths, row-normalised)
    ///   cotan           cotangent Laplace–Beltrami stiffness (Pinkall–Polthier,
    ///                   Desbrun et al.) with a lumped mass matrix (--mass)
    ///   mean-value, mv  Floater's mean-value weights, row-normalised
    #[arg(long, short, verbatim_doc_comment)]
    pub kind: OperatorKind,
    /// Write the matrix as Matrix Market (coordinate real general, 1-based), readable
    /// by scipy.io.mmread, in the cleaned mesh's vertex order.
    #[arg(long, short, value_name = "FILE.mtx")]
    pub output: Option<PathBuf>,
    /// Write the cotangent operator's lumped mass matrix (--mass; n×n, diagonal) as
    /// Matrix Market, as --output writes the stiffness: `L v = λ M v` from the two
    /// files. Only with --kind cotan.
    #[arg(long, value_name = "FILE.mtx")]
    pub mass_output: Option<PathBuf>,
    /// Print machine-readable JSON: every field of the report, including symmetric,
    /// negative_weights, max_abs_row_sum, gsml, lambda_min, lambda_max,
    /// gershgorin_max, zero_eigenvalue_multiplicity and, for TL and GL,
    /// same_spectrum_max_difference.
    #[arg(long)]
    pub json: bool,
    /// SQL boundary diagonal: zero-row-sum (correct) or printed (the paper's erratum).
    #[arg(long, value_enum, default_value_t = BoundaryDiagonal::default())]
    pub sql_diagonal: BoundaryDiagonal,
    /// Mass matrix of the cotangent operator: voronoi or barycentric.
    #[arg(long, value_enum, default_value_t = MassKind::default())]
    pub mass: MassKind,
    /// Largest n for which the full spectrum is computed densely.
    #[arg(long, default_value_t = PropertyOptions::default().dense_limit)]
    pub dense_limit: usize,
}

pub fn options(sql_boundary: BoundaryDiagonal, mass: MassKind) -> OperatorOptions {
    OperatorOptions { sql_boundary, mass }
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    if args.mass_output.is_some() && args.kind != OperatorKind::Cotan {
        return Err(meshlap::Error::InvalidArgument(format!(
            "--mass-output: the {} operator has no mass matrix (only --kind cotan has one)",
            args.kind
        )));
    }
    let input = args.mesh.open()?;
    let opts = options(args.sql_diagonal, args.mass);
    let op = Operator::assemble(args.kind, &input.mesh, &input.topology, &opts)?;
    if let Some(path) = &args.output {
        meshlap::io::write_matrix_market(path, op.matrix.as_ref())?;
    }
    if let (Some(path), Some(mass)) = (&args.mass_output, op.mass_matrix()) {
        meshlap::io::write_matrix_market(path, mass.as_ref())?;
    }
    let popts = PropertyOptions {
        dense_limit: args.dense_limit,
        ..Default::default()
    };
    let out = operator_report(&input, &op, &opts, &popts)?;
    if args.json {
        return print_json(&out);
    }
    let r = &out.report;
    println!("operator        {} on {}", args.kind, input.source);
    println!("size            n = {}, nnz = {}", r.n, r.nnz);
    println!(
        "symmetric       {} (max |F − Fᵀ| = {:.3e})",
        r.symmetric, r.max_asymmetry
    );
    match &r.most_negative_weight {
        Some(w) => println!(
            "weights         {} negative (most negative {:.6} on ({}, {}))",
            r.negative_weights, w.weight, w.i, w.j
        ),
        None => println!("weights         all nonnegative"),
    }
    println!(
        "irreducible     {} ({} pattern components)",
        r.irreducible, r.pattern_components
    );
    println!("row sums        max |Σ_j F_ij| = {:.3e}", r.max_abs_row_sum);
    println!(
        "column sums     [{:.6}, {:.6}]",
        r.column_sum_min, r.column_sum_max
    );
    let s = &r.smoothing;
    println!(
        "H = I − F/k     k = {:.6}: nonnegative {}, row-stochastic {}, doubly stochastic {}, variance diminishing {} (gain {})",
        s.k, s.nonnegative, s.row_stochastic, s.doubly_stochastic, s.variance_diminishing,
        opt(s.variance_gain)
    );
    println!("spectrum        {}", r.spectrum_method);
    println!(
        "eigenvalues     λ_min = {}, λ_max = {}, Gershgorin [{:.6}, {:.6}] holds: {}",
        opt(r.lambda_min),
        opt(r.lambda_max),
        r.gershgorin_min,
        r.gershgorin_max,
        r.gershgorin_holds.map_or("n/a".into(), |b| b.to_string())
    );
    println!(
        "zero eigenvalue multiplicity {} (components of the mesh: {})",
        r.zero_eigenvalue_multiplicity
            .map_or("n/a".into(), |m| m.to_string()),
        input.topology.components().1
    );
    println!(
        "PSD             {}",
        r.positive_semidefinite
            .map_or("n/a".into(), |b| b.to_string())
    );
    if let Some(d) = out.same_spectrum_max_difference {
        println!("TL/GL spectra   max difference {d:.3e}");
    }
    if r.gsml.is_gsml {
        println!("GSML            yes");
    } else {
        println!("GSML            no: fails {}", r.gsml.failing.join(", "));
    }
    for p in args.output.iter().chain(&args.mass_output) {
        println!("wrote           {}", p.display());
    }
    Ok(())
}
