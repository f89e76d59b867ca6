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

use super::geometry::{dot, norm, sub};
use super::OperatorError;
use crate::mesh::{topology::Topology, TriMesh};
use crate::SparseMatrix;
use rayon::prelude::*;

/// Inverse edge lengths, in [`Topology::edges`] order (sequential); a zero-length
/// (or overflowing) edge is an error naming the first such edge. The error path of
/// [`sdl`], which computes the same values per vertex.
fn inverse_lengths(mesh: &TriMesh, topo: &Topology) -> Result<Vec<f64>, OperatorError> {
    let mut w = Vec::with_capacity(topo.n_edges());
    for &[a, b] in topo.edges() {
        let l = norm(sub(mesh.positions[a as usize], mesh.positions[b as usize]));
        if !(l > 0.0 && l.is_finite() && (1.0 / l).is_finite()) {
            return Err(OperatorError::ZeroLengthEdge { a, b, kind: "sdl" });
        }
        w.push(1.0 / l);
    }
    Ok(w)
}

/// [`sdl`]'s first pass over the vertices `start..start + inv_sums.len()`: each
/// neighbour's weight `w_vu = 1/‖x_v − x_u‖` in adjacency order into `w` (the block's
/// part of the adjacency-sized array), and each vertex's reciprocal row sum
/// `1/Σ_u w_vu` into `inv_sums`. Returns false if a weight or a sum is not finite and
/// positive.
///
/// Three loops over the block: the squared lengths `d·d` into `w` (scalar: the
/// neighbours are scattered), then `1/√(d·d)` in place over the whole block, a long
/// contiguous loop that vectorises (correctly rounded in every lane: the bits of
/// `1 / norm(d)`), then the row sums in neighbour order. The kernel runs in the AVX2
/// build where the CPU has it ([`crate::cpu::dispatch`], the same bits).
struct RowWeights<'a> {
    pos: &'a [[f64; 3]],
    adj: &'a [u32],
    offsets: &'a [u32],
    start: usize,
    w: &'a mut [std::mem::MaybeUninit<f64>],
    inv_sums: &'a mut [std::mem::MaybeUninit<f64>],
}

impl crate::cpu::Kernel for RowWeights<'_> {
    type Output = bool;
    #[inline(always)]
    fn portable(self) -> bool {
        let RowWeights {
            pos,
            adj,
            offsets,
            start,
            w,
            inv_sums,
        } = self;
        let end = start + inv_sums.len();
        let base = offsets[start] as usize;
        let slots = |v: usize| offsets[v] as usize - base..offsets[v + 1] as usize - base;
        for v in start..end {
            let x = pos[v];
            let r = slots(v);
            for (o, &u) in w[r.clone()]
                .iter_mut()
                .zip(&adj[r.start + base..r.end + base])
            {
                let d = sub(x, pos[u as usize]);
                o.write(dot(d, d));
            }
        }
        // SAFETY: the slots of the block's vertices are the whole of `w` (it is
        // the block's part of the adjacency), and the loop above wrote each.
        let w = unsafe { crate::mem::assume_init_slice(w) };
        let mut ok = true;
        for x in w.iter_mut() {
            let l = x.sqrt();
            let r = 1.0 / l;
            let good = (l > 0.0) & l.is_finite() & r.is_finite();
            *x = if good { r } else { f64::NAN };
            ok &= good;
        }
        for (v, inv) in (start..end).zip(inv_sums.iter_mut()) {
            // In neighbour order, as `assemble::vertex_weight_sums` sums.
            let sum = w[slots(v)].iter().fold(0.0f64, |s, &x| s + x);
            ok &= sum.is_finite();
            inv.write(1.0 / sum);
        }
        ok
    }
}

