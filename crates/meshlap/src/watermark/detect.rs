//! Non-blind watermark detection (Ohbuchi et al. GI 2001 §4, CGF 2002 §4) with a
//! rigorous false-positive probability.
//!
//! ## Steps
//! 1. **Register** the suspect to the original ([`super::register`]: similarity by
//!    vertex correspondences when the connectivity is the same, else principal axes
//!    and trimmed ICP with scale).
//! 2. **Resample** when the connectivity differs ([`super::resample`]): each original
//!    vertex takes the closest point of the registered suspect's surface (missing
//!    vertices, e.g. cropped ones, keep their original position).
//! 3. **Transform** both with the ORIGINAL's patch bases ([`super::layout`]) and
//!    subtract: the residual `r_s = X̃_s − X_s` of every slot s.
//! 4. **Remove the smoothing component.** Smoothing (and the corner cutting of a
//!    resampled, simplified surface) moves the low-frequency coefficients by a
//!    polynomial in the umbrella operator `T = I − C` (C the neighbour average of the
//!    whole mesh) applied to the geometry: `x_s ≈ p(T) x`, so the residual lies near the
//!    span of the coefficients of `x, Tx, T²x, …` of the original — up to thirty times
//!    the mark's amplitude after ten smoothing steps, mostly from the patch borders,
//!    where the patch operator is not the mesh's. Per patch, the least-squares
//!    component of the residual in the span of `{X, TX, …, T^q X}` (q =
//!    `smoothing_order`, one coefficient per vector shared by the three axes) is
//!    subtracted. The subspace depends on the original only, so the bound below still
//!    holds; the mark, spread by random chips, loses about `(q + 1) / (3·band)` of its
//!    energy.
//! 5. **Weight** the residuals by inverse variances (treating them as independent
//!    noise whose variance depends on the group; inverse-variance weights maximise the
//!    correlation's SNR). Patches damaged by an attack — cropped, badly resampled —
//!    count less; a group with zero residual counts nothing.
//!    - Same connectivity ([`Weighting::PatchAxis`]): one weight per patch and axis,
//!      `w_{p,a} = 1 / mean_k r²_{p,k,a}`. Coordinate quantization to a grid leaves a
//!      patch that faces an axis a slowly varying error along that axis, i.e. noise
//!      concentrated in the low frequencies the mark occupies, on one axis only.
//!    - Resampled suspect ([`Weighting::Patch`]): one weight per patch,
//!      `w_p = 1 / mean_{s∈p} r_s²`. Closest-point resampling keeps the mark's normal
//!      component and loses its tangential one, so per patch the tangential axes have
//!      a small residual *without* mark; per-axis weights would favour exactly them.
//!
//!    [`Weighting::Auto`] (the default) takes the first for a suspect with the
//!    original's connectivity and the second otherwise.
//! 6. **Correlate**: for bit i with slots `s_ij` and chips `χ_ij`,
//!    `q_i = Σ_j χ_ij w r_{s_ij}` (w the slot's weight), normalised `u_i = q_i / √(Σ_j w² r²_{s_ij})`; the
//!    bit is the sign of `q_i` and its confidence the normalised correlation
//!    `ρ_i = u_i / √c ∈ [−1, 1]` (the cosine between the chips and the weighted
//!    residuals).
//!
//! ## False-positive probability (rigorous)
//! Under H0 — an unmarked mesh, or a mesh marked with another key — the chips of the
//! tested key are independent fair ±1 signs, independent of the residuals and weights
//! (these depend on the two meshes only; [`super::key`] draws the chips from a stream
//! of their own). Conditioned on the residuals, each `u_i` is then a Rademacher sum
//! with unit variance proxy, and the `u_i` of different bits (disjoint slots,
//! independent chips) are independent. For λ < ½,
//! `E exp(λu_i²) = E_g E exp(√(2λ) g u_i) ≤ E_g exp(λ g²) = (1 − 2λ)^{−½}`
//! (g standard normal; Hoeffding's lemma for the inner expectation), so by Chernoff
//! the statistic `T = Σ_i u_i²` of B bits satisfies
//!
//! `P_H0(T ≥ t) ≤ exp(−(t − B)/2) · (t / B)^{B/2}` for t > B (and ≤ 1 otherwise),
//!
//! whatever the distribution of the residuals (noise of any attack, heavy tails). This
//! bound at the observed T is `false_positive_probability`: the probability that an
//! unmarked mesh or a wrong key correlates at least this strongly. The watermark is
//! reported **found** only when it is at most `max_false_positive` (default 10⁻⁶);
//! otherwise the message is withheld ("no watermark found").
//!
//! With an expected message, `bit_errors`/`ber` count the sign decisions that differ
//! from it (whether or not the mark was found), and `chance_match_probability` is
//! `P(Binomial(B, ½) ≤ bit_errors)`: the chance that a random decoding (each bit's
//! sign is a fair coin under H0, by the symmetry of the chips) agrees this well.

