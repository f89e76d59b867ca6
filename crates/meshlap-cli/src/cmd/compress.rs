//! `meshlap compress`.

use crate::common::{print_json, MeshArgs};
use meshlap::codec::spatial::SpatialParams;
use meshlap::codec::spectral::{Keep, SpectralParams};
use meshlap::codec::{compress, CompressOptions, GeometryMode, Quantisation};
use meshlap::operator::OperatorKind;
use std::path::PathBuf;

/// Compress a mesh to a `.mlz` file: connectivity losslessly (cut-border machine,
/// range-coded), geometry by one of two coders (`--mode`): Karni–Gotsman spectral
/// coding — per patch of about `--patch-size` vertices, the eigenvectors of a
/// combinatorial Laplacian (F = D − W, positive semi-definite) are the frequencies;
/// the lowest are kept, quantised and range-coded, and the decoder rebuilds the bases
/// from the connectivity — or spatial coding — each vertex, in the connectivity
/// coder's order, predicted from already decoded ones (parallelograms), its residual
/// quantised in the loop and range-coded. By default both are tried and the better
/// kept (spectral wins at low rates, spatial at high rates). The mesh must be
/// manifold and consistently oriented (see `meshlap clean`).
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub mesh: MeshArgs,
    /// Output file (.mlz).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Geometry coder: auto (code both, keep the lower error — under `--target-bpv`
    /// the lower product of vertex RMS and normal RMS, under `--bits` the lower
    /// log2(vertex RMS · normal RMS) + 2·geometry bpv/3), spectral or spatial.
    #[arg(long, default_value = "auto")]
    pub mode: GeometryMode,
    /// Spatial coder: rate–distortion multiplier μ (step² per bit) of the rounding
    /// (each residual is rounded to the nearest integer or the next one towards zero,
    /// whichever has the lower squared error + μ·bits) and of the predictor choice;
    /// 0: plain rounding.
    #[arg(long, default_value_t = SpatialParams::default().lambda)]
    pub rdo_lambda: f64,
    /// Spatial coder: always predict by the mean of the parallelograms instead of
    /// letting the encoder choose per vertex between it and single parallelograms.
    #[arg(long)]
    pub no_select: bool,
    /// Operator whose eigenvectors form the basis: sstl, sql, tutte, kirchhoff, graph.
    #[arg(long, default_value = "kirchhoff")]
    pub operator: OperatorKind,
    /// Patch size in vertices (each patch is eigen-decomposed densely).
    #[arg(long, default_value_t = 100)]
    pub patch_size: usize,
    /// Fraction of each patch's coefficients kept (low frequencies first).
    #[arg(long, conflicts_with = "coefficients")]
    pub keep_ratio: Option<f64>,
    /// Number of coefficients kept per patch.
    #[arg(long)]
    pub coefficients: Option<u32>,
    /// Quantisation: step = bounding-box diagonal · 2^-bits.
    #[arg(long, conflicts_with = "target_bpv")]
    pub bits: Option<f64>,
    /// Rate control: the finest quantisation whose file fits this many bits per vertex.
    #[arg(long)]
    pub target_bpv: Option<f64>,
    /// Store the input vertex order (costs about log2(n) bits per vertex).
    #[arg(long)]
    pub preserve_order: bool,
    /// Per-band steps: band b of 4 (low to high frequency) uses step·(1 + slope·b/3).
    #[arg(long, default_value_t = 1.0)]
    pub band_slope: f64,
    /// Border-aware coding: also code the residuals of patch-border vertices, where a
    /// truncated basis errs most (useful with a keep ratio below 1).
    #[arg(long)]
    pub border_residuals: bool,
    /// Dead-zone rounding offset θ in [0.2, 0.5] of the coefficient quantiser,
    /// q = sign(c)·floor(|c|/step + θ) (0.5: plain rounding; smaller values zero more
    /// small coefficients, trading a little error for rate).
    #[arg(long, default_value_t = 0.35)]
    pub dead_zone: f64,
    /// Turn off inter-patch prediction (each patch codes its coordinates instead of
    /// their difference from the smoothest continuation of earlier patches).
    #[arg(long)]
    pub no_prediction: bool,
    /// Also measure the distortion of the decoded mesh against the input (the
    /// metrics of `meshlap compare`, through the coder's vertex order).
    #[arg(long)]
    pub measure: bool,
    /// Sample points per surface for `--measure`.
    #[arg(long, default_value_t = 200_000)]
    pub samples: usize,
    /// Print machine-readable JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let input = args.mesh.open()?;
    let keep = match (args.keep_ratio, args.coefficients) {
        (_, Some(m)) => Keep::Count(m),
        (Some(r), None) => Keep::Ratio(r),
        (None, None) => SpectralParams::default().keep,
    };
    let quantisation = match (args.bits, args.target_bpv) {
        (_, Some(b)) => Quantisation::TargetBpv(b),
        (Some(q), None) => Quantisation::Bits(q),
        (None, None) => Quantisation::Bits(10.0),
    };
    let opts = CompressOptions {
        mode: args.mode,
        spatial: SpatialParams {
            select: !args.no_select,
            lambda: args.rdo_lambda,
        },
        geometry: SpectralParams {
            operator: args.operator,
            patch_size: args.patch_size,
            keep,
            border_residuals: args.border_residuals,
            band_slope: args.band_slope,
            predicted: !args.no_prediction,
            dead_zone: args.dead_zone,
        },
        quantisation,
        preserve_order: args.preserve_order,
    };
    let c = compress(&input.mesh, &input.topology, &opts)?;
    meshlap::io::write_atomic(&args.output, |w| w.write_all(&c.bytes))?;
    let r = &c.report;
    let distortion = if args.measure {
        Some(meshlap::metric::compare(
            &input.mesh,
            &c.decoded,
            Some(&c.order),
            args.samples,
        )?)
    } else {
        None
    };
    if args.json {
        #[derive(serde::Serialize)]
        struct Out<'a> {
            #[serde(flatten)]
            report: &'a meshlap::codec::CompressReport,
            distortion: Option<meshlap::metric::Comparison>,
        }
        return print_json(&Out {
            report: r,
            distortion,
        });
    }
    println!(
        "wrote           {} ({} bytes)",
        args.output.display(),
        r.bytes
    );
    println!("vertices        {}  faces {}", r.vertices, r.faces);
    println!(
        "bits/vertex     {:.3} total = {:.3} connectivity + {:.3} geometry + {:.3} order",
        r.bits_per_vertex, r.connectivity_bpv, r.geometry_bpv, r.permutation_bpv
    );
    println!(
        "quantisation    step {:.4e} ({:.2} bits of the diagonal)",
        r.step, r.quantisation_bits
    );
    println!(
        "geometry        {} coder, vertex RMS {:.4e}, normal RMS {:.4e} (of the diagonal)",
        r.geometry_mode, r.vertex_rms, r.normal_rms
    );
    if r.geometry_mode == GeometryMode::Spectral {
        println!(
            "spectral        {} patches, {} coefficients, {} residual vertices",
            r.geometry.patches, r.geometry.coefficients, r.geometry.residual_vertices
        );
        println!(
            "patch borders   spectral RMS {:.4e} on borders vs {:.4e} inside",
            r.geometry.border_rms_before, r.geometry.interior_rms
        );
    }
    if let Some(d) = distortion {
        println!(
            "distortion      vertex RMS {:.4e}  Metro RMS {:.4e}/{:.4e}  Hausdorff {:.4e} (of the diagonal)",
            d.vertex_rms.unwrap_or(f64::NAN),
            d.a_to_b_rms,
            d.b_to_a_rms,
            d.hausdorff
        );
    }
    Ok(())
}
