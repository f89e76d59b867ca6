//! Compressing meshes the connectivity coder cannot represent: the encoder cuts the
//! mesh into one it can (manifold, consistently oriented, every boundary loop at least
//! three edges long), codes that, and codes in the *re-join section* which vertices of
//! the cut mesh are copies of which, so the decoder glues them back together.
//!
//! **Cutting** ([`split`]). Each face corner `3f + k` is a node; corners of the same
//! vertex in two faces that share an edge are joined across that edge when the edge
//! has exactly two faces, runs in opposite directions in them (consistent orientation)
//! and is not marked as cut. The classes are the vertex's *fans*; the first fan met
//! (in face order) keeps the vertex's index, every further fan gets a copy appended
//! after the input's vertices. This is `mesh::clean::split_non_manifold` extended in
//! two ways:
//!
//! * inconsistently oriented edges are cut too, so afterwards every shared edge is
//!   consistent (a Möbius strip is cut open; no face is ever flipped);
//! * a cut that leaves the two faces sharing the edge anyway (a slit whose endpoints
//!   still have one fan each, or two sheets of a non-manifold edge that close up into
//!   a boundary loop of two edges, as two tetrahedra sharing an edge do) is repaired
//!   by also cutting the face's other edge at one endpoint, which detaches that corner.
//!   This repeats until nothing is left to repair; every round adds a cut, so it ends.
//!
//! Faces keep their order and orientation: the cut mesh has exactly the input's faces,
//! some of their corners renamed to copies.
//!
//! **The section** (absent when nothing was cut; then the file is what version 4
//! wrote): one range-coded stream, the number of copies `k` (adaptive Elias-gamma),
//! then one adaptive flag per cut-mesh vertex in the decoded order (the connectivity
//! coder's), "this vertex is a copy", and for each copy the decoded vertex it
//! re-joins, as the distance back from the newest kept vertex (adaptive
//! Elias-gamma). The first vertex
//! of each group met by the traversal is kept, so every copy refers back. Positions are
//! coded once per input vertex (the geometry coders run on the re-joined mesh).
//! Decoding checks that there are exactly `k` copies, each referring to a kept vertex.

use super::entropy::{BitModel, RangeDecoder, RangeEncoder, UintModel};
use super::CodecError;
use crate::mesh::topology::{Topology, UnionFind, INVALID};

/// A mesh cut for the connectivity coder.
#[derive(Clone, Debug)]
pub(super) struct Split {
    /// The input's faces in the input's order, over `parent.len()` vertices.
    pub faces: Vec<[u32; 3]>,
    /// `parent[v]` = the input vertex that cut-mesh vertex `v` stands for (`v` itself
    /// for `v < n`, the copied vertex for the copies `v ≥ n`).
    pub parent: Vec<u32>,
}

impl Split {
    /// Number of vertex copies the cut added.
    pub fn copies(&self, n: usize) -> usize {
        self.parent.len() - n
    }
}

/// Cuts `topo`'s mesh into one the connectivity coder can represent (see the module
/// documentation). A manifold, consistently oriented mesh without two-edge boundary
/// loops comes back unchanged (no copies).
pub(super) fn split(topo: &Topology) -> Result<Split, CodecError> {
    if topo.is_manifold()
        && topo.inconsistently_oriented_edges() == 0
        && corners_to_detach(topo).is_empty()
    {
        // Nothing to cut (the common case): no union-find, no second topology.
        return Ok(Split {
            faces: topo.faces().to_vec(),
            parent: (0..topo.n_vertices() as u32).collect(),
        });
    }
    let nh = 3 * topo.n_faces();
    let mut cut = vec![false; nh];
    for h in 0..nh as u32 {
        let t = topo.twin(h);
        if t != INVALID && topo.from(t) == topo.from(h) {
            cut[h as usize] = true;
        }
    }
    // Each round cuts at least one more half-edge pair, so at most nh rounds.
    for _ in 0..=nh {
        let s = split_fans(topo, &cut);
        let stopo = Topology::from_faces(s.parent.len(), &s.faces).map_err(CodecError::Mesh)?;
        let bad = corners_to_detach(&stopo);
        if bad.is_empty() {
            if stopo.non_manifold_edges().next().is_some()
                || stopo.non_manifold_vertices().next().is_some()
            {
                return Err(CodecError::Internal("the cut mesh is not manifold"));
            }
            return Ok(s);
        }
        let mut progress = false;
        for c in bad {
            // The face's other half-edge at the corner's vertex: the one ending there.
            let f = c / 3;
            let other = 3 * f + (c + 2) % 3;
            for h in [other, topo.twin(other as u32) as usize] {
                if h != INVALID as usize && !cut[h] {
                    cut[h] = true;
                    progress = true;
                }
            }
        }
        if !progress {
            return Err(CodecError::Internal("cutting the mesh made no progress"));
        }
    }
    Err(CodecError::Internal("cutting the mesh did not finish"))
}

