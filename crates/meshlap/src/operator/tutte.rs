//! The Tutte Laplacian (TL, the uniform or "umbrella" operator), Zhang (2004) §3;
//! Taubin (1995); Karni & Gotsman (2000).
//!
//! `T = I − D⁻¹A = D⁻¹K`: n×n, **not symmetric** (`T_ij = −1/d_i` for each edge), zero
//! row sums, sign convention `F = D − W` (positive semi-definite spectrum). It is
//! similar to the normalized graph Laplacian, `T = D^{-1/2} G D^{1/2}`, so its
//! eigenvalues are real and lie in `[0, 2]`. Boundary vertices need no special case.

use super::{degree_map_checked, OperatorError};
use crate::mesh::topology::Topology;
use crate::SparseMatrix;

/// Assembles the Tutte Laplacian `T = I − D⁻¹A` of `topo`.
pub fn tutte(topo: &Topology) -> Result<SparseMatrix, OperatorError> {
    // −(1/d_i) and −1/d_i are the same number (rounding is sign-symmetric).
    let inv = degree_map_checked(topo, |d| 1.0 / d)?;
    Ok(super::assemble::one_ring_matrix(
        topo,
        |_| 1.0,
        |i, _, _| -inv[i],
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::operator::{graph::graph, test_util::*};
    use faer::Side;

    #[test]
    fn zero_row_sums() {
        for (name, m) in meshes() {
            assert!(
                max_abs_row_sum(&tutte(&topo(&m)).unwrap()) < 1e-15,
                "{name}"
            );
        }
    }

    #[test]
    fn same_spectrum_as_graph_laplacian() {
        for (name, m) in meshes() {
            let t = topo(&m);
            let mut ev: Vec<f64> = tutte(&t)
                .unwrap()
                .to_dense()
                .eigenvalues()
                .unwrap()
                .iter()
                .map(|c| {
                    assert!(c.im.abs() < 1e-9, "{name}: complex eigenvalue {c:?}");
                    c.re
                })
                .collect();
            ev.sort_by(f64::total_cmp);
            let g = graph(&t)
                .unwrap()
                .to_dense()
                .self_adjoint_eigenvalues(Side::Lower)
                .unwrap();
            for (a, b) in ev.iter().zip(&g) {
                assert!((a - b).abs() < 1e-9, "{name}: {a} vs {b}");
            }
            assert!(ev[0].abs() < 1e-9 && *ev.last().unwrap() <= 2.0 + 1e-9);
        }
    }
}
