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
use rayon::prelude::*;
use serde::Serialize;
use std::borrow::Cow;
use std::sync::atomic::{AtomicBool, Ordering};

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
/// [`MeshError::Empty`]. Every pass runs in parallel (rayon, on a worker of the pool)
/// and the result does not depend on the thread count.
pub fn clean(mesh: &TriMesh, opts: &CleanOptions) -> Result<(TriMesh, CleanReport), MeshError> {
    clean_parts(
        Cow::Borrowed(&mesh.positions),
        Cow::Borrowed(&mesh.faces),
        opts,
    )
}

/// As [`clean`], taking the mesh by value: arrays with nothing to drop are moved into
/// the result instead of copied (the usual case for a mesh read from a file).
pub fn clean_owned(
    mesh: TriMesh,
    opts: &CleanOptions,
) -> Result<(TriMesh, CleanReport), MeshError> {
    let TriMesh { positions, faces } = mesh;
    clean_parts(Cow::Owned(positions), Cow::Owned(faces), opts)
}

fn clean_parts(
    positions: Cow<'_, [[f64; 3]]>,
    faces: Cow<'_, [[u32; 3]]>,
    opts: &CleanOptions,
) -> Result<(TriMesh, CleanReport), MeshError> {
    crate::par::on_worker(|| clean_parts_here(positions, faces, opts))
}

/// [`clean_parts`] on the calling thread.
fn clean_parts_here(
    positions: Cow<'_, [[f64; 3]]>,
    faces: Cow<'_, [[u32; 3]]>,
    opts: &CleanOptions,
) -> Result<(TriMesh, CleanReport), MeshError> {
    super::validate_parts(&positions, &faces).or_else(|e| match e {
        MeshError::Empty => Ok(()),
        e => Err(e),
    })?;
    let mut report = CleanReport::default();
    let n = positions.len();
    let degenerate = |f: &[u32; 3]| f[0] == f[1] || f[1] == f[2] || f[0] == f[2];
    if opts.drop_degenerate_faces {
        report.dropped_degenerate_faces = faces.par_iter().filter(|f| degenerate(f)).count();
    }
    let mut faces: Vec<[u32; 3]> = if report.dropped_degenerate_faces > 0 {
        faces
            .par_iter()
            .filter(|f| !degenerate(f))
            .copied()
            .collect()
    } else {
        faces.into_owned()
    };
    if opts.drop_duplicate_faces {
        let repeated = repeated_faces(n, &faces);
        report.dropped_duplicate_faces = repeated.par_iter().filter(|r| **r).count();
        if report.dropped_duplicate_faces > 0 {
            faces = faces
                .par_iter()
                .zip(repeated.par_iter())
                .filter(|(_, r)| !**r)
                .map(|(f, _)| *f)
                .collect();
        }
    }
    let used: Vec<bool> = if opts.drop_unreferenced_vertices {
        let used: Vec<AtomicBool> = (0..n)
            .into_par_iter()
            .map(|_| AtomicBool::new(false))
            .collect();
        // Per face, not `flatten()`: that makes every face a parallel iterator of its
        // own, several times slower (BENCHMARKS.md, "Python API").
        faces.par_iter().with_min_len(1 << 12).for_each(|f| {
            for &v in f {
                used[v as usize].store(true, Ordering::Relaxed);
            }
        });
        used.into_par_iter().map(AtomicBool::into_inner).collect()
    } else {
        Vec::new()
    };
    let unreferenced = used.par_iter().filter(|u| !**u).count();
    let positions = if unreferenced == 0 {
        report.vertex_map = identity_vertex_map(n);
        positions.into_owned()
    } else {
        // Rare: number the kept vertices in order (a sequential scan) and renumber
        // the faces.
        let mut map: Vec<Option<u32>> = vec![None; n];
        let mut next = 0u32;
        for (m, &u) in map.iter_mut().zip(&used) {
            if u {
                *m = Some(next);
                next += 1;
            }
        }
        report.dropped_unreferenced_vertices = unreferenced;
        // Every vertex of a kept face is used, so the map has an entry.
        faces.par_iter_mut().with_min_len(1 << 12).for_each(|f| {
            for v in f {
                *v = map[*v as usize].unwrap_or(0);
            }
        });
        let kept = positions
            .par_iter()
            .zip(used.par_iter())
            .filter(|(_, u)| **u)
            .map(|(p, _)| *p)
            .collect();
        report.vertex_map = map;
        kept
    };
    if faces.is_empty() {
        return Err(MeshError::Empty);
    }
    Ok((TriMesh::new(positions, faces), report))
}

