//! Rate control and the choice of the geometry coder.
//!
//! **Rate control** (`--target-bpv`): the finest step whose whole file fits the
//! budget, found by [`fit_bits`] from a guess (10 bits, or for the spatial coder half
//! a bit finer than the spectral coder's answer: it runs at about half a bit finer
//! for the same rate).
//!
//! **Mode decision** ([`GeometryMode::Auto`]): a transform coder wins at low rates,
//! where most high-frequency coefficients quantize to zero; at high rates, where
//! every coefficient is significant, it pays about as much per coefficient as a
//! predictive coder pays per coordinate, and the parallelogram residual is the
//! cheaper signal. So the encoder codes both and keeps the better ([`choose`]):
//! under rate control the lower product of the vertex RMS and the normal RMS (the
//! error along the input's vertex normals, which stands in for the surface distance
//! the encoder cannot afford to sample) within the budget; at a fixed step, the lower
//! `log2(RMS·normal RMS) + 2R/3` (`R`: geometry bits/vertex; one bit per coordinate
//! per halving of each error, the high-rate exchange rate). The vertex RMS alone is
//! not enough: the spectral coder's error is more tangential, so at equal vertex RMS
//! its surface error is lower (BENCHMARKS.md, Compression).

use super::geometry::{Coders, GeometrySection};
use super::{CodecError, GeometryMode, Quantization};
use glam::DVec3;

/// Rate control: the largest `q ∈ [1, 30]` (step `diag·2^{−q}`) whose file `size(q)`
/// fits `budget` bytes (`q = 1` if none does). The size grows with `q`, nearly
/// linearly. A bracket `[lo, hi]` (`lo` fits, `hi` does not) is found by steps of 1,
/// 2, 4, … bits from `guess`, then narrowed by regula falsi (Illinois variant), each
/// guess kept at least 5 % of the bracket from either end, until the bracket is below
/// 1e-3 bits or `size(lo)` is within 0.1 % of the budget. With a guess within a bit
/// or two this takes 5–7 encodes where bisection on `[1, 30]` takes about 15.
fn fit_bits(
    mut size: impl FnMut(f64) -> Result<usize, CodecError>,
    budget: usize,
    guess: f64,
) -> Result<f64, CodecError> {
    const MIN: f64 = 1.0;
    const MAX: f64 = 30.0;
    let q0 = guess.clamp(MIN, MAX);
    let s0 = size(q0)?;
    // Walk from the guess away from the budget's side (up if it fits, down if not)
    // by doubling steps until the other side is reached.
    let fits = s0 <= budget;
    let (dir, limit) = if fits { (1.0, MAX) } else { (-1.0, MIN) };
    let (mut near, mut s_near) = (q0, s0);
    let mut d = 1.0;
    let (far, s_far) = loop {
        if (near - limit) * dir >= 0.0 {
            return Ok(limit);
        }
        let q = (near + dir * d).clamp(MIN, MAX);
        let s = size(q)?;
        if (s <= budget) != fits {
            break (q, s);
        }
        (near, s_near) = (q, s);
        d *= 2.0;
    };
    let (mut lo, mut s_lo, mut hi, mut s_hi) = if fits {
        (near, s_near, far, s_far)
    } else {
        (far, s_far, near, s_near)
    };
    let b = budget as f64;
    // Illinois weights of the two ends (halved when an end is kept twice).
    let (mut w_lo, mut w_hi) = (1.0f64, 1.0f64);
    let mut last_side = 0i8;
    for _ in 0..40 {
        if hi - lo < 1e-3 || (b - s_lo as f64) < 1e-3 * b {
            break;
        }
        let (f_lo, f_hi) = (
            (s_lo as f64 - b) * w_lo,
            (s_hi.min(usize::MAX / 2) as f64 - b) * w_hi,
        );
        let mut t = if f_hi > f_lo {
            -f_lo / (f_hi - f_lo)
        } else {
            0.5
        };
        if !t.is_finite() {
            t = 0.5;
        }
        let mid = lo + (hi - lo) * t.clamp(0.05, 0.95);
        let s = size(mid)?;
        if s <= budget {
            lo = mid;
            s_lo = s;
            w_lo = 1.0;
            if last_side == 1 {
                w_hi *= 0.5;
            }
            last_side = 1;
        } else {
            hi = mid;
            s_hi = s;
            w_hi = 1.0;
            if last_side == -1 {
                w_lo *= 0.5;
            }
            last_side = -1;
        }
    }
    Ok(lo)
}

/// The distortion measures the encoder uses, against the input positions (decoded
/// vertex order), divided by the bounding-box diagonal.
pub(super) struct Estimate<'a> {
    positions: &'a [[f64; 3]],
    /// Unit vertex normals of the input (area-weighted).
    normals: Vec<DVec3>,
    diag: f64,
}

