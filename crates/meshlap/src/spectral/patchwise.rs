//! Truncated ED reconstruction of a partitioned mesh, patch by patch (Zhang 2004 §4.9
//! and Fig. 1; Karni & Gotsman 2000). Sign convention of every operator: `F = D − W`,
//! positive semi-definite.

use crate::mesh::topology::Topology;
use crate::mesh::{MeshError, TriMesh};
use crate::operator::OperatorError;
use crate::partition::Partition;
use crate::spectral::SpectralError;

/// Why [`patchwise_positions`] failed; every cause is kept as the source.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PatchwiseError {
    /// The fraction of coefficients to keep is not in (0, 1].
    ///
    /// Fix: pass `m / n` for `1 ≤ m ≤ n` (a `Keep` resolved against the mesh).
    #[error("keep fraction must be in (0, 1], got {0}")]
    KeepFraction(f64),
    /// A patch's submesh has no valid connectivity.
    ///
    /// Cause: a degenerate patch of a mesh that was not cleaned. Fix: clean the mesh
    /// (`crate::input::open` does) before partitioning it.
    #[error("patch {patch}: cannot build its connectivity")]
    Topology {
        /// The patch.
        patch: usize,
        /// Why.
        #[source]
        source: MeshError,
    },
    /// The operator cannot be assembled on a patch.
    ///
    /// Cause: e.g. the SQL on a patch with a non-manifold edge. Fix: split the mesh
    /// (`meshlap clean --split-nonmanifold`) or choose another kind.
    #[error("patch {patch}: cannot assemble the operator")]
    Operator {
        /// The patch.
        patch: usize,
        /// Why.
        #[source]
        source: OperatorError,
    },
    /// A patch's spectrum cannot be computed.
    ///
    /// Cause: a kind that is neither symmetric nor diagonally symmetrizable
    /// ([`SpectralError::NoRealSpectrum`], e.g. the mean-value operator), or an
    /// invalid mass. Fix: use a symmetric or symmetrizable kind.
    #[error("patch {patch}: cannot compute its spectrum")]
    Spectral {
        /// The patch.
        patch: usize,
        /// Why.
        #[source]
        source: SpectralError,
    },
}

