//! Similarity registration of a suspect mesh to the original: the scale `s`, rotation
//! `R` and translation `t` with `s·R·x + t` (x a suspect point) closest to the
//! original's surface.
//!
//! ## Method
//! - **Same connectivity** (equal vertex count and faces, e.g. after noise, smoothing,
//!   quantization or a similarity transform): vertex `i` of the suspect corresponds to
//!   vertex `i` of the original, and the least-squares similarity is found in closed
//!   form ([`fit_similarity`]: Horn 1987's unit-quaternion method, "Closed-form
//!   solution of absolute orientation using unit quaternions", with the optimal scale
//!   `s = Σ b′·R a′ / Σ |a′|²`).
//! - **Different connectivity** (simplified, subdivided, cropped): iterative closest
//!   points (Besl & McKay 1992) with scale. The start is the principal axes: the
//!   area-weighted centroids and second moments of both surfaces, the scale
//!   `√(tr C_original / tr C_suspect)` and the 24 proper rotations mapping the
//!   suspect's axes to the original's (every sign and order of the axes, since
//!   principal axes are defined only up to these), and the identity (most attacks do
//!   not move the mesh; a cropped part has other axes than the whole). Each start runs a few ICP steps on
//!   a small sample of suspect vertices; the best one continues to convergence on a
//!   larger sample. Each step takes the closest point of the original's surface to
//!   every transformed sample point ([`crate::metric::bvh::Bvh`]), drops the pairs
//!   beyond the `trim` quantile of distance (outliers, cropped parts: trimmed ICP,
//!   Chetverikov et al. 2002) and refits the similarity to the rest.
//!
//! The RMS residual is the root mean square of the kept pairs' distances in the
//! original's units; above `max_rms` × the original's bounding-box diagonal the
//! suspect is declared unrelated ([`RegisterError::NoMatch`]).

use crate::mesh::TriMesh;
use crate::metric::bvh::Bvh;
use crate::rng::SplitMix64;
use faer::{Mat, Side};
use rayon::prelude::*;
use serde::Serialize;

/// Errors of [`register`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RegisterError {
    /// The suspect or the original has no triangles or only degenerate ones.
    #[error("the {which} mesh has no triangle of positive area")]
    Degenerate {
        /// "suspect" or "original".
        which: &'static str,
    },
    /// A coordinate is NaN or infinite.
    #[error("the {which} mesh has a NaN or infinite coordinate")]
    NonFinite {
        /// "suspect" or "original".
        which: &'static str,
    },
    /// No similarity brings the suspect close to the original: it is a different
    /// object (or too damaged). Raise `max_rms` only if the suspect is known to match.
    #[error("the suspect does not match the original: RMS residual {relative:.3e} of the diagonal after registration (limit {limit:.1e})")]
    NoMatch {
        /// The best RMS residual ÷ the original's bounding-box diagonal.
        relative: f64,
        /// The limit (`max_rms`).
        limit: f64,
    },
    /// A parameter is out of range.
    #[error("registration parameter `{name}`: {reason}")]
    InvalidParameter {
        /// The field.
        name: &'static str,
        /// The valid range.
        reason: &'static str,
    },
}

/// Parameters of [`register`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct RegisterParams {
    /// Suspect vertices sampled for the final ICP (all when fewer).
    pub samples: usize,
    /// Suspect vertices sampled to rank the 24 principal-axes starts.
    pub start_samples: usize,
    /// ICP steps per start.
    pub start_iterations: usize,
    /// Most ICP steps of the final run.
    pub max_iterations: usize,
    /// Fraction of the closest pairs kept in each step, in (0, 1].
    pub trim: f64,
    /// Stop when the RMS residual improves by less than this fraction.
    pub tolerance: f64,
    /// Largest RMS residual, relative to the original's diagonal, still a match.
    pub max_rms: f64,
    /// Seed of the samples.
    pub seed: u64,
    /// Use vertex correspondences when the connectivity is the same.
    pub use_correspondences: bool,
}

impl Default for RegisterParams {
    fn default() -> Self {
        Self {
            samples: 6000,
            start_samples: 800,
            start_iterations: 6,
            max_iterations: 60,
            trim: 0.9,
            tolerance: 1e-6,
            max_rms: 0.02,
            seed: 0x1c9,
            use_correspondences: true,
        }
    }
}

/// A similarity transform `p ↦ s·R·p + t`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Similarity {
    /// Uniform scale s > 0.
    pub scale: f64,
    /// Rotation R (row-major, proper: det = +1).
    pub rotation: [[f64; 3]; 3],
    /// Translation t.
    pub translation: [f64; 3],
}

