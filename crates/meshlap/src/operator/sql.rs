//! Zhang's symmetric quasi-Laplacian (SQL), Zhang (2004) §3.7.
//!
//! `S = D − W`: n×n, symmetric, sign convention `F = D − W`. For an edge (i, j):
//!
//! - interior edge with opposite vertices k, l:
//!   `W_ij = 1/d_i + 1/d_j − ½(1/d_k + 1/d_l)`;
//! - boundary edge with its one opposite vertex k: `W_ij = 1/d_i + 1/d_j − 1/d_k`.
//!
//! `D_ii = 1` at interior vertices. At a boundary vertex i with boundary edges
//! (i, j_m) and their opposite vertices k_m:
//!
//! ```text
//! D_ii = 1 + ½ Σ_m (1/d_{j_m} − 1/d_{k_m})
//! ```
//!
//! **Erratum.** The paper prints `D_ii = 1 + ½ Σ_m (1/d_{k_m} − 1/d_{j_m})`, which
//! contradicts its own claim of zero row sums. Summing the weights of a boundary fan
//! `j_1 = n_1, n_2, …, n_m = j_2` around i gives
//! `Σ_j W_ij = 1 + ½(1/d_{n_1} + 1/d_{n_m}) − ½(1/d_{n_2} + 1/d_{n_{m−1}})`, and
//! `k_1 = n_2`, `k_2 = n_{m−1}`: the row sum is zero only with the sign used here
//! ([`BoundaryDiagonal::ZeroRowSum`], the default). The printed sign
//! ([`BoundaryDiagonal::AsPrinted`]) is available to reproduce the discrepancy: it
//! leaves row sums up to 0.73 on teapot.obj and 0.46 on stanford-bunny.obj. The
//! corrected formula is written per boundary edge, so it also holds at vertices with
//! several boundary fans.
//!
//! W can have negative weights where neighbouring degrees differ a lot; then S may be
//! indefinite. [`crate::analysis::repair`] removes them by greedy edge swapping. The SQL
//! refuses non-manifold edges (the opposite vertices k, l are not unique there).

use super::{degree_map_checked, degrees_checked, OperatorError};
use crate::mesh::{topology::Topology, EdgeId, MeshError, VertexId};
use crate::SparseMatrix;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// Which boundary diagonal the SQL uses; see the module documentation.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum BoundaryDiagonal {
    /// `1 + ½ Σ (1/d_j − 1/d_k)`: zero row sums (correct).
    #[default]
    ZeroRowSum,
    /// `1 + ½ Σ (1/d_k − 1/d_j)`, as printed in the paper (wrong sign; row sums ≠ 0).
    #[cfg_attr(feature = "clap", value(name = "printed"))]
    AsPrinted,
}

crate::names::option_names!(BoundaryDiagonal, OperatorError, |s| OperatorError::UnknownOption {
    what: "SQL boundary diagonal",
    name: s.to_string(),
    choices: "zero-row-sum, printed",
}, {
    ZeroRowSum => "zero-row-sum",
    AsPrinted => "printed",
});

/// The SQL weight `W_e` of every undirected edge (in [`Topology::edges`] order), given
/// degrees `d`. Errors on a non-manifold edge, naming it.
pub fn sql_edge_weights(topo: &Topology, d: &[f64]) -> Result<Vec<f64>, OperatorError> {
    (0..topo.n_edges())
        .map(|e| sql_edge_weight(topo, d, EdgeId(e as u32)))
        .collect()
}

/// The SQL weight of one edge; see the module documentation.
pub fn sql_edge_weight(topo: &Topology, d: &[f64], e: EdgeId) -> Result<f64, OperatorError> {
    let [a, b] = topo.edge(e);
    let base = 1.0 / d[a as usize] + 1.0 / d[b as usize];
    match topo.edge_face_count(e) {
        1 => {
            let k = topo.edge_opposite_vertices(e).next().unwrap_or(a);
            Ok(base - 1.0 / d[k as usize])
        }
        2 => {
            let s: f64 = topo
                .edge_opposite_vertices(e)
                .map(|k| 1.0 / d[k as usize])
                .sum();
            Ok(base - 0.5 * s)
        }
        faces => Err(MeshError::NonManifoldEdge { a, b, faces }.into()),
    }
}

/// The diagonal `D` of the SQL (see the module documentation for both conventions).
pub fn sql_diagonal(topo: &Topology, d: &[f64], convention: BoundaryDiagonal) -> Vec<f64> {
    let mut diag = vec![1.0; topo.n_vertices()];
    for e in topo.boundary_edges() {
        let [a, b] = topo.edge(e);
        let Some(k) = topo.edge_opposite_vertices(e).next() else {
            continue;
        };
        let inv_k = 1.0 / d[k as usize];
        for (i, j) in [(a, b), (b, a)] {
            let delta = 0.5 * (1.0 / d[j as usize] - inv_k);
            diag[i as usize] += match convention {
                BoundaryDiagonal::ZeroRowSum => delta,
                BoundaryDiagonal::AsPrinted => -delta,
            };
        }
    }
    diag
}