/// Groups corners into fans across the uncut two-face edges and names the fans.
fn split_fans(topo: &Topology, cut: &[bool]) -> Split {
    let faces = topo.faces();
    let nh = 3 * faces.len();
    let mut uf = UnionFind::new(nh);
    let next = |h: usize| 3 * (h / 3) + (h + 1) % 3;
    for h in 0..nh {
        let t = topo.twin(h as u32) as usize;
        if t == INVALID as usize || t < h || cut[h] || cut[t] {
            continue;
        }
        // Consistent twins: h runs a → b, t runs b → a. Corner h is a in h's face,
        // corner next(t) is a in t's face; likewise for b.
        uf.union(h, next(t));
        uf.union(next(h), t);
    }
    let n = topo.n_vertices();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    let mut owner = vec![usize::MAX; n];
    let mut name = vec![INVALID; nh];
    let mut out = faces.to_vec();
    for c in 0..nh {
        let v = faces[c / 3][c % 3] as usize;
        let r = uf.find(c);
        if owner[v] == usize::MAX {
            owner[v] = r;
        }
        if owner[v] != r {
            if name[r] == INVALID {
                name[r] = parent.len() as u32;
                parent.push(v as u32);
            }
            out[c / 3][c % 3] = name[r];
        }
    }
    Split { faces: out, parent }
}

/// Corners the cut mesh `stopo` still needs detached: one endpoint's corner of every
/// inconsistently oriented shared edge and of every boundary loop of two edges.
fn corners_to_detach(stopo: &Topology) -> Vec<usize> {
    let nh = 3 * stopo.n_faces();
    let mut bad = Vec::new();
    let mut boundary_out = vec![INVALID; stopo.n_vertices()];
    for h in 0..nh as u32 {
        let t = stopo.twin(h);
        if t == INVALID {
            boundary_out[stopo.from(h) as usize] = h;
        } else if t > h && stopo.from(t) == stopo.from(h) {
            bad.push(h as usize);
        }
    }
    for h in 0..nh as u32 {
        if stopo.twin(h) != INVALID {
            continue;
        }
        let g = boundary_out[stopo.to(h) as usize];
        if g != INVALID && g != h && stopo.to(g) == stopo.from(h) && g > h {
            bad.push(h as usize);
        }
    }
    bad
}

/// The re-join section of a cut mesh coded in the order `order_s` (`order_s[new] =
/// old` cut-mesh vertex), and the map of each new cut-mesh vertex to its re-joined
/// (decoded) vertex with the decoded vertices' input vertices: `(bytes, to_decoded,
/// order)`.
pub(super) fn encode(parent: &[u32], n: usize, order_s: &[u32]) -> (Vec<u8>, Vec<u32>, Vec<u32>) {
    let mut enc = RangeEncoder::new();
    let (mut flag, mut back) = (BitModel::default(), UintModel::default());
    UintModel::default().encode(&mut enc, (parent.len() - n) as u32);
    let mut first = vec![INVALID; n];
    let mut to_decoded = Vec::with_capacity(order_s.len());
    let mut order = Vec::with_capacity(n);
    for &s in order_s {
        let v = parent[s as usize] as usize;
        let copy = first[v] != INVALID;
        enc.bit(&mut flag, copy);
        if copy {
            back.encode(&mut enc, order.len() as u32 - 1 - first[v]);
            to_decoded.push(first[v]);
        } else {
            first[v] = order.len() as u32;
            to_decoded.push(first[v]);
            order.push(v as u32);
        }
    }
    (enc.finish(), to_decoded, order)
}

