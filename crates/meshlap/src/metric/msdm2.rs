//! MSDM2, the multiscale mesh structural distortion measure of G. Lavoué, "A multiscale
//! metric for 3D mesh visual quality assessment" (SGP 2011, *Computer Graphics Forum*
//! 30(5)): a score in [0, 1) (0 for identical meshes) predicting how visible the
//! difference between a reference and a test mesh is. The meshes may have different
//! connectivity and vertex counts; they must be aligned (no registration is done, so a
//! rotation of one mesh alone is a large distortion).
//!
//! ## How it is computed
//! Let `D` be the largest side of the reference's bounding box. For each scale
//! `i = 0 … n−1` (published: n = 3) the neighbourhood radius is
//! `hᵢ = (0.010 + 0.005·i)·D` (0.010 D, 0.015 D, 0.020 D) and the curvature radius
//! `rᵢ = hᵢ/5`.
//!
//! 1. **Curvature.** On each mesh, at every vertex v, the curvature tensor of
//!    Cohen-Steiner and Morvan (SoCG 2003; the normal-cycle estimator as used by Alliez
//!    et al., SIGGRAPH 2003) over the ball of radius `rᵢ`:
//!    `T(v) = 1/(π rᵢ²) · Σ_e β(e) · |e ∩ B| · ê êᵀ`, over the edges reached from v
//!    through vertices inside the ball (`β(e)` the signed dihedral angle, `|e ∩ B|` the
//!    length of the edge inside the ball, boundary edges contribute nothing). Its two
//!    eigenvalues of largest magnitude estimate the principal curvatures κ₁, κ₂; the
//!    field is the scale-free curvature amplitude `c(v) = D·(|κ₁| + |κ₂|)/2`.
//! 2. **Matching.** Each vertex v of the mesh X being scanned is matched to its
//!    closest point `v̂` on the other mesh Y (the BVH of [`super::bvh`]); the curvature
//!    of Y there, `ĉ(v)`, is interpolated barycentrically in the matched triangle.
//! 3. **Local statistics.** For each vertex v of X, the neighbourhood `N(v)` is the
//!    set of points of X within distance `hᵢ` of v reached through the mesh (vertices
//!    inside, plus the points where edges leave the sphere, with curvatures and
//!    matched points interpolated linearly along the edge). With Gaussian weights
//!    `w = exp(−d²/(2σ²))`, `σ = hᵢ/2` (d the distance to v on X, and to `v̂` on Y
//!    for the matched side), the weighted means μ₁ (of c) and μ₂ (of ĉ), standard
//!    deviations σ₁, σ₂ and covariance σ₁₂ (weighted with X's weights) give
//!    the curvature-amplitude, contrast and structure terms
//!    `L = |μ₁ − μ₂|/(max(μ₁, μ₂) + K)`, `C = |σ₁ − σ₂|/(max(σ₁, σ₂) + K)`,
//!    `S = |σ₁σ₂ − σ₁₂|/(σ₁σ₂ + K)` with `K = 1`, and the local distance
//!    `LD(v) = (αL + βC + γS)/(α + β + γ)`, published α = β = 1, γ = 0.5.
//! 4. **Pooling.** The local MSDM2 of v is the mean of `LD` over the scales; the
//!    score of X against Y is the Minkowski mean `(1/|X| Σ_v LD(v)³)^(1/3)`.
//! 5. **Symmetry.** As published, MSDM2 = ½ (score(test → reference) +
//!    score(reference → test)).
//!
//! ## Degenerate input
//! Everything is computed in units of `D` (both meshes translated and scaled by a
//! power of two), so the result does not depend on the magnitude of the coordinates
//! (tested from 10⁻²⁰⁰ to 10²⁰⁰). A zero-area face (collinear or coincident corners,
//! to rounding: `‖ab × ac‖ ≤ ε·ℓ²`, ℓ its longest edge, as for the operators, or a
//! height within four roundings of the input coordinates) has no normal: its edges get no dihedral angle and add no curvature, and matching
//! onto it measures its edges (`bvh::closest_on_triangle`) and interpolates at its
//! centroid. A zero-length edge (coincident vertices) has no direction and adds
//! nothing. A needle has the finite normal its rounding gives, so its edges add a
//! crease of bounded angle (|β| ≤ π). A vertex on no face is its own neighbourhood
//! (curvature 0) and is left out of the pooling: it is not part of the surface (and
//! matched onto the other surface it would make a mesh differ from itself). Of several
//! coincident vertices of the other mesh, a vertex is matched to its namesake (same
//! index) when that one is among them, so a damaged mesh is at 0 from itself. The
//! score is always finite and in [0, 1.2); the errors are
//! [`MetricError::Empty`] (no faces, or a zero or overflowing reference bounding box)
//! and [`MetricError::Topology`] (the connectivity cannot be built, e.g. a face with a
//! repeated corner, named in the source error). Tested in `tests/degenerate.rs`.
//!
//! The parameters are [`Msdm2Params`] (defaults: the published ones). The statistics
//! follow the MEPP platform's reference implementation in spirit (neighbourhoods,
//! Gaussian weights, constants); the tensor and neighbourhood code here is our own.
//! Terms L and C lie in [0, 1) and S in [0, 2), so the score is below 1.2 in theory
//! and below 1 on every realistic pair.

