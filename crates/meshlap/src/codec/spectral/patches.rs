//! Patches and their bases: the partition of the decoded connectivity (Lloyd cells
//! from format 7, METIS before; [`partition_method`]), per patch
//! the eigenvectors of the combinatorial operator of the patch submesh, and which
//! vertices lie on a patch border or on no face of their patch.
//!
//! Everything here depends on the connectivity only, so the decoder, which has the
//! same connectivity in the same vertex order, rebuilds exactly the encoder's patches
//! and bases.

use super::params::{Keep, SpectralParams};
use super::prediction::{patch_prediction, Prediction, PredictorForm};
use crate::codec::CodecError;
use crate::mesh::graph::VertexGraph;
use crate::mesh::TriMesh;
use crate::operator::{Operator, OperatorKind, OperatorOptions};
use crate::spectral::{
    forward, inverse, BasisOptions, DenseSolver, EigenBasis, EigenPath, FactoredEvd, SpectralError,
};
use faer::Mat;
use rayon::prelude::*;

/// How the coefficient products `X = E⁻¹x`, `x̃ = E_m X̃` and the predictor's Cholesky
/// are computed. The bases themselves are bit-reproducible either way
/// ([`crate::spectral::dense_evd`], plain loops in the canonicalization).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum Arithmetic {
    /// faer's products and Cholesky, whose kernels (picked by `pulp` at run time:
    /// AVX2 + FMA or scalar) sum in CPU-dependent orders, so decoded coordinates can
    /// differ in their last bits between machines. Format versions 4 and 5 were
    /// written with it and are decoded with it (their golden hashes pin it).
    Faer,
    /// Plain loops in index order with correctly rounded `+ − × ÷ √` only (no fused
    /// operations, no reassociation): the same bits on every IEEE-754 CPU, with or
    /// without AVX2/FMA, and every thread count. Format version 6 on.
    Fixed,
}

impl Arithmetic {
    /// The arithmetic files of format `version` were written with.
    pub fn for_version(version: u16) -> Self {
        if version >= 6 {
            Arithmetic::Fixed
        } else {
            Arithmetic::Faer
        }
    }
}

/// How a patch's basis is kept and applied.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum BasisForm {
    /// The basis matrix E itself ([`EigenBasis`]: back-transformed, canonical
    /// vectors), applied by products with E. Format versions 4 to 7, and the Tutte
    /// operator (not symmetric) in every version.
    Explicit,
    /// For the symmetric operators (Kirchhoff, graph, SQL, SSTL), the decomposition
    /// kept factored ([`FactoredEvd`]: Householder reflectors and the tridiagonal
    /// eigenvectors, `X = Zᵀ(Qᵀx)`, `x̃ = Q(Z X̃)`), so that E is never formed: the
    /// back-transformation (as many flops as the tridiagonalisation) is skipped on
    /// both sides. Format version 8 on.
    Factored,
}

impl BasisForm {
    /// The form files of format `version` were written with.
    pub fn for_version(version: u16) -> Self {
        if version >= 8 {
            BasisForm::Factored
        } else {
            BasisForm::Explicit
        }
    }
}

/// How the files of one format version compute their patches' bases, coefficient
/// products and predictors.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) struct Recipe {
    /// The arithmetic of the products and the predictor's Cholesky.
    pub arith: Arithmetic,
    /// How the predictor is applied.
    pub predictor: PredictorForm,
    /// How the bases are kept.
    pub basis: BasisForm,
}

impl Recipe {
    /// The recipe of format `version`.
    pub fn for_version(version: u16) -> Self {
        Self {
            arith: Arithmetic::for_version(version),
            predictor: PredictorForm::for_version(version),
            basis: BasisForm::for_version(version),
        }
    }
}

/// A patch's basis, in the form its format version keeps it.
pub(super) enum Basis {
    /// The basis matrix ([`BasisForm::Explicit`]).
    Explicit(EigenBasis),
    /// The factored decomposition ([`BasisForm::Factored`]).
    Factored(FactoredEvd),
}

