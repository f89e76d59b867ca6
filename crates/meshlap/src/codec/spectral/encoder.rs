//! The spectral encoder: partition, bases and unquantized coefficients once, then a
//! stream per quantization step (rate control codes several).

use super::coefficients::{octave, Models, FREQ_BANDS};
use super::header::Header;
use super::params::SpectralParams;
use super::patches::{
    bases_then, border_and_loose, chunks, layout, predictor_owners, stream, PatchBasis,
    PatchLayout, Recipe, CHUNK_BYTES,
};
use super::residuals::Residuals;
use crate::codec::entropy::RangeEncoder;
use crate::codec::quantize::{dead_zone, nearest};
use crate::codec::{CodecError, ParameterError};
use crate::mesh::graph::VertexGraph;
use faer::Mat;
use glam::DVec3;

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

/// A patch's coordinates (n_p×3, the basis' row order) from the positions (n×3).
fn patch_coordinates(b: &PatchBasis, positions: &[[f64; 3]]) -> Mat<f64> {
    Mat::from_fn(b.verts.len(), 3, |i, k| positions[b.verts[i] as usize][k])
}

/// The full bases of the patches `range` of `layout` (with their predictors when
/// `owner` is given) and the unquantized coefficients (m×3) of the positions (n×3) on
/// them, in parallel, each patch's analysis right after its basis in the same task
/// (while the basis is in cache); `then` gets each patch's index, basis and
/// coefficients there, and its results are returned in patch order.
fn analyzed_bases_then<T: Send>(
    topo: &VertexGraph,
    params: &SpectralParams,
    layout: &[PatchLayout],
    owner: Option<&[u32]>,
    positions: &[[f64; 3]],
    range: std::ops::Range<usize>,
    then: impl Fn(usize, PatchBasis, Mat<f64>) -> Result<T, CodecError> + Sync,
) -> Result<Vec<T>, CodecError> {
    bases_then(
        topo,
        params,
        Recipe::for_version(crate::codec::container::VERSION),
        layout,
        owner,
        range,
        |_| usize::MAX,
        |p, b| {
            let c = b.analyze(&patch_coordinates(&b, positions))?;
            then(p, b, c)
        },
    )
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

/// Bytes of bases (at most 3n_p²/2 values per patch, `PatchLayout::basis_bytes`) that
/// [`SpectralEncoder::new`] keeps for rate control's repeated encodes; above it every
/// encode computes the bases again, a chunk at a time. With their predictors and
/// allocations the kept bases take about twice this.
pub const CACHE_BYTES: usize = 1 << 30;

/// The bases: kept for every encode, or computed again by each.
enum Bases {
    /// Every patch's basis and unquantized coefficients (m×3).
    Kept(Vec<PatchBasis>, Vec<Mat<f64>>),
    /// Computed in chunks of about `chunk` bytes ([`CHUNK_BYTES`]) during each
    /// encode ([`stream`]), with the predictors' patch owners.
    Streamed {
        owner: Option<Vec<u32>>,
        chunk: usize,
    },
}

/// Precomputed state of the spectral encoder: the partition and, when they fit
/// [`CACHE_BYTES`] (or the budget given to [`SpectralEncoder::with_cache_budget`]),
/// the bases that rate control reuses.
pub struct SpectralEncoder<'a> {
    topo: &'a VertexGraph,
    params: SpectralParams,
    layout: Vec<PatchLayout>,
    bases: Bases,
    positions: &'a [[f64; 3]],
    border: Vec<bool>,
    residuals: Residuals,
}

/// The state of one encode pass, patch after patch.
struct Pass {
    enc: RangeEncoder,
    models: Models,
    rec: Vec<[f64; 3]>,
    octave_bits: [f64; FREQ_BANDS],
}

impl<'a> SpectralEncoder<'a> {
    /// Partitions, decomposes and transforms; `positions` (n×3) are in the
    /// connectivity coder's (decoded) vertex order, `topo` is the decoded
    /// connectivity. The bases are kept for later encodes when they fit
    /// [`CACHE_BYTES`].
    pub fn new(
        topo: &'a VertexGraph,
        positions: &'a [[f64; 3]],
        params: SpectralParams,
    ) -> Result<Self, CodecError> {
        Self::with_cache_budget(topo, positions, params, CACHE_BYTES)
    }

    /// [`Self::new`] keeping the bases only when they take at most `budget` bytes
    /// (n_p² values per patch); else each [`Self::encode`] computes them again, a chunk
    /// at a time, so the memory stays bounded at any mesh size. A single encode (a
    /// fixed step) costs the same either way, and the stream is the same bytes.
    pub fn with_cache_budget(
        topo: &'a VertexGraph,
        positions: &'a [[f64; 3]],
        params: SpectralParams,
        budget: usize,
    ) -> Result<Self, CodecError> {
        Self::with_budgets(topo, positions, params, budget, CHUNK_BYTES)
    }

