//! Where the watermark lives: the patches, their low-frequency eigenvectors and the
//! key's assignment of chips to coefficient slots (shared by [`super::embed()`] and
//! [`super::detect()`], which must build exactly the same layout from the original).
//!
//! ## Patches and bases (Ohbuchi et al. GI 2001 §3, CGF 2002 §3)
//! The mesh is split into connected patches of about `P` vertices by
//! [`crate::partition::partition`] (METIS, seed 0, as the codec); `P` is
//! [`LayoutParams::patch_size`] or, by default, [`LayoutParams::patch_size_for`] the
//! mesh: about [`LayoutParams::TARGET_PATCHES`] patches of at least
//! [`LayoutParams::MIN_PATCH_SIZE`] vertices. Each patch submesh
//! gets its combinatorial operator `F = D − W` (positive semi-definite sign
//! convention; Kirchhoff by default, as in the papers) and its `band + 1` smallest
//! eigenpairs of `K v = λ M v` ([`crate::spectral::partial`]: `K = F`, `M = I` for the
//! symmetric KL, SQL, SSTL; `K = D·T`, `M = D` for the Tutte Laplacian, whose
//! eigenvectors are then `D`-orthonormal). The first (constant, λ = 0) vector is the
//! patch's DC and is skipped; the next `band` vectors `v_1 … v_band` (fewer in a patch
//! of at most `band` vertices) carry the mark.
//!
//! ## Slots
//! A slot is one (patch, eigenvector k, axis) triple: its coefficient is
//! `X = v_kᵀ M x_axis` (the ED-transform of Zhang 2004 §2.3, restricted to the patch)
//! and changing it by `δ` moves the patch vertices by `δ·v_k` along the axis. Slots are
//! numbered patch by patch, then by k, then axis; there are `3·Σ_p band_p` of them.
//! Unlike Ohbuchi et al., who add the same chip to x, y and z (moving every vertex
//! along (1, 1, 1)), each axis is a slot of its own, so the displacement has no
//! preferred direction and three times as many chips fit.
//!
//! ## Spreading (the key)
//! With `B` bits and chip rate `c` (`None`: as many as fit, `⌊slots / B⌋`), the key's
//! permutation ([`super::key::permutation`]) picks `B·c` distinct slots; slot
//! `perm[i·c + j]` carries chip `j` of bit `i` with the sign `chips[i·c + j]`
//! ([`super::key::chips`]). Each bit is thus spread over `c` coefficients scattered over
//! the whole mesh.

use super::error::WatermarkError;
use super::key;
use crate::mesh::topology::Topology;
use crate::mesh::TriMesh;
use crate::operator::{Operator, OperatorKind, OperatorOptions};
use crate::partition::{partition, PartitionOptions};
use crate::spectral::partial::{partial_spectrum, PartialParams, SymmetricProblem};
use faer::Mat;
use rayon::prelude::*;
use serde::Serialize;

/// How the mark is laid out: operator, patches, band and chip rate. Embedding and
/// detection must use the same values.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LayoutParams {
    /// Combinatorial operator of the patch bases (PSD, `F = D − W`).
    pub operator: OperatorKind,
    /// Target vertices per patch, `P` (at least 3); `None`: from the mesh's size
    /// ([`LayoutParams::patch_size_for`]).
    pub patch_size: Option<usize>,
    /// Low-frequency eigenvectors per patch carrying the mark (after the skipped DC).
    pub band: usize,
    /// Chips per bit; `None` uses every slot (`⌊slots / bits⌋`).
    pub chip_rate: Option<usize>,
}

impl Default for LayoutParams {
    /// Kirchhoff, patches from the mesh's size (about 36 of at least 1,000 vertices),
    /// a band of 24 eigenvectors, every slot: chosen from the parameter sweep in
    /// BENCHMARKS.md ("Spectral watermarking", "Parameter sweep"). Larger patches lower
    /// the MSDM2 cost (lower spatial frequencies) but leave a small mesh too few
    /// patches to survive cropping, hence a patch count rather than a fixed size; a
    /// narrower band loses bits under simplification, a wider one costs more MSDM2.
    fn default() -> Self {
        Self {
            operator: OperatorKind::Kirchhoff,
            patch_size: None,
            band: 24,
            chip_rate: None,
        }
    }
}