/// The three columns of `x` (n×3) as vectors.
fn columns(x: &Mat<f64>) -> [Vec<f64>; 3] {
    std::array::from_fn(|k| (0..x.nrows()).map(|i| x[(i, k)]).collect())
}

/// `X = g ∘ Eᵀ(s ∘ x)` (m×3, the first `m` coefficients) in index order: what
/// [`forward`] computes for the symmetric and symmetrized paths, without faer.
fn forward_fixed(b: &EigenBasis, x: &Mat<f64>, m: usize) -> Mat<f64> {
    let (n, e, s, g) = (b.n(), b.vectors(), b.weights(), b.coefficient_scale());
    let sx: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            let w = s.map_or(1.0, |s| s[i]);
            let r = [x[(i, 0)], x[(i, 1)], x[(i, 2)]];
            if s.is_some() {
                r.map(|v| w * v)
            } else {
                r
            }
        })
        .collect();
    let mut out = Mat::<f64>::zeros(m, 3);
    for j in 0..m {
        let col = e.col(j);
        let mut acc = [0.0f64; 3];
        for (i, r) in sx.iter().enumerate() {
            let v = col[i];
            for k in 0..3 {
                acc[k] += v * r[k];
            }
        }
        for k in 0..3 {
            out[(j, k)] = if g[j] != 1.0 { acc[k] * g[j] } else { acc[k] };
        }
    }
    out
}

/// `x̃ = E_m X̃` (n×3) summed over the coefficients in index order, without faer.
fn inverse_fixed(b: &EigenBasis, c: &Mat<f64>) -> Mat<f64> {
    let (n, e) = (b.n(), b.vectors());
    let mut acc = vec![[0.0f64; 3]; n];
    for j in 0..c.nrows() {
        let col = e.col(j);
        let cj = [c[(j, 0)], c[(j, 1)], c[(j, 2)]];
        for (i, a) in acc.iter_mut().enumerate() {
            let v = col[i];
            for k in 0..3 {
                a[k] += v * cj[k];
            }
        }
    }
    Mat::from_fn(n, 3, |i, k| acc[i][k])
}

/// The partitioner files of format `version` were written with: METIS k-way with a
/// fixed seed up to version 6, the Lloyd relaxation of graph Voronoi cells from
/// version 7 (integer arithmetic from the connectivity alone, several times faster;
/// [`crate::partition::PartitionMethod`]).
pub(super) fn partition_method(version: u16) -> crate::partition::PartitionMethod {
    use crate::partition::PartitionMethod;
    if version >= 7 {
        PartitionMethod::Lloyd
    } else {
        PartitionMethod::Metis
    }
}

/// Lloyd steps of the patches of format `version` (versions 7 and 8: five; 9 on: two).
pub(super) fn lloyd_iterations(version: u16) -> usize {
    use crate::partition::PartitionMethod;
    if version >= 9 {
        PartitionMethod::LLOYD_ITERATIONS_FAST
    } else {
        PartitionMethod::LLOYD_ITERATIONS
    }
}

/// Patches of about `p` vertices ([`crate::partition`] with the method of format
/// `version`, [`partition_method`]: connected patches, every vertex on a face of its
/// own patch). Deterministic for a given connectivity, so the decoder, which has the
/// same connectivity in the same order, gets the same patches. Each vertex belongs to
/// exactly one patch.
fn partition(
    topo: &VertexGraph,
    p: usize,
    version: u16,
) -> Result<crate::partition::Partition, CodecError> {
    use crate::partition::{partition as make_patches, PartitionOptions};
    let opts = PartitionOptions {
        method: partition_method(version),
        lloyd_iterations: lloyd_iterations(version),
        ..PartitionOptions::new(p.max(3))
    };
    make_patches(topo, &opts).map_err(CodecError::Partition)
}

/// A patch's basis ([`crate::spectral::EigenBasis`]: canonical, deterministic
/// eigenvectors, ascending eigenvalues), how many coefficients it keeps and its
/// inter-patch predictor.
pub(super) struct PatchBasis {
    /// The patch vertices that lie on a face of the patch (the others are coded as
    /// loose vertices), in the basis' row order.
    pub verts: Vec<u32>,
    /// `None` for a patch without faces.
    pub basis: Option<Basis>,
    /// Coefficients kept.
    pub m: usize,
    /// The predictor from earlier patches (with inter-patch prediction on).
    pub pred: Option<Prediction>,
    /// How the coefficient products are computed.
    pub arith: Arithmetic,
}

