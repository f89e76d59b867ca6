//! The second-order Tutte Laplacian `T²`, Zhang (2004) §3.8, for comparison with the
//! SSTL `TᵀT`: n×n, **not symmetric**, zero row sums, two-ring pattern, sign convention
//! `F = D − W`; eigenvalues are the squares of the TL's (real, in `[0, 4]`).

use super::{assemble, degrees_checked, OperatorError};
use crate::mesh::{topology::Topology, VertexId};
use crate::SparseMatrix;

/// Assembles `T²`: column j is `Σ_k T_kj · (column k of T)`.
pub fn tutte2(topo: &Topology) -> Result<SparseMatrix, OperatorError> {
    let d = degrees_checked(topo)?;
    Ok(assemble::combine_columns(
        topo.n_vertices(),
        |j, out| {
            out.push((j, 1.0));
            for &k in topo.neighbors(VertexId(j as u32)) {
                out.push((k as usize, -1.0 / d[k as usize]));
            }
        },
        |k, out| assemble::one_ring_column(topo, k, 1.0, |i| -1.0 / d[i], out),
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