use super::bvh::Bvh;
use super::sym3::sym3_eigen;
use super::MetricError;
use crate::mesh::topology::{Topology, INVALID};
use crate::mesh::{EdgeId, TriMesh, VertexId};
use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

/// Parameters of [`msdm2`]; `Default` gives the published ones (Lavoué 2011).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Msdm2Params {
    /// Number of scales n (3).
    pub scales: usize,
    /// Neighbourhood radius of the first scale, as a fraction of the reference's
    /// largest bounding-box side (0.010).
    pub first_radius: f64,
    /// Increase of the radius per scale, same unit (0.005).
    pub radius_step: f64,
    /// Curvature radius ÷ neighbourhood radius (1/5).
    pub curvature_ratio: f64,
    /// Weight α of the curvature-amplitude term L (1).
    pub alpha: f64,
    /// Weight β of the contrast term C (1).
    pub beta: f64,
    /// Weight γ of the structure term S (0.5).
    pub gamma: f64,
    /// Stabilising constant K of the three terms (1).
    pub k: f64,
    /// Minkowski pooling exponent (3).
    pub minkowski: f64,
}

impl Default for Msdm2Params {
    fn default() -> Self {
        Msdm2Params {
            scales: 3,
            first_radius: 0.010,
            radius_step: 0.005,
            curvature_ratio: 0.2,
            alpha: 1.0,
            beta: 1.0,
            gamma: 0.5,
            k: 1.0,
            minkowski: 3.0,
        }
    }
}

/// A mesh prepared for MSDM2: positions, connectivity, per-edge direction and signed
/// dihedral angle, and the BVH for matching onto it.
struct Side<'a> {
    mesh: &'a TriMesh,
    pos: Vec<DVec3>,
    topo: Topology,
    /// Per edge: unit direction and signed dihedral angle (0 off interior edges).
    edge_shape: Vec<(DVec3, f64)>,
    bvh: Bvh,
    /// Per vertex: a face it is a corner of (`u32::MAX`: none).
    incident: Vec<u32>,
}