/// The vertex map of a cleaning that kept all `n` vertices.
pub(crate) fn identity_vertex_map(n: usize) -> Vec<Option<u32>> {
    (0..n as u32).into_par_iter().map(Some).collect()
}

/// Checks that a mesh taken as given needs none of [`clean`]'s face removals: every
/// index below `n` ([`MeshError::IndexOutOfRange`]), then no face with a vertex at two
/// corners ([`MeshError::RepeatedCorner`]), then no face with the vertex set of an
/// earlier one ([`MeshError::DuplicateFace`], naming the later copy and the first);
/// each error names the lowest offending face, as a sequential scan would. For front
/// ends that refuse such faces instead of dropping them silently (the Python
/// package's `(V, F)` arguments). Unreferenced vertices are allowed (an isolated
/// vertex gets an empty row in every operator). In parallel, O(faces + n): the
/// duplicates by the same counting sort as cleaning's.
pub fn check_clean(n: usize, faces: &[[u32; 3]]) -> Result<(), MeshError> {
    super::check_face_indices(faces, n)?;
    super::graph::check_distinct_corners(faces)?;
    check_no_duplicates(n, faces)
}

/// [`check_clean`] for faces whose connectivity is built: [`Topology::from_faces`]
/// has refused indices out of range and repeated corners with the same errors, so
/// only duplicates remain, and the twins find them without sorting the faces again.
/// Without an edge of more than two faces, a face with a copy shares each of its
/// three edges with that copy alone, so the twins of its three half-edges all lie in
/// the copy; conversely, three twins in one face mean the same three edges, the same
/// vertex set. One parallel scan of the twins then finds every duplicate. An edge of
/// more than two faces (a face with two copies, or any non-manifold edge) has no
/// twins, and [`check_clean`]'s counting sort runs instead. The same error as
/// [`check_clean`]: [`MeshError::DuplicateFace`] naming the lowest later copy and
/// the first.
pub fn check_clean_given(topology: &Topology) -> Result<(), MeshError> {
    use super::topology::INVALID;
    let faces = topology.faces();
    if topology.non_manifold_edges().next().is_some() {
        return check_no_duplicates(topology.n_vertices(), faces);
    }
    const CHUNK: usize = 1 << 12;
    let twins = topology.twins().as_chunks::<3>().0;
    // The copy of face f comes first when all three twins lie in one earlier face.
    let earlier_copy = |f: usize, t: &[u32; 3]| -> Option<(usize, usize)> {
        let g = t[0] / 3;
        let copy = t[0] != INVALID && t[1] != INVALID && t[2] != INVALID;
        (copy && t[1] / 3 == g && t[2] / 3 == g && (g as usize) < f).then_some((f, g as usize))
    };
    let lowest = twins
        .par_chunks(CHUNK)
        .enumerate()
        .find_map_first(|(c, chunk)| {
            (chunk.iter().enumerate()).find_map(|(k, t)| earlier_copy(c * CHUNK + k, t))
        });
    match lowest {
        Some((face, first)) => Err(MeshError::DuplicateFace { face, first }),
        None => Ok(()),
    }
}

/// The duplicate part of [`check_clean`] (indices below `n`, corners distinct).
fn check_no_duplicates(n: usize, faces: &[[u32; 3]]) -> Result<(), MeshError> {
    let (offsets, entries) = faces_by_smallest_vertex(n, faces);
    let bucket = |v: usize| &entries[offsets[v] as usize..offsets[v + 1] as usize];
    // The lowest later copy over all buckets (each face is in one bucket, so the
    // minimum is unique and does not depend on the split).
    let lowest = (0..n)
        .into_par_iter()
        .with_min_len(4096)
        .filter_map(|v| {
            let mut low: Option<(u32, u32)> = None;
            repeats(bucket(v), |later, first| {
                if low.is_none_or(|(l, _)| later < l) {
                    low = Some((later, first));
                }
            });
            low
        })
        .min();
    match lowest {
        Some((face, first)) => Err(MeshError::DuplicateFace {
            face: face as usize,
            first: first as usize,
        }),
        None => Ok(()),
    }
}