use super::error::WatermarkError;
use super::layout::{Layout, LayoutParams};
use super::message::{bits_to_hex, Message};
use super::register::{register, RegisterParams, RegistrationReport};
use super::resample::{resample, ResampleParams, ResampleReport};
use crate::mesh::topology::Topology;
use crate::mesh::TriMesh;
use serde::Serialize;

/// Parameters of [`detect`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DetectParams {
    /// The secret key tested.
    pub key: u64,
    /// Message length in bits (the embedded message's).
    pub bits: usize,
    /// The layout used at embedding.
    pub layout: LayoutParams,
    /// Registration of the suspect.
    pub registration: RegisterParams,
    /// Resampling when the connectivity differs.
    pub resample: ResampleParams,
    /// Largest false-positive probability at which the mark counts as found.
    pub max_false_positive: f64,
    /// The message expected, for `bit_errors` and `ber`.
    pub expect: Option<Message>,
    /// Highest power q of the umbrella operator in the nuisance subspace
    /// `{X, TX, …, T^q X}` projected out of each patch's residual (0: none, the
    /// plain correlation of Ohbuchi et al.).
    pub smoothing_order: usize,
    /// How the residuals are weighted before the correlation (step 5).
    pub weighting: Weighting,
}

/// Weighting of the residuals before the correlation (module documentation, step 5).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Weighting {
    /// One weight per patch, `w_p = 1 / mean_{s∈p} r_s²`.
    Patch,
    /// One weight per patch and axis, `w_{p,a} = 1 / mean r_s²` over the patch's slots
    /// of axis a.
    PatchAxis,
    /// [`Weighting::PatchAxis`] when the suspect has the original's connectivity,
    /// [`Weighting::Patch`] when it was resampled (the default; module documentation,
    /// step 5).
    #[default]
    Auto,
}

crate::names::option_names!(Weighting, WatermarkError, |s| WatermarkError::InvalidParameter {
    name: "weighting",
    value: s.to_string(),
    reason: "must be auto, patch or patch-axis",
}, {
    Auto => "auto",
    Patch => "patch",
    PatchAxis => "patch-axis",
});

impl DetectParams {
    /// Library defaults for `key` and a message of `bits` bits.
    pub fn new(key: u64, bits: usize) -> Self {
        Self {
            key,
            bits,
            layout: LayoutParams::default(),
            registration: RegisterParams::default(),
            resample: ResampleParams::default(),
            max_false_positive: 1e-6,
            expect: None,
            smoothing_order: 3,
            weighting: Weighting::default(),
        }
    }
}

impl Default for DetectParams {
    /// Key 0, 64 bits.
    fn default() -> Self {
        Self::new(0, 64)
    }
}

