//! Embedding a watermark: Ohbuchi, Takahashi, Miyazawa, Mukaiyama (GI 2001) and
//! Ohbuchi, Mukaiyama, Takahashi (CGF 2002), spread-spectrum in the patch-wise
//! ED-transform of a combinatorial Laplacian (Zhang 2004 §4.9).
//!
//! With the layout of [`super::layout`] (patches, their `band` low-frequency
//! eigenvectors of `F = D − W`, DC skipped, and the key's slots and ±1 chips), bit
//! `b_i ∈ {0, 1}` with sign `s_i = 2b_i − 1` changes the coefficient of each of its `c`
//! slots by `α·s_i·chip`:
//!
//! `X′ = X + α·s_i·chip_{ij}`, hence `x′ = x + α Σ_{i,j} s_i chip_{ij} v_{k(ij)} e_{axis(ij)}`.
//!
//! **Amplitude.** `strength` is the watermark's RMS vertex displacement relative to
//! the bounding-box diagonal (the MRMS of the marked mesh): α is solved from it
//! exactly, `α = strength · diagonal / RMS(Σ s_i chip_{ij} v_k e_axis)` (for the
//! orthonormal KL/SQL/SSTL bases, `α ≈ strength · diagonal · √(n / (B·c))`). So every
//! mesh and operator pays the same distortion, stated in advance.
//!
//! The marked mesh has the input's connectivity and vertex order; only positions move.

use super::error::WatermarkError;
use super::layout::{Layout, LayoutParams};
use super::message::Message;
use crate::mesh::topology::Topology;
use crate::mesh::TriMesh;
use serde::Serialize;

/// Parameters of [`embed`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EmbedParams {
    /// The secret 64-bit key.
    pub key: u64,
    /// The message.
    pub message: Message,
    /// RMS displacement ÷ bounding-box diagonal (the MRMS), > 0.
    pub strength: f64,
    /// Operator, patches, band and chip rate (detection must use the same).
    pub layout: LayoutParams,
    /// Measure MSDM2 between the original and the marked mesh (the report's `msdm2`).
    pub measure_msdm2: bool,
}

/// Default strength: MRMS 1.2e-4 of the diagonal, below the goal of 1.5e-4. The
/// correlation SNR per bit grows as `MRMS·√(n/bits)`, but MSDM2 grows with the MRMS
/// too and is the binding distortion limit on some meshes (BENCHMARKS.md, "Spectral
/// watermarking", parameter sweep).
pub const DEFAULT_STRENGTH: f64 = 1.2e-4;

impl EmbedParams {
    /// Library defaults for `key` and `message`.
    pub fn new(key: u64, message: Message) -> Self {
        Self {
            key,
            message,
            strength: DEFAULT_STRENGTH,
            layout: LayoutParams::default(),
            measure_msdm2: true,
        }
    }
}

/// What [`embed`] did (JSON keys of `meshlap watermark embed`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EmbedReport {
    /// Bits embedded.
    pub bits: usize,
    /// Patches of the partition.
    pub patches: usize,
    /// Chip rate c: coefficients carrying each bit.
    pub coefficients_per_bit: usize,
    /// Coefficient slots available (3 × Σ band).
    pub slots: usize,
    /// α, the change of each carrying coefficient (mesh units).
    pub alpha: f64,
    /// RMS vertex displacement ÷ bounding-box diagonal.
    pub mrms: f64,
    /// Largest vertex displacement (mesh units).
    pub max_displacement: f64,
    /// MSDM2 between the original and the marked mesh (Lavoué 2011,
    /// [`crate::metric::msdm2`] with its published parameters), when measured.
    pub msdm2: Option<f64>,
    /// The layout used, with the patch size resolved
    /// ([`LayoutParams::patch_size_for`] the mesh).
    pub layout: LayoutParams,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// Embeds `params.message` into `mesh` under `params.key`; returns the marked mesh
/// (same connectivity and vertex order) and the report. The mesh must be clean
/// (every vertex on a face, manifold edges).
pub fn embed(
    mesh: &TriMesh,
    params: &EmbedParams,
) -> Result<(TriMesh, EmbedReport), WatermarkError> {
    let start = std::time::Instant::now();
    if !(params.strength > 0.0 && params.strength.is_finite()) {
        return Err(WatermarkError::InvalidParameter {
            name: "strength",
            value: params.strength.to_string(),
            reason: "must be a positive number (the MRMS, e.g. 1.2e-4)",
        });
    }
    let topo = Topology::new(mesh)?;
    let bits = params.message.bits();
    let layout = Layout::new(mesh, &topo, &params.layout, params.key, bits.len())?;
    let c = layout.chip_rate;
    let mut delta = vec![0.0; layout.slots];
    for (i, &b) in bits.iter().enumerate() {
        let s = if b { 1.0 } else { -1.0 };
        for j in 0..c {
            delta[layout.assigned[i * c + j] as usize] = s * layout.chips[i * c + j];
        }
    }
    let n = mesh.n_vertices();
    let d = layout.synthesize(&delta, n);
    let diag = mesh.bbox_diagonal();
    let ss: f64 = d
        .iter()
        .map(|v| v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
        .sum();
    let unit_rms = (ss / n as f64).sqrt();
    if !(unit_rms > 0.0 && diag > 0.0) {
        return Err(WatermarkError::InvalidParameter {
            name: "mesh",
            value: format!("diagonal {diag}"),
            reason: "the mesh is flat to a point: nothing to mark",
        });
    }
    let alpha = params.strength * diag / unit_rms;
    let mut marked = mesh.clone();
    let mut max_d2 = 0.0f64;
    let mut sum_d2 = 0.0;
    for (p, dv) in marked.positions.iter_mut().zip(&d) {
        let mut d2 = 0.0;
        for k in 0..3 {
            p[k] += alpha * dv[k];
            d2 += (alpha * dv[k]).powi(2);
        }
        max_d2 = max_d2.max(d2);
        sum_d2 += d2;
    }
    let msdm2 = if params.measure_msdm2 {
        Some(crate::metric::msdm2::msdm2(
            mesh,
            &marked,
            &crate::metric::msdm2::Msdm2Params::default(),
        )?)
    } else {
        None
    };
    let report = EmbedReport {
        bits: bits.len(),
        patches: layout.patches.len(),
        coefficients_per_bit: c,
        slots: layout.slots,
        alpha,
        mrms: (sum_d2 / n as f64).sqrt() / diag,
        max_displacement: max_d2.sqrt(),
        msdm2,
        layout: LayoutParams {
            patch_size: Some(params.layout.patch_size_for(n)),
            ..params.layout
        },
        seconds: start.elapsed().as_secs_f64(),
    };
    Ok((marked, report))
}
