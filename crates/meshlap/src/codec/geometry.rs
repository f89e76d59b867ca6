//! Spectral geometry coding after Karni and Gotsman, *Spectral compression of mesh
//! geometry* (SIGGRAPH 2000), as discussed in Zhang 2004 §2.6 and §4.9.
//!
//! The (decoded) connectivity is split into patches of about `P` vertices (default
//! 100). For each patch the n_p×n_p combinatorial operator `F = D − W` (PSD sign
//! convention) of the patch submesh is eigen-decomposed; its eigenvectors, by increasing eigenvalue, are
//! the patch's "frequencies". The default operator is Kirchhoff's `K = D − A`, Karni
//! and Gotsman's choice; with inter-patch prediction it beat SSTL at every rate in
//! 3–8 bits/vertex (Igea at 8 bits/vertex, patches of 300: vertex RMS 2.16e-4
//! against 2.43e-4; bunny 3.92e-4 against 4.54e-4). The n_p×3 coordinates `x` are
//! transformed, `X = E⁻¹x`, the first `m` coefficients (low frequencies) are kept
//! (default: all), quantised and range-coded.
//! Since the basis depends on connectivity only, the decoder rebuilds it and computes
//! `x̃ = E_m X̃`.
//!
//! * Symmetric operators (KL, GL, SQL, SSTL): `E` is orthonormal, `X = Eᵀx`, and the
//!   coefficient error equals the vertex error (Parseval).
//! * The Tutte Laplacian `T = I − D⁻¹A` is not symmetric, but it is similar to the
//!   normalised graph Laplacian `G = I − D^{-1/2} A D^{-1/2}`: `T = D^{-1/2} G D^{1/2}`,
//!   so `EigenBasis`' symmetrized path gives `E = D^{-1/2}U` (unit columns) and the
//!   coefficients by a D-weighted projection — no dense solve (Zhang §4.9 remarks that
//!   TL needs one otherwise).
//!
//! **Determinism.** The decoder must reproduce the encoder's basis bit for bit,
//! including inside repeated eigenvalues (icosphere, cube). The bases come from
//! [`crate::spectral::EigenBasis`] (canonical vectors: probe-vector rule inside
//! eigenvalue clusters, thread-independent arithmetic) on a matrix built from the
//! decoded connectivity in the decoded vertex order, so encoder and decoder agree
//! exactly; tests check this on `builtin:icosphere:3` and `builtin:cube:8`.
//!
//! **Quantisation.** A global step `Δ` (from `--bits q`: `Δ = diag·2^{−q}`, or found by
//! rate control for `--target-bpv`) scaled per band: the kept coefficients are cut
//! into four bands of equal count, band `b` using step `Δ·(1 + s·b/3)` (`s` =
//! `band_slope`, default 1). The quantiser has a dead zone, `q = sign(c)·⌊|c|/s_b +
//! θ⌋` with `θ = 0.35` (`dead_zone`; ½ is plain rounding): coefficients just above
//! half a step, which cost the most bits for the error they remove, become zeros.
//! Measured on Igea (SSTL, patches of 300, rate control at 8 bits/vertex): vertex RMS
//! 2.55e-4 with rounding, 2.43e-4 with `θ = 0.4`, 2.46e-4 with 0.33. With patches of
//! 100 (Kirchhoff, rate control at 3, 5 and 6 bits/vertex, bunny and Igea), `s = 1,
//! θ = 0.35` instead of `s = 0.5, θ = 0.4` lowers the Metro surface RMS by 4–9 % at
//! vertex RMS within +1.2 % (coarser high bands and more zeros spend the bits on the
//! low frequencies, which shape the surface; the vertex error is spread along it).
//! Integers are range-coded with adaptive models whose context is the coefficient's
//! frequency octave and the magnitude of its already coded neighbours (see
//! [`coef_context`]).
//!
//! **Inter-patch prediction** (on by default, format version 2). Patches are coded in
//! index order; patch `p` first predicts its coordinates from the decoded vertices of
//! patches `< p` that touch it: `x̂ = G y`, the minimiser of the discrete thin-plate
//! energy `‖L_U x̂ + L_S y‖²` of the umbrella operator over the patch and its decoded
//! ring (see [`patch_prediction`]; `G` depends on connectivity only). The coder then
//! transforms the difference, `X = E⁻¹(x − x̂)`, and the decoder returns
//! `x̂ + E_m X̃`. The coefficient error, hence the vertex error, is unchanged; the
//! rate falls because a patch no longer pays for its position, orientation and the
//! part of its shape its neighbours already imply. Measured on the bunny at 10 bits,
//! all coefficients, band slope 0: geometry 7.74 → 6.83 bits/vertex with patches of
//! 300, 8.06 → 7.04 with 200, 8.39 → 7.22 with 150.
//!
//! **Patch borders.** A truncated basis on a patch with a free border reconstructs
//! border vertices worst (the basis functions have no constraint there). The coder
//! measures the RMS error on border and interior vertices and, when enabled
//! (`border_residuals`, off by default), codes the border vertices' residuals with step `Δ` (border-aware coding), which
//! bounds their error by `Δ/2` per coordinate. Vertices that belong to no face of
//! their patch (rare, from the partition) are coded the same way, predicted from
//! their decoded neighbours.
//!
//! **Partition and patch size.** Patches come from METIS ([`partition`]), numbered by
//! their smallest vertex, which is also the coding (and prediction) order. Basis cost
//! grows as `n·P²` (a dense eigendecomposition per patch); with inter-patch
//! prediction the rate hardly depends on `P` any more (Igea, Kirchhoff, rate control
//! at 8 bits/vertex: vertex RMS 2.38e-4 at P = 100, 2.28e-4 at 150, 2.23e-4 at 200,
//! 2.16e-4 at 300). The default is 100, for speed: encode + decode of Igea at the
//! default 10 bits takes 1.6–1.8 s at P = 100 and 2.3–2.4 s at 150 (2 threads,
//! `meshlap-bench codec`, BENCHMARKS.md), and P = 150 has 4–6 % lower vertex and
//! Metro error at 4–6 bits/vertex under rate control (bunny 4 bpv: vertex 1.007e-3 vs
//! 1.066e-3, Metro 3.86e-4 vs 4.03e-4; Igea 6 bpv: 3.47e-4 vs 3.62e-4, 1.33e-4 vs
//! 1.38e-4). Patches are at most 1000 vertices (a hostile file cannot ask for more).
//!
//! **Eigensolver.** Bases come from [`crate::spectral::dense_evd`] (selected by
//! [`crate::spectral::DenseSolver::Reproducible`]) and the canonicalisation in
//! `spectral::basis` (plain loops in index order): the arithmetic is fixed-order and
//! correctly rounded, so the bases are the same bit for bit on every CPU with FMA.
//! The coefficient products (`forward`/`inverse`) and the prediction's Cholesky use
//! faer, whose kernels depend on the CPU, so decoded coordinates can differ in their
//! last bits between machines (at rounding level: the integers are in the file).
//! The solver is also faster (cow's patches, `cargo bench --bench core
//! patch_bases`: 0.53 ms per basis at P = 100 against faer's 1.30 ms, 1.36 against
//! 2.08 ms at 150).

