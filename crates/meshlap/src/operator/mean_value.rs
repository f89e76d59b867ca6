//! Floater's mean-value weights, Floater (2003), as a Laplacian.
//!
//! For an edge (i, j), `w_ij = (tan(δ_ij/2) + tan(γ_ij/2)) / ‖x_j − x_i‖`, where δ and γ
//! are the angles **at x_i** of the (one or two) triangles adjacent to the edge. The
//! weights are positive for any non-degenerate triangle and not symmetric; normalised
//! per row, `F = I − W̃` with `W̃_ij = w_ij / Σ_k w_ik`: n×n, non-symmetric, zero row
//! sums, sign convention `F = D − W`. Mean-value coordinates reproduce linear
//! functions, so `F·x = 0` at interior vertices of a planar mesh.
//!
//! **Degenerate input.** A zero-length edge is [`OperatorError::ZeroLengthEdge`]; a
//! triangle that is zero-area to rounding (the cotangent operator's test, see
//! [`super::cotan`]) is [`OperatorError::DegenerateFace`] naming the face, since its
//! angles of 0 or π make the half-angle tangents 0 or infinite. An overflow of
//! extremely scaled coordinates is [`OperatorError::NonFinite`]. An isolated vertex
//! gets the identity row. The result is never NaN or infinite.

use super::assemble::{FaceSink, FaceValues};
use super::geometry::{add, cross, dot, norm, scale, sub};
use super::OperatorError;
use crate::mesh::{topology::Topology, TriMesh};
use crate::SparseMatrix;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// Assembles the row-normalised mean-value Laplacian of `mesh`: n×n, non-symmetric,
/// zero row sums, `F = D − W` with `D = I`.
///
/// Fixed summation orders, so the same bits on any number of threads: each edge's two
/// directed weights summed over its faces in face order (`directed_weights`), each
/// row's normalising sum in neighbour order (its entries are the weights times the
/// sum's reciprocal; `incoming_weights`, which also lists each column's weights in
/// order), then the columns in parallel. Of several faulty faces the first is named.
pub fn mean_value(mesh: &TriMesh, topo: &Topology) -> Result<SparseMatrix, OperatorError> {
    let sides = directed_weights(mesh, topo)?;
    let (w_in, inv_sums) = incoming_weights(topo, &sides);
    // Raised by a column whose entries' sum is not finite: only then is the matrix
    // scanned again (a sum that overflows with finite entries finds nothing there).
    let flagged = AtomicBool::new(false);
    let offsets = topo.adjacency_offsets();
    let f = super::assemble::one_ring_columns(topo, |j, off| {
        let v = crate::VertexId(j as u32);
        let (lo, hi) = (offsets[j] as usize, offsets[j + 1] as usize);
        let mut sum = 0.0;
        for ((o, &i), &w) in off.iter_mut().zip(topo.neighbors(v)).zip(&w_in[lo..hi]) {
            *o = -w * inv_sums[i as usize];
            sum += *o;
        }
        if !sum.is_finite() {
            flagged.store(true, Ordering::Relaxed);
        }
        1.0
    });
    super::check_finite_flagged(&f, flagged.into_inner(), None, "mean-value")?;
    Ok(f)
}

/// From the edges' [`directed_weights`], in one pass over the vertices (parallel over
/// `assemble::vertex_blocks`), two arrays:
///
/// - per adjacency entry (vertex v, neighbour u; [`Topology::adjacency`] order) the
///   weight `w_uv` from u to v, which column v's entry (u, v) needs: written in order
///   here, so the columns read it in order instead of gathering each edge's sides a
///   second time;
/// - per vertex v the reciprocal `1/Σ_u w_vu` of its row's sum, in neighbour order.
///
/// Both weights of an edge come from its sides as `0 + side₀ + side₁` in face order.
fn incoming_weights(topo: &Topology, sides: &[[[f64; 2]; 2]]) -> (Vec<f64>, Vec<f64>) {
    let (adj, offsets) = (topo.adjacency(), topo.adjacency_offsets());
    let mut w_in = crate::mem::uninit_vec::<f64>(adj.len());
    let mut inv_sums = crate::mem::uninit_vec::<f64>(topo.n_vertices());
    super::assemble::vertex_blocks(topo, &mut w_in, &mut inv_sums)
        .into_par_iter()
        .for_each(|(start, w_in, inv_sums)| {
            let base = offsets[start] as usize;
            for (v, inv) in (start..).zip(inv_sums.iter_mut()) {
                let (lo, hi) = (offsets[v] as usize, offsets[v + 1] as usize);
                // From −0.0, as `Iterator::sum` starts.
                let mut sum = -0.0;
                for ((w, &u), &e) in w_in[lo - base..hi - base]
                    .iter_mut()
                    .zip(&adj[lo..hi])
                    .zip(topo.neighbor_edges(crate::VertexId(v as u32)))
                {
                    // Slot `from > to` of each side holds the weight from `from`.
                    let [a, b] = sides[e as usize];
                    let (out, into) = (usize::from(v as u32 > u), usize::from(u > v as u32));
                    sum += 0.0 + a[out] + b[out];
                    w.write(0.0 + a[into] + b[into]);
                }
                inv.write(1.0 / sum);
            }
        });
    // SAFETY: the blocks cover `w_in` and `inv_sums`; each task wrote every entry of
    // its vertices and every one of its vertices.
    unsafe {
        (
            crate::mem::assume_init_vec(w_in),
            crate::mem::assume_init_vec(inv_sums),
        )
    }
}

