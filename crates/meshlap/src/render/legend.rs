//! The legend of a scalar coloring: a vertical color bar at the right of the picture,
//! its range's ends (and zero, for a diverging map over a range that contains it) as
//! ticks with labels, and the caption running up along the bar.
//!
//! The legend takes a strip of the picture's right side; the mesh is framed in the
//! rest (see [`render`](super::render)).

use super::scalars::Scalars;
use crate::raster::number::compact;
use crate::raster::text::{self, HAlign, Rotation, TextStyle, VAlign};
use crate::raster::Image;

/// Top and bottom of the color bar as fractions of the picture height.
const BAR_SPAN: (f64, f64) = (0.15, 0.85);

/// The laid-out legend of one picture.
#[derive(Clone, Debug)]
pub(super) struct Legend {
    /// Width of the strip it takes, pixels.
    pub width: u32,
    font: f64,
    caption: String,
    colormap: crate::raster::Colormap,
    /// `(t, label)`: position along the bar (0 bottom, 1 top) and text.
    ticks: Vec<(f64, String)>,
}

impl Legend {
    /// The legend of `scalars` over `range` for a picture `height` pixels high.
    pub fn new(scalars: &Scalars, (lo, hi): (f64, f64), height: u32) -> Legend {
        let font = (height as f64 / 32.0).clamp(12.0, 22.0);
        let mut ticks = vec![(0.0, compact(lo, 3)), (1.0, compact(hi, 3))];
        if scalars.colormap.is_diverging() && lo < 0.0 && hi > 0.0 {
            ticks.push((-lo / (hi - lo), "0".to_string()));
        }
        let label_width = ticks
            .iter()
            .map(|(_, s)| text::size(s, font).0)
            .max()
            .unwrap_or(0) as f64;
        let caption_width = if scalars.label.is_empty() {
            0.0
        } else {
            text::size(&scalars.label, font).1 as f64 + 0.5 * font
        };
        let width =
            0.8 * font + caption_width + Self::bar_width(font) + 8.0 + label_width + 0.6 * font;
        Legend {
            width: width.ceil() as u32,
            font,
            caption: scalars.label.clone(),
            colormap: scalars.colormap,
            ticks,
        }
    }

    fn bar_width(font: f64) -> f64 {
        (0.9 * font).max(10.0).round()
    }

    /// Draws the legend into the strip of `image` starting at column `x0`.
    pub fn draw(&self, image: &mut Image, x0: u32) {
        let (top, bottom) = Self::bar_rows(image.height);
        let (top, bottom) = (top as f64, bottom as f64);
        let mut x = x0 as f64 + 0.8 * self.font;
        let black = [0, 0, 0];
        let style = TextStyle::new(self.font).with_color(black);
        if !self.caption.is_empty() {
            let at = (x as i64, (0.5 * (top + bottom)) as i64);
            let s = style
                .aligned(HAlign::Center, VAlign::Top)
                .rotated(Rotation::Counterclockwise);
            image.draw_text(&self.caption, at, &s);
            x += text::size(&self.caption, self.font).1 as f64 + 0.5 * self.font;
        }
        let (bx0, bx1) = (x as i64, (x + Self::bar_width(self.font)) as i64);
        let (by0, by1) = (top as i64, bottom as i64);
        for y in by0..=by1 {
            let t = (bottom - y as f64) / (bottom - top);
            image.fill_rect((bx0, y), (bx1, y + 1), self.colormap.map_rgb8(t));
        }
        // frame
        image.fill_rect((bx0 - 1, by0 - 1), (bx1 + 1, by0), black);
        image.fill_rect((bx0 - 1, by1 + 1), (bx1 + 1, by1 + 2), black);
        image.fill_rect((bx0 - 1, by0 - 1), (bx0, by1 + 2), black);
        image.fill_rect((bx1, by0 - 1), (bx1 + 1, by1 + 2), black);
        let label_style = style.aligned(HAlign::Left, VAlign::Center);
        for (t, label) in &self.ticks {
            let y = (bottom - t * (bottom - top)).round() as i64;
            image.fill_rect((bx1, y), (bx1 + 5, y + 1), black);
            image.draw_text(label, (bx1 + 8, y), &label_style);
        }
    }

    /// Picture rows of the bar's top (value `hi`) and bottom (value `lo`) for a picture
    /// `height` pixels high.
    pub fn bar_rows(height: u32) -> (u32, u32) {
        let h = height as f64;
        (
            (BAR_SPAN.0 * h).round() as u32,
            (BAR_SPAN.1 * h).round() as u32,
        )
    }
}
