//! Distortion metrics between an original mesh `A` and an approximation `B`.
//!
//! * Vertex error (same vertex count, optionally after a vertex map): RMS and maximum
//!   of `‖a_i − b_i‖`, divided by A's bounding-box diagonal.
//! * Metro-style surface distance (Cignoni, Rocchini, Scopigno 1998): points sampled
//!   area-uniformly on one surface (seeded, deterministic), their distance to the
//!   other surface by a bounding-volume hierarchy closest-point query; both one-sided
//!   distances (RMS and max), the symmetric Hausdorff distance is the larger max. Works
//!   whatever the vertex order of B. Normalised by A's diagonal.
//! * Zhang 2004 §4.9 measure: `Σ_i ‖L(a)_i − L(b)_i‖² + ⟨a_i − b_i, n_i⟩²` with `L` the
//!   scale-dependent Laplacian (inverse edge-length weights, F = D − W sign) of each
//!   mesh and `n_i = L(a)_i/‖L(a)_i‖`; reported per vertex, divided by diag².
//! * Karni–Gotsman 2000 (§5) geometric-Laplacian error:
//!   `½(‖a − b‖ + ‖GL(a) − GL(b)‖)/‖a − ā‖` (Frobenius norms over all vertices,
//!   `GL(v)_i = v_i − Σ_j l_ij⁻¹ v_j / Σ_j l_ij⁻¹`, `ā` the centroid; KG normalise by
//!   the model size in a similar way).
//! * MSDM2 (Lavoué, SGP 2011): a multiscale perceptual distance from local curvature
//!   statistics, for meshes of any connectivity ([`msdm2`]).
//!
//! **Degenerate input.** Zero-area faces get no samples and are measured as their
//! edges (see [`bvh::closest_on_triangle`]); coincident vertices get the Karni–Gotsman
//! inverse lengths of edges clamped at `ε·diag`; the Zhang measure is omitted (`None`)
//! when the SDL is undefined (a zero-length edge). A reference mesh A without faces
//! or with a zero bounding box is [`MetricError::Empty`]. Every reported figure is
//! finite.

pub mod bvh;
pub mod msdm2;
pub mod sym3;
pub mod vertex;

pub use vertex::{vertex_errors, VertexErrors};

use crate::mesh::topology::Topology;
use crate::mesh::TriMesh;
use crate::operator::{Operator, OperatorKind, OperatorOptions};
use crate::rng::SplitMix64;
use serde::Serialize;

