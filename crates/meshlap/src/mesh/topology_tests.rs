use super::*;
use crate::mesh::builtin;

fn tet() -> TriMesh {
    builtin::tetrahedron()
}

#[test]
fn tetrahedron_counts() {
    let t = Topology::new(&tet()).unwrap();
    assert_eq!(t.n_edges(), 6);
    assert_eq!(t.boundary_edges().count(), 0);
    assert!(t.is_manifold());
    assert_eq!(t.inconsistently_oriented_edges(), 0);
    for v in 0..4 {
        assert_eq!(t.degree(VertexId(v)), 3);
        assert_eq!(t.one_ring(VertexId(v)).unwrap().len(), 3);
    }
    assert_eq!(t.components().1, 1);
}

#[test]
fn grid_boundary_and_rings() {
    let g = builtin::grid(4).unwrap();
    let t = Topology::new(&g).unwrap();
    assert_eq!(t.boundary_loop_count(), 1);
    let loops = t.boundary_loops();
    assert_eq!(loops.len(), 1);
    assert_eq!(loops[0].len(), 16);
    for v in 0..g.n_vertices() as u32 {
        let ring = t.one_ring(VertexId(v)).unwrap();
        let mut sorted = ring.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, t.neighbors(VertexId(v)), "vertex {v}");
        // consecutive ring vertices are adjacent
        for w in ring.windows(2) {
            assert!(t.find_edge(VertexId(w[0]), VertexId(w[1])).is_some());
        }
    }
    // Interior vertices of the regular grid have degree 6.
    assert_eq!(t.degree(VertexId(6)), 6);
}

#[test]
fn opposite_vertices() {
    let t = Topology::new(&tet()).unwrap();
    for e in 0..t.n_edges() as u32 {
        let [a, b] = t.edge(EdgeId(e));
        let opp: Vec<u32> = t.edge_opposite_vertices(EdgeId(e)).collect();
        assert_eq!(opp.len(), 2);
        for o in opp {
            assert!(o != a && o != b);
        }
    }
}

#[test]
fn non_manifold_edge_detected() {
    // three triangles sharing edge (0, 1)
    let m = TriMesh::new(vec![[0.0; 3]; 5], vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]]);
    let t = Topology::new(&m).unwrap();
    assert_eq!(t.non_manifold_edges().count(), 1);
    assert!(!t.is_manifold_vertex(VertexId(0)));
    assert!(!t.is_manifold());
}

#[test]
fn bowtie_vertex_detected() {
    let m = TriMesh::new(vec![[0.0; 3]; 5], vec![[0, 1, 2], [0, 3, 4]]);
    let t = Topology::new(&m).unwrap();
    assert_eq!(t.non_manifold_edges().count(), 0);
    assert!(!t.is_manifold_vertex(VertexId(0)));
    assert_eq!(t.non_manifold_vertices().count(), 1);
    assert_eq!(t.boundary_loop_count(), 1);
}

#[test]
fn inconsistent_orientation_detected() {
    let m = TriMesh::new(vec![[0.0; 3]; 4], vec![[0, 1, 2], [0, 1, 3]]);
    let t = Topology::new(&m).unwrap();
    assert_eq!(t.inconsistently_oriented_edges(), 1);
}

/// One flipped face on a closed mesh: three inconsistent edges, but every vertex
/// is still manifold and its one-ring still lists all its neighbours cyclically.
#[test]
fn flipped_face_is_inconsistent_but_manifold() {
    let mut m = builtin::icosahedron();
    let [a, b, c] = m.faces[0];
    m.faces[0] = [a, c, b];
    let t = Topology::new(&m).unwrap();
    assert_eq!(t.inconsistently_oriented_edges(), 3);
    assert!(t.is_manifold());
    for v in 0..12 {
        let ring = t.one_ring(VertexId(v)).unwrap();
        let mut sorted = ring.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, t.neighbors(VertexId(v)));
        for k in 0..ring.len() {
            let (x, y) = (ring[k], ring[(k + 1) % ring.len()]);
            assert!(t.find_edge(VertexId(x), VertexId(y)).is_some());
        }
    }
}