/// Decodes a re-join section for `n` decoded vertices of a mesh of `n_faces` faces:
/// for each of the `n + k` cut-mesh vertices, its decoded vertex (`< n`). The count
/// `k` is checked against the face corners (a copy needs one) before anything is
/// allocated, and exactly `k` vertices must be copies.
pub(super) fn decode(section: &[u8], n: usize, n_faces: usize) -> Result<Vec<u32>, CodecError> {
    let mut dec = RangeDecoder::new(section);
    let (mut flag, mut back) = (BitModel::default(), UintModel::default());
    let k = UintModel::default().decode(&mut dec)? as usize;
    if k as u64 > 3 * n_faces as u64 {
        return Err(CodecError::Corrupt("more vertex copies than face corners"));
    }
    let mut to_decoded = Vec::with_capacity(n + k);
    let mut kept = 0u32;
    for _ in 0..n + k {
        if dec.bit(&mut flag) {
            let d = back.decode(&mut dec)?;
            if d >= kept {
                return Err(CodecError::Corrupt("a vertex copy refers to no vertex"));
            }
            to_decoded.push(kept - 1 - d);
        } else {
            if kept as usize == n {
                return Err(CodecError::Corrupt(
                    "re-join section keeps too many vertices",
                ));
            }
            to_decoded.push(kept);
            kept += 1;
        }
    }
    if kept as usize != n {
        return Err(CodecError::Corrupt(
            "re-join section keeps too few vertices",
        ));
    }
    dec.finish()?;
    Ok(to_decoded)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cut(faces: &[[u32; 3]], n: usize) -> Split {
        let t = Topology::from_faces(n, faces).unwrap();
        let s = split(&t).unwrap();
        let st = Topology::from_faces(s.parent.len(), &s.faces).unwrap();
        // The cut mesh is what the connectivity coder needs, with the same faces.
        assert!(st.is_manifold(), "{:?}", s.faces);
        assert_eq!(st.inconsistently_oriented_edges(), 0);
        assert!(st.boundary_loops().iter().all(|l| l.len() >= 3));
        let back: Vec<[u32; 3]> = s
            .faces
            .iter()
            .map(|f| f.map(|v| s.parent[v as usize]))
            .collect();
        assert_eq!(back, faces);
        s
    }

    #[test]
    fn manifold_meshes_are_not_cut() {
        let m = crate::mesh::builtin::torus(8, 6).unwrap();
        let s = cut(&m.faces, m.n_vertices());
        assert_eq!(s.copies(m.n_vertices()), 0);
        assert_eq!(s.faces, m.faces);
    }

    #[test]
    fn two_tetrahedra_on_an_edge_and_a_slit() {
        // Two tetrahedra sharing edge (0, 1): four faces on it. Splitting fans alone
        // leaves a boundary loop of two edges in each; a corner is detached per loop.
        let tet = |a: u32, b: u32, c: u32, d: u32| [[a, b, c], [a, c, d], [a, d, b], [b, d, c]];
        let mut faces = tet(0, 1, 2, 3).to_vec();
        faces.extend(tet(1, 0, 4, 5));
        let s = cut(&faces, 6);
        assert!(s.copies(6) >= 2);
        // One flipped face of an octahedron: three inconsistent edges, cut open.
        let mut o = crate::mesh::builtin::octahedron();
        o.faces[0].swap(1, 2);
        let s = cut(&o.faces, o.n_vertices());
        assert!(s.copies(o.n_vertices()) >= 1);
    }

    #[test]
    fn section_round_trip_and_corruption() {
        let parent = vec![0, 1, 2, 3, 0, 2, 0];
        let order_s = vec![4, 1, 2, 0, 5, 3, 6];
        let (bytes, to_dec, order) = encode(&parent, 4, &order_s);
        assert_eq!(order, vec![0, 1, 2, 3]);
        assert_eq!(to_dec, vec![0, 1, 2, 0, 2, 3, 0]);
        assert_eq!(decode(&bytes, 4, 10).unwrap(), to_dec);
        // Three copies need at least one face; a fourth kept vertex is one too many.
        assert!(decode(&bytes, 4, 0).is_err());
        assert!(decode(&bytes, 3, 10).is_err());
        assert!(decode(&[], 4, 10).is_err());
    }
}
