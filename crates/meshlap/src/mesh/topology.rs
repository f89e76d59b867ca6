//! Half-edge connectivity of a triangle mesh, built once from its faces.
//!
//! Half-edge `h = 3·f + c` of face `f = [v0, v1, v2]` runs from corner `c` to corner
//! `c + 1 (mod 3)`; its *opposite vertex* is corner `c + 2`. `next`/`prev` are therefore
//! implicit, and the structure stores only the twin of each half-edge, the undirected
//! edge it belongs to and, per vertex, one outgoing half-edge plus a sorted neighbour
//! list (CSR). Construction is O(n) (counting sort by the smaller endpoint, tiny
//! per-vertex sorts; every pass in parallel, the counting sorts with a histogram per
//! thread (`mem::bucket_sort`), and the result independent of the thread
//! count), with no hashing, so a 1M-vertex mesh builds in a
//! fraction of a second (`meshlap-bench topology builtin:icosphere:9`; BENCHMARKS.md).
//! The outgoing half-edges and the manifold flags, which the operators never use, are
//! computed on first use instead: the first by one sequential pass, the second in
//! parallel over the vertices.
//!
//! Non-manifold input is represented, not rejected: an edge with more than two faces
//! has no twins (each of its half-edges behaves like a boundary half-edge for rotation)
//! and is listed by [`Topology::non_manifold_edges`]; a vertex whose faces do not form a
//! single fan is flagged by [`Topology::is_manifold_vertex`].

use super::graph::VertexGraph;
use super::{EdgeId, FaceId, MeshError, TriMesh, VertexId};
use crate::mem::Scatter;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// Marker for "no half-edge" (boundary or non-manifold edge).
pub const INVALID: u32 = u32::MAX;

/// Largest face count [`Topology::from_faces`] accepts: half-edge ids need 31 bits.
pub const MAX_FACES: usize = (i32::MAX as usize) / 3;
const REVERSED: u64 = 1 << 31;
const HALF_EDGE: u64 = REVERSED - 1;

/// Whether a part of [`Topology`] computed on first use has a computation under way.
/// A clone starts afresh (its cells are cloned as they are: set, or to be computed).
#[derive(Debug, Default)]
struct Busy(AtomicBool);

impl Clone for Busy {
    fn clone(&self) -> Self {
        Self::default()
    }
}

/// Half-edge connectivity; see the module documentation.
#[derive(Clone, Debug)]
pub struct Topology {
    graph: VertexGraph,
    twin: Vec<u32>,
    he_edge: Vec<u32>,
    edges: Vec<[u32; 2]>,
    edge_he: Vec<u32>,
    edge_faces: Vec<u32>,
    adj_edge: Vec<u32>,
    /// Per vertex, one outgoing half-edge (see [`Self::outgoing`]): computed on first
    /// use, since the operators never rotate around a vertex.
    vertex_out: std::sync::OnceLock<Vec<u32>>,
    /// Per vertex, whether it is manifold: computed on first use (fan walks), since
    /// the operators, the most common users, never ask.
    vertex_manifold: std::sync::OnceLock<Vec<bool>>,
    /// Whether a first computation of `vertex_manifold` has started (see
    /// [`Self::manifold_flags`]).
    manifold_busy: Busy,
    inconsistent_edges: usize,
    /// How many edges have more than two faces: 0 lets [`Topology::non_manifold_edges`]
    /// skip its scan (the operators ask on every call).
    non_manifold_edges: usize,
}

impl Topology {
    /// Builds the connectivity of `mesh`. An out-of-range index gives
    /// [`MeshError::IndexOutOfRange`], a face with a repeated vertex
    /// [`MeshError::RepeatedCorner`] ([`super::clean::clean`] removes such faces).
    pub fn new(mesh: &TriMesh) -> Result<Self, MeshError> {
        Self::from_faces(mesh.n_vertices(), &mesh.faces)
    }

