//! The cotangent Laplace–Beltrami operator, Pinkall & Polthier (1993); Desbrun et al.
//! (1999); Meyer et al. (2003), with its lumped mass matrix.
//!
//! Stiffness `L`: n×n, symmetric, `L_ij = −½(cot α_ij + cot β_ij)` for an interior edge
//! (α, β the angles opposite the edge), `−½ cot α_ij` on a boundary edge, and
//! `L_ii = −Σ_j L_ij`. Sign convention `F = D − W`: positive semi-definite when no
//! weight is negative (libigl's `cotmatrix` is `−L`). Zero row sums; linear precision on
//! planar meshes (`L·x = 0` at interior vertices for linear `x`). The generalized
//! eigenproblem `L v = λ M v` uses the diagonal mass matrix `M`:
//!
//! - [`MassKind::Voronoi`]: the mixed Voronoi area of Meyer et al. (2003) (circumcentric
//!   Voronoi cells, with the obtuse-triangle fallback: half the area to the obtuse
//!   vertex, a quarter to each other);
//! - [`MassKind::Barycentric`]: one third of each incident triangle's area.
//!
//! **Degenerate input.** A triangle whose doubled area `‖(b − a) × (c − a)‖` is not
//! above `ε·ℓ²` (ε the `f64` machine epsilon, ℓ its longest edge) is zero-area to
//! rounding — collinear or coincident corners, or a needle thinner than the rounding
//! of its edges — and its cotangents are meaningless (infinite, or as large as
//! `1/ε`): such a face is an error, [`OperatorError::DegenerateFace`], naming the face.
//! Above the threshold every cotangent is bounded by about `1/ε`, so the weights are
//! finite; an overflow of extremely scaled coordinates is
//! [`OperatorError::NonFinite`]. An isolated vertex (no faces) gets an empty row and
//! zero mass. The result is never NaN or infinite.

use super::assemble::FaceSink;
#[cfg(test)]
use super::geometry::norm;
use super::geometry::{cross, dot, sub};
use super::OperatorError;
use crate::mesh::{topology::Topology, TriMesh};
use crate::SparseMatrix;
use std::sync::atomic::{AtomicBool, Ordering};

/// Lumped mass matrix of the cotangent operator.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum MassKind {
    /// Mixed Voronoi areas (Meyer et al. 2003).
    #[default]
    Voronoi,
    /// One third of the incident triangle areas.
    Barycentric,
}

crate::names::option_names!(MassKind, OperatorError, |s| OperatorError::UnknownOption {
    what: "mass matrix",
    name: s.to_string(),
    choices: "voronoi, barycentric",
}, {
    Voronoi => "voronoi",
    Barycentric => "barycentric",
});

/// Assembles the cotangent stiffness matrix (n×n, `F = D − W`, positive semi-definite
/// when no weight is negative) and the lumped mass diagonal (n).
///
/// Two passes, each parallel and each summing in a fixed order, so every entry is
/// the same sum in the same order on any number of threads: the per-face geometry
/// over chunks of faces, ½ cot of the corner opposite each half-edge written to its
/// side of the edge and each corner's mass share to its slot
/// (`assemble::per_face_edge_sides`); the columns, each edge's weight summed from its
/// two sides in face order and the diagonal in neighbour order
/// (`assemble::one_ring_columns`). The masses are added face by face on one thread
/// while the others fill the matrix.
pub fn cotan(
    mesh: &TriMesh,
    topo: &Topology,
    mass_kind: MassKind,
) -> Result<(SparseMatrix, Vec<f64>), OperatorError> {
    let faces = topo.faces();
    // Per half-edge 3f + m (from corner m to corner m + 1 of face f): ½ cot of the
    // corner opposite it, corner m + 2, summed per edge; per corner m its mass share.
    let (sides, shares) = super::assemble::per_face_edge_sides(
        topo,
        0.0f64,
        |a, b| a + b,
        &CotanFaces {
            pos: &mesh.positions,
            faces,
            mass_kind,
        },
    )?;
    // Edge e's weight ½(cot α + cot β), its half-edges in face order.
    let w = |e: u32| {
        let [a, b] = sides[e as usize];
        0.0 + a + b
    };
    // Raised by a column with a non-finite entry: only then is the matrix scanned again.
    let flagged = AtomicBool::new(false);
    let (mass, l) = rayon::join(
        || add_corner_shares(topo.n_vertices(), faces, &shares),
        || {
            super::assemble::one_ring_columns(topo, |j, off| {
                let edges = topo.neighbor_edges(crate::VertexId(j as u32));
                // Each weight read once; the diagonal summed in the same order and
                // from the same −0.0 as `Iterator::sum`.
                let mut diag = -0.0;
                for (o, &e) in off.iter_mut().zip(edges) {
                    let x = w(e);
                    *o = -x;
                    diag += x;
                }
                // The sum of the column's weights is non-finite exactly when one of
                // its entries is (the diagonal included).
                if !diag.is_finite() {
                    flagged.store(true, Ordering::Relaxed);
                }
                diag
            })
        },
    );
    super::check_finite_flagged(&l, flagged.into_inner(), Some(&mass), "cotan")?;
    Ok((l, mass))
}

