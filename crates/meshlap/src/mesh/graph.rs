//! The vertex graph of a triangle mesh: its faces and the sorted neighbour lists
//! (CSR) of its vertices, without the half-edges of [`super::topology::Topology`].
//!
//! What the partition ([`crate::partition`]) and the spectral codec's patches,
//! predictors and residuals read: neighbours and faces, never twins or fans. A
//! [`Topology`](super::topology::Topology) holds one
//! ([`Topology::graph`](super::topology::Topology::graph)); the `.mlz` decoder builds
//! one alone ([`VertexGraph::from_faces`]), at about a third of the cost of the
//! half-edges.
//!
//! Construction: each face gives each corner its two other corners; the entries are
//! bucketed by vertex (`mem::bucket_sort`: a histogram and a scatter per
//! thread over its range of faces), each bucket is sorted and deduplicated in
//! parallel, and the buckets are packed. The result does not depend on the thread
//! count.

use super::{MeshError, VertexId};
use crate::mem::Scatter;
use rayon::prelude::*;

/// Faces and vertex adjacency of a triangle mesh; see the module documentation.
#[derive(Clone, Debug)]
pub struct VertexGraph {
    pub(super) n: usize,
    pub(super) faces: Vec<[u32; 3]>,
    pub(super) offsets: Vec<u32>,
    pub(super) adj: Vec<u32>,
}

impl VertexGraph {
    /// The graph of `n` vertices joined by the edges of `faces`. An out-of-range
    /// index gives [`MeshError::IndexOutOfRange`], a face with a repeated vertex
    /// [`MeshError::RepeatedCorner`], more than [`super::topology::MAX_FACES`]
    /// faces [`MeshError::TooManyFaces`] — the checks of
    /// [`Topology::from_faces`](super::topology::Topology::from_faces), whose
    /// [`neighbors`](super::topology::Topology::neighbors) are the same lists.
    pub fn from_faces(n: usize, faces: &[[u32; 3]]) -> Result<Self, MeshError> {
        check_faces(n, faces)?;
        // Each corner's two other corners, bucketed by corner.
        let (start, mut raw) = crate::mem::bucket_sort(n, faces.len(), 0u32, |f| {
            let [a, b, c] = faces[f];
            [(a, b), (a, c), (b, c), (b, a), (c, a), (c, b)]
        });
        // Sort and deduplicate each bucket in place, over blocks of vertices.
        let block = (n / (8 * rayon::current_num_threads().max(1))).clamp(1, 4096);
        let mut blocks: Vec<(usize, &mut [u32])> = Vec::new();
        {
            let mut rest: &mut [u32] = &mut raw;
            let mut lo = 0;
            while lo < n {
                let hi = (lo + block).min(n);
                let (head, tail) = rest.split_at_mut((start[hi] - start[lo]) as usize);
                blocks.push((lo, head));
                rest = tail;
                lo = hi;
            }
        }
        let mut degree = vec![0u32; n];
        {
            let deg = Scatter::new(&mut degree);
            blocks.into_par_iter().for_each(|(lo, slice)| {
                let base = start[lo] as usize;
                let mut v = lo;
                while v < n && (start[v] as usize) < base + slice.len() {
                    let row = &mut slice[start[v] as usize - base..start[v + 1] as usize - base];
                    row.sort_unstable();
                    let mut k = 0;
                    for i in 0..row.len() {
                        if i == 0 || row[i] != row[k - 1] {
                            row[k] = row[i];
                            k += 1;
                        }
                    }
                    // SAFETY: vertex v is in this block only.
                    unsafe { deg.write(v, k as u32) };
                    v += 1;
                }
            });
        }
        let mut offsets = vec![0u32; n + 1];
        for v in 0..n {
            offsets[v + 1] = offsets[v] + degree[v];
        }
        let mut adj = crate::mem::zeroed_vec(0u32, offsets[n] as usize);
        {
            let out = Scatter::new(&mut adj);
            (0..n).into_par_iter().with_min_len(1 << 12).for_each(|v| {
                let (s, o) = (start[v] as usize, offsets[v] as usize);
                for i in 0..degree[v] as usize {
                    // SAFETY: row v's packed range is its own.
                    unsafe { out.write(o + i, raw[s + i]) };
                }
            });
        }
        Ok(Self {
            n,
            faces: faces.to_vec(),
            offsets,
            adj,
        })
    }

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.n
    }
    /// The faces the graph was built from.
    pub fn faces(&self) -> &[[u32; 3]] {
        &self.faces
    }
    /// Neighbours of `v`, ascending, each once.
    #[inline]
    pub fn neighbors(&self, v: VertexId) -> &[u32] {
        &self.adj[self.offsets[v.idx()] as usize..self.offsets[v.idx() + 1] as usize]
    }
    /// Number of neighbours of `v`.
    #[inline]
    pub fn degree(&self, v: VertexId) -> usize {
        (self.offsets[v.idx() + 1] - self.offsets[v.idx()]) as usize
    }
    /// CSR row offsets of the adjacency (`n + 1` entries).
    pub fn adjacency_offsets(&self) -> &[u32] {
        &self.offsets
    }
    /// CSR column indices of the adjacency (each row ascending).
    pub fn adjacency(&self) -> &[u32] {
        &self.adj
    }
    /// Number of undirected edges.
    pub fn n_edges(&self) -> usize {
        self.adj.len() / 2
    }
    /// Edges whose endpoints have different `part`s (`part[v]` for every vertex).
    pub fn cut(&self, part: &[u32]) -> usize {
        (0..self.n)
            .into_par_iter()
            .with_min_len(1 << 12)
            .map(|v| {
                let p = part[v];
                self.neighbors(VertexId(v as u32))
                    .iter()
                    .filter(|&&w| w as usize > v && part[w as usize] != p)
                    .count()
            })
            .sum()
    }
}

