//! Mesh cleaning (what is removed) and validation (what is only detected).
//!
//! [`clean`] removes, in this order and each counted: faces with a repeated vertex,
//! exact duplicate faces (same three vertices, in any order or orientation; the first
//! is kept), and vertices no face references (the relative order of the others is
//! kept). [`MeshReport`] then describes the cleaned mesh without repairing anything:
//! non-manifold edges and vertices, inconsistently oriented neighbours, components,
//! boundary loops, zero-area faces, Euler characteristic and genus, degrees.
//! [`split_non_manifold`] is the one repair: it makes a manifold mesh by duplicating
//! vertices.

use super::topology::{Topology, UnionFind};
use super::{MeshError, TriMesh};
use serde::Serialize;

/// What [`clean`] removes. All on by default.
#[derive(Clone, Copy, Debug)]
pub struct CleanOptions {
    /// Drop faces that use a vertex twice.
    pub drop_degenerate_faces: bool,
    /// Drop exact duplicate faces (same vertex set), keeping the first.
    pub drop_duplicate_faces: bool,
    /// Drop vertices no face references, keeping the order of the others.
    pub drop_unreferenced_vertices: bool,
}

impl Default for CleanOptions {
    fn default() -> Self {
        Self {
            drop_degenerate_faces: true,
            drop_duplicate_faces: true,
            drop_unreferenced_vertices: true,
        }
    }
}

/// Counts of what [`clean`] removed, and the vertex map it applied.
#[derive(Clone, Debug, Default, Serialize)]
pub struct CleanReport {
    /// Vertices no face referenced.
    pub dropped_unreferenced_vertices: usize,
    /// Faces with a repeated vertex.
    pub dropped_degenerate_faces: usize,
    /// Faces that repeated an earlier face.
    pub dropped_duplicate_faces: usize,
    /// For each input vertex, its index in the cleaned mesh (`None` if dropped).
    #[serde(skip)]
    pub vertex_map: Vec<Option<u32>>,
}

/// Cleans `mesh` (see the module documentation). The input must satisfy
/// [`TriMesh::validate`] except for emptiness; an empty result is
/// [`MeshError::Empty`].
pub fn clean(mesh: &TriMesh, opts: &CleanOptions) -> Result<(TriMesh, CleanReport), MeshError> {
    mesh.validate().or_else(|e| match e {
        MeshError::Empty => Ok(()),
        e => Err(e),
    })?;
    let mut report = CleanReport::default();
    let n = mesh.n_vertices();
    let mut faces: Vec<[u32; 3]> = Vec::with_capacity(mesh.n_faces());
    for f in &mesh.faces {
        if opts.drop_degenerate_faces && (f[0] == f[1] || f[1] == f[2] || f[0] == f[2]) {
            report.dropped_degenerate_faces += 1;
        } else {
            faces.push(*f);
        }
    }
    if opts.drop_duplicate_faces {
        let keep = first_occurrences(n, &faces);
        let before = faces.len();
        faces = faces
            .into_iter()
            .zip(keep)
            .filter_map(|(f, k)| k.then_some(f))
            .collect();
        report.dropped_duplicate_faces = before - faces.len();
    }
    let mut map: Vec<Option<u32>> = (0..n as u32).map(Some).collect();
    let mut positions = Vec::new();
    if !opts.drop_unreferenced_vertices {
        positions = mesh.positions.clone();
    } else {
        let mut used = vec![false; n];
        for f in &faces {
            for &v in f {
                used[v as usize] = true;
            }
        }
        let mut next = 0u32;
        positions.reserve(n);
        for (v, &u) in used.iter().enumerate() {
            if u {
                map[v] = Some(next);
                positions.push(mesh.positions[v]);
                next += 1;
            } else {
                map[v] = None;
            }
        }
        report.dropped_unreferenced_vertices = n - next as usize;
        for f in &mut faces {
            for v in f.iter_mut() {
                // Every vertex of a kept face is used, so the map has an entry.
                *v = map[*v as usize].unwrap_or(0);
            }
        }
    }
    report.vertex_map = map;
    if faces.is_empty() {
        return Err(MeshError::Empty);
    }
    Ok((TriMesh::new(positions, faces), report))
}