use super::container::ByteReader;
use super::entropy::{IntModel, RangeDecoder, RangeEncoder};
use super::CodecError;
use crate::mesh::topology::Topology;
use crate::mesh::TriMesh;
use crate::operator::{Operator, OperatorKind, OperatorOptions};
use crate::spectral::{forward, inverse, BasisOptions, DenseSolver, EigenBasis};
use faer::Mat;
use rayon::prelude::*;

const BANDS: usize = 4;

/// Largest patch size: each patch costs a dense O(P³) eigendecomposition with O(P²)
/// memory on both sides, and a hostile file must not ask for more (P = 1000: about
/// 1 s per patch).
const MAX_PATCH: usize = 1000;

/// How many low-frequency coefficients each patch keeps.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum Keep {
    /// A fraction `r ∈ (0, 1]` of the patch's vertex count (at least 1).
    Ratio(f64),
    /// A fixed number per patch (at most the patch's vertex count).
    Count(u32),
}

impl Keep {
    fn count(self, n: usize) -> usize {
        let m = match self {
            Keep::Ratio(r) => (r * n as f64).round() as usize,
            Keep::Count(m) => m as usize,
        };
        m.clamp(1, n.max(1))
    }
}

/// Parameters of the geometry coder.
#[derive(Copy, Clone, Debug)]
pub struct GeometryParams {
    /// The combinatorial operator whose eigenvectors form the basis.
    pub operator: OperatorKind,
    /// Target patch size (vertices).
    pub patch_size: usize,
    /// Coefficients kept per patch.
    pub keep: Keep,
    /// Border-aware coding: code residuals of patch-border vertices.
    pub border_residuals: bool,
    /// Per-band steps: band `b ∈ 0..4` of the kept coefficients uses step
    /// `Δ·(1 + slope·b/3)` (0: one step for all; high-rate theory says uniform steps
    /// minimise the mean squared error of an orthonormal transform).
    pub band_slope: f64,
    /// Inter-patch prediction: each patch codes the coefficients of its difference
    /// from the smoothest continuation of the earlier patches' decoded vertices.
    pub predicted: bool,
    /// Dead-zone rounding offset `θ ∈ [0.2, 0.5]` of the coefficient quantiser
    /// `q = sign(c)·⌊|c|/s + θ⌋` (½: plain rounding). Encoder-side only: the decoder
    /// reconstructs `q·s` either way.
    pub dead_zone: f64,
}

impl Default for GeometryParams {
    fn default() -> Self {
        GeometryParams {
            operator: OperatorKind::Kirchhoff,
            patch_size: 100,
            keep: Keep::Ratio(1.0),
            border_residuals: false,
            band_slope: 1.0,
            predicted: true,
            dead_zone: 0.35,
        }
    }
}

fn operator_code(k: OperatorKind) -> Result<u8, CodecError> {
    Ok(match k {
        OperatorKind::Kirchhoff => 0,
        OperatorKind::Tutte => 1,
        OperatorKind::Graph => 2,
        OperatorKind::Sql => 3,
        OperatorKind::Sstl => 4,
        other => {
            return Err(CodecError::Parameter(format!(
                "the {other} operator cannot be used for compression; choose sstl, sql, tutte, kirchhoff or graph"
            )))
        }
    })
}

fn operator_from_code(c: u8) -> Result<OperatorKind, CodecError> {
    Ok(match c {
        0 => OperatorKind::Kirchhoff,
        1 => OperatorKind::Tutte,
        2 => OperatorKind::Graph,
        3 => OperatorKind::Sql,
        4 => OperatorKind::Sstl,
        _ => return Err(CodecError::Corrupt("unknown operator")),
    })
}