impl Similarity {
    /// The identity.
    pub fn identity() -> Self {
        Self {
            scale: 1.0,
            rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            translation: [0.0; 3],
        }
    }

    /// `s·R·p + t`.
    pub fn apply(&self, p: [f64; 3]) -> [f64; 3] {
        let r = &self.rotation;
        std::array::from_fn(|i| {
            self.scale * (r[i][0] * p[0] + r[i][1] * p[1] + r[i][2] * p[2]) + self.translation[i]
        })
    }

    /// The rotation angle in degrees, `acos((tr R − 1)/2)`.
    pub fn rotation_degrees(&self) -> f64 {
        let r = &self.rotation;
        let c = ((r[0][0] + r[1][1] + r[2][2] - 1.0) / 2.0).clamp(-1.0, 1.0);
        c.acos().to_degrees()
    }
}

/// What [`register`] found (JSON keys of `meshlap watermark detect`'s `registration`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RegistrationReport {
    /// Scale s of the suspect-to-original transform.
    pub scale: f64,
    /// Its rotation angle in degrees.
    pub rotation_degrees: f64,
    /// Its translation t.
    pub translation: [f64; 3],
    /// RMS distance of the (kept) pairs after registration, original units.
    pub rms_residual: f64,
    /// "correspondences" (same connectivity) or "icp".
    pub method: &'static str,
    /// ICP steps of the final run (0 for correspondences).
    pub iterations: usize,
}

/// The least-squares similarity mapping points `a` onto `b` (pairs `a[i] ↔ b[i]`):
/// minimises `Σ |b_i − (s·R·a_i + t)|²` (Horn 1987 with the optimal scale). `None`
/// when the `a` points coincide.
pub fn fit_similarity(a: &[[f64; 3]], b: &[[f64; 3]]) -> Option<Similarity> {
    let n = a.len().min(b.len());
    if n == 0 {
        return None;
    }
    let mean = |p: &[[f64; 3]]| -> [f64; 3] {
        let mut c = [0.0; 3];
        for q in &p[..n] {
            for k in 0..3 {
                c[k] += q[k];
            }
        }
        c.map(|v| v / n as f64)
    };
    let (ca, cb) = (mean(a), mean(b));
    let mut s = [[0.0f64; 3]; 3];
    let mut norm_a = 0.0;
    for i in 0..n {
        let pa: [f64; 3] = std::array::from_fn(|k| a[i][k] - ca[k]);
        let pb: [f64; 3] = std::array::from_fn(|k| b[i][k] - cb[k]);
        for r in 0..3 {
            for c in 0..3 {
                s[r][c] += pa[r] * pb[c];
            }
            norm_a += pa[r] * pa[r];
        }
    }
    if !(norm_a > 0.0) || !norm_a.is_finite() {
        return None;
    }
    let [[sxx, sxy, sxz], [syx, syy, syz], [szx, szy, szz]] = s;
    let nm = [
        [sxx + syy + szz, syz - szy, szx - sxz, sxy - syx],
        [syz - szy, sxx - syy - szz, sxy + syx, szx + sxz],
        [szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy],
        [sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz],
    ];
    let evd = Mat::from_fn(4, 4, |i, j| nm[i][j])
        .self_adjoint_eigen(Side::Lower)
        .ok()?;
    let (u, ev) = (evd.U(), evd.S());
    let top = (0..4).max_by(|&i, &j| ev[i].total_cmp(&ev[j]))?;
    let q: [f64; 4] = std::array::from_fn(|i| u[(i, top)]);
    let len = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    let [w, x, y, z] = q.map(|v| v / len);
    let rotation = [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ];
    let trace_rs: f64 = (0..3)
        .map(|r| (0..3).map(|c| rotation[r][c] * s[c][r]).sum::<f64>())
        .sum();
    let scale = trace_rs / norm_a;
    if !(scale > 0.0) || !scale.is_finite() {
        return None;
    }
    let rot = Similarity {
        scale,
        rotation,
        translation: [0.0; 3],
    };
    let rc = rot.apply(ca);
    Some(Similarity {
        translation: std::array::from_fn(|k| cb[k] - rc[k]),
        ..rot
    })
}