/// Directed weights per edge `[a, b]` (`a < b`, [`Topology::edges`] order), as two
/// sides to be added in order (`0 + side₀ + side₁`, `assemble::per_face_edge_sides`):
/// `[w_ab, w_ba]`, each the sum over the edge's faces, in face order, of
/// `tan(θ/2)/‖x_b − x_a‖` for the angle θ at the weight's start. A half-edge from x to
/// y adds its start's angle to the weight from x (slot `x > y`), its end's to the
/// other. The faces are computed in parallel; the sums are the same on any number of
/// threads.
fn directed_weights(mesh: &TriMesh, topo: &Topology) -> Result<Vec<[[f64; 2]; 2]>, OperatorError> {
    let faces = topo.faces();
    let (sides, _) = super::assemble::per_face_edge_sides(
        topo,
        [0.0f64; 2],
        |acc, v| [acc[0] + v[0], acc[1] + v[1]],
        &MeanValueFaces { mesh, faces },
    )?;
    Ok(sides)
}

/// The mean-value operator's per-face values for `assemble::per_face_edge_sides`:
/// [`FaceLanes`], and [`face_contributions`] for the face where the lanes stop.
#[derive(Clone, Copy)]
struct MeanValueFaces<'a> {
    mesh: &'a TriMesh,
    faces: &'a [[u32; 3]],
}

impl FaceValues<[f64; 2], ()> for MeanValueFaces<'_> {
    type Error = OperatorError;
    fn put_faces<S: FaceSink<[f64; 2], ()>>(
        &self,
        range: std::ops::Range<usize>,
        out: &mut S,
    ) -> Result<(), OperatorError> {
        let MeanValueFaces { mesh, faces } = *self;
        // The lanes stop at a face they cannot take (a zero-length edge or a
        // degenerate triangle); the one-face function names its error.
        let mut start = range.start;
        while start < range.end {
            let stop = crate::cpu::dispatch(FaceLanes {
                pos: &mesh.positions,
                faces: &faces[start..range.end],
                out: &mut *out,
            });
            let Some(q) = stop else { break };
            let f = start + q;
            out.put(face_contributions(mesh, f, faces[f])?, [(); 3]);
            start = f + 1;
        }
        Ok(())
    }
}

/// Faces per group of lanes in [`FaceLanes`].
const LANES: usize = 64;

/// [`face_contributions`] of consecutive faces, put into `out` in face order (with
/// `()` per corner); stops before the first face with a zero-length edge or a
/// triangle that is zero-area to rounding and returns its index in `faces`, for
/// [`face_contributions`] to name the error.
///
/// Per group of [`LANES`] faces, one loop gathers the corners and forms the edge
/// vectors, squared lengths and squared doubled area (scalar: the corners are
/// scattered), one loop over the lanes does the six square roots and nine divisions
/// of each face without branches, so that it vectorises, and one loop puts the
/// weights in their edges' slots. Each lane computes the IEEE operations of
/// [`face_contributions`] in the same order (the vector from corner k to corner k + 2
/// is the exact negation of edge k + 2), so the bits are the same; the kernel runs
/// in the AVX2 build where the CPU has it ([`crate::cpu::dispatch`]).
struct FaceLanes<'a, S> {
    pos: &'a [[f64; 3]],
    faces: &'a [[u32; 3]],
    out: &'a mut S,
}

