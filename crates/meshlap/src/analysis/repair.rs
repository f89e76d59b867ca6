//! Removal of the SQL's negative weights by greedy edge swapping (Zhang 2004 §3.7).
//!
//! A negative SQL weight `W_ij < 0` on an interior edge (i, j) with opposite vertices
//! k, l means the degrees of i, j are small compared with those of k, l; swapping the
//! edge to (k, l) lowers `d_i, d_j` and raises `d_k, d_l`. The greedy loop repeatedly
//! takes the edge with the most negative weight (a priority queue with lazy deletion)
//! and flips it when
//!
//! 1. the flip is legal: interior manifold edge, `k ≠ l`, no edge k–l yet (so the mesh
//!    stays a manifold without duplicate faces), and, if a dihedral threshold is set,
//!    the two new triangles are non-degenerate, keep the old orientation and meet at
//!    a dihedral angle (between normals) at most the threshold;
//! 2. the flip helps: the smallest weight among all edges whose weight the flip
//!    changes (the edges of the faces around i, j, k, l) strictly increases.
//!
//! Only the affected weights are recomputed. Rule 2 makes the sorted vector of all
//! weights grow lexicographically with every accepted flip, so the loop terminates. It
//! stops when no weight is negative or no legal flip helps; the weights left are
//! reported. Degrees and weights use the SQL definition of [`crate::operator::sql`].

use crate::mesh::{topology::Topology, MeshError, TriMesh};
use serde::Serialize;
use std::cmp::Ordering;
use std::collections::{BinaryHeap, HashSet};

const NONE: u32 = u32::MAX;

/// Options of [`repair_sql`].
#[derive(Clone, Copy, Debug)]
pub struct RepairOptions {
    /// Largest angle (degrees) allowed between the normals of the two triangles a
    /// flip creates; `None` disables the geometric check.
    pub max_dihedral_degrees: Option<f64>,
    /// Upper bound on the number of flips.
    pub max_flips: usize,
}

impl Default for RepairOptions {
    fn default() -> Self {
        Self {
            max_dihedral_degrees: None,
            max_flips: 1_000_000,
        }
    }
}

/// A weight left negative after the repair.
#[derive(Clone, Debug, Serialize)]
pub struct RemainingWeight {
    /// First endpoint.
    pub i: u32,
    /// Second endpoint.
    pub j: u32,
    /// The SQL weight `W_ij`.
    pub weight: f64,
}

/// What [`repair_sql`] did.
#[derive(Clone, Debug, Serialize)]
pub struct RepairReport {
    /// Negative weights (edges) before.
    pub negative_before: usize,
    /// Most negative weight before.
    pub min_weight_before: f64,
    /// Edge flips performed.
    pub flips: usize,
    /// Flips tried and rejected (illegal or not helping).
    pub rejected: usize,
    /// Negative weights after.
    pub negative_after: usize,
    /// Most negative weight after.
    pub min_weight_after: f64,
    /// The negative weights left, most negative first.
    pub remaining: Vec<RemainingWeight>,
}

/// Mutable manifold half-edge mesh for flipping (half-edge `3f + c` as in
/// [`Topology`]).
struct FlipMesh<'a> {
    positions: &'a [[f64; 3]],
    faces: Vec<[u32; 3]>,
    twin: Vec<u32>,
    degree: Vec<u32>,
    vertex_faces: Vec<Vec<u32>>,
    edges: HashSet<(u32, u32)>,
}

#[derive(PartialEq)]
struct Entry {
    weight: f64,
    he: u32,
    a: u32,
    b: u32,
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        // Max-heap on −weight: the most negative weight first; ties by half-edge.
        other
            .weight
            .total_cmp(&self.weight)
            .then(other.he.cmp(&self.he))
    }
}

