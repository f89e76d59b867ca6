//! `meshlap compress`.

use crate::common::{print_json, MeshInOut};
use meshlap::codec::{
    compress_owned, CompressOptions, CompressReport, Compressed, GeometryMode, Keep, Quantization,
    SpatialParams, SpectralParams,
};
use meshlap::operator::OperatorKind;

/// Compress a mesh to a `.mlz` file: connectivity losslessly (cut-border machine,
/// range-coded), geometry by one of two coders (`--mode`): Karni–Gotsman spectral
/// coding — per patch of about `--patch-size` vertices, the eigenvectors of a
/// combinatorial Laplacian (F = D − W, positive semi-definite) are the frequencies;
/// the lowest are kept, quantized and range-coded, and the decoder rebuilds the bases
/// from the connectivity — or spatial coding — each vertex, in the connectivity
/// coder's order, predicted from already decoded ones (parallelograms), its residual
/// quantized in the loop and range-coded. By default both are tried and the better
/// kept (spectral wins at low rates, spatial at high rates). Any mesh `clean`
/// accepts is compressed: non-manifold edges and vertices and inconsistently oriented
/// faces are cut apart for the connectivity coder and re-joined by the decoder (a
/// re-join section), so the decoded faces are exactly the input's.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub io: MeshInOut,
    /// Geometry coder: auto (code both, keep the lower error — under `--target-bpv`
    /// the lower product of vertex RMS and normal RMS, under `--bits` the lower
    /// log2(vertex RMS · normal RMS) + 2·geometry bpv/3), spectral or spatial.
    #[arg(long, value_enum, default_value_t = CompressOptions::default().mode)]
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
    #[arg(long, default_value_t = SpectralParams::default().operator)]
    pub operator: OperatorKind,
    /// Patch size in vertices (each patch is eigen-decomposed densely).
    #[arg(long, default_value_t = SpectralParams::default().patch_size)]
    pub patch_size: usize,
    /// Fraction of each patch's coefficients kept (low frequencies first; default:
    /// all).
    #[arg(long, conflicts_with = "coefficients")]
    pub keep_ratio: Option<f64>,
    /// Number of coefficients kept per patch.
    #[arg(long)]
    pub coefficients: Option<u32>,
    /// Quantization: step = bounding-box diagonal · 2^-bits.
    #[arg(long, conflicts_with = "target_bpv", default_value_t = Quantization::DEFAULT_BITS)]
    pub bits: f64,
    /// Rate control: the finest quantization whose file fits this many bits per vertex.
    #[arg(long)]
    pub target_bpv: Option<f64>,
    /// Store the input vertex order (costs about log2(n) bits per vertex).
    #[arg(long)]
    pub preserve_order: bool,
    /// Per-band steps: band b of 4 (low to high frequency) uses step·(1 + slope·b/3).
    #[arg(long, default_value_t = SpectralParams::default().band_slope)]
    pub band_slope: f64,
    /// Border-aware coding: also code the residuals of patch-border vertices, where a
    /// truncated basis errs most (useful with a keep ratio below 1).
    #[arg(long)]
    pub border_residuals: bool,
    /// Dead-zone rounding offset θ in [0.2, 0.5] of the coefficient quantizer,
    /// q = sign(c)·floor(|c|/step + θ) (0.5: plain rounding; smaller values zero more
    /// small coefficients, trading a little error for rate).
    #[arg(long, default_value_t = SpectralParams::default().dead_zone)]
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
    #[arg(long, default_value_t = Compressed::DEFAULT_SAMPLES)]
    pub samples: usize,
    /// Print machine-readable JSON.
    #[arg(long)]
    pub json: bool,
}

impl Args {
    /// The library's options from the arguments.
    fn options(&self) -> CompressOptions {
        CompressOptions {
            mode: self.mode,
            spectral: SpectralParams {
                operator: self.operator,
                patch_size: self.patch_size,
                keep: Keep::from_options(self.keep_ratio, self.coefficients),
                border_residuals: self.border_residuals,
                band_slope: self.band_slope,
                predicted: !self.no_prediction,
                dead_zone: self.dead_zone,
            },
            spatial: SpatialParams {
                select: !self.no_select,
                lambda: self.rdo_lambda,
            },
            quantization: Quantization::from_options(Some(self.bits), self.target_bpv),
            preserve_order: self.preserve_order,
        }
    }
}

pub fn run(args: &Args) -> meshlap::Result<()> {
    let meshlap::input::Input { mesh, topology, .. } = args.io.mesh.open()?;
    let c = compress_owned(&mesh, topology, &args.options())?;
    meshlap::io::write_atomic(&args.io.output, |w| w.write_all(&c.bytes))?;
    let distortion = if args.measure {
        Some(c.distortion(&mesh, args.samples)?)
    } else {
        None
    };
    let r = &c.report;
    if args.json {
        #[derive(serde::Serialize)]
        struct Out<'a> {
            #[serde(flatten)]
            report: &'a CompressReport,
            distortion: Option<meshlap::metric::Comparison>,
        }
        return print_json(&Out {
            report: r,
            distortion,
        });
    }
    println!(
        "wrote           {} ({} bytes)",
        args.io.output.display(),
        r.bytes
    );
    println!("vertices        {}  faces {}", r.vertices, r.faces);
    println!(
        "bits/vertex     {:.3} total = {:.3} connectivity + {:.3} geometry + {:.3} order + {:.3} re-join",
        r.bits_per_vertex, r.connectivity_bpv, r.geometry_bpv, r.permutation_bpv, r.rejoin_bpv
    );
    if r.vertex_copies > 0 {
        println!(
            "re-join         {} vertex copies (non-manifold or inconsistently oriented parts cut apart, re-joined on decoding)",
            r.vertex_copies
        );
    }
    println!(
        "quantization    step {:.4e} ({:.2} bits of the diagonal)",
        r.step, r.quantization_bits
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