    /// Builds the connectivity from `n` vertices and a face list.
    ///
    /// Half-edges are bucketed by their smaller endpoint (counting sort), each bucket is
    /// sorted by the larger endpoint in parallel (rayon) to form the undirected edges in
    /// lexicographic order, and twins, edge ids and the vertex adjacency are scattered
    /// from there. At most `(2³¹ − 1) / 3` faces ([`MeshError::TooManyFaces`]). Runs
    /// on a worker of rayon's pool ([`crate::par::on_worker`]).
    pub fn from_faces(n: usize, faces: &[[u32; 3]]) -> Result<Self, MeshError> {
        crate::par::on_worker(|| Self::build(n, faces, crate::mem::LARGE_FROM))
    }

    /// [`Self::from_faces`] on the calling thread. Arrays from `large_from` bytes on
    /// are taken to exceed the cache: the steps that are otherwise sequential (the
    /// edge lists' join, each edge's first half-edge and face count, the faces' copy)
    /// run in parallel, and the twins' scatter prefetches its slots. The same
    /// connectivity either way (tested).
    fn build(n: usize, faces: &[[u32; 3]], large_from: usize) -> Result<Self, MeshError> {
        super::graph::check_faces(n, faces)?;
        let nh = faces.len() * 3;
        // Counting sort of half-edges by their smaller endpoint. Each entry packs
        // `hi << 32 | reversed << 31 | h`, where `reversed` says h runs hi → lo; sorting
        // a bucket then groups it by `hi`, and orientation needs no lookup in `faces`.
        let (count, mut bucket) = crate::mem::bucket_sort::<3, u64>(n, faces.len(), 0u64, |f| {
            let t = faces[f];
            std::array::from_fn(|c| {
                let (a, b) = (t[c], t[(c + 1) % 3]);
                let reversed = u64::from(a > b) << 31;
                (
                    a.min(b),
                    (u64::from(a.max(b)) << 32) | reversed | (3 * f + c) as u64,
                )
            })
        });
        // Group each bucket by the larger endpoint into undirected edges, in parallel
        // over contiguous ranges of `lo` (disjoint slices of `bucket`).
        let chunk_vertices = (n / (8 * rayon::current_num_threads().max(1))).max(4096);
        let mut chunks: Vec<(usize, &mut [u64])> = Vec::new();
        {
            let mut rest: &mut [u64] = &mut bucket;
            let mut lo = 0;
            while lo < n {
                let hi = (lo + chunk_vertices).min(n);
                let len = (count[hi] - count[lo]) as usize;
                let (head, tail) = rest.split_at_mut(len);
                chunks.push((lo, head));
                rest = tail;
                lo = hi;
            }
        }
        struct Part {
            edges: Vec<[u32; 2]>,
            edge_pos: Vec<u32>,
            inconsistent: usize,
            non_manifold: usize,
        }
        let parts: Vec<Part> = chunks
            .into_par_iter()
            .map(|(lo0, slice)| {
                let base = count[lo0] as usize;
                let mut part = Part {
                    edges: Vec::with_capacity(slice.len() / 2 + 1),
                    edge_pos: Vec::with_capacity(slice.len() / 2 + 1),
                    inconsistent: 0,
                    non_manifold: 0,
                };
                let mut lo = lo0;
                let mut off = 0usize;
                while off < slice.len() {
                    let len = (count[lo + 1] - count[lo]) as usize;
                    let b = &mut slice[off..off + len];
                    b.sort_unstable();
                    let mut i = 0;
                    while i < b.len() {
                        let hi = (b[i] >> 32) as u32;
                        let mut j = i + 1;
                        while j < b.len() && (b[j] >> 32) as u32 == hi {
                            j += 1;
                        }
                        part.edges.push([lo as u32, hi]);
                        part.edge_pos.push((base + off + i) as u32);
                        if j - i == 2 && (b[i] ^ b[i + 1]) & REVERSED == 0 {
                            part.inconsistent += 1;
                        }
                        part.non_manifold += usize::from(j - i > 2);
                        i = j;
                    }
                    off += len;
                    lo += 1;
                }
                part
            })
            .collect();
        // The parts joined (in parallel for large meshes, `mem::concat`).
        let edges = crate::mem::concat(&parts, |p| &p.edges[..], 0, large_from);
        let mut edge_pos = crate::mem::concat(&parts, |p| &p.edge_pos[..], 1, large_from);
        let n_edges = edges.len();
        let inconsistent_edges: usize = parts.iter().map(|p| p.inconsistent).sum();
        let non_manifold_edges: usize = parts.iter().map(|p| p.non_manifold).sum();
        drop(parts);
        edge_pos.push(nh as u32);
        // Scatter twins and edge ids to the half-edges, in parallel over edges: every
        // half-edge belongs to exactly one edge, so every slot is written once. Beyond
        // the cache, the slots of the half-edges a few edges ahead are prefetched
        // (`bucket` holds them in order), as in `mem::bucket_sort`.
        let he_of = |x: u64| (x & HALF_EDGE) as u32;
        let mut twin = crate::mem::zeroed_vec(0u32, nh); // every slot written below
        let mut he_edge = crate::mem::zeroed_vec(0u32, nh);
        {
            let (tw, he) = (Scatter::new(&mut twin), Scatter::new(&mut he_edge));
            let ahead = if nh * 4 >= large_from {
                crate::mem::SCATTER_PREFETCH_AHEAD
            } else {
                0
            };
            (0..n_edges)
                .into_par_iter()
                .with_min_len(1 << 12)
                .for_each(|e| {
                    let (s, t) = (edge_pos[e] as usize, edge_pos[e + 1] as usize);
                    if ahead > 0 {
                        // About two half-edges per edge: this edge's share of the
                        // entries `ahead` places on.
                        for &x in bucket.iter().skip(s + ahead).take(t - s) {
                            let h = he_of(x) as usize;
                            tw.prefetch(h);
                            he.prefetch(h);
                        }
                    }
                    for k in s..t {
                        let h = he_of(bucket[k]) as usize;
                        let other = if t - s == 2 {
                            he_of(bucket[s + t - 1 - k])
                        } else {
                            INVALID
                        };
                        // SAFETY: half-edge h is in this edge's range only.
                        unsafe {
                            he.write(h, e as u32);
                            tw.write(h, other);
                        }
                    }
                });
        }
        // Each edge's first half-edge and face count: in parallel for large meshes
        // only, where one thread's pass costs more than waking the pool.
        let first_he = |&p: &u32| he_of(bucket[p as usize]);
        let face_count = |w: &[u32]| w[1] - w[0];
        let (edge_he, edge_faces): (Vec<u32>, Vec<u32>) = if n_edges * 4 >= large_from {
            (
                edge_pos[..n_edges].par_iter().map(first_he).collect(),
                edge_pos.par_windows(2).map(face_count).collect(),
            )
        } else {
            (
                edge_pos[..n_edges].iter().map(first_he).collect(),
                edge_pos.windows(2).map(face_count).collect(),
            )
        };
        drop(bucket);
        drop(edge_pos);
        // Vertex adjacency (CSR) from the edge list. Edges are sorted by (lo, hi), so
        // row x receives first its smaller neighbours (as `hi` of earlier edges, in
        // ascending order) and then its larger ones (as `lo`, ascending): every row
        // comes out sorted without a sort.
        // (neighbour, edge) packed; the bucket sort keeps the edge order in a row.
        let (adj_offsets, packed) = crate::mem::bucket_sort(n, edges.len(), 0u64, |e| {
            let [a, b] = edges[e];
            [
                (a, (u64::from(b) << 32) | e as u64),
                (b, (u64::from(a) << 32) | e as u64),
            ]
        });
        let (mut adj, mut adj_edge) = (Vec::new(), Vec::new());
        packed
            .par_iter()
            .map(|&x| ((x >> 32) as u32, x as u32))
            .unzip_into_vecs(&mut adj, &mut adj_edge);
        drop(packed);
        debug_assert!(
            (0..n).all(|v| adj[adj_offsets[v] as usize..adj_offsets[v + 1] as usize].is_sorted())
        );
        let topo = Topology {
            graph: VertexGraph {
                n,
                faces: crate::mem::to_vec(faces, large_from),
                offsets: adj_offsets,
                adj,
            },
            twin,
            he_edge,
            edges,
            edge_he,
            edge_faces,
            adj_edge,
            vertex_out: std::sync::OnceLock::new(),
            vertex_manifold: std::sync::OnceLock::new(),
            manifold_busy: Busy::default(),
            inconsistent_edges,
            non_manifold_edges,
        };
        Ok(topo)
    }