/// Patches of about `p` vertices from the multilevel partitioner
/// ([`crate::partition`]: METIS k-way with a fixed seed, connected patches,
/// every vertex on a face of its own patch). Deterministic for a given connectivity, so
/// the decoder, which has the same connectivity in the same order, gets the same
/// patches. Each vertex belongs to exactly one patch.
pub(crate) fn partition(topo: &Topology, p: usize) -> Result<Vec<Vec<u32>>, CodecError> {
    use crate::partition::{partition as metis_patches, PartitionOptions};
    let part = metis_patches(topo, &PartitionOptions::new(p.max(3)))
        .map_err(|e| CodecError::Parameter(format!("partitioning into patches: {e}")))?;
    Ok((0..part.n_patches())
        .map(|i| part.patch_vertices(i).to_vec())
        .collect())
}

/// A patch's basis ([`crate::spectral::EigenBasis`]: canonical, deterministic
/// eigenvectors, ascending eigenvalues) and how many coefficients it keeps; `verts`
/// lists the patch vertices that lie on a face of the patch (the others are coded as
/// loose vertices).
struct PatchBasis {
    verts: Vec<u32>,
    basis: Option<EigenBasis>,
    m: usize,
    pred: Option<Prediction>,
}

/// Prediction of a patch's coordinates from decoded vertices of earlier patches:
/// `x̂ = G·y`, `y` the positions of `src` (n_src×3), `G` n_p×n_src.
struct Prediction {
    src: Vec<u32>,
    g: Mat<f64>,
}

impl Prediction {
    /// `x̂ = G·y` (n_p×3) from the decoded positions `rec` (fixed summation order).
    fn predict(&self, rec: &[[f64; 3]]) -> Mat<f64> {
        let mut out = Mat::<f64>::zeros(self.g.nrows(), 3);
        for (t, &v) in self.src.iter().enumerate() {
            let y = rec[v as usize];
            for j in 0..self.g.nrows() {
                let w = self.g[(j, t)];
                for k in 0..3 {
                    out[(j, k)] += w * y[k];
                }
            }
        }
        out
    }
}

impl PatchBasis {
    /// The first `m` coefficients (m×3) of the patch coordinates `x` (n_p×3).
    fn analyse(&self, x: &Mat<f64>) -> Result<Mat<f64>, CodecError> {
        match &self.basis {
            None => Ok(Mat::zeros(0, 3)),
            Some(b) => {
                let all = forward(b, x.as_ref()).map_err(spectral_err)?;
                Ok(all.subrows(0, self.m).to_owned())
            }
        }
    }
    /// Coordinates (n_p×3) from the first m coefficients.
    fn synthesise(&self, c: &Mat<f64>) -> Result<Mat<f64>, CodecError> {
        match &self.basis {
            None => Ok(Mat::zeros(0, 3)),
            Some(b) => inverse(b, c.as_ref()).map_err(spectral_err),
        }
    }
}

fn spectral_err(e: crate::spectral::SpectralError) -> CodecError {
    CodecError::Parameter(format!("patch eigenbasis: {e}"))
}

/// The basis of one patch given its submesh connectivity `pt` (local numbering);
/// vertices on no face of the patch are left out (`verts` lists the kept ones, local).
fn patch_basis(pt: &Topology, kind: OperatorKind, keep: Keep) -> Result<PatchBasis, CodecError> {
    let mut on_face = vec![false; pt.n_vertices()];
    for f in pt.faces() {
        for &x in f {
            on_face[x as usize] = true;
        }
    }
    let mut remap = vec![u32::MAX; pt.n_vertices()];
    let mut verts = Vec::new();
    for i in 0..pt.n_vertices() {
        if on_face[i] {
            remap[i] = verts.len() as u32;
            verts.push(i as u32);
        }
    }
    let faces: Vec<[u32; 3]> = pt
        .faces()
        .iter()
        .map(|f| f.map(|x| remap[x as usize]))
        .collect();
    let np = verts.len();
    if np == 0 {
        return Ok(PatchBasis {
            verts,
            basis: None,
            m: 0,
            pred: None,
        });
    }
    let sub = TriMesh::new(vec![[0.0; 3]; np], faces);
    let st = Topology::new(&sub).map_err(|_| CodecError::Internal("patch topology"))?;
    let op = Operator::assemble(kind, &sub, &st, &OperatorOptions::default())
        .map_err(|e| CodecError::Parameter(format!("operator on a patch: {e}")))?;
    let opts = BasisOptions {
        dense_solver: DenseSolver::Reproducible,
        ..Default::default()
    };
    let basis = EigenBasis::compute(&op, &opts).map_err(spectral_err)?;
    Ok(PatchBasis {
        verts,
        basis: Some(basis),
        m: keep.count(np),
        pred: None,
    })
}

