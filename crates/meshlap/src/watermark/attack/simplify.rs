//! Simplification by quadric edge collapse (M. Garland and P. Heckbert, "Surface
//! simplification using quadric error metrics", SIGGRAPH 1997), the benchmark's
//! "simplification".
//!
//! Each vertex carries the quadric `Q = Σ area·ppᵀ` of the planes `p = (n, −n·x)` of
//! its faces, plus, on a boundary edge, the plane through the edge perpendicular to its
//! face with weight 1000·‖e‖² (so open borders are kept). The cost of collapsing edge
//! (a, b) is `v̄ᵀ(Q_a + Q_b)v̄` at the optimal position `v̄` (the minimiser of the
//! quadric when its 3×3 block is well conditioned and `v̄` stays within two edge
//! lengths of the midpoint; otherwise the best of a, b and the midpoint). Edges are
//! collapsed cheapest first (a binary heap with lazy invalidation: entries carry the
//! endpoints' version numbers) until `⌊X/100 · n⌉` vertices are gone. A collapse is
//! refused when it would
//!
//! - break manifoldness: the link condition (the common neighbours of a and b are
//!   exactly the vertices opposite the edge, Dey et al. 1999), an interior edge
//!   joining two boundary vertices, or a vertex left with fewer than three neighbours;
//! - flip or degenerate a face: a surviving face around a or b whose normal would turn
//!   by 90° or more, or whose area would vanish.
//!
//! Each collapse removes exactly one vertex. After a collapse the edges around the new
//! vertex and its neighbours are re-queued, so a collapse refused earlier is retried
//! when its neighbourhood changes. Vertex order of the survivors is the input's.

use super::AttackError;
use crate::mesh::{topology::Topology, EdgeId, MeshError, TriMesh};
use glam::{DMat3, DVec3};
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// A symmetric 4×4 quadric, upper triangle row by row.
#[derive(Copy, Clone, Debug, Default)]
struct Quadric([f64; 10]);

impl Quadric {
    /// `w·ppᵀ` for the plane `n·x + d = 0`.
    fn plane(n: DVec3, d: f64, w: f64) -> Self {
        let p = [n.x, n.y, n.z, d];
        let mut q = [0.0; 10];
        let mut k = 0;
        for i in 0..4 {
            for j in i..4 {
                q[k] = w * p[i] * p[j];
                k += 1;
            }
        }
        Quadric(q)
    }
    fn add(&mut self, o: &Quadric) {
        for k in 0..10 {
            self.0[k] += o.0[k];
        }
    }
    fn eval(&self, v: DVec3) -> f64 {
        let q = &self.0;
        let (x, y, z) = (v.x, v.y, v.z);
        q[0] * x * x
            + 2.0 * q[1] * x * y
            + 2.0 * q[2] * x * z
            + 2.0 * q[3] * x
            + q[4] * y * y
            + 2.0 * q[5] * y * z
            + 2.0 * q[6] * y
            + q[7] * z * z
            + 2.0 * q[8] * z
            + q[9]
    }
    /// The minimiser of the quadric, when its 3×3 block is well conditioned.
    fn minimiser(&self) -> Option<DVec3> {
        let q = &self.0;
        let a = DMat3::from_cols_array(&[q[0], q[1], q[2], q[1], q[4], q[5], q[2], q[5], q[7]]);
        let scale = q[0].abs() + q[4].abs() + q[7].abs();
        let det = a.determinant();
        if !(det.abs() > 1e-12 * scale * scale * scale) {
            return None;
        }
        let x = a.inverse() * DVec3::new(-q[3], -q[6], -q[8]);
        x.is_finite().then_some(x)
    }
}