/// Assembles the scale-dependent Laplacian of `mesh`: n×n, non-symmetric, zero row
/// sums, `F = D − W` with `D = I` and `W_ij = w_ij · (1/Σ_k w_ik)`, `w_ij = 1/‖x_i − x_j‖`
/// (each row scaled by the reciprocal of its sum, computed once per vertex).
///
/// Two parallel passes. The first computes, per vertex, its weights in adjacency
/// order and its reciprocal row sum (`RowWeights`; each edge's weight twice, once
/// from each end, the same bits: `x_i − x_j` and `x_j − x_i` have the same squares).
/// Since the weights are symmetric, column j's entries `−w_ij · (1/Σ_k w_ik)` then
/// read j's own weights in order and gather only the reciprocal sums
/// (`assemble::one_ring_columns`). No per-edge array is built or gathered from.
pub fn sdl(mesh: &TriMesh, topo: &Topology) -> Result<SparseMatrix, OperatorError> {
    let n = topo.n_vertices();
    let (adj, offsets) = (topo.adjacency(), topo.adjacency_offsets());
    let mut w = crate::mem::uninit_vec::<f64>(adj.len());
    let mut inv_sums = crate::mem::uninit_vec::<f64>(n);
    let ok = super::assemble::vertex_blocks(topo, &mut w, &mut inv_sums)
        .into_par_iter()
        .map(|(start, w, inv_sums)| {
            crate::cpu::dispatch(RowWeights {
                pos: &mesh.positions,
                adj,
                offsets,
                start,
                w,
                inv_sums,
            })
        })
        .reduce(|| true, |a, b| a && b);
    // SAFETY: the blocks cover `w` and `inv_sums`; each task wrote the weights of its
    // vertices' neighbours and the sum of each of its vertices.
    let (w, inv_sums) = unsafe {
        (
            crate::mem::assume_init_vec(w),
            crate::mem::assume_init_vec(inv_sums),
        )
    };
    if !ok {
        return Err(first_error(mesh, topo));
    }
    Ok(super::assemble::one_ring_columns(topo, |j, out| {
        let (lo, hi) = (offsets[j] as usize, offsets[j + 1] as usize);
        for ((o, &i), &wij) in out.iter_mut().zip(&adj[lo..hi]).zip(&w[lo..hi]) {
            *o = -wij * inv_sums[i as usize];
        }
        1.0
    }))
}

/// The error [`sdl`] reports when a weight or a row sum is not finite: the first
/// zero-length (or overflowing) edge in edge order, else the first vertex whose sum
/// overflows. (An isolated vertex has an empty, zero sum, which is never used.)
fn first_error(mesh: &TriMesh, topo: &Topology) -> OperatorError {
    let w = match inverse_lengths(mesh, topo) {
        Ok(w) => w,
        Err(e) => return e,
    };
    let sums = super::assemble::vertex_weight_sums(topo, &w);
    let vertex = super::first_non_finite(&sums).unwrap_or(0) as u32;
    OperatorError::NonFinite {
        vertex,
        kind: "sdl",
    }
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

    /// The two-pass assembly (weights per vertex, each edge's twice) has the bits of
    /// the per-edge one: one weight per edge, gathered into row sums and entries.
    #[test]
    fn equals_the_per_edge_assembly_bit_for_bit() {
        // Larger than one parallel task (2,048 vertices), jittered so that every
        // weight differs (seeded), and with a boundary.
        let mut sphere = builtin::icosphere(5).unwrap();
        let mut rng = crate::rng::SplitMix64::new(17);
        for p in &mut sphere.positions {
            p.iter_mut().for_each(|x| *x += 0.01 * rng.next_signed());
        }
        let large = [
            ("icosphere5, jittered", sphere),
            ("grid60", builtin::grid(60).unwrap()),
        ];
        for (name, m) in meshes().into_iter().chain(large) {
            let t = topo(&m);
            let w = inverse_lengths(&m, &t).unwrap();
            let sums = crate::operator::assemble::vertex_weight_sums(&t, &w);
            let want = crate::operator::assemble::reference::one_ring_matrix(
                &t,
                |_| 1.0,
                |i, _, e| -w[e] * (1.0 / sums[i]),
            );
            for threads in [1, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let got = pool.install(|| sdl(&m, &t)).unwrap();
                assert_eq!(got.col_ptr(), want.col_ptr(), "{name}");
                assert_eq!(got.row_idx(), want.row_idx(), "{name}");
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(
                    bits(got.val()),
                    bits(want.val()),
                    "{name}, {threads} threads"
                );
            }
        }
    }

    /// A zero-length edge is named (the first in edge order), on a mesh large enough
    /// for several parallel tasks.
    #[test]
    fn zero_length_edge_is_named_on_a_large_mesh() {
        let mut m = builtin::icosphere(5).unwrap();
        let t = topo(&m);
        let [a, b] = t.edges()[t.n_edges() - 7];
        m.positions[b as usize] = m.positions[a as usize];
        let t = topo(&m);
        match sdl(&m, &t) {
            Err(OperatorError::ZeroLengthEdge { a: ea, b: eb, .. }) => {
                assert_eq!([ea, eb], [a.min(b), a.max(b)])
            }
            other => panic!("{:?}", other.map(|_| ())),
        }
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
