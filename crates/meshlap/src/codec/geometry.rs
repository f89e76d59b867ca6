//! The geometry section of an `.mlz` file: a mode byte (0 spectral, 1 spatial) and
//! the chosen coder's stream; and the two coders of one mesh, set up once for every
//! step that rate control tries.

use super::spatial::{self, SpatialParams};
use super::spectral::{self, SpectralEncoder, SpectralParams, SpectralStats, CACHE_BYTES};
use super::{CodecError, GeometryMode};
use crate::mesh::graph::VertexGraph;
use crate::mesh::topology::Topology;

const MODE_SPECTRAL: u8 = 0;
const MODE_SPATIAL: u8 = 1;

/// A coded geometry section.
pub(super) struct GeometrySection {
    /// The section: mode byte and stream.
    pub bytes: Vec<u8>,
    /// The positions the decoder will produce (decoded vertex order, n×3).
    pub decoded: Vec<[f64; 3]>,
    /// The spectral coder's measurements (spatial mode: `bytes` only).
    pub stats: SpectralStats,
}

/// The geometry coders of one mesh, in the decoded vertex order.
pub(super) struct Coders<'a> {
    topo: &'a Topology,
    positions: &'a [[f64; 3]],
    spectral: Option<SpectralEncoder<'a>>,
    spatial: Option<(spatial::Plan, SpatialParams)>,
    /// The spatial section at the fixed step, coded during the set-up.
    spatial_fixed: Option<Result<GeometrySection, CodecError>>,
}

impl<'a> Coders<'a> {
    /// Sets up the coders of `modes` for the decoded connectivity `topo` and the
    /// positions in its vertex order. The spectral coder's set-up (partition, bases,
    /// prediction) is long and starts with the partition; the spatial
    /// coder's plan — and, at a `fixed_step`, its whole encode — runs beside it on
    /// the other thread.
    pub fn new(
        topo: &'a Topology,
        positions: &'a [[f64; 3]],
        modes: &[GeometryMode],
        spectral_params: SpectralParams,
        spatial_params: SpatialParams,
        fixed_step: Option<f64>,
    ) -> Result<Self, CodecError> {
        let (spectral, spatial_pre) = rayon::join(
            || {
                modes
                    .contains(&GeometryMode::Spectral)
                    .then(|| {
                        // One encode at a fixed step: nothing to reuse, so stream the
                        // bases (bounded memory); rate control keeps them if they fit.
                        let budget = match fixed_step {
                            Some(_) => 0,
                            None => CACHE_BYTES,
                        };
                        SpectralEncoder::with_cache_budget(
                            topo.graph(),
                            positions,
                            spectral_params,
                            budget,
                        )
                    })
                    .transpose()
            },
            || {
                modes.contains(&GeometryMode::Spatial).then(|| {
                    let plan = spatial::Plan::new(topo);
                    let fixed = fixed_step
                        .map(|step| spatial_section(topo, positions, &plan, &spatial_params, step));
                    (plan, fixed)
                })
            },
        );
        let (spatial, spatial_fixed) = match spatial_pre {
            Some((plan, fixed)) => (Some((plan, spatial_params)), fixed),
            None => (None, None),
        };
        Ok(Coders {
            topo,
            positions,
            spectral: spectral?,
            spatial,
            spatial_fixed,
        })
    }

    /// The geometry section of `mode` at `step`; `final_pass` adds the spectral
    /// coder's per-octave measurements (rate control's trial encodes skip them).
    pub fn encode(
        &self,
        mode: GeometryMode,
        step: f64,
        final_pass: bool,
    ) -> Result<GeometrySection, CodecError> {
        match (mode, &self.spectral, &self.spatial) {
            (GeometryMode::Spectral, Some(enc), _) => {
                let s = if final_pass {
                    enc.encode(step)?
                } else {
                    enc.encode_fast(step)?
                };
                let mut bytes = Vec::with_capacity(s.bytes.len() + 1);
                bytes.push(MODE_SPECTRAL);
                bytes.extend_from_slice(&s.bytes);
                Ok(GeometrySection {
                    bytes,
                    decoded: s.decoded,
                    stats: s.stats,
                })
            }
            (GeometryMode::Spatial, _, Some((plan, params))) => {
                spatial_section(self.topo, self.positions, plan, params, step)
            }
            _ => Err(CodecError::Internal("geometry mode without its encoder")),
        }
    }

    /// The spatial section coded during the set-up at the fixed step (once).
    pub fn take_spatial_fixed(&mut self) -> Option<Result<GeometrySection, CodecError>> {
        self.spatial_fixed.take()
    }
}

/// The spatial section of one step.
fn spatial_section(
    topo: &Topology,
    positions: &[[f64; 3]],
    plan: &spatial::Plan,
    params: &SpatialParams,
    step: f64,
) -> Result<GeometrySection, CodecError> {
    let (data, decoded) = spatial::encode(topo, plan, positions, step, params)?;
    let mut bytes = Vec::with_capacity(data.len() + 1);
    bytes.push(MODE_SPATIAL);
    bytes.extend_from_slice(&data);
    let stats = SpectralStats {
        bytes: bytes.len(),
        ..Default::default()
    };
    Ok(GeometrySection {
        bytes,
        decoded,
        stats,
    })
}

/// Decodes a geometry section of a file of format `version` for the decoded
/// connectivity (`n` vertices, `faces`), building what its mode reads: the vertex
/// graph for the spectral coder, the half-edges for the spatial one. Faces the
/// connectivity checks refuse give [`CodecError::CorruptFaces`].
pub(super) fn decode(
    n: usize,
    faces: &[[u32; 3]],
    section: &[u8],
    version: u16,
) -> Result<Vec<[f64; 3]>, CodecError> {
    match section.split_first() {
        None => Err(CodecError::Truncated("geometry header")),
        Some((&MODE_SPECTRAL, rest)) => {
            let graph = VertexGraph::from_faces(n, faces).map_err(CodecError::CorruptFaces)?;
            spectral::decode(&graph, rest, version)
        }
        Some((&MODE_SPATIAL, rest)) => {
            let topo = Topology::from_faces(n, faces).map_err(CodecError::CorruptFaces)?;
            spatial::decode(&topo, rest)
        }
        Some(_) => Err(CodecError::Corrupt("unknown geometry mode")),
    }
}
