//! Parameters of the spectral geometry coder and their defaults.

use crate::codec::ParameterError;
use crate::operator::OperatorKind;

/// Smallest patch size (vertices).
pub const MIN_PATCH: usize = 4;

/// Largest patch size: each patch costs a dense O(P³) eigendecomposition with O(P²)
/// memory on both sides, and a hostile file must not ask for more.
pub const MAX_PATCH: usize = 1000;

/// Largest band slope.
pub const MAX_BAND_SLOPE: f64 = 16.0;

/// Smallest dead-zone rounding offset.
pub const MIN_DEAD_ZONE: f64 = 0.2;

/// Largest dead-zone rounding offset (plain rounding).
pub const MAX_DEAD_ZONE: f64 = 0.5;

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
    /// A fixed number `m ≥ 1` per patch (at most the patch's vertex count).
    Count(u32),
}

impl Default for Keep {
    /// Every coefficient: `Ratio(1.0)`.
    fn default() -> Self {
        Keep::Ratio(1.0)
    }
}

impl Keep {
    /// The rule a front end's two optional settings give: a fixed `count` if given,
    /// else a `ratio` if given, else the default (every coefficient).
    pub fn from_options(ratio: Option<f64>, count: Option<u32>) -> Self {
        match (ratio, count) {
            (_, Some(m)) => Keep::Count(m),
            (Some(r), None) => Keep::Ratio(r),
            (None, None) => Keep::default(),
        }
    }

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
    /// Target patch size (vertices), in [`MIN_PATCH`]`..=`[`MAX_PATCH`].
    pub patch_size: usize,
    /// Coefficients kept per patch.
    pub keep: Keep,
    /// Border-aware coding: code residuals of patch-border vertices.
    pub border_residuals: bool,
    /// Per-band steps: band `b ∈ 0..4` of the kept coefficients uses step
    /// `Δ·(1 + slope·b/3)`, slope in `[0, MAX_BAND_SLOPE]` (0: one step for all; high-rate theory
    /// says uniform steps minimize the mean squared error of an orthonormal
    /// transform).
    pub band_slope: f64,
    /// Inter-patch prediction: each patch codes the coefficients of its difference
    /// from the smoothest continuation of the earlier patches' decoded vertices.
    pub predicted: bool,
    /// Dead-zone rounding offset `θ ∈ [MIN_DEAD_ZONE, MAX_DEAD_ZONE]` of the coefficient quantizer
    /// `q = sign(c)·⌊|c|/s + θ⌋` (½: plain rounding). Encoder-side only: the decoder
    /// reconstructs `q·s` either way.
    pub dead_zone: f64,
}

impl Default for SpectralParams {
    fn default() -> Self {
        SpectralParams {
            operator: OperatorKind::Kirchhoff,
            patch_size: 100,
            keep: Keep::default(),
            border_residuals: false,
            band_slope: 1.0,
            predicted: true,
            dead_zone: 0.35,
        }
    }
}

impl SpectralParams {
    /// Checks every parameter's range: the operator is one the coder can use, the
    /// patch size in `MIN_PATCH..=MAX_PATCH`, the keep ratio in `(0, 1]` or the
    /// count at least 1, the band slope in `[0, MAX_BAND_SLOPE]`, the dead zone in
    /// `[MIN_DEAD_ZONE, MAX_DEAD_ZONE]`.
    pub fn validate(&self) -> Result<(), ParameterError> {
        if operator_code(self.operator).is_none() {
            return Err(ParameterError::Operator(self.operator));
        }
        if !(MIN_PATCH..=MAX_PATCH).contains(&self.patch_size) {
            return Err(ParameterError::PatchSize {
                got: self.patch_size,
                min: MIN_PATCH,
                max: MAX_PATCH,
            });
        }
        match self.keep {
            Keep::Ratio(r) if !(r > 0.0 && r <= 1.0) => return Err(ParameterError::KeepRatio(r)),
            Keep::Count(0) => return Err(ParameterError::Coefficients(0)),
            _ => {}
        }
        if !(0.0..=MAX_BAND_SLOPE).contains(&self.band_slope) {
            return Err(ParameterError::BandSlope {
                got: self.band_slope,
                max: MAX_BAND_SLOPE,
            });
        }
        if !(MIN_DEAD_ZONE..=MAX_DEAD_ZONE).contains(&self.dead_zone) {
            return Err(ParameterError::DeadZone {
                got: self.dead_zone,
                min: MIN_DEAD_ZONE,
                max: MAX_DEAD_ZONE,
            });
        }
        Ok(())
    }
}
