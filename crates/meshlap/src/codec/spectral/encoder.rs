//! The spectral encoder: partition, bases and unquantized coefficients once, then a
//! stream per quantization step (rate control codes several).

use super::coefficients::{octave, Models, FREQ_BANDS};
use super::header::Header;
use super::params::SpectralParams;
use super::patches::{bases, border_and_loose, Arithmetic, PatchBasis};
use super::residuals::Residuals;
use crate::codec::entropy::RangeEncoder;
use crate::codec::quantize::{dead_zone, nearest};
use crate::codec::{CodecError, ParameterError};
use crate::mesh::topology::Topology;
use faer::Mat;
use glam::DVec3;
use rayon::prelude::*;

/// What the spectral encoder measured.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct SpectralStats {
    /// Number of patches.
    pub patches: usize,
    /// Coefficients kept (all patches, per coordinate).
    pub coefficients: usize,
    /// Vertices coded by residual (patch borders and loose vertices).
    pub residual_vertices: usize,
    /// RMS vertex error of the spectral reconstruction on patch-border vertices,
    /// before residual coding.
    pub border_rms_before: f64,
    /// The same on interior vertices.
    pub interior_rms: f64,
    /// Bits per vertex spent on the coefficients of each frequency octave `⌈log2(j+1)⌉`
    /// of the coefficient index `j` (0, 1, 2–3, 4–7, …, 64 and above), from the
    /// adaptive models' costs (empty when not measured).
    pub octave_bpv: Vec<f64>,
    /// Geometry stream bytes.
    pub bytes: usize,
}

/// A coded spectral geometry stream.
#[derive(Clone, Debug)]
pub struct EncodedSpectral {
    /// The stream: header and range-coded payload.
    pub bytes: Vec<u8>,
    /// The positions the decoder will produce from it (decoded vertex order, n×3).
    pub decoded: Vec<[f64; 3]>,
    /// The encoder's measurements.
    pub stats: SpectralStats,
}

/// Precomputed state of the spectral encoder (bases are reused by rate control).
pub struct SpectralEncoder<'a> {
    topo: &'a Topology,
    params: SpectralParams,
    bases: Vec<PatchBasis>,
    /// Unquantized coefficients per patch, m×3.
    coefs: Vec<Mat<f64>>,
    positions: &'a [[f64; 3]],
    border: Vec<bool>,
    residuals: Residuals,
}

impl<'a> SpectralEncoder<'a> {
    /// Partitions, decomposes and transforms; `positions` (n×3) are in the
    /// connectivity coder's (decoded) vertex order, `topo` is the decoded
    /// connectivity.
    pub fn new(
        topo: &'a Topology,
        positions: &'a [[f64; 3]],
        params: SpectralParams,
    ) -> Result<Self, CodecError> {
        params.validate()?;
        // The current format (version 6): fixed-order products, the same on every CPU.
        let bases = bases(topo, &params, Arithmetic::Fixed)?;
        let coefs = bases
            .par_iter()
            .map(|b| {
                let np = b.verts.len();
                let mut x = Mat::<f64>::zeros(np, 3);
                for (i, &v) in b.verts.iter().enumerate() {
                    for k in 0..3 {
                        x[(i, k)] = positions[v as usize][k];
                    }
                }
                b.analyze(&x)
            })
            .collect::<Result<Vec<_>, _>>()?;
        let (border, loose) = border_and_loose(topo, &bases);
        let residuals = Residuals::new(&border, &loose, params.border_residuals);
        Ok(SpectralEncoder {
            topo,
            params,
            bases,
            coefs,
            positions,
            border,
            residuals,
        })
    }

    /// Codes the geometry with global step `step`; returns the stream, the
    /// reconstruction the decoder will produce, and statistics.
    pub fn encode(&self, step: f64) -> Result<EncodedSpectral, CodecError> {
        self.encode_measured(step, true)
    }

    /// [`Self::encode`] without the per-octave cost measurement (rate control).
    pub(crate) fn encode_fast(&self, step: f64) -> Result<EncodedSpectral, CodecError> {
        self.encode_measured(step, false)
    }

    fn encode_measured(&self, step: f64, measure: bool) -> Result<EncodedSpectral, CodecError> {
        if !(step.is_finite() && step > 0.0) {
            return Err(ParameterError::Step(step).into());
        }
        let mut out = Vec::new();
        Header {
            params: self.params,
            step,
        }
        .write(&mut out)?;
        let mut enc = RangeEncoder::new();
        let mut models = Models::new();
        let n = self.topo.n_vertices();
        let mut rec = vec![[0.0f64; 3]; n];
        let mut octave_bits = [0.0f64; FREQ_BANDS];
        for (b, c) in self.bases.iter().zip(&self.coefs) {
            let (xhat, chat) = match &b.pred {
                Some(pr) => {
                    let xh = pr.predict(&rec);
                    let ch = b.analyze(&xh)?;
                    (Some(xh), Some(ch))
                }
                None => (None, None),
            };
            let q =
                models.code_patch(c.nrows(), step, self.params.band_slope, |j, k, s, model| {
                    let base = chat.as_ref().map_or(0.0, |ch| ch[(j, k)]);
                    let qi = dead_zone(c[(j, k)] - base, s, self.params.dead_zone)?;
                    if measure {
                        octave_bits[octave(j)] += model.cost(qi) as f64;
                    }
                    model.encode(&mut enc, qi);
                    Ok(qi)
                })?;
            b.place(xhat.as_ref(), &b.synthesize(&q)?, &mut rec);
        }
        let mut stats = SpectralStats {
            patches: self.bases.len(),
            coefficients: self.coefs.iter().map(|c| c.nrows()).sum(),
            octave_bpv: if measure {
                octave_bits.iter().map(|b| b / n.max(1) as f64).collect()
            } else {
                Vec::new()
            },
            ..Default::default()
        };
        let (mut be, mut bn, mut ie, mut inn) = (0.0, 0usize, 0.0, 0usize);
        for b in &self.bases {
            for &v in &b.verts {
                let e = (DVec3::from(rec[v as usize]) - DVec3::from(self.positions[v as usize]))
                    .length_squared();
                if self.border[v as usize] {
                    be += e;
                    bn += 1;
                } else {
                    ie += e;
                    inn += 1;
                }
            }
        }
        stats.border_rms_before = (be / bn.max(1) as f64).sqrt();
        stats.interior_rms = (ie / inn.max(1) as f64).sqrt();
        self.residuals.code(
            self.topo,
            &mut rec,
            step,
            &mut models.resid,
            |v, k, pred, model| {
                let qi = nearest(self.positions[v as usize][k] - pred, step)?;
                model.encode(&mut enc, qi);
                Ok(qi)
            },
        )?;
        stats.residual_vertices = self.residuals.targets.len();
        out.extend_from_slice(&enc.finish());
        stats.bytes = out.len();
        Ok(EncodedSpectral {
            bytes: out,
            decoded: rec,
            stats,
        })
    }
}
