//! The spectral geometry header: what the decoder needs to rebuild the encoder's
//! patches, bases and steps, stored after the geometry section's mode byte.
//!
//! ```text
//! operator          u8       0 Kirchhoff, 1 Tutte, 2 graph, 3 SQL, 4 SSTL
//! patch size        u32 LE   MIN_PATCH..=MAX_PATCH (4..=1000)
//! coefficient rule  u8, f64 LE   0: keep ratio in (0, 1]; 1: count ≥ 1
//! step              f64 LE   > 0
//! border residuals  u8       0 or 1
//! band slope        f64 LE   in [0, MAX_BAND_SLOPE] ([0, 16])
//! prediction        u8       0 or 1
//! ```
//!
//! The dead zone is encoder-side only and not stored.

use super::params::{
    operator_code, Keep, SpectralParams, MAX_BAND_SLOPE, MAX_DEAD_ZONE, MAX_PATCH, MIN_PATCH,
    OPERATORS,
};
use crate::codec::container::ByteReader;
use crate::codec::{CodecError, ParameterError};

/// The parameters a spectral geometry stream starts with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Header {
    /// Coder parameters (the dead zone is not stored: `MAX_DEAD_ZONE`, plain
    /// rounding, when read).
    pub params: SpectralParams,
    /// Global quantization step `Δ`.
    pub step: f64,
}

impl Header {
    /// Appends the header to `out`.
    pub fn write(&self, out: &mut Vec<u8>) -> Result<(), CodecError> {
        let p = &self.params;
        let op = operator_code(p.operator).ok_or(ParameterError::Operator(p.operator))?;
        out.push(op);
        out.extend_from_slice(&(p.patch_size as u32).to_le_bytes());
        let (rule, value) = match p.keep {
            Keep::Ratio(r) => (0, r),
            Keep::Count(m) => (1, m as f64),
        };
        out.push(rule);
        out.extend_from_slice(&value.to_le_bytes());
        out.extend_from_slice(&self.step.to_le_bytes());
        out.push(p.border_residuals as u8);
        out.extend_from_slice(&p.band_slope.to_le_bytes());
        out.push(p.predicted as u8);
        Ok(())
    }

    /// Reads a header, checking every field's range.
    pub fn read(r: &mut ByteReader) -> Result<Self, CodecError> {
        let operator = *OPERATORS
            .get(r.u8()? as usize)
            .ok_or(CodecError::Corrupt("unknown operator"))?;
        let patch_size = r.u32()? as usize;
        if !(MIN_PATCH..=MAX_PATCH).contains(&patch_size) {
            return Err(CodecError::Corrupt("patch size out of range"));
        }
        let keep = match r.u8()? {
            0 => {
                let x = r.f64()?;
                if !(x > 0.0 && x <= 1.0) {
                    return Err(CodecError::Corrupt("keep ratio out of range"));
                }
                Keep::Ratio(x)
            }
            1 => {
                let x = r.f64()?;
                if !(1.0..=u32::MAX as f64).contains(&x) {
                    return Err(CodecError::Corrupt("coefficient count out of range"));
                }
                Keep::Count(x as u32)
            }
            _ => return Err(CodecError::Corrupt("unknown coefficient rule")),
        };
        let step = r.f64()?;
        if step <= 0.0 {
            return Err(CodecError::Corrupt("non-positive quantization step"));
        }
        let border_residuals = r.flag("bad border flag")?;
        let band_slope = r.f64()?;
        if !(0.0..=MAX_BAND_SLOPE).contains(&band_slope) {
            return Err(CodecError::Corrupt("band slope out of range"));
        }
        let predicted = r.flag("bad prediction flag")?;
        Ok(Header {
            params: SpectralParams {
                operator,
                patch_size,
                keep,
                border_residuals,
                band_slope,
                predicted,
                dead_zone: MAX_DEAD_ZONE,
            },
            step,
        })
    }
}
