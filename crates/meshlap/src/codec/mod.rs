//! Mesh compression: lossless connectivity coding ([`connectivity`], a cut-border
//! machine), adaptive range coding ([`entropy`]), the `.mlz` container
//! ([`container`]) and two geometry coders: spectral coding after Karni and Gotsman,
//! *Spectral compression of mesh geometry* (SIGGRAPH 2000) ([`geometry`]), and
//! spatial predictive coding (closed-loop parallelogram DPCM, [`spatial`]).
//!
//! **Geometry mode** (`.mlz` version 3: the geometry section starts with a mode
//! byte, 0 spectral, 1 spatial). A transform coder wins at low rates, where most
//! high-frequency coefficients quantise to zero; at high rates, where every
//! coefficient is significant, it pays about as much per coefficient as a predictive
//! coder pays per coordinate, and the parallelogram residual turned out to be the
//! cheaper signal. Measured at Draco's 10-bit step (bunny, `diag`-relative step
//! 6.1e-4, vertex RMS ≈ 3.0e-4): spectral (θ = ½, no band slope) 8.08 geometry
//! bits/vertex, lattice multi-parallelogram (zeroth-order entropy, Draco-like) 7.49,
//! closed-loop DPCM with contexts 7.12, with predictor selection 6.68. With
//! [`GeometryMode::Auto`] (default) the encoder codes both and keeps the better: under
//! rate control (`--target-bpv`), the lower product of the vertex RMS and the normal
//! RMS (the error along the input's vertex normals, which stands in for the surface
//! distance the encoder cannot afford to sample) within the budget; at a fixed step
//! (`--bits`), the lower `log2(RMS·normal RMS) + 2R/3` (`R`: geometry bits/vertex; one
//! bit per coordinate per halving of each error, the high-rate exchange rate).
//! Choosing by the vertex RMS alone picked the spatial coder for Igea at 6 bpv
//! (vertex RMS 3.19e-4 against 3.41e-4) whose Metro RMS was 19 % worse (1.72e-4
//! against 1.44e-4): the spectral coder's error is more tangential.

pub mod connectivity;
pub mod container;
pub mod entropy;
pub mod geometry;
pub mod spatial;

/// Errors of encoding and decoding.
#[derive(Debug, thiserror::Error)]
pub enum CodecError {
    /// The mesh has a non-manifold edge or vertex.
    #[error(
        "cannot compress a non-manifold mesh ({0}); run `meshlap clean --split-nonmanifold` first"
    )]
    NonManifold(String),
    /// The mesh is not consistently oriented.
    #[error("cannot compress a mesh that is not consistently oriented ({0} edges disagree)")]
    NotOriented(usize),
    /// The input ended early.
    #[error("truncated file: the {0} ends early")]
    Truncated(&'static str),
    /// The input is not a valid stream.
    #[error("corrupt file: {0}")]
    Corrupt(&'static str),
    /// Not an `.mlz` file.
    #[error("not a meshlap compressed file (bad magic number)")]
    BadMagic,
    /// A format version this build cannot read.
    #[error(
        "unsupported .mlz version {0}: this build reads version {v} only; re-compress the mesh with this meshlap",
        v = container::VERSION
    )]
    Version(u16),
    /// The checksum does not match.
    #[error("corrupt file: checksum mismatch in the {0} section")]
    Checksum(&'static str),
    /// A parameter is out of range.
    #[error("{0}")]
    Parameter(String),
    /// An internal invariant failed (a bug).
    #[error("internal codec error: {0}")]
    Internal(&'static str),
}

use crate::mesh::topology::Topology;
use crate::mesh::TriMesh;
use container::{ByteReader, SectionKind};
use entropy::{RangeDecoder, RangeEncoder};
use geometry::{GeometryEncoder, GeometryParams, GeometryStats};
use serde::Serialize;
use spatial::SpatialParams;

/// Which geometry coder.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum GeometryMode {
    /// Code both and keep the better (see the module documentation).
    Auto,
    /// Patch-wise spectral coding ([`geometry`]).
    Spectral,
    /// Parallelogram DPCM ([`spatial`]).
    Spatial,
}

