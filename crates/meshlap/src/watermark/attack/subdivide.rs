//! One step of subdivision (the benchmark's "subdivision"), three schemes:
//!
//! - **Midpoint**: every edge split at its midpoint, every face into four
//!   ([`crate::mesh::builtin::subdivide_midpoint`]); V + E vertices, 4F faces; the
//!   surface is unchanged.
//! - **Loop** (C. Loop, 1987): the same connectivity; a new interior edge vertex is
//!   `3/8 (a + b) + 1/8 (c + d)` (c, d the opposite vertices), an old interior vertex of
//!   degree n becomes `(1 − nβ) v + β Σ neighbours` with Loop's
//!   `β = (5/8 − (3/8 + cos(2π/n)/4)²)/n`. Boundaries follow the cubic B-spline curve
//!   rules: a boundary edge vertex is the midpoint, a boundary vertex becomes
//!   `3/4 v + 1/8 (b₁ + b₂)` (b the boundary neighbours; a vertex on more than two
//!   boundary edges stays).
//! - **√3** (L. Kobbelt, SIGGRAPH 2000): a vertex at each face centroid, every interior
//!   edge flipped (each original interior half-edge a→b of face f, with twin in face g,
//!   gives the triangle (a, m_g, m_f)), old interior vertices relaxed to
//!   `(1 − αₙ) v + αₙ/n Σ neighbours`, `αₙ = (4 − 2 cos(2π/n))/9`. A boundary
//!   half-edge keeps its triangle (a, b, m_f) and boundary vertices stay (Kobbelt's
//!   boundary 1→3 split applies on every second step only, so one step leaves the
//!   boundary polygon as it is). V + F vertices, 3F faces.
//!
//! New vertices are appended after the old ones (edge vertices in
//! [`Topology::edges`] order, face vertices in face order); orientation is kept.

use super::{AttackError, SubdivisionScheme};
use crate::mesh::topology::{Topology, INVALID};
use crate::mesh::{builtin::subdivide_midpoint, EdgeId, TriMesh, VertexId};

/// One subdivision step of `mesh` with `scheme` (module documentation).
pub fn subdivide(mesh: &TriMesh, scheme: SubdivisionScheme) -> Result<TriMesh, AttackError> {
    match scheme {
        SubdivisionScheme::Midpoint => Ok(subdivide_midpoint(mesh)?),
        SubdivisionScheme::Loop => loop_step(mesh),
        SubdivisionScheme::Sqrt3 => sqrt3_step(mesh),
    }
}

fn add(a: &mut [f64; 3], p: [f64; 3], w: f64) {
    for k in 0..3 {
        a[k] += w * p[k];
    }
}

/// A vertex whose position the interior masks may not move (boundary or non-manifold).
fn is_fixed_boundary(topo: &Topology, v: VertexId) -> bool {
    topo.is_boundary_vertex(v) || !topo.is_manifold_vertex(v)
}

fn loop_step(mesh: &TriMesh) -> Result<TriMesh, AttackError> {
    let topo = Topology::new(mesh)?;
    let mut out = subdivide_midpoint(mesh)?;
    let n = mesh.n_vertices();
    let p = &mesh.positions;
    for (e, &[a, b]) in topo.edges().iter().enumerate() {
        let opp: Vec<u32> = topo.edge_opposite_vertices(EdgeId(e as u32)).collect();
        if opp.len() == 2 {
            let mut q = [0.0; 3];
            add(&mut q, p[a as usize], 3.0 / 8.0);
            add(&mut q, p[b as usize], 3.0 / 8.0);
            add(&mut q, p[opp[0] as usize], 1.0 / 8.0);
            add(&mut q, p[opp[1] as usize], 1.0 / 8.0);
            out.positions[n + e] = q;
        }
    }
    for v in 0..n {
        let id = VertexId(v as u32);
        let nb = topo.neighbors(id);
        if nb.is_empty() {
            continue;
        }
        let mut q = [0.0; 3];
        if is_fixed_boundary(&topo, id) {
            let bnd: Vec<u32> = nb
                .iter()
                .zip(topo.neighbor_edges(id))
                .filter(|&(_, &e)| topo.is_boundary_edge(EdgeId(e)))
                .map(|(&w, _)| w)
                .collect();
            if bnd.len() != 2 || !topo.is_manifold_vertex(id) {
                continue;
            }
            add(&mut q, p[v], 0.75);
            add(&mut q, p[bnd[0] as usize], 0.125);
            add(&mut q, p[bnd[1] as usize], 0.125);
        } else {
            let d = nb.len() as f64;
            let c = 3.0 / 8.0 + 0.25 * (std::f64::consts::TAU / d).cos();
            let beta = (5.0 / 8.0 - c * c) / d;
            add(&mut q, p[v], 1.0 - d * beta);
            for &w in nb {
                add(&mut q, p[w as usize], beta);
            }
        }
        out.positions[v] = q;
    }
    Ok(out)
}