/// The lumped mass diagonal (n) of the cotangent operator alone, without its
/// stiffness matrix or the mesh's connectivity: per vertex the sum of its corners'
/// shares ([`MassKind`]: mixed Voronoi areas, Meyer et al. 2003, or a third of each
/// incident triangle's area), added face by face — the same bits as the mass
/// [`cotan`] returns, on any number of threads. The `M` of `L v = λ M v` with `L`
/// the cotangent stiffness (sign `F = D − W`, positive semi-definite).
///
/// `mesh.faces`: f×3 corner indices below n; positions n×3. An isolated vertex gets
/// zero mass. Errors: a corner out of range ([`crate::mesh::MeshError::IndexOutOfRange`]);
/// a degenerate face, a repeated corner included ([`OperatorError::DegenerateFace`],
/// the lowest such face, as [`cotan`] names it); a mass that overflows
/// ([`OperatorError::NonFinite`]). Unlike [`cotan`], stiffness weights that overflow
/// while every mass is finite are no error here.
pub fn mass(mesh: &TriMesh, mass_kind: MassKind) -> Result<Vec<f64>, OperatorError> {
    use rayon::prelude::*;
    const CHUNK: usize = 1024;
    let faces = &mesh.faces[..];
    crate::mesh::check_face_indices(faces, mesh.n_vertices())?;
    let mut shares = vec![[0.0f64; 3]; faces.len()];
    let first_bad = shares
        .par_chunks_mut(CHUNK)
        .enumerate()
        .map_init(
            || Vec::with_capacity(CHUNK),
            |buf, (c, out)| {
                buf.clear();
                let range = c * CHUNK..c * CHUNK + out.len();
                match face_geometry(&mesh.positions, faces, range, mass_kind, buf) {
                    Ok(()) => {
                        for (o, &(_, share)) in out.iter_mut().zip(buf.iter()) {
                            *o = share;
                        }
                        None
                    }
                    Err(e) => Some((c, e)),
                }
            },
        )
        .flatten()
        .min_by_key(|&(c, _)| c);
    if let Some((_, e)) = first_bad {
        return Err(e);
    }
    let mass = add_corner_shares(mesh.n_vertices(), faces, shares.as_flattened());
    match super::first_non_finite(&mass) {
        Some(v) => Err(OperatorError::NonFinite {
            vertex: v as u32,
            kind: "cotan",
        }),
        None => Ok(mass),
    }
}

/// The mass diagonal (n) from the corners' shares (three per face, in face order):
/// added face by face on one thread, so that [`cotan`] and [`mass`] give the same
/// bits on any number of threads.
fn add_corner_shares(n: usize, faces: &[[u32; 3]], shares: &[f64]) -> Vec<f64> {
    let mut mass = vec![0.0f64; n];
    for (t, s) in faces.iter().zip(shares.chunks_exact(3)) {
        for k in 0..3 {
            mass[t[k] as usize] += s[k];
        }
    }
    mass
}

/// The cotan's per-face values for `assemble::per_face_edge_sides`: [`FaceGeometry`].
struct CotanFaces<'a> {
    pos: &'a [[f64; 3]],
    faces: &'a [[u32; 3]],
    mass_kind: MassKind,
}