impl std::fmt::Display for GeometryMode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            GeometryMode::Auto => "auto",
            GeometryMode::Spectral => "spectral",
            GeometryMode::Spatial => "spatial",
        })
    }
}

impl std::str::FromStr for GeometryMode {
    type Err = CodecError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s.to_ascii_lowercase().as_str() {
            "auto" => GeometryMode::Auto,
            "spectral" => GeometryMode::Spectral,
            "spatial" | "predictive" => GeometryMode::Spatial,
            _ => {
                return Err(CodecError::Parameter(format!(
                    "unknown geometry mode {s:?}: choose auto, spectral or spatial"
                )))
            }
        })
    }
}

const MODE_SPECTRAL: u8 = 0;
const MODE_SPATIAL: u8 = 1;

/// How finely the geometry is quantised.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum Quantisation {
    /// Global step `diag · 2^{−q}` (diag: bounding-box diagonal).
    Bits(f64),
    /// Rate control: the finest step whose whole file fits `b` bits per vertex.
    TargetBpv(f64),
}

/// Options of [`compress`].
#[derive(Copy, Clone, Debug)]
pub struct CompressOptions {
    /// Geometry coder: spectral, spatial or the better of the two.
    pub mode: GeometryMode,
    /// Spectral geometry coder parameters.
    pub geometry: GeometryParams,
    /// Spatial geometry coder parameters.
    pub spatial: SpatialParams,
    /// Quantisation or rate target.
    pub quantisation: Quantisation,
    /// Store the input vertex order (otherwise the decoder's order is the traversal's).
    pub preserve_order: bool,
}

impl Default for CompressOptions {
    fn default() -> Self {
        CompressOptions {
            mode: GeometryMode::Auto,
            geometry: GeometryParams::default(),
            spatial: SpatialParams::default(),
            quantisation: Quantisation::Bits(10.0),
            preserve_order: false,
        }
    }
}

/// Sizes and parameters of a compressed mesh.
#[derive(Clone, Debug, Serialize)]
pub struct CompressReport {
    /// Vertices.
    pub vertices: usize,
    /// Faces.
    pub faces: usize,
    /// File size in bytes.
    pub bytes: usize,
    /// Whole file, bits per vertex.
    pub bits_per_vertex: f64,
    /// Connectivity section, bits per vertex.
    pub connectivity_bpv: f64,
    /// Geometry section, bits per vertex.
    pub geometry_bpv: f64,
    /// Permutation section, bits per vertex (0 without `--preserve-order`).
    pub permutation_bpv: f64,
    /// Global quantisation step (absolute).
    pub step: f64,
    /// The same as bits: `log2(diag / step)`.
    pub quantisation_bits: f64,
    /// Operator of the basis.
    pub operator: crate::operator::OperatorKind,
    /// The geometry coder used (never `auto`).
    pub geometry_mode: GeometryMode,
    /// Vertex RMS error of the decoded positions, divided by the bounding-box
    /// diagonal (the encoder's own measurement).
    pub vertex_rms: f64,
    /// RMS of the error along the input's (area-weighted) vertex normals, divided by
    /// the diagonal: a cheap stand-in for the surface (Metro) distance.
    pub normal_rms: f64,
    /// Geometry coder measurements (spectral mode; zeros but `bytes` in spatial mode).
    pub geometry: GeometryStats,
}

/// A compressed mesh: the file image, the report, and the mesh the decoder will
/// produce (in the decoder's vertex order, or the input's with `preserve_order`).
#[derive(Clone, Debug)]
pub struct Compressed {
    /// The `.mlz` file image.
    pub bytes: Vec<u8>,
    /// Sizes and parameters.
    pub report: CompressReport,
    /// The decoded mesh.
    pub decoded: TriMesh,
    /// `order[i]` = input vertex of decoded vertex `i` (identity with `preserve_order`).
    pub order: Vec<u32>,
}

