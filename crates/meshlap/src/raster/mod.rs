//! Raster images: the layer that charts ([`crate::plot`]) and mesh pictures
//! ([`crate::render`]) both draw on.
//!
//! - [`image`]: [`Image`], an RGB8 buffer (row-major, top row first) with alpha
//!   blending, rectangles, copies and text;
//! - [`png`]: PNG encoding, to memory or to a file written atomically through
//!   [`crate::io::write_atomic`] (a picture file is either complete or absent);
//! - [`text`]: the embedded font (Ubuntu Light from `epaint_default_fonts`, so no system
//!   font library is needed), line layout by advance widths and kerning, and
//!   anti-aliased glyph rasterization;
//! - [`number`]: short number labels for axis ticks and legends;
//! - [`colormap`]: color maps for scalar data (viridis; a diverging cool–warm map for
//!   signed data).
//!
//! Only built with the `pictures` feature.

pub mod colormap;
pub mod image;
pub mod number;
pub mod png;
pub mod text;

pub use colormap::Colormap;
pub use image::Image;
pub use text::{HAlign, Rotation, TextStyle, VAlign};
