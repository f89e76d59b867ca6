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
/// [`Submesh`](crate::partition::Submesh) gets its own operator `kind` (sign convention
/// `F = D − W`) as a symmetric problem `K v = λ M v` (symmetric kinds directly, the
/// TL and other diagonally symmetrizable kinds through `K = SF`, `M = S`), and its
/// coordinates x (n_p×3) are projected as `X = VᵀM x` on the `M`-orthonormal
/// eigenvectors `V` and rebuilt from the first `m_p = ⌈keep_fraction · n_p⌉`
/// coefficients, `x⁽ᵐ⁾ = V_m X_m`. Patches run in parallel (rayon); each vertex is
/// rebuilt by its own patch only. `keep_fraction` in (0, 1]; 1 reproduces the mesh.
/// `progress(done, total)` is called as patches finish.
///
/// Only the projection is formed, never the eigenvectors (see `lowest_projection`):
/// with `A = M^{-1/2} K M^{-1/2} = Q T Qᵀ` (faer's blocked Householder
/// tridiagonalisation, 4n³/3 flops) and `Z_m` the lowest m eigenvectors of T,
/// `x⁽ᵐ⁾ = M^{-1/2} Q Z_m Z_mᵀ Qᵀ M^{1/2} x`. This is the same projection as the
/// eigenvector route (the span of the m lowest eigenvectors; the crate's sign and
/// cluster rule only rotates inside it) up to rounding (tested to 1e-12 against it),
/// but not bit-reproducible across CPUs: faer's kernels depend on the instruction
/// set. The codec, which needs bits, uses [`crate::spectral::dense_evd`] instead.
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
    use crate::operator::symmetrize::{symmetrized_dense, Scaling};
    use crate::operator::{Operator, OperatorOptions};
    use crate::spectral::partial::{check_mass, SymmetricProblem};
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
            if let Some(index) = prob.stiffness.val().iter().position(|v| !v.is_finite()) {
                return Err(spectral(SpectralError::NonFinite { index }));
            }
            let a = match prob.mass.as_deref() {
                Some(w) => {
                    check_mass(w, n).map_err(spectral)?;
                    symmetrized_dense(&prob.stiffness, Scaling::Congruence(w))
                }
                None => symmetrized_dense(&prob.stiffness, Scaling::None),
            };
            // y = M^{1/2} x, projected, then x⁽ᵐ⁾ = M^{-1/2} y⁽ᵐ⁾.
            let root = |i: usize| prob.mass.as_ref().map_or(1.0, |w| w[i].sqrt());
            let y = faer::Mat::from_fn(n, 3, |i, c| sub.mesh.positions[i][c] * root(i));
            let y = lowest_projection(a, m, y).ok_or(spectral(SpectralError::NoConvergence {
                path: "patch-wise tridiagonal QL",
            }))?;
            let out: Vec<[f64; 3]> = (0..n)
                .map(|i| std::array::from_fn(|c| y[(i, c)] / root(i)))
                .collect();
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

