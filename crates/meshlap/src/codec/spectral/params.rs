//! Parameters of the spectral geometry coder and their defaults.

use crate::codec::CodecError;
use crate::operator::OperatorKind;

/// Smallest patch size (vertices).
pub const MIN_PATCH: usize = 4;

/// Largest patch size: each patch costs a dense O(P³) eigendecomposition with O(P²)
/// memory on both sides, and a hostile file must not ask for more.
pub const MAX_PATCH: usize = 1000;

/// The operators a spectral `.mlz` stream can name, by code.
pub(super) const OPERATORS: [OperatorKind; 5] = [
    OperatorKind::Kirchhoff,
    OperatorKind::Tutte,
    OperatorKind::Graph,
    OperatorKind::Sql,
    OperatorKind::Sstl,
];

/// The code of an operator in the header, `None` for an operator the coder cannot use.
pub(super) fn operator_code(k: OperatorKind) -> Option<u8> {
    OPERATORS.iter().position(|&o| o == k).map(|c| c as u8)
}

/// How many low-frequency coefficients each patch keeps.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum Keep {
    /// A fraction `r ∈ (0, 1]` of the patch's vertex count (at least 1).
    Ratio(f64),
    /// A fixed number per patch (at most the patch's vertex count).
    Count(u32),
}

impl Keep {
    /// Coefficients kept by a patch of `n` vertices: `round(r·n)` or the fixed count,
    /// clamped to `1..=n`.
    pub fn count(self, n: usize) -> usize {
        let m = match self {
            Keep::Ratio(r) => (r * n as f64).round() as usize,
            Keep::Count(m) => m as usize,
        };
        m.clamp(1, n.max(1))
    }
}

/// Parameters of the spectral geometry coder.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct SpectralParams {
    /// The combinatorial operator (`F = D − W`, positive semi-definite) whose
    /// eigenvectors form the basis: Kirchhoff, Tutte, graph, SQL or SSTL.
    pub operator: OperatorKind,
    /// Target patch size (vertices), in `MIN_PATCH..=MAX_PATCH`.
    pub patch_size: usize,
    /// Coefficients kept per patch.
    pub keep: Keep,
    /// Border-aware coding: code residuals of patch-border vertices.
    pub border_residuals: bool,
    /// Per-band steps: band `b ∈ 0..4` of the kept coefficients uses step
    /// `Δ·(1 + slope·b/3)`, slope in `[0, 16]` (0: one step for all; high-rate theory
    /// says uniform steps minimise the mean squared error of an orthonormal
    /// transform).
    pub band_slope: f64,
    /// Inter-patch prediction: each patch codes the coefficients of its difference
    /// from the smoothest continuation of the earlier patches' decoded vertices.
    pub predicted: bool,
    /// Dead-zone rounding offset `θ ∈ [0.2, 0.5]` of the coefficient quantizer
    /// `q = sign(c)·⌊|c|/s + θ⌋` (½: plain rounding). Encoder-side only: the decoder
    /// reconstructs `q·s` either way.
    pub dead_zone: f64,
}

impl Default for SpectralParams {
    fn default() -> Self {
        SpectralParams {
            operator: OperatorKind::Kirchhoff,
            patch_size: 100,
            keep: Keep::Ratio(1.0),
            border_residuals: false,
            band_slope: 1.0,
            predicted: true,
            dead_zone: 0.35,
        }
    }
}

impl SpectralParams {
    /// Checks every parameter's range.
    pub fn validate(&self) -> Result<(), CodecError> {
        if operator_code(self.operator).is_none() {
            return Err(CodecError::Parameter(format!(
                "the {} operator cannot be used for compression; choose sstl, sql, tutte, kirchhoff or graph",
                self.operator
            )));
        }
        if let Keep::Ratio(r) = self.keep {
            if !(r > 0.0 && r <= 1.0) {
                return Err(CodecError::Parameter(format!(
                    "--keep-ratio must be in (0, 1], got {r}"
                )));
            }
        }
        if !(0.0..=16.0).contains(&self.band_slope) {
            return Err(CodecError::Parameter(format!(
                "band slope must be in [0, 16], got {}",
                self.band_slope
            )));
        }
        if !(0.2..=0.5).contains(&self.dead_zone) {
            return Err(CodecError::Parameter(format!(
                "dead-zone rounding offset must be in [0.2, 0.5], got {}",
                self.dead_zone
            )));
        }
        if self.patch_size < MIN_PATCH || self.patch_size > MAX_PATCH {
            return Err(CodecError::Parameter(format!(
                "--patch-size must be between {MIN_PATCH} and {MAX_PATCH}, got {}",
                self.patch_size
            )));
        }
        Ok(())
    }
}
