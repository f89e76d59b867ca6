//! Quantization and context modelling of the spectral coefficients, shared by the
//! encoder and the decoder so that both walk the coefficients in the same order with
//! the same models.
//!
//! **Quantization.** A global step `Δ` scaled per band: the kept coefficients of a
//! patch are cut into four bands of equal count, band `b` using step
//! `Δ·(1 + s·b/3)` (`s`: the band slope). The quantizer has a dead zone,
//! `q = sign(c)·⌊|c|/s_b + θ⌋` (`θ`: the dead zone, ½ being plain rounding):
//! coefficients just above half a step, which cost the most bits for the error they
//! remove, become zeros. Coarser high bands and more zeros spend the bits on the low
//! frequencies, which shape the surface; the vertex error is spread along it.
//!
//! **Contexts.** Each integer is range-coded with an adaptive model chosen by the
//! coefficient's frequency octave and the magnitude of its already coded neighbours
//! ([`coef_context`]). Spectra decay with frequency roughly by octaves, and
//! neighbouring coefficients have similar magnitudes.

use crate::codec::entropy::IntModel;
use crate::codec::CodecError;
use faer::Mat;

/// Bands of equal count with their own step.
const BANDS: usize = 4;
/// Magnitude buckets of the coefficient contexts.
const MAG_BUCKETS: usize = 8;
/// Frequency bands (octaves) of the coefficient contexts.
pub(super) const FREQ_BANDS: usize = 8;

/// Step of coefficient `j` of `m`: `step·(1 + slope·b/3)` in band `b = ⌊4j/m⌋`.
fn band_step(step: f64, slope: f64, j: usize, m: usize) -> f64 {
    let b = (j * BANDS) / m.max(1);
    step * (1.0 + slope * b as f64 / (BANDS - 1) as f64)
}

/// Context of coefficient `j`, coordinate `k`: its frequency band `⌈log2(j+1)⌉`
/// (capped at 7: spectra decay with frequency, roughly by octaves) times a bucket of
/// the expected magnitude, a weighted mean of the same coordinate's four previous
/// quantized coefficients and of this coefficient's already coded coordinates.
fn coef_context(j: usize, k: usize, hist: &[[i64; 3]; 4], row: &[i64; 3]) -> usize {
    let h = |t: usize| hist[3 - t][k].unsigned_abs();
    let same: u64 = (0..k).map(|kk| row[kk].unsigned_abs()).sum::<u64>() * 2 / (k.max(1) as u64);
    let a = (2 * (h(0) + h(1)) + h(2) + h(3) + same + 2) / 4;
    let mag = match a {
        0 => 0,
        1 => 1,
        2..=3 => 2,
        4..=7 => 3,
        8..=15 => 4,
        16..=31 => 5,
        32..=63 => 6,
        _ => 7,
    };
    octave(j) * MAG_BUCKETS + mag
}

/// Frequency octave `⌈log2(j+1)⌉` of coefficient `j`, capped at `FREQ_BANDS − 1`.
pub(super) fn octave(j: usize) -> usize {
    ((usize::BITS - j.leading_zeros()) as usize).min(FREQ_BANDS - 1)
}

/// The adaptive models of the spectral geometry stream.
pub(super) struct Models {
    /// One per coefficient context.
    coef: Vec<IntModel>,
    /// One per coordinate of the residual-coded vertices.
    pub resid: Vec<IntModel>,
}

impl Models {
    /// Fresh models (every probability ½).
    pub fn new() -> Self {
        Models {
            coef: (0..MAG_BUCKETS * FREQ_BANDS)
                .map(|_| IntModel::default())
                .collect(),
            resid: (0..3).map(|_| IntModel::default()).collect(),
        }
    }

    /// Codes the `m` kept coefficients of one patch, row by row (x, y, z): for each,
    /// `code(j, k, s, model)` gets the coefficient's band step `s` and the model of its
    /// context, and encodes or decodes the quantized integer it returns. Returns the
    /// dequantized coefficients `q·s` (m×3), as the decoder will have them.
    pub fn code_patch(
        &mut self,
        m: usize,
        step: f64,
        band_slope: f64,
        mut code: impl FnMut(usize, usize, f64, &mut IntModel) -> Result<i64, CodecError>,
    ) -> Result<Mat<f64>, CodecError> {
        let mut q = Mat::<f64>::zeros(m, 3);
        let mut hist = [[0i64; 3]; 4];
        for j in 0..m {
            let s = band_step(step, band_slope, j, m);
            let mut row = [0i64; 3];
            for k in 0..3 {
                let qi = code(j, k, s, &mut self.coef[coef_context(j, k, &hist, &row)])?;
                q[(j, k)] = qi as f64 * s;
                row[k] = qi;
            }
            hist = [hist[1], hist[2], hist[3], row];
        }
        Ok(q)
    }
}
