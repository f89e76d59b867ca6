//! Spectral projection of the geometry: keep the first m ED-transform coefficients of
//! the vertex positions and reconstruct (Zhang 2004 §2.3, Fig. 1; Karni & Gotsman
//! 2000), whole-mesh or patch by patch.
//!
//! **Sign convention.** Operators are `F = D − W`, positive semi-definite (libigl and
//! pmp use the negative), so the first coefficients are the lowest frequencies and
//! `x⁽ᵐ⁾ = e₁X₁ + … + e_mX_m` gets smoother as m shrinks for a GSML (KL, TL, SQL,
//! SSTL); with the GL it does not (its lowest eigenvector is not constant), as the
//! paper's Fig. 1 shows.
//!
//! Whole-mesh projection uses the dense eigenbasis (n ≤ [`super::DENSE_LIMIT`]);
//! with a patch size the mesh is split into METIS patches ([`crate::partition`]) and
//! each keeps the same fraction m/n of its coefficients
//! ([`super::patchwise::patchwise_positions`]), in parallel, at any n.

use super::basis::{BasisOptions, EigenBasis, EigenPath};
use super::compaction::energy_compaction;
use super::transform::{forward, inverse, mat_to_positions, positions_to_mat};
use crate::mesh::{topology::Topology, TriMesh};
use crate::metric::{vertex_errors, VertexErrors};
use crate::operator::{Operator, OperatorKind, OperatorOptions};
use crate::partition::{partition_mesh, PartitionOptions, PartitionStats};
use serde::Serialize;
use std::str::FromStr;

/// How many coefficients to keep: a count m or a percentage of n.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Keep {
    /// m coefficients, `1 ≤ m ≤ n`.
    Count(usize),
    /// A percentage `p ∈ (0, 100]` of n, rounded, at least 1.
    Percent(f64),
}

/// A `--keep` value that is neither a count nor a percentage in range.
#[derive(Debug, thiserror::Error)]
#[error(
    "keep must be a count in {} or a percentage in (0, 100] such as 10%, got `{given}`",
    count_range(*.n)
)]
pub struct KeepError {
    /// The text or value given.
    pub given: String,
    /// The vertex count it was checked against (0 when parsed without a mesh).
    pub n: usize,
}

/// `1..=n`, or `1..` when parsed without a mesh (`n = 0`).
fn count_range(n: usize) -> String {
    if n == 0 {
        "1..".into()
    } else {
        format!("1..={n}")
    }
}

impl FromStr for Keep {
    type Err = KeepError;
    /// `m` or `P%`.
    fn from_str(s: &str) -> Result<Self, KeepError> {
        let bad = || KeepError {
            given: s.to_string(),
            n: 0,
        };
        match s.trim().strip_suffix('%') {
            Some(p) => Ok(Keep::Percent(p.trim().parse().map_err(|_| bad())?)),
            None => Ok(Keep::Count(s.trim().parse().map_err(|_| bad())?)),
        }
    }
}

impl Keep {
    /// The count m for n vertices.
    pub fn resolve(self, n: usize) -> Result<usize, KeepError> {
        let m = match self {
            Keep::Count(m) => m,
            Keep::Percent(p) if p > 0.0 && p <= 100.0 => {
                ((p / 100.0 * n as f64).round() as usize).max(1)
            }
            Keep::Percent(_) => 0,
        };
        if m == 0 || m > n {
            let given = match self {
                Keep::Count(m) => m.to_string(),
                Keep::Percent(p) => format!("{p}%"),
            };
            return Err(KeepError { given, n });
        }
        Ok(m)
    }
}

/// Parameters of [`project`].
#[derive(Clone, Copy, Debug, Default)]
pub struct ProjectParams {
    /// Operator options (SQL diagonal, cotangent mass).
    pub operator: OperatorOptions,
    /// Dense eigenbasis options (whole-mesh path).
    pub basis: BasisOptions,
    /// Patch-wise transform with patches of about this many vertices.
    pub patch_size: Option<usize>,
}

/// What [`project`] reports.
#[derive(Clone, Debug, Serialize)]
pub struct ProjectionInfo {
    /// Coefficients kept (whole mesh) or the equivalent count m for the fraction.
    pub keep: usize,
    /// m/n, the fraction of each patch's coefficients kept.
    pub keep_fraction: f64,
    /// The eigensolver path (whole-mesh only).
    pub path: Option<EigenPath>,
    /// Fraction of the coefficient energy in the kept coefficients (whole-mesh only).
    pub energy_kept: Option<f64>,
    /// The partition (patch-wise only).
    pub partition: Option<PartitionStats>,
    /// `‖x − x⁽ᵐ⁾‖_F / ‖x‖_F`, and the RMS and max vertex displacement ÷ the
    /// bounding-box diagonal.
    pub errors: VertexErrors,
}

