//! The ED-transform of a mesh signal (Zhang 2004 §2.3 eq. (2), §2.6 eq. (4)).
//!
//! A signal is an n×c matrix (column-major faer `Mat`; for geometry the n×3 vertex
//! positions, one column per coordinate). With the basis `E` (n×k) of an operator
//! `F = D − W` (PSD sign convention, eigenvalues ascending):
//!
//! - [`forward`]: the spectral coefficients `X = E⁻¹x` (k×c). For symmetric
//!   operators a projection `X = Eᵀx`; for symmetrizable ones (TL, cotangent with
//!   mass) the S-weighted projection `X_j = g_j·e_jᵀ S x`; on the general path a
//!   dense LU solve `E X = x`.
//! - [`inverse`]: `x = Σ_{j<m} e_j X_j` from the first m rows of the coefficients.
//! - [`truncated`]: the reconstruction `x⁽ᵐ⁾ = e₁X₁ + … + e_mX_m` from the first m
//!   coefficients — the JPEG-like compression of the paper's Fig. 1 and of Karni &
//!   Gotsman (2000). `x⁽ⁿ⁾ = x`.
//!
//! Products run with the basis module's fixed faer parallelism, so coefficients do
//! not depend on the rayon pool size either.

use super::basis::{EigenBasis, EigenPath, PARALLELISM_DEGREE};
use super::SpectralError;
use faer::linalg::matmul::matmul;
use faer::linalg::solvers::Solve;
use faer::{Accum, Mat, MatRef, Par};

fn par() -> Par {
    Par::rayon(PARALLELISM_DEGREE)
}

/// Vertex positions as an n×3 matrix (column c = coordinate c).
pub fn positions_to_mat(positions: &[[f64; 3]]) -> Mat<f64> {
    Mat::from_fn(positions.len(), 3, |i, c| positions[i][c])
}

/// An n×3 matrix back to vertex positions.
pub fn mat_to_positions(x: MatRef<'_, f64>) -> Result<Vec<[f64; 3]>, SpectralError> {
    if x.ncols() != 3 {
        return Err(SpectralError::ShapeMismatch {
            what: "position columns",
            expected: 3,
            got: x.ncols(),
        });
    }
    Ok((0..x.nrows())
        .map(|i| [x[(i, 0)], x[(i, 1)], x[(i, 2)]])
        .collect())
}

/// Spectral coefficients `X = E⁻¹x` of an n×c signal: k×c, row j ↔ eigenvalue j.
/// For a partial (k < n) projection basis, the coefficients of the projection onto
/// its span.
pub fn forward(basis: &EigenBasis, x: MatRef<'_, f64>) -> Result<Mat<f64>, SpectralError> {
    let n = basis.n();
    if x.nrows() != n {
        return Err(SpectralError::ShapeMismatch {
            what: "signal rows",
            expected: n,
            got: x.nrows(),
        });
    }
    if basis.path() == EigenPath::General {
        let lu = basis.lu().ok_or(SpectralError::SingularBasis)?;
        return Ok(lu.solve(x));
    }
    let e = basis.vectors();
    let mut out = Mat::<f64>::zeros(basis.len(), x.ncols());
    match basis.weights() {
        None => matmul(out.as_mut(), Accum::Replace, e.transpose(), x, 1.0, par()),
        Some(s) => {
            let sx = Mat::from_fn(n, x.ncols(), |i, c| s[i] * x[(i, c)]);
            matmul(
                out.as_mut(),
                Accum::Replace,
                e.transpose(),
                sx.as_ref(),
                1.0,
                par(),
            );
        }
    }
    for (j, &g) in basis.coefficient_scale().iter().enumerate() {
        if g != 1.0 {
            for c in 0..out.ncols() {
                out[(j, c)] *= g;
            }
        }
    }
    Ok(out)
}