    /// A vertex is manifold when none of its edges has more than two faces and one
    /// walk through its fan sweeps all its faces (each face at v holds two of v's
    /// edges, so the face count is half the sum of its edges' face counts). The walk
    /// ignores orientation, so an inconsistently oriented neighbour (reported
    /// separately) does not make a vertex non-manifold.
    ///
    /// Computed once, on first use, outside the cell's initialisation: the first
    /// caller in parallel over the vertices; anyone asking while it runs (another
    /// thread, or the same one through a task of its caller's parallel loop that it
    /// picked up while waiting) sequentially. Nobody waits on a lock that the waiting
    /// thread itself could hold, and parallel passes never nest; the flags are the
    /// same either way, and the first stored is kept.
    fn manifold_flags(&self) -> &[bool] {
        if let Some(m) = self.vertex_manifold.get() {
            return m;
        }
        let outgoing = self.outgoing();
        let flags = if self.manifold_busy.0.swap(true, Ordering::AcqRel) {
            (0..self.graph.n)
                .map(|v| self.vertex_is_manifold(outgoing, v))
                .collect()
        } else {
            (0..self.graph.n)
                .into_par_iter()
                .with_min_len(1 << 10)
                .map(|v| self.vertex_is_manifold(outgoing, v))
                .collect()
        };
        self.vertex_manifold.get_or_init(|| flags)
    }