/// One patch: its vertices (global indices), the band's eigenvectors (columns, DC
/// dropped) and the mass `M` of the projection (`None`: identity).
#[derive(Clone)]
pub(crate) struct PatchBasis {
    pub vertices: Vec<u32>,
    pub vectors: Mat<f64>,
    pub mass: Option<Vec<f64>>,
    /// First slot of the patch.
    pub offset: usize,
}

impl PatchBasis {
    fn band(&self) -> usize {
        self.vectors.ncols()
    }
}

/// The bases of every patch and the key's slot assignment.
pub(crate) struct Layout {
    pub patches: Vec<PatchBasis>,
    /// Total slots.
    pub slots: usize,
    /// Patch of each slot.
    pub slot_patch: Vec<u32>,
    /// Chips per bit.
    pub chip_rate: usize,
    /// Slot of chip `j` of bit `i` at `i·c + j`.
    pub assigned: Vec<u32>,
    /// Its ±1 sign.
    pub chips: Vec<f64>,
}

impl LayoutParams {
    /// Patches the automatic patch size aims at: with the full band each patch holds
    /// 72 slots, so 36 patches carry 64 bits at a chip rate of about 40, and a 50 %
    /// crop still leaves about 18 patches.
    pub const TARGET_PATCHES: usize = 36;
    /// Smallest automatic patch size: smaller patches put the mark at higher spatial
    /// frequencies, which MSDM2 charges more.
    pub const MIN_PATCH_SIZE: usize = 1000;

    /// The patch size used for a mesh of `n` vertices: [`Self::patch_size`] when set,
    /// else `max(MIN_PATCH_SIZE, ⌈n / TARGET_PATCHES⌉)` (stanford-bunny.obj: 1,000;
    /// horse.ply: 1,347; igea.ply: 3,732). Embedding and detection compute it from the
    /// original, so they agree.
    pub fn patch_size_for(&self, n: usize) -> usize {
        self.patch_size
            .unwrap_or_else(|| n.div_ceil(Self::TARGET_PATCHES).max(Self::MIN_PATCH_SIZE))
    }

    pub(crate) fn validate(&self) -> Result<(), WatermarkError> {
        if !self.operator.is_combinatorial() {
            return Err(WatermarkError::UnsupportedOperator(self.operator));
        }
        if let Some(p) = self.patch_size.filter(|&p| p < 3) {
            return Err(WatermarkError::InvalidParameter {
                name: "patch_size",
                value: p.to_string(),
                reason: "must be at least 3 vertices",
            });
        }
        if self.band == 0 {
            return Err(WatermarkError::InvalidParameter {
                name: "band",
                value: "0".into(),
                reason: "must be at least 1 eigenvector",
            });
        }
        if self.chip_rate == Some(0) {
            return Err(WatermarkError::InvalidParameter {
                name: "chip_rate",
                value: "0".into(),
                reason: "must be at least 1 (or unset: every slot)",
            });
        }
        Ok(())
    }
}

impl Layout {
    /// The layout of `mesh` (the original) for `bits` bits under `key`.
    pub fn new(
        mesh: &TriMesh,
        topo: &Topology,
        params: &LayoutParams,
        key: u64,
        bits: usize,
    ) -> Result<Self, WatermarkError> {
        params.validate()?;
        let patches = bases(mesh, topo, params)?;
        let slots: usize = patches.iter().map(|p| 3 * p.band()).sum();
        let mut slot_patch = Vec::with_capacity(slots);
        for (p, b) in patches.iter().enumerate() {
            slot_patch.extend(std::iter::repeat_n(p as u32, 3 * b.band()));
        }
        let chip_rate = params.chip_rate.unwrap_or(slots / bits.max(1));
        let needed = bits * chip_rate;
        if chip_rate == 0 || needed > slots {
            return Err(WatermarkError::TooSmall {
                bits,
                chip_rate: chip_rate.max(1),
                needed: needed.max(bits),
                slots,
            });
        }
        Ok(Self {
            patches,
            slots,
            slot_patch,
            chip_rate,
            assigned: key::permutation(key, slots, needed),
            chips: key::chips(key, needed),
        })
    }