/// The result of [`detect`] (JSON keys of `meshlap watermark detect`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DetectReport {
    /// True when the false-positive probability is at most the threshold.
    pub found: bool,
    /// The message (hex), only when found.
    pub message: Option<String>,
    /// The bits (0/1), only when found.
    pub bits: Option<Vec<u8>>,
    /// Normalised correlation ρ_i ∈ [−1, 1] per bit (its sign is the bit).
    pub correlations: Vec<f64>,
    /// Bound on the probability that an unmarked mesh or a wrong key correlates at
    /// least this strongly (see the module documentation).
    pub false_positive_probability: f64,
    /// Its base-10 logarithm (finite where the probability underflows to 0).
    pub false_positive_log10: f64,
    /// The registration of the suspect.
    pub registration: RegistrationReport,
    /// True when the suspect was resampled onto the original's connectivity.
    pub resampled: bool,
    /// The resampling, when done.
    pub resampling: Option<ResampleReport>,
    /// Chips per bit.
    pub coefficients_per_bit: usize,
    /// RMS over every slot of the residual `X̃ − X` after step 4 (mesh units): the
    /// mark's per-slot amplitude and the attack's noise in the band together.
    pub residual_rms: f64,
    /// Sign decisions differing from the expected message (with `expect`).
    pub bit_errors: Option<usize>,
    /// `bit_errors / bits`.
    pub ber: Option<f64>,
    /// `P(Binomial(B, ½) ≤ bit_errors)` (with `expect`).
    pub chance_match_probability: Option<f64>,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// `ln P_H0(T ≥ t)` bound for B bits: `−(t − B)/2 + (B/2) ln(t/B)` for t > B, else 0.
pub fn chi_square_tail_ln(t: f64, bits: usize) -> f64 {
    let b = bits as f64;
    if !(t > b) {
        return 0.0;
    }
    (-(t - b) / 2.0 + b / 2.0 * (t / b).ln()).min(0.0)
}

/// `ln P(Binomial(n, ½) ≤ k)`.
pub fn binomial_lower_tail_ln(n: usize, k: usize) -> f64 {
    if k >= n {
        return 0.0;
    }
    // ln C(n, j) by the recurrence C(n, j) = C(n, j−1)(n − j + 1)/j; log-sum-exp.
    let mut terms = Vec::with_capacity(k + 1);
    let mut lc = 0.0f64;
    for j in 0..=k {
        if j > 0 {
            lc += ((n - j + 1) as f64).ln() - (j as f64).ln();
        }
        terms.push(lc);
    }
    let m = terms.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    m + terms.iter().map(|t| (t - m).exp()).sum::<f64>().ln() - n as f64 * 2f64.ln()
}

/// Detects the watermark of `params.key` in `suspect`, given the `original` it was
/// embedded into (non-blind); see the module documentation. To test many suspects
/// against one original, build a [`Detector`] once.
pub fn detect(
    suspect: &TriMesh,
    original: &TriMesh,
    params: &DetectParams,
) -> Result<DetectReport, WatermarkError> {
    let start = std::time::Instant::now();
    let mut r = Detector::new(original, params)?.detect(suspect)?;
    r.seconds = start.elapsed().as_secs_f64();
    Ok(r)
}

/// The original's layout and coefficients, computed once for many suspects.
pub struct Detector<'a> {
    original: &'a TriMesh,
    params: DetectParams,
    layout: Layout,
    coefficients: Vec<f64>,
    /// Slot coefficients of `X, TX, …, T^q X` (q = `smoothing_order`).
    nuisance: Vec<Vec<f64>>,
}

impl<'a> Detector<'a> {
    /// Validates `params` and computes the original's patch bases and coefficients.
    pub fn new(original: &'a TriMesh, params: &DetectParams) -> Result<Self, WatermarkError> {
        if params.bits == 0 || params.bits > super::message::MAX_BITS {
            return Err(WatermarkError::InvalidParameter {
                name: "bits",
                value: params.bits.to_string(),
                reason: "must be 1 to 4096",
            });
        }
        if let Some(e) = &params.expect {
            if e.len() != params.bits {
                return Err(WatermarkError::InvalidParameter {
                    name: "expect",
                    value: format!("{} bits", e.len()),
                    reason: "the expected message must have `bits` bits",
                });
            }
        }
        if !(params.max_false_positive > 0.0 && params.max_false_positive < 1.0) {
            return Err(WatermarkError::InvalidParameter {
                name: "max_false_positive",
                value: params.max_false_positive.to_string(),
                reason: "must be in (0, 1)",
            });
        }
        params.layout.validate()?;
        let topo = Topology::new(original)?;
        let layout = Layout::new(original, &topo, &params.layout, params.key, params.bits)?;
        let coefficients = layout.coefficients(&original.positions);
        let mut nuisance = Vec::with_capacity(params.smoothing_order + 1);
        if params.smoothing_order > 0 {
            nuisance.push(coefficients.clone());
            let mut x = original.positions.clone();
            for _ in 0..params.smoothing_order {
                x = umbrella(&topo, &x);
                nuisance.push(layout.coefficients(&x));
            }
        }
        Ok(Self {
            original,
            params: params.clone(),
            layout,
            coefficients,
            nuisance,
        })
    }