impl<S: FaceSink<[f64; 2], ()>> crate::cpu::Kernel for FaceLanes<'_, S> {
    type Output = Option<usize>;
    #[inline(always)]
    fn portable(self) -> Option<usize> {
        let FaceLanes { pos, faces, out } = self;
        // Per lane: edge m (from corner m to corner m + 1) per coordinate, its squared
        // length, and the squared doubled area; per corner k the weights along edges
        // k and k + 2. Zeroed once per call, not per group: a group writes every lane
        // it reads, except that the lanes past a short last group compute on an
        // earlier group's values (or zeros) and are not read.
        let mut edge = [[[0.0f64; LANES]; 3]; 3];
        let mut len2 = [[0.0f64; LANES]; 3];
        let mut cross2 = [0.0f64; LANES];
        let mut start = [[0.0f64; LANES]; 3];
        let mut end = [[0.0f64; LANES]; 3];
        let mut fine = [false; LANES];
        for (g, group) in faces.chunks(LANES).enumerate() {
            for (q, t) in group.iter().enumerate() {
                let c = t.map(|v| pos[v as usize]);
                let e: [[f64; 3]; 3] = [sub(c[1], c[0]), sub(c[2], c[1]), sub(c[0], c[2])];
                for m in 0..3 {
                    for x in 0..3 {
                        edge[m][x][q] = e[m][x];
                    }
                    len2[m][q] = dot(e[m], e[m]);
                }
                let n = cross(e[0], sub(c[2], c[0]));
                cross2[q] = dot(n, n);
            }
            // Per corner k: the weight along edge k (`start`) and along edge k + 2
            // (`end`), both tan(θ_k/2) over the edge's length.
            for q in 0..LANES {
                let l2 = [len2[0][q], len2[1][q], len2[2][q]];
                let len = [l2[0].sqrt(), l2[1].sqrt(), l2[2].sqrt()];
                let area2 = cross2[q].sqrt();
                let mut ok = super::cotan::proper_triangle(area2, l2);
                for k in 0..3 {
                    let k2 = (k + 2) % 3;
                    let u = [edge[k][0][q], edge[k][1][q], edge[k][2][q]];
                    let v = [-edge[k2][0][q], -edge[k2][1][q], -edge[k2][2][q]];
                    let (lu, lv) = (len[k], len[k2]);
                    // `!(x > 0)`: NaN or not positive.
                    ok &= lu > 0.0 && lv > 0.0;
                    let (du, dv) = (scale(u, lv), scale(v, lu));
                    let (plus, minus) = (add(du, dv), sub(du, dv));
                    let denom2 = dot(plus, plus);
                    ok &= denom2 > 0.0;
                    let half_tan = (dot(minus, minus) / denom2).sqrt();
                    start[k][q] = half_tan / lu;
                    end[k][q] = half_tan / lv;
                }
                fine[q] = ok;
            }
            for (q, t) in group.iter().enumerate() {
                if !fine[q] {
                    return Some(g * LANES + q);
                }
                // As `face_contributions` writes them, in the same order.
                let mut w = [[0.0f64; 2]; 3];
                for k in 0..3 {
                    let (i, j, l) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
                    w[k][usize::from(i > j)] = start[k][q];
                    w[(k + 2) % 3][usize::from(i > l)] = end[k][q];
                }
                out.put(w, [(); 3]);
            }
        }
        None
    }
}