fn header_bytes(n: usize, f: usize) -> Vec<u8> {
    let mut h = Vec::with_capacity(8);
    h.extend_from_slice(&(n as u32).to_le_bytes());
    h.extend_from_slice(&(f as u32).to_le_bytes());
    h
}

fn encode_permutation(order: &[u32]) -> Vec<u8> {
    let n = order.len();
    let bits = usize::BITS - n.saturating_sub(1).leading_zeros();
    let mut enc = RangeEncoder::new();
    for &v in order {
        enc.direct(v, bits);
    }
    enc.finish()
}

fn decode_permutation(data: &[u8], n: usize) -> Result<Vec<u32>, CodecError> {
    let bits = usize::BITS - n.saturating_sub(1).leading_zeros();
    // Each entry takes `bits` bits: bound the count by the data before allocating.
    if (n as u64) * (bits as u64) > (data.len() as u64 + 8) * 8 {
        return Err(CodecError::Truncated("permutation"));
    }
    let mut dec = RangeDecoder::new(data);
    let mut seen = vec![false; n];
    let mut order = Vec::with_capacity(n);
    for _ in 0..n {
        let v = dec.direct(bits) as usize;
        if v >= n || seen[v] {
            return Err(CodecError::Corrupt("permutation is not a permutation"));
        }
        seen[v] = true;
        order.push(v as u32);
    }
    dec.finish()?;
    Ok(order)
}

/// A geometry section, the positions it decodes to, and the coder's statistics.
type EncodedGeo = (Vec<u8>, Vec<[f64; 3]>, GeometryStats);

/// Rate control: the largest `q ∈ [1, 30]` (step `diag·2^{−q}`) whose file `size(q)`
/// fits `budget` bytes (`q = 1` if none does). The size grows with `q`, nearly
/// linearly. A bracket `[lo, hi]` (`lo` fits, `hi` does not) is found by steps of 1,
/// 2, 4, … bits from `guess`, then narrowed by regula falsi (Illinois variant), each
/// guess kept at least 5 % of the bracket from either end, until the bracket is below
/// 1e-3 bits or `size(lo)` is within 0.1 % of the budget. With a guess within a bit
/// or two this takes 5–7 encodes (Igea at 8 bpv: 6 spectral, then 6 spatial from the
/// spectral answer + ½; bisection on [1, 30] took 15).
fn fit_bits(
    mut size: impl FnMut(f64) -> Result<usize, CodecError>,
    budget: usize,
    guess: f64,
) -> Result<f64, CodecError> {
    const MIN: f64 = 1.0;
    const MAX: f64 = 30.0;
    let q0 = guess.clamp(MIN, MAX);
    let s0 = size(q0)?;
    let (mut lo, mut s_lo, mut hi, mut s_hi);
    let mut d = 1.0;
    if s0 <= budget {
        (lo, s_lo) = (q0, s0);
        loop {
            if lo >= MAX {
                return Ok(MAX);
            }
            let q = (lo + d).min(MAX);
            let s = size(q)?;
            if s > budget {
                (hi, s_hi) = (q, s);
                break;
            }
            (lo, s_lo) = (q, s);
            d *= 2.0;
        }
    } else {
        (hi, s_hi) = (q0, s0);
        loop {
            if hi <= MIN {
                return Ok(MIN);
            }
            let q = (hi - d).max(MIN);
            let s = size(q)?;
            if s <= budget {
                (lo, s_lo) = (q, s);
                break;
            }
            (hi, s_hi) = (q, s);
            d *= 2.0;
        }
    }
    let b = budget as f64;
    // Illinois weights of the two ends (halved when an end is kept twice).
    let (mut w_lo, mut w_hi) = (1.0f64, 1.0f64);
    let mut last_side = 0i8;
    for _ in 0..40 {
        if hi - lo < 1e-3 || (b - s_lo as f64) < 1e-3 * b {
            break;
        }
        let (f_lo, f_hi) = (
            (s_lo as f64 - b) * w_lo,
            (s_hi.min(usize::MAX / 2) as f64 - b) * w_hi,
        );
        let mut t = if f_hi > f_lo {
            -f_lo / (f_hi - f_lo)
        } else {
            0.5
        };
        if !t.is_finite() {
            t = 0.5;
        }
        let mid = lo + (hi - lo) * t.clamp(0.05, 0.95);
        let s = size(mid)?;
        if s <= budget {
            lo = mid;
            s_lo = s;
            w_lo = 1.0;
            if last_side == 1 {
                w_hi *= 0.5;
            }
            last_side = 1;
        } else {
            hi = mid;
            s_hi = s;
            w_hi = 1.0;
            if last_side == -1 {
                w_lo *= 0.5;
            }
            last_side = -1;
        }
    }
    Ok(lo)
}