/// The bases of every patch (in parallel; each decomposition is sequential).
fn bases(topo: &Topology, params: &GeometryParams) -> Result<Vec<PatchBasis>, CodecError> {
    let patches = partition(topo, params.patch_size)?;
    let n = topo.n_vertices();
    let mut patch_of = vec![0u32; n];
    for (p, patch) in patches.iter().enumerate() {
        for &v in patch {
            patch_of[v as usize] = p as u32;
        }
    }
    // Faces per patch: a face belongs to the patch of its first corner if all three
    // corners share it.
    let mut pfaces: Vec<Vec<[u32; 3]>> = vec![Vec::new(); patches.len()];
    for f in topo.faces() {
        let p = patch_of[f[0] as usize];
        if patch_of[f[1] as usize] == p && patch_of[f[2] as usize] == p {
            pfaces[p as usize].push(*f);
        }
    }
    patches
        .par_iter()
        .zip(pfaces.par_iter())
        .map(|(patch, faces)| {
            let mut local = std::collections::HashMap::with_capacity(patch.len());
            for (i, &v) in patch.iter().enumerate() {
                local.insert(v, i as u32);
            }
            let ft = Topology::from_faces(
                patch.len(),
                &faces
                    .iter()
                    .map(|f| f.map(|v| local[&v]))
                    .collect::<Vec<_>>(),
            )
            .map_err(|_| CodecError::Internal("patch topology"))?;
            let b = patch_basis(&ft, params.operator, params.keep)?;
            Ok(PatchBasis {
                verts: b.verts.iter().map(|&i| patch[i as usize]).collect(),
                basis: b.basis,
                m: b.m,
                pred: None,
            })
        })
        .collect::<Result<Vec<_>, CodecError>>()
        .map(|mut bases| {
            if params.predicted {
                let owner = owners(n, &bases);
                let preds: Vec<Option<Prediction>> = (0..bases.len())
                    .into_par_iter()
                    .map(|p| patch_prediction(topo, &owner, &bases[p], p as u32))
                    .collect();
                for (b, pr) in bases.iter_mut().zip(preds) {
                    b.pred = pr;
                }
            }
            bases
        })
}

/// Patch of each vertex in the patch bases (`u32::MAX`: loose vertex).
fn owners(n: usize, bases: &[PatchBasis]) -> Vec<u32> {
    let mut owner = vec![u32::MAX; n];
    for (p, b) in bases.iter().enumerate() {
        for &v in &b.verts {
            owner[v as usize] = p as u32;
        }
    }
    owner
}

/// The predictor of patch `p` (vertices `U`), or `None` when no vertex of an earlier
/// patch touches it (or the system is singular).
///
/// Known vertices are those of patches `< p` (decoded before `p`). With `K₁` the known
/// vertices adjacent to `U`, take the rows `R = U ∪ K₁` of the umbrella operator of
/// the graph restricted to `U ∪ known` (`(Lx)_i = x_i − mean_{w ∈ N'(i)} x_w`), split
/// as `L = [L_U | L_S]` over unknown and known columns (`S`: the known vertices these
/// rows touch). The prediction is the smoothest continuation of the decoded
/// neighbourhood into the patch, the minimiser of the discrete thin-plate energy
/// `‖L_U x_U + L_S y‖²` (affine continuations cost nearly nothing):
/// `x̂_U = G y` with `G = −(L_UᵀL_U)⁻¹ L_UᵀL_S` (n_p × |S|), a dense Cholesky
/// (sequential, so encoder and decoder get the same `G` bit for bit).
fn patch_prediction(topo: &Topology, owner: &[u32], b: &PatchBasis, p: u32) -> Option<Prediction> {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::linalg::cholesky::llt;
    b.basis.as_ref()?;
    let np = b.verts.len();
    let known = |w: u32| owner[w as usize] < p;
    let mut local = std::collections::HashMap::with_capacity(np);
    for (i, &v) in b.verts.iter().enumerate() {
        local.insert(v, i);
    }
    let mut k1: Vec<u32> = b
        .verts
        .iter()
        .flat_map(|&v| topo.neighbors(crate::mesh::VertexId(v)).iter().copied())
        .filter(|&w| known(w))
        .collect();
    k1.sort_unstable();
    k1.dedup();
    if k1.is_empty() {
        return None;
    }
    let mut src_index = std::collections::HashMap::new();
    let mut src: Vec<u32> = Vec::new();
    // Sparse rows of L_U and L_S.
    let mut lu: Vec<Vec<(usize, f64)>> = Vec::with_capacity(np + k1.len());
    let mut ls: Vec<Vec<(usize, f64)>> = Vec::with_capacity(np + k1.len());
    for &i in b.verts.iter().chain(k1.iter()) {
        let nb: Vec<u32> = topo
            .neighbors(crate::mesh::VertexId(i))
            .iter()
            .copied()
            .filter(|&w| known(w) || owner[w as usize] == p)
            .collect();
        let (mut ru, mut rs) = (Vec::new(), Vec::new());
        let inv = if nb.is_empty() {
            0.0
        } else {
            1.0 / nb.len() as f64
        };
        for (w, wt) in std::iter::once((i, 1.0)).chain(nb.iter().map(|&w| (w, -inv))) {
            if let Some(&li) = local.get(&w) {
                ru.push((li, wt));
            } else {
                let t = *src_index.entry(w).or_insert_with(|| {
                    src.push(w);
                    src.len() - 1
                });
                rs.push((t, wt));
            }
        }
        lu.push(ru);
        ls.push(rs);
    }
    // M = L_UᵀL_U + ridge, G = −L_UᵀL_S.
    let mut m = Mat::<f64>::zeros(np, np);
    let mut g = Mat::<f64>::zeros(np, src.len());
    for (ru, rs) in lu.iter().zip(&ls) {
        for &(a, wa) in ru {
            for &(c, wc) in ru {
                m[(a, c)] += wa * wc;
            }
            for &(t, wt) in rs {
                g[(a, t)] -= wa * wt;
            }
        }
    }
    let tr = (0..np).map(|i| m[(i, i)]).sum::<f64>() / np as f64;
    for i in 0..np {
        m[(i, i)] += 1e-10 * tr;
    }
    let par = faer::Par::Seq;
    let mut mem = MemBuffer::new(
        llt::factor::cholesky_in_place_scratch::<f64>(np, par, Default::default()).or(
            llt::solve::solve_in_place_scratch::<f64>(np, src.len(), par),
        ),
    );
    let stack = MemStack::new(&mut mem);
    llt::factor::cholesky_in_place(
        m.as_mut(),
        Default::default(),
        par,
        stack,
        Default::default(),
    )
    .ok()?;
    llt::solve::solve_in_place(m.as_ref(), g.as_mut(), par, stack);
    if (0..g.ncols()).any(|c| g.col(c).iter().any(|x| !x.is_finite())) {
        return None;
    }
    Some(Prediction { src, g })
}