impl PatchBasis {
    /// The first `m` coefficients (m×3) of the patch coordinates `x` (n_p×3).
    pub fn analyze(&self, x: &Mat<f64>) -> Result<Mat<f64>, CodecError> {
        match &self.basis {
            None => Ok(Mat::zeros(0, 3)),
            Some(Basis::Factored(f)) => {
                let x = columns(x);
                let c = f.analyze([&x[0], &x[1], &x[2]], self.m.min(f.len()));
                Ok(Mat::from_fn(c[0].len(), 3, |j, k| c[k][j]))
            }
            Some(Basis::Explicit(b))
                if self.arith == Arithmetic::Fixed && b.path() != EigenPath::General =>
            {
                Ok(forward_fixed(b, x, self.m))
            }
            Some(Basis::Explicit(b)) => {
                let all = forward(b, x.as_ref()).map_err(CodecError::PatchBasis)?;
                Ok(all.subrows(0, self.m).to_owned())
            }
        }
    }

    /// Coordinates (n_p×3) from the first coefficients (at most the basis' vectors).
    /// Without a basis (a patch without faces, or a decoder's patch whose
    /// coefficients are all zero) zeros, as the synthesis of zero coefficients is.
    pub fn synthesize(&self, c: &Mat<f64>) -> Result<Mat<f64>, CodecError> {
        match &self.basis {
            None => Ok(Mat::zeros(self.verts.len(), 3)),
            Some(Basis::Factored(f)) if c.nrows() <= f.len() => {
                let c = columns(c);
                let y = f.synthesize([&c[0], &c[1], &c[2]]);
                Ok(Mat::from_fn(f.n(), 3, |i, k| y[k][i]))
            }
            Some(Basis::Factored(_)) => Err(CodecError::Internal(
                "more coefficients than the factored basis keeps",
            )),
            Some(Basis::Explicit(b)) if self.arith == Arithmetic::Fixed && c.nrows() <= b.len() => {
                Ok(inverse_fixed(b, c))
            }
            Some(Basis::Explicit(b)) => inverse(b, c.as_ref()).map_err(CodecError::PatchBasis),
        }
    }