    /// The same detector testing another key (the bases are reused).
    pub fn with_key(&self, key: u64) -> Self {
        let layout = self.layout.rekeyed(key, self.params.bits);
        Self {
            original: self.original,
            params: DetectParams {
                key,
                ..self.params.clone()
            },
            layout,
            coefficients: self.coefficients.clone(),
            nuisance: self.nuisance.clone(),
        }
    }

    /// Detects the watermark in `suspect`.
    pub fn detect(&self, suspect: &TriMesh) -> Result<DetectReport, WatermarkError> {
        let start = std::time::Instant::now();
        let (original, params, layout) = (self.original, &self.params, &self.layout);
        let (sim, registration) = register(suspect, original, &params.registration)?;
        let registered = TriMesh::new(
            suspect.positions.iter().map(|&p| sim.apply(p)).collect(),
            suspect.faces.clone(),
        );
        let same =
            suspect.positions.len() == original.positions.len() && suspect.faces == original.faces;
        let (positions, resampling) = if same {
            (registered.positions, None)
        } else {
            let (p, _, rep) = resample(&registered, original, &params.resample)?;
            (p, Some(rep))
        };
        let xs = layout.coefficients(&positions);
        let mut r: Vec<f64> = xs
            .iter()
            .zip(&self.coefficients)
            .map(|(a, b)| a - b)
            .collect();
        project_out(layout, &self.nuisance, &mut r);
        let residual_rms = (r.iter().map(|x| x * x).sum::<f64>() / r.len().max(1) as f64).sqrt();
        let weighting = match params.weighting {
            Weighting::Auto if same => Weighting::PatchAxis,
            Weighting::Auto => Weighting::Patch,
            w => w,
        };
        let z = weighted(layout, &r, weighting);
        let c = layout.chip_rate;
        let mut u = Vec::with_capacity(params.bits);
        for i in 0..params.bits {
            let (mut q, mut n2) = (0.0, 0.0);
            for j in 0..c {
                let s = layout.assigned[i * c + j] as usize;
                let wr = z[s];
                q += layout.chips[i * c + j] * wr;
                n2 += wr * wr;
            }
            u.push(if n2 > 0.0 { q / n2.sqrt() } else { 0.0 });
        }
        let t: f64 = u.iter().map(|x| x * x).sum();
        let ln_p = chi_square_tail_ln(t, params.bits);
        let p = ln_p.exp();
        let found = p <= params.max_false_positive;
        let decided: Vec<bool> = u.iter().map(|&x| x > 0.0).collect();
        let (bit_errors, ber, chance) = match &params.expect {
            Some(e) => {
                let errors = decided.iter().zip(e.bits()).filter(|(a, b)| a != b).count();
                (
                    Some(errors),
                    Some(errors as f64 / params.bits as f64),
                    Some(binomial_lower_tail_ln(params.bits, errors).exp()),
                )
            }
            None => (None, None, None),
        };
        Ok(DetectReport {
            found,
            message: found.then(|| bits_to_hex(&decided)),
            bits: found.then(|| decided.iter().map(|&b| u8::from(b)).collect()),
            correlations: u.iter().map(|x| x / (c as f64).sqrt()).collect(),
            false_positive_probability: p,
            false_positive_log10: ln_p / std::f64::consts::LN_10,
            registration,
            resampled: !same,
            resampling,
            coefficients_per_bit: c,
            residual_rms,
            bit_errors,
            ber,
            chance_match_probability: chance,
            seconds: start.elapsed().as_secs_f64(),
        })
    }
}

