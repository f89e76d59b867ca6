//! Small generated meshes with every kind of non-manifold configuration, for tests of
//! the commands that must accept them (`builtin:nm-KIND`; see [`NonManifoldKind`]).
//! Positions are in general position (no zero-area face, no zero-length edge), so the
//! geometric operators are defined on them.

use super::TriMesh;
use glam::DVec3;

/// Which non-manifold configuration [`non_manifold`] builds.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum NonManifoldKind {
    /// `nm-fin`: a closed cone with a triangular fin on one of its edges (an edge of
    /// three faces).
    Fin,
    /// `nm-book`: two closed tetrahedra sharing an edge (an edge of four faces).
    Book,
    /// `nm-bowtie`: two closed cones touching at their apex (a vertex whose faces form
    /// two closed fans).
    Bowtie,
    /// `nm-fans`: two open cones (no base) touching at their apex (a vertex joining
    /// two boundary fans).
    Fans,
    /// `nm-flipped`: an octahedron with one face flipped (three inconsistently
    /// oriented edges).
    Flipped,
    /// `nm-moebius`: a Möbius strip (not orientable: one inconsistent edge whatever the
    /// orientation).
    Moebius,
    /// `nm-mixed`: all of the above side by side, and a grid with a fin on an interior
    /// edge: one mesh of seven components.
    Mixed,
}

impl NonManifoldKind {
    /// Every kind, with its `builtin:` name.
    pub const ALL: [(NonManifoldKind, &'static str); 7] = [
        (NonManifoldKind::Fin, "nm-fin"),
        (NonManifoldKind::Book, "nm-book"),
        (NonManifoldKind::Bowtie, "nm-bowtie"),
        (NonManifoldKind::Fans, "nm-fans"),
        (NonManifoldKind::Flipped, "nm-flipped"),
        (NonManifoldKind::Moebius, "nm-moebius"),
        (NonManifoldKind::Mixed, "nm-mixed"),
    ];

    /// The kind named `name` (`nm-fin`, …).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.iter().find(|(_, n)| *n == name).map(|(k, _)| *k)
    }
}

/// A cone over a ring of `k` vertices around the z axis at height 0, apex at
/// `apex_z`, closed by a base fan around a centre vertex when `closed`; faces
/// oriented outwards. Vertex 0 is the apex.
fn cone(k: usize, apex_z: f64, closed: bool) -> TriMesh {
    let mut p = vec![[0.0, 0.0, apex_z]];
    for i in 0..k {
        let t = std::f64::consts::TAU * i as f64 / k as f64;
        // A slightly irregular ring: no two edges alike.
        let r = 1.0 + 0.1 * (i as f64 * 1.7).sin();
        p.push([r * t.cos(), r * t.sin(), 0.0]);
    }
    let up = apex_z > 0.0;
    let mut f = Vec::new();
    for i in 0..k as u32 {
        let (a, b) = (1 + i, 1 + (i + 1) % k as u32);
        f.push(if up { [0, a, b] } else { [0, b, a] });
    }
    if closed {
        let c = p.len() as u32;
        p.push([0.05, -0.03, 0.0]);
        for i in 0..k as u32 {
            let (a, b) = (1 + i, 1 + (i + 1) % k as u32);
            f.push(if up { [c, b, a] } else { [c, a, b] });
        }
    }
    TriMesh::new(p, f)
}

/// Appends `b` to `a` shifted by `offset` (no shared vertices).
fn append(a: &mut TriMesh, b: &TriMesh, offset: [f64; 3]) {
    let base = a.positions.len() as u32;
    a.positions.extend(
        b.positions
            .iter()
            .map(|p| (DVec3::from(*p) + DVec3::from(offset)).to_array()),
    );
    a.faces.extend(b.faces.iter().map(|f| f.map(|v| v + base)));
}

/// Merges vertex `from` into vertex `into` (`from` must be the last vertex).
fn glue_last(m: &mut TriMesh, into: u32) {
    let from = (m.positions.len() - 1) as u32;
    m.positions.pop();
    for f in &mut m.faces {
        for v in f.iter_mut() {
            if *v == from {
                *v = into;
            }
        }
    }
}