    /// [`Self::with_cache_budget`] streaming in chunks of about `chunk` bytes.
    pub(super) fn with_budgets(
        topo: &'a VertexGraph,
        positions: &'a [[f64; 3]],
        params: SpectralParams,
        budget: usize,
        chunk: usize,
    ) -> Result<Self, CodecError> {
        params.validate()?;
        let layout = layout(topo, &params, crate::codec::container::VERSION)?;
        let owner = predictor_owners(topo.n_vertices(), &params, &layout);
        let total: usize = layout.iter().map(PatchLayout::basis_bytes).sum();
        let bases = if total <= budget {
            let (b, c) = analyzed_bases_then(
                topo,
                &params,
                &layout,
                owner.as_deref(),
                positions,
                0..layout.len(),
                |_, b, c| Ok((b, c)),
            )?
            .into_iter()
            .unzip();
            Bases::Kept(b, c)
        } else {
            Bases::Streamed { owner, chunk }
        };
        let (border, loose) = border_and_loose(topo, &layout);
        let residuals = Residuals::new(&border, &loose, params.border_residuals);
        Ok(SpectralEncoder {
            topo,
            params,
            layout,
            bases,
            positions,
            border,
            residuals,
        })
    }

    /// Whether each encode computes the bases again (they did not fit the budget).
    pub fn streams(&self) -> bool {
        matches!(self.bases, Bases::Streamed { .. })
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

    /// Codes one patch: its prediction from the earlier patches, its quantized
    /// coefficients, and its reconstruction into `pass.rec`.
    fn encode_patch(
        &self,
        pass: &mut Pass,
        b: &PatchBasis,
        c: &Mat<f64>,
        step: f64,
        measure: bool,
    ) -> Result<(), CodecError> {
        let (xhat, chat) = match &b.pred {
            Some(pr) => {
                let xh = pr.predict(&pass.rec);
                let ch = b.analyze(&xh)?;
                (Some(xh), Some(ch))
            }
            None => (None, None),
        };
        let Pass {
            enc,
            models,
            octave_bits,
            ..
        } = pass;
        let q = models.code_patch(c.nrows(), step, self.params.band_slope, |j, k, s, model| {
            let base = chat.as_ref().map_or(0.0, |ch| ch[(j, k)]);
            let qi = dead_zone(c[(j, k)] - base, s, self.params.dead_zone)?;
            if measure {
                octave_bits[octave(j)] += model.cost(qi) as f64;
            }
            model.encode(enc, qi);
            Ok(qi)
        })?;
        b.place(xhat.as_ref(), &b.synthesize(&q)?, &mut pass.rec);
        Ok(())
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
        let n = self.topo.n_vertices();
        let mut pass = Pass {
            enc: RangeEncoder::new(),
            models: Models::new(),
            rec: vec![[0.0f64; 3]; n],
            octave_bits: [0.0f64; FREQ_BANDS],
        };
        match &self.bases {
            Bases::Kept(bases, coefs) => {
                for (b, c) in bases.iter().zip(coefs) {
                    self.encode_patch(&mut pass, b, c, step, measure)?;
                }
            }
            Bases::Streamed { owner, chunk } => {
                let ranges = chunks(&self.layout, *chunk);
                let compute = |r, sink: &(dyn Fn(usize, _) + Sync)| {
                    analyzed_bases_then(
                        self.topo,
                        &self.params,
                        &self.layout,
                        owner.as_deref(),
                        self.positions,
                        r,
                        |p, b, c| {
                            sink(p, (b, c));
                            Ok(())
                        },
                    )?;
                    Ok(())
                };
                stream(&ranges, compute, |_, (b, c)| {
                    self.encode_patch(&mut pass, &b, &c, step, measure)
                })?;
            }
        }
        let Pass {
            mut enc,
            mut models,
            mut rec,
            octave_bits,
        } = pass;
        let mut stats = SpectralStats {
            patches: self.layout.len(),
            coefficients: self.layout.iter().map(|l| l.m).sum(),
            octave_bpv: if measure {
                octave_bits.iter().map(|b| b / n.max(1) as f64).collect()
            } else {
                Vec::new()
            },
            ..Default::default()
        };
        let (mut be, mut bn, mut ie, mut inn) = (0.0, 0usize, 0.0, 0usize);
        for l in &self.layout {
            for &v in &l.verts {
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