/// Truncated ED reconstruction patch by patch (the JPEG-like transform of Zhang 2004
/// Fig. 1 on a partitioned mesh, after Karni & Gotsman 2000): every patch's
/// [`Submesh`](crate::partition::Submesh) gets its own operator `kind` (sign convention `F = D − W`), its full
/// spectrum (dense, through [`crate::spectral::partial`]: symmetric kinds directly,
/// the TL and other diagonally symmetrizable kinds through `K = SF`, `M = S`), and its
/// coordinates x (n_p×3) are projected as `X = VᵀM x` on the `M`-orthonormal
/// eigenvectors `V` and rebuilt from the first `m_p = ⌈keep_fraction · n_p⌉`
/// coefficients, `x⁽ᵐ⁾ = V_m X_m`. Patches run in parallel (rayon); each vertex is
/// rebuilt by its own patch only. `keep_fraction` in (0, 1]; 1 reproduces the mesh.
/// `progress(done, total)` is called as patches finish.
///
/// # Errors
/// [`PatchwiseError`]: a keep fraction outside (0, 1], or the first patch (in patch
/// order) whose connectivity, operator or spectrum fails, with the cause as source.
pub fn patchwise_positions(
    mesh: &TriMesh,
    part: &Partition,
    kind: crate::operator::OperatorKind,
    keep_fraction: f64,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Vec<[f64; 3]>, PatchwiseError> {
    use crate::operator::{Operator, OperatorOptions};
    use crate::spectral::partial::{partial_spectrum, PartialParams, SymmetricProblem};
    use rayon::prelude::*;
    if !(keep_fraction > 0.0 && keep_fraction <= 1.0) {
        return Err(PatchwiseError::KeepFraction(keep_fraction));
    }
    let total = part.n_patches();
    let done = std::sync::atomic::AtomicUsize::new(0);
    type PatchResult = Result<(Vec<u32>, Vec<[f64; 3]>), PatchwiseError>;
    let patches: Vec<PatchResult> = (0..total)
        .into_par_iter()
        .map(|p| {
            let sub = part.submesh(mesh, p);
            let topo = Topology::new(&sub.mesh)
                .map_err(|source| PatchwiseError::Topology { patch: p, source })?;
            let op = Operator::assemble(kind, &sub.mesh, &topo, &OperatorOptions::default())
                .map_err(|source| PatchwiseError::Operator { patch: p, source })?;
            let spectral = |source| PatchwiseError::Spectral { patch: p, source };
            let prob = SymmetricProblem::from_operator(&op, true).map_err(spectral)?;
            let n = sub.vertices.len();
            let m = ((keep_fraction * n as f64).ceil() as usize).clamp(1, n);
            let opts = PartialParams {
                dense_below: usize::MAX,
                ..PartialParams::new(m)
            };
            let ps = partial_spectrum(&prob.stiffness, prob.mass.as_deref(), &opts, &mut |_, _| {})
                .map_err(spectral)?;
            let mass = |i: usize| prob.mass.as_ref().map_or(1.0, |w| w[i]);
            let v = &ps.eigenvectors;
            let mut out = vec![[0.0f64; 3]; n];
            for j in 0..m {
                let mut x = [0.0f64; 3];
                for i in 0..n {
                    let w = v[(i, j)] * mass(i);
                    for c in 0..3 {
                        x[c] += w * sub.mesh.positions[i][c];
                    }
                }
                for i in 0..n {
                    for c in 0..3 {
                        out[i][c] += v[(i, j)] * x[c];
                    }
                }
            }
            let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            progress(d, total);
            Ok((sub.vertices, out))
        })
        .collect();
    let mut positions = mesh.positions.clone();
    for r in patches {
        let (verts, local) = r?;
        for (l, &g) in verts.iter().enumerate() {
            positions[g as usize] = local[l];
        }
    }
    Ok(positions)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;
    use crate::partition::{partition, PartitionOptions};

    #[test]
    fn patchwise_positions_are_exact_at_full_keep_and_smooth_below() {
        use crate::operator::OperatorKind;
        let mesh = builtin::step(14).unwrap();
        let topo = Topology::new(&mesh).unwrap();
        let part = partition(&topo, &PartitionOptions::new(40)).unwrap();
        for kind in [
            OperatorKind::Sql,
            OperatorKind::Tutte,
            OperatorKind::Kirchhoff,
        ] {
            let full = patchwise_positions(&mesh, &part, kind, 1.0, &|_, _| {}).unwrap();
            let err = full
                .iter()
                .zip(&mesh.positions)
                .map(|(a, b)| (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0, f64::max))
                .fold(0.0, f64::max);
            assert!(err < 1e-10, "{kind}: {err}");
            // One coefficient per patch: each patch collapses to a constant for the
            // GSMLs (zero row sums: the lowest eigenvector is constant) — its centroid
            // for the KL/SQL, its degree-weighted centroid for the TL.
            let low = patchwise_positions(&mesh, &part, kind, 1e-9, &|_, _| {}).unwrap();
            for p in 0..part.n_patches() {
                let vs = part.patch_vertices(p);
                let first = low[vs[0] as usize];
                for &v in vs {
                    for c in 0..3 {
                        assert!((low[v as usize][c] - first[c]).abs() < 1e-9, "{kind}");
                    }
                }
                if kind != OperatorKind::Tutte {
                    for c in 0..3 {
                        let mean = vs
                            .iter()
                            .map(|&v| mesh.positions[v as usize][c])
                            .sum::<f64>()
                            / vs.len() as f64;
                        assert!((first[c] - mean).abs() < 1e-9);
                    }
                }
            }
        }
        assert!(matches!(
            patchwise_positions(&mesh, &part, OperatorKind::Sql, 0.0, &|_, _| {}),
            Err(PatchwiseError::KeepFraction(_))
        ));
    }
}