impl<'a> Estimate<'a> {
    /// The measures for `positions` (n×3) with faces `faces` and bounding-box
    /// diagonal `diag`.
    pub fn new(positions: &'a [[f64; 3]], faces: &[[u32; 3]], diag: f64) -> Self {
        let mut nrm = vec![DVec3::ZERO; positions.len()];
        for f in faces {
            let [a, b, c] = f.map(|v| DVec3::from(positions[v as usize]));
            // Twice the face's area times its unit normal.
            let x = (b - a).cross(c - a);
            for &v in f {
                nrm[v as usize] += x;
            }
        }
        let normals = nrm
            .iter()
            .map(|&x| {
                let l = x.length();
                if l > 0.0 {
                    x / l
                } else {
                    DVec3::ZERO
                }
            })
            .collect();
        Estimate {
            positions,
            normals,
            diag,
        }
    }

    /// Vertex RMS error of `rec` ÷ diagonal.
    pub fn vertex_rms(&self, rec: &[[f64; 3]]) -> f64 {
        let s: f64 = rec
            .iter()
            .zip(self.positions)
            .map(|(&a, &b)| (DVec3::from(a) - DVec3::from(b)).length_squared())
            .sum();
        (s / rec.len().max(1) as f64).sqrt() / self.diag
    }

    /// RMS of the error along the input's vertex normals ÷ diagonal.
    pub fn normal_rms(&self, rec: &[[f64; 3]]) -> f64 {
        let s: f64 = rec
            .iter()
            .zip(self.positions)
            .zip(&self.normals)
            .map(|((&a, &b), &m)| (DVec3::from(a) - DVec3::from(b)).dot(m).powi(2))
            .sum();
        (s / rec.len().max(1) as f64).sqrt() / self.diag
    }
}

/// The geometry coder kept, its step and section, and its error estimates.
pub(super) struct Choice {
    /// The coder (never `Auto`).
    pub mode: GeometryMode,
    /// Global quantization step.
    pub step: f64,
    /// The coded section.
    pub section: GeometrySection,
    /// [`Estimate::vertex_rms`] of the decoded positions.
    pub vertex_rms: f64,
    /// [`Estimate::normal_rms`] of the decoded positions.
    pub normal_rms: f64,
}

/// Codes the geometry with every coder of `modes` (at the step `quantization` gives,
/// or the one rate control finds) and keeps the best (see the module documentation).
/// `file_size` is the whole file's size around a geometry section; `diag` the
/// bounding-box diagonal; `n` the vertex count.
pub(super) fn choose(
    coders: &mut Coders,
    modes: &[GeometryMode],
    quantization: Quantization,
    diag: f64,
    n: usize,
    file_size: impl Fn(&[u8]) -> Result<usize, CodecError>,
    estimate: &Estimate,
) -> Result<Choice, CodecError> {
    let mut best: Option<(f64, Choice)> = None;
    let mut last_q = None;
    for &mode in modes {
        let step = match quantization {
            Quantization::Bits(q) => diag * (-q).exp2(),
            Quantization::TargetBpv(b) => {
                let budget = (b * n as f64 / 8.0).floor() as usize;
                // A step too small for 31-bit integers counts as "too large a file".
                let size = |q: f64| -> Result<usize, CodecError> {
                    match coders.encode(mode, diag * (-q).exp2(), false) {
                        Ok(g) => file_size(&g.bytes),
                        Err(CodecError::StepTooSmall) => Ok(usize::MAX),
                        Err(e) => Err(e),
                    }
                };
                // The spatial coder runs at about half a bit finer than the spectral
                // one for the same rate.
                let guess = match (mode, last_q) {
                    (GeometryMode::Spatial, Some(q)) => q + 0.5,
                    _ => 10.0,
                };
                let q = fit_bits(size, budget, guess)?;
                last_q = Some(q);
                diag * (-q).exp2()
            }
        };
        let pre = match mode {
            GeometryMode::Spatial => coders.take_spatial_fixed(),
            _ => None,
        };
        let section = match pre {
            Some(g) => g?,
            None => coders.encode(mode, step, true)?,
        };
        let (e, en) = (
            estimate.vertex_rms(&section.decoded),
            estimate.normal_rms(&section.decoded),
        );
        // Lower is better: the product of the vertex RMS and the normal RMS under
        // rate control; at a fixed step, traded against rate at 3 bits/vertex per
        // halving of each.
        let lg = |x: f64| x.max(f64::MIN_POSITIVE).log2();
        let score = lg(e)
            + lg(en)
            + match quantization {
                Quantization::TargetBpv(_) => 0.0,
                Quantization::Bits(_) => {
                    2.0 * section.bytes.len() as f64 * 8.0 / n.max(1) as f64 / 3.0
                }
            };
        if best.as_ref().is_none_or(|b| score < b.0) {
            best = Some((
                score,
                Choice {
                    mode,
                    step,
                    section,
                    vertex_rms: e,
                    normal_rms: en,
                },
            ));
        }
    }
    best.map(|b| b.1)
        .ok_or(CodecError::Internal("no geometry mode"))
}