/// The mesh of `kind` (see [`NonManifoldKind`]).
pub fn non_manifold(kind: NonManifoldKind) -> TriMesh {
    match kind {
        NonManifoldKind::Fin => {
            let mut m = cone(6, 1.0, true);
            // Fin on the side edge (apex, ring vertex 1).
            m.positions.push([1.2, 0.9, 0.8]);
            m.faces.push([0, 1, 8]);
            m
        }
        NonManifoldKind::Book => {
            let p = vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.1],
                [0.45, 1.0, 0.0],
                [0.55, 0.4, 1.0],
                [0.5, -1.1, 0.05],
                [0.4, -0.5, -0.9],
            ];
            let f = vec![
                [0, 2, 1],
                [0, 1, 3],
                [1, 2, 3],
                [0, 3, 2],
                [1, 0, 4],
                [0, 4, 5],
                [1, 5, 4],
                [0, 5, 1],
            ];
            let mut m = TriMesh::new(p, f);
            orient_per_tetrahedron(&mut m);
            m
        }
        NonManifoldKind::Bowtie | NonManifoldKind::Fans => {
            let closed = kind == NonManifoldKind::Bowtie;
            let mut m = cone(7, 1.0, closed);
            let mut lower = cone(5, -1.0, closed);
            // Put the lower cone's apex at the upper one's, then glue them there.
            for p in &mut lower.positions {
                p[2] += 2.0;
                p[0] += 0.1;
            }
            let last = (lower.positions.len() - 1) as u32;
            lower.positions.swap(0, last as usize);
            for f in &mut lower.faces {
                for v in f.iter_mut() {
                    *v = if *v == 0 {
                        last
                    } else if *v == last {
                        0
                    } else {
                        *v
                    };
                }
            }
            append(&mut m, &lower, [0.0; 3]);
            glue_last(&mut m, 0);
            m
        }
        NonManifoldKind::Flipped => {
            let mut m = super::builtin::octahedron();
            m.faces[0].swap(1, 2);
            m
        }
        NonManifoldKind::Moebius => {
            let u = 9usize;
            let mut p = Vec::new();
            for i in 0..u {
                let t = std::f64::consts::TAU * i as f64 / u as f64;
                for j in 0..2 {
                    let w = (j as f64 - 0.5) * 0.6;
                    let r = 1.0 + w * (t / 2.0).cos();
                    p.push([r * t.cos(), r * t.sin(), w * (t / 2.0).sin()]);
                }
            }
            let mut f = Vec::new();
            for i in 0..u as u32 {
                let (a, b) = (2 * i, 2 * i + 1);
                // The last segment closes with a half twist.
                let (c, d) = if i + 1 == u as u32 {
                    (1, 0)
                } else {
                    (a + 2, a + 3)
                };
                f.push([a, c, b]);
                f.push([b, c, d]);
            }
            TriMesh::new(p, f)
        }
        NonManifoldKind::Mixed => {
            let mut m = TriMesh::new(Vec::new(), Vec::new());
            for (i, (k, _)) in NonManifoldKind::ALL[..6].iter().enumerate() {
                append(
                    &mut m,
                    &non_manifold(*k),
                    [4.0 * i as f64, 0.3 * i as f64, 0.0],
                );
            }
            // And a grid (a boundary) with a fin on an interior edge.
            let g = super::builtin::grid(3).unwrap_or_else(|_| TriMesh::new(vec![], vec![]));
            append(&mut m, &g, [0.0, 5.0, 0.0]);
            let base = (m.positions.len() - g.positions.len()) as u32;
            m.positions.push([0.5, 5.4, 0.7]);
            let tip = (m.positions.len() - 1) as u32;
            // An edge of two grid faces: (a, b) in one, (b, a) in another.
            let shared = g
                .faces
                .iter()
                .flat_map(|f| (0..3).map(move |k| (f[k], f[(k + 1) % 3])))
                .find(|&(a, b)| {
                    g.faces
                        .iter()
                        .any(|f| (0..3).any(|k| (f[k], f[(k + 1) % 3]) == (b, a)))
                });
            if let Some((a, b)) = shared {
                m.faces.push([base + a, base + b, tip]);
            }
            m
        }
    }
}

/// Orients every face of a mesh of tetrahedra (faces `4t..4t + 4`) outwards.
fn orient_per_tetrahedron(m: &mut TriMesh) {
    for t in 0..m.faces.len() / 4 {
        let vs: Vec<DVec3> = m.faces[4 * t..4 * t + 4]
            .iter()
            .flatten()
            .map(|&v| DVec3::from(m.positions[v as usize]))
            .collect();
        let centre = vs.iter().copied().sum::<DVec3>() / vs.len() as f64;
        for f in &mut m.faces[4 * t..4 * t + 4] {
            let [a, b, c] = f.map(|v| DVec3::from(m.positions[v as usize]));
            if (b - a).cross(c - a).dot((a + b + c) / 3.0 - centre) < 0.0 {
                f.swap(1, 2);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::topology::Topology;

    #[test]
    fn each_kind_has_its_defect() {
        for (kind, name) in NonManifoldKind::ALL {
            let m = non_manifold(kind);
            m.validate().unwrap();
            let t = Topology::new(&m).unwrap();
            let nme = t.non_manifold_edges().count();
            let nmv = t.non_manifold_vertices().count();
            let inc = t.inconsistently_oriented_edges();
            let counts: Vec<usize> = t
                .non_manifold_edges()
                .map(|e| t.edge_face_count(e))
                .collect();
            match kind {
                NonManifoldKind::Fin => assert_eq!(counts, vec![3], "{name}"),
                NonManifoldKind::Book => assert_eq!(counts, vec![4], "{name}"),
                NonManifoldKind::Bowtie | NonManifoldKind::Fans => {
                    assert_eq!((nme, nmv, inc), (0, 1, 0), "{name}")
                }
                NonManifoldKind::Flipped => assert_eq!((nme, nmv, inc), (0, 0, 3), "{name}"),
                NonManifoldKind::Moebius => assert_eq!((nme, nmv, inc), (0, 0, 1), "{name}"),
                NonManifoldKind::Mixed => {
                    assert_eq!((nme, inc), (3, 4), "{name}");
                    assert_eq!(t.components().1, 7, "{name}");
                }
            }
            if matches!(kind, NonManifoldKind::Fans) {
                assert!(t.boundary_edges().count() > 0);
            }
            assert_eq!(crate::mesh::clean::zero_area_faces(&m), 0, "{name}");
        }
    }
}