/// `T x = x − C x` (C: the neighbour average) of positions `x`.
fn umbrella(topo: &Topology, x: &[[f64; 3]]) -> Vec<[f64; 3]> {
    (0..x.len())
        .map(|i| {
            let nb = topo.neighbors(crate::mesh::VertexId(i as u32));
            let mut c = [0.0; 3];
            for &j in nb {
                for k in 0..3 {
                    c[k] += x[j as usize][k];
                }
            }
            let d = nb.len().max(1) as f64;
            std::array::from_fn(|k| x[i][k] - c[k] / d)
        })
        .collect()
}

/// Subtracts from each patch's residual its least-squares component in the span of
/// the nuisance vectors restricted to the patch (normal equations with a tiny ridge;
/// Gaussian elimination with partial pivoting).
fn project_out(layout: &Layout, nuisance: &[Vec<f64>], r: &mut [f64]) {
    let q = nuisance.len();
    if q == 0 {
        return;
    }
    for (p, b) in layout.patches.iter().enumerate() {
        let end = layout.patches.get(p + 1).map_or(layout.slots, |n| n.offset);
        let range = b.offset..end;
        let mut a = vec![vec![0.0f64; q + 1]; q];
        for i in 0..q {
            for j in 0..q {
                a[i][j] = range.clone().map(|s| nuisance[i][s] * nuisance[j][s]).sum();
            }
            a[i][q] = range.clone().map(|s| nuisance[i][s] * r[s]).sum();
        }
        let trace: f64 = (0..q).map(|i| a[i][i]).sum();
        if !(trace > 0.0) {
            continue;
        }
        for i in 0..q {
            a[i][i] += 1e-12 * trace;
        }
        let Some(beta) = solve(a) else { continue };
        for s in range {
            r[s] -= (0..q).map(|i| beta[i] * nuisance[i][s]).sum::<f64>();
        }
    }
}

/// Solves the q×q system with its right-hand side as column q.
fn solve(mut a: Vec<Vec<f64>>) -> Option<Vec<f64>> {
    let q = a.len();
    for c in 0..q {
        let piv = (c..q).max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))?;
        a.swap(c, piv);
        if a[c][c].abs() < f64::MIN_POSITIVE {
            return None;
        }
        for i in c + 1..q {
            let f = a[i][c] / a[c][c];
            for j in c..=q {
                a[i][j] -= f * a[c][j];
            }
        }
    }
    let mut x = vec![0.0; q];
    for i in (0..q).rev() {
        x[i] = (a[i][q] - (i + 1..q).map(|j| a[i][j] * x[j]).sum::<f64>()) / a[i][i];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// The weighted residual `z_s = w r_s` of every slot (see [`Weighting`]; a group with
/// zero residual gets weight 0).
fn weighted(layout: &Layout, r: &[f64], weighting: Weighting) -> Vec<f64> {
    let mut z = vec![0.0; r.len()];
    for (p, b) in layout.patches.iter().enumerate() {
        let end = layout.patches.get(p + 1).map_or(layout.slots, |n| n.offset);
        // Slots are numbered 3k + axis within the patch.
        let groups: &[&[usize]] = match weighting {
            Weighting::Patch | Weighting::Auto => &[&[0, 1, 2]],
            Weighting::PatchAxis => &[&[0], &[1], &[2]],
        };
        for axes in groups {
            let slots: Vec<usize> = (b.offset..end)
                .filter(|s| axes.contains(&((s - b.offset) % 3)))
                .collect();
            let ms = slots.iter().map(|&s| r[s] * r[s]).sum::<f64>() / slots.len().max(1) as f64;
            let w = if ms > 0.0 && ms.is_finite() {
                1.0 / ms
            } else {
                0.0
            };
            for &s in &slots {
                z[s] = w * r[s];
            }
        }
    }
    z
}
