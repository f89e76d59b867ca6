//! The scale-dependent Laplacian (SDL), Fujiwara (1995); Desbrun et al. (1999);
//! used by Zhang (2004) §4.9 as a geometric error measure.
//!
//! Weights `w_ij = 1/‖x_i − x_j‖`, normalised per row: `F = I − W̃` with
//! `W̃_ij = w_ij / Σ_k w_ik`. n×n, **not symmetric**, zero row sums, sign convention
//! `F = D − W` (so `−F·x` is the SDL vector, pointing inwards on a convex surface).
//! Boundary vertices use their one-ring as is.
//!
//! **Degenerate input.** Only edge lengths enter, so zero-area faces and needles are
//! fine; a zero-length edge (coincident endpoints) is
//! [`OperatorError::ZeroLengthEdge`], and an edge so short that its inverse length
//! overflows, or weights whose sum overflows, [`OperatorError::ZeroLengthEdge`] or
//! [`OperatorError::NonFinite`]. An isolated vertex gets the identity row. The result
//! is never NaN or infinite.

use super::geometry::{norm, sub};
use super::OperatorError;
use crate::mesh::{topology::Topology, TriMesh};
use crate::SparseMatrix;

/// Inverse edge lengths, in [`Topology::edges`] order.
fn inverse_lengths(mesh: &TriMesh, topo: &Topology) -> Result<Vec<f64>, OperatorError> {
    topo.edges()
        .iter()
        .map(|&[a, b]| {
            let l = norm(sub(mesh.positions[a as usize], mesh.positions[b as usize]));
            if l > 0.0 && l.is_finite() && (1.0 / l).is_finite() {
                Ok(1.0 / l)
            } else {
                Err(OperatorError::ZeroLengthEdge { a, b, kind: "sdl" })
            }
        })
        .collect()
}

/// Assembles the scale-dependent Laplacian of `mesh`.
pub fn sdl(mesh: &TriMesh, topo: &Topology) -> Result<SparseMatrix, OperatorError> {
    let w = inverse_lengths(mesh, topo)?;
    let sums = super::assemble::vertex_weight_sums(topo, &w);
    let f = super::assemble::one_ring_matrix(topo, |_| 1.0, |i, _, e| -w[e] / sums[i]);
    super::check_finite(&f, None, "sdl")?;
    Ok(f)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;
    use crate::operator::{test_util::*, tutte::tutte};

    #[test]
    fn equals_tutte_when_all_edges_are_equal() {
        let m = builtin::icosahedron();
        let t = topo(&m);
        let diff = &sdl(&m, &t).unwrap().to_dense() - &tutte(&t).unwrap().to_dense();
        assert!(diff.norm_max() < 1e-14);
    }

    #[test]
    fn zero_row_sums() {
        for (name, m) in meshes() {
            assert!(
                max_abs_row_sum(&sdl(&m, &topo(&m)).unwrap()) < 1e-14,
                "{name}"
            );
        }
    }

    #[test]
    fn zero_length_edge_is_an_error() {
        let m = TriMesh::new(vec![[0.0; 3], [0.0; 3], [1.0, 0.0, 0.0]], vec![[0, 1, 2]]);
        assert!(matches!(
            sdl(&m, &topo(&m)),
            Err(OperatorError::ZeroLengthEdge { .. })
        ));
    }
}
