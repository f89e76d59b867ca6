//! Mesh compression to `.mlz` files: [`compress`] and [`decompress`], their options
//! and report.
//!
//! Connectivity is coded losslessly ([`connectivity`], a cut-border machine), every
//! stream with an adaptive binary range coder ([`entropy`]), the sections in a small
//! checksummed container ([`container`]). The geometry has two coders:
//!
//! * [`spectral`] — Karni and Gotsman, *Spectral compression of mesh geometry*
//!   (SIGGRAPH 2000): per patch, the coordinates in the eigenbasis of a combinatorial
//!   Laplacian (`F = D − W`, PSD), the low frequencies kept and quantized;
//! * [`spatial`] — closed-loop parallelogram prediction (DPCM), each vertex's
//!   residual quantized in the loop.
//!
//! A transform coder wins at low rates and a predictive coder at high rates, so by
//! default ([`GeometryMode::Auto`]) both are coded and the better one is kept; the
//! decision and rate control (`Quantization::TargetBpv`) are in `rate.rs`. Every
//! default and range of the options lives here and in the coders' parameter types
//! ([`SpectralParams`], [`SpatialParams`]), so front ends (the CLI, the Python
//! package) only pass values on.
//!
//! **Any mesh that `clean` accepts** is compressed: non-manifold edges and vertices,
//! inconsistently oriented faces, boundaries, several components, handles. The
//! connectivity coder needs a manifold, consistently oriented mesh, so the encoder cuts
//! the mesh into one (module `rejoin`: vertices duplicated per fan) and codes, in the
//! re-join section, which vertices of the cut mesh are copies of which; the decoder
//! glues them back, so the decoded faces are exactly the input's (same orientation, up
//! to the vertex order — and in the input's vertex order too with `preserve_order`).
//! Positions are coded once per input vertex: the geometry coders run on the re-joined
//! (possibly non-manifold) mesh. A manifold, consistently oriented mesh is not cut and
//! its file has no re-join section. Vertices no face references are refused by
//! [`compress`] ([`CodecError::Unreferenced`], in every mode: the spectral coder's
//! patches are made of faces), as everywhere in meshlap: `clean` drops them, and
//! `meshlap compress` reads its input through `clean`, so the CLI's files hold the
//! cleaned mesh.
//!
//! File layout (`.mlz` version [`container::VERSION`]; versions 4 and 5 are still
//! read and decode as they always did — version 4 files never have a re-join
//! section): a header section (vertex and face counts,
//! `u32` LE each), the connectivity section (of the cut mesh), the optional re-join
//! section, the optional permutation section (the input vertex order) and the geometry
//! section — a mode byte (0 spectral, 1 spatial) then that coder's stream.

#![warn(missing_docs)]

pub mod connectivity;
pub mod container;
pub mod entropy;
mod error;
mod geometry;
mod permutation;
mod quantize;
mod rate;
mod rejoin;
pub mod spatial;
pub mod spectral;
#[cfg(test)]
mod tests;

pub use error::{CodecError, NonManifold, ParameterError};
pub use spatial::SpatialParams;
pub use spectral::{Keep, SpectralParams, SpectralStats};

use crate::mesh::topology::Topology;
use crate::mesh::{TriMesh, VertexId};
use container::{ByteReader, SectionKind};
use serde::Serialize;

/// Which geometry coder.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum GeometryMode {
    /// Code both and keep the better: spectral wins at low rates, spatial at high
    /// rates.
    #[default]
    Auto,
    /// Patch-wise spectral coding ([`spectral`]).
    Spectral,
    /// Parallelogram prediction ([`spatial`]).
    #[cfg_attr(feature = "clap", value(alias = "predictive"))]
    Spatial,
}

impl GeometryMode {
    /// The coders this mode tries, in order.
    fn coders(self) -> &'static [GeometryMode] {
        match self {
            GeometryMode::Auto => &[GeometryMode::Spectral, GeometryMode::Spatial],
            GeometryMode::Spectral => &[GeometryMode::Spectral],
            GeometryMode::Spatial => &[GeometryMode::Spatial],
        }
    }
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
    type Err = ParameterError;
    /// `auto`, `spectral` or `spatial` (alias `predictive`), in any case.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s.to_ascii_lowercase().as_str() {
            "auto" => GeometryMode::Auto,
            "spectral" => GeometryMode::Spectral,
            "spatial" | "predictive" => GeometryMode::Spatial,
            _ => return Err(ParameterError::Mode(s.to_string())),
        })
    }
}