impl super::assemble::FaceValues<f64, f64> for CotanFaces<'_> {
    type Error = OperatorError;
    #[inline]
    fn put_faces<S: FaceSink<f64, f64>>(
        &self,
        range: std::ops::Range<usize>,
        sink: &mut S,
    ) -> Result<(), OperatorError> {
        face_geometry(self.pos, self.faces, range, self.mass_kind, sink)
    }
}

/// [`FaceGeometry`] of `faces[range]` put into `out`, or the degenerate face it met
/// first, named.
fn face_geometry<S: FaceSink<f64, f64>>(
    pos: &[[f64; 3]],
    faces: &[[u32; 3]],
    range: std::ops::Range<usize>,
    mass_kind: MassKind,
    out: &mut S,
) -> Result<(), OperatorError> {
    let first = range.start;
    let bad = crate::cpu::dispatch(FaceGeometry {
        pos,
        faces: &faces[range],
        mass_kind,
        out,
    });
    match bad {
        None => Ok(()),
        Some(q) => {
            let t = faces[first + q];
            Err(OperatorError::DegenerateFace {
                face: (first + q) as u32,
                a: t[0],
                b: t[1],
                c: t[2],
                kind: "cotan",
            })
        }
    }
}

/// Faces per group of lanes in [`FaceGeometry`].
const LANES: usize = 64;

/// The per-face geometry of consecutive faces: per face, ½·cot of the corner opposite
/// each half-edge m (from corner m to corner m + 1: the corner m + 2) and each
/// corner's mass share, put into `out` in face order; stops at the first face that
/// is degenerate ([`is_proper_triangle`]) and returns its index in `faces`.
///
/// Per group of [`LANES`] faces, one loop gathers the corners and forms the edge
/// vectors' products (scalar: the corners are scattered), and one loop over the lanes
/// does the square roots, divisions and the mass's cases without branches, so that it
/// vectorises; each lane computes the same IEEE operations in the same order as a
/// face at a time (the cot at corner k: the dot product of the two edges leaving it
/// over the doubled area `‖e₀ × (c − a)‖`), so the bits do not depend on the build.
/// The kernel runs in the AVX2 build where the CPU has it ([`crate::cpu::dispatch`]).
struct FaceGeometry<'a, S> {
    pos: &'a [[f64; 3]],
    faces: &'a [[u32; 3]],
    mass_kind: MassKind,
    out: &'a mut S,
}