/// Area-weighted centroid, second-moment covariance (3×3) and area of a surface.
fn moments(m: &TriMesh) -> Option<([f64; 3], [[f64; 3]; 3], f64)> {
    let mut area = 0.0;
    let mut c = [0.0; 3];
    let mut s = [[0.0; 3]; 3];
    for f in &m.faces {
        let [a, b, d] = f.map(|v| m.positions[v as usize]);
        let u: [f64; 3] = std::array::from_fn(|k| b[k] - a[k]);
        let v: [f64; 3] = std::array::from_fn(|k| d[k] - a[k]);
        let cr = [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ];
        let ar = 0.5 * (cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]).sqrt();
        area += ar;
        let sum: [f64; 3] = std::array::from_fn(|k| a[k] + b[k] + d[k]);
        for i in 0..3 {
            c[i] += ar * sum[i] / 3.0;
            for j in 0..3 {
                // ∫ x_i x_j dA over a triangle = A/12 (Σ_v v_i v_j + S_i S_j).
                let vv = a[i] * a[j] + b[i] * b[j] + d[i] * d[j];
                s[i][j] += ar / 12.0 * (vv + sum[i] * sum[j]);
            }
        }
    }
    if !(area > 0.0) || !area.is_finite() {
        return None;
    }
    let c = c.map(|v| v / area);
    let cov = std::array::from_fn(|i| std::array::from_fn(|j| s[i][j] / area - c[i] * c[j]));
    Some((c, cov, area))
}

/// Eigenvectors of a symmetric 3×3 matrix as the columns of a row-major matrix.
fn axes(cov: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let evd = Mat::from_fn(3, 3, |i, j| cov[i][j])
        .self_adjoint_eigen(Side::Lower)
        .ok()?;
    let u = evd.U();
    Some(std::array::from_fn(|i| std::array::from_fn(|j| u[(i, j)])))
}

fn det(m: &[[f64; 3]; 3]) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// The 24 proper rotations `E_o · P · E_sᵀ` over signed permutations `P`.
fn axis_rotations(eo: &[[f64; 3]; 3], es: &[[f64; 3]; 3]) -> Vec<[[f64; 3]; 3]> {
    const PERMS: [[usize; 3]; 6] = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    let mut out = Vec::with_capacity(24);
    for perm in PERMS {
        for signs in 0..8u32 {
            // P maps suspect axis perm[j] to original axis j with a sign.
            let mut p = [[0.0; 3]; 3];
            for j in 0..3 {
                p[j][perm[j]] = if signs >> j & 1 == 1 { -1.0 } else { 1.0 };
            }
            let r: [[f64; 3]; 3] = std::array::from_fn(|i| {
                std::array::from_fn(|k| {
                    (0..3)
                        .map(|j| eo[i][j] * (0..3).map(|l| p[j][l] * es[k][l]).sum::<f64>())
                        .sum()
                })
            });
            if det(&r) > 0.0 {
                out.push(r);
            }
        }
    }
    out
}

/// Evenly spread, seeded sample of `count` vertex positions (all when fewer).
fn sample(m: &TriMesh, count: usize, seed: u64) -> Vec<[f64; 3]> {
    let n = m.positions.len();
    if n <= count {
        return m.positions.clone();
    }
    let mut g = SplitMix64::new(seed);
    crate::watermark::key::permutation(g.next_u64(), n, count)
        .into_iter()
        .map(|i| m.positions[i as usize])
        .collect()
}

/// ICP from `start`: returns the transform, the trimmed RMS residual and the steps.
fn icp(
    points: &[[f64; 3]],
    bvh: &Bvh,
    start: Similarity,
    iterations: usize,
    params: &RegisterParams,
) -> (Similarity, f64, usize) {
    let mut t = start;
    let mut best_rms = f64::INFINITY;
    let mut steps = 0;
    for _ in 0..iterations {
        steps += 1;
        let pairs: Vec<([f64; 3], [f64; 3], f64)> = points
            .par_iter()
            .map(|&p| {
                let q = t.apply(p);
                let (c, d2) = bvh.closest(&q);
                (p, c, d2)
            })
            .collect();
        let mut d2: Vec<f64> = pairs.iter().map(|x| x.2).collect();
        let keep = ((params.trim * pairs.len() as f64).ceil() as usize).clamp(1, pairs.len());
        d2.select_nth_unstable_by(keep - 1, f64::total_cmp);
        let cut = d2[keep - 1];
        let kept: Vec<&([f64; 3], [f64; 3], f64)> = pairs.iter().filter(|x| x.2 <= cut).collect();
        let rms = (kept.iter().map(|x| x.2).sum::<f64>() / kept.len() as f64).sqrt();
        let a: Vec<[f64; 3]> = kept.iter().map(|x| x.0).collect();
        let b: Vec<[f64; 3]> = kept.iter().map(|x| x.1).collect();
        let improved = best_rms - rms;
        best_rms = best_rms.min(rms);
        match fit_similarity(&a, &b) {
            Some(next) => t = next,
            None => break,
        }
        if improved.is_finite() && improved <= params.tolerance * rms {
            break;
        }
    }
    // The residual of the final transform.
    let d: Vec<f64> = points
        .par_iter()
        .map(|&p| bvh.closest(&t.apply(p)).1)
        .collect();
    let mut d = d;
    let keep = ((params.trim * d.len() as f64).ceil() as usize).clamp(1, d.len());
    d.select_nth_unstable_by(keep - 1, f64::total_cmp);
    let rms = (d[..keep].iter().sum::<f64>() / keep as f64).sqrt();
    (t, rms, steps)
}