/// The face checks shared with [`Topology::from_faces`](super::topology::Topology::from_faces).
pub(super) fn check_faces(n: usize, faces: &[[u32; 3]]) -> Result<(), MeshError> {
    if faces.len() > super::topology::MAX_FACES {
        return Err(MeshError::TooManyFaces {
            faces: faces.len(),
            max: super::topology::MAX_FACES,
        });
    }
    super::check_face_indices(faces, n)?;
    check_distinct_corners(faces)
}

/// [`MeshError::RepeatedCorner`] for the first face (lowest index) that uses a vertex
/// at two corners; in parallel.
pub(super) fn check_distinct_corners(faces: &[[u32; 3]]) -> Result<(), MeshError> {
    if let Some(face) =
        crate::par::position_first(faces, |t| t[0] == t[1] || t[1] == t[2] || t[0] == t[2])
    {
        let t = faces[face];
        let vertex = if t[0] == t[1] || t[0] == t[2] {
            t[0]
        } else {
            t[1]
        };
        return Err(MeshError::RepeatedCorner {
            face,
            vertex: vertex as usize,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::topology::Topology;
    use crate::mesh::{builtin, TriMesh};

    fn same_as_topology(n: usize, faces: &[[u32; 3]]) {
        let t = Topology::from_faces(n, faces).unwrap();
        let g = VertexGraph::from_faces(n, faces).unwrap();
        assert_eq!(g.adjacency_offsets(), t.adjacency_offsets());
        assert_eq!(g.adjacency(), t.adjacency());
        assert_eq!(g.faces(), t.faces());
        assert_eq!(g.n_edges(), t.n_edges());
        assert_eq!(t.graph().adjacency(), g.adjacency());
        // Two ways to count a cut: over the edge list and over the rows.
        let part: Vec<u32> = (0..n as u32).map(|v| (v * 7919) % 5).collect();
        let want = t
            .edges()
            .iter()
            .filter(|&&[a, b]| part[a as usize] != part[b as usize])
            .count();
        assert_eq!(g.cut(&part), want);
    }

    /// The neighbour lists are the half-edge connectivity's, on closed, boundary
    /// and non-manifold meshes and with an isolated vertex.
    #[test]
    fn neighbours_match_the_topology() {
        for m in [
            builtin::icosphere(5).unwrap(),
            builtin::grid(40).unwrap(),
            builtin::torus(30, 20).unwrap(),
        ] {
            same_as_topology(m.n_vertices(), &m.faces);
        }
        // Three faces on one edge, a bowtie, and vertex 7 on no face.
        let faces = [[0, 1, 2], [1, 0, 3], [0, 1, 4], [0, 5, 6]];
        same_as_topology(8, &faces);
        same_as_topology(0, &[]);
    }

    /// Random face soups large enough for several ranges of faces give the same
    /// graph on pools of 1 and 3 threads, and the topology's lists.
    #[test]
    fn same_graph_on_any_thread_count() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = |k: u32| {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((state >> 33) % u64::from(k)) as u32
        };
        let n = 30_000u32;
        let mut faces = Vec::new();
        while faces.len() < 120_000 {
            let a = next(n);
            let (b, c) = ((a + 1 + next(3)) % n, (a + 4 + next(3)) % n);
            faces.push([a, b, c]);
        }
        same_as_topology(n as usize, &faces);
        let run = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| VertexGraph::from_faces(n as usize, &faces).unwrap())
        };
        let (a, b) = (run(1), run(3));
        assert_eq!(a.adjacency_offsets(), b.adjacency_offsets());
        assert_eq!(a.adjacency(), b.adjacency());
    }

    /// Bad faces give the topology's typed errors.
    #[test]
    fn bad_faces_are_refused() {
        let m = TriMesh::new(vec![[0.0; 3]; 3], vec![[0, 1, 3]]);
        assert!(matches!(
            VertexGraph::from_faces(3, &m.faces),
            Err(MeshError::IndexOutOfRange {
                face: 0,
                index: 3,
                ..
            })
        ));
        assert!(matches!(
            VertexGraph::from_faces(3, &[[0, 1, 2], [2, 1, 2]]),
            Err(MeshError::RepeatedCorner { face: 1, vertex: 2 })
        ));
    }
}
