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

/// Assembles the SQL `S = D − W` of `topo` (n×n, symmetric, sign convention
/// `F = D − W`) with the given boundary diagonal.
///
/// Two passes, both in parallel. Per face, in face order (sequential reads of the
/// faces), each half-edge's opposite vertex gives `1/d_k` to its own side of its edge
/// (`edge_sides`: an interior edge's two sides are its two opposite vertices, a
/// boundary edge's are `[1/d_k, 0]`). Then the matrix is filled
/// column by column (`assemble::one_ring_columns`): entry (i, j) is
/// `−(1/d_j + 1/d_i − ½(s₀ + s₁))` from the edge's sides, or `−(1/d_j + 1/d_i − s₀)`
/// when the second side is 0 (a boundary edge: every `1/d` is positive), and the
/// boundary diagonal of vertex j is summed over its boundary edges in neighbour order
/// (which is the edge order of j's edges). Both sums of two are commutative in IEEE
/// arithmetic, so the result equals, bit for bit, `diag` from [`sql_diagonal`] minus
/// `W` from [`sql_edge_weights`] (tested), without a per-edge weight array and without
/// its random reads of the half-edge arrays in edge order.
///
/// Errors on an isolated vertex and on a non-manifold edge (the first in edge order).
pub fn sql(topo: &Topology, convention: BoundaryDiagonal) -> Result<SparseMatrix, OperatorError> {
    let inv = degree_map_checked(topo, |d| 1.0 / d)?;
    if topo.non_manifold_edges().next().is_some() {
        // Name the first non-manifold edge, in edge order, as the sequential build did.
        sql_edge_weights(topo, &degrees_checked(topo)?)?;
    }
    let sides = edge_sides(topo, &inv);
    let sign = match convention {
        BoundaryDiagonal::ZeroRowSum => 1.0,
        BoundaryDiagonal::AsPrinted => -1.0,
    };
    Ok(super::assemble::one_ring_columns(topo, |j, off| {
        let v = VertexId(j as u32);
        let inv_j = inv[j];
        let mut diag = 1.0;
        for ((o, &i), &e) in off
            .iter_mut()
            .zip(topo.neighbors(v))
            .zip(topo.neighbor_edges(v))
        {
            let [s0, s1] = sides[e as usize];
            let inv_i = inv[i as usize];
            let base = inv_j + inv_i;
            if s1 == 0.0 {
                // A boundary edge, s0 = 1/d_k of its opposite vertex k. As in
                // `sql_diagonal`: ±½(1/d_i − 1/d_k), i the other endpoint; `sign ·
                // delta` is exact (a sign flip).
                *o = -(base - s0);
                diag += sign * (0.5 * (inv_i - s0));
            } else {
                *o = -(base - 0.5 * (s0 + s1));
            }
        }
        diag
    }))
}

/// Faces per parallel task of [`edge_sides`].
const FACE_CHUNK: usize = 2048;

/// Per edge (in [`Topology::edges`] order) its two sides `[1/d_k, 1/d_l]`: the
/// reciprocal degrees `inv` of the vertices opposite its two half-edges, the lower
/// half-edge's first; `[1/d_k, 0]` on a boundary edge. Each face writes its three
/// half-edges' values straight to their slots (`assemble::EdgeSideSlots`), in
/// parallel over blocks of faces.
///
/// `assemble::per_face_edge_sides` with the values inlined: it fills the same slots
/// with the same values (each slot has one writer, so the order does not matter)
/// without that pass' error path, corner values or non-manifold edges (tested
/// against it). (This pass is where the geometric operators' per-block buffer of
/// every face's values was first dropped; BENCHMARKS.md, "Operator assembly".) The
/// topology must have no non-manifold edge ([`sql`] rejects those first): such an
/// edge's sides are written by no face.
fn edge_sides(topo: &Topology, inv: &[f64]) -> Vec<[f64; 2]> {
    use rayon::prelude::*;
    assert!(
        topo.non_manifold_edges().next().is_none(),
        "edge_sides: a non-manifold edge"
    );
    let slots = super::assemble::EdgeSideSlots::new(topo);
    let mut sides = crate::mem::uninit_vec::<[f64; 2]>(topo.n_edges());
    {
        // SAFETY: `sides` is borrowed mutably for the scatter's life and used by no
        // one else; `MaybeUninit<[f64; 2]>` has the layout of two consecutive f64.
        let scatter = unsafe {
            crate::mem::Scatter::from_raw_parts(sides.as_mut_ptr().cast::<f64>(), 2 * sides.len())
        };
        topo.faces()
            .par_chunks(FACE_CHUNK)
            .enumerate()
            .for_each(|(c, faces)| {
                for (f, t) in (c * FACE_CHUNK..).zip(faces) {
                    // Half-edge 3f + m runs t[m] → t[m + 1]; its opposite vertex is
                    // t[m + 2].
                    let [a, b, c] = t.map(|v| inv[v as usize]);
                    for (m, v) in [c, a, b].into_iter().enumerate() {
                        // SAFETY: `sides` has two slots per edge and each half-edge
                        // is written once (by its own face).
                        unsafe { slots.write(&scatter, 3 * f + m, v, 0.0) };
                    }
                }
            });
    }
    // SAFETY: every half-edge wrote its slot; with no non-manifold edge, every edge
    // has two twins or is a boundary edge, so both sides of every edge were written.
    unsafe { crate::mem::assume_init_vec(sides) }
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
    fn edge_sides_equal_the_generic_per_face_pass() {
        // The inlined pass against `assemble::per_face_edge_sides` with the same
        // values, bit for bit, on closed and boundary meshes and on one of more faces
        // than a parallel block.
        let many = builtin::grid(60).unwrap();
        for (name, m) in meshes().into_iter().chain([("grid60", many)]) {
            let t = topo(&m);
            assert!(t.n_faces() > FACE_CHUNK || name != "grid60");
            let inv: Vec<f64> = degrees_checked(&t)
                .unwrap()
                .iter()
                .map(|d| 1.0 / d)
                .collect();
            let faces = t.faces();
            let (want, _) = crate::operator::assemble::per_face_edge_sides(
                &t,
                0.0f64,
                |a, b| a + b,
                &crate::operator::assemble::Collected(
                    |range: std::ops::Range<usize>, out: &mut Vec<_>| {
                        out.extend(faces[range].iter().map(|f| {
                            let [a, b, c] = f.map(|v| inv[v as usize]);
                            ([c, a, b], [(); 3])
                        }));
                        Ok::<_, std::convert::Infallible>(())
                    },
                ),
            )
            .unwrap();
            let got = edge_sides(&t, &inv);
            let bits = |s: &[[f64; 2]]| s.iter().map(|p| p.map(f64::to_bits)).collect::<Vec<_>>();
            assert!(bits(&got) == bits(&want), "{name}");
        }
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