fn band_step(step: f64, slope: f64, j: usize, m: usize) -> f64 {
    let b = (j * BANDS) / m.max(1);
    step * (1.0 + slope * b as f64 / (BANDS - 1) as f64)
}

/// Magnitude buckets of the coefficient contexts.
const MAG_BUCKETS: usize = 8;
/// Frequency bands of the coefficient contexts.
const FREQ_BANDS: usize = 8;

/// Context of coefficient `j`, coordinate `k`: its frequency band `⌈log2(j+1)⌉`
/// (capped at 7: spectra decay with frequency, roughly by octaves) times a bucket of
/// the expected magnitude, a weighted mean of the same coordinate's four previous
/// quantised coefficients and of this coefficient's already coded coordinates.
/// Measured at 10 bits, all coefficients, band slope 0, with prediction: bunny
/// (patches of 200) 7.04 → 6.75 geometry bits/vertex and Igea 4.59 → 4.27 against
/// the former context (the two previous magnitudes of the same coordinate only);
/// linear bands of `j/m` or fewer magnitude terms were within 0.06 of this.
fn coef_context(j: usize, k: usize, hist: &[[i64; 3]; 4], row: &[i64; 3]) -> usize {
    let h = |t: usize| hist[3 - t][k].unsigned_abs();
    let same: u64 = (0..k).map(|kk| row[kk].unsigned_abs()).sum::<u64>() * 2 / (k.max(1) as u64);
    let a = (2 * (h(0) + h(1)) + h(2) + h(3) + same + 2) / 4;
    let mag = match a {
        0 => 0,
        1 => 1,
        2..=3 => 2,
        4..=7 => 3,
        8..=15 => 4,
        16..=31 => 5,
        32..=63 => 6,
        _ => 7,
    };
    octave(j) * MAG_BUCKETS + mag
}

/// Frequency octave `⌈log2(j+1)⌉` of coefficient `j`, capped at `FREQ_BANDS − 1`.
fn octave(j: usize) -> usize {
    ((usize::BITS - j.leading_zeros()) as usize).min(FREQ_BANDS - 1)
}

fn quantise(v: f64, s: f64) -> Result<i64, CodecError> {
    quantise_dz(v, s, 0.5)
}

/// Dead-zone quantiser `sign(v)·⌊|v|/s + θ⌋` (`θ = ½`: rounding to the nearest).
fn quantise_dz(v: f64, s: f64, theta: f64) -> Result<i64, CodecError> {
    let q = ((v / s).abs() + theta).floor().copysign(v);
    if q.abs() >= (1u64 << 31) as f64 {
        return Err(CodecError::Parameter(
            "quantisation step too small for these coordinates".into(),
        ));
    }
    Ok(q as i64)
}

/// Models of the geometry stream.
struct GeoModels {
    coef: Vec<IntModel>,
    resid: Vec<IntModel>,
}

impl GeoModels {
    fn new() -> Self {
        GeoModels {
            coef: (0..MAG_BUCKETS * FREQ_BANDS)
                .map(|_| IntModel::default())
                .collect(),
            resid: (0..3).map(|_| IntModel::default()).collect(),
        }
    }
}

/// What the geometry encoder measured.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct GeometryStats {
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

/// A coded geometry stream, the positions the decoder will produce from it (decoded
/// vertex order, n×3) and the encoder's measurements.
pub type EncodedGeometry = (Vec<u8>, Vec<[f64; 3]>, GeometryStats);

/// Precomputed state of the encoder (bases are reused by rate control).
pub struct GeometryEncoder<'a> {
    topo: &'a Topology,
    params: GeometryParams,
    bases: Vec<PatchBasis>,
    /// Unquantised coefficients per patch, m×3.
    coefs: Vec<Mat<f64>>,
    positions: &'a [[f64; 3]],
    border: Vec<bool>,
    loose: Vec<u32>,
}

/// Vertices adjacent to a vertex of another patch, and vertices in no patch basis.
fn border_and_loose(topo: &Topology, bases: &[PatchBasis]) -> (Vec<bool>, Vec<u32>) {
    let n = topo.n_vertices();
    let mut owner = vec![u32::MAX; n];
    for (p, b) in bases.iter().enumerate() {
        for &v in &b.verts {
            owner[v as usize] = p as u32;
        }
    }
    let mut border = vec![false; n];
    for v in 0..n {
        if owner[v] == u32::MAX {
            continue;
        }
        border[v] = topo
            .neighbors(crate::mesh::VertexId(v as u32))
            .iter()
            .any(|&w| owner[w as usize] != owner[v]);
    }
    let loose = (0..n as u32)
        .filter(|&v| owner[v as usize] == u32::MAX)
        .collect();
    (border, loose)
}

