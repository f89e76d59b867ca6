//! Zhang's second-order symmetric Tutte Laplacian (SSTL), Zhang (2004) §3.8.
//!
//! `J = TᵀT` with `T` the Tutte Laplacian: n×n, symmetric, positive semi-definite
//! (`vᵀJv = ‖Tv‖²`), zero row sums (because `T·1 = 0`), sign convention `F = D − W`.
//! Its pattern is the two-ring of each vertex. Boundary vertices need no special case.

use super::{assemble, degree_map_checked, OperatorError};
use crate::mesh::topology::Topology;
use crate::SparseMatrix;

/// Assembles `J = TᵀT` directly from the connectivity: column j of J is
/// `Σ_k T_kj · (row k of T)ᵀ`, with `T_jj = 1` and `T_kj = −1/d_k` for k ∈ N(j), summed
/// in ascending k so that `J_ij` and `J_ji` add the same products `T_ki·T_kj` in the
/// same order: J is symmetric bit for bit. Two-ring pattern filled in place
/// (`assemble::two_ring_matrix`).
pub fn sstl(topo: &Topology) -> Result<SparseMatrix, OperatorError> {
    // −1/d_k once per vertex, not once per product.
    let neg_inv = degree_map_checked(topo, |d| -1.0 / d)?;
    // T_kj = 1 on the diagonal, −1/d_k for k ∈ N(j): row k of T is v[k] = −1/d_k off
    // the diagonal.
    let t_kj = |j: usize, k: usize| if k == j { 1.0 } else { neg_inv[k] };
    Ok(assemble::two_ring_matrix(
        topo,
        assemble::RingOrder::Ascending,
        t_kj,
        |_| 1.0,
        assemble::RingEntries::PerColumn(&neg_inv),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::operator::{test_util::*, tutte::tutte};

    #[test]
    fn equals_dense_tt_product() {
        for (name, m) in meshes() {
            let t = topo(&m);
            let j = sstl(&t).unwrap().to_dense();
            let td = tutte(&t).unwrap().to_dense();
            let want = td.transpose() * &td;
            assert!((&j - &want).norm_max() < 1e-14, "{name}");
        }
    }

    #[test]
    fn zero_row_sums_symmetric_psd() {
        for (name, m) in meshes() {
            let j = sstl(&topo(&m)).unwrap();
            assert!(max_abs_row_sum(&j) < 1e-14, "{name}");
            assert!(asymmetry(&j) == 0.0, "{name}");
            let ev = j
                .to_dense()
                .self_adjoint_eigenvalues(faer::Side::Lower)
                .unwrap();
            assert!(ev[0] > -1e-12 && ev[1] > 1e-9, "{name}: {:?}", &ev[..2]);
        }
    }
}