/// A face's vertex set as its three indices ascending.
fn sorted(mut f: [u32; 3]) -> [u32; 3] {
    f.sort_unstable();
    f
}

/// The faces bucketed by their smallest vertex (`mem::bucket_sort`: a histogram per
/// thread, no atomics): bucket starts (n + 1) and, per face, `[middle, largest, face]`,
/// each bucket in face order. Indices must be below `n`.
fn faces_by_smallest_vertex(n: usize, faces: &[[u32; 3]]) -> (Vec<u32>, Vec<[u32; 3]>) {
    crate::mem::bucket_sort::<1, [u32; 3]>(n, faces.len(), [0; 3], |f| {
        let k = sorted(faces[f]);
        [(k[0], [k[1], k[2], f as u32])]
    })
}

/// Calls `hit(later, first)` for every entry of `bucket` (one smallest vertex's faces,
/// in face order, as [`faces_by_smallest_vertex`] gives them) whose vertex set repeats
/// an earlier entry's, with the first face of that set. A bucket holds a vertex's
/// faces (a handful); a large one (a high-degree vertex) is sorted instead of
/// compared pairwise.
fn repeats(bucket: &[[u32; 3]], mut hit: impl FnMut(u32, u32)) {
    if bucket.len() <= 32 {
        for (i, e) in bucket.iter().enumerate().skip(1) {
            if let Some(f) = bucket[..i].iter().find(|f| f[0] == e[0] && f[1] == e[1]) {
                hit(e[2], f[2]);
            }
        }
    } else {
        let mut sorted = bucket.to_vec();
        sorted.sort_unstable();
        for run in sorted.chunk_by(|a, b| a[0] == b[0] && a[1] == b[1]) {
            for e in &run[1..] {
                hit(e[2], run[0][2]);
            }
        }
    }
}

