//! Editable connectivity: edge flips and vertex splits on a manifold triangle mesh,
//! with an undo journal.
//!
//! [`super::topology::Topology`] is built once and immutable (CSR adjacency, sorted
//! edges); local edits need a different structure. [`EditMesh`] keeps the half-edge
//! convention of `Topology` (half-edge `h = 3·f + c` runs from corner `c` to corner
//! `c + 1` of face `f`; `next`/`prev` are implicit) plus twins, vertex degrees, the
//! faces around each vertex and the set of edges, and updates all of them in O(degree)
//! per edit:
//!
//! - [`EditMesh::flip`]: edge (i, j) with faces (i, j, k), (j, i, l) becomes (k, l) with
//!   faces (k, i, l), (l, j, k); legal when the edge is interior, its faces are
//!   consistently oriented, `k ≠ l` and there is no edge k–l yet (so the mesh stays a
//!   manifold without duplicate faces). Vertices and face count are unchanged.
//! - [`EditMesh::split_vertex`]: the "vertex split" of Hoppe's progressive meshes
//!   (Hoppe 1996), the alternative Zhang (2004, §3.7) names for removing high degrees:
//!   the fan of v is cut at two of its neighbors `a`, `b` into two consecutive parts;
//!   v keeps the first, a new vertex v' takes the second, and the faces (v, b, v'),
//!   (v', a, v) close the gap (one face (v, b, v') for a boundary vertex, whose fan is
//!   cut at one neighbor). The Euler characteristic, manifoldness and orientation are
//!   preserved; d_v + d_v' = d + 4 inside (d + 3 on the boundary), and `a`, `b` gain one.
//!
//! [`EditMesh::checkpoint`] / [`EditMesh::rollback`] undo every edit since the
//! checkpoint exactly (greedy algorithms try an edit, measure, and undo it).
//!
//! Requires a mesh without non-manifold edges; vertex splits also need a manifold,
//! consistently oriented fan at the split vertex (both are checked, with typed errors).

use super::{topology::Topology, MeshError, TriMesh};
use std::collections::HashSet;

/// Marker for "no twin" (boundary half-edge).
pub const NONE: u32 = u32::MAX;

fn key(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

/// The next half-edge in the same face.
fn next(h: u32) -> u32 {
    if h % 3 == 2 {
        h - 2
    } else {
        h + 1
    }
}

/// The previous half-edge in the same face.
fn prev(h: u32) -> u32 {
    if h.is_multiple_of(3) {
        h + 2
    } else {
        h - 1
    }
}

#[derive(Clone, Debug)]
enum Change {
    Face(u32, [u32; 3]),
    Position(u32, [f64; 3]),
    Twin(u32, u32),
    Degree(u32, u32),
    VertexFaces(u32, Vec<u32>),
    EdgeInserted((u32, u32)),
    EdgeRemoved((u32, u32)),
    FacePushed,
    VertexPushed,
}

/// A manifold triangle mesh whose connectivity can be edited; see the module docs.
#[derive(Clone, Debug)]
pub struct EditMesh {
    positions: Vec<[f64; 3]>,
    faces: Vec<[u32; 3]>,
    twin: Vec<u32>,
    degree: Vec<u32>,
    vertex_faces: Vec<Vec<u32>>,
    edges: HashSet<(u32, u32)>,
    journal: Option<Vec<Change>>,
}

/// The fan of a vertex in rotation order (see [`EditMesh::fan`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Fan {
    /// Neighbors `u_0, u_1, …` in rotation order (counter-clockwise for a
    /// counter-clockwise oriented mesh). On the boundary `u_0` and the last one are the
    /// boundary neighbors.
    pub ring: Vec<u32>,
    /// Outgoing half-edge `v → u_a` of the face `(v, u_a, u_{a+1})`, one per face.
    pub out: Vec<u32>,
    /// True for an interior vertex (the faces close around it).
    pub closed: bool,
}