/// A heap entry: cost and the edge with its endpoints' versions.
#[derive(Copy, Clone, Debug)]
struct Candidate {
    cost: f64,
    a: u32,
    b: u32,
    va: u32,
    vb: u32,
    target: DVec3,
}
impl PartialEq for Candidate {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Candidate {}
impl PartialOrd for Candidate {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Candidate {
    /// Reversed: the cheapest candidate is the heap's maximum (ties by edge).
    fn cmp(&self, o: &Self) -> Ordering {
        o.cost
            .total_cmp(&self.cost)
            .then((o.a, o.b).cmp(&(self.a, self.b)))
    }
}

struct Simplifier {
    pos: Vec<DVec3>,
    faces: Vec<[u32; 3]>,
    face_alive: Vec<bool>,
    vfaces: Vec<Vec<u32>>,
    dead: Vec<bool>,
    version: Vec<u32>,
    quadric: Vec<Quadric>,
    heap: BinaryHeap<Candidate>,
}

impl Simplifier {
    fn new(mesh: &TriMesh) -> Result<Self, MeshError> {
        let topo = Topology::new(mesh)?;
        if let Some(e) = topo.non_manifold_edges().next() {
            let [a, b] = topo.edge(e);
            return Err(MeshError::NonManifoldEdge {
                a,
                b,
                faces: topo.edge_face_count(e),
            });
        }
        let n = mesh.n_vertices();
        let pos: Vec<DVec3> = mesh.positions.iter().map(|&p| DVec3::from(p)).collect();
        let mut quadric = vec![Quadric::default(); n];
        let mut vfaces = vec![Vec::new(); n];
        for (f, t) in mesh.faces.iter().enumerate() {
            let [a, b, c] = t.map(|v| pos[v as usize]);
            let cr = (b - a).cross(c - a);
            let area = 0.5 * cr.length();
            if area > 0.0 {
                let nrm = cr.normalize();
                let q = Quadric::plane(nrm, -nrm.dot(a), area);
                t.iter().for_each(|&v| quadric[v as usize].add(&q));
            }
            t.iter().for_each(|&v| vfaces[v as usize].push(f as u32));
        }
        for e in topo.boundary_edges() {
            let h = topo.edge_half_edge(e);
            let (a, b) = (topo.from(h), topo.to(h));
            let c = topo.opposite_vertex(h);
            let (pa, pb, pc) = (pos[a as usize], pos[b as usize], pos[c as usize]);
            let fnrm = (pb - pa).cross(pc - pa);
            let m = (pb - pa).cross(fnrm);
            if m.length() > 0.0 {
                let m = m.normalize();
                let q = Quadric::plane(m, -m.dot(pa), 1000.0 * (pb - pa).length_squared());
                quadric[a as usize].add(&q);
                quadric[b as usize].add(&q);
            }
        }
        let mut s = Simplifier {
            pos,
            faces: mesh.faces.clone(),
            face_alive: vec![true; mesh.n_faces()],
            vfaces,
            dead: vec![false; n],
            version: vec![0; n],
            quadric,
            heap: BinaryHeap::new(),
        };
        for e in 0..topo.n_edges() {
            let [a, b] = topo.edge(EdgeId(e as u32));
            s.push(a, b);
        }
        Ok(s)
    }

    fn push(&mut self, a: u32, b: u32) {
        let mut q = self.quadric[a as usize];
        q.add(&self.quadric[b as usize]);
        let (pa, pb) = (self.pos[a as usize], self.pos[b as usize]);
        let mid = 0.5 * (pa + pb);
        let reach = 2.0 * (pb - pa).length();
        let target = match q.minimiser() {
            Some(x) if (x - mid).length() <= reach => x,
            _ => [pa, pb, mid]
                .into_iter()
                .min_by(|x, y| q.eval(*x).total_cmp(&q.eval(*y)))
                .unwrap_or(mid),
        };
        self.heap.push(Candidate {
            cost: q.eval(target).max(0.0),
            a,
            b,
            va: self.version[a as usize],
            vb: self.version[b as usize],
            target,
        });
    }