    /// Writes the patch's coordinates, prediction `x̂` (if any) plus synthesized
    /// residual `x` (n_p×3), into `rec`.
    pub fn place(&self, xhat: Option<&Mat<f64>>, x: &Mat<f64>, rec: &mut [[f64; 3]]) {
        for (i, &v) in self.verts.iter().enumerate() {
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
}

/// A patch before its basis: what the partition and the connectivity give. Small
/// (its vertices and faces): the submesh, its connectivity and its operator are
/// built only when the basis is computed ([`patch_basis`]), so a layout of every
/// patch of a 10-million-vertex mesh stays within a few hundred MB.
pub(super) struct PatchLayout {
    /// The patch vertices that lie on a face of the patch (global numbering; the
    /// basis' row order).
    pub verts: Vec<u32>,
    /// The patch's faces over `verts` (local numbering); empty for a patch without
    /// faces.
    faces: Vec<[u32; 3]>,
    /// Coefficients kept.
    pub m: usize,
}

impl PatchLayout {
    /// Bytes of the patch's basis at most, the unit of [`chunks`]' budget: 3n_p²/2
    /// values, what a factored basis keeps with every vector (n_p(n_p − 1)/2
    /// reflector entries and n_p² of Z); an explicit basis takes n_p².
    pub(super) fn basis_bytes(&self) -> usize {
        let n = self.verts.len();
        (n * n + n * n / 2) * std::mem::size_of::<f64>()
    }
}

/// The layout of one patch (vertices `patch`, global; `pfaces` its faces, in the
/// patch's numbering: index into `patch`): vertices on no face of the patch are left
/// out (coded as loose vertices).
fn patch_layout(patch: &[u32], pfaces: Vec<[u32; 3]>, keep: Keep) -> PatchLayout {
    let mut on_face = vec![false; patch.len()];
    for f in &pfaces {
        for &x in f {
            on_face[x as usize] = true;
        }
    }
    let mut remap = vec![u32::MAX; patch.len()];
    let mut verts = Vec::new();
    for i in 0..patch.len() {
        if on_face[i] {
            remap[i] = verts.len() as u32;
            verts.push(i as u32);
        }
    }
    let faces: Vec<[u32; 3]> = pfaces
        .iter()
        .map(|f| f.map(|x| remap[x as usize]))
        .collect();
    let np = verts.len();
    let verts: Vec<u32> = verts.iter().map(|&i| patch[i as usize]).collect();
    PatchLayout {
        verts,
        faces,
        m: if np == 0 { 0 } else { keep.count(np) },
    }
}

/// The operator `kind` (`F = D − W`, PSD) of a patch's submesh; `None` for a patch
/// without faces.
pub(super) fn patch_operator(
    layout: &PatchLayout,
    kind: OperatorKind,
) -> Result<Option<Operator>, CodecError> {
    let np = layout.verts.len();
    if np == 0 {
        return Ok(None);
    }
    let sub = TriMesh::new(vec![[0.0; 3]; np], layout.faces.clone());
    let st = crate::mesh::topology::Topology::new(&sub).map_err(CodecError::PatchTopology)?;
    Operator::assemble(kind, &sub, &st, &OperatorOptions::default())
        .map(Some)
        .map_err(CodecError::PatchOperator)
}

/// The bases of a few patches (`layouts`, needing `needs` vectors each: all for
/// `usize::MAX`, none for 0) of the operator `kind`, kept as `recipe` says: factored
/// ([`FactoredEvd::batch_dense`], the first `min(need, m)` tridiagonal eigenvectors) for the
/// symmetric operators from format 8, else explicit ([`EigenBasis::compute_lowest`]:
/// canonical vectors, at least the first `need`). `None` for a patch without faces
/// or needing none.
fn patch_bases(
    layouts: &[PatchLayout],
    needs: &[usize],
    kind: OperatorKind,
    recipe: Recipe,
) -> Result<Vec<Option<Basis>>, CodecError> {
    if !(recipe.basis == BasisForm::Factored && kind.is_symmetric()) {
        let opts = BasisOptions {
            dense_solver: DenseSolver::Reproducible,
            ..Default::default()
        };
        return layouts
            .iter()
            .zip(needs)
            .map(|(l, &need)| {
                if need == 0 {
                    return Ok(None);
                }
                patch_operator(l, kind)?
                    .map(|op| {
                        EigenBasis::compute_lowest(&op, &opts, need)
                            .map(Basis::Explicit)
                            .map_err(CodecError::PatchBasis)
                    })
                    .transpose()
            })
            .collect();
    }
    // Every patch's dense operator, decomposed in one batch.
    let mut dense = Vec::new();
    let mut at = Vec::new();
    for (i, (l, &need)) in layouts.iter().zip(needs).enumerate() {
        let np = l.verts.len();
        if need == 0 || np == 0 {
            continue;
        }
        let a = if kind == OperatorKind::Kirchhoff {
            // K = D − A straight from the faces: the values `Operator::assemble`
            // gives (small integers, exact), without building the patch's topology.
            kirchhoff_dense(l)
        } else {
            let op = patch_operator(l, kind)?.ok_or(CodecError::Internal(
                "a patch with vertices and no operator",
            ))?;
            if op.mass.is_some() {
                return Err(CodecError::Internal("a combinatorial operator with a mass"));
            }
            let d = op.matrix.to_dense();
            (0..np * np).map(|x| d[(x % np, x / np)]).collect()
        };
        // The coefficients past the kept ones are never used.
        dense.push((np, a, need.min(l.m)));
        at.push(i);
    }
    let mut out: Vec<Option<Basis>> = (0..layouts.len()).map(|_| None).collect();
    for (i, f) in at.into_iter().zip(FactoredEvd::batch_dense(dense)) {
        let f = f.ok_or(CodecError::PatchBasis(SpectralError::NoConvergence {
            path: "symmetric (factored reproducible solver)",
        }))?;
        out[i] = Some(Basis::Factored(f));
    }
    Ok(out)
}

/// The Kirchhoff operator `K = D − A` (PSD sign convention) of a patch's submesh,
/// dense n_p×n_p column-major (`k[i + j·n_p]`): −1 for each edge of its faces, the
/// vertex degrees on the diagonal.
pub(super) fn kirchhoff_dense(layout: &PatchLayout) -> Vec<f64> {
    let np = layout.verts.len();
    let mut k = vec![0.0f64; np * np];
    let mut deg = vec![0u32; np];
    for f in &layout.faces {
        for (a, b) in [(f[0], f[1]), (f[1], f[2]), (f[2], f[0])] {
            let (a, b) = (a as usize, b as usize);
            if k[a + b * np] == 0.0 {
                k[a + b * np] = -1.0;
                k[b + a * np] = -1.0;
                deg[a] += 1;
                deg[b] += 1;
            }
        }
    }
    for (i, &d) in deg.iter().enumerate() {
        k[i + i * np] = f64::from(d);
    }
    k
}

/// The partition into patches (by the method of format `version`) and each patch's
/// layout, in coding order (in parallel). Depends on the connectivity only.
pub(super) fn layout(
    topo: &VertexGraph,
    params: &SpectralParams,
    version: u16,
) -> Result<Vec<PatchLayout>, CodecError> {
    let part = partition(topo, params.patch_size, version)?;
    // Each vertex's index in its patch (a patch lists its vertices ascending).
    let mut local = vec![0u32; topo.n_vertices()];
    for p in 0..part.n_patches() {
        for (i, &v) in part.patch_vertices(p).iter().enumerate() {
            local[v as usize] = i as u32;
        }
    }
    // A patch's faces are those with all three corners in it, ascending.
    let faces = topo.faces();
    Ok((0..part.n_patches())
        .into_par_iter()
        .map(|p| {
            let pfaces = part
                .patch_faces(p)
                .iter()
                .map(|&f| faces[f as usize].map(|v| local[v as usize]))
                .collect();
            patch_layout(part.patch_vertices(p), pfaces, params.keep)
        })
        .collect())
}

/// Patch of each vertex in `layout` (`u32::MAX`: loose vertex), for the predictors
/// when `params.predicted` (`None` otherwise).
pub(super) fn predictor_owners(
    n: usize,
    params: &SpectralParams,
    layout: &[PatchLayout],
) -> Option<Vec<u32>> {
    params
        .predicted
        .then(|| owners(n, layout.iter().map(|l| l.verts.as_slice())))
}

/// The bases of the patches `range` of `layout` ([`layout`]), in coding order (in
/// parallel; each decomposition is sequential), with their predictors when `owner`
/// is given ([`predictor_owners`]); `recipe` (the format version's) says how their
/// bases are kept and their products and predictions computed. Patch `p` gets at
/// least its first `need(p)` vectors (all for `usize::MAX`; none for 0, its synthesis
/// then being zero): the decoder, which
/// knows the coefficients before the bases, needs the vectors up to a patch's last
/// non-zero coefficient only. Bases and predictors are computed together (they are
/// independent: the predictors need the vertex sets only). Each patch's basis (with
/// its index) goes to `then` as soon as its group is computed, in the same task, and
/// `then`'s results are returned in patch order: a decoder that synthesizes there and
/// drops the basis keeps a few bases alive at a time instead of a chunk's, so their
/// memory is reused while still in cache.
#[allow(clippy::too_many_arguments)] // the bases' arguments and the hook
pub(super) fn bases_then<T: Send>(
    topo: &VertexGraph,
    params: &SpectralParams,
    recipe: Recipe,
    layout: &[PatchLayout],
    owner: Option<&[u32]>,
    range: std::ops::Range<usize>,
    need: impl Fn(usize) -> usize + Sync,
    then: impl Fn(usize, PatchBasis) -> Result<T, CodecError> + Sync,
) -> Result<Vec<T>, CodecError> {
    // Eight patches per task: their factored decompositions run together
    // ([`FactoredEvd::batch_dense`], whose QL iterations go eight at a time).
    const GROUP: usize = 8;
    let start = range.start;
    let groups = layout[range]
        .par_chunks(GROUP)
        .enumerate()
        .map(|(g, ls)| {
            let p0 = start + g * GROUP;
            let needs: Vec<usize> = (p0..p0 + ls.len()).map(&need).collect();
            let bases = patch_bases(ls, &needs, params.operator, recipe)?;
            ls.iter()
                .zip(bases)
                .enumerate()
                .map(|(i, (l, basis))| {
                    let pred = match owner {
                        Some(owner) if !l.verts.is_empty() => patch_prediction(
                            topo,
                            owner,
                            &l.verts,
                            (p0 + i) as u32,
                            recipe.arith,
                            recipe.predictor,
                        ),
                        _ => None,
                    };
                    then(
                        p0 + i,
                        PatchBasis {
                            verts: l.verts.clone(),
                            basis,
                            m: l.m,
                            pred,
                            arith: recipe.arith,
                        },
                    )
                })
                .collect::<Result<Vec<_>, CodecError>>()
        })
        .collect::<Result<Vec<_>, CodecError>>()?;
    Ok(groups.into_iter().flatten().collect())
}

/// Bytes of dense bases computed at once by [`stream`]: with two chunks alive (one
/// being coded, the next being computed) the bases of any mesh take about twice
/// this, plus their predictors.
pub(super) const CHUNK_BYTES: usize = 64 << 20;

/// Consecutive ranges of patches whose dense bases ([`PatchLayout::basis_bytes`]) take
/// at most `budget` bytes each (a single larger patch makes a range of its own).
pub(super) fn chunks(layout: &[PatchLayout], budget: usize) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let (mut start, mut bytes) = (0, 0usize);
    for (p, l) in layout.iter().enumerate() {
        let b = l.basis_bytes();
        if p > start && bytes + b > budget {
            out.push(start..p);
            (start, bytes) = (p, 0);
        }
        bytes += b;
    }
    if start < layout.len() {
        out.push(start..layout.len());
    }
    out
}

/// Runs `compute` on each range of `ranges` (consecutive, ascending) in order; it
/// hands each patch's result to its sink (in any order, from any thread), and
/// `consume` gets them one patch at a time in patch order: the patches' bases
/// (parallel, independent of the coded positions) overlap the sequential coding that
/// needs them in order. With more than one thread in the pool, `consume` runs on a
/// thread of its own and takes each patch as soon as it and every earlier one are
/// computed, so the coding of a range overlaps its own computation and no range
/// waits for the slowest patch of the one before; range `i + 1` is computed only once
/// range `i − 1` is consumed, so at most two ranges' results are alive at once. On
/// one thread, each range is computed, then consumed. The first error is returned:
/// `compute`'s if it failed (the coding then stops at the first patch that never
/// came), else `consume`'s (the computation then stops after its current range).
pub(super) fn stream<T: Send>(
    ranges: &[std::ops::Range<usize>],
    compute: impl Fn(std::ops::Range<usize>, &(dyn Fn(usize, T) + Sync)) -> Result<(), CodecError>
        + Sync,
    mut consume: impl FnMut(usize, T) -> Result<(), CodecError> + Send,
) -> Result<(), CodecError> {
    let (Some(first), Some(last)) = (ranges.first(), ranges.last()) else {
        return Ok(());
    };
    if rayon::current_num_threads() <= 1 {
        for r in ranges {
            let slots: Vec<std::sync::Mutex<Option<T>>> =
                r.clone().map(|_| std::sync::Mutex::new(None)).collect();
            compute(r.clone(), &|p, t| {
                if let Some(slot) = p.checked_sub(r.start).and_then(|i| slots.get(i)) {
                    *slot.lock().unwrap_or_else(|e| e.into_inner()) = Some(t);
                }
            })?;
            for (p, slot) in r.clone().zip(slots) {
                let t = slot.into_inner().unwrap_or_else(|e| e.into_inner());
                consume(
                    p,
                    t.ok_or(CodecError::Internal("stream: a patch was not computed"))?,
                )?;
            }
        }
        return Ok(());
    }
    let (begin, end) = (first.start, last.end);
    let consumed = Progress::new(begin);
    let (tx, rx) = std::sync::mpsc::channel::<(usize, T)>();
    std::thread::scope(|sc| {
        // Owned here, so that an unwinding computation drops it and the coding ends.
        let tx = tx;
        let consumer = sc.spawn(|| {
            let rx = rx;
            // Stops the computation however this returns (error or unwinding).
            let _stop = StopOnDrop(Some(&consumed));
            let mut early = std::collections::BTreeMap::new();
            let mut next = begin;
            while next < end {
                let Ok((p, t)) = rx.recv() else {
                    return Err(CodecError::Internal("stream: a patch never came"));
                };
                early.insert(p, t);
                while let Some(t) = early.remove(&next) {
                    consume(next, t)?;
                    next += 1;
                    consumed.advance(next);
                }
            }
            Ok(())
        });
        let computed = (|| {
            for (i, r) in ranges.iter().enumerate() {
                // Range i − 2 consumed (or the coding stopped).
                if i >= 2 {
                    consumed.wait_past(ranges[i - 1].start - 1);
                }
                if consumed.stopped() {
                    break;
                }
                let tx = tx.clone();
                compute(r.clone(), &move |p, t| {
                    // The coding stopped: nothing takes the rest.
                    let _ = tx.send((p, t));
                })?;
            }
            Ok(())
        })();
        drop(tx);
        let coded = consumer
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        computed.and(coded)
    })
}

/// How far a sequential producer (the coefficients' range decoder, the coding of
/// [`stream`]) has got, for the threads that wait on it: a count of items done in
/// order, and whether it stopped early.
pub(super) struct Progress {
    state: std::sync::Mutex<(usize, bool)>,
    changed: std::sync::Condvar,
}

impl Progress {
    /// Nothing done yet beyond `start` items.
    pub fn new(start: usize) -> Self {
        Self {
            state: std::sync::Mutex::new((start, false)),
            changed: std::sync::Condvar::new(),
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, (usize, bool)> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// `done` items are done.
    pub fn advance(&self, done: usize) {
        self.lock().0 = done;
        self.changed.notify_all();
    }

    /// No more items come.
    pub fn stop(&self) {
        self.lock().1 = true;
        self.changed.notify_all();
    }

    /// Whether the producer stopped early.
    pub fn stopped(&self) -> bool {
        self.lock().1
    }

    /// Waits until item `i` is done or the producer stopped.
    pub fn wait_past(&self, i: usize) {
        let mut g = self.lock();
        while g.0 <= i && !g.1 {
            g = self.changed.wait(g).unwrap_or_else(|e| e.into_inner());
        }
    }
}

/// Stops a [`Progress`] when dropped (a producer's early return or unwinding)
/// unless disarmed (`.0 = None`), so that no thread waits for items that never come.
pub(super) struct StopOnDrop<'a>(pub Option<&'a Progress>);

impl Drop for StopOnDrop<'_> {
    fn drop(&mut self) {
        if let Some(p) = self.0 {
            p.stop();
        }
    }
}

/// Patch of each vertex given each patch's vertices in order (`u32::MAX`: in no
/// patch, a loose vertex).
fn owners<'v>(n: usize, patches: impl Iterator<Item = &'v [u32]>) -> Vec<u32> {
    let mut owner = vec![u32::MAX; n];
    for (p, verts) in patches.enumerate() {
        for &v in verts {
            owner[v as usize] = p as u32;
        }
    }
    owner
}

/// Vertices adjacent to a vertex of another patch (`border[v]`), and the vertices in
/// no patch basis (loose, ascending).
pub(super) fn border_and_loose(
    topo: &VertexGraph,
    layout: &[PatchLayout],
) -> (Vec<bool>, Vec<u32>) {
    let n = topo.n_vertices();
    let owner = owners(n, layout.iter().map(|l| l.verts.as_slice()));
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
