//! Spectral mesh watermarking (Ohbuchi, Takahashi, Miyazawa, Mukaiyama, GI 2001;
//! Ohbuchi, Mukaiyama, Takahashi, CGF 2002; Zhang 2004 §4.9): a bit string is spread
//! by a keyed ±1 sequence over the low-frequency coefficients of the patch-wise
//! ED-transform of a combinatorial Laplacian (`F = D − W`, positive semi-definite).
//!
//! - [`embed()`] / [`detect()`]: embedding and non-blind detection with a rigorous
//!   false-positive probability; [`layout`] (patches, bases, slots), [`key`] (chips and
//!   permutation), [`message`] (hex ↔ bits), [`register`] (similarity registration),
//!   [`resample`] (onto the original's connectivity).

pub mod detect;
pub mod embed;
mod error;
pub mod key;
pub mod layout;
pub mod message;
pub mod register;
pub mod resample;

pub use detect::{detect, DetectParams, DetectReport, Detector};
pub use embed::{embed, EmbedParams, EmbedReport};
pub use error::WatermarkError;
pub use layout::LayoutParams;
pub use message::{Message, MessageError};

#[cfg(test)]
mod tests;