/// How finely the geometry is quantized.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum Quantization {
    /// Global step `diag · 2^{−q}` (diag: bounding-box diagonal), `q` in
    /// `[MIN_BITS, MAX_BITS]`.
    Bits(f64),
    /// Rate control: the finest step whose whole file fits `b > 0` bits per vertex.
    TargetBpv(f64),
}

impl Quantization {
    /// Default quantization: 10 bits (Draco's default too).
    pub const DEFAULT_BITS: f64 = 10.0;
    /// Fewest bits.
    pub const MIN_BITS: f64 = 1.0;
    /// Most bits.
    pub const MAX_BITS: f64 = 40.0;

    /// The quantization a front end's two optional settings give: a rate target if
    /// given, else `bits` if given, else the default.
    pub fn from_options(bits: Option<f64>, target_bpv: Option<f64>) -> Self {
        match (bits, target_bpv) {
            (_, Some(b)) => Quantization::TargetBpv(b),
            (Some(q), None) => Quantization::Bits(q),
            (None, None) => Quantization::default(),
        }
    }

    /// Checks the range: bits in `[MIN_BITS, MAX_BITS]`, a positive finite target.
    pub fn validate(self) -> Result<(), ParameterError> {
        match self {
            Quantization::Bits(q) if !(Self::MIN_BITS..=Self::MAX_BITS).contains(&q) => {
                Err(ParameterError::Bits {
                    got: q,
                    min: Self::MIN_BITS,
                    max: Self::MAX_BITS,
                })
            }
            Quantization::TargetBpv(b) if !(b.is_finite() && b > 0.0) => {
                Err(ParameterError::TargetBpv(b))
            }
            _ => Ok(()),
        }
    }
}

impl Default for Quantization {
    fn default() -> Self {
        Quantization::Bits(Quantization::DEFAULT_BITS)
    }
}

/// Options of [`compress`]. The defaults are the codec's defaults everywhere
/// (`meshlap compress` and the Python package take them from here).
#[derive(Copy, Clone, Debug, Default)]
pub struct CompressOptions {
    /// Geometry coder: spectral, spatial or the better of the two.
    pub mode: GeometryMode,
    /// Spectral geometry coder parameters.
    pub spectral: SpectralParams,
    /// Spatial geometry coder parameters.
    pub spatial: SpatialParams,
    /// Quantization or rate target.
    pub quantization: Quantization,
    /// Store the input vertex order (otherwise the decoder's order is the traversal's).
    pub preserve_order: bool,
}

