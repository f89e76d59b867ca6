//! Eigen-decomposition of a symmetric 3×3 matrix by cyclic Jacobi rotations (Golub &
//! Van Loan, *Matrix Computations*, §8.5): used for curvature tensors
//! ([`super::msdm2`]) and principal axes. A few sweeps reach machine precision; no
//! allocation.

/// Eigenvalues and unit eigenvectors of the symmetric matrix `a` (only its upper
/// triangle is read): `(values, vectors)` with `vectors[k]` the eigenvector of
/// `values[k]`, sorted by decreasing absolute value.
pub fn sym3_eigen(a: [[f64; 3]; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    let mut m = a;
    for i in 0..3 {
        for j in 0..i {
            m[i][j] = m[j][i];
        }
    }
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _sweep in 0..50 {
        let off = m[0][1].abs() + m[0][2].abs() + m[1][2].abs();
        let scale = m[0][0].abs() + m[1][1].abs() + m[2][2].abs();
        if off <= f64::EPSILON * scale * 1e-3 || off == 0.0 {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if m[p][q] == 0.0 {
                continue;
            }
            let theta = (m[q][q] - m[p][p]) / (2.0 * m[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // m ← Jᵀ m J with the rotation J in the (p, q) plane.
            for k in 0..3 {
                let (mkp, mkq) = (m[k][p], m[k][q]);
                m[k][p] = c * mkp - s * mkq;
                m[k][q] = s * mkp + c * mkq;
            }
            for k in 0..3 {
                let (mpk, mqk) = (m[p][k], m[q][k]);
                m[p][k] = c * mpk - s * mqk;
                m[q][k] = s * mpk + c * mqk;
            }
            for row in &mut v {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    let mut idx = [0, 1, 2];
    idx.sort_by(|&x, &y| m[y][y].abs().total_cmp(&m[x][x].abs()));
    let values = idx.map(|k| m[k][k]);
    let vectors = idx.map(|k| [v[0][k], v[1][k], v[2][k]]);
    (values, vectors)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reconstructs_the_matrix_and_sorts_by_magnitude() {
        let a = [[2.0, -1.0, 0.5], [-1.0, -3.0, 0.25], [0.5, 0.25, 1.0]];
        let (l, v) = sym3_eigen(a);
        assert!(l[0].abs() >= l[1].abs() && l[1].abs() >= l[2].abs());
        for i in 0..3 {
            for j in 0..3 {
                let r: f64 = (0..3).map(|k| l[k] * v[k][i] * v[k][j]).sum();
                assert!((r - a[i][j]).abs() < 1e-12, "{i}{j}");
            }
            let dot: f64 = (0..3).map(|k| v[i][k] * v[(i + 1) % 3][k]).sum();
            assert!(dot.abs() < 1e-12);
        }
        // Trace and a diagonal matrix.
        assert!((l.iter().sum::<f64>() - 0.0).abs() < 1e-12);
        let (l, _) = sym3_eigen([[1.0, 0.0, 0.0], [0.0, -5.0, 0.0], [0.0, 0.0, 2.0]]);
        assert_eq!(l, [-5.0, 2.0, 1.0]);
    }
}