/// `x = Σ_{j<m} e_j X_j` for the m×c coefficients `coeffs` (m ≤ k; the first m basis
/// vectors are used).
pub fn inverse(basis: &EigenBasis, coeffs: MatRef<'_, f64>) -> Result<Mat<f64>, SpectralError> {
    let m = coeffs.nrows();
    if m > basis.len() {
        return Err(SpectralError::ShapeMismatch {
            what: "coefficient rows",
            expected: basis.len(),
            got: m,
        });
    }
    let mut out = Mat::<f64>::zeros(basis.n(), coeffs.ncols());
    matmul(
        out.as_mut(),
        Accum::Replace,
        basis.vectors().subcols(0, m),
        coeffs,
        1.0,
        par(),
    );
    Ok(out)
}

/// The truncated reconstruction `x⁽ᵐ⁾` from the first `keep` coefficients
/// (1 ≤ keep ≤ k).
pub fn truncated(
    basis: &EigenBasis,
    x: MatRef<'_, f64>,
    keep: usize,
) -> Result<Mat<f64>, SpectralError> {
    if keep == 0 || keep > basis.len() {
        return Err(SpectralError::InvalidArgument(format!(
            "keep must be in 1..={}, got {keep}",
            basis.len()
        )));
    }
    let coeffs = forward(basis, x)?;
    inverse(basis, coeffs.as_ref().subrows(0, keep))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{builtin, topology::Topology, TriMesh};
    use crate::operator::{Operator, OperatorKind, OperatorOptions};
    use crate::spectral::basis::BasisOptions;

    fn basis(m: &TriMesh, kind: OperatorKind, path: EigenPath) -> (Operator, EigenBasis) {
        let t = Topology::new(m).unwrap();
        let op = Operator::assemble(kind, m, &t, &OperatorOptions::default()).unwrap();
        let b = EigenBasis::compute(
            &op,
            &BasisOptions {
                path,
                ..Default::default()
            },
        )
        .unwrap();
        (op, b)
    }

    fn max_diff(a: MatRef<'_, f64>, b: MatRef<'_, f64>) -> f64 {
        let mut w = 0.0f64;
        for j in 0..a.ncols() {
            for i in 0..a.nrows() {
                w = w.max((a[(i, j)] - b[(i, j)]).abs());
            }
        }
        w
    }

    fn irregular() -> TriMesh {
        crate::spectral::test_util::irregular()
    }

    #[test]
    fn keep_n_reproduces_the_mesh() {
        let meshes = [
            builtin::icosphere(2).unwrap(),
            builtin::cube(3).unwrap(),
            builtin::step(5).unwrap(),
        ];
        for m in &meshes {
            let x = positions_to_mat(&m.positions);
            let scale = m.bbox_diagonal();
            for kind in crate::spectral::test_util::REAL_SPECTRUM_KINDS {
                let (_, b) = basis(m, kind, EigenPath::Auto);
                let y = truncated(&b, x.as_ref(), b.len()).unwrap();
                let err = max_diff(x.as_ref(), y.as_ref());
                assert!(err <= 1e-10 * scale, "{kind}: {err}");
            }
            let (_, b) = basis(m, OperatorKind::Tutte, EigenPath::General);
            let y = truncated(&b, x.as_ref(), b.len()).unwrap();
            assert!(max_diff(x.as_ref(), y.as_ref()) <= 1e-10 * scale);
        }
    }

    #[test]
    fn projection_is_idempotent_and_orthogonal() {
        // x⁽ᵐ⁾ of x⁽ᵐ⁾ is x⁽ᵐ⁾; for an orthonormal basis the residual x − x⁽ᵐ⁾ is
        // orthogonal to x⁽ᵐ⁾ (Pythagoras), for the TL S-orthogonal.
        let m = irregular();
        let x = positions_to_mat(&m.positions);
        for kind in [OperatorKind::Sql, OperatorKind::Tutte] {
            let (_, b) = basis(&m, kind, EigenPath::Auto);
            let keep = b.len() / 3;
            let y = truncated(&b, x.as_ref(), keep).unwrap();
            let z = truncated(&b, y.as_ref(), keep).unwrap();
            assert!(max_diff(y.as_ref(), z.as_ref()) < 1e-11);
            let s = b.weights().map(|s| s.to_vec()).unwrap_or(vec![1.0; b.n()]);
            for c in 0..3 {
                let ip: f64 = (0..b.n())
                    .map(|i| s[i] * y[(i, c)] * (x[(i, c)] - y[(i, c)]))
                    .sum();
                assert!(ip.abs() < 1e-10, "{kind}: {ip}");
            }
        }
    }

    #[test]
    fn tl_similarity_and_general_reconstructions_agree() {
        // Truncated reconstructions are basis-independent at cluster boundaries, so
        // the two TL paths must agree there (with clusters: the cube; without: a
        // bumpy torus with irregular valences).
        for m in [irregular(), builtin::cube(2).unwrap()] {
            let x = positions_to_mat(&m.positions);
            let (_, s) = basis(&m, OperatorKind::Tutte, EigenPath::Auto);
            let (_, g) = basis(&m, OperatorKind::Tutte, EigenPath::General);
            assert_eq!(s.clusters(), g.clusters());
            for &(start, k) in s.clusters().iter().step_by(3) {
                let keep = start + k;
                let a = truncated(&s, x.as_ref(), keep).unwrap();
                let b = truncated(&g, x.as_ref(), keep).unwrap();
                assert!(max_diff(a.as_ref(), b.as_ref()) < 1e-9, "keep {keep}");
            }
        }
    }

    #[test]
    fn gsml_reconstructions_are_smooth_gl_ones_are_not() {
        // Paper Fig. 1: x⁽¹⁾ is a point (all vertices at the centroid) for a GSML,
        // because its first eigenvector is constant; the GL's is D^{1/2}·1, so x⁽¹⁾
        // scatters the vertices (the sphere collapses onto a valence-scaled blob).
        let m = builtin::icosphere(2).unwrap();
        // A patch-like mesh with varying valence: the step.
        for m in [m, builtin::step(6).unwrap(), irregular()] {
            let x = positions_to_mat(&m.positions);
            for kind in [
                OperatorKind::Kirchhoff,
                OperatorKind::Tutte,
                OperatorKind::Sql,
                OperatorKind::Sstl,
            ] {
                let (_, b) = basis(&m, kind, EigenPath::Auto);
                let e0 = b.vectors().col(0);
                let spread = e0.iter().fold(0.0f64, |a, v| a.max((v - e0[0]).abs()));
                assert!(spread < 1e-10, "{kind}: lowest eigenvector not constant");
                let y = truncated(&b, x.as_ref(), 1).unwrap();
                for c in 0..3 {
                    for i in 0..b.n() {
                        assert!((y[(i, c)] - y[(0, c)]).abs() < 1e-10);
                    }
                }
            }
            // Off the origin, so that the first coefficient is not zero by symmetry.
            let x = Mat::from_fn(x.nrows(), 3, |i, c| x[(i, c)] + [1.0, 2.0, 3.0][c]);
            let (_, g) = basis(&m, OperatorKind::Graph, EigenPath::Auto);
            let e0 = g.vectors().col(0);
            let spread = e0.iter().fold(0.0f64, |a, v| a.max((v - e0[0]).abs()));
            let has_valence_variation = {
                let t = Topology::new(&m).unwrap();
                let d = t.degrees();
                d.iter().any(|&x| x != d[0])
            };
            if has_valence_variation {
                assert!(spread > 1e-3, "GL lowest eigenvector is constant");
                let y = truncated(&g, x.as_ref(), 1).unwrap();
                let moved = (0..g.n()).any(|i| (y[(i, 0)] - y[(0, 0)]).abs() > 1e-6);
                assert!(moved, "GL x⁽¹⁾ collapsed to a point");
            }
        }
    }

    #[test]
    fn bad_shapes_are_errors() {
        let m = builtin::octahedron();
        let (_, b) = basis(&m, OperatorKind::Kirchhoff, EigenPath::Auto);
        let x = Mat::<f64>::zeros(5, 3);
        assert!(matches!(
            forward(&b, x.as_ref()),
            Err(SpectralError::ShapeMismatch { .. })
        ));
        let x = positions_to_mat(&m.positions);
        assert!(truncated(&b, x.as_ref(), 0).is_err());
        assert!(truncated(&b, x.as_ref(), 7).is_err());
        let c = Mat::<f64>::zeros(7, 3);
        assert!(inverse(&b, c.as_ref()).is_err());
        assert!(mat_to_positions(Mat::<f64>::zeros(2, 2).as_ref()).is_err());
    }
}