fn key(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

impl<'a> FlipMesh<'a> {
    fn new(mesh: &'a TriMesh) -> Result<Self, MeshError> {
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
        Ok(FlipMesh {
            positions: &mesh.positions,
            faces: mesh.faces.clone(),
            twin: (0..3 * mesh.n_faces() as u32)
                .map(|h| topo.twin(h))
                .collect(),
            degree: topo.degrees(),
            vertex_faces,
            edges: topo.edges().iter().map(|&[a, b]| (a, b)).collect(),
        })
    }

    fn from(&self, h: u32) -> u32 {
        self.faces[h as usize / 3][h as usize % 3]
    }
    fn to(&self, h: u32) -> u32 {
        self.faces[h as usize / 3][(h as usize + 1) % 3]
    }
    fn opposite(&self, h: u32) -> u32 {
        self.faces[h as usize / 3][(h as usize + 2) % 3]
    }
    fn inv_d(&self, v: u32) -> f64 {
        1.0 / self.degree[v as usize] as f64
    }

    /// SQL weight of the edge of half-edge `h`.
    fn weight(&self, h: u32) -> f64 {
        let base = self.inv_d(self.from(h)) + self.inv_d(self.to(h));
        let t = self.twin[h as usize];
        if t == NONE {
            base - self.inv_d(self.opposite(h))
        } else {
            base - 0.5 * (self.inv_d(self.opposite(h)) + self.inv_d(self.opposite(t)))
        }
    }

    /// Canonical half-edges of every edge of the faces around `verts`.
    fn region(&self, verts: &[u32]) -> Vec<u32> {
        let mut hs: Vec<u32> = verts
            .iter()
            .flat_map(|&v| self.vertex_faces[v as usize].iter())
            .flat_map(|&f| (0..3).map(move |c| 3 * f + c))
            .map(|h| {
                let t = self.twin[h as usize];
                if t != NONE && t < h {
                    t
                } else {
                    h
                }
            })
            .collect();
        hs.sort_unstable();
        hs.dedup();
        hs
    }

    fn region_min(&self, verts: &[u32]) -> f64 {
        self.region(verts)
            .into_iter()
            .map(|h| self.weight(h))
            .fold(f64::INFINITY, f64::min)
    }

    fn legal(&self, h: u32, max_dihedral: Option<f64>) -> bool {
        let g = self.twin[h as usize];
        if g == NONE {
            return false;
        }
        let (k, l) = (self.opposite(h), self.opposite(g));
        if k == l || self.edges.contains(&key(k, l)) {
            return false;
        }
        let Some(max_deg) = max_dihedral else {
            return true;
        };
        let (i, j) = (self.from(h), self.to(h));
        let p = |v: u32| self.positions[v as usize];
        let normal = |a: u32, b: u32, c: u32| {
            let (pa, pb, pc) = (p(a), p(b), p(c));
            let u = [pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]];
            let w = [pc[0] - pa[0], pc[1] - pa[1], pc[2] - pa[2]];
            [
                u[1] * w[2] - u[2] * w[1],
                u[2] * w[0] - u[0] * w[2],
                u[0] * w[1] - u[1] * w[0],
            ]
        };
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let (n1, n2) = (normal(k, i, l), normal(l, j, k));
        let old = {
            let (a, b) = (normal(i, j, k), normal(j, i, l));
            [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
        };
        let (l1, l2) = (dot(n1, n1).sqrt(), dot(n2, n2).sqrt());
        if l1 == 0.0 || l2 == 0.0 || dot(n1, old) <= 0.0 || dot(n2, old) <= 0.0 {
            return false;
        }
        let cos = (dot(n1, n2) / (l1 * l2)).clamp(-1.0, 1.0);
        cos.acos().to_degrees() <= max_deg
    }

    /// Flips the edge of `h` = (i→j) in face (i, j, k), twin in (j, i, l), into faces
    /// (k, i, l) and (l, j, k). Returns the new diagonal's half-edge (l→k).
    fn flip(&mut self, h: u32) -> u32 {
        let g = self.twin[h as usize];
        let (f1, f2) = (h / 3, g / 3);
        let (i, j, k, l) = (self.from(h), self.to(h), self.opposite(h), self.opposite(g));
        let next = |x: u32| if x % 3 == 2 { x - 2 } else { x + 1 };
        let prev = |x: u32| if x % 3 == 0 { x + 2 } else { x - 1 };
        // Outer twins: j→k, k→i (face 1), i→l, l→j (face 2).
        let t_jk = self.twin[next(h) as usize];
        let t_ki = self.twin[prev(h) as usize];
        let t_il = self.twin[next(g) as usize];
        let t_lj = self.twin[prev(g) as usize];
        self.faces[f1 as usize] = [k, i, l];
        self.faces[f2 as usize] = [l, j, k];
        let link = |tw: &mut Vec<u32>, a: u32, b: u32| {
            tw[a as usize] = b;
            if b != NONE {
                tw[b as usize] = a;
            }
        };
        link(&mut self.twin, 3 * f1, t_ki);
        link(&mut self.twin, 3 * f1 + 1, t_il);
        link(&mut self.twin, 3 * f2, t_lj);
        link(&mut self.twin, 3 * f2 + 1, t_jk);
        link(&mut self.twin, 3 * f1 + 2, 3 * f2 + 2);
        self.edges.remove(&key(i, j));
        self.edges.insert(key(k, l));
        self.degree[i as usize] -= 1;
        self.degree[j as usize] -= 1;
        self.degree[k as usize] += 1;
        self.degree[l as usize] += 1;
        self.vertex_faces[i as usize].retain(|&f| f != f2);
        self.vertex_faces[j as usize].retain(|&f| f != f1);
        self.vertex_faces[k as usize].push(f2);
        self.vertex_faces[l as usize].push(f1);
        3 * f1 + 2
    }

    fn negative_weights(&self) -> Vec<RemainingWeight> {
        let mut out: Vec<RemainingWeight> = (0..self.twin.len() as u32)
            .filter(|&h| {
                let t = self.twin[h as usize];
                t == NONE || h < t
            })
            .filter_map(|h| {
                let w = self.weight(h);
                (w < 0.0).then(|| RemainingWeight {
                    i: self.from(h),
                    j: self.to(h),
                    weight: w,
                })
            })
            .collect();
        out.sort_by(|a, b| a.weight.total_cmp(&b.weight));
        out
    }
}

/// Removes negative SQL weights by greedy edge swapping; returns the flipped mesh
/// (same vertices, same number of faces) and a report. Refuses non-manifold edges.
pub fn repair_sql(
    mesh: &TriMesh,
    opts: &RepairOptions,
) -> Result<(TriMesh, RepairReport), MeshError> {
    let mut fm = FlipMesh::new(mesh)?;
    let before = fm.negative_weights();
    let mut heap: BinaryHeap<Entry> = before
        .iter()
        .map(|r| {
            let h = canonical_he(&fm, r.i, r.j);
            Entry {
                weight: r.weight,
                he: h,
                a: r.i,
                b: r.j,
            }
        })
        .collect();
    let (mut flips, mut rejected) = (0usize, 0usize);
    while let Some(e) = heap.pop() {
        if flips >= opts.max_flips {
            break;
        }
        // Lazy deletion: the entry is stale if the half-edge no longer joins a–b or
        // its weight changed.
        let h = e.he;
        if key(fm.from(h), fm.to(h)) != key(e.a, e.b) || fm.weight(h) != e.weight {
            continue;
        }
        if !fm.legal(h, opts.max_dihedral_degrees) {
            rejected += 1;
            continue;
        }
        let g = fm.twin[h as usize];
        let verts = [fm.from(h), fm.to(h), fm.opposite(h), fm.opposite(g)];
        let min_before = fm.region_min(&verts);
        let diag = fm.flip(h);
        let min_after = fm.region_min(&verts);
        if min_after <= min_before {
            fm.flip(diag);
            rejected += 1;
            continue;
        }
        flips += 1;
        for hh in fm.region(&verts) {
            let w = fm.weight(hh);
            if w < 0.0 {
                heap.push(Entry {
                    weight: w,
                    he: hh,
                    a: fm.from(hh),
                    b: fm.to(hh),
                });
            }
        }
    }
    let remaining = fm.negative_weights();
    let report = RepairReport {
        negative_before: before.len(),
        min_weight_before: before.first().map_or(0.0, |r| r.weight),
        flips,
        rejected,
        negative_after: remaining.len(),
        min_weight_after: remaining.first().map_or(0.0, |r| r.weight),
        remaining,
    };
    Ok((TriMesh::new(mesh.positions.clone(), fm.faces), report))
}

fn canonical_he(fm: &FlipMesh<'_>, a: u32, b: u32) -> u32 {
    for &f in &fm.vertex_faces[a as usize] {
        for c in 0..3 {
            let h = 3 * f + c;
            if key(fm.from(h), fm.to(h)) == key(a, b) {
                let t = fm.twin[h as usize];
                return if t != NONE && t < h { t } else { h };
            }
        }
    }
    NONE
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;
    use crate::operator::sql::{sql_diagonal, sql_edge_weights, BoundaryDiagonal};

    fn negatives(m: &TriMesh) -> usize {
        let t = Topology::new(m).unwrap();
        let d: Vec<f64> = t.degrees().iter().map(|&x| x as f64).collect();
        sql_edge_weights(&t, &d)
            .unwrap()
            .iter()
            .filter(|&&w| w < 0.0)
            .count()
    }

    /// A fan of `k` triangles around a centre on an icosphere-like cap: a closed mesh
    /// with one very high-degree vertex, which makes negative SQL weights.
    fn high_degree_mesh() -> TriMesh {
        let mut m = builtin::icosphere(2).unwrap();
        // Collapse-free construction: add a vertex above face 0..k fan by splitting
        // every face around vertex 0's neighbourhood into a cone at a new apex.
        let apex = m.positions.len() as u32;
        m.positions.push([0.0, 0.0, 1.3]);
        let mut faces = Vec::new();
        for f in &m.faces {
            let c = f.map(|v| m.positions[v as usize]);
            let z = (c[0][2] + c[1][2] + c[2][2]) / 3.0;
            if z > 0.75 {
                continue;
            }
            faces.push(*f);
        }
        // Re-close the hole with a cone at the apex.
        let tmp = TriMesh::new(m.positions.clone(), faces.clone());
        let t = Topology::new(&tmp).unwrap();
        for lp in t.boundary_loops() {
            for w in 0..lp.len() {
                let (a, b) = (lp[w], lp[(w + 1) % lp.len()]);
                faces.push([b, a, apex]);
            }
        }
        let m = TriMesh::new(m.positions, faces);
        let (m, _) = crate::mesh::clean::clean(&m, &Default::default()).unwrap();
        m
    }

    #[test]
    fn removes_negative_weights_and_keeps_a_manifold() {
        let m = high_degree_mesh();
        let t = Topology::new(&m).unwrap();
        assert!(t.is_manifold() && t.boundary_edges().count() == 0);
        let before = negatives(&m);
        assert!(before > 0, "test mesh must have negative weights");
        let (fixed, r) = repair_sql(&m, &RepairOptions::default()).unwrap();
        assert_eq!(r.negative_before, before);
        assert_eq!(r.negative_after, negatives(&fixed));
        assert!(r.negative_after < before);
        assert!(r.flips > 0);
        let tf = Topology::new(&fixed).unwrap();
        assert!(tf.is_manifold());
        assert_eq!(tf.inconsistently_oriented_edges(), 0);
        assert_eq!(tf.n_edges(), t.n_edges());
        // Zero row sums survive (the SQL is rebuilt on the new connectivity).
        let d: Vec<f64> = tf.degrees().iter().map(|&x| x as f64).collect();
        let w = sql_edge_weights(&tf, &d).unwrap();
        let diag = sql_diagonal(&tf, &d, BoundaryDiagonal::ZeroRowSum);
        for v in 0..tf.n_vertices() {
            let s: f64 = tf
                .neighbor_edges(crate::VertexId(v as u32))
                .iter()
                .map(|&e| w[e as usize])
                .sum();
            assert!((s - diag[v]).abs() < 1e-13);
        }
    }

    #[test]
    fn no_op_on_regular_meshes() {
        let m = builtin::torus(10, 8).unwrap();
        let (fixed, r) = repair_sql(&m, &RepairOptions::default()).unwrap();
        assert_eq!((r.negative_before, r.flips), (0, 0));
        assert_eq!(fixed, m);
    }

    #[test]
    fn refuses_non_manifold() {
        let m = TriMesh::new(vec![[0.0; 3]; 5], vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]]);
        assert!(matches!(
            repair_sql(&m, &RepairOptions::default()),
            Err(MeshError::NonManifoldEdge { .. })
        ));
    }
}