/// Assembles the SQL `S = D − W` of `topo` with the given boundary diagonal.
///
/// The edge weights are computed in parallel in edge order (sequential reads of the
/// edge arrays), then the matrix is filled column by column
/// (`assemble::one_ring_columns`) with the boundary diagonal of vertex j
/// summed over its boundary edges in edge order — so the result equals, bit for bit,
/// `diag` from [`sql_diagonal`] minus `W` from [`sql_edge_weights`].
pub fn sql(topo: &Topology, convention: BoundaryDiagonal) -> Result<SparseMatrix, OperatorError> {
    let inv = degree_map_checked(topo, |d| 1.0 / d)?;
    let non_manifold = AtomicBool::new(false);
    // Whether any edge is a boundary edge: a closed mesh's columns then skip the
    // boundary test of each entry.
    let has_boundary = AtomicBool::new(false);
    let w: Vec<f64> = (0..topo.n_edges())
        .into_par_iter()
        .with_min_len(4096)
        .map(|e| {
            let e = EdgeId(e as u32);
            let [a, b] = topo.edge(e);
            // The expressions of `sql_edge_weight`, with 1/d precomputed (same bits).
            let base = inv[a as usize] + inv[b as usize];
            let h = topo.edge_half_edge(e);
            let inv_k = inv[topo.opposite_vertex(h) as usize];
            match topo.edge_face_count(e) {
                1 => {
                    has_boundary.store(true, Ordering::Relaxed);
                    base - inv_k
                }
                2 => base - 0.5 * (inv_k + inv[topo.opposite_vertex(topo.twin(h)) as usize]),
                _ => {
                    non_manifold.store(true, Ordering::Relaxed);
                    f64::NAN
                }
            }
        })
        .collect();
    if non_manifold.load(Ordering::Relaxed) {
        // Name the first non-manifold edge, in edge order, as the sequential build did.
        sql_edge_weights(topo, &degrees_checked(topo)?)?;
    }
    let has_boundary = has_boundary.load(Ordering::Relaxed);
    let sign = match convention {
        BoundaryDiagonal::ZeroRowSum => 1.0,
        BoundaryDiagonal::AsPrinted => -1.0,
    };
    Ok(super::assemble::one_ring_columns(topo, |j, off| {
        let v = VertexId(j as u32);
        let mut diag = 1.0;
        for ((o, &i), &e) in off
            .iter_mut()
            .zip(topo.neighbors(v))
            .zip(topo.neighbor_edges(v))
        {
            let e = EdgeId(e);
            *o = -w[e.idx()];
            if has_boundary && topo.is_boundary_edge(e) {
                // As in `sql_diagonal`: ±½(1/d_i − 1/d_k), i the other endpoint, k the
                // opposite vertex; `sign · delta` is exact (a sign flip).
                let inv_k = inv[topo.opposite_vertex(topo.edge_half_edge(e)) as usize];
                diag += sign * (0.5 * (inv[i as usize] - inv_k));
            }
        }
        diag
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{builtin, TriMesh, VertexId};
    use crate::operator::{test_util::*, tutte::tutte};

    #[test]
    fn zero_row_sums_and_symmetry_everywhere() {
        for (name, m) in meshes() {
            let s = sql(&topo(&m), BoundaryDiagonal::ZeroRowSum).unwrap();
            assert!(
                max_abs_row_sum(&s) < 1e-14,
                "{name}: {}",
                max_abs_row_sum(&s)
            );
            assert!(asymmetry(&s) == 0.0, "{name}");
        }
    }

    #[test]
    fn printed_boundary_diagonal_breaks_row_sums() {
        // The step mesh has boundary vertices whose fans are irregular.
        for m in [builtin::grid(5).unwrap(), builtin::step(7).unwrap()] {
            let t = topo(&m);
            let printed = sql(&t, BoundaryDiagonal::AsPrinted).unwrap();
            assert!(max_abs_row_sum(&printed) > 0.05);
            // Closed meshes have no boundary: both conventions agree.
            let c = builtin::cube(2).unwrap();
            let tc = topo(&c);
            assert!(max_abs_row_sum(&sql(&tc, BoundaryDiagonal::AsPrinted).unwrap()) < 1e-14);
        }
    }

    #[test]
    fn equals_tutte_on_regular_connectivity() {
        let m = builtin::grid(8).unwrap();
        let t = topo(&m);
        let s = sql(&t, BoundaryDiagonal::ZeroRowSum).unwrap().to_dense();
        let tl = tutte(&t).unwrap().to_dense();
        let n = 9;
        let mut checked = 0;
        for j in 2..n - 2 {
            for i in 2..n - 2 {
                // Vertices at distance ≥ 2 from the boundary: their neighbours and the
                // opposite vertices of their edges all have degree 6.
                let v = j * n + i;
                assert_eq!(t.degree(VertexId(v as u32)), 6);
                for c in 0..n * n {
                    assert!((s[(v, c)] - tl[(v, c)]).abs() < 1e-15);
                }
                checked += 1;
            }
        }
        assert_eq!(checked, 25);
    }

    #[test]
    fn non_manifold_edge_is_refused_by_name() {
        let m = TriMesh::new(vec![[0.0; 3]; 5], vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]]);
        let err = sql(&topo(&m), BoundaryDiagonal::ZeroRowSum).unwrap_err();
        assert!(err.to_string().contains("edge (0, 1)"), "{err}");
    }

    #[test]
    fn explicit_diagonal_equals_weight_row_sum() {
        // Cross-check the closed-form diagonal against Σ_j W_ij.
        for (name, m) in meshes() {
            let t = topo(&m);
            let d = degrees_checked(&t).unwrap();
            let w = sql_edge_weights(&t, &d).unwrap();
            let diag = sql_diagonal(&t, &d, BoundaryDiagonal::ZeroRowSum);
            for v in 0..t.n_vertices() {
                let s: f64 = t
                    .neighbor_edges(VertexId(v as u32))
                    .iter()
                    .map(|&e| w[e as usize])
                    .sum();
                assert!((s - diag[v]).abs() < 1e-14, "{name} vertex {v}");
            }
        }
    }
}