impl<'a> GeometryEncoder<'a> {
    /// Partitions, decomposes and transforms; `positions` are in the connectivity
    /// coder's (decoded) vertex order.
    pub fn new(
        topo: &'a Topology,
        positions: &'a [[f64; 3]],
        params: GeometryParams,
    ) -> Result<Self, CodecError> {
        operator_code(params.operator)?;
        if let Keep::Ratio(r) = params.keep {
            if !(r > 0.0 && r <= 1.0) {
                return Err(CodecError::Parameter(format!(
                    "--keep-ratio must be in (0, 1], got {r}"
                )));
            }
        }
        if !(0.0..=16.0).contains(&params.band_slope) {
            return Err(CodecError::Parameter(format!(
                "band slope must be in [0, 16], got {}",
                params.band_slope
            )));
        }
        if !(0.2..=0.5).contains(&params.dead_zone) {
            return Err(CodecError::Parameter(format!(
                "dead-zone rounding offset must be in [0.2, 0.5], got {}",
                params.dead_zone
            )));
        }
        if params.patch_size < 4 || params.patch_size > MAX_PATCH {
            return Err(CodecError::Parameter(format!(
                "--patch-size must be between 4 and {MAX_PATCH}, got {}",
                params.patch_size
            )));
        }
        let bases = bases(topo, &params)?;
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
                b.analyse(&x)
            })
            .collect::<Result<Vec<_>, _>>()?;
        let (border, loose) = border_and_loose(topo, &bases);
        Ok(GeometryEncoder {
            topo,
            params,
            bases,
            coefs,
            positions,
            border,
            loose,
        })
    }

    /// Codes the geometry with global step `step`; returns the stream, the
    /// reconstruction the decoder will produce, and statistics.
    pub fn encode(&self, step: f64) -> Result<EncodedGeometry, CodecError> {
        self.encode_measured(step, true)
    }

    /// [`Self::encode`] without the per-octave cost measurement (rate control).
    pub(crate) fn encode_fast(&self, step: f64) -> Result<EncodedGeometry, CodecError> {
        self.encode_measured(step, false)
    }

    fn encode_measured(&self, step: f64, measure: bool) -> Result<EncodedGeometry, CodecError> {
        if !(step.is_finite() && step > 0.0) {
            return Err(CodecError::Parameter(format!(
                "invalid quantisation step {step}"
            )));
        }
        let mut head = Vec::new();
        head.push(operator_code(self.params.operator)?);
        head.extend_from_slice(&(self.params.patch_size as u32).to_le_bytes());
        match self.params.keep {
            Keep::Ratio(r) => {
                head.push(0);
                head.extend_from_slice(&r.to_le_bytes());
            }
            Keep::Count(m) => {
                head.push(1);
                head.extend_from_slice(&(m as f64).to_le_bytes());
            }
        }
        head.extend_from_slice(&step.to_le_bytes());
        head.push(self.params.border_residuals as u8);
        head.extend_from_slice(&self.params.band_slope.to_le_bytes());
        head.push(self.params.predicted as u8);
        let mut enc = RangeEncoder::new();
        let mut models = GeoModels::new();
        let n = self.topo.n_vertices();
        let mut rec = vec![[0.0f64; 3]; n];
        let mut octave_bits = [0.0f64; FREQ_BANDS];
        for (b, c) in self.bases.iter().zip(&self.coefs) {
            let m = c.nrows();
            let (xhat, chat) = match &b.pred {
                Some(pr) => {
                    let xh = pr.predict(&rec);
                    let ch = b.analyse(&xh)?;
                    (Some(xh), Some(ch))
                }
                None => (None, None),
            };
            let mut q = Mat::<f64>::zeros(m, 3);
            let mut hist = [[0i64; 3]; 4];
            for j in 0..m {
                let s = band_step(step, self.params.band_slope, j, m);
                let mut row = [0i64; 3];
                for k in 0..3 {
                    let base = chat.as_ref().map_or(0.0, |ch| ch[(j, k)]);
                    let qi = quantise_dz(c[(j, k)] - base, s, self.params.dead_zone)?;
                    let model = &mut models.coef[coef_context(j, k, &hist, &row)];
                    if measure {
                        octave_bits[octave(j)] += model.cost(qi) as f64;
                    }
                    model.encode(&mut enc, qi);
                    q[(j, k)] = qi as f64 * s;
                    row[k] = qi;
                }
                hist = [hist[1], hist[2], hist[3], row];
            }
            place(b, xhat.as_ref(), &b.synthesise(&q)?, &mut rec);
        }
        let mut stats = GeometryStats {
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
                let e: f64 = (0..3)
                    .map(|k| (rec[v as usize][k] - self.positions[v as usize][k]).powi(2))
                    .sum();
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
        let targets = residual_targets(&self.border, &self.loose, self.params.border_residuals);
        for &v in &targets {
            let pred = prediction(self.topo, v, &rec, &self.loose_set());
            for k in 0..3 {
                let qi = quantise(self.positions[v as usize][k] - pred[k], step)?;
                models.resid[k].encode(&mut enc, qi);
                rec[v as usize][k] = pred[k] + qi as f64 * step;
            }
        }
        stats.residual_vertices = targets.len();
        let mut out = head;
        out.extend_from_slice(&enc.finish());
        stats.bytes = out.len();
        Ok((out, rec, stats))
    }

    fn loose_set(&self) -> Vec<bool> {
        let mut s = vec![false; self.topo.n_vertices()];
        for &v in &self.loose {
            s[v as usize] = true;
        }
        s
    }
}

/// Residual-coded vertices in order: loose vertices always, border vertices if
/// border-aware coding is on.
fn residual_targets(border: &[bool], loose: &[u32], border_on: bool) -> Vec<u32> {
    let mut t: Vec<u32> = if border_on {
        (0..border.len() as u32)
            .filter(|&v| border[v as usize])
            .collect()
    } else {
        Vec::new()
    };
    t.extend_from_slice(loose);
    t
}