impl<'a> Side<'a> {
    /// `rounding`: the rounding of the input coordinates in `mesh`'s units (`ε` times
    /// their largest magnitude before normalisation).
    fn new(mesh: &'a TriMesh, which: &'static str, rounding: f64) -> Result<Self, MetricError> {
        let topo = Topology::new(mesh).map_err(|source| MetricError::Topology { which, source })?;
        let pos: Vec<DVec3> = mesh.positions.iter().map(|&p| DVec3::from(p)).collect();
        // A face that is zero-area to rounding has no normal: otherwise the normal of
        // a flattened face would be the direction of its rounding errors, and its
        // edges would add arbitrary creases that change with the scale. To rounding:
        // `‖ab × ac‖ ≤ ε·ℓ²` (ℓ the longest edge; the rule of the operators and of
        // `bvh::closest_on_triangle`), or a height `‖ab × ac‖/ℓ` within a few
        // roundings of the coordinates (a corner placed on the line of the other two
        // is off it by the rounding of its coordinates, not of the edge lengths).
        let normal = |f: usize| {
            let [a, b, c] = mesh.faces[f].map(|v| pos[v as usize]);
            let n = (b - a).cross(c - a);
            let longest2 = (b - a)
                .length_squared()
                .max((c - a).length_squared())
                .max((c - b).length_squared());
            let area2 = n.length();
            if area2 <= f64::EPSILON * longest2 || area2 <= 4.0 * rounding * longest2.sqrt() {
                DVec3::ZERO
            } else {
                n.normalize_or_zero()
            }
        };
        let edge_shape = (0..topo.n_edges())
            .map(|e| {
                let h = topo.edge_half_edge(EdgeId(e as u32));
                let (a, b) = (pos[topo.from(h) as usize], pos[topo.to(h) as usize]);
                let dir = (b - a).normalize_or_zero();
                let t = topo.twin(h);
                if topo.edge_face_count(EdgeId(e as u32)) != 2 || t == INVALID {
                    return (dir, 0.0);
                }
                let (n1, n2) = (normal(h as usize / 3), normal(t as usize / 3));
                // Sign from the half-edge of the first face: swapping the faces also
                // reverses `dir`, so the sign is the edge's own (convex vs concave).
                (dir, n1.cross(n2).dot(dir).atan2(n1.dot(n2)))
            })
            .collect();
        let mut incident = vec![u32::MAX; mesh.n_vertices()];
        for (f, face) in mesh.faces.iter().enumerate().rev() {
            for &v in face {
                incident[v as usize] = f as u32;
            }
        }
        Ok(Side {
            mesh,
            incident,
            bvh: Bvh::new(mesh),
            pos,
            topo,
            edge_shape,
        })
    }

    /// Visits the ball of radius `r` around vertex `v` through the mesh: calls
    /// `inside(w)` for each vertex inside and `crossing(w, u, t)` for each edge leaving
    /// the ball from inside vertex `w` towards `u` at fraction `t` of the edge, and
    /// `edge(e, len)` for every edge reached with its length inside the ball.
    fn ball(
        &self,
        v: u32,
        r: f64,
        scratch: &mut Scratch,
        mut inside: impl FnMut(u32),
        mut crossing: impl FnMut(u32, u32, f64),
        mut edge: impl FnMut(u32, f64),
    ) {
        let o = self.pos[v as usize];
        let r2 = r * r;
        let Scratch { stack, seen } = scratch;
        stack.clear();
        // Reset the flags of the previous ball (cheaper than clearing all of them).
        for &w in &seen.0 {
            seen.1[w as usize] = false;
        }
        seen.0.clear();
        if seen.1.len() != self.pos.len() {
            seen.1 = vec![false; self.pos.len()];
        }
        stack.push(v);
        seen.0.push(v);
        seen.1[v as usize] = true;
        inside(v);
        while let Some(w) = stack.pop() {
            let pw = self.pos[w as usize];
            let id = VertexId(w);
            for (&u, &e) in self
                .topo
                .neighbors(id)
                .iter()
                .zip(self.topo.neighbor_edges(id))
            {
                let pu = self.pos[u as usize];
                if (pu - o).length_squared() < r2 {
                    // Both ends inside: count the edge once, from its smaller end.
                    if w < u {
                        edge(e, (pu - pw).length());
                    }
                    if !seen.1[u as usize] {
                        seen.0.push(u);
                        seen.1[u as usize] = true;
                        stack.push(u);
                        inside(u);
                    }
                } else {
                    // Leaves the ball: |pw + t (pu − pw) − o| = r, t in (0, 1].
                    let d = pu - pw;
                    let f = pw - o;
                    let (a, b, c) = (d.length_squared(), 2.0 * d.dot(f), f.length_squared() - r2);
                    let t = if a > 0.0 {
                        ((-b + (b * b - 4.0 * a * c).max(0.0).sqrt()) / (2.0 * a)).clamp(0.0, 1.0)
                    } else {
                        0.0
                    };
                    edge(e, t * a.sqrt());
                    crossing(w, u, t);
                }
            }
        }
    }