    /// The same patches and bases with the slots and chips of another key.
    pub fn rekeyed(&self, key: u64, bits: usize) -> Layout {
        let needed = bits * self.chip_rate;
        Layout {
            patches: self.patches.clone(),
            slots: self.slots,
            slot_patch: self.slot_patch.clone(),
            chip_rate: self.chip_rate,
            assigned: key::permutation(key, self.slots, needed),
            chips: key::chips(key, needed),
        }
    }

    /// Every slot's coefficient `v_kᵀ M x_axis` of the positions `x` (the mesh's
    /// vertex order).
    pub fn coefficients(&self, x: &[[f64; 3]]) -> Vec<f64> {
        let per: Vec<Vec<f64>> = self
            .patches
            .par_iter()
            .map(|p| {
                let mut out = vec![0.0; 3 * p.band()];
                for (l, &g) in p.vertices.iter().enumerate() {
                    let m = p.mass.as_ref().map_or(1.0, |m| m[l]);
                    let xg = x[g as usize];
                    for k in 0..p.band() {
                        let w = m * p.vectors[(l, k)];
                        for a in 0..3 {
                            out[3 * k + a] += w * xg[a];
                        }
                    }
                }
                out
            })
            .collect();
        per.concat()
    }

    /// The displacement `Σ_slots δ_s v_k(s)` along each slot's axis (n×3, the mesh's
    /// vertex order) of per-slot coefficient changes `delta`.
    pub fn synthesize(&self, delta: &[f64], n: usize) -> Vec<[f64; 3]> {
        let mut d = vec![[0.0; 3]; n];
        for p in &self.patches {
            let dp = &delta[p.offset..p.offset + 3 * p.band()];
            for (l, &g) in p.vertices.iter().enumerate() {
                for k in 0..p.band() {
                    let v = p.vectors[(l, k)];
                    for a in 0..3 {
                        d[g as usize][a] += dp[3 * k + a] * v;
                    }
                }
            }
        }
        d
    }
}

/// Every patch's band of eigenvectors (patches in parallel).
fn bases(
    mesh: &TriMesh,
    topo: &Topology,
    params: &LayoutParams,
) -> Result<Vec<PatchBasis>, WatermarkError> {
    let size = params.patch_size_for(mesh.n_vertices());
    let part = partition(topo.graph(), &PartitionOptions::new(size))?;
    let mut patches = (0..part.n_patches())
        .into_par_iter()
        .map(|p| {
            let sub = part.submesh(mesh, p);
            let st = Topology::new(&sub.mesh)?;
            let op =
                Operator::assemble(params.operator, &sub.mesh, &st, &OperatorOptions::default())?;
            let n = sub.vertices.len();
            let count = (params.band + 1).min(n);
            let prob = SymmetricProblem::from_operator(&op, false)?;
            let ps = partial_spectrum(
                &prob.stiffness,
                prob.mass.as_deref(),
                &PartialParams::new(count),
                &mut |_, _| {},
            )?;
            let mass = prob.mass;
            let vectors = ps.eigenvectors.subcols(1, count - 1).to_owned();
            Ok(PatchBasis {
                vertices: sub.vertices,
                vectors,
                mass,
                offset: 0,
            })
        })
        .collect::<Result<Vec<_>, WatermarkError>>()?;
    let mut offset = 0;
    for p in &mut patches {
        p.offset = offset;
        offset += 3 * p.band();
    }
    Ok(patches)
}