/// Cross-check against a naive map-based construction on seeded random face
/// soups (non-manifold edges, bowties, inconsistent orientation included), with
/// enough vertices that the parallel grouping and scatter split into chunks.
#[test]
fn matches_naive_construction_on_random_soups() {
    use rand::{Rng, SeedableRng};
    use std::collections::{BTreeMap, BTreeSet};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    for (n, m) in [(6usize, 8usize), (40, 120), (20_000, 60_000)] {
        let mut faces = Vec::new();
        while faces.len() < m {
            let a = rng.gen_range(0..n as u32);
            // Local triangles, so that edges are shared by several faces.
            let b = (a + rng.gen_range(1..4)) % n as u32;
            let c = (a + rng.gen_range(4..7)) % n as u32;
            if a != b && b != c && a != c {
                faces.push(if rng.gen_bool(0.5) {
                    [a, b, c]
                } else {
                    [a, c, b]
                });
            }
        }
        let t = Topology::from_faces(n, &faces).unwrap();
        // The parallel build does not depend on the thread count.
        for threads in [1, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let other = pool.install(|| Topology::from_faces(n, &faces).unwrap());
            assert_eq!(format!("{other:?}"), format!("{t:?}"), "{threads} threads");
            // The sequential steps in parallel, as for large meshes: the same.
            let forced = pool.install(|| Topology::build(n, &faces, 0).unwrap());
            assert_eq!(
                format!("{forced:?}"),
                format!("{t:?}"),
                "{threads}, parallel"
            );
        }
        // The outgoing half-edge: the smallest boundary one, else the smallest one.
        let mut want_out = vec![INVALID; n];
        for h in 0..3 * faces.len() {
            let v = faces[h / 3][h % 3] as usize;
            let boundary = t.twin(h as u32) == INVALID;
            let cur = want_out[v];
            if cur == INVALID || (boundary && t.twin(cur) != INVALID) {
                want_out[v] = h as u32;
            }
        }
        assert_eq!(t.outgoing(), want_out);
        // The manifold flags in parallel equal the sequential computation (of a
        // caller that asks while the first one runs).
        let sequential: Vec<bool> = (0..n).map(|v| t.vertex_is_manifold(&want_out, v)).collect();
        assert_eq!(t.manifold_flags(), &sequential[..]);
        let mut naive: BTreeMap<(u32, u32), Vec<u32>> = BTreeMap::new();
        for (f, tri) in faces.iter().enumerate() {
            for c in 0..3 {
                let (a, b) = (tri[c], tri[(c + 1) % 3]);
                naive
                    .entry((a.min(b), a.max(b)))
                    .or_default()
                    .push((3 * f + c) as u32);
            }
        }
        let want: Vec<[u32; 2]> = naive.keys().map(|&(a, b)| [a, b]).collect();
        assert_eq!(t.edges(), &want[..]);
        let mut inconsistent = 0;
        for (e, hs) in naive.values().enumerate() {
            let e = EdgeId(e as u32);
            assert_eq!(t.edge_face_count(e), hs.len());
            for &h in hs {
                assert_eq!(t.half_edge_edge(h), e);
                let expect = if hs.len() == 2 {
                    hs[0] + hs[1] - h
                } else {
                    INVALID
                };
                assert_eq!(t.twin(h), expect);
            }
            if hs.len() == 2 && t.from(hs[0]) == t.from(hs[1]) {
                inconsistent += 1;
            }
        }
        assert_eq!(t.inconsistently_oriented_edges(), inconsistent);
        // The non-manifold edges, counted while building, against the naive map.
        let want_nm: Vec<EdgeId> = naive
            .values()
            .enumerate()
            .filter(|(_, hs)| hs.len() > 2)
            .map(|(e, _)| EdgeId(e as u32))
            .collect();
        assert!(
            n < 100 || !want_nm.is_empty(),
            "the soup has no non-manifold edge"
        );
        assert_eq!(t.non_manifold_edges().collect::<Vec<_>>(), want_nm);
        assert_eq!(
            t.is_manifold(),
            want_nm.is_empty() && (0..n as u32).all(|v| t.is_manifold_vertex(VertexId(v)))
        );
        for v in 0..n as u32 {
            let nb: BTreeSet<u32> = naive
                .keys()
                .filter_map(|&(a, b)| (a == v).then_some(b).or_else(|| (b == v).then_some(a)))
                .collect();
            let nb: Vec<u32> = nb.into_iter().collect();
            assert_eq!(t.neighbors(VertexId(v)), &nb[..]);
            for (&u, &e) in nb.iter().zip(t.neighbor_edges(VertexId(v))) {
                assert_eq!(t.edge(EdgeId(e)), [v.min(u), v.max(u)]);
            }
            // Manifold vertex: no edge with > 2 faces and its faces are connected
            // through its edges (flood fill over the faces at v).
            let at_v: Vec<usize> = (0..faces.len())
                .filter(|&f| faces[f].contains(&v))
                .collect();
            let nm_edge = nb.iter().any(|&u| naive[&(v.min(u), v.max(u))].len() > 2);
            let mut seen = vec![false; at_v.len()];
            if !at_v.is_empty() {
                let mut stack = vec![0usize];
                seen[0] = true;
                while let Some(i) = stack.pop() {
                    for j in 0..at_v.len() {
                        let shared = faces[at_v[i]]
                            .iter()
                            .filter(|&&x| x != v && faces[at_v[j]].contains(&x))
                            .count();
                        if !seen[j] && shared > 0 {
                            seen[j] = true;
                            stack.push(j);
                        }
                    }
                }
            }
            let manifold = !nm_edge && seen.iter().all(|&s| s);
            assert_eq!(t.is_manifold_vertex(VertexId(v)), manifold, "vertex {v}");
            if n > 1000 && v > 200 {
                break; // the quadratic fan check on a prefix is enough
            }
        }
    }
}