    /// Curvature amplitude `scale·(|κ₁| + |κ₂|)/2` per vertex at radius `r`.
    fn curvature(&self, r: f64, scale: f64) -> Vec<f64> {
        let area = std::f64::consts::PI * r * r;
        (0..self.pos.len() as u32)
            .into_par_iter()
            .map_init(Scratch::default, |scratch, v| {
                let mut t = [[0.0; 3]; 3];
                self.ball(
                    v,
                    r,
                    scratch,
                    |_| {},
                    |_, _, _| {},
                    |e, len| {
                        let (d, beta) = self.edge_shape[e as usize];
                        let w = beta * len;
                        for i in 0..3 {
                            for j in i..3 {
                                t[i][j] += w * d[i] * d[j];
                            }
                        }
                    },
                );
                let (l, _) = sym3_eigen(t);
                scale * (l[0].abs() + l[1].abs()) / (2.0 * area)
            })
            .collect()
    }

    /// Matches every vertex of `self` onto `other`: closest point and the barycentric
    /// coordinates in its face. A vertex whose namesake in `other` (same index, on a
    /// face) sits at exactly its position is matched to it: among the points at
    /// distance 0 — several when vertices coincide — the one meshes sharing their
    /// vertex order mean (so a mesh with coincident vertices is at 0 from itself).
    fn matches(&self, other: &Side) -> Vec<(DVec3, u32, [f64; 3])> {
        self.mesh
            .positions
            .par_iter()
            .enumerate()
            .map(|(i, p)| {
                if let (Some(&q), Some(&f)) = (other.mesh.positions.get(i), other.incident.get(i)) {
                    if f != u32::MAX && q == *p {
                        let face = other.mesh.faces[f as usize];
                        let w = [0, 1, 2].map(|k| if face[k] as usize == i { 1.0 } else { 0.0 });
                        return (DVec3::from(q), f, w);
                    }
                }
                let (f, q, _) = other.bvh.closest_face(p);
                let corners = other.mesh.faces[f].map(|v| other.mesh.positions[v as usize]);
                (DVec3::from(q), f as u32, barycentric(q, corners))
            })
            .collect()
    }
}

/// Per-thread work space of [`Side::ball`]: the traversal stack and the vertices
/// seen (list, and a flag per vertex).
#[derive(Default)]
struct Scratch {
    stack: Vec<u32>,
    seen: (Vec<u32>, Vec<bool>),
}

/// Barycentric coordinates of `q` (a point of the triangle) in `[a, b, c]`; exact at
/// the corners, clamped to be non-negative, the centroid for a degenerate triangle.
fn barycentric(q: [f64; 3], t: [[f64; 3]; 3]) -> [f64; 3] {
    for k in 0..3 {
        if q == t[k] {
            let mut w = [0.0; 3];
            w[k] = 1.0;
            return w;
        }
    }
    let [a, b, c] = t.map(DVec3::from);
    let q = DVec3::from(q);
    let n = (b - a).cross(c - a);
    let nn = n.length_squared();
    if nn <= 0.0 {
        return [1.0 / 3.0; 3];
    }
    let wa = (c - b).cross(q - b).dot(n) / nn;
    let wb = (a - c).cross(q - c).dot(n) / nn;
    let w = [wa.max(0.0), wb.max(0.0), (1.0 - wa - wb).max(0.0)];
    let s = w[0] + w[1] + w[2];
    w.map(|x| x / s)
}