/// Prediction of a residual-coded vertex: its own spectral reconstruction, or for a
/// loose vertex the mean of its decoded non-loose neighbours (origin if none).
fn prediction(topo: &Topology, v: u32, rec: &[[f64; 3]], loose: &[bool]) -> [f64; 3] {
    if !loose[v as usize] {
        return rec[v as usize];
    }
    let mut s = [0.0; 3];
    let mut c = 0usize;
    for &w in topo.neighbors(crate::mesh::VertexId(v)) {
        if !loose[w as usize] {
            for k in 0..3 {
                s[k] += rec[w as usize][k];
            }
            c += 1;
        }
    }
    if c > 0 {
        s.map(|x| x / c as f64)
    } else {
        s
    }
}

/// Writes a patch's coordinates, prediction `x̂` (if any) plus synthesised residual
/// (n_p×3), into `rec`.
fn place(b: &PatchBasis, xhat: Option<&Mat<f64>>, x: &Mat<f64>, rec: &mut [[f64; 3]]) {
    for (i, &v) in b.verts.iter().enumerate() {
        rec[v as usize] = match xhat {
            Some(h) => [
                h[(i, 0)] + x[(i, 0)],
                h[(i, 1)] + x[(i, 1)],
                h[(i, 2)] + x[(i, 2)],
            ],
            None => [x[(i, 0)], x[(i, 1)], x[(i, 2)]],
        };
    }
}

/// Decodes a geometry stream for the decoded connectivity `topo`.
pub fn decode(topo: &Topology, data: &[u8]) -> Result<Vec<[f64; 3]>, CodecError> {
    let mut r = ByteReader::new(data, "geometry header");
    let operator = operator_from_code(r.u8()?)?;
    let patch_size = r.u32()? as usize;
    if !(4..=MAX_PATCH).contains(&patch_size) {
        return Err(CodecError::Corrupt("patch size out of range"));
    }
    let keep = match r.u8()? {
        0 => {
            let x = r.f64()?;
            if !(x > 0.0 && x <= 1.0) {
                return Err(CodecError::Corrupt("keep ratio out of range"));
            }
            Keep::Ratio(x)
        }
        1 => {
            let x = r.f64()?;
            if !(1.0..=u32::MAX as f64).contains(&x) {
                return Err(CodecError::Corrupt("coefficient count out of range"));
            }
            Keep::Count(x as u32)
        }
        _ => return Err(CodecError::Corrupt("unknown coefficient rule")),
    };
    let step = r.f64()?;
    if step <= 0.0 {
        return Err(CodecError::Corrupt("non-positive quantisation step"));
    }
    let border_residuals = match r.u8()? {
        0 => false,
        1 => true,
        _ => return Err(CodecError::Corrupt("bad border flag")),
    };
    let band_slope = r.f64()?;
    if !(0.0..=16.0).contains(&band_slope) {
        return Err(CodecError::Corrupt("band slope out of range"));
    }
    let predicted = match r.u8()? {
        0 => false,
        1 => true,
        _ => return Err(CodecError::Corrupt("bad prediction flag")),
    };
    let params = GeometryParams {
        operator,
        patch_size,
        keep,
        border_residuals,
        band_slope,
        predicted,
        dead_zone: 0.5,
    };
    let bases = bases(topo, &params)?;
    let mut dec = RangeDecoder::new(r.rest());
    let mut models = GeoModels::new();
    let n = topo.n_vertices();
    let mut rec = vec![[0.0f64; 3]; n];
    // The coefficients depend on the stream only and the synthesis `E_m X̃` on the
    // patch only: range-decode every patch in order, synthesise in parallel, then
    // add the predictions in order (each reads earlier patches' positions).
    let mut coefs = Vec::with_capacity(bases.len());
    for b in &bases {
        let m = b.m;
        let mut q = Mat::<f64>::zeros(m, 3);
        let mut hist = [[0i64; 3]; 4];
        for j in 0..m {
            let s = band_step(step, band_slope, j, m);
            let mut row = [0i64; 3];
            for k in 0..3 {
                let qi = models.coef[coef_context(j, k, &hist, &row)].decode(&mut dec)?;
                q[(j, k)] = qi as f64 * s;
                row[k] = qi;
            }
            hist = [hist[1], hist[2], hist[3], row];
        }
        if dec.exhausted() {
            return Err(CodecError::Truncated("geometry stream"));
        }
        coefs.push(q);
    }
    let synth = bases
        .par_iter()
        .zip(coefs.par_iter())
        .map(|(b, q)| b.synthesise(q))
        .collect::<Result<Vec<_>, _>>()?;
    for (b, x) in bases.iter().zip(&synth) {
        let xhat = b.pred.as_ref().map(|pr| pr.predict(&rec));
        place(b, xhat.as_ref(), x, &mut rec);
    }
    let (border, loose) = border_and_loose(topo, &bases);
    let mut loose_set = vec![false; n];
    for &v in &loose {
        loose_set[v as usize] = true;
    }
    for v in residual_targets(&border, &loose, border_residuals) {
        let pred = prediction(topo, v, &rec, &loose_set);
        for k in 0..3 {
            rec[v as usize][k] = pred[k] + models.resid[k].decode(&mut dec)? as f64 * step;
        }
    }
    dec.finish()?;
    if rec.iter().flatten().any(|x| !x.is_finite()) {
        return Err(CodecError::Corrupt("non-finite decoded coordinate"));
    }
    Ok(rec)
}