    fn neighbours(&self, v: u32) -> Vec<u32> {
        let mut nb: Vec<u32> = self.vfaces[v as usize]
            .iter()
            .flat_map(|&f| self.faces[f as usize])
            .filter(|&w| w != v)
            .collect();
        nb.sort_unstable();
        nb.dedup();
        nb
    }

    /// True when `v` has an edge with a single face.
    fn is_boundary(&self, v: u32) -> bool {
        let mut count: Vec<(u32, u32)> = Vec::new();
        for &f in &self.vfaces[v as usize] {
            for w in self.faces[f as usize] {
                if w != v {
                    match count.iter_mut().find(|(x, _)| *x == w) {
                        Some(c) => c.1 += 1,
                        None => count.push((w, 1)),
                    }
                }
            }
        }
        count.iter().any(|&(_, c)| c == 1)
    }

    /// The faces containing both `a` and `b`.
    fn edge_faces(&self, a: u32, b: u32) -> Vec<u32> {
        self.vfaces[a as usize]
            .iter()
            .copied()
            .filter(|&f| self.faces[f as usize].contains(&b))
            .collect()
    }

    fn legal(&self, c: &Candidate, shared: &[u32]) -> bool {
        let (a, b) = (c.a, c.b);
        if shared.is_empty() || shared.len() > 2 {
            return false;
        }
        let (na, nb) = (self.neighbours(a), self.neighbours(b));
        let common: Vec<u32> = na.iter().copied().filter(|w| nb.contains(w)).collect();
        let mut opposite: Vec<u32> = shared
            .iter()
            .flat_map(|&f| self.faces[f as usize])
            .filter(|&w| w != a && w != b)
            .collect();
        opposite.sort_unstable();
        if common != opposite {
            return false;
        }
        if shared.len() == 2 && self.is_boundary(a) && self.is_boundary(b) {
            return false;
        }
        if na.len() + nb.len() - 2 - common.len() < 3 {
            return false;
        }
        for v in [a, b] {
            for &f in &self.vfaces[v as usize] {
                if shared.contains(&f) {
                    continue;
                }
                let t = self.faces[f as usize];
                let p = t.map(|w| self.pos[w as usize]);
                let q = t.map(|w| {
                    if w == a || w == b {
                        c.target
                    } else {
                        self.pos[w as usize]
                    }
                });
                let n0 = (p[1] - p[0]).cross(p[2] - p[0]);
                let n1 = (q[1] - q[0]).cross(q[2] - q[0]);
                if n0.dot(n1) <= 0.0 || n1.length() <= 1e-12 * n0.length() {
                    return false;
                }
            }
        }
        true
    }