#[test]
fn out_of_range_is_an_error() {
    let m = TriMesh::new(vec![[0.0; 3]; 2], vec![[0, 1, 2]]);
    assert!(matches!(
        Topology::new(&m),
        Err(MeshError::IndexOutOfRange { .. })
    ));
}

#[test]
fn repeated_corner_is_an_error_not_a_panic_downstream() {
    let faces = vec![[0u32, 1, 2], [2, 1, 1]];
    match Topology::from_faces(3, &faces) {
        Err(MeshError::RepeatedCorner { face: 1, vertex: 1 }) => {}
        other => panic!("{other:?}"),
    }
}

/// The lazily computed outgoing half-edges and manifold flags, first asked for from
/// inside a parallel loop over the vertices on several threads, give what a topology
/// asked from one thread gives. (The outgoing half-edges are computed by a sequential
/// pass inside their cell's initialisation; the first caller of the manifold flags
/// computes them in parallel without holding their cell, and a caller that asks
/// meanwhile, which may be a task the first one picked up while waiting, computes
/// them sequentially instead of waiting. A parallel pass inside `get_or_init` passed
/// this test too, its deadlock depending on timing.)
#[test]
fn lazy_vertex_data_first_asked_for_in_parallel() {
    use rayon::prelude::*;
    let mesh = builtin::icosphere(5).unwrap();
    let want: Vec<Option<Vec<u32>>> = {
        let t = Topology::new(&mesh).unwrap();
        (0..mesh.n_vertices() as u32)
            .map(|v| t.one_ring(VertexId(v)))
            .collect()
    };
    for threads in [2, 3, 4] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        for _ in 0..5 {
            let t = Topology::new(&mesh).unwrap();
            let got: Vec<Option<Vec<u32>>> = pool.install(|| {
                (0..mesh.n_vertices() as u32)
                    .into_par_iter()
                    .with_max_len(64)
                    .map(|v| t.one_ring(VertexId(v)))
                    .collect()
            });
            assert_eq!(got, want, "{threads} threads");
            assert!(t.is_manifold());
        }
    }
}
