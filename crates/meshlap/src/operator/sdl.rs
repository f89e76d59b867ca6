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
use rayon::prelude::*;

/// Inverse edge lengths, in [`Topology::edges`] order, computed in parallel; a
/// zero-length (or overflowing) edge is an error naming the first such edge.
fn inverse_lengths(mesh: &TriMesh, topo: &Topology) -> Result<Vec<f64>, OperatorError> {
    let inv = |[a, b]: [u32; 2]| {
        let l = norm(sub(mesh.positions[a as usize], mesh.positions[b as usize]));
        (l > 0.0 && l.is_finite() && (1.0 / l).is_finite()).then(|| 1.0 / l)
    };
    let w: Vec<f64> = topo
        .edges()
        .par_iter()
        .with_min_len(8192)
        .map(|&e| inv(e).unwrap_or(f64::NAN))
        .collect();
    match super::first_non_finite(&w) {
        Some(e) => {
            let [a, b] = topo.edges()[e];
            Err(OperatorError::ZeroLengthEdge { a, b, kind: "sdl" })
        }
        None => Ok(w),
    }
}

/// Assembles the scale-dependent Laplacian of `mesh`: n×n, non-symmetric, zero row
/// sums, `F = D − W` with `D = I` and `W_ij = w_ij · (1/Σ_k w_ik)`, `w_ij = 1/‖x_i − x_j‖`
/// (each row scaled by the reciprocal of its sum, computed once per vertex).
pub fn sdl(mesh: &TriMesh, topo: &Topology) -> Result<SparseMatrix, OperatorError> {
    let w = inverse_lengths(mesh, topo)?;
    let sums = super::assemble::vertex_weight_sums(topo, &w);
    // Every weight is finite and positive, so every entry `w_ij · (1/Σ_k w_ik)` (at
    // most 1 in magnitude) is finite once every sum is: a sum that overflows is the
    // one way to a non-finite entry, and it is found here, on n values, instead of
    // on the assembled matrix. (An isolated vertex's zero sum is never used.)
    if let Some(v) = super::first_non_finite(&sums) {
        return Err(OperatorError::NonFinite {
            vertex: v as u32,
            kind: "sdl",
        });
    }
    // One division per vertex, not one per entry.
    let inv_sums: Vec<f64> = sums
        .par_iter()
        .with_min_len(4096)
        .map(|&s| 1.0 / s)
        .collect();
    Ok(super::assemble::one_ring_matrix(
        topo,
        |_| 1.0,
        |i, _, e| -w[e] * inv_sums[i],
    ))
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
