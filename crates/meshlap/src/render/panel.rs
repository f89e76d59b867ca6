//! [`Panel`]: several pictures side by side, each with a caption underneath, under an
//! optional title — the layout of the paper's figures.

use super::RenderError;
use crate::raster::text::{HAlign, TextStyle, VAlign};
use crate::raster::Image;

/// Several images side by side, each with a caption underneath.
#[derive(Clone, Debug, Default)]
pub struct Panel {
    /// `(image, caption)` pairs, left to right. Images may differ in size.
    pub cells: Vec<(Image, String)>,
    /// Optional title above the row.
    pub title: Option<String>,
}

impl Panel {
    /// Composes the row into one image: an 8-pixel gap around every cell, a 44-pixel
    /// title band when there is a title, and a 40-pixel caption band.
    pub fn compose(&self) -> Result<Image, RenderError> {
        if self.cells.is_empty() {
            return Err(RenderError::EmptyPanel);
        }
        let caption_h = 40u32;
        let title_h = if self.title.is_some() { 44 } else { 0 };
        let gap = 8u64;
        let width = self.cells.iter().map(|c| c.0.width as u64).sum::<u64>()
            + gap * (self.cells.len() as u64 + 1);
        let height = (title_h + caption_h) as u64
            + self
                .cells
                .iter()
                .map(|c| c.0.height as u64)
                .max()
                .unwrap_or(0);
        if width > 16384 || height > 16384 {
            return Err(RenderError::PanelSize { width, height });
        }
        let (width, height) = (width as u32, height as u32);
        let mut out = Image::filled(width, height, [255, 255, 255]);
        let centered = |size: f64| TextStyle::new(size).aligned(HAlign::Center, VAlign::Center);
        if let Some(t) = &self.title {
            out.draw_text(
                t,
                ((width / 2) as i64, (title_h / 2) as i64),
                &centered(26.0),
            );
        }
        let mut x0 = gap as i64;
        let caption_y = (height - caption_h / 2) as i64;
        for (img, caption) in &self.cells {
            out.blit(img, x0, title_h as i64);
            out.draw_text(
                caption,
                (x0 + img.width as i64 / 2, caption_y),
                &centered(20.0),
            );
            x0 += img.width as i64 + gap as i64;
        }
        Ok(out)
    }
}