/// The directed contributions of face `f` with corners `t` to its three edges: per
/// half-edge m (from corner m to corner m + 1), `tan(θ_m/2) / ‖x_{m+1} − x_m‖` from
/// corner m and `tan(θ_{m+1}/2) / ‖x_{m+1} − x_m‖` from corner m + 1 (θ_c the angle at
/// corner c), ordered as the edge's slots: the one from the lower vertex first. Or the
/// face's error (a zero-length edge, or a triangle that is zero-area to rounding).
fn face_contributions(
    mesh: &TriMesh,
    f: usize,
    t: [u32; 3],
) -> Result<[[f64; 2]; 3], OperatorError> {
    let corners = t.map(|v| mesh.positions[v as usize]);
    // Edge m from corner m to corner m + 1, and its length (one square root per edge,
    // shared by the two corners it bounds).
    let edge: [[f64; 3]; 3] = std::array::from_fn(|m| sub(corners[(m + 1) % 3], corners[m]));
    let len = edge.map(norm);
    let area2 = norm(cross(edge[0], sub(corners[2], corners[0])));
    let proper = super::cotan::is_proper_triangle(area2, corners);
    let mut out = [[0.0f64; 2]; 3];
    for k in 0..3 {
        let (i, j, l) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
        // From corner k: u along edge k, v against edge k + 2.
        let (u, v) = (edge[k], sub(corners[(k + 2) % 3], corners[k]));
        let (lu, lv) = (len[k], len[(k + 2) % 3]);
        if lu.is_nan() || lv.is_nan() || lu <= 0.0 || lv <= 0.0 {
            let (a, b) = if lu > 0.0 { (i, l) } else { (i, j) };
            return Err(OperatorError::ZeroLengthEdge {
                a,
                b,
                kind: "mean-value",
            });
        }
        // tan(θ/2) = ‖ |v|u − |u|v ‖ / ‖ |v|u + |u|v ‖ (Kahan's form: accurate for
        // angles near 0 and π, where sin θ / (1 + cos θ) cancels), as the root of the
        // ratio of the squared norms.
        let (du, dv) = (scale(u, lv), scale(v, lu));
        let (plus, minus) = (add(du, dv), sub(du, dv));
        let denom2 = dot(plus, plus);
        if !proper || denom2.is_nan() || denom2 <= 0.0 {
            return Err(OperatorError::DegenerateFace {
                face: f as u32,
                a: t[0],
                b: t[1],
                c: t[2],
                kind: "mean-value",
            });
        }
        let half_tan = (dot(minus, minus) / denom2).sqrt();
        // The angle at i starts half-edge k (i → j) and ends half-edge k + 2 (l → i).
        out[k][usize::from(i > j)] = half_tan / lu;
        out[(k + 2) % 3][usize::from(i > l)] = half_tan / lv;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{builtin, VertexId};
    use crate::operator::test_util::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn reproduces_linear_functions_on_planar_meshes() {
        let mut m = builtin::grid(6).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for p in &mut m.positions {
            if p[0] > 0.0 && p[0] < 1.0 && p[1] > 0.0 && p[1] < 1.0 {
                p[0] += rng.gen_range(-0.03..0.03);
                p[1] += rng.gen_range(-0.03..0.03);
            }
        }
        let t = topo(&m);
        let f = mean_value(&m, &t).unwrap();
        for coord in 0..2 {
            let x = faer::Col::<f64>::from_fn(m.n_vertices(), |i| m.positions[i][coord]);
            let y = &f * &x;
            for v in 0..m.n_vertices() {
                if !t.is_boundary_vertex(VertexId(v as u32)) {
                    assert!(y[v].abs() < 1e-13, "vertex {v}: {}", y[v]);
                }
            }
        }
    }

    /// A zero-length edge, then a collinear triangle, in 3,000 separate triangles
    /// (many lane groups): the error is the one a face-at-a-time loop meets first, on
    /// any pool.
    #[test]
    fn the_lanes_stop_where_a_face_loop_fails() {
        let (mut v, mut f) = (Vec::new(), Vec::new());
        for i in 0..3000u32 {
            let x = f64::from(i);
            let apex = match i {
                2100 => [x, 0.0, 0.0],              // on corner 0: a zero-length edge
                2500 | 2900 => [x + 0.5, 0.0, 0.0], // collinear
                _ => [x, 1.0, 0.0],
            };
            v.extend([[x, 0.0, 0.0], [x + 1.0, 0.0, 0.0], apex]);
            f.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        let whole = TriMesh::new(v, f);
        // The whole mesh, then without the first faulty face (the collinear one first).
        let mut later = whole.clone();
        later.positions[3 * 2100 + 2] = [2100.0, 1.0, 0.0];
        for (m, zero_length) in [(&whole, true), (&later, false)] {
            let t = topo(m);
            let want = t
                .faces()
                .iter()
                .enumerate()
                .find_map(|(f, &face)| face_contributions(m, f, face).err())
                .expect("a faulty face");
            assert_eq!(
                matches!(want, OperatorError::ZeroLengthEdge { .. }),
                zero_length,
                "{want}"
            );
            for threads in [1, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let got = pool.install(|| mean_value(m, &t)).unwrap_err();
                assert_eq!(got.to_string(), want.to_string(), "{threads} threads");
            }
        }
    }

    #[test]
    fn the_first_faulty_face_is_named_on_any_pool() {
        first_degenerate_face_is_named(mean_value);
    }

    #[test]
    fn positive_weights_and_zero_row_sums() {
        for (name, m) in meshes() {
            let f = mean_value(&m, &topo(&m)).unwrap();
            assert!(max_abs_row_sum(&f) < 1e-14, "{name}");
            let d = f.to_dense();
            for i in 0..d.nrows() {
                for j in 0..d.ncols() {
                    assert!(i == j || d[(i, j)] <= 0.0, "{name}");
                }
            }
        }
    }
}