/// For each face, whether it is the first with its vertex set. Linear time: faces are
/// bucketed by their smallest vertex (counting sort) and compared within buckets.
fn first_occurrences(n: usize, faces: &[[u32; 3]]) -> Vec<bool> {
    let key = |f: &[u32; 3]| {
        let mut k = *f;
        k.sort_unstable();
        k
    };
    let mut offsets = vec![0u32; n + 1];
    for f in faces {
        offsets[key(f)[0] as usize + 1] += 1;
    }
    for i in 0..n {
        offsets[i + 1] += offsets[i];
    }
    let mut fill = offsets.clone();
    let mut order = vec![0u32; faces.len()];
    for (i, f) in faces.iter().enumerate() {
        let b = key(f)[0] as usize;
        order[fill[b] as usize] = i as u32;
        fill[b] += 1;
    }
    let mut keep = vec![true; faces.len()];
    for v in 0..n {
        let bucket = &order[offsets[v] as usize..offsets[v + 1] as usize];
        for (a, &i) in bucket.iter().enumerate() {
            let ki = key(&faces[i as usize]);
            // Buckets keep input order, so an earlier equal face is the original.
            if bucket[..a]
                .iter()
                .any(|&j| keep[j as usize] && key(&faces[j as usize]) == ki)
            {
                keep[i as usize] = false;
            }
        }
    }
    keep
}

/// Vertex-degree statistics.
#[derive(Clone, Debug, Default, Serialize)]
pub struct DegreeStats {
    /// Smallest degree.
    pub min: usize,
    /// Mean degree.
    pub mean: f64,
    /// Largest degree.
    pub max: usize,
    /// `histogram[d]` = number of vertices of degree `d`.
    pub histogram: Vec<usize>,
}

/// Everything `meshlap info` reports about a (cleaned) mesh.
#[derive(Clone, Debug, Default, Serialize)]
pub struct MeshReport {
    /// Number of vertices.
    pub vertices: usize,
    /// Number of triangles.
    pub faces: usize,
    /// Number of undirected edges.
    pub edges: usize,
    /// Edges with one incident face.
    pub boundary_edges: usize,
    /// Connected components of the boundary-edge graph.
    pub boundary_loops: usize,
    /// Connected components of the mesh graph.
    pub components: usize,
    /// V − E + F.
    pub euler_characteristic: i64,
    /// Total genus Σ gᵢ = (2·components − χ)/2, given for closed, manifold,
    /// consistently oriented meshes only.
    pub genus: Option<i64>,
    /// Edges with more than two faces.
    pub non_manifold_edges: usize,
    /// Vertices whose faces are not a single fan.
    pub non_manifold_vertices: usize,
    /// Interior edges whose two faces have opposite orientations.
    pub inconsistently_oriented_edges: usize,
    /// Faces whose area is at most 1e-12 × (longest edge)².
    pub zero_area_faces: usize,
    /// Vertex degree statistics.
    pub degree: DegreeStats,
    /// Bounding box minimum.
    pub bbox_min: [f64; 3],
    /// Bounding box maximum.
    pub bbox_max: [f64; 3],
    /// Bounding-box diagonal length.
    pub bbox_diagonal: f64,
    /// Vertices dropped because no face referenced them.
    pub dropped_unreferenced_vertices: usize,
    /// Faces dropped for a repeated vertex.
    pub dropped_degenerate_faces: usize,
    /// Faces dropped as duplicates.
    pub dropped_duplicate_faces: usize,
}