impl CompressOptions {
    /// Checks the quantization and the parameters of the coders `mode` uses.
    pub fn validate(&self) -> Result<(), ParameterError> {
        self.quantization.validate()?;
        let coders = self.mode.coders();
        if coders.contains(&GeometryMode::Spectral) {
            self.spectral.validate()?;
        }
        if coders.contains(&GeometryMode::Spatial) {
            self.spatial.validate()?;
        }
        Ok(())
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
    /// Permutation section, bits per vertex (0 unless the vertex order is kept).
    pub permutation_bpv: f64,
    /// Re-join section, bits per vertex (0 unless the mesh had to be cut: non-manifold
    /// edges or vertices, inconsistent orientation).
    pub rejoin_bpv: f64,
    /// Vertex copies the cut for the connectivity coder made (each re-joined by the
    /// decoder).
    pub vertex_copies: usize,
    /// Global quantization step (absolute).
    pub step: f64,
    /// The same as bits: `log2(diag / step)`.
    pub quantization_bits: f64,
    /// Operator of the spectral basis (`F = D − W`, PSD; reported in spatial mode too).
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
    pub geometry: SpectralStats,
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

impl Compressed {
    /// Surface samples of [`Compressed::distortion`] unless told otherwise (as
    /// `meshlap compare`).
    pub const DEFAULT_SAMPLES: usize = 200_000;

    /// The distortion of the decoded mesh against the `input` it was compressed from
    /// ([`crate::metric::compare`] through the coder's vertex order, `samples` points
    /// per surface).
    pub fn distortion(
        &self,
        input: &TriMesh,
        samples: usize,
    ) -> Result<crate::metric::Comparison, crate::metric::MetricError> {
        crate::metric::compare(
            input,
            &self.decoded,
            Some(&self.order),
            &crate::metric::CompareOptions::without_msdm2(samples),
        )
    }
}

/// The header section: vertex and face counts.
fn header_bytes(n: usize, f: usize) -> Vec<u8> {
    let mut h = Vec::with_capacity(8);
    h.extend_from_slice(&(n as u32).to_le_bytes());
    h.extend_from_slice(&(f as u32).to_le_bytes());
    h
}

/// Compresses a triangle mesh (n vertices, f faces; non-manifold edges and vertices,
/// inconsistent orientation, boundaries, several components and handles allowed;
/// every vertex must be in a face: clean the mesh first) to an `.mlz` file image:
/// connectivity losslessly (the decoded faces are `mesh`'s, up to the vertex order),
/// geometry to the quantization of `opts`. `topo` is `mesh`'s connectivity.
///
/// Errors: [`CodecError::Parameter`] for an option out of range, [`CodecError::Mesh`]
/// for an invalid mesh (no faces, a NaN coordinate), [`CodecError::Unreferenced`] for
/// a vertex no face references, [`CodecError::DegenerateFace`] for a face that uses a
/// vertex twice, [`CodecError::PatchOperator`] when the spectral coder's operator is
/// undefined on the mesh (the SQL on a non-manifold edge: choose another `operator` or
/// the spatial coder).
pub fn compress(
    mesh: &TriMesh,
    topo: &Topology,
    opts: &CompressOptions,
) -> Result<Compressed, CodecError> {
    compress_cow(mesh, std::borrow::Cow::Borrowed(topo), opts)
}

/// [`compress`] taking `mesh`'s connectivity by value: it is freed as soon as the
/// connectivity coder is done with it, before the decoded-order connectivity the
/// geometry coders need is built, so the peak memory holds one connectivity instead of
/// two (about 180 bytes per vertex less; the command line uses it). The same file.
///
/// Errors: as [`compress`].
pub fn compress_owned(
    mesh: &TriMesh,
    topo: Topology,
    opts: &CompressOptions,
) -> Result<Compressed, CodecError> {
    compress_cow(mesh, std::borrow::Cow::Owned(topo), opts)
}

fn compress_cow(
    mesh: &TriMesh,
    topo: std::borrow::Cow<'_, Topology>,
    opts: &CompressOptions,
) -> Result<Compressed, CodecError> {
    opts.validate()?;
    mesh.validate().map_err(CodecError::Mesh)?;
    let n = mesh.n_vertices();
    if let Some(face) = mesh
        .faces
        .iter()
        .position(|f| f[0] == f[1] || f[1] == f[2] || f[0] == f[2])
    {
        return Err(CodecError::DegenerateFace { face });
    }
    let unreferenced = (0..n as u32).filter(|&v| topo.as_ref().degree(VertexId(v)) == 0);
    if let Some(vertex) = unreferenced.clone().next() {
        return Err(CodecError::Unreferenced {
            vertex,
            count: unreferenced.count(),
        });
    }
    let cut = rejoin::split(&topo)?;
    let copies = cut.copies(n);
    let (conn, rejoin_section, order, faces) = if copies == 0 {
        let mut conn = connectivity::encode(&topo)?;
        let (order, faces) = (
            std::mem::take(&mut conn.order),
            std::mem::take(&mut conn.faces),
        );
        (conn, None, order, faces)
    } else {
        let stopo = Topology::from_faces(cut.parent.len(), &cut.faces).map_err(CodecError::Mesh)?;
        let conn = connectivity::encode(&stopo)?;
        let (bytes, to_decoded, order) = rejoin::encode(&cut.parent, n, &conn.order);
        let faces = conn
            .faces
            .iter()
            .map(|f| f.map(|v| to_decoded[v as usize]))
            .collect();
        (conn, Some(bytes), order, faces)
    };
    // The input's connectivity and its cut are no longer needed: free them (when
    // owned) before the decoded-order connectivity is built.
    drop(cut);
    if let std::borrow::Cow::Owned(t) = topo {
        drop(t);
        crate::mem::release_free_memory();
    }
    let positions: Vec<[f64; 3]> = order.iter().map(|&v| mesh.positions[v as usize]).collect();
    let dtopo = Topology::from_faces(n, &faces).map_err(CodecError::Mesh)?;
    let diag = mesh.bbox_diagonal().max(f64::MIN_POSITIVE);
    let modes = opts.mode.coders();
    let fixed_step = match opts.quantization {
        Quantization::Bits(q) => Some(diag * (-q).exp2()),
        Quantization::TargetBpv(_) => None,
    };
    let mut coders = geometry::Coders::new(
        &dtopo,
        &positions,
        modes,
        opts.spectral,
        opts.spatial,
        fixed_step,
    )?;
    let perm = opts.preserve_order.then(|| permutation::encode(&order));
    let header = header_bytes(n, mesh.n_faces());
    let assemble = |geo: &[u8]| -> Result<Vec<u8>, CodecError> {
        let mut secs: Vec<(SectionKind, &[u8])> = vec![
            (SectionKind::Header, &header),
            (SectionKind::Connectivity, &conn.data),
        ];
        if let Some(r) = &rejoin_section {
            secs.push((SectionKind::Rejoin, r));
        }
        if let Some(p) = &perm {
            secs.push((SectionKind::Permutation, p));
        }
        secs.push((SectionKind::Geometry, geo));
        container::write(&secs)
    };
    let estimate = rate::Estimate::new(&positions, &faces, diag);
    let choice = rate::choose(
        &mut coders,
        modes,
        opts.quantization,
        diag,
        n,
        |geo| Ok(assemble(geo)?.len()),
        &estimate,
    )?;
    let geo = choice.section;
    let bytes = assemble(&geo.bytes)?;
    let bpv = |b: usize| b as f64 * 8.0 / n.max(1) as f64;
    let report = CompressReport {
        vertices: n,
        faces: mesh.n_faces(),
        bytes: bytes.len(),
        bits_per_vertex: bpv(bytes.len()),
        connectivity_bpv: bpv(conn.data.len()),
        geometry_bpv: bpv(geo.bytes.len()),
        permutation_bpv: perm.as_ref().map_or(0.0, |p| bpv(p.len())),
        rejoin_bpv: rejoin_section.as_ref().map_or(0.0, |r| bpv(r.len())),
        vertex_copies: copies,
        step: choice.step,
        quantization_bits: (diag / choice.step).log2(),
        operator: opts.spectral.operator,
        geometry_mode: choice.mode,
        vertex_rms: choice.vertex_rms,
        normal_rms: choice.normal_rms,
        geometry: geo.stats,
    };
    let (decoded, order) = if opts.preserve_order {
        (
            permutation::apply(&order, &geo.decoded, &faces),
            (0..n as u32).collect(),
        )
    } else {
        (TriMesh::new(geo.decoded, faces), order)
    };
    Ok(Compressed {
        bytes,
        report,
        decoded,
        order,
    })
}

/// Decompresses an `.mlz` file image (any format version from
/// [`container::MIN_VERSION`] to [`container::VERSION`]). Connectivity is rebuilt
/// exactly (a cut mesh re-joined); geometry to the coded precision; the vertex order
/// is the input's if it was stored.
///
/// A truncated, corrupt or foreign file is an error ([`CodecError::Truncated`],
/// [`CodecError::Corrupt`], [`CodecError::Checksum`], [`CodecError::BadMagic`],
/// [`CodecError::Version`]), never a panic; counts are checked against the bytes
/// present before anything is allocated.
pub fn decompress(bytes: &[u8]) -> Result<TriMesh, CodecError> {
    let secs = container::read(bytes)?;
    // `read` checked the magic and a supported version.
    let version = u16::from_le_bytes([bytes[4], bytes[5]]);
    let need = |k: SectionKind| {
        container::section(&secs, k).ok_or(CodecError::Corrupt("a required section is missing"))
    };
    let mut h = ByteReader::new(need(SectionKind::Header)?, "header");
    let n = h.u32()? as usize;
    let nf = h.u32()? as usize;
    let conn = need(SectionKind::Connectivity)?;
    // Every face takes at least one range-coded decision, and a byte holds at most
    // `MAX_DECISIONS_PER_BYTE` of them (a regular mesh such as an icosphere comes
    // close: 21M faces in 16 KB): refuse counts the data cannot hold before
    // allocating.
    let most_faces = entropy::MAX_DECISIONS_PER_BYTE * (conn.len() as u64 + 16);
    if nf as u64 > most_faces || n > 3 * nf + 3 {
        return Err(CodecError::Corrupt("counts larger than the data can hold"));
    }
    let faces = match container::section(&secs, SectionKind::Rejoin) {
        None => connectivity::decode(conn, n, nf)?,
        Some(r) => {
            let to_decoded = rejoin::decode(r, n, nf)?;
            let cut_faces = connectivity::decode(conn, to_decoded.len(), nf)?;
            let faces: Vec<[u32; 3]> = cut_faces
                .iter()
                .map(|f| f.map(|v| to_decoded[v as usize]))
                .collect();
            // The encoder never joins two corners of one face (its input has no
            // degenerate faces): a forged section could.
            if faces
                .iter()
                .any(|f| f[0] == f[1] || f[1] == f[2] || f[0] == f[2])
            {
                return Err(CodecError::Corrupt("a re-joined face repeats a vertex"));
            }
            faces
        }
    };
    let pos = geometry::decode(n, &faces, need(SectionKind::Geometry)?, version)?;
    match container::section(&secs, SectionKind::Permutation) {
        None => Ok(TriMesh::new(pos, faces)),
        Some(p) => Ok(permutation::apply(
            &permutation::decode(p, n)?,
            &pos,
            &faces,
        )),
    }
}