/// `Q Z_m Z_mᵀ Qᵀ y`: the orthogonal projection of `y` (n×k) onto the span of the
/// eigenvectors of the `m` smallest eigenvalues of the dense symmetric `a` (n×n,
/// consumed), computed as `A = Q T Qᵀ` (faer's `tridiag_in_place`, sequential),
/// T's lowest m eigenvalues and eigenvectors `Z_m` by bisection (or QL) and inverse
/// iteration ([`crate::spectral::dense_evd`]'s steps 3–4), and `Qᵀ`, `Q` applied to y's k
/// columns only: O(4n³/3 + 4n²k + 2nmk) flops, without forming any eigenvector of
/// `a`. `a` is first scaled by an exact power of two so its largest entry is in
/// [1, 2), as `dense_evd` does. `None` if an entry is not finite or the QL iteration
/// does not converge.
fn lowest_projection(
    mut a: faer::Mat<f64>,
    m: usize,
    mut y: faer::Mat<f64>,
) -> Option<faer::Mat<f64>> {
    use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
    use faer::linalg::evd::tridiag::{tridiag_in_place, tridiag_in_place_scratch};
    use faer::linalg::householder::{
        apply_block_householder_sequence_on_the_left_in_place_scratch as q_req,
        apply_block_householder_sequence_on_the_left_in_place_with_conj as apply_q,
        apply_block_householder_sequence_transpose_on_the_left_in_place_with_conj as apply_qt,
    };
    use faer::linalg::matmul::matmul;
    use faer::{Accum, Conj, Par};
    let n = a.nrows();
    let k = y.ncols();
    let m = m.min(n);
    let mut amax = 0.0f64;
    for j in 0..n {
        for i in 0..n {
            let x = a[(i, j)];
            if !x.is_finite() {
                return None;
            }
            amax = amax.max(x.abs());
        }
    }
    if n == 0 || m == n {
        return Some(y);
    }
    if amax == 0.0 {
        // A = 0: every vector is an eigenvector; the basis is the identity's columns.
        for i in m..n {
            for c in 0..k {
                y[(i, c)] = 0.0;
            }
        }
        return Some(y);
    }
    let (scale, _) = crate::spectral::dense_evd::power_of_two_scaling(amax);
    for j in 0..n {
        for i in 0..n {
            a[(i, j)] *= scale;
        }
    }
    let bs = faer::linalg::qr::no_pivoting::factor::recommended_block_size::<f64>(n, n);
    let mut h = faer::Mat::<f64>::zeros(bs, n - 1);
    let mut buf = MemBuffer::new(StackReq::any_of(&[
        tridiag_in_place_scratch::<f64>(n, Par::Seq, Default::default()),
        q_req::<f64>(n - 1, bs, k),
    ]));
    let stack = MemStack::new(&mut buf);
    tridiag_in_place(a.as_mut(), h.as_mut(), Par::Seq, stack, Default::default());
    let d: Vec<f64> = (0..n).map(|i| a[(i, i)]).collect();
    let e: Vec<f64> = (0..n - 1).map(|i| a[(i + 1, i)]).collect();
    let (_, z) = crate::spectral::dense_evd::tridiagonal_lowest(&d, &e, m)?;
    let basis = a.as_ref().submatrix(1, 0, n - 1, n - 1);
    apply_qt(
        basis,
        h.as_ref(),
        Conj::No,
        y.as_mut().subrows_mut(1, n - 1),
        Par::Seq,
        stack,
    );
    // g = Z_mᵀ y (m×k), then y = Z_m g.
    let z = faer::MatRef::from_row_major_slice(&z, n, m);
    let mut g = faer::Mat::<f64>::zeros(m, k);
    matmul(
        g.as_mut(),
        Accum::Replace,
        z.transpose(),
        y.as_ref(),
        1.0,
        Par::Seq,
    );
    matmul(y.as_mut(), Accum::Replace, z, g.as_ref(), 1.0, Par::Seq);
    apply_q(
        basis,
        h.as_ref(),
        Conj::No,
        y.as_mut().subrows_mut(1, n - 1),
        Par::Seq,
        stack,
    );
    let finite = (0..k).all(|c| (0..n).all(|i| y[(i, c)].is_finite()));
    finite.then_some(y)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;
    use crate::partition::{partition, PartitionOptions};

    /// The eigenvector route [`patchwise_positions`] took before it formed only the
    /// projection: every patch's lowest m eigenvectors from
    /// [`crate::spectral::partial::partial_spectrum`] on its dense path (canonical
    /// signs and cluster rotations), then `X = VᵀM x` and `V_m X_m`. Also returns,
    /// per vertex, whether its patch's cut is well defined: `λ_{m+1} − λ_m` above
    /// 1e-6 (the SQL/TL/GL spectra here are O(1)). Where an eigenvalue cluster
    /// straddles the cut, the projection is onto an arbitrary part of the cluster's
    /// eigenspace on either route (the step mesh's TL patches have λ = 1.5 several
    /// times over), so only well-defined cuts are comparable.
    fn eigenvector_route(
        mesh: &TriMesh,
        part: &Partition,
        kind: crate::operator::OperatorKind,
        keep_fraction: f64,
    ) -> (Vec<[f64; 3]>, Vec<bool>) {
        use crate::operator::{Operator, OperatorOptions};
        use crate::spectral::partial::{partial_spectrum, PartialParams, SymmetricProblem};
        let mut positions = mesh.positions.clone();
        let mut defined = vec![true; positions.len()];
        for p in 0..part.n_patches() {
            let sub = part.submesh(mesh, p);
            let topo = Topology::new(&sub.mesh).unwrap();
            let op =
                Operator::assemble(kind, &sub.mesh, &topo, &OperatorOptions::default()).unwrap();
            let prob = SymmetricProblem::from_operator(&op, true).unwrap();
            let n = sub.vertices.len();
            let m = ((keep_fraction * n as f64).ceil() as usize).clamp(1, n);
            let opts = PartialParams {
                dense_below: usize::MAX,
                ..PartialParams::new(m)
            };
            let ps = partial_spectrum(&prob.stiffness, prob.mass.as_deref(), &opts, &mut |_, _| {})
                .unwrap();
            let full = PartialParams {
                dense_below: usize::MAX,
                ..PartialParams::new(n)
            };
            let lam =
                partial_spectrum(&prob.stiffness, prob.mass.as_deref(), &full, &mut |_, _| {})
                    .unwrap()
                    .eigenvalues;
            let gap_ok = m == n || lam[m] - lam[m - 1] > 1e-6;
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
            for (l, &g) in sub.vertices.iter().enumerate() {
                positions[g as usize] = out[l];
                defined[g as usize] = gap_ok;
            }
        }
        (positions, defined)
    }

    #[test]
    fn projection_matches_the_eigenvector_route() {
        use crate::operator::OperatorKind;
        // Closed (icosphere, torus) and with boundary (step, grid); patch sizes from
        // tens to a few hundred; keep fractions from one coefficient to all.
        for (name, mesh, p) in [
            ("icosphere:4", builtin::icosphere(4).unwrap(), 300),
            ("torus", builtin::torus(40, 24).unwrap(), 120),
            ("step", builtin::step(16).unwrap(), 60),
            ("grid", builtin::grid(30).unwrap(), 200),
        ] {
            let topo = Topology::new(&mesh).unwrap();
            let part = partition(topo.graph(), &PartitionOptions::new(p)).unwrap();
            let scale = mesh.bbox_diagonal();
            for kind in [OperatorKind::Sql, OperatorKind::Tutte, OperatorKind::Graph] {
                for keep in [1e-9, 0.05, 0.1, 0.37, 0.9, 1.0] {
                    let new = patchwise_positions(&mesh, &part, kind, keep, &|_, _| {}).unwrap();
                    let (old, defined) = eigenvector_route(&mesh, &part, kind, keep);
                    let compared = defined.iter().filter(|&&d| d).count();
                    assert!(
                        compared * 10 >= 7 * defined.len(),
                        "{name} {kind} keep {keep}: only {compared} of {} vertices comparable",
                        defined.len()
                    );
                    let err = new
                        .iter()
                        .zip(&old)
                        .zip(&defined)
                        .filter(|(_, &d)| d)
                        .map(|((a, b), _)| (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0, f64::max))
                        .fold(0.0, f64::max);
                    assert!(err < 1e-12 * scale, "{name} {kind} keep {keep}: {err:e}");
                }
            }
        }
    }

    #[test]
    fn patchwise_positions_are_exact_at_full_keep_and_smooth_below() {
        use crate::operator::OperatorKind;
        let mesh = builtin::step(14).unwrap();
        let topo = Topology::new(&mesh).unwrap();
        let part = partition(topo.graph(), &PartitionOptions::new(40)).unwrap();
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