/// For each face, whether an earlier face has the same vertex set (in any order or
/// orientation). Linear time: faces are bucketed by their smallest vertex
/// ([`faces_by_smallest_vertex`]) and compared within their bucket; the buckets with
/// a repeat are found in parallel and marked in order (duplicates are rare).
fn repeated_faces(n: usize, faces: &[[u32; 3]]) -> Vec<bool> {
    let (offsets, entries) = faces_by_smallest_vertex(n, faces);
    let bucket = |v: usize| &entries[offsets[v] as usize..offsets[v + 1] as usize];
    let with_repeats: Vec<usize> = (0..n)
        .into_par_iter()
        .with_min_len(4096)
        .filter(|&v| {
            let mut any = false;
            repeats(bucket(v), |_, _| any = true);
            any
        })
        .collect();
    let mut repeated = vec![false; faces.len()];
    for v in with_repeats {
        repeats(bucket(v), |later, _| repeated[later as usize] = true);
    }
    repeated
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

    /// Inserts, at a random place, a copy of a random face rotated and possibly
    /// reversed (the same vertex set).
    fn plant_duplicate(rng: &mut crate::rng::SplitMix64, faces: &mut Vec<[u32; 3]>) {
        let f = faces[rng.below(faces.len() as u64) as usize];
        let r = rng.below(3) as usize;
        let mut g = [f[r], f[(r + 1) % 3], f[(r + 2) % 3]];
        if rng.below(2) == 1 {
            g.swap(0, 1);
        }
        let at = rng.below(faces.len() as u64 + 1) as usize;
        faces.insert(at, g);
    }

    /// The parallel cleaning equals a sequential reference (a hash set of sorted
    /// vertex triples, first occurrence kept) on random soups with planted duplicates
    /// in every order and orientation, degenerate faces and unused vertices, and does
    /// not depend on the number of threads.
    #[test]
    fn parallel_clean_equals_a_sequential_reference() {
        let mut rng = crate::rng::SplitMix64::new(17);
        for case in 0..6 {
            let n = 50 + 400 * case;
            let mut faces: Vec<[u32; 3]> = (0..3 * n)
                .map(|_| {
                    let mut t = [0u32; 3];
                    for c in &mut t {
                        *c = rng.below(n as u64) as u32;
                    }
                    t
                })
                .collect();
            for _ in 0..n / 4 {
                plant_duplicate(&mut rng, &mut faces);
            }
            let positions = (0..n).map(|i| [i as f64, 0.0, 1.0]).collect();
            let m = TriMesh::new(positions, faces.clone());
            // Reference.
            let mut seen = std::collections::HashSet::new();
            let (mut degenerate, mut duplicate) = (0, 0);
            let mut kept = Vec::new();
            for f in &faces {
                if f[0] == f[1] || f[1] == f[2] || f[0] == f[2] {
                    degenerate += 1;
                    continue;
                }
                let mut k = *f;
                k.sort_unstable();
                if seen.insert(k) {
                    kept.push(*f);
                } else {
                    duplicate += 1;
                }
            }
            let mut used = vec![false; n];
            kept.iter().flatten().for_each(|&v| used[v as usize] = true);
            let mut map = vec![None; n];
            let mut next = 0;
            for v in 0..n {
                if used[v] {
                    map[v] = Some(next);
                    next += 1;
                }
            }
            let kept: Vec<[u32; 3]> = kept
                .iter()
                .map(|f| f.map(|v| map[v as usize].unwrap()))
                .collect();
            for threads in [1, 2, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let (c, r) = pool.install(|| clean(&m, &CleanOptions::default()).unwrap());
                assert_eq!(c.faces, kept, "case {case}, {threads} threads");
                assert_eq!(r.dropped_degenerate_faces, degenerate);
                assert_eq!(r.dropped_duplicate_faces, duplicate);
                assert_eq!(r.dropped_unreferenced_vertices, n - next as usize);
                assert_eq!(r.vertex_map, map);
                assert_eq!(c.n_vertices(), next as usize);
                let (o, ro) = clean_owned(m.clone(), &CleanOptions::default()).unwrap();
                assert_eq!(o, c);
                assert_eq!(ro.vertex_map, r.vertex_map);
            }
        }
    }

    /// `check_clean_given` on closed meshes: none on the icosphere; a face copied once
    /// (its three edges then have three faces: the counting sort), twice, and a
    /// lone pair of faces glued back to back (the twins), each naming the lowest
    /// later copy and the first as `check_clean` does.
    #[test]
    fn check_clean_given_agrees_with_check_clean_on_closed_meshes() {
        let ico = crate::mesh::builtin::icosphere(3).unwrap();
        let n = ico.n_vertices();
        let given = |faces: &[[u32; 3]]| {
            let topology = Topology::from_faces(n, faces).unwrap();
            (check_clean_given(&topology), check_clean(n, faces))
        };
        let (a, b) = given(&ico.faces);
        assert_eq!((a, b), (Ok(()), Ok(())));
        let mut once = ico.faces.clone();
        let f = once[100];
        once.insert(400, [f[2], f[1], f[0]]);
        let mut twice = once.clone();
        twice.insert(300, [f[1], f[2], f[0]]);
        for (faces, face) in [(&once, 400), (&twice, 300)] {
            let (a, b) = given(faces);
            assert_eq!(a, Err(MeshError::DuplicateFace { face, first: 100 }));
            assert_eq!(a, b);
        }
        // A pillow beside the sphere: two faces on three new vertices.
        let mut pillow = ico.faces.clone();
        let m = n as u32;
        pillow.push([m, m + 1, m + 2]);
        pillow.push([m + 1, m, m + 2]);
        let topology = Topology::from_faces(n + 3, &pillow).unwrap();
        assert!(topology.non_manifold_edges().next().is_none());
        let later = ico.faces.len() + 1;
        assert_eq!(
            check_clean_given(&topology),
            Err(MeshError::DuplicateFace {
                face: later,
                first: later - 1
            })
        );
        assert_eq!(check_clean_given(&topology), check_clean(n + 3, &pillow));
    }

    /// `check_clean` names what a sequential scan finds first: the lowest face with a
    /// repeated corner, else the lowest later copy of a face and its first copy; a
    /// cleaned mesh passes. Random soups, planted duplicates in every order and
    /// orientation, 1 to 3 threads.
    #[test]
    fn check_clean_names_what_a_sequential_scan_finds_first() {
        let mut rng = crate::rng::SplitMix64::new(29);
        // Duplicates found by `check_clean_given`'s counting sort and by its twins.
        let mut paths = [0usize; 2];
        for case in 0..12 {
            let n = 20 + 300 * (case % 4);
            let mut faces: Vec<[u32; 3]> = Vec::new();
            while faces.len() < 2 * n {
                let t = [0; 3].map(|_| rng.below(n as u64) as u32);
                if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                    faces.push(t);
                }
            }
            // Cases 0–3 keep the random soup (duplicates only by chance), 4–7 plant
            // duplicates, 8–11 plant duplicates and a degenerate face.
            if case >= 4 {
                for _ in 0..3 {
                    plant_duplicate(&mut rng, &mut faces);
                }
            }
            if case >= 8 {
                let at = rng.below(faces.len() as u64) as usize;
                faces[at][2] = faces[at][0];
            }
            let mut seen = std::collections::HashMap::new();
            let mut expected = Ok(());
            if let Some(face) = faces
                .iter()
                .position(|t| t[0] == t[1] || t[1] == t[2] || t[0] == t[2])
            {
                expected = Err(MeshError::RepeatedCorner {
                    face,
                    vertex: faces[face][0] as usize,
                });
            } else {
                for (i, &f) in faces.iter().enumerate() {
                    if let Some(&first) = seen.get(&sorted(f)) {
                        expected = Err(MeshError::DuplicateFace { face: i, first });
                        break;
                    }
                    seen.insert(sorted(f), i);
                }
            }
            if case >= 4 {
                assert!(expected.is_err(), "case {case}: nothing planted was found");
            }
            for threads in [1, 2, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let got = pool.install(|| check_clean(n, &faces));
                assert_eq!(got, expected, "case {case}, {threads} threads");
                // From the connectivity, where it can be built (no repeated corner).
                if let Ok(topology) = Topology::from_faces(n, &faces) {
                    let got = pool.install(|| check_clean_given(&topology));
                    assert_eq!(got, expected, "case {case}, {threads} threads, given");
                    let by_twins = topology.non_manifold_edges().next().is_none();
                    paths[usize::from(by_twins)] += usize::from(expected.is_err());
                }
            }
            let positions = (0..n).map(|i| [i as f64, 0.0, 1.0]).collect();
            let (c, _) =
                clean_owned(TriMesh::new(positions, faces), &CleanOptions::default()).unwrap();
            assert_eq!(check_clean(c.n_vertices(), &c.faces), Ok(()), "case {case}");
        }
        assert!(paths[0] > 0 && paths[1] > 0, "{paths:?}");
        assert!(matches!(
            check_clean(3, &[[0, 1, 3]]),
            Err(MeshError::IndexOutOfRange {
                face: 0,
                index: 3,
                ..
            })
        ));
    }

    #[test]
    fn validation_names_the_first_offender() {
        let mut p = vec![[0.0; 3]; 100_000];
        let mut f: Vec<[u32; 3]> = (0..100_000u32)
            .map(|i| [i, (i + 1) % 100_000, (i + 2) % 100_000])
            .collect();
        p[70_000][1] = f64::NAN;
        p[90_000][2] = f64::INFINITY;
        f[60_000][2] = 100_000;
        f[80_000][0] = 200_000;
        let m = TriMesh::new(p.clone(), f.clone());
        assert!(matches!(
            m.validate(),
            Err(MeshError::NonFinite { vertex: 70_000 })
        ));
        p[70_000][1] = 0.0;
        p[90_000][2] = 0.0;
        let m = TriMesh::new(p, f);
        assert!(matches!(
            clean(&m, &CleanOptions::default()),
            Err(MeshError::IndexOutOfRange {
                face: 60_000,
                index: 100_000,
                ..
            })
        ));
    }

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