/// The reconstruction and its report.
#[derive(Clone, Debug)]
pub struct Projection {
    /// n reconstructed positions, in the input's vertex order.
    pub positions: Vec<[f64; 3]>,
    /// The report.
    pub info: ProjectionInfo,
}

/// Projects `mesh` (n vertices, its `topo`) onto the first `keep` eigenvectors of the
/// `kind` operator (or the same fraction per patch); see the module documentation.
/// `progress(done, total)` reports patches (patch-wise) or is called once.
pub fn project(
    mesh: &TriMesh,
    topo: &Topology,
    kind: OperatorKind,
    keep: Keep,
    params: &ProjectParams,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> crate::Result<Projection> {
    let n = mesh.n_vertices();
    let m = keep.resolve(n).map_err(super::SpectralError::from)?;
    let diag = mesh.bbox_diagonal();
    if let Some(p) = params.patch_size {
        let part = partition_mesh(mesh, topo, &PartitionOptions::new(p))?;
        let fraction = m as f64 / n as f64;
        let positions =
            super::patchwise::patchwise_positions(mesh, &part, kind, fraction, progress)?;
        let errors = vertex_errors(&mesh.positions, &positions, diag);
        return Ok(Projection {
            positions,
            info: ProjectionInfo {
                keep: m,
                keep_fraction: fraction,
                path: None,
                energy_kept: None,
                partition: Some(part.stats().clone()),
                errors,
            },
        });
    }
    let op = Operator::assemble(kind, mesh, topo, &params.operator)?;
    let basis = EigenBasis::compute(&op, &params.basis)?;
    let x = positions_to_mat(&mesh.positions);
    let coeffs = forward(&basis, x.as_ref())?;
    let y = inverse(&basis, coeffs.as_ref().subrows(0, m))?;
    let positions = mat_to_positions(y.as_ref())?;
    progress(1, 1);
    let errors = vertex_errors(&mesh.positions, &positions, diag);
    Ok(Projection {
        positions,
        info: ProjectionInfo {
            keep: m,
            keep_fraction: m as f64 / n as f64,
            path: Some(basis.path()),
            energy_kept: Some(energy_compaction(coeffs.as_ref()).total[m - 1]),
            partition: None,
            errors,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;

    #[test]
    fn keep_parses_and_resolves() {
        assert_eq!("10".parse::<Keep>().unwrap(), Keep::Count(10));
        assert_eq!(" 25% ".parse::<Keep>().unwrap(), Keep::Percent(25.0));
        assert!("x%".parse::<Keep>().is_err());
        assert_eq!(Keep::Percent(25.0).resolve(42).unwrap(), 11);
        assert_eq!(Keep::Percent(0.1).resolve(42).unwrap(), 1);
        assert!(Keep::Percent(0.0).resolve(42).is_err());
        assert!(Keep::Count(43).resolve(42).is_err());
        assert!(Keep::Count(0).resolve(42).is_err());
    }

    /// Keeping every coefficient reproduces the mesh on both paths; keeping one
    /// coefficient of a GSML collapses each patch (or the mesh) to its centroid.
    #[test]
    fn full_and_single_coefficient_projections() {
        let mesh = builtin::icosphere(2).unwrap();
        let topo = Topology::new(&mesh).unwrap();
        let none = |_: usize, _: usize| {};
        for patch_size in [None, Some(40)] {
            let params = ProjectParams {
                patch_size,
                ..Default::default()
            };
            let all = project(
                &mesh,
                &topo,
                OperatorKind::Kirchhoff,
                Keep::Count(162),
                &params,
                &none,
            )
            .unwrap();
            assert!(
                all.info.errors.max < 1e-10,
                "{patch_size:?}: {:?}",
                all.info.errors
            );
            assert_eq!(all.info.path.is_some(), patch_size.is_none());
        }
        let one = project(
            &mesh,
            &topo,
            OperatorKind::Kirchhoff,
            Keep::Count(1),
            &ProjectParams::default(),
            &none,
        )
        .unwrap();
        let c = one.positions[0];
        assert!(one
            .positions
            .iter()
            .all(|p| (0..3).all(|k| (p[k] - c[k]).abs() < 1e-12)));
        assert!((one.info.errors.relative - 1.0).abs() < 1e-9);
    }
}
