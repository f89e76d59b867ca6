//! The integer range both geometry coders quantize into.
//!
//! Quantized values are coded as integers of magnitude below `2^31`, so that they fit
//! an `i32` and `q·Δ` is exact in `f64`; a step so fine that a value exceeds this is
//! refused ([`CodecError::StepTooSmall`]; rate control treats it as "too large a
//! file").

use super::CodecError;

/// Largest magnitude (exclusive) of a quantized value.
const LIMIT: f64 = (1u64 << 31) as f64;

/// The integer-valued `q` as a coded integer, [`CodecError::StepTooSmall`] unless
/// `|q| < 2^31`.
pub(super) fn checked(q: f64) -> Result<i64, CodecError> {
    if q.abs() < LIMIT {
        Ok(q as i64)
    } else {
        Err(CodecError::StepTooSmall)
    }
}

/// Dead-zone quantizer `sign(v)·⌊|v|/s + θ⌋` (`θ = ½`: rounding to the nearest).
pub(super) fn dead_zone(v: f64, s: f64, theta: f64) -> Result<i64, CodecError> {
    checked(((v / s).abs() + theta).floor().copysign(v))
}

/// Rounding to the nearest multiple of `s`: `round(v/s)` (halves away from zero).
pub(super) fn nearest(v: f64, s: f64) -> Result<i64, CodecError> {
    dead_zone(v, s, 0.5)
}
