//! [`Image`]: an RGB8 pixel buffer, row-major, top row first — what every picture of
//! the crate is drawn into, and what the Python bindings hand out as an `(H, W, 3)`
//! `uint8` array.

use super::text::{self, TextStyle};
use std::path::Path;

/// An RGB8 image, row-major, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width·height·3` bytes: red, green, blue of each pixel.
    pub rgb: Vec<u8>,
}

impl Image {
    /// A blank image of one color.
    pub fn filled(width: u32, height: u32, color: [u8; 3]) -> Self {
        let rgb = color
            .iter()
            .copied()
            .cycle()
            .take(width as usize * height as usize * 3)
            .collect();
        Image { width, height, rgb }
    }

    /// The pixel at `(x, y)`. Panics outside the image, like slice indexing.
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 3] {
        let i = self.index(x, y);
        [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]]
    }

    fn index(&self, x: u32, y: u32) -> usize {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside the image"
        );
        3 * (y as usize * self.width as usize + x as usize)
    }

    /// Mixes `color` into the pixel at `(x, y)` with opacity `alpha ∈ [0, 1]`; points
    /// outside the image are ignored.
    pub fn blend(&mut self, x: i64, y: i64, color: [u8; 3], alpha: f32) {
        if x < 0 || y < 0 || x >= self.width as i64 || y >= self.height as i64 {
            return;
        }
        let a = alpha.clamp(0.0, 1.0);
        let i = self.index(x as u32, y as u32);
        for (k, &c) in color.iter().enumerate() {
            let old = self.rgb[i + k] as f32;
            self.rgb[i + k] = (old + (c as f32 - old) * a).round() as u8;
        }
    }

    /// Fills the rectangle `[x0, x1) × [y0, y1)` (clipped to the image).
    pub fn fill_rect(&mut self, (x0, y0): (i64, i64), (x1, y1): (i64, i64), color: [u8; 3]) {
        for y in y0.max(0)..y1.min(self.height as i64) {
            for x in x0.max(0)..x1.min(self.width as i64) {
                self.blend(x, y, color, 1.0);
            }
        }
    }

    /// Copies `src` with its top-left corner at `(x, y)` (clipped to the image).
    pub fn blit(&mut self, src: &Image, x: i64, y: i64) {
        for sy in 0..src.height {
            let ty = y + sy as i64;
            if ty < 0 || ty >= self.height as i64 {
                continue;
            }
            for sx in 0..src.width {
                let tx = x + sx as i64;
                if tx >= 0 && tx < self.width as i64 {
                    self.blend(tx, ty, src.pixel(sx, sy), 1.0);
                }
            }
        }
    }

    /// Draws one line of text anchored at `at` (see [`TextStyle`] for the alignment).
    pub fn draw_text(&mut self, label: &str, at: (i64, i64), style: &TextStyle) {
        text::draw(label, style, at, |x, y, coverage| {
            self.blend(x, y, style.color, coverage)
        });
    }

    /// The PNG encoding of the image (fails only when `rgb` does not hold
    /// `width·height·3` bytes or a side is zero).
    pub fn to_png(&self) -> std::io::Result<Vec<u8>> {
        super::png::encode(self.width, self.height, &self.rgb)
    }

    /// Writes the image as a PNG file, atomically (complete or absent).
    pub fn write_png(&self, path: &Path) -> Result<(), crate::io::IoError> {
        super::png::write(path, self.width, self.height, &self.rgb)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blend_fill_blit_and_clipping() {
        let mut img = Image::filled(4, 3, [255, 255, 255]);
        img.blend(1, 1, [0, 0, 0], 0.5);
        assert_eq!(img.pixel(1, 1), [128, 128, 128]);
        img.blend(-1, 7, [0, 0, 0], 1.0); // outside: ignored
        img.fill_rect((2, 0), (9, 2), [10, 20, 30]);
        assert_eq!(img.pixel(3, 1), [10, 20, 30]);
        assert_eq!(img.pixel(1, 0), [255, 255, 255]);
        let mut big = Image::filled(5, 5, [0, 0, 0]);
        big.blit(&img, 3, -1);
        assert_eq!(big.pixel(4, 0), [128, 128, 128]);
        assert_eq!(big.pixel(3, 0), [255, 255, 255]);
        assert_eq!(big.pixel(2, 2), [0, 0, 0]);
    }

    #[test]
    fn text_darkens_pixels_inside_its_box_only() {
        let mut img = Image::filled(120, 40, [255, 255, 255]);
        let style = TextStyle::new(20.0);
        img.draw_text("obj", (10, 10), &style);
        let (w, h) = text::size("obj", 20.0);
        let dark = |x0: u32, x1: u32, y0: u32, y1: u32| {
            (y0..y1)
                .flat_map(|y| (x0..x1).map(move |x| (x, y)))
                .filter(|&(x, y)| img.pixel(x, y)[0] < 128)
                .count()
        };
        assert!(dark(10, 10 + w, 10, 10 + h) > 30);
        assert_eq!(dark(0, 120, 0, 9), 0);
        assert_eq!(dark(12 + w, 120, 0, 40), 0);
    }
}