    /// One outgoing half-edge per vertex, preferring a boundary one so that rotation
    /// from it sweeps the whole fan: the smallest boundary half-edge leaving v, else
    /// the smallest half-edge (the minimum of `(has twin, h)` over v's outgoing
    /// half-edges); [`INVALID`] for an isolated vertex.
    ///
    /// Computed once, on first use, in one sequential pass over the half-edges: a
    /// parallel pass inside the initialisation could let its thread pick up, while it
    /// waits, a pending task of the caller's own parallel loop that asks for the same
    /// cell, and block on itself. (A parallel pass over the vertices outside the cell,
    /// through their edges, was slower than this scan on two threads: BENCHMARKS.md,
    /// "Connectivity".)
    fn outgoing(&self) -> &[u32] {
        self.vertex_out.get_or_init(|| {
            let mut key = vec![u64::MAX; self.graph.n];
            for (f, t) in self.graph.faces.iter().enumerate() {
                for (c, &v) in t.iter().enumerate() {
                    let h = 3 * f + c;
                    let k = (u64::from(self.twin[h] != INVALID) << 32) | h as u64;
                    let slot = &mut key[v as usize];
                    *slot = (*slot).min(k);
                }
            }
            key.into_iter()
                .map(|k| match k {
                    u64::MAX => INVALID,
                    k => k as u32,
                })
                .collect()
        })
    }

    /// [`Self::manifold_flags`]'s value for `v`, given the outgoing half-edges.
    fn vertex_is_manifold(&self, outgoing: &[u32], v: usize) -> bool {
        if outgoing[v] == INVALID {
            return true; // isolated vertex: nothing non-manifold about it
        }
        let mut incident2 = 0u32;
        for p in self.graph.offsets[v]..self.graph.offsets[v + 1] {
            let c = self.edge_faces[self.adj_edge[p as usize] as usize];
            if c > 2 {
                return false;
            }
            incident2 += c;
        }
        let (_, _, swept) = self.fan_sweep(v as u32);
        2 * swept as u32 == incident2
    }

    /// The edge at `v` other than `h` in `h`'s face (`h` must be incident to `v`).
    #[inline]
    fn other_at(&self, h: u32, v: u32) -> u32 {
        if self.from(h) == v {
            self.prev(h)
        } else {
            self.next(h)
        }
    }

    /// The endpoint of `h` that is not `v`.
    #[inline]
    fn across(&self, h: u32, v: u32) -> u32 {
        if self.from(h) == v {
            self.to(h)
        } else {
            self.from(h)
        }
    }

