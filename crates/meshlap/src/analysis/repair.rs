//! Removal of the SQL's negative weights (Zhang 2004 §3.7): greedy edge swapping and
//! the vertex split the paper names as the alternative.
//!
//! A negative SQL weight `W_ij = 1/d_i + 1/d_j − (1/d_k + 1/d_l)/2 < 0` on an edge
//! (i, j) with opposite vertices k, l means the degrees of i, j are large compared with
//! those of k, l. The greedy loop repeatedly takes the edge with the most negative
//! weight (a priority queue with lazy deletion) and
//!
//! 1. **swaps** it to (k, l) (lowering `d_i, d_j`, raising `d_k, d_l`) when the flip is
//!    legal (interior manifold edge, consistently oriented faces, `k ≠ l`, no edge k–l
//!    yet, so the mesh stays a manifold without duplicate faces; and, if a dihedral
//!    threshold is set, the two new triangles are non-degenerate, keep the old
//!    orientation and meet at a dihedral angle (between normals) at most the
//!    threshold) and helps: the smallest weight among all edges whose weight the flip
//!    changes (the edges of the faces around i, j, k, l) strictly increases;
//! 2. otherwise, with [`RepairMethod::Split`] or [`RepairMethod::SwapSplit`],
//!    **splits** the higher-degree endpoint (then the other) with a progressive-mesh
//!    vertex split ([`crate::mesh::edit::EditMesh::split_vertex`], Hoppe 1996): its
//!    fan is halved (every rotation of the cut is tried, inside; every inner cut
//!    neighbor, on the boundary), the two halves' centres move a third of the way
//!    towards their ring parts' centroids, and the cut that most raises the smallest
//!    affected weight is kept (only if it strictly raises it, and, when a threshold is
//!    set, passes a geometric check: non-degenerate faces, no face turned by 90° or
//!    more from the old fan's normal, the new faces' dihedral angles within the
//!    threshold). A vertex split needs a manifold fan: non-manifold vertices (such as
//!    the teapot's poles) are not split.
//!
//! Only the affected weights are recomputed. For swaps, rule 1 makes the sorted vector
//! of all weights grow lexicographically with every accepted flip, so swapping alone
//! terminates; splits add vertices, so the number of edits is also capped
//! ([`RepairOptions::max_edits`]). The loop stops when no weight is negative or no
//! edit helps; the weights left are reported. Neither heuristic is guaranteed to
//! remove every negative weight (the paper says as much). Degrees and weights use the
//! SQL definition of [`crate::operator::sql`].

use crate::mesh::edit::{EditMesh, NONE};
use crate::mesh::{MeshError, TriMesh};
use glam::DVec3;
use serde::Serialize;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// Why [`repair_sql`] failed.
#[derive(Debug, thiserror::Error)]
pub enum RepairError {
    /// The mesh cannot be edited: a non-manifold edge (split it first, e.g. with the
    /// cleaning's non-manifold splitting) or an out-of-range index.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// The dihedral threshold is not an angle in (0°, 180°].
    #[error("the largest dihedral angle must be in (0°, 180°], got {0}°")]
    Dihedral(f64),
    /// Not the name of a repair method.
    #[error("unknown repair method `{0}` (swap, split, swap-split)")]
    UnknownMethod(String),
}

/// How [`repair_sql`] removes negative weights.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum RepairMethod {
    /// Greedy edge swapping only (the paper's main heuristic).
    #[default]
    Swap,
    /// Vertex splits only (the paper's alternative).
    Split,
    /// Edge swapping, and a vertex split where no swap of the edge helps.
    SwapSplit,
}

crate::names::option_names!(RepairMethod, RepairError, |s| RepairError::UnknownMethod(s.to_string()), {
    Swap => "swap",
    Split => "split",
    SwapSplit => "swap-split",
});

/// Options of [`repair_sql`].
#[derive(Clone, Copy, Debug)]
pub struct RepairOptions {
    /// Largest angle (degrees, in (0, 180]) allowed between the normals of the two
    /// triangles a flip creates; `None` disables the geometric check.
    pub max_dihedral_degrees: Option<f64>,
    /// Swapping, splitting or both.
    pub method: RepairMethod,
    /// Upper bound on the number of edits (flips plus splits).
    pub max_edits: usize,
}