    /// Collapses `b` into `a` at the candidate's target.
    fn collapse(&mut self, c: &Candidate, shared: &[u32]) {
        let (a, b) = (c.a, c.b);
        for &f in shared {
            self.face_alive[f as usize] = false;
            for w in self.faces[f as usize] {
                self.vfaces[w as usize].retain(|&g| g != f);
            }
        }
        let moved = std::mem::take(&mut self.vfaces[b as usize]);
        for &f in &moved {
            for w in &mut self.faces[f as usize] {
                if *w == b {
                    *w = a;
                }
            }
        }
        self.vfaces[a as usize].extend(moved);
        self.dead[b as usize] = true;
        self.pos[a as usize] = c.target;
        let qb = self.quadric[b as usize];
        self.quadric[a as usize].add(&qb);
        self.version[a as usize] += 1;
        let ring = self.neighbours(a);
        for &w in &ring {
            self.push(a, w);
        }
        for &w in &ring {
            for x in self.neighbours(w) {
                if x != a && w < x {
                    self.push(w, x);
                }
            }
        }
    }
}

/// `mesh` with `percent` % of its vertices removed by quadric edge collapses (module
/// documentation). Non-manifold edges are refused ([`MeshError::NonManifoldEdge`]);
/// [`AttackError::SimplifyStalled`] when no legal collapse is left more than 1 % of
/// the vertices short of the target.
pub fn simplify(mesh: &TriMesh, percent: f64) -> Result<TriMesh, AttackError> {
    let n = mesh.n_vertices();
    let requested = (percent / 100.0 * n as f64).round() as usize;
    let mut s = Simplifier::new(mesh)?;
    let mut removed = 0;
    while removed < requested {
        let Some(c) = s.heap.pop() else { break };
        let (a, b) = (c.a as usize, c.b as usize);
        if s.dead[a] || s.dead[b] || s.version[a] != c.va || s.version[b] != c.vb {
            continue;
        }
        let shared = s.edge_faces(c.a, c.b);
        if s.legal(&c, &shared) {
            s.collapse(&c, &shared);
            removed += 1;
        }
    }
    if removed + n / 100 < requested {
        return Err(AttackError::SimplifyStalled { removed, requested });
    }
    let mut index = vec![u32::MAX; n];
    let mut positions = Vec::with_capacity(n - removed);
    for v in 0..n {
        if !s.dead[v] {
            index[v] = positions.len() as u32;
            positions.push(s.pos[v].to_array());
        }
    }
    let faces = s
        .faces
        .iter()
        .zip(&s.face_alive)
        .filter(|(_, &alive)| alive)
        .map(|(t, _)| t.map(|v| index[v as usize]))
        .collect();
    Ok(TriMesh::new(positions, faces))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;
    use crate::mesh::clean::{clean, CleanOptions, MeshReport};

    fn report(m: &TriMesh) -> MeshReport {
        let (c, r) = clean(m, &CleanOptions::default()).unwrap();
        assert_eq!((c.n_vertices(), c.n_faces()), (m.n_vertices(), m.n_faces()));
        MeshReport::new(&c, &Topology::new(&c).unwrap(), &r)
    }

    #[test]
    fn removes_the_fraction_and_stays_a_closed_manifold() {
        let m = builtin::icosphere(4).unwrap();
        let r0 = report(&m);
        for pct in [10.0, 30.0, 50.0, 70.0] {
            let s = simplify(&m, pct).unwrap();
            let removed = 100.0 * (m.n_vertices() - s.n_vertices()) as f64 / m.n_vertices() as f64;
            assert!((removed - pct).abs() <= 1.0, "{pct}: {removed}");
            let r = report(&s);
            assert_eq!(r.non_manifold_edges + r.non_manifold_vertices, 0, "{pct}");
            assert_eq!(r.boundary_edges, 0, "closed stays closed");
            assert_eq!(r.euler_characteristic, r0.euler_characteristic);
            assert_eq!(r.inconsistently_oriented_edges, 0);
            assert_eq!(r.zero_area_faces, 0);
            // Still close to the unit sphere.
            for p in &s.positions {
                let rad = DVec3::from(*p).length();
                assert!((rad - 1.0).abs() < 0.05, "{pct}: {rad}");
            }
        }
    }

    #[test]
    fn open_meshes_keep_their_border_and_the_result_is_deterministic() {
        let g = builtin::grid(12).unwrap();
        let s = simplify(&g, 50.0).unwrap();
        let r = report(&s);
        assert_eq!(r.boundary_loops, 1);
        assert_eq!(r.non_manifold_edges + r.non_manifold_vertices, 0);
        assert_eq!(s.bounding_box(), g.bounding_box());
        assert_eq!(simplify(&g, 50.0).unwrap(), s);
        // A torus keeps its genus.
        let t = builtin::torus(24, 12).unwrap();
        let st = simplify(&t, 50.0).unwrap();
        assert_eq!(report(&st).genus, Some(1));
        assert_eq!(simplify(&t, 0.0).unwrap(), t);
    }

    #[test]
    fn a_tetrahedron_cannot_be_simplified() {
        let m = builtin::tetrahedron();
        assert!(matches!(
            simplify(&m, 50.0),
            Err(AttackError::SimplifyStalled {
                removed: 0,
                requested: 2
            })
        ));
    }
}