/// Compresses a manifold, consistently oriented mesh (Karni–Gotsman spectral geometry
/// coding over a cut-border connectivity code). `topo` is `mesh`'s connectivity.
pub fn compress(
    mesh: &TriMesh,
    topo: &Topology,
    opts: &CompressOptions,
) -> Result<Compressed, crate::Error> {
    mesh.validate()?;
    let n = mesh.n_vertices();
    let conn = connectivity::encode(topo)?;
    let positions: Vec<[f64; 3]> = conn
        .order
        .iter()
        .map(|&v| mesh.positions[v as usize])
        .collect();
    let dtopo = Topology::from_faces(n, &conn.faces)?;
    let diag = mesh.bbox_diagonal().max(f64::MIN_POSITIVE);
    let modes: &[GeometryMode] = match opts.mode {
        GeometryMode::Auto => &[GeometryMode::Spectral, GeometryMode::Spatial],
        GeometryMode::Spectral => &[GeometryMode::Spectral],
        GeometryMode::Spatial => &[GeometryMode::Spatial],
    };
    if let Quantisation::Bits(q) = opts.quantisation {
        if !(1.0..=40.0).contains(&q) {
            return Err(CodecError::Parameter(format!("--bits must be in 1..=40, got {q}")).into());
        }
    }
    // The spatial section of one step (stream, decoded positions, stats).
    let spatial_geo = |p: &spatial::Plan, step: f64| -> Result<EncodedGeo, CodecError> {
        let (data, rec) = spatial::encode(&dtopo, p, &positions, step, &opts.spatial)?;
        let mut out = Vec::with_capacity(data.len() + 10);
        out.push(MODE_SPATIAL);
        out.extend_from_slice(&step.to_le_bytes());
        out.push(opts.spatial.select as u8);
        out.extend_from_slice(&data);
        let stats = GeometryStats {
            bytes: out.len(),
            ..Default::default()
        };
        Ok((out, rec, stats))
    };
    // The spectral coder's set-up (partition, bases, prediction) is long and starts
    // with the sequential METIS call; the spatial coder's plan — and, at a fixed
    // step, its whole encode — runs beside it on the other thread.
    let (genc, spatial_pre) = rayon::join(
        || {
            modes
                .contains(&GeometryMode::Spectral)
                .then(|| GeometryEncoder::new(&dtopo, &positions, opts.geometry))
                .transpose()
        },
        || {
            modes.contains(&GeometryMode::Spatial).then(|| {
                let plan = spatial::Plan::new(&dtopo);
                let fixed = match opts.quantisation {
                    Quantisation::Bits(q) => Some(spatial_geo(&plan, diag * (-q).exp2())),
                    Quantisation::TargetBpv(_) => None,
                };
                (plan, fixed)
            })
        },
    );
    let genc = genc?;
    let (plan, mut spatial_fixed) = match spatial_pre {
        Some((p, f)) => (Some(p), f),
        None => (None, None),
    };
    // The geometry section of one mode at one step: stream, decoded positions, stats.
    let encode_geo =
        |mode: GeometryMode, step: f64, final_pass: bool| -> Result<EncodedGeo, CodecError> {
            match (mode, &genc, &plan) {
                (GeometryMode::Spectral, Some(g), _) => {
                    let (data, rec, stats) = if final_pass {
                        g.encode(step)?
                    } else {
                        g.encode_fast(step)?
                    };
                    let mut out = Vec::with_capacity(data.len() + 1);
                    out.push(MODE_SPECTRAL);
                    out.extend_from_slice(&data);
                    Ok((out, rec, stats))
                }
                (GeometryMode::Spatial, _, Some(p)) => spatial_geo(p, step),
                _ => Err(CodecError::Internal("geometry mode without its encoder")),
            }
        };
    let perm = if opts.preserve_order {
        Some(encode_permutation(&conn.order))
    } else {
        None
    };
    let header = header_bytes(n, mesh.n_faces());
    let assemble = |geo: &[u8]| -> Result<Vec<u8>, CodecError> {
        let mut secs: Vec<(SectionKind, &[u8])> = vec![
            (SectionKind::Header, &header),
            (SectionKind::Connectivity, &conn.data),
        ];
        if let Some(p) = &perm {
            secs.push((SectionKind::Permutation, p));
        }
        secs.push((SectionKind::Geometry, geo));
        container::write(&secs)
    };
    let rms = |rec: &[[f64; 3]]| -> f64 {
        let s: f64 = rec
            .iter()
            .zip(&positions)
            .map(|(a, b)| (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>())
            .sum();
        (s / n.max(1) as f64).sqrt() / diag
    };
    // Unit vertex normals of the input (area-weighted), in the decoded order.
    let normals: Vec<[f64; 3]> = {
        let mut nrm = vec![[0.0f64; 3]; n];
        for f in &conn.faces {
            let [a, b, c] = f.map(|v| positions[v as usize]);
            let (u, w) = (
                [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
                [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
            );
            let x = [
                u[1] * w[2] - u[2] * w[1],
                u[2] * w[0] - u[0] * w[2],
                u[0] * w[1] - u[1] * w[0],
            ];
            for &v in f {
                for k in 0..3 {
                    nrm[v as usize][k] += x[k];
                }
            }
        }
        nrm.iter()
            .map(|x| {
                let l = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt();
                if l > 0.0 {
                    x.map(|c| c / l)
                } else {
                    [0.0; 3]
                }
            })
            .collect()
    };
    // RMS of the error along the input's vertex normals ÷ diagonal.
    let normal_rms = |rec: &[[f64; 3]]| -> f64 {
        let s: f64 = rec
            .iter()
            .zip(&positions)
            .zip(&normals)
            .map(|((a, b), m)| (0..3).map(|k| (a[k] - b[k]) * m[k]).sum::<f64>().powi(2))
            .sum();
        (s / n.max(1) as f64).sqrt() / diag
    };
    // Per mode: (step, geometry section, decoded positions, stats).
    let mut best: Option<(f64, GeometryMode, f64, EncodedGeo)> = None;
    let mut last_q = None;
    for &mode in modes {
        let step = match opts.quantisation {
            Quantisation::Bits(q) => diag * (-q).exp2(),
            Quantisation::TargetBpv(b) => {
                if !(b.is_finite() && b > 0.0) {
                    return Err(CodecError::Parameter(format!("invalid --target-bpv {b}")).into());
                }
                let budget = (b * n as f64 / 8.0).floor() as usize;
                // A step too small for 31-bit integers counts as "too large a file".
                let size = |q: f64| -> Result<usize, CodecError> {
                    match encode_geo(mode, diag * (-q).exp2(), false) {
                        Ok((g, _, _)) => Ok(assemble(&g)?.len()),
                        Err(CodecError::Parameter(_)) => Ok(usize::MAX),
                        Err(e) => Err(e),
                    }
                };
                // The spatial coder runs at about half a bit finer than the spectral
                // one for the same rate (bunny, Igea at 6–8 bpv).
                let guess = match (mode, last_q) {
                    (GeometryMode::Spatial, Some(q)) => q + 0.5,
                    _ => 10.0,
                };
                let q = fit_bits(size, budget, guess)?;
                last_q = Some(q);
                diag * (-q).exp2()
            }
        };
        let pre = match mode {
            GeometryMode::Spatial => spatial_fixed.take(),
            _ => None,
        };
        let g = match pre {
            Some(g) => g?,
            None => encode_geo(mode, step, true)?,
        };
        let (e, en) = (rms(&g.1), normal_rms(&g.1));
        // Lower is better: the product of the vertex RMS and the normal RMS (the
        // latter stands in for the surface distance) under rate control; at a fixed
        // step, traded against rate at 3 bits/vertex per halving of each.
        let lg = |x: f64| x.max(f64::MIN_POSITIVE).log2();
        let score = lg(e)
            + lg(en)
            + match opts.quantisation {
                Quantisation::TargetBpv(_) => 0.0,
                Quantisation::Bits(_) => 2.0 * g.0.len() as f64 * 8.0 / n.max(1) as f64 / 3.0,
            };
        if best.as_ref().is_none_or(|b| score < b.0) {
            best = Some((score, mode, step, g));
        }
    }
    let (_, mode, step, (geo, rec, gstats)) =
        best.ok_or(CodecError::Internal("no geometry mode"))?;
    let bytes = assemble(&geo)?;
    let bpv = |b: usize| b as f64 * 8.0 / n.max(1) as f64;
    let report = CompressReport {
        vertices: n,
        faces: mesh.n_faces(),
        bytes: bytes.len(),
        bits_per_vertex: bpv(bytes.len()),
        connectivity_bpv: bpv(conn.data.len()),
        geometry_bpv: bpv(geo.len()),
        permutation_bpv: perm.as_ref().map_or(0.0, |p| bpv(p.len())),
        step,
        quantisation_bits: (diag / step).log2(),
        operator: opts.geometry.operator,
        geometry_mode: mode,
        vertex_rms: rms(&rec),
        normal_rms: normal_rms(&rec),
        geometry: gstats,
    };
    let (decoded, order) = if opts.preserve_order {
        let mut pos = vec![[0.0; 3]; n];
        for (i, &v) in conn.order.iter().enumerate() {
            pos[v as usize] = rec[i];
        }
        let faces = conn
            .faces
            .iter()
            .map(|f| f.map(|v| conn.order[v as usize]))
            .collect();
        (TriMesh::new(pos, faces), (0..n as u32).collect())
    } else {
        (TriMesh::new(rec, conn.faces.clone()), conn.order.clone())
    };
    Ok(Compressed {
        bytes,
        report,
        decoded,
        order,
    })
}

/// Decompresses an `.mlz` file image. Connectivity is rebuilt exactly; geometry to
/// the coded precision; vertex order is the input's if it was stored.
pub fn decompress(bytes: &[u8]) -> Result<TriMesh, CodecError> {
    let secs = container::read(bytes)?;
    let need = |k: SectionKind| {
        container::section(&secs, k).ok_or(CodecError::Corrupt("a required section is missing"))
    };
    let mut h = ByteReader::new(need(SectionKind::Header)?, "header");
    let n = h.u32()? as usize;
    let nf = h.u32()? as usize;
    let conn = need(SectionKind::Connectivity)?;
    // A face costs at least ~1/400 byte of range-coded data (adaptive probabilities
    // saturate): refuse counts the data cannot possibly hold before allocating.
    if nf as u64 > 400 * (conn.len() as u64 + 16) || n > 3 * nf + 3 {
        return Err(CodecError::Corrupt("counts larger than the data can hold"));
    }
    let faces = connectivity::decode(conn, n, nf)?;
    let topo = Topology::from_faces(n, &faces).map_err(|_| CodecError::Corrupt("faces"))?;
    let geo = need(SectionKind::Geometry)?;
    let pos = match geo.first() {
        None => return Err(CodecError::Truncated("geometry header")),
        Some(&MODE_SPECTRAL) => geometry::decode(&topo, &geo[1..])?,
        Some(&MODE_SPATIAL) => {
            let mut r = ByteReader::new(&geo[1..], "geometry header");
            let step = r.f64()?;
            if step <= 0.0 {
                return Err(CodecError::Corrupt("non-positive quantisation step"));
            }
            let select = match r.u8()? {
                0 => false,
                1 => true,
                _ => return Err(CodecError::Corrupt("bad predictor-selection flag")),
            };
            spatial::decode(&topo, r.rest(), step, select)?
        }
        Some(_) => return Err(CodecError::Corrupt("unknown geometry mode")),
    };
    match container::section(&secs, SectionKind::Permutation) {
        None => Ok(TriMesh::new(pos, faces)),
        Some(p) => {
            let order = decode_permutation(p, n)?;
            let mut out = vec![[0.0; 3]; n];
            for (i, &v) in order.iter().enumerate() {
                out[v as usize] = pos[i];
            }
            let faces = faces.iter().map(|f| f.map(|v| order[v as usize])).collect();
            Ok(TriMesh::new(out, faces))
        }
    }
}

/// Helpers shared by the codec's unit tests.
#[cfg(test)]
pub(crate) mod test_util {
    /// Root-mean-square vertex distance between two position lists (absolute).
    pub(crate) fn rms(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
        let s: f64 = a
            .iter()
            .zip(b)
            .map(|(p, q)| (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>())
            .sum();
        (s / a.len() as f64).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;
    use rand::{Rng, SeedableRng};

    fn open(spec: &str) -> (TriMesh, Topology) {
        let m = builtin::from_spec(spec).unwrap();
        let t = Topology::new(&m).unwrap();
        (m, t)
    }

    #[test]
    fn file_round_trip_matches_encoder_prediction() {
        for spec in [
            "builtin:icosphere:3",
            "builtin:cube:8",
            "builtin:torus:12:8",
        ] {
            let (m, t) = open(spec);
            for preserve in [false, true] {
                let c = compress(
                    &m,
                    &t,
                    &CompressOptions {
                        preserve_order: preserve,
                        ..Default::default()
                    },
                )
                .unwrap();
                let d = decompress(&c.bytes).unwrap();
                assert_eq!(d, c.decoded, "{spec}");
                if preserve {
                    let canon = |f: &[[u32; 3]]| {
                        let mut v: Vec<[u32; 3]> = f
                            .iter()
                            .map(|t| {
                                let k = (0..3).min_by_key(|&k| t[k]).unwrap();
                                [t[k], t[(k + 1) % 3], t[(k + 2) % 3]]
                            })
                            .collect();
                        v.sort_unstable();
                        v
                    };
                    assert_eq!(canon(&d.faces), canon(&m.faces));
                    assert!(c.report.permutation_bpv > 0.0);
                }
            }
        }
    }

    #[test]
    fn decoding_does_not_depend_on_the_thread_count() {
        // Encoder on 2 threads, decoder on 1 and 3: the bases, the inter-patch
        // predictors and the synthesis must agree bit for bit.
        let (m, t) = open("builtin:torus:40:24");
        let opts = CompressOptions {
            mode: GeometryMode::Spectral,
            geometry: GeometryParams {
                patch_size: 60,
                ..Default::default()
            },
            ..Default::default()
        };
        let pool = |k| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(k)
                .build()
                .unwrap()
        };
        let c = pool(2).install(|| compress(&m, &t, &opts).unwrap());
        assert!(c.report.geometry.patches >= 10);
        for k in [1, 3] {
            let d = pool(k).install(|| decompress(&c.bytes).unwrap());
            assert_eq!(d, c.decoded, "{k} threads");
        }
    }

    #[test]
    fn auto_mode_keeps_the_better_coder() {
        // A smooth surface: spectral wins at a low rate, spatial at a high one; auto
        // picks the lower vertex × normal RMS under rate control, and every mode
        // decodes exactly.
        let (m, t) = open("builtin:icosphere:4");
        let run = |mode, b| {
            let c = compress(
                &m,
                &t,
                &CompressOptions {
                    mode,
                    quantisation: Quantisation::TargetBpv(b),
                    ..Default::default()
                },
            )
            .unwrap();
            assert_eq!(decompress(&c.bytes).unwrap(), c.decoded, "{mode} {b}");
            assert!(c.report.bits_per_vertex <= b);
            c.report
        };
        for b in [3.0, 9.0] {
            let spec = run(GeometryMode::Spectral, b);
            let spat = run(GeometryMode::Spatial, b);
            let auto = run(GeometryMode::Auto, b);
            let better = if spec.vertex_rms * spec.normal_rms < spat.vertex_rms * spat.normal_rms {
                GeometryMode::Spectral
            } else {
                GeometryMode::Spatial
            };
            assert_eq!(auto.geometry_mode, better, "{b} bpv");
            // Rate control may land a hair apart (the spatial search starts from the
            // spectral answer in auto mode, from 10 bits alone).
            let kept = if better == GeometryMode::Spectral {
                &spec
            } else {
                &spat
            };
            assert!(
                (auto.vertex_rms / kept.vertex_rms - 1.0).abs() < 0.1,
                "{} vs {}",
                auto.vertex_rms,
                kept.vertex_rms
            );
            assert!(auto.normal_rms <= auto.vertex_rms);
        }
        let low = run(GeometryMode::Auto, 3.0);
        let high = run(GeometryMode::Auto, 9.0);
        assert_eq!(low.geometry_mode, GeometryMode::Spectral);
        assert_eq!(high.geometry_mode, GeometryMode::Spatial);
        assert_eq!(
            "spatial".parse::<GeometryMode>().unwrap(),
            GeometryMode::Spatial
        );
        assert!("fractal".parse::<GeometryMode>().is_err());
    }

    #[test]
    fn rate_control_meets_the_target() {
        let (m, t) = open("builtin:icosphere:4");
        for b in [4.0, 8.0] {
            let c = compress(
                &m,
                &t,
                &CompressOptions {
                    quantisation: Quantisation::TargetBpv(b),
                    ..Default::default()
                },
            )
            .unwrap();
            assert!(
                c.report.bits_per_vertex <= b,
                "{} > {b}",
                c.report.bits_per_vertex
            );
            assert!(
                c.report.bits_per_vertex > 0.8 * b,
                "{} ≪ {b}",
                c.report.bits_per_vertex
            );
        }
    }

    #[test]
    fn hostile_files_give_typed_errors() {
        let (m, t) = open("builtin:torus:9:7");
        let c = compress(&m, &t, &CompressOptions::default()).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(21);
        for _ in 0..300 {
            let mut d = c.bytes.clone();
            match rng.gen_range(0..3) {
                0 => d.truncate(rng.gen_range(0..d.len())),
                1 => {
                    let i = rng.gen_range(0..d.len());
                    d[i] ^= 1 << rng.gen_range(0..8);
                }
                _ => {
                    // Forge a valid container around garbage with huge counts.
                    let mut hdr = vec![0xFF; 8];
                    hdr[..4].copy_from_slice(&rng.gen::<u32>().to_le_bytes());
                    let junk: Vec<u8> = (0..rng.gen_range(0..40)).map(|_| rng.gen()).collect();
                    d = container::write(&[
                        (SectionKind::Header, &hdr),
                        (SectionKind::Connectivity, &junk),
                        (SectionKind::Geometry, &junk),
                    ])
                    .unwrap();
                }
            }
            assert!(decompress(&d).is_err());
        }
    }
}