impl Default for RepairOptions {
    fn default() -> Self {
        Self {
            max_dihedral_degrees: None,
            method: RepairMethod::Swap,
            max_edits: 1_000_000,
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
    /// The method used.
    pub method: RepairMethod,
    /// Negative weights (edges) before.
    pub negative_before: usize,
    /// Most negative weight before.
    pub min_weight_before: f64,
    /// Edge flips performed.
    pub flips: usize,
    /// Vertex splits performed.
    pub splits: usize,
    /// Vertices added by the splits (appended after the input's vertices).
    pub vertices_added: usize,
    /// Negative edges for which no legal edit helped (counted each time one is tried).
    pub rejected: usize,
    /// Negative weights after.
    pub negative_after: usize,
    /// Most negative weight after.
    pub min_weight_after: f64,
    /// The negative weights left, most negative first.
    pub remaining: Vec<RemainingWeight>,
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

fn inv_d(m: &EditMesh, v: u32) -> f64 {
    1.0 / m.degree(v) as f64
}

/// SQL weight of the edge of half-edge `h` (Zhang 2004 §3.7; boundary edges use the
/// one opposite vertex).
fn weight(m: &EditMesh, h: u32) -> f64 {
    let base = inv_d(m, m.from(h)) + inv_d(m, m.to(h));
    let t = m.twin(h);
    if t == NONE {
        base - inv_d(m, m.opposite(h))
    } else {
        base - 0.5 * (inv_d(m, m.opposite(h)) + inv_d(m, m.opposite(t)))
    }
}

/// Canonical half-edges (the smaller of a twin pair) of every edge of the faces
/// around `verts`: all the edges whose SQL weight depends on the degrees of `verts`.
fn region(m: &EditMesh, verts: &[u32]) -> Vec<u32> {
    let mut hs: Vec<u32> = verts
        .iter()
        .flat_map(|&v| m.vertex_faces(v).iter())
        .flat_map(|&f| (0..3).map(move |c| 3 * f + c))
        .map(|h| {
            let t = m.twin(h);
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

fn region_min(m: &EditMesh, verts: &[u32]) -> f64 {
    region(m, verts)
        .into_iter()
        .map(|h| weight(m, h))
        .fold(f64::INFINITY, f64::min)
}

fn position(m: &EditMesh, v: u32) -> DVec3 {
    DVec3::from(m.positions()[v as usize])
}
fn face_normal(m: &EditMesh, t: [u32; 3]) -> DVec3 {
    let [a, b, c] = t.map(|v| position(m, v));
    (b - a).cross(c - a)
}
fn angle_deg(a: DVec3, b: DVec3) -> f64 {
    (a.dot(b) / (a.length() * b.length()))
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees()
}

/// Geometric check of a flip of `h` (before flipping): the two new triangles are
/// non-degenerate, keep the old orientation and meet at most at `max_deg`.
fn flip_geometry_ok(m: &EditMesh, h: u32, max_deg: f64) -> bool {
    let g = m.twin(h);
    let (i, j, k, l) = (m.from(h), m.to(h), m.opposite(h), m.opposite(g));
    let (n1, n2) = (face_normal(m, [k, i, l]), face_normal(m, [l, j, k]));
    let o1 = face_normal(m, [i, j, k]);
    let o2 = face_normal(m, [j, i, l]);
    let old = o1 + o2;
    if n1.length_squared() == 0.0
        || n2.length_squared() == 0.0
        || n1.dot(old) <= 0.0
        || n2.dot(old) <= 0.0
    {
        return false;
    }
    angle_deg(n1, n2) <= max_deg
}

/// Geometric check after a split of `v` into `v`, `w` that added `new_faces`: every
/// face around them is non-degenerate and turns less than 90° from the old fan's
/// normal `old`, and each new face meets its neighbors at most at `max_deg`.
fn split_geometry_ok(
    m: &EditMesh,
    v: u32,
    w: u32,
    new_faces: usize,
    old: DVec3,
    max_deg: f64,
) -> bool {
    for &f in m.vertex_faces(v).iter().chain(m.vertex_faces(w)) {
        let n = face_normal(m, m.faces()[f as usize]);
        if n.length_squared() == 0.0 || n.dot(old) <= 0.0 {
            return false;
        }
    }
    (m.n_faces() - new_faces..m.n_faces()).all(|f| {
        let n = face_normal(m, m.faces()[f]);
        (0..3).all(|c| {
            let t = m.twin(3 * f as u32 + c);
            t == NONE || angle_deg(n, face_normal(m, m.faces()[t as usize / 3])) <= max_deg
        })
    })
}

/// Tries to raise the smallest weight around edge (i, j) by splitting i or j
/// (the higher degree first). Candidate cuts halve the fan at every rotation (inside)
/// or at every inner neighbor (on the boundary); the best one that strictly raises
/// the smallest weight of the affected region is kept. Returns the new vertex.
fn try_split(m: &mut EditMesh, i: u32, j: u32, max_dihedral: Option<f64>) -> Option<u32> {
    let mut ends = [i, j];
    if m.degree(j) > m.degree(i) {
        ends.swap(0, 1);
    }
    // The best cut: the smallest affected weight after it, the vertex, the cut and
    // the two new positions.
    struct Cut {
        after: f64,
        v: u32,
        first: usize,
        last: usize,
        pv: [f64; 3],
        pw: [f64; 3],
    }
    let mut best: Option<Cut> = None;
    for v in ends {
        let Some(fan) = m.fan(v) else { continue };
        let nf = fan.out.len();
        let cuts: Vec<(usize, usize)> = if fan.closed {
            if nf < 6 {
                continue; // v and v' would be left with degree < 4
            }
            (0..nf).map(|s| (s, (s + nf / 2) % nf)).collect()
        } else {
            if nf < 4 {
                continue;
            }
            (2..nf - 1).map(|t| (0, t)).collect()
        };
        let p = position(m, v);
        let old_normal: DVec3 = fan
            .out
            .iter()
            .map(|&h| face_normal(m, m.faces()[h as usize / 3]))
            .sum();
        for (first, last) in cuts {
            // v and v' move a third of the way towards the centroids of their parts
            // of the ring (a progressive-mesh vertex split without stored positions).
            let part = |from: usize, to: usize| -> [f64; 3] {
                let mut c = DVec3::ZERO;
                let mut k = 0.0;
                let mut a = from;
                loop {
                    c += position(m, fan.ring[a]);
                    k += 1.0;
                    if a == to {
                        break;
                    }
                    a = (a + 1) % fan.ring.len();
                }
                (p + (c / k - p) / 3.0).to_array()
            };
            let (pv, pw) = if fan.closed {
                (part(first, last), part(last, first))
            } else {
                (part(0, last), part(last, fan.ring.len() - 1))
            };
            let (a, b) = (fan.ring[first], fan.ring[last]);
            let before = region_min(m, &[v, a, b]);
            m.checkpoint();
            let Ok(w) = m.split_vertex(v, first, last, pv, pw) else {
                m.rollback();
                continue;
            };
            let added = if fan.closed { 2 } else { 1 };
            let ok_geometry =
                max_dihedral.is_none_or(|d| split_geometry_ok(m, v, w, added, old_normal, d));
            let after = region_min(m, &[v, w, a, b]);
            m.rollback();
            if ok_geometry && after > before && best.as_ref().is_none_or(|b| after > b.after) {
                best = Some(Cut {
                    after,
                    v,
                    first,
                    last,
                    pv,
                    pw,
                });
            }
        }
        if best.is_some() {
            break;
        }
    }
    let Cut {
        v,
        first,
        last,
        pv,
        pw,
        ..
    } = best?;
    m.split_vertex(v, first, last, pv, pw).ok()
}

/// Removes negative SQL weights by greedy edge swapping and/or vertex splitting;
/// returns the edited mesh and a report. Swapping keeps the vertices and the face
/// count; each vertex split appends one vertex (at the end, so earlier indices are
/// unchanged) and two faces (one on the boundary). Refuses non-manifold edges.
///
/// # Errors
/// [`RepairError::Mesh`] for a mesh with a non-manifold edge;
/// [`RepairError::Dihedral`] for a threshold outside (0°, 180°].
pub fn repair_sql(
    mesh: &TriMesh,
    opts: &RepairOptions,
) -> Result<(TriMesh, RepairReport), RepairError> {
    if let Some(d) = opts.max_dihedral_degrees {
        if !(d > 0.0 && d <= 180.0) {
            return Err(RepairError::Dihedral(d));
        }
    }
    let mut fm = EditMesh::new(mesh)?;
    let before = negative_weights(&fm);
    let mut heap: BinaryHeap<Entry> = before
        .iter()
        .filter_map(|r| {
            let h = canonical(&fm, fm.half_edge(r.i, r.j)?);
            Some(Entry {
                weight: r.weight,
                he: h,
                a: r.i,
                b: r.j,
            })
        })
        .collect();
    let (mut flips, mut splits, mut rejected) = (0usize, 0usize, 0usize);
    let swap = opts.method != RepairMethod::Split;
    let split = opts.method != RepairMethod::Swap;
    while let Some(e) = heap.pop() {
        if flips + splits >= opts.max_edits {
            break;
        }
        // Lazy deletion: the entry is stale if the half-edge no longer joins a–b or
        // its weight changed.
        let h = e.he;
        if h >= fm.n_half_edges()
            || key(fm.from(h), fm.to(h)) != key(e.a, e.b)
            || weight(&fm, h) != e.weight
        {
            continue;
        }
        let mut touched: Option<Vec<u32>> = None;
        if swap
            && fm.can_flip(h).is_ok()
            && opts
                .max_dihedral_degrees
                .is_none_or(|d| flip_geometry_ok(&fm, h, d))
        {
            let g = fm.twin(h);
            let verts = [fm.from(h), fm.to(h), fm.opposite(h), fm.opposite(g)];
            let min_before = region_min(&fm, &verts);
            fm.checkpoint();
            fm.flip(h)?;
            if region_min(&fm, &verts) > min_before {
                fm.commit();
                flips += 1;
                touched = Some(verts.to_vec());
            } else {
                fm.rollback();
            }
        }
        if touched.is_none() && split {
            let (i, j) = (fm.from(h), fm.to(h));
            if let Some(w) = try_split(&mut fm, i, j, opts.max_dihedral_degrees) {
                splits += 1;
                let mut verts: Vec<u32> = vec![i, j, w];
                for &f in fm.vertex_faces(w) {
                    verts.extend(fm.faces()[f as usize]);
                }
                touched = Some(verts);
            }
        }
        let Some(verts) = touched else {
            rejected += 1;
            continue;
        };
        for hh in region(&fm, &verts) {
            let w = weight(&fm, hh);
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
    let remaining = negative_weights(&fm);
    let report = RepairReport {
        method: opts.method,
        negative_before: before.len(),
        min_weight_before: before.first().map_or(0.0, |r| r.weight),
        flips,
        splits,
        vertices_added: fm.n_vertices() - mesh.n_vertices(),
        rejected,
        negative_after: remaining.len(),
        min_weight_after: remaining.first().map_or(0.0, |r| r.weight),
        remaining,
    };
    Ok((fm.into_mesh(), report))
}

fn canonical(m: &EditMesh, h: u32) -> u32 {
    let t = m.twin(h);
    if t != NONE && t < h {
        t
    } else {
        h
    }
}

fn negative_weights(m: &EditMesh) -> Vec<RemainingWeight> {
    let mut out: Vec<RemainingWeight> = (0..m.n_half_edges())
        .filter(|&h| {
            let t = m.twin(h);
            t == NONE || h < t
        })
        .filter_map(|h| {
            let w = weight(m, h);
            (w < 0.0).then(|| RemainingWeight {
                i: m.from(h),
                j: m.to(h),
                weight: w,
            })
        })
        .collect();
    out.sort_by(|a, b| a.weight.total_cmp(&b.weight));
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{builtin, topology::Topology};
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

    /// A fan of `k` triangles around a center on an icosphere-like cap: a closed mesh
    /// with one very high-degree vertex, which makes negative SQL weights.
    fn high_degree_mesh() -> TriMesh {
        let mut m = builtin::icosphere(2).unwrap();
        // Collapse-free construction: add a vertex above face 0..k fan by splitting
        // every face around vertex 0's neighborhood into a cone at a new apex.
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
    fn vertex_splits_remove_negative_weights_and_keep_a_manifold() {
        let m = high_degree_mesh();
        let before = negatives(&m);
        let t = Topology::new(&m).unwrap();
        let chi = |t: &Topology| t.n_vertices() as i64 - t.n_edges() as i64 + t.n_faces() as i64;
        for method in [RepairMethod::Split, RepairMethod::SwapSplit] {
            let opts = RepairOptions {
                method,
                ..Default::default()
            };
            let (fixed, r) = repair_sql(&m, &opts).unwrap();
            assert_eq!(r.negative_before, before);
            assert_eq!(r.negative_after, negatives(&fixed), "{method:?}");
            assert!(r.negative_after < before, "{method:?}: {r:?}");
            assert_eq!(r.vertices_added, fixed.n_vertices() - m.n_vertices());
            assert_eq!(r.vertices_added, r.splits);
            assert_eq!(fixed.n_faces(), m.n_faces() + 2 * r.splits);
            if method == RepairMethod::Split {
                assert!(r.splits > 0 && r.flips == 0);
            }
            let tf = Topology::new(&fixed).unwrap();
            assert!(tf.is_manifold() && tf.boundary_edges().count() == 0);
            assert_eq!(tf.inconsistently_oriented_edges(), 0);
            assert_eq!(chi(&tf), chi(&t));
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
            Err(RepairError::Mesh(MeshError::NonManifoldEdge { .. }))
        ));
    }

    #[test]
    fn bad_options_are_typed_errors() {
        let m = builtin::torus(10, 8).unwrap();
        for d in [0.0, -5.0, 190.0, f64::NAN] {
            let opts = RepairOptions {
                max_dihedral_degrees: Some(d),
                ..Default::default()
            };
            assert!(matches!(
                repair_sql(&m, &opts),
                Err(RepairError::Dihedral(_))
            ));
        }
    }
}