fn sqrt3_step(mesh: &TriMesh) -> Result<TriMesh, AttackError> {
    let topo = Topology::new(mesh)?;
    let n = mesh.n_vertices() as u32;
    let p = &mesh.positions;
    let mut positions = Vec::with_capacity(mesh.n_vertices() + mesh.n_faces());
    for v in 0..n {
        let id = VertexId(v);
        let nb = topo.neighbors(id);
        if nb.is_empty() || is_fixed_boundary(&topo, id) {
            positions.push(p[v as usize]);
            continue;
        }
        let d = nb.len() as f64;
        let alpha = (4.0 - 2.0 * (std::f64::consts::TAU / d).cos()) / 9.0;
        let mut q = [0.0; 3];
        add(&mut q, p[v as usize], 1.0 - alpha);
        for &w in nb {
            add(&mut q, p[w as usize], alpha / d);
        }
        positions.push(q);
    }
    for t in &mesh.faces {
        let mut c = [0.0; 3];
        for &v in t {
            add(&mut c, p[v as usize], 1.0 / 3.0);
        }
        positions.push(c);
    }
    let mut faces = Vec::with_capacity(3 * mesh.n_faces());
    for h in 0..3 * mesh.n_faces() as u32 {
        let m_f = n + h / 3;
        let tw = topo.twin(h);
        let consistent = tw != INVALID && topo.from(tw) == topo.to(h);
        if consistent {
            faces.push([topo.from(h), n + tw / 3, m_f]);
        } else {
            faces.push([topo.from(h), topo.to(h), m_f]);
        }
    }
    Ok(TriMesh::new(positions, faces))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;
    use crate::mesh::clean::{clean, CleanOptions, MeshReport};

    fn report(m: &TriMesh) -> MeshReport {
        let (c, r) = clean(m, &CleanOptions::default()).unwrap();
        assert_eq!(c.n_vertices(), m.n_vertices(), "no vertex dropped");
        assert_eq!(c.n_faces(), m.n_faces(), "no face dropped");
        MeshReport::new(&c, &Topology::new(&c).unwrap(), &r)
    }

    #[test]
    fn vertex_and_face_counts_and_topology_are_right() {
        for m in [
            builtin::icosphere(1).unwrap(),
            builtin::torus(8, 5).unwrap(),
            builtin::grid(5).unwrap(),
        ] {
            let t = Topology::new(&m).unwrap();
            let (v, e, f) = (m.n_vertices(), t.n_edges(), m.n_faces());
            let r0 = report(&m);
            for scheme in SubdivisionScheme::ALL {
                let s = subdivide(&m, scheme).unwrap();
                let (want_v, want_f) = match scheme {
                    SubdivisionScheme::Sqrt3 => (v + f, 3 * f),
                    _ => (v + e, 4 * f),
                };
                assert_eq!(
                    (s.n_vertices(), s.n_faces()),
                    (want_v, want_f),
                    "{scheme:?}"
                );
                let r = report(&s);
                assert_eq!(
                    r.euler_characteristic, r0.euler_characteristic,
                    "{scheme:?}"
                );
                assert_eq!(r.boundary_loops, r0.boundary_loops);
                assert_eq!(r.non_manifold_edges + r.non_manifold_vertices, 0);
                assert_eq!(
                    r.inconsistently_oriented_edges, 0,
                    "{scheme:?} keeps orientation"
                );
            }
        }
    }

    #[test]
    fn loop_and_sqrt3_shrink_a_sphere_slightly_and_keep_a_plane() {
        let m = builtin::icosphere(2).unwrap();
        for scheme in [SubdivisionScheme::Loop, SubdivisionScheme::Sqrt3] {
            let s = subdivide(&m, scheme).unwrap();
            for p in &s.positions {
                let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                assert!(r < 1.0 + 1e-12 && r > 0.9, "{scheme:?} {r}");
            }
        }
        // Affine invariance: a flat grid stays flat, boundary vertices on the boundary.
        let g = builtin::grid(4).unwrap();
        let (lo, hi) = g.bounding_box().unwrap();
        let flat = (0..3).find(|&k| hi[k] == lo[k]).unwrap();
        for scheme in SubdivisionScheme::ALL {
            let s = subdivide(&g, scheme).unwrap();
            assert!(s
                .positions
                .iter()
                .all(|p| (p[flat] - lo[flat]).abs() < 1e-15));
            let (slo, shi) = s.bounding_box().unwrap();
            for k in 0..3 {
                assert!((slo[k] - lo[k]).abs() < 1e-12 && (shi[k] - hi[k]).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn loop_reproduces_the_regular_masks() {
        // On the torus every vertex has degree 6: β = 1/16, so v' = 5/8 v + 1/16 Σ.
        let m = builtin::torus(7, 5).unwrap();
        let t = Topology::new(&m).unwrap();
        let s = subdivide(&m, SubdivisionScheme::Loop).unwrap();
        let v = 3;
        let mut want = [0.0; 3];
        add(&mut want, m.positions[v], 5.0 / 8.0);
        for &w in t.neighbors(VertexId(v as u32)) {
            add(&mut want, m.positions[w as usize], 1.0 / 16.0);
        }
        for k in 0..3 {
            assert!((s.positions[v][k] - want[k]).abs() < 1e-12);
        }
    }
}
