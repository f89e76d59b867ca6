//! The second-order Tutte Laplacian `T²`, Zhang (2004) §3.8, for comparison with the
//! SSTL `TᵀT`: n×n, **not symmetric**, zero row sums, two-ring pattern, sign convention
//! `F = D − W`; eigenvalues are the squares of the TL's (real, in `[0, 4]`).

use super::{assemble, degree_map_checked, OperatorError};
use crate::mesh::topology::Topology;
use crate::SparseMatrix;

/// Assembles `T²`: column j is `Σ_k T_kj · (column k of T)` over k = j, then the
/// neighbours of j ascending, with `T_kk = 1`, `T_ik = −1/d_i` for i ∈ N(k). Two-ring
/// pattern filled in place (`assemble::two_ring_matrix`).
pub fn tutte2(topo: &Topology) -> Result<SparseMatrix, OperatorError> {
    // −1/d_i once per vertex, not once per product.
    let neg_inv = degree_map_checked(topo, |d| -1.0 / d)?;
    let t = |i: usize, k: usize| if i == k { 1.0 } else { neg_inv[i] };
    // Column k of T: 1 on the diagonal, T_ik = −1/d_i at its rows i ∈ N(k).
    Ok(assemble::two_ring_matrix(
        topo,
        assemble::RingOrder::DiagonalFirst,
        |j, k| t(k, j),
        |_| 1.0,
        assemble::RingEntries::PerRow(&neg_inv),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::operator::{test_util::*, tutte::tutte};

    #[test]
    fn equals_dense_square() {
        for (name, m) in meshes() {
            let t = topo(&m);
            let t2 = tutte2(&t).unwrap().to_dense();
            let td = tutte(&t).unwrap().to_dense();
            assert!((&t2 - &td * &td).norm_max() < 1e-14, "{name}");
            assert!(max_abs_row_sum(&tutte2(&t).unwrap()) < 1e-14, "{name}");
        }
    }
}