fn check(m: &TriMesh, which: &'static str) -> Result<(), RegisterError> {
    if m.positions.iter().flatten().any(|v| !v.is_finite()) {
        return Err(RegisterError::NonFinite { which });
    }
    Ok(())
}

/// Registers `suspect` to `original`: the similarity mapping the suspect onto the
/// original (see the module documentation) and its report.
pub fn register(
    suspect: &TriMesh,
    original: &TriMesh,
    params: &RegisterParams,
) -> Result<(Similarity, RegistrationReport), RegisterError> {
    if !(params.trim > 0.0 && params.trim <= 1.0) {
        return Err(RegisterError::InvalidParameter {
            name: "trim",
            reason: "must be in (0, 1]",
        });
    }
    if !(params.max_rms > 0.0) || params.samples == 0 || params.start_samples == 0 {
        return Err(RegisterError::InvalidParameter {
            name: "max_rms/samples",
            reason: "must be positive",
        });
    }
    check(suspect, "suspect")?;
    check(original, "original")?;
    let (co, cov_o, _) =
        moments(original).ok_or(RegisterError::Degenerate { which: "original" })?;
    let (cs, cov_s, _) = moments(suspect).ok_or(RegisterError::Degenerate { which: "suspect" })?;
    let diag = original.bbox_diagonal();
    let same = params.use_correspondences
        && suspect.positions.len() == original.positions.len()
        && suspect.faces == original.faces;
    let (t, rms, method, iterations) = if same {
        let t = fit_similarity(&suspect.positions, &original.positions)
            .ok_or(RegisterError::Degenerate { which: "suspect" })?;
        let ss: f64 = suspect
            .positions
            .iter()
            .zip(&original.positions)
            .map(|(&a, b)| {
                let p = t.apply(a);
                (0..3).map(|k| (p[k] - b[k]).powi(2)).sum::<f64>()
            })
            .sum();
        (
            t,
            (ss / suspect.positions.len() as f64).sqrt(),
            "correspondences",
            0,
        )
    } else {
        let bvh = Bvh::new(original);
        let (eo, es) = (
            axes(&cov_o).ok_or(RegisterError::Degenerate { which: "original" })?,
            axes(&cov_s).ok_or(RegisterError::Degenerate { which: "suspect" })?,
        );
        let tr = |c: &[[f64; 3]; 3]| c[0][0] + c[1][1] + c[2][2];
        let s0 = (tr(&cov_o) / tr(&cov_s)).sqrt();
        if !(s0 > 0.0) || !s0.is_finite() {
            return Err(RegisterError::Degenerate { which: "suspect" });
        }
        let few = sample(suspect, params.start_samples, params.seed);
        let mut best: Option<(Similarity, f64)> = None;
        for rotation in axis_rotations(&eo, &es) {
            let r = Similarity {
                scale: s0,
                rotation,
                translation: [0.0; 3],
            };
            let rc = r.apply(cs);
            let start = Similarity {
                translation: std::array::from_fn(|k| co[k] - rc[k]),
                ..r
            };
            let (t, rms, _) = icp(&few, &bvh, start, params.start_iterations, params);
            if best.as_ref().is_none_or(|b| rms < b.1) {
                best = Some((t, rms));
            }
        }
        // The identity too: most attacks do not move the mesh, and a part of it
        // (cropping) has other principal axes than the whole.
        let (t, rms, _) = icp(
            &few,
            &bvh,
            Similarity::identity(),
            params.start_iterations,
            params,
        );
        if best.as_ref().is_none_or(|b| rms < b.1) {
            best = Some((t, rms));
        }
        let (start, _) = best.ok_or(RegisterError::Degenerate { which: "suspect" })?;
        let many = sample(suspect, params.samples, params.seed ^ 1);
        let (t, rms, steps) = icp(&many, &bvh, start, params.max_iterations, params);
        (t, rms, "icp", steps)
    };
    let relative = rms / diag;
    if !(relative <= params.max_rms) {
        return Err(RegisterError::NoMatch {
            relative,
            limit: params.max_rms,
        });
    }
    Ok((
        t,
        RegistrationReport {
            scale: t.scale,
            rotation_degrees: t.rotation_degrees(),
            translation: t.translation,
            rms_residual: rms,
            method,
            iterations,
        },
    ))
}