    /// Walks the fan of `v` face by face, starting in the face of `h` (a half-edge at
    /// `v`) and leaving it through its other edge at `v`; yields the half-edge each
    /// face is left by (one per face swept). Stops at a boundary or non-manifold edge
    /// or when the walk returns to the start face. Orientation-agnostic.
    fn walk_fan(&self, v: u32, h: u32) -> impl Iterator<Item = u32> + '_ {
        let start_face = h / 3;
        let mut exit = Some(self.other_at(h, v));
        let mut steps = 0usize;
        let limit = self.graph.faces.len() + 1;
        std::iter::from_fn(move || {
            let e = exit?;
            steps += 1;
            let t = self.twin[e as usize];
            exit = if t == INVALID || t / 3 == start_face || steps > limit {
                None
            } else {
                Some(self.other_at(t, v))
            };
            Some(e)
        })
    }

    /// A half-edge at `v` from which [`Self::walk_fan`] sweeps `v`'s whole fan when
    /// `v` is manifold (an end of the fan on the boundary), whether the fan is closed,
    /// and the number of faces that walk sweeps. One walk suffices unless the walk from
    /// `vertex_out` (a boundary half-edge when `v` has an outgoing one) stops at a
    /// boundary midway, which needs inconsistent orientation.
    fn fan_sweep(&self, v: u32) -> (u32, bool, usize) {
        let h = self.outgoing()[v as usize];
        if self.inconsistent_edges == 0 {
            // Consistent orientation: rotate by twin(prev(·)) from the outgoing
            // (boundary, if any) half-edge, touching only `twin`.
            let (mut cur, mut count) = (h, 0usize);
            let limit = self.graph.faces.len() + 1;
            loop {
                count += 1;
                let t = self.twin[self.prev(cur) as usize];
                if t == INVALID || count > limit {
                    return (h, false, count);
                }
                if t == h {
                    return (h, true, count);
                }
                cur = t;
            }
        }
        let mut count = 0usize;
        let mut last = h;
        for e in self.walk_fan(v, h) {
            last = e;
            count += 1;
        }
        if self.twin[h as usize] == INVALID {
            return (h, false, count); // started at a boundary end
        }
        if self.twin[last as usize] != INVALID {
            return (h, true, count); // came back to the start face
        }
        (last, false, self.walk_fan(v, last).count())
    }

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.graph.n_vertices()
    }
    /// Number of faces.
    pub fn n_faces(&self) -> usize {
        self.graph.faces.len()
    }
    /// Number of undirected edges.
    pub fn n_edges(&self) -> usize {
        self.edges.len()
    }
    /// The faces this connectivity was built from.
    pub fn faces(&self) -> &[[u32; 3]] {
        self.graph.faces()
    }
    /// The faces and the vertex adjacency alone ([`VertexGraph`]).
    pub fn graph(&self) -> &VertexGraph {
        &self.graph
    }
    /// Undirected edges as `[a, b]` with `a < b`, sorted lexicographically.
    pub fn edges(&self) -> &[[u32; 2]] {
        &self.edges
    }
    /// Endpoints of edge `e` (`a < b`).
    pub fn edge(&self, e: EdgeId) -> [u32; 2] {
        self.edges[e.idx()]
    }
    /// Number of faces incident to edge `e` (1: boundary, 2: interior, >2: non-manifold).
    pub fn edge_face_count(&self, e: EdgeId) -> usize {
        self.edge_faces[e.idx()] as usize
    }
    /// True when edge `e` has exactly one incident face.
    pub fn is_boundary_edge(&self, e: EdgeId) -> bool {
        self.edge_faces[e.idx()] == 1
    }
    /// Source vertex of half-edge `h`.
    #[inline]
    pub fn from(&self, h: u32) -> u32 {
        self.graph.faces[h as usize / 3][h as usize % 3]
    }
    /// Target vertex of half-edge `h`.
    #[inline]
    pub fn to(&self, h: u32) -> u32 {
        self.graph.faces[h as usize / 3][(h as usize + 1) % 3]
    }
    /// The vertex of `h`'s face opposite to `h`.
    #[inline]
    pub fn opposite_vertex(&self, h: u32) -> u32 {
        self.graph.faces[h as usize / 3][(h as usize + 2) % 3]
    }
    /// Next half-edge in the same face.
    #[inline]
    pub fn next(&self, h: u32) -> u32 {
        if h % 3 == 2 {
            h - 2
        } else {
            h + 1
        }
    }
    /// Previous half-edge in the same face.
    #[inline]
    pub fn prev(&self, h: u32) -> u32 {
        if h.is_multiple_of(3) {
            h + 2
        } else {
            h - 1
        }
    }
    /// Twin half-edge, or [`INVALID`] on a boundary or non-manifold edge.
    #[inline]
    pub fn twin(&self, h: u32) -> u32 {
        self.twin[h as usize]
    }
    /// Every half-edge's [twin](Topology::twin) (3·faces entries; [`INVALID`] on a
    /// boundary or non-manifold edge).
    pub(crate) fn twins(&self) -> &[u32] {
        &self.twin
    }
    /// Every half-edge's [undirected edge](Topology::half_edge_edge) (3·faces entries).
    pub(crate) fn half_edge_edges(&self) -> &[u32] {
        &self.he_edge
    }
    /// Every edge's [face count](Topology::edge_face_count), in [`Topology::edges`]
    /// order.
    pub(crate) fn edge_face_counts(&self) -> &[u32] {
        &self.edge_faces
    }
    /// The undirected edge of half-edge `h`.
    #[inline]
    pub fn half_edge_edge(&self, h: u32) -> EdgeId {
        EdgeId(self.he_edge[h as usize])
    }
    /// The face of half-edge `h`.
    #[inline]
    pub fn half_edge_face(&self, h: u32) -> FaceId {
        FaceId(h / 3)
    }

    /// The vertices opposite edge `e`: one per incident face (one on the boundary, two
    /// inside, more on a non-manifold edge).
    pub fn edge_opposite_vertices(&self, e: EdgeId) -> EdgeOpposites<'_> {
        let h = self.edge_he[e.idx()];
        EdgeOpposites {
            topo: self,
            first: h,
            second: if self.edge_faces[e.idx()] == 2 {
                self.twin[h as usize]
            } else {
                INVALID
            },
            state: 0,
        }
    }

    /// One half-edge of edge `e`.
    pub fn edge_half_edge(&self, e: EdgeId) -> u32 {
        self.edge_he[e.idx()]
    }

    /// Degree (number of distinct neighbours) of vertex `v`.
    #[inline]
    pub fn degree(&self, v: VertexId) -> usize {
        self.graph.degree(v)
    }

    /// All vertex degrees.
    pub fn degrees(&self) -> Vec<u32> {
        self.graph.offsets.windows(2).map(|w| w[1] - w[0]).collect()
    }

    /// Neighbours of `v`, ascending by index.
    #[inline]
    pub fn neighbors(&self, v: VertexId) -> &[u32] {
        self.graph.neighbors(v)
    }

    /// Edges incident to `v`, in the order of [`Topology::neighbors`].
    #[inline]
    pub fn neighbor_edges(&self, v: VertexId) -> &[u32] {
        &self.adj_edge
            [self.graph.offsets[v.idx()] as usize..self.graph.offsets[v.idx() + 1] as usize]
    }

    /// CSR offsets of the adjacency (`n + 1` entries).
    pub fn adjacency_offsets(&self) -> &[u32] {
        self.graph.adjacency_offsets()
    }
    /// CSR column indices of the adjacency (each row ascending).
    pub fn adjacency(&self) -> &[u32] {
        self.graph.adjacency()
    }

    /// The edge joining `a` and `b`, if any (binary search in `a`'s sorted row).
    pub fn find_edge(&self, a: VertexId, b: VertexId) -> Option<EdgeId> {
        let row = self.neighbors(a);
        row.binary_search(&b.0)
            .ok()
            .map(|k| EdgeId(self.neighbor_edges(a)[k]))
    }

    /// The one-ring of a manifold vertex in cyclic order (counter-clockwise for a
    /// consistently, counter-clockwise oriented mesh), starting at a boundary neighbour
    /// on the boundary. `None` for a non-manifold or isolated vertex.
    pub fn one_ring(&self, v: VertexId) -> Option<Vec<u32>> {
        if !self.manifold_flags()[v.idx()] || self.outgoing()[v.idx()] == INVALID {
            return None;
        }
        let (start, closed, _) = self.fan_sweep(v.0);
        let mut ring: Vec<u32> = Vec::with_capacity(self.degree(v));
        ring.push(self.across(start, v.0));
        ring.extend(self.walk_fan(v.0, start).map(|e| self.across(e, v.0)));
        if closed {
            ring.pop(); // the walk ends on the start edge again
        }
        Some(ring)
    }

    /// True when `v` has at least one boundary edge.
    pub fn is_boundary_vertex(&self, v: VertexId) -> bool {
        self.neighbor_edges(v)
            .iter()
            .any(|&e| self.edge_faces[e as usize] == 1)
    }

    /// True when the faces around `v` form a single fan (disk or half-disk) with no
    /// non-manifold edge. Isolated vertices count as manifold.
    pub fn is_manifold_vertex(&self, v: VertexId) -> bool {
        self.manifold_flags()[v.idx()]
    }

    /// Edges with more than two incident faces, ascending. Empty without a scan when
    /// there are none (counted while the connectivity was built).
    pub fn non_manifold_edges(&self) -> impl Iterator<Item = EdgeId> + '_ {
        let scan = if self.non_manifold_edges == 0 {
            0
        } else {
            self.edges.len()
        };
        (0..scan)
            .filter(|&e| self.edge_faces[e] > 2)
            .map(|e| EdgeId(e as u32))
    }

    /// Vertices that are not [manifold](Topology::is_manifold_vertex).
    pub fn non_manifold_vertices(&self) -> impl Iterator<Item = VertexId> + '_ {
        let flags = self.manifold_flags();
        (0..self.graph.n)
            .filter(move |&v| !flags[v])
            .map(|v| VertexId(v as u32))
    }

    /// Edges with one incident face.
    pub fn boundary_edges(&self) -> impl Iterator<Item = EdgeId> + '_ {
        (0..self.edges.len())
            .filter(|&e| self.edge_faces[e] == 1)
            .map(|e| EdgeId(e as u32))
    }

    /// Interior (two-face) edges whose two faces traverse them in the same direction,
    /// i.e. neighbouring faces with inconsistent orientation.
    pub fn inconsistently_oriented_edges(&self) -> usize {
        self.inconsistent_edges
    }

    /// True when the mesh is edge- and vertex-manifold.
    pub fn is_manifold(&self) -> bool {
        self.non_manifold_edges == 0 && self.manifold_flags().iter().all(|&m| m)
    }

    /// Number of boundary loops: connected components of the graph formed by the
    /// boundary edges (robust to inconsistent orientation and non-manifold vertices).
    pub fn boundary_loop_count(&self) -> usize {
        let mut uf = UnionFind::new(self.graph.n);
        let mut on_boundary = vec![false; self.graph.n];
        for e in self.boundary_edges() {
            let [a, b] = self.edges[e.idx()];
            uf.union(a as usize, b as usize);
            on_boundary[a as usize] = true;
            on_boundary[b as usize] = true;
        }
        (0..self.graph.n)
            .filter(|&v| on_boundary[v] && uf.find(v) == v)
            .count()
    }

    /// The boundary loops of a manifold, consistently oriented mesh as vertex cycles,
    /// each following the boundary half-edges. Loops through a non-manifold vertex are
    /// still returned, split at that vertex where the walk is ambiguous.
    pub fn boundary_loops(&self) -> Vec<Vec<u32>> {
        // Outgoing boundary half-edge per vertex (CSR, since a non-manifold vertex can
        // have several).
        let bhe: Vec<u32> = (0..self.graph.faces.len() as u32 * 3)
            .filter(|&h| self.edge_faces[self.he_edge[h as usize] as usize] == 1)
            .collect();
        let mut out_off = vec![0usize; self.graph.n + 1];
        for &h in &bhe {
            out_off[self.from(h) as usize + 1] += 1;
        }
        for i in 0..self.graph.n {
            out_off[i + 1] += out_off[i];
        }
        let mut fill = out_off.clone();
        let mut out = vec![0u32; bhe.len()];
        for &h in &bhe {
            let v = self.from(h) as usize;
            out[fill[v]] = h;
            fill[v] += 1;
        }
        let mut used = vec![false; bhe.len()];
        let index_of = |h: u32, out: &[u32], off: &[usize], v: usize| {
            (off[v]..off[v + 1]).find(|&k| out[k] == h)
        };
        let mut loops = Vec::new();
        for v in 0..self.graph.n {
            for k in out_off[v]..out_off[v + 1] {
                if used[k] {
                    continue;
                }
                let mut lp = Vec::new();
                let mut h = out[k];
                let mut kk = k;
                loop {
                    used[kk] = true;
                    lp.push(self.from(h));
                    let w = self.to(h) as usize;
                    match (out_off[w]..out_off[w + 1]).find(|&j| !used[j]) {
                        Some(j) => {
                            kk = j;
                            h = out[j];
                        }
                        None => break,
                    }
                    debug_assert!(index_of(h, &out, &out_off, w).is_some());
                }
                loops.push(lp);
            }
        }
        loops
    }

    /// Connected components: a label per vertex (`0..count`, in order of first vertex)
    /// and the count. Isolated vertices form their own components.
    pub fn components(&self) -> (Vec<u32>, usize) {
        let mut uf = UnionFind::new(self.graph.n);
        for &[a, b] in &self.edges {
            uf.union(a as usize, b as usize);
        }
        let mut label = vec![u32::MAX; self.graph.n];
        let mut root_label = vec![u32::MAX; self.graph.n];
        let mut count = 0u32;
        for (v, l) in label.iter_mut().enumerate() {
            let r = uf.find(v);
            if root_label[r] == u32::MAX {
                root_label[r] = count;
                count += 1;
            }
            *l = root_label[r];
        }
        (label, count as usize)
    }
}