impl<S: FaceSink<f64, f64>> crate::cpu::Kernel for FaceGeometry<'_, S> {
    type Output = Option<usize>;
    #[inline(always)]
    fn portable(self) -> Option<usize> {
        let FaceGeometry {
            pos,
            faces,
            mass_kind,
            out,
        } = self;
        let voronoi = mass_kind == MassKind::Voronoi;
        // Per lane: the squared edge lengths (edge k from corner k to corner k + 1),
        // the cots' numerators (corner k) and the squared doubled area; the halved cots
        // and the mass shares. Zeroed once per call, not per group (BENCHMARKS.md,
        // "Operator assembly"): a group writes every lane it reads, except that the
        // lanes past a short last group compute on an earlier group's values (or
        // zeros) and are not read.
        let mut len2 = [[0.0f64; LANES]; 3];
        let mut num = [[0.0f64; LANES]; 3];
        let mut cross2 = [0.0f64; LANES];
        let mut half = [[0.0f64; LANES]; 3];
        let mut mass = [[0.0f64; LANES]; 3];
        let mut proper = [false; LANES];
        for (g, group) in faces.chunks(LANES).enumerate() {
            for (q, t) in group.iter().enumerate() {
                let [a, b, c] = [pos[t[0] as usize], pos[t[1] as usize], pos[t[2] as usize]];
                let (e0, e1, e2) = (sub(b, a), sub(c, b), sub(a, c));
                len2[0][q] = dot(e0, e0);
                len2[1][q] = dot(e1, e1);
                len2[2][q] = dot(e2, e2);
                let n = cross(e0, sub(c, a));
                cross2[q] = dot(n, n);
                let neg = |v: [f64; 3]| [-v[0], -v[1], -v[2]];
                num[0][q] = dot(e0, neg(e2));
                num[1][q] = dot(e1, neg(e0));
                num[2][q] = dot(e2, neg(e1));
            }
            for q in 0..LANES {
                let area2 = cross2[q].sqrt();
                let l2 = [len2[0][q], len2[1][q], len2[2][q]];
                proper[q] = proper_triangle(area2, l2);
                let cots = [num[0][q] / area2, num[1][q] / area2, num[2][q] / area2];
                let area = 0.5 * area2;
                // The first obtuse corner, if any, takes half the area, the others a
                // quarter; else the Voronoi area at corner k: 1/8 (|e_kj|² cot at l +
                // |e_kl|² cot at j), j = k + 1, l = k + 2 (e_kj edge k, e_kl edge k + 2).
                let o = [cots[0] < 0.0, cots[1] < 0.0, cots[2] < 0.0];
                let first = [o[0], !o[0] && o[1], !o[0] && !o[1] && o[2]];
                let obtuse = o[0] | o[1] | o[2];
                for k in 0..3 {
                    half[k][q] = 0.5 * cots[k];
                    let (j, l) = ((k + 1) % 3, (k + 2) % 3);
                    let circum = (l2[k] * cots[l] + l2[l] * cots[j]) / 8.0;
                    let share = if first[k] { area / 2.0 } else { area / 4.0 };
                    mass[k][q] = if !voronoi {
                        area / 3.0
                    } else if obtuse {
                        share
                    } else {
                        circum
                    };
                }
            }
            for q in 0..group.len() {
                if !proper[q] {
                    return Some(g * LANES + q);
                }
                out.put(
                    [half[2][q], half[0][q], half[1][q]],
                    [mass[0][q], mass[1][q], mass[2][q]],
                );
            }
        }
        None
    }
}

/// True when a triangle with doubled area `area2` and corners `p` has an area above
/// the rounding of its edge lengths: `area2 > ε·ℓ²` (ℓ the longest edge), both finite.
/// Below that the corners are collinear to rounding and angles, cotangents and
/// half-angle tangents are meaningless. Shared by the geometric operators.
pub(crate) fn is_proper_triangle(area2: f64, p: [[f64; 3]; 3]) -> bool {
    let len2: [f64; 3] = std::array::from_fn(|k| {
        let e = sub(p[(k + 1) % 3], p[k]);
        dot(e, e)
    });
    proper_triangle(area2, len2)
}