#[cfg(test)]
mod tests {
    use super::super::test_util::rms;
    use super::*;
    use crate::mesh::builtin;

    #[test]
    fn decoder_reproduces_encoder_exactly_with_repeated_eigenvalues() {
        for spec in ["builtin:icosphere:3", "builtin:cube:8", "builtin:grid:9"] {
            let m = builtin::from_spec(spec).unwrap();
            let topo = Topology::new(&m).unwrap();
            for (op, predicted) in [
                (OperatorKind::Sstl, true),
                (OperatorKind::Sstl, false),
                (OperatorKind::Sql, true),
                (OperatorKind::Tutte, true),
                (OperatorKind::Kirchhoff, false),
                (OperatorKind::Graph, true),
            ] {
                let params = GeometryParams {
                    operator: op,
                    patch_size: 120,
                    keep: Keep::Ratio(0.5),
                    border_residuals: true,
                    band_slope: 0.5,
                    predicted,
                    dead_zone: 0.4,
                };
                let enc = GeometryEncoder::new(&topo, &m.positions, params).unwrap();
                let step = m.bbox_diagonal() / 1024.0;
                let (data, rec, _) = enc.encode(step).unwrap();
                let dec = decode(&topo, &data).unwrap();
                assert_eq!(dec, rec, "{spec} {op}");
            }
        }
    }

    #[test]
    fn full_basis_is_lossless_up_to_quantisation() {
        let m = builtin::from_spec("builtin:torus:10:8").unwrap();
        let topo = Topology::new(&m).unwrap();
        for op in [OperatorKind::Sstl, OperatorKind::Tutte] {
            let params = GeometryParams {
                operator: op,
                patch_size: 1000,
                keep: Keep::Ratio(1.0),
                border_residuals: false,
                band_slope: 0.0,
                predicted: false,
                dead_zone: 0.5,
            };
            let enc = GeometryEncoder::new(&topo, &m.positions, params).unwrap();
            let step = 1e-6;
            let (_, rec, _) = enc.encode(step).unwrap();
            // One patch, orthonormal (or D^{1/2}-scaled) basis: error of order the step.
            assert!(rms(&rec, &m.positions) < 1e-5, "{op}");
        }
    }

    #[test]
    fn fewer_coefficients_more_error_and_border_coding_helps() {
        let m = builtin::from_spec("builtin:icosphere:4").unwrap();
        let topo = Topology::new(&m).unwrap();
        let step = m.bbox_diagonal() / 4096.0;
        let mut last = 0.0;
        // Without inter-patch prediction (which pins the borders shared with earlier
        // patches), a truncated SSTL basis errs most on the free patch borders (the
        // Kirchhoff basis need not: at keep ratio 0.8 here its border RMS is half the
        // interior's).
        for r in [0.8, 0.4, 0.1] {
            let params = GeometryParams {
                keep: Keep::Ratio(r),
                patch_size: 200,
                border_residuals: false,
                predicted: false,
                operator: OperatorKind::Sstl,
                ..Default::default()
            };
            let (_, rec, st) = GeometryEncoder::new(&topo, &m.positions, params)
                .unwrap()
                .encode(step)
                .unwrap();
            let e = rms(&rec, &m.positions);
            assert!(e > last, "ratio {r}: {e} ≤ {last}");
            assert!(st.border_rms_before > st.interior_rms);
            last = e;
        }
        let params = GeometryParams {
            keep: Keep::Ratio(0.1),
            patch_size: 200,
            border_residuals: true,
            predicted: false,
            operator: OperatorKind::Sstl,
            ..Default::default()
        };
        let (_, rec, _) = GeometryEncoder::new(&topo, &m.positions, params)
            .unwrap()
            .encode(step)
            .unwrap();
        assert!(rms(&rec, &m.positions) < last);
    }

    #[test]
    fn prediction_shrinks_the_stream_and_keeps_the_error() {
        let m = builtin::from_spec("builtin:torus:40:24").unwrap();
        let topo = Topology::new(&m).unwrap();
        let step = m.bbox_diagonal() / 2048.0;
        let run = |predicted| {
            let params = GeometryParams {
                patch_size: 100,
                predicted,
                band_slope: 0.0,
                ..Default::default()
            };
            let enc = GeometryEncoder::new(&topo, &m.positions, params).unwrap();
            let (data, rec, st) = enc.encode(step).unwrap();
            assert_eq!(decode(&topo, &data).unwrap(), rec);
            assert!(st.patches >= 8);
            (data.len(), rms(&rec, &m.positions))
        };
        let (with, e_with) = run(true);
        let (without, e_without) = run(false);
        assert!(
            (with as f64) < 0.9 * without as f64,
            "{with} vs {without} bytes"
        );
        // Same step, same (uniform) quantisation error up to noise.
        assert!(e_with < 1.2 * e_without && e_without < 1.2 * e_with);
    }

    #[test]
    fn corrupt_geometry_never_panics() {
        use rand::{Rng, SeedableRng};
        let m = builtin::from_spec("builtin:icosphere:2").unwrap();
        let topo = Topology::new(&m).unwrap();
        let (data, _, _) = GeometryEncoder::new(&topo, &m.positions, GeometryParams::default())
            .unwrap()
            .encode(0.01)
            .unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        for _ in 0..200 {
            let mut d = data.clone();
            if rng.gen_bool(0.5) {
                d.truncate(rng.gen_range(0..d.len()));
            } else {
                let i = rng.gen_range(0..d.len());
                d[i] ^= 1 << rng.gen_range(0..8);
            }
            let _ = decode(&topo, &d);
        }
    }
}