/// Iterator over the vertices opposite an edge; see
/// [`Topology::edge_opposite_vertices`].
pub struct EdgeOpposites<'a> {
    topo: &'a Topology,
    first: u32,
    second: u32,
    state: u8,
}

impl Iterator for EdgeOpposites<'_> {
    type Item = u32;
    fn next(&mut self) -> Option<u32> {
        let h = match self.state {
            0 => self.first,
            1 => self.second,
            _ => INVALID,
        };
        self.state = self.state.saturating_add(1);
        if h == INVALID {
            None
        } else {
            Some(self.topo.opposite_vertex(h))
        }
    }
}

/// Disjoint-set forest with path halving and union by size.
#[derive(Clone, Debug)]
pub struct UnionFind {
    parent: Vec<u32>,
    size: Vec<u32>,
}

impl UnionFind {
    /// `n` singletons.
    pub fn new(n: usize) -> Self {
        Self {
            parent: (0..n as u32).collect(),
            size: vec![1; n],
        }
    }
    /// Representative of `x`.
    pub fn find(&mut self, mut x: usize) -> usize {
        while self.parent[x] as usize != x {
            let p = self.parent[x] as usize;
            self.parent[x] = self.parent[p];
            x = self.parent[x] as usize;
        }
        x
    }
    /// Merges the sets of `a` and `b`; true when they were distinct.
    pub fn union(&mut self, a: usize, b: usize) -> bool {
        let (mut ra, mut rb) = (self.find(a), self.find(b));
        if ra == rb {
            return false;
        }
        if self.size[ra] < self.size[rb] {
            std::mem::swap(&mut ra, &mut rb);
        }
        self.parent[rb] = ra as u32;
        self.size[ra] += self.size[rb];
        true
    }
}

/// The connectivity's internal variants, for differential fuzzing (`fuzz/src/entry.rs`,
/// whose `open` target checks that the steps for large meshes give what the steps for
/// small ones give) and for the stable replay of its corpus. Not part of the API:
/// these may change or go at any time. Use [`Topology::from_faces`].
#[doc(hidden)]
pub mod variants {
    use super::{MeshError, Topology};

    /// [`Topology::from_faces`] taking arrays from `large_from` bytes on to exceed the
    /// cache: 0 runs the steps for large meshes (the parallel joins and copies, the
    /// prefetching scatter) on any mesh, `usize::MAX` never.
    pub fn topology(
        n: usize,
        faces: &[[u32; 3]],
        large_from: usize,
    ) -> Result<Topology, MeshError> {
        crate::par::on_worker(|| Topology::build(n, faces, large_from))
    }
}

#[cfg(test)]
#[path = "topology_tests.rs"]
mod tests;