/// Errors of the metrics.
#[derive(Debug, thiserror::Error)]
pub enum MetricError {
    /// A mesh has no faces, or the reference mesh's bounding box is zero (every
    /// vertex at one point) or too large for `f64`: nothing to normalise by.
    #[error("mesh {0} has no faces or a zero (or overflowing) bounding box")]
    Empty(&'static str),
    /// A mesh's connectivity cannot be built (MSDM2 walks the surface: e.g. a face
    /// with a repeated corner).
    #[error("mesh {which}: {source}")]
    Topology {
        /// "reference" or "test".
        which: &'static str,
        /// Why.
        #[source]
        source: crate::mesh::MeshError,
    },
    /// The vertex map does not fit.
    #[error("vertex map has {got} entries, the meshes have {n}")]
    BadMap {
        /// Entries given.
        got: usize,
        /// Vertices.
        n: usize,
    },
}

/// Everything `meshlap compare` reports.
#[derive(Clone, Debug, Serialize)]
pub struct Comparison {
    /// A's bounding-box diagonal (the normaliser).
    pub diagonal: f64,
    /// True when the vertex counts match and the face sets are identical (after the map).
    pub same_connectivity: bool,
    /// Vertex errors (only when the vertex counts match).
    pub vertex_rms: Option<f64>,
    /// Maximum vertex error.
    pub vertex_max: Option<f64>,
    /// RMS distance from samples of A to B.
    pub a_to_b_rms: f64,
    /// Max distance from samples of A to B.
    pub a_to_b_max: f64,
    /// RMS distance from samples of B to A.
    pub b_to_a_rms: f64,
    /// Max distance from samples of B to A.
    pub b_to_a_max: f64,
    /// Symmetric Hausdorff distance (sampled).
    pub hausdorff: f64,
    /// Zhang §4.9 measure (only with matching vertices).
    pub zhang_sdl: Option<f64>,
    /// Karni–Gotsman geometric-Laplacian error (only with matching vertices).
    pub karni_gotsman: Option<f64>,
    /// Samples per surface.
    pub samples: usize,
    /// MSDM2 perceptual distance (Lavoué 2011, [`msdm2`]; published parameters;
    /// works across connectivities); `None` when not asked for
    /// ([`CompareOptions::msdm2`]).
    pub msdm2: Option<f64>,
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn norm(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

/// `count` points area-uniformly on `m` (seeded), plus every vertex.
pub fn sample_surface(m: &TriMesh, count: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut cum = Vec::with_capacity(m.n_faces());
    let mut total = 0.0;
    for f in &m.faces {
        let [a, b, c] = f.map(|v| m.positions[v as usize]);
        total += 0.5 * norm(cross(sub(b, a), sub(c, a)));
        cum.push(total);
    }
    let mut out: Vec<[f64; 3]> = m.positions.clone();
    if total <= 0.0 {
        return out;
    }
    let mut rng = SplitMix64::new(seed);
    for _ in 0..count {
        let t = rng.next_f64() * total;
        let fi = cum.partition_point(|&c| c < t).min(m.n_faces() - 1);
        let [a, b, c] = m.faces[fi].map(|v| m.positions[v as usize]);
        let (mut u, mut v) = (rng.next_f64(), rng.next_f64());
        if u + v > 1.0 {
            u = 1.0 - u;
            v = 1.0 - v;
        }
        out.push([0, 1, 2].map(|k| a[k] + u * (b[k] - a[k]) + v * (c[k] - a[k])));
    }
    out
}

/// One-sided distances from samples of `from` to the surface `to`: (RMS, max).
fn one_sided(from: &TriMesh, to: &TriMesh, samples: usize, seed: u64) -> (f64, f64) {
    let tree = bvh::Bvh::new(to);
    let pts = sample_surface(from, samples, seed);
    use rayon::prelude::*;
    let d: Vec<f64> = pts.par_iter().map(|p| tree.closest(p).1.sqrt()).collect();
    let rms = (d.iter().map(|x| x * x).sum::<f64>() / d.len().max(1) as f64).sqrt();
    (rms, d.iter().copied().fold(0.0, f64::max))
}

/// The oriented face set of `faces` renumbered by `map`: each face rotated so its
/// smallest index comes first, sorted.
pub(crate) fn canon_faces(faces: &[[u32; 3]], map: impl Fn(u32) -> u32) -> Vec<[u32; 3]> {
    let mut v: Vec<[u32; 3]> = faces
        .iter()
        .map(|t| {
            let t = t.map(&map);
            let k = (0..3).min_by_key(|&k| t[k]).unwrap_or(0);
            [t[k], t[(k + 1) % 3], t[(k + 2) % 3]]
        })
        .collect();
    v.sort_unstable();
    v
}

fn sdl_vectors(m: &TriMesh) -> Option<Vec<[f64; 3]>> {
    let topo = Topology::new(m).ok()?;
    let op = Operator::assemble(OperatorKind::Sdl, m, &topo, &OperatorOptions::default()).ok()?;
    let mut out = vec![[0.0; 3]; m.n_vertices()];
    let mat = op.matrix.as_ref();
    for j in 0..mat.ncols() {
        let rows = mat.row_idx_of_col_raw(j);
        let vals = mat.val_of_col(j);
        for (&i, &w) in rows.iter().zip(vals) {
            for k in 0..3 {
                out[i][k] += w * m.positions[j][k];
            }
        }
    }
    Some(out)
}

/// Karni–Gotsman geometric Laplacian `GL(v)_i = v_i − Σ l_ij⁻¹ v_j / Σ l_ij⁻¹`, edge
/// lengths clamped below at `min_len` (> 0) so that coincident vertices stay finite.
fn kg_laplacian(m: &TriMesh, topo: &Topology, min_len: f64) -> Vec<[f64; 3]> {
    (0..m.n_vertices())
        .map(|i| {
            let p = m.positions[i];
            let (mut s, mut w) = ([0.0; 3], 0.0);
            for &j in topo.neighbors(crate::mesh::VertexId(i as u32)) {
                let q = m.positions[j as usize];
                let l = norm(sub(p, q)).max(min_len);
                for k in 0..3 {
                    s[k] += q[k] / l;
                }
                w += 1.0 / l;
            }
            if w > 0.0 {
                [0, 1, 2].map(|k| p[k] - s[k] / w)
            } else {
                [0.0; 3]
            }
        })
        .collect()
}

/// What [`compare`] measures.
#[derive(Clone, Copy, Debug)]
pub struct CompareOptions {
    /// Sample points per surface for the Metro distance (besides the vertices).
    pub samples: usize,
    /// Also compute MSDM2 (curvature statistics at three scales on both meshes: the
    /// most expensive measure here; the codec's rate loops leave it out).
    pub msdm2: bool,
}

impl Default for CompareOptions {
    /// 200,000 samples and MSDM2, as `meshlap compare` reports.
    fn default() -> Self {
        Self {
            samples: 200_000,
            msdm2: true,
        }
    }
}

impl CompareOptions {
    /// The surface and vertex measures only, with `samples` points per surface.
    pub fn without_msdm2(samples: usize) -> Self {
        Self {
            samples,
            msdm2: false,
        }
    }
}

/// Compares `a` (reference) and `b`. `map[i]`, if given, is the vertex of `a` that
/// vertex `i` of `b` corresponds to (e.g. a codec's decoded order).
pub fn compare(
    a: &TriMesh,
    b: &TriMesh,
    map: Option<&[u32]>,
    opts: &CompareOptions,
) -> Result<Comparison, MetricError> {
    let samples = opts.samples;
    if a.faces.is_empty() {
        return Err(MetricError::Empty("A"));
    }
    if b.faces.is_empty() {
        return Err(MetricError::Empty("B"));
    }
    let diag = a.bbox_diagonal();
    if !diag.is_finite() || diag < f64::MIN_POSITIVE {
        return Err(MetricError::Empty("A"));
    }
    let (ab_rms, ab_max) = one_sided(a, b, samples, 1);
    let (ba_rms, ba_max) = one_sided(b, a, samples, 2);
    let mut c = Comparison {
        diagonal: diag,
        same_connectivity: false,
        vertex_rms: None,
        vertex_max: None,
        a_to_b_rms: ab_rms / diag,
        a_to_b_max: ab_max / diag,
        b_to_a_rms: ba_rms / diag,
        b_to_a_max: ba_max / diag,
        hausdorff: ab_max.max(ba_max) / diag,
        zhang_sdl: None,
        karni_gotsman: None,
        samples,
        msdm2: if opts.msdm2 {
            Some(msdm2::msdm2(a, b, &msdm2::Msdm2Params::default())?)
        } else {
            None
        },
    };
    let n = a.n_vertices();
    if b.n_vertices() != n {
        return Ok(c);
    }
    // b reordered into a's numbering.
    let bb = match map {
        Some(m) => {
            if m.len() != n || m.iter().any(|&v| v as usize >= n) {
                return Err(MetricError::BadMap { got: m.len(), n });
            }
            let mut pos = vec![[0.0; 3]; n];
            for (i, &v) in m.iter().enumerate() {
                pos[v as usize] = b.positions[i];
            }
            TriMesh::new(
                pos,
                b.faces.iter().map(|f| f.map(|v| m[v as usize])).collect(),
            )
        }
        None => b.clone(),
    };
    c.same_connectivity = canon_faces(&a.faces, |v| v) == canon_faces(&bb.faces, |v| v);
    let e = vertex_errors(&a.positions, &bb.positions, diag);
    c.vertex_rms = Some(e.rms);
    c.vertex_max = Some(e.max);
    if c.same_connectivity {
        if let (Some(la), Some(lb)) = (sdl_vectors(a), sdl_vectors(&bb)) {
            let mut s = 0.0;
            for i in 0..n {
                let dl = sub(la[i], lb[i]);
                let nl = norm(la[i]);
                let disp = sub(a.positions[i], bb.positions[i]);
                let along = if nl > 0.0 {
                    (disp[0] * la[i][0] + disp[1] * la[i][1] + disp[2] * la[i][2]) / nl
                } else {
                    0.0
                };
                s += dl[0] * dl[0] + dl[1] * dl[1] + dl[2] * dl[2] + along * along;
            }
            c.zhang_sdl = Some(s / n as f64 / diag / diag);
        }
        if let Ok(topo) = Topology::new(a) {
            let min_len = f64::EPSILON * diag;
            let ga = kg_laplacian(a, &topo, min_len);
            let gb = kg_laplacian(&bb, &topo, min_len);
            let mut cen = [0.0; 3];
            for p in &a.positions {
                for k in 0..3 {
                    cen[k] += p[k] / n as f64;
                }
            }
            let fro = |f: &dyn Fn(usize) -> [f64; 3]| {
                (0..n)
                    .map(|i| {
                        let v = f(i);
                        v[0] * v[0] + v[1] * v[1] + v[2] * v[2]
                    })
                    .sum::<f64>()
                    .sqrt()
            };
            let dx = fro(&|i| sub(a.positions[i], bb.positions[i]));
            let dg = fro(&|i| sub(ga[i], gb[i]));
            let x = fro(&|i| sub(a.positions[i], cen)).max(f64::MIN_POSITIVE);
            c.karni_gotsman = Some(0.5 * (dx + dg) / x);
        }
    }
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;

    #[test]
    fn identical_meshes_have_zero_distance() {
        let m = builtin::from_spec("builtin:icosphere:2").unwrap();
        let c = compare(
            &m,
            &m,
            None,
            &CompareOptions {
                samples: 2000,
                msdm2: true,
            },
        )
        .unwrap();
        assert!(c.same_connectivity);
        assert!(c.hausdorff < 1e-12 && c.vertex_max.unwrap() == 0.0);
        assert!(c.zhang_sdl.unwrap() < 1e-20 && c.karni_gotsman.unwrap() < 1e-12);
        assert_eq!(c.msdm2, Some(0.0));
    }

    #[test]
    fn translated_plane_and_scaled_sphere() {
        let g = builtin::grid(8).unwrap();
        let mut h = g.clone();
        let off = 0.1;
        // Translate along the grid's normal (the grid lies in a coordinate plane).
        let (lo, hi) = g.bounding_box().unwrap();
        let k = (0..3).find(|&k| (hi[k] - lo[k]).abs() < 1e-12).unwrap();
        for p in &mut h.positions {
            p[k] += off;
        }
        let c = compare(
            &g,
            &h,
            None,
            &CompareOptions {
                samples: 4000,
                msdm2: true,
            },
        )
        .unwrap();
        let d = off / c.diagonal;
        assert!((c.hausdorff - d).abs() < 1e-9 && (c.a_to_b_rms - d).abs() < 1e-9);
        assert!((c.vertex_rms.unwrap() - d).abs() < 1e-12);
        // A sphere scaled by s: vertex distance is |s − 1|·r everywhere.
        let s = builtin::icosphere(3).unwrap();
        let mut t = s.clone();
        for p in &mut t.positions {
            *p = p.map(|x| 1.1 * x);
        }
        let c = compare(
            &s,
            &t,
            None,
            &CompareOptions {
                samples: 4000,
                msdm2: true,
            },
        )
        .unwrap();
        let r = norm(s.positions[0]);
        assert!((c.vertex_max.unwrap() * c.diagonal - 0.1 * r).abs() < 1e-9);
        // Inner to outer polyhedron: 0.1 × the distance of the point's face plane from
        // the centre, so between 0.1·(inradius of a facet) and 0.1 r.
        let (d_max, d_rms) = (c.a_to_b_max * c.diagonal, c.a_to_b_rms * c.diagonal);
        assert!(
            d_max <= 0.1 * r + 1e-9 && d_max > 0.095 * r,
            "{d_max} vs {r}"
        );
        assert!(d_rms <= d_max && d_rms > 0.09 * r, "{d_rms}");
    }

    #[test]
    fn reordered_vertices_are_matched_by_the_map() {
        let m = builtin::from_spec("builtin:torus:8:6").unwrap();
        let n = m.n_vertices();
        // A seeded random permutation: b's vertex i is a's vertex map[i].
        let mut map: Vec<u32> = (0..n as u32).collect();
        let mut rng = SplitMix64::new(99);
        for i in (1..n).rev() {
            let j = (rng.next_f64() * (i + 1) as f64) as usize;
            map.swap(i, j.min(i));
        }
        let mut inv = vec![0u32; n];
        for (i, &v) in map.iter().enumerate() {
            inv[v as usize] = i as u32;
        }
        let b = TriMesh::new(
            map.iter().map(|&v| m.positions[v as usize]).collect(),
            m.faces.iter().map(|f| f.map(|v| inv[v as usize])).collect(),
        );
        let c = compare(
            &m,
            &b,
            Some(&map),
            &CompareOptions {
                samples: 1000,
                msdm2: true,
            },
        )
        .unwrap();
        assert!(c.same_connectivity && c.vertex_max.unwrap() == 0.0);
        let c = compare(
            &m,
            &b,
            None,
            &CompareOptions {
                samples: 1000,
                msdm2: true,
            },
        )
        .unwrap();
        assert!(!c.same_connectivity && c.hausdorff < 1e-12);
    }
}
