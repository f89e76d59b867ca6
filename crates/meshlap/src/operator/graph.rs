//! The normalized graph Laplacian (GL), Chung (1997); Zhang (2004) §3.
//!
//! `G = I − D^{-1/2} A D^{-1/2}`: n×n, symmetric, `G_ij = −1/√(d_i d_j)` for each edge,
//! positive semi-definite (sign convention `F = D − W`), eigenvalues in `[0, 2]`. Its row
//! sums are **not** zero on irregular meshes and its null vector is `D^{1/2}·1`, not
//! constant — which is why it is not a GSML and its truncated spectral reconstructions
//! are not smooth (the paper's Fig. 1).

use super::{degree_map_checked, OperatorError};
use crate::mesh::topology::Topology;
use crate::SparseMatrix;

/// Assembles the normalized graph Laplacian of `topo`.
pub fn graph(topo: &Topology) -> Result<SparseMatrix, OperatorError> {
    let s = degree_map_checked(topo, |d| 1.0 / d.sqrt())?;
    Ok(super::assemble::one_ring_matrix(
        topo,
        |_| 1.0,
        |i, j, _| -s[i] * s[j],
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::operator::test_util::*;

    #[test]
    fn symmetric_with_sqrt_degree_null_vector() {
        for (name, m) in meshes() {
            let t = topo(&m);
            let g = graph(&t).unwrap();
            assert!(asymmetry(&g) == 0.0, "{name}");
            let d = t.degrees();
            let x = faer::Col::<f64>::from_fn(d.len(), |i| (d[i] as f64).sqrt());
            let y = &g * &x;
            assert!(y.norm_max() < 1e-13, "{name}");
        }
    }

    #[test]
    fn row_sums_are_not_zero_on_irregular_meshes() {
        let m = crate::mesh::builtin::cube(3).unwrap();
        assert!(max_abs_row_sum(&graph(&topo(&m)).unwrap()) > 1e-3);
    }
}
