//! Spectral mesh watermarking after Ohbuchi, Takahashi, Miyazawa and Mukaiyama (GI 2001)
//! and Ohbuchi, Mukaiyama and Takahashi (CGF 2002), the application of the
//! eigenvalue-decomposition transforms that Zhang (2004, §4.9) names beside spectral
//! compression: a bit stream is spread over the low-frequency spectral coefficients of
//! a mesh (per METIS patch, the eigenvectors of a combinatorial Laplacian `F = D − W`,
//! positive semi-definite) so that it survives attacks such as smoothing; detection is
//! non-blind (registration against the original, resampling, correlation).
//!
//! - [`attack`]: the attacks of the 3D mesh watermarking benchmark of Wang, Lavoué,
//!   Denis and Baskurt (SMI 2010) — noise, smoothing, quantization, similarity,
//!   simplification, subdivision, cropping — and the benchmark's strengths.
//!
//! - [`embed()`] / [`detect()`] ([`Detector`] for many suspects): embedding and
//!   non-blind detection with a rigorous false-positive probability; [`layout`]
//!   (patches, bases, slots), [`key`] (chips and permutation), [`message`] (hex ↔ bits),
//!   [`register`] (similarity registration), [`resample`] (onto the original's
//!   connectivity).
//!
//! The imperceptibility metric MSDM2 is [`crate::metric::msdm2`].

// `!(x > 0.0)` and friends reject NaN along with the out-of-range values, on purpose.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod attack;
pub mod detect;
pub mod embed;
mod error;
pub mod key;
pub mod layout;
pub mod message;
pub mod register;
pub mod resample;

pub use detect::{detect, DetectParams, DetectReport, Detector, Weighting};
pub use embed::{embed, EmbedParams, EmbedReport};
pub use error::WatermarkError;
pub use layout::LayoutParams;
pub use message::{Message, MessageError};

#[cfg(test)]
mod tests;