/// Per-vertex local MSDM2 of `x` against `y`, averaged over the scales.
fn local(
    x: &Side,
    y: &Side,
    curv_x: &[Vec<f64>],
    curv_y: &[Vec<f64>],
    radii: &[f64],
    p: &Msdm2Params,
) -> Vec<f64> {
    let m = x.matches(y);
    let mut acc = vec![0.0; x.pos.len()];
    for (s, &h) in radii.iter().enumerate() {
        let (cx, cy) = (&curv_x[s], &curv_y[s]);
        let matched: Vec<f64> = m
            .iter()
            .map(|&(_, f, w)| {
                let t = y.mesh.faces[f as usize];
                (0..3).map(|k| w[k] * cy[t[k] as usize]).sum()
            })
            .collect();
        let inv2s2 = 1.0 / (2.0 * (h / 2.0) * (h / 2.0));
        let ld: Vec<f64> = (0..x.pos.len() as u32)
            .into_par_iter()
            .map_init(
                || (Scratch::default(), Vec::new()),
                |(scratch, pts), v| {
                    // (c1, w1, c2, w2) per neighbourhood point.
                    pts.clear();
                    let (o1, o2) = (x.pos[v as usize], m[v as usize].0);
                    let mut push = |p1: DVec3, c1: f64, p2: DVec3, c2: f64| {
                        let w1 = (-(p1 - o1).length_squared() * inv2s2).exp();
                        let w2 = (-(p2 - o2).length_squared() * inv2s2).exp();
                        pts.push((c1, w1, c2, w2));
                    };
                    let mut inside = Vec::new();
                    let mut cross = Vec::new();
                    x.ball(
                        v,
                        h,
                        scratch,
                        |w| inside.push(w),
                        |w, u, t| cross.push((w, u, t)),
                        |_, _| {},
                    );
                    for w in inside {
                        let w = w as usize;
                        push(x.pos[w], cx[w], m[w].0, matched[w]);
                    }
                    for (w, u, t) in cross {
                        let (w, u) = (w as usize, u as usize);
                        push(
                            x.pos[w].lerp(x.pos[u], t),
                            (1.0 - t) * cx[w] + t * cx[u],
                            m[w].0.lerp(m[u].0, t),
                            (1.0 - t) * matched[w] + t * matched[u],
                        );
                    }
                    local_distance(pts, p)
                },
            )
            .collect();
        for (a, l) in acc.iter_mut().zip(ld) {
            *a += l / radii.len() as f64;
        }
    }
    acc
}

/// `LD = (αL + βC + γS)/(α + β + γ)` from the weighted statistics of the points
/// `(c₁, w₁, c₂, w₂)`.
fn local_distance(pts: &[(f64, f64, f64, f64)], p: &Msdm2Params) -> f64 {
    let (sw1, sw2) = pts.iter().fold((0.0, 0.0), |(a, b), q| (a + q.1, b + q.3));
    let mu1 = pts.iter().map(|q| q.1 * q.0).sum::<f64>() / sw1;
    let mu2 = pts.iter().map(|q| q.3 * q.2).sum::<f64>() / sw2;
    let var1 = pts
        .iter()
        .map(|q| q.1 * ((q.0 - mu1) * (q.0 - mu1)))
        .sum::<f64>()
        / sw1;
    let var2 = pts
        .iter()
        .map(|q| q.3 * ((q.2 - mu2) * (q.2 - mu2)))
        .sum::<f64>()
        / sw2;
    let cov = pts
        .iter()
        .map(|q| q.1 * ((q.0 - mu1) * (q.2 - mu2)))
        .sum::<f64>()
        / sw1;
    let (s1, s2) = (var1.sqrt(), var2.sqrt());
    let l = (mu1 - mu2).abs() / (mu1.max(mu2) + p.k);
    let c = (s1 - s2).abs() / (s1.max(s2) + p.k);
    // σ₁σ₂ as √(var₁·var₂): exactly var₁ when both sides agree, so S = 0 then.
    let s12 = (var1 * var2).sqrt();
    let s = (s12 - cov).abs() / (s12 + p.k);
    (p.alpha * l + p.beta * c + p.gamma * s) / (p.alpha + p.beta + p.gamma)
}