impl EditMesh {
    /// Editable copy of `mesh`. Refuses a non-manifold edge
    /// ([`MeshError::NonManifoldEdge`]) and out-of-range indices.
    pub fn new(mesh: &TriMesh) -> Result<Self, MeshError> {
        let topo = Topology::new(mesh)?;
        if let Some(e) = topo.non_manifold_edges().next() {
            let [a, b] = topo.edge(e);
            return Err(MeshError::NonManifoldEdge {
                a,
                b,
                faces: topo.edge_face_count(e),
            });
        }
        let mut vertex_faces = vec![Vec::new(); mesh.n_vertices()];
        for (f, t) in mesh.faces.iter().enumerate() {
            for &v in t {
                vertex_faces[v as usize].push(f as u32);
            }
        }
        Ok(EditMesh {
            positions: mesh.positions.clone(),
            faces: mesh.faces.clone(),
            twin: (0..3 * mesh.n_faces() as u32)
                .map(|h| topo.twin(h))
                .collect(),
            degree: topo.degrees(),
            vertex_faces,
            edges: topo.edges().iter().map(|&[a, b]| (a, b)).collect(),
            journal: None,
        })
    }

    /// The edited mesh.
    pub fn to_mesh(&self) -> TriMesh {
        TriMesh::new(self.positions.clone(), self.faces.clone())
    }
    /// The edited mesh, consuming `self`.
    pub fn into_mesh(self) -> TriMesh {
        TriMesh::new(self.positions, self.faces)
    }
    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.positions.len()
    }
    /// Number of faces.
    pub fn n_faces(&self) -> usize {
        self.faces.len()
    }
    /// Number of half-edges (3 per face).
    pub fn n_half_edges(&self) -> u32 {
        self.twin.len() as u32
    }
    /// Vertex positions.
    pub fn positions(&self) -> &[[f64; 3]] {
        &self.positions
    }
    /// Faces.
    pub fn faces(&self) -> &[[u32; 3]] {
        &self.faces
    }
    /// Source vertex of half-edge `h`.
    #[inline]
    pub fn from(&self, h: u32) -> u32 {
        self.corner(h, 0)
    }
    /// Target vertex of half-edge `h`.
    #[inline]
    pub fn to(&self, h: u32) -> u32 {
        self.corner(h, 1)
    }
    /// The vertex of `h`'s face opposite to `h`.
    #[inline]
    pub fn opposite(&self, h: u32) -> u32 {
        self.corner(h, 2)
    }
    /// The corner `offset` places after the start of `h` in its face.
    #[inline]
    fn corner(&self, h: u32, offset: usize) -> u32 {
        self.faces[h as usize / 3][(h as usize + offset) % 3]
    }
    /// Twin of `h`, or [`NONE`] on the boundary.
    #[inline]
    pub fn twin(&self, h: u32) -> u32 {
        self.twin[h as usize]
    }
    /// Degree (number of neighbors) of `v`.
    #[inline]
    pub fn degree(&self, v: u32) -> u32 {
        self.degree[v as usize]
    }
    /// Faces incident to `v` (no particular order).
    pub fn vertex_faces(&self, v: u32) -> &[u32] {
        &self.vertex_faces[v as usize]
    }
    /// True when `a` and `b` are joined by an edge.
    pub fn has_edge(&self, a: u32, b: u32) -> bool {
        self.edges.contains(&key(a, b))
    }
    /// Number of undirected edges.
    pub fn n_edges(&self) -> usize {
        self.edges.len()
    }
    /// The half-edge `a → b`, or its twin `b → a` when `a → b` is not in a face.
    pub fn half_edge(&self, a: u32, b: u32) -> Option<u32> {
        let mut found = None;
        for &f in &self.vertex_faces[a as usize] {
            for c in 0..3 {
                let h = 3 * f + c;
                if self.from(h) == a && self.to(h) == b {
                    return Some(h);
                }
                if self.from(h) == b && self.to(h) == a {
                    found = Some(h);
                }
            }
        }
        found
    }

    /// Starts recording edits for [`EditMesh::rollback`] (discarding an earlier record).
    pub fn checkpoint(&mut self) {
        self.journal = Some(Vec::new());
    }
    /// Keeps the edits since the checkpoint and stops recording.
    pub fn commit(&mut self) {
        self.journal = None;
    }
    /// Undoes every edit since [`EditMesh::checkpoint`] and stops recording.
    pub fn rollback(&mut self) {
        let Some(journal) = self.journal.take() else {
            return;
        };
        for change in journal.into_iter().rev() {
            match change {
                Change::Face(f, old) => self.faces[f as usize] = old,
                Change::Position(v, old) => self.positions[v as usize] = old,
                Change::Twin(h, old) => self.twin[h as usize] = old,
                Change::Degree(v, old) => self.degree[v as usize] = old,
                Change::VertexFaces(v, old) => self.vertex_faces[v as usize] = old,
                Change::EdgeInserted(k) => {
                    self.edges.remove(&k);
                }
                Change::EdgeRemoved(k) => {
                    self.edges.insert(k);
                }
                Change::FacePushed => {
                    self.faces.pop();
                    self.twin.truncate(self.twin.len() - 3);
                }
                Change::VertexPushed => {
                    self.positions.pop();
                    self.degree.pop();
                    self.vertex_faces.pop();
                }
            }
        }
    }

    fn log(&mut self, c: Change) {
        if let Some(j) = &mut self.journal {
            j.push(c);
        }
    }
    fn set_face(&mut self, f: u32, t: [u32; 3]) {
        self.log(Change::Face(f, self.faces[f as usize]));
        self.faces[f as usize] = t;
    }
    fn set_twin(&mut self, h: u32, t: u32) {
        self.log(Change::Twin(h, self.twin[h as usize]));
        self.twin[h as usize] = t;
    }
    fn link(&mut self, a: u32, b: u32) {
        self.set_twin(a, b);
        if b != NONE {
            self.set_twin(b, a);
        }
    }
    fn add_degree(&mut self, v: u32, delta: i32) {
        self.log(Change::Degree(v, self.degree[v as usize]));
        self.degree[v as usize] = self.degree[v as usize].wrapping_add_signed(delta);
    }
    fn edit_vertex_faces(&mut self, v: u32, f: impl FnOnce(&mut Vec<u32>)) {
        if self.journal.is_some() {
            self.log(Change::VertexFaces(
                v,
                self.vertex_faces[v as usize].clone(),
            ));
        }
        f(&mut self.vertex_faces[v as usize]);
    }
    fn insert_edge(&mut self, a: u32, b: u32) {
        if self.edges.insert(key(a, b)) {
            self.log(Change::EdgeInserted(key(a, b)));
        }
    }
    fn remove_edge(&mut self, a: u32, b: u32) {
        if self.edges.remove(&key(a, b)) {
            self.log(Change::EdgeRemoved(key(a, b)));
        }
    }
    fn push_face(&mut self, t: [u32; 3]) -> u32 {
        let f = self.faces.len() as u32;
        self.faces.push(t);
        self.twin.extend([NONE; 3]);
        self.log(Change::FacePushed);
        f
    }
    fn push_vertex(&mut self, p: [f64; 3]) -> u32 {
        let v = self.positions.len() as u32;
        self.positions.push(p);
        self.degree.push(0);
        self.vertex_faces.push(Vec::new());
        self.log(Change::VertexPushed);
        v
    }

    fn illegal(&self, h: u32, reason: &'static str) -> MeshError {
        MeshError::IllegalFlip {
            a: self.from(h),
            b: self.to(h),
            reason,
        }
    }

    /// Whether the edge of `h` can be flipped (see the module docs), with the reason
    /// when not.
    pub fn can_flip(&self, h: u32) -> Result<(), MeshError> {
        if h >= self.n_half_edges() {
            return Err(MeshError::IllegalFlip {
                a: u32::MAX,
                b: u32::MAX,
                reason: "no such half-edge",
            });
        }
        let g = self.twin[h as usize];
        if g == NONE {
            return Err(self.illegal(h, "boundary edge"));
        }
        if self.from(g) != self.to(h) {
            return Err(self.illegal(h, "its two faces are inconsistently oriented"));
        }
        let (k, l) = (self.opposite(h), self.opposite(g));
        if k == l {
            return Err(self.illegal(h, "both faces have the same opposite vertex"));
        }
        if self.has_edge(k, l) {
            return Err(self.illegal(h, "the opposite vertices are already joined"));
        }
        Ok(())
    }

    /// Flips the edge of `h` = (i → j) in face (i, j, k), twin in (j, i, l), into faces
    /// (k, i, l) and (l, j, k) (same face slots). Returns the new diagonal's half-edge
    /// (l → k); flipping it restores the connectivity (not necessarily the face slots'
    /// corner order). Illegal flips give [`MeshError::IllegalFlip`] and change nothing.
    pub fn flip(&mut self, h: u32) -> Result<u32, MeshError> {
        self.can_flip(h)?;
        let g = self.twin[h as usize];
        let (f1, f2) = (h / 3, g / 3);
        let (i, j, k, l) = (self.from(h), self.to(h), self.opposite(h), self.opposite(g));
        // Outer twins: j→k, k→i (face 1), i→l, l→j (face 2).
        let t_jk = self.twin[next(h) as usize];
        let t_ki = self.twin[prev(h) as usize];
        let t_il = self.twin[next(g) as usize];
        let t_lj = self.twin[prev(g) as usize];
        self.set_face(f1, [k, i, l]);
        self.set_face(f2, [l, j, k]);
        self.link(3 * f1, t_ki);
        self.link(3 * f1 + 1, t_il);
        self.link(3 * f2, t_lj);
        self.link(3 * f2 + 1, t_jk);
        self.link(3 * f1 + 2, 3 * f2 + 2);
        self.remove_edge(i, j);
        self.insert_edge(k, l);
        self.add_degree(i, -1);
        self.add_degree(j, -1);
        self.add_degree(k, 1);
        self.add_degree(l, 1);
        self.edit_vertex_faces(i, |v| v.retain(|&f| f != f2));
        self.edit_vertex_faces(j, |v| v.retain(|&f| f != f1));
        self.edit_vertex_faces(k, |v| v.push(f2));
        self.edit_vertex_faces(l, |v| v.push(f1));
        Ok(3 * f1 + 2)
    }

    /// The fan of `v` in rotation order, or `None` when `v` is isolated, non-manifold
    /// (several fans) or its fan is inconsistently oriented.
    pub fn fan(&self, v: u32) -> Option<Fan> {
        let faces = &self.vertex_faces[v as usize];
        let outgoing = |f: u32| (0..3).map(|c| 3 * f + c).find(|&h| self.from(h) == v);
        // Start on the boundary if there is one (the face whose v → u_0 half-edge has
        // no twin); rotation goes from (v, u_a, u_{a+1}) to the face across
        // u_{a+1} – v, whose outgoing half-edge is twin(prev(out)).
        let mut start = None;
        for &f in faces {
            let h = outgoing(f)?;
            if self.twin[h as usize] == NONE {
                start = Some(h);
                break;
            }
        }
        let start = start.or_else(|| faces.first().and_then(|&f| outgoing(f)))?;
        let mut fan = Fan {
            ring: Vec::with_capacity(faces.len() + 1),
            out: Vec::with_capacity(faces.len()),
            closed: false,
        };
        let mut h = start;
        loop {
            fan.ring.push(self.to(h));
            fan.out.push(h);
            let t = self.twin[prev(h) as usize];
            if t == NONE {
                fan.ring.push(self.from(prev(h)));
                break;
            }
            if self.from(t) != v {
                return None; // inconsistent orientation inside the fan
            }
            if t == start {
                fan.closed = true;
                break;
            }
            if fan.out.len() > faces.len() {
                return None;
            }
            h = t;
        }
        (fan.out.len() == faces.len()).then_some(fan)
    }

    /// Vertex split (see the module docs) of `v` with fan `u_0, …` (as in
    /// [`EditMesh::fan`]): faces `(v, u_a, u_{a+1})` for `a` from `first` (taken
    /// cyclically) to just before `last` stay with `v`, the rest move to the new vertex
    /// v'. Interior `v`: cut at `a = u_first`, `b = u_last` (`last ≠ first`,
    /// indices mod d), new faces (v, b, v') and (v', a, v). Boundary `v`: `first` must
    /// be 0 and `0 < last < d − 1`; new face (v, u_last, v'). `v` moves to `pos_v`, v' is
    /// placed at `pos_new`. Returns v'.
    pub fn split_vertex(
        &mut self,
        v: u32,
        first: usize,
        last: usize,
        pos_v: [f64; 3],
        pos_new: [f64; 3],
    ) -> Result<u32, MeshError> {
        let illegal = |reason| MeshError::IllegalSplit { vertex: v, reason };
        if v as usize >= self.n_vertices() {
            return Err(illegal("no such vertex"));
        }
        let fan = self
            .fan(v)
            .ok_or(illegal("non-manifold or inconsistently oriented fan"))?;
        let nf = fan.out.len();
        let (first, last) = if fan.closed {
            if first >= nf || last >= nf || first == last {
                return Err(illegal("the cut needs two distinct neighbors"));
            }
            (first, last)
        } else {
            if first != 0 || last == 0 || last >= nf {
                return Err(illegal("a boundary fan is cut at one inner neighbor"));
            }
            (0, last)
        };
        // Faces staying with v: `first..last` (cyclically); the others move to v'.
        let stay = (last + nf - first) % nf;
        let moving: Vec<usize> = (0..nf - stay).map(|s| (last + s) % nf).collect();
        let (a, b) = (fan.ring[first], fan.ring[last]);
        let w = self.push_vertex(pos_new);
        self.set_position(v, pos_v);
        // Re-label v → v' in the moving faces; v's edges to their inner ring
        // vertices become v'’s.
        for &s in &moving {
            let f = fan.out[s] / 3;
            let t = self.faces[f as usize].map(|x| if x == v { w } else { x });
            self.set_face(f, t);
        }
        let moved_faces: Vec<u32> = moving.iter().map(|&s| fan.out[s] / 3).collect();
        self.edit_vertex_faces(v, |vf| vf.retain(|f| !moved_faces.contains(f)));
        self.edit_vertex_faces(w, |vf| vf.extend_from_slice(&moved_faces));
        let d = fan.ring.len();
        // Ring vertices strictly inside the moving part lose v and gain v'.
        let inner: Vec<u32> = if fan.closed {
            (1..nf - stay).map(|s| fan.ring[(last + s) % nf]).collect()
        } else {
            (last + 1..d).map(|s| fan.ring[s]).collect()
        };
        for &u in &inner {
            self.remove_edge(v, u);
            self.insert_edge(w, u);
        }
        // New face (v, b, v'): twins with b → v of the last staying face and with
        // v' → b of the first moving face.
        let fa = self.push_face([v, b, w]);
        let last_stay = fan.out[(last + nf - 1) % nf];
        self.link(3 * fa, prev(last_stay));
        self.link(3 * fa + 1, fan.out[last]);
        self.insert_edge(v, w);
        self.insert_edge(w, b);
        self.edit_vertex_faces(v, |vf| vf.push(fa));
        self.edit_vertex_faces(w, |vf| vf.push(fa));
        self.edit_vertex_faces(b, |vf| vf.push(fa));
        self.add_degree(b, 1);
        if fan.closed {
            // New face (v', a, v): twins with a → v' of the last moving face, with
            // v → a of the first staying face, and with (v, b, v')'s v' → v.
            let fb = self.push_face([w, a, v]);
            let last_move = fan.out[(first + nf - 1) % nf];
            self.link(3 * fb, prev(last_move));
            self.link(3 * fb + 1, fan.out[first]);
            self.link(3 * fb + 2, 3 * fa + 2);
            self.insert_edge(w, a);
            self.edit_vertex_faces(v, |vf| vf.push(fb));
            self.edit_vertex_faces(w, |vf| vf.push(fb));
            self.edit_vertex_faces(a, |vf| vf.push(fb));
            self.add_degree(a, 1);
            // v: u_first..u_last and v'; v': u_last..u_first and v.
            let dv = stay as u32 + 2;
            let dw = (nf - stay) as u32 + 2;
            let old_dv = self.degree[v as usize];
            self.add_degree(v, dv as i32 - old_dv as i32);
            self.add_degree(w, dw as i32);
        } else {
            // v: u_0..u_last and v'; v': u_last..u_{d-1} and v.
            let dv = last as u32 + 2;
            let dw = (d - last) as u32 + 1;
            let old_dv = self.degree[v as usize];
            self.add_degree(v, dv as i32 - old_dv as i32);
            self.add_degree(w, dw as i32);
        }
        Ok(w)
    }

    fn set_position(&mut self, v: u32, p: [f64; 3]) {
        self.log(Change::Position(v, self.positions[v as usize]));
        self.positions[v as usize] = p;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{builtin, VertexId};
    use rand::{Rng, SeedableRng};

    /// Every cached field agrees with a connectivity built from scratch, and the mesh
    /// is a consistently oriented manifold.
    fn assert_consistent(m: &EditMesh) {
        let mesh = m.to_mesh();
        let t = Topology::new(&mesh).unwrap();
        assert!(t.is_manifold());
        assert_eq!(t.inconsistently_oriented_edges(), 0);
        for h in 0..m.n_half_edges() {
            assert_eq!(m.twin(h), t.twin(h), "twin of {h}");
        }
        let degrees = t.degrees();
        for v in 0..m.n_vertices() as u32 {
            assert_eq!(m.degree(v), degrees[v as usize], "degree of {v}");
            let mut vf = m.vertex_faces(v).to_vec();
            vf.sort_unstable();
            let want: Vec<u32> = (0..m.n_faces() as u32)
                .filter(|&f| mesh.faces[f as usize].contains(&v))
                .collect();
            assert_eq!(vf, want, "faces of {v}");
        }
        let mut edges: Vec<(u32, u32)> = m.edges.iter().copied().collect();
        edges.sort_unstable();
        let want: Vec<(u32, u32)> = t.edges().iter().map(|&[a, b]| (a, b)).collect();
        assert_eq!(edges, want);
    }

    fn euler(m: &EditMesh) -> i64 {
        m.n_vertices() as i64 - m.n_edges() as i64 + m.n_faces() as i64
    }

    #[test]
    fn flip_updates_everything_and_flips_back() {
        let mut m = EditMesh::new(&builtin::icosphere(1).unwrap()).unwrap();
        let h = m.half_edge(0, m.fan(0).unwrap().ring[0]).unwrap();
        let (i, j, k, l) = (m.from(h), m.to(h), m.opposite(h), m.opposite(m.twin(h)));
        let (di, dk) = (m.degree(i), m.degree(k));
        let diag = m.flip(h).unwrap();
        assert_consistent(&m);
        assert!(!m.has_edge(i, j) && m.has_edge(k, l));
        assert_eq!((m.degree(i), m.degree(k)), (di - 1, dk + 1));
        assert_eq!(key(m.from(diag), m.to(diag)), key(k, l));
        m.flip(diag).unwrap();
        assert_consistent(&m);
        assert!(m.has_edge(i, j) && !m.has_edge(k, l));
    }

    #[test]
    fn illegal_flips_are_typed_errors_and_change_nothing() {
        // On a tetrahedron every opposite pair is already joined.
        let mut m = EditMesh::new(&builtin::tetrahedron()).unwrap();
        let before = m.faces().to_vec();
        for h in 0..m.n_half_edges() {
            let err = m.flip(h).unwrap_err();
            assert!(err.to_string().contains("already joined"), "{err}");
        }
        assert_eq!(m.faces(), &before[..]);
        // Boundary edges of a grid cannot flip.
        let g = EditMesh::new(&builtin::grid(3).unwrap()).unwrap();
        let h = (0..g.n_half_edges()).find(|&h| g.twin(h) == NONE).unwrap();
        assert!(matches!(g.can_flip(h), Err(MeshError::IllegalFlip { .. })));
        assert!(g.can_flip(g.n_half_edges()).is_err());
    }

    #[test]
    fn interior_split_keeps_a_manifold_and_the_euler_characteristic() {
        let mut m = EditMesh::new(&builtin::icosphere(1).unwrap()).unwrap();
        let v = (0..m.n_vertices() as u32)
            .find(|&v| m.degree(v) == 6)
            .unwrap();
        let fan = m.fan(v).unwrap();
        assert!(fan.closed && fan.ring.len() == 6);
        let (a, b) = (fan.ring[1], fan.ring[4]);
        let (da, db) = (m.degree(a), m.degree(b));
        let chi = euler(&m);
        let p = m.positions()[v as usize];
        let w = m
            .split_vertex(v, 1, 4, p, [p[0] * 1.01, p[1], p[2]])
            .unwrap();
        assert_eq!(w as usize, m.n_vertices() - 1);
        assert_consistent(&m);
        assert_eq!(euler(&m), chi);
        // v keeps u_1..u_4 and v' (5); v' gets u_4, u_5, u_0, u_1 and v (5).
        assert_eq!((m.degree(v), m.degree(w)), (5, 5));
        assert_eq!((m.degree(a), m.degree(b)), (da + 1, db + 1));
        assert!(m.has_edge(v, w) && m.has_edge(w, a) && m.has_edge(w, b));
    }

    #[test]
    fn boundary_split() {
        let grid = builtin::grid(4).unwrap();
        let mut m = EditMesh::new(&grid).unwrap();
        let t = Topology::new(&grid).unwrap();
        let v = (0..m.n_vertices() as u32)
            .find(|&v| t.is_boundary_vertex(VertexId(v)) && m.degree(v) == 4)
            .unwrap();
        let fan = m.fan(v).unwrap();
        assert!(!fan.closed && fan.ring.len() == 4);
        let chi = euler(&m);
        let p = m.positions()[v as usize];
        // Illegal cuts of a boundary fan.
        for (first, last) in [(1, 2), (0, 0), (0, 3)] {
            assert!(matches!(
                m.split_vertex(v, first, last, p, p),
                Err(MeshError::IllegalSplit { .. })
            ));
        }
        assert_consistent(&m);
        let w = m.split_vertex(v, 0, 2, p, [p[0], p[1], 0.1]).unwrap();
        assert_consistent(&m);
        assert_eq!(euler(&m), chi);
        assert_eq!((m.degree(v), m.degree(w)), (4, 3));
        let tw = Topology::new(&m.to_mesh()).unwrap();
        assert_eq!(tw.boundary_loop_count(), 1);
        assert!(tw.is_boundary_vertex(VertexId(w)));
    }

    #[test]
    fn non_manifold_split_and_input_are_refused() {
        let bowtie = TriMesh::new(vec![[0.0; 3]; 5], vec![[0, 1, 2], [0, 3, 4]]);
        let mut m = EditMesh::new(&bowtie).unwrap();
        assert!(m.fan(0).is_none());
        assert!(matches!(
            m.split_vertex(0, 0, 1, [0.0; 3], [0.0; 3]),
            Err(MeshError::IllegalSplit { .. })
        ));
        let three = TriMesh::new(vec![[0.0; 3]; 5], vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]]);
        assert!(matches!(
            EditMesh::new(&three),
            Err(MeshError::NonManifoldEdge { .. })
        ));
    }

    /// Seeded random sequences of flips and splits; rollback restores the exact state.
    #[test]
    fn random_edits_stay_consistent_and_roll_back_exactly() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for mesh in [builtin::icosphere(2).unwrap(), builtin::grid(6).unwrap()] {
            let mut m = EditMesh::new(&mesh).unwrap();
            let chi = euler(&m);
            let (mut flips, mut splits) = (0, 0);
            for round in 0..20 {
                let saved = m.clone();
                m.checkpoint();
                for _ in 0..5 {
                    if rng.gen_bool(0.6) {
                        let h = rng.gen_range(0..m.n_half_edges());
                        flips += usize::from(m.flip(h).is_ok());
                    } else {
                        let v = rng.gen_range(0..m.n_vertices() as u32);
                        if let Some(fan) = m.fan(v) {
                            let n = fan.out.len();
                            let (first, last) = if fan.closed {
                                (rng.gen_range(0..n), rng.gen_range(0..n))
                            } else {
                                (0, rng.gen_range(0..n + 1))
                            };
                            let p = m.positions()[v as usize];
                            splits += usize::from(m.split_vertex(v, first, last, p, p).is_ok());
                        }
                    }
                }
                assert_consistent(&m);
                assert_eq!(euler(&m), chi);
                if round % 2 == 0 {
                    m.rollback();
                    assert_eq!(m.faces, saved.faces);
                    assert_eq!(m.positions, saved.positions);
                    assert_eq!(m.twin, saved.twin);
                    assert_eq!(m.degree, saved.degree);
                    assert_eq!(m.edges, saved.edges);
                    for v in 0..m.n_vertices() {
                        let (mut a, mut b) =
                            (m.vertex_faces[v].clone(), saved.vertex_faces[v].clone());
                        a.sort_unstable();
                        b.sort_unstable();
                        assert_eq!(a, b);
                    }
                } else {
                    m.commit();
                }
            }
            assert!(flips > 10 && splits > 10, "{flips} flips, {splits} splits");
        }
    }
}
