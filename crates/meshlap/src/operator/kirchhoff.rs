//! The Kirchhoff operator (combinatorial graph Laplacian), Zhang (2004) §3.
//!
//! `K = diag(d) − A`: n×n, symmetric, `K_ii = d_i`, `K_ij = −1` for each edge (i, j).
//! Positive semi-definite (sign convention of the crate: `F = D − W`), zero row sums,
//! eigenvalues in `[0, 2·d_max]` (Gershgorin); the multiplicity of the eigenvalue 0 is
//! the number of connected components. Boundary vertices need no special handling.

use crate::mesh::topology::Topology;
use crate::SparseMatrix;

/// Assembles the Kirchhoff operator `K = diag(d) − A` of `topo`.
pub fn kirchhoff(topo: &Topology) -> SparseMatrix {
    let degrees = topo.degrees();
    super::assemble::one_ring_matrix(topo, |i| degrees[i] as f64, |_, _, _| -1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;
    use crate::operator::test_util::*;
    use faer::Side;

    fn spectrum(m: &crate::TriMesh) -> Vec<f64> {
        kirchhoff(&topo(m))
            .to_dense()
            .self_adjoint_eigenvalues(Side::Lower)
            .unwrap()
    }

    fn assert_spectrum(got: Vec<f64>, want: &[f64]) {
        assert_eq!(got.len(), want.len());
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() < 1e-12, "{got:?} vs {want:?}");
        }
    }

    #[test]
    fn closed_form_platonic_spectra() {
        assert_spectrum(spectrum(&builtin::tetrahedron()), &[0.0, 4.0, 4.0, 4.0]);
        assert_spectrum(
            spectrum(&builtin::octahedron()),
            &[0.0, 4.0, 4.0, 4.0, 6.0, 6.0],
        );
        let (a, b) = (5.0 - 5f64.sqrt(), 5.0 + 5f64.sqrt());
        assert_spectrum(
            spectrum(&builtin::icosahedron()),
            &[0.0, a, a, a, 6.0, 6.0, 6.0, 6.0, 6.0, b, b, b],
        );
    }

    #[test]
    fn zero_row_sums_and_symmetry() {
        for (name, m) in meshes() {
            let k = kirchhoff(&topo(&m));
            assert!(max_abs_row_sum(&k) == 0.0, "{name}");
            assert!(asymmetry(&k) == 0.0, "{name}");
        }
    }
}