/// The largest side of `m`'s bounding box.
fn max_side(m: &TriMesh) -> f64 {
    m.bounding_box()
        .map(|(lo, hi)| (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max))
        .unwrap_or(0.0)
}

/// MSDM2 between `reference` and `test` (module documentation): 0 for identical
/// meshes, larger for more visible distortion, symmetric in its arguments up to the
/// scale `D` (taken from the reference). [`MetricError::Empty`] when a mesh has no
/// faces or the reference has a zero-size bounding box.
pub fn msdm2(
    reference: &TriMesh,
    test: &TriMesh,
    params: &Msdm2Params,
) -> Result<f64, MetricError> {
    if reference.faces.is_empty() {
        return Err(MetricError::Empty("reference"));
    }
    if test.faces.is_empty() {
        return Err(MetricError::Empty("test"));
    }
    let d = max_side(reference);
    if !d.is_finite() || d <= 0.0 {
        return Err(MetricError::Empty("reference"));
    }
    // Work in units of D: both meshes translated by the reference's lowest bounding-box
    // corner and scaled by a power of two (exact) close to 1/D. MSDM2 is invariant
    // under a common translation and scale, and every squared length, ball area and
    // Gaussian weight below then stays far from overflow and underflow whatever the
    // input's magnitude (at D = 10⁻¹⁶⁰ the squared radius underflows and the weights
    // become NaN otherwise).
    let (lo, _) = reference
        .bounding_box()
        .ok_or(MetricError::Empty("reference"))?;
    let exp = (((d.to_bits() >> 52) & 0x7ff) as i32 - 1023).clamp(-1000, 1000);
    let s = f64::from_bits(((1023 - exp) as u64) << 52);
    let normalized = |m: &TriMesh| {
        TriMesh::new(
            m.positions
                .iter()
                .map(|p| [0, 1, 2].map(|k| (p[k] - lo[k]) * s))
                .collect(),
            m.faces.clone(),
        )
    };
    let rounding = |m: &TriMesh| {
        let big = m
            .positions
            .iter()
            .flatten()
            .fold(0.0f64, |a, x| a.max(x.abs()));
        f64::EPSILON * big * s
    };
    let (ra, rb) = (rounding(reference), rounding(test));
    let (reference, test) = (normalized(reference), normalized(test));
    let d = d * s;
    let a = Side::new(&reference, "reference", ra)?;
    let b = Side::new(&test, "test", rb)?;
    let radii: Vec<f64> = (0..params.scales.max(1))
        .map(|i| (params.first_radius + params.radius_step * i as f64) * d)
        .collect();
    let curv = |s: &Side| -> Vec<Vec<f64>> {
        radii
            .iter()
            .map(|h| s.curvature(h * params.curvature_ratio, d))
            .collect()
    };
    let (ca, cb) = (curv(&a), curv(&b));
    // Minkowski mean over the vertices on a face: a vertex on no face is not part of
    // the surface (nothing of it is seen), and would otherwise be matched onto the
    // other mesh's surface even against itself.
    let pool = |ld: Vec<f64>, m: &TriMesh| -> f64 {
        let e = params.minkowski;
        let mut on_face = vec![false; m.n_vertices()];
        for f in &m.faces {
            for &v in f {
                on_face[v as usize] = true;
            }
        }
        let (sum, count) = ld
            .iter()
            .zip(&on_face)
            .filter(|(_, &o)| o)
            .fold((0.0, 0usize), |(s, c), (x, _)| (s + x.powf(e), c + 1));
        (sum / count.max(1) as f64).powf(1.0 / e)
    };
    let test_to_ref = pool(local(&b, &a, &cb, &ca, &radii, params), &test);
    let ref_to_test = pool(local(&a, &b, &ca, &cb, &radii, params), &reference);
    Ok(0.5 * (test_to_ref + ref_to_test))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;
    use crate::watermark::attack::{attack, AttackKind, AttackOptions};

    #[test]
    fn identical_meshes_give_zero() {
        for m in [
            builtin::icosphere(3).unwrap(),
            builtin::torus(20, 10).unwrap(),
        ] {
            assert_eq!(msdm2(&m, &m, &Msdm2Params::default()).unwrap(), 0.0);
        }
    }

    #[test]
    fn increasing_noise_increases_it_strictly_and_it_stays_below_one() {
        for m in [
            builtin::icosphere(4).unwrap(),
            builtin::torus(48, 24).unwrap(),
        ] {
            let mut last = 0.0;
            for pct in [0.05, 0.1, 0.3, 0.5, 1.0, 2.0] {
                let n = attack(&m, &AttackOptions::new(AttackKind::Noise, pct)).unwrap();
                let v = msdm2(&m, &n, &Msdm2Params::default()).unwrap();
                assert!(v > last && v < 1.0, "{pct} %: {v} after {last}");
                last = v;
            }
        }
    }

    #[test]
    fn translation_and_uniform_scale_of_both_meshes_change_nothing() {
        let m = builtin::torus(30, 14).unwrap();
        let n = attack(&m, &AttackOptions::new(AttackKind::Noise, 0.5)).unwrap();
        let v = msdm2(&m, &n, &Msdm2Params::default()).unwrap();
        let f = |t: &TriMesh| {
            let mut t = t.clone();
            t.positions
                .iter_mut()
                .for_each(|p| *p = [3.0 * p[0] + 1.0, 3.0 * p[1] - 2.0, 3.0 * p[2] + 0.5]);
            t
        };
        let w = msdm2(&f(&m), &f(&n), &Msdm2Params::default()).unwrap();
        assert!((v - w).abs() < 1e-9 * v, "{v} vs {w}");
    }

    #[test]
    fn works_across_connectivities() {
        // Midpoint subdivision keeps the surface: tiny distance; Loop smooths it: more.
        let m = builtin::icosphere(3).unwrap();
        let mid = attack(&m, &AttackOptions::new(AttackKind::Subdivide, 1.0)).unwrap();
        let v_mid = msdm2(&m, &mid, &Msdm2Params::default()).unwrap();
        let noisy = attack(&m, &AttackOptions::new(AttackKind::Noise, 1.0)).unwrap();
        let v_noise = msdm2(&m, &noisy, &Msdm2Params::default()).unwrap();
        assert!(v_mid < v_noise, "{v_mid} vs {v_noise}");
        assert!(msdm2(&m, &TriMesh::default(), &Msdm2Params::default()).is_err());
    }

    #[test]
    fn curvature_of_a_sphere_is_its_inverse_radius_times_the_scale() {
        // On a fine sphere of radius 2 with a ball holding many edges, κ₁ ≈ κ₂ ≈ 1/2.
        let mut m = builtin::icosphere(5).unwrap();
        m.positions.iter_mut().for_each(|p| *p = p.map(|x| 2.0 * x));
        let s = Side::new(&m, "test", 0.0).unwrap();
        let c = s.curvature(0.3, 1.0);
        let mean = c.iter().sum::<f64>() / c.len() as f64;
        assert!((mean - 0.5).abs() < 0.05, "{mean}");
    }
}