impl MeshReport {
    /// Measures `mesh` through its `topology`; `clean` supplies the dropped counts.
    pub fn new(mesh: &TriMesh, topology: &Topology, clean: &CleanReport) -> Self {
        let (v, e, f) = (mesh.n_vertices(), topology.n_edges(), mesh.n_faces());
        let euler = v as i64 - e as i64 + f as i64;
        let (_, components) = topology.components();
        let boundary_edges = topology.boundary_edges().count();
        let non_manifold_edges = topology.non_manifold_edges().count();
        let non_manifold_vertices = topology.non_manifold_vertices().count();
        let inconsistent = topology.inconsistently_oriented_edges();
        let genus = (boundary_edges == 0
            && non_manifold_edges == 0
            && non_manifold_vertices == 0
            && inconsistent == 0)
            .then(|| (2 * components as i64 - euler) / 2);
        let degrees = topology.degrees();
        let max = degrees.iter().copied().max().unwrap_or(0) as usize;
        let mut histogram = vec![0usize; max + 1];
        for &d in &degrees {
            histogram[d as usize] += 1;
        }
        let degree = DegreeStats {
            min: degrees.iter().copied().min().unwrap_or(0) as usize,
            mean: if v > 0 {
                degrees.iter().map(|&d| d as f64).sum::<f64>() / v as f64
            } else {
                0.0
            },
            max,
            histogram,
        };
        let (bbox_min, bbox_max) = mesh.bounding_box().unwrap_or(([0.0; 3], [0.0; 3]));
        MeshReport {
            vertices: v,
            faces: f,
            edges: e,
            boundary_edges,
            boundary_loops: topology.boundary_loop_count(),
            components,
            euler_characteristic: euler,
            genus,
            non_manifold_edges,
            non_manifold_vertices,
            inconsistently_oriented_edges: inconsistent,
            zero_area_faces: zero_area_faces(mesh),
            degree,
            bbox_min,
            bbox_max,
            bbox_diagonal: mesh.bbox_diagonal(),
            dropped_unreferenced_vertices: clean.dropped_unreferenced_vertices,
            dropped_degenerate_faces: clean.dropped_degenerate_faces,
            dropped_duplicate_faces: clean.dropped_duplicate_faces,
        }
    }
}

/// Number of faces with area ≤ 1e-12 × (longest edge)² (including exactly zero).
pub fn zero_area_faces(mesh: &TriMesh) -> usize {
    mesh.faces
        .iter()
        .filter(|f| {
            let [a, b, c] = f.map(|v| mesh.positions[v as usize]);
            let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let w = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
            let x = [
                u[1] * w[2] - u[2] * w[1],
                u[2] * w[0] - u[0] * w[2],
                u[0] * w[1] - u[1] * w[0],
            ];
            let area2 = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt();
            let len2 = |p: [f64; 3], q: [f64; 3]| {
                (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)
            };
            let longest = len2(a, b).max(len2(b, c)).max(len2(c, a));
            area2 <= 2e-12 * longest
        })
        .count()
}

/// What [`split_non_manifold`] did.
#[derive(Clone, Debug, Default, Serialize)]
pub struct SplitReport {
    /// Vertex copies appended to the mesh.
    pub vertices_added: usize,
    /// Non-manifold edges before the split.
    pub non_manifold_edges_before: usize,
    /// Non-manifold vertices before the split.
    pub non_manifold_vertices_before: usize,
}

/// Makes `mesh` manifold by duplicating vertices along non-manifold edges and at
/// non-manifold vertices.
///
/// Around each vertex, the face corners are grouped into fans: two faces are in the
/// same fan when they share an edge at that vertex which has exactly two faces (a
/// non-manifold edge is treated as a cut). The first fan of a vertex keeps its index;
/// every further fan gets a copy of the vertex, appended after the original vertices.
/// A fan is a path or a cycle of faces, so it holds at most two faces of any cut edge:
/// afterwards every edge has at most two faces and every vertex is a single fan.
pub fn split_non_manifold(mesh: &TriMesh) -> Result<(TriMesh, SplitReport), MeshError> {
    let topo = Topology::new(mesh)?;
    let mut report = SplitReport {
        non_manifold_edges_before: topo.non_manifold_edges().count(),
        non_manifold_vertices_before: topo.non_manifold_vertices().count(),
        ..Default::default()
    };
    let nh = 3 * mesh.n_faces();
    // Corner c of face f is index 3f + c; union corners of the same vertex across
    // manifold (two-face) edges.
    let mut uf = UnionFind::new(nh);
    for h in 0..nh as u32 {
        let t = topo.twin(h);
        if t == INVALID_TWIN || t < h {
            continue;
        }
        for v in [topo.from(h), topo.to(h)] {
            let ch = corner_of(mesh, h / 3, v);
            let ct = corner_of(mesh, t / 3, v);
            uf.union(ch, ct);
        }
    }
    let mut positions = mesh.positions.clone();
    let mut faces = mesh.faces.clone();
    // For each vertex, the first fan root seen keeps the vertex; others get copies.
    let mut owner_root = vec![usize::MAX; mesh.n_vertices()];
    let mut copy_of_root: std::collections::HashMap<usize, u32> = Default::default();
    for c in 0..nh {
        let (f, k) = (c / 3, c % 3);
        let v = mesh.faces[f][k] as usize;
        let r = uf.find(c);
        if owner_root[v] == usize::MAX {
            owner_root[v] = r;
        }
        if owner_root[v] != r {
            let idx = *copy_of_root.entry(r).or_insert_with(|| {
                positions.push(mesh.positions[v]);
                (positions.len() - 1) as u32
            });
            faces[f][k] = idx;
        }
    }
    report.vertices_added = positions.len() - mesh.n_vertices();
    Ok((TriMesh::new(positions, faces), report))
}