/// [`is_proper_triangle`] from the squared edge lengths.
#[inline]
pub(crate) fn proper_triangle(area2: f64, len2: [f64; 3]) -> bool {
    let longest2 = len2.into_iter().fold(0.0f64, f64::max);
    area2.is_finite() && longest2.is_finite() && area2 > f64::EPSILON * longest2
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{builtin, VertexId};
    use crate::operator::test_util::*;
    use rand::{Rng, SeedableRng};

    fn jittered_grid(n: usize, seed: u64) -> TriMesh {
        let mut m = builtin::grid(n).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let h = 1.0 / n as f64;
        for p in &mut m.positions {
            if p[0] > 0.0 && p[0] < 1.0 && p[1] > 0.0 && p[1] < 1.0 {
                p[0] += rng.gen_range(-0.2..0.2) * h;
                p[1] += rng.gen_range(-0.2..0.2) * h;
            }
        }
        m
    }

    #[test]
    fn linear_precision_on_planar_meshes() {
        for seed in 0..3 {
            let m = jittered_grid(7, seed);
            let t = topo(&m);
            let (l, _) = cotan(&m, &t, MassKind::Voronoi).unwrap();
            for coord in 0..2 {
                let x = faer::Col::<f64>::from_fn(m.n_vertices(), |i| m.positions[i][coord]);
                let y = &l * &x;
                for v in 0..m.n_vertices() {
                    if !t.is_boundary_vertex(VertexId(v as u32)) {
                        assert!(y[v].abs() < 1e-13, "seed {seed} vertex {v}: {}", y[v]);
                    }
                }
            }
        }
    }

    #[test]
    fn symmetric_zero_row_sum_and_mass_is_area() {
        for (name, m) in meshes() {
            let t = topo(&m);
            let area: f64 = m
                .faces
                .iter()
                .map(|f| {
                    let [a, b, c] = f.map(|v| m.positions[v as usize]);
                    0.5 * norm(cross(sub(b, a), sub(c, a)))
                })
                .sum();
            for kind in [MassKind::Voronoi, MassKind::Barycentric] {
                let (l, mass) = cotan(&m, &t, kind).unwrap();
                // Both entries of an edge come from its one weight: exactly.
                assert!(asymmetry(&l) == 0.0, "{name}");
                assert!(max_abs_row_sum(&l) < 1e-12, "{name}");
                let total: f64 = mass.iter().sum();
                assert!((total - area).abs() < 1e-12 * area, "{name} {kind:?}");
                assert!(mass.iter().all(|&x| x > 0.0));
            }
        }
    }

    /// The masses of a face at a time, with the formulas of the module doc (the obtuse
    /// case by a search for the first obtuse corner), as the lanes replaced them.
    fn masses_face_at_a_time(m: &TriMesh, kind: MassKind) -> Vec<f64> {
        let mut mass = vec![0.0f64; m.n_vertices()];
        for t in &m.faces {
            let [a, b, c] = t.map(|v| m.positions[v as usize]);
            let (e0, e1, e2) = (sub(b, a), sub(c, b), sub(a, c));
            let len2 = [dot(e0, e0), dot(e1, e1), dot(e2, e2)];
            let area2 = norm(cross(e0, sub(c, a)));
            let neg = |v: [f64; 3]| [-v[0], -v[1], -v[2]];
            let cots = [
                dot(e0, neg(e2)) / area2,
                dot(e1, neg(e0)) / area2,
                dot(e2, neg(e1)) / area2,
            ];
            let area = 0.5 * area2;
            let obtuse = (0..3).find(|&k| cots[k] < 0.0);
            for k in 0..3 {
                let share = match (kind, obtuse) {
                    (MassKind::Barycentric, _) => area / 3.0,
                    (MassKind::Voronoi, Some(o)) if o == k => area / 2.0,
                    (MassKind::Voronoi, Some(_)) => area / 4.0,
                    (MassKind::Voronoi, None) => {
                        let (j, l) = ((k + 1) % 3, (k + 2) % 3);
                        (len2[k] * cots[l] + len2[l] * cots[j]) / 8.0
                    }
                };
                mass[t[k] as usize] += share;
            }
        }
        mass
    }

    #[test]
    fn masses_equal_a_face_at_a_time_bit_for_bit() {
        let cow = crate::input::open(
            &format!("{}/../../tests/data/cow.obj", env!("CARGO_MANIFEST_DIR")),
            &crate::input::OpenOptions::default(),
        )
        .unwrap()
        .mesh;
        let mut cases: Vec<(String, TriMesh)> = meshes()
            .into_iter()
            .map(|(n, m)| (n.to_string(), m))
            .collect();
        cases.push(("cow".into(), cow));
        // Jittered by up to 0.4 of the spacing: many obtuse triangles.
        let mut grid = builtin::grid(40).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for p in &mut grid.positions {
            p[0] += rng.gen_range(-0.01..0.01);
            p[1] += rng.gen_range(-0.01..0.01);
            p[2] = rng.gen_range(-0.002..0.002);
        }
        cases.push(("jittered grid".into(), grid));
        for (name, m) in &cases {
            let t = topo(m);
            for kind in [MassKind::Voronoi, MassKind::Barycentric] {
                let want: Vec<u64> = masses_face_at_a_time(m, kind)
                    .iter()
                    .map(|x| x.to_bits())
                    .collect();
                for threads in [1, 3] {
                    let pool = rayon::ThreadPoolBuilder::new()
                        .num_threads(threads)
                        .build()
                        .unwrap();
                    let (_, with_stiffness) = pool.install(|| cotan(m, &t, kind).unwrap());
                    let alone = pool.install(|| mass(m, kind).unwrap());
                    for (what, got) in [("cotan", with_stiffness), ("mass", alone)] {
                        let got: Vec<u64> = got.iter().map(|x| x.to_bits()).collect();
                        assert!(got == want, "{what}: {name} {kind:?} {threads} threads");
                    }
                }
            }
        }
    }

    #[test]
    fn needle_below_rounding_is_an_error_above_it_finite() {
        for (h, ok) in [(1e-17, false), (1e-13, true), (1e-6, true)] {
            let m = TriMesh::new(
                vec![[0.0; 3], [1.0, 0.0, 0.0], [0.5, h, 0.0]],
                vec![[0, 1, 2]],
            );
            let r = cotan(&m, &topo(&m), MassKind::Voronoi);
            match r {
                Ok((l, mass)) => {
                    assert!(ok, "height {h}");
                    assert!(l.val().iter().chain(&mass).all(|v| v.is_finite()));
                }
                Err(e) => {
                    assert!(!ok, "height {h}: {e}");
                    assert!(e.to_string().contains("face 0 (0, 1, 2)"), "{e}");
                }
            }
        }
    }

    #[test]
    fn the_first_degenerate_face_is_named_on_any_pool() {
        first_degenerate_face_is_named(|m, t| cotan(m, t, MassKind::Voronoi));
        first_degenerate_face_is_named(|m, _| mass(m, MassKind::Voronoi));
    }

    #[test]
    fn the_mass_alone_refuses_bad_corners_and_leaves_isolated_vertices_at_zero() {
        let tri = |faces: Vec<[u32; 3]>| {
            TriMesh::new(
                vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [5.0, 5.0, 5.0]],
                faces,
            )
        };
        let m = mass(&tri(vec![[0, 1, 2]]), MassKind::Barycentric).unwrap();
        assert_eq!(m, vec![0.5 / 3.0, 0.5 / 3.0, 0.5 / 3.0, 0.0]);
        assert!(matches!(
            mass(&tri(vec![[0, 1, 2], [0, 1, 4]]), MassKind::Voronoi),
            Err(OperatorError::Mesh(
                crate::mesh::MeshError::IndexOutOfRange { .. }
            ))
        ));
        // A repeated corner is a face of zero area.
        assert!(matches!(
            mass(&tri(vec![[0, 1, 2], [1, 1, 3]]), MassKind::Voronoi),
            Err(OperatorError::DegenerateFace { face: 1, .. })
        ));
        // Areas that overflow: degenerate, as in `cotan`.
        let mut huge = tri(vec![[0, 1, 2]]);
        huge.positions
            .iter_mut()
            .flatten()
            .for_each(|x| *x *= 1e200);
        assert!(matches!(
            mass(&huge, MassKind::Voronoi),
            Err(OperatorError::DegenerateFace { face: 0, .. })
        ));
    }

    #[test]
    fn large_meshes_scale_and_overflowing_areas_are_an_error() {
        // At 1e70 every weight and mass is finite and scales as it should (the columns'
        // finiteness test raises no false alarm); at 1e154 the squared doubled areas
        // overflow, which is an area that overflows (`DegenerateFace`), never a NaN.
        let base = crate::mesh::builtin::icosphere(2).unwrap();
        let scaled = |s: f64| {
            let mut m = base.clone();
            m.positions.iter_mut().flatten().for_each(|x| *x *= s);
            m
        };
        let (l1, m1) = cotan(&base, &topo(&base), MassKind::Voronoi).unwrap();
        let big = scaled(1e70);
        let (l, m) = cotan(&big, &topo(&big), MassKind::Voronoi).unwrap();
        // Cotangents are scale-free, masses scale with the square.
        assert!((l.to_dense() - l1.to_dense()).norm_max() < 1e-12);
        assert!(m
            .iter()
            .zip(&m1)
            .all(|(a, b)| (a / 1e140 - b).abs() < 1e-12 * b));
        let huge = scaled(1e154);
        assert!(matches!(
            cotan(&huge, &topo(&huge), MassKind::Voronoi),
            Err(OperatorError::DegenerateFace { kind: "cotan", .. })
        ));
    }

    #[test]
    fn degenerate_face_is_an_error() {
        let m = TriMesh::new(
            vec![[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
            vec![[0, 1, 2]],
        );
        assert!(matches!(
            cotan(&m, &topo(&m), MassKind::Voronoi),
            Err(OperatorError::DegenerateFace { .. })
        ));
    }
}