const INVALID_TWIN: u32 = super::topology::INVALID;

fn corner_of(mesh: &TriMesh, f: u32, v: u32) -> usize {
    let t = mesh.faces[f as usize];
    let k = t.iter().position(|&x| x == v).unwrap_or(0);
    3 * f as usize + k
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;

    #[test]
    fn drops_and_counts() {
        let m = TriMesh::new(
            vec![
                [0.0; 3],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [9.0; 3],
                [1.0, 1.0, 0.0],
            ],
            vec![[0, 1, 2], [2, 1, 0], [0, 0, 1], [1, 4, 2]],
        );
        let (c, r) = clean(&m, &CleanOptions::default()).unwrap();
        assert_eq!(r.dropped_degenerate_faces, 1);
        assert_eq!(r.dropped_duplicate_faces, 1);
        assert_eq!(r.dropped_unreferenced_vertices, 1);
        assert_eq!(c.faces, vec![[0, 1, 2], [1, 3, 2]]);
        assert_eq!(c.positions[3], [1.0, 1.0, 0.0]);
        assert_eq!(r.vertex_map[3], None);
        assert_eq!(r.vertex_map[4], Some(3));
    }

    #[test]
    fn empty_after_cleaning_is_an_error() {
        let m = TriMesh::new(vec![[0.0; 3]; 3], vec![[0, 0, 1]]);
        assert_eq!(
            clean(&m, &CleanOptions::default()).unwrap_err(),
            MeshError::Empty
        );
    }

    #[test]
    fn report_of_a_cube() {
        let m = builtin::cube(3).unwrap();
        let (m, cr) = clean(&m, &CleanOptions::default()).unwrap();
        let t = Topology::new(&m).unwrap();
        let r = MeshReport::new(&m, &t, &cr);
        assert_eq!(r.euler_characteristic, 2);
        assert_eq!(r.genus, Some(0));
        assert_eq!(r.components, 1);
        // Closed genus 0: E = 3V − 6, so the mean degree is 6 − 12/V.
        let v = r.vertices as f64;
        assert!((r.degree.mean - (6.0 - 12.0 / v)).abs() < 1e-12);
        assert!(r.degree.min >= 3 && r.degree.max <= 6);
        assert_eq!(r.degree.histogram.iter().sum::<usize>(), r.vertices);
        assert_eq!(r.zero_area_faces, 0);
        let torus = builtin::torus(12, 8).unwrap();
        let tt = Topology::new(&torus).unwrap();
        assert_eq!(MeshReport::new(&torus, &tt, &cr).genus, Some(1));
    }

    #[test]
    fn split_fixes_a_three_sheet_edge_and_a_bowtie() {
        let m = TriMesh::new(
            vec![[0.0; 3]; 8],
            vec![[0, 1, 2], [1, 0, 3], [0, 1, 4], [0, 5, 6], [0, 6, 7]],
        );
        let (s, r) = split_non_manifold(&m).unwrap();
        assert_eq!(r.non_manifold_edges_before, 1);
        let t = Topology::new(&s).unwrap();
        assert!(t.is_manifold(), "{:?}", s.faces);
        // Vertex 0 is in four fans (each sheet of the edge alone, plus the bowtie
        // fan {3, 4}), vertex 1 in three: 3 + 2 copies.
        assert_eq!(r.vertices_added, 5);
        assert_eq!(t.non_manifold_edges().count(), 0);
    }

    #[test]
    fn split_leaves_manifold_meshes_alone() {
        let m = builtin::icosphere(2).unwrap();
        let (s, r) = split_non_manifold(&m).unwrap();
        assert_eq!(r.vertices_added, 0);
        assert_eq!(s, m);
    }
}
