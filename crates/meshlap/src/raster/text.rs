//! One line of text: layout and anti-aliased rasterization with the embedded font
//! (Ubuntu Light from `epaint_default_fonts`).
//!
//! Layout follows the font: the pen advances by each glyph's advance width plus the
//! kerning of the pair, and each glyph's outline is placed at the pen position *plus
//! its own bearing* (ab_glyph's pixel bounds of the positioned glyph). plotters' own
//! ab_glyph text drawing leaves the bearing out, so glyphs with a large or negative
//! left bearing shift against their neighbors ("obj" reads "ob j", "GENERAL"
//! "GENER AL"); the charts of [`crate::plot`] therefore draw their text through this
//! module too.
//!
//! Coordinates are pixels, x to the right and y down. The text box of a line is
//! `advance width × (ascent − descent)`; the baseline lies `ascent` below its top.

use ab_glyph::{point, Font, FontRef, PxScale, ScaleFont};
use std::sync::OnceLock;

/// The embedded font's file (TrueType).
pub const FONT_BYTES: &[u8] = epaint_default_fonts::UBUNTU_LIGHT;

/// The parsed embedded font; `None` only if the embedded file were corrupt, and then
/// text is measured as empty and not drawn (tested in this module).
fn font() -> Option<&'static FontRef<'static>> {
    static FONT: OnceLock<Option<FontRef<'static>>> = OnceLock::new();
    FONT.get_or_init(|| FontRef::try_from_slice(FONT_BYTES).ok())
        .as_ref()
}

/// Horizontal position of the anchor point on the text box.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub enum HAlign {
    /// The anchor is the left edge.
    #[default]
    Left,
    /// The anchor is the middle.
    Center,
    /// The anchor is the right edge.
    Right,
}

/// Vertical position of the anchor point on the text box.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub enum VAlign {
    /// The anchor is the top (the ascent line).
    #[default]
    Top,
    /// The anchor is the middle.
    Center,
    /// The anchor is the bottom (the descent line).
    Bottom,
}

/// Rotation of the text box about the anchor, as seen on the image (y down).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub enum Rotation {
    /// Left to right.
    #[default]
    None,
    /// A quarter turn clockwise: the text runs downwards.
    Clockwise,
    /// Upside down.
    Half,
    /// A quarter turn counterclockwise: the text runs upwards (vertical axis labels).
    Counterclockwise,
}

impl Rotation {
    /// Image offset of the text-box point `(x, y)` relative to the anchor.
    pub fn apply(self, x: i64, y: i64) -> (i64, i64) {
        match self {
            Rotation::None => (x, y),
            Rotation::Clockwise => (-y, x),
            Rotation::Half => (-x, -y),
            Rotation::Counterclockwise => (y, -x),
        }
    }
}

/// How a line of text is drawn.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct TextStyle {
    /// Font size in pixels: the height `ascent − descent` of the text box.
    pub size: f64,
    /// Text color.
    pub color: [u8; 3],
    /// Horizontal alignment on the anchor.
    pub h_align: HAlign,
    /// Vertical alignment on the anchor.
    pub v_align: VAlign,
    /// Rotation about the anchor.
    pub rotation: Rotation,
}

impl TextStyle {
    /// Black text of `size` pixels, anchored at its top-left corner.
    pub fn new(size: f64) -> Self {
        TextStyle {
            size,
            color: [0, 0, 0],
            h_align: HAlign::Left,
            v_align: VAlign::Top,
            rotation: Rotation::None,
        }
    }

    /// The same style with another color.
    pub fn with_color(mut self, color: [u8; 3]) -> Self {
        self.color = color;
        self
    }

    /// The same style with another alignment.
    pub fn aligned(mut self, h_align: HAlign, v_align: VAlign) -> Self {
        self.h_align = h_align;
        self.v_align = v_align;
        self
    }

    /// The same style, rotated.
    pub fn rotated(mut self, rotation: Rotation) -> Self {
        self.rotation = rotation;
        self
    }
}

/// The glyphs of `text` at `size` pixels, each with its pen position (advance widths
/// plus pair kerning), and the advance width of the whole line.
fn layout(
    font: &'static FontRef<'static>,
    text: &str,
    size: f64,
) -> (Vec<(ab_glyph::GlyphId, f32)>, f32) {
    let scaled = font.as_scaled(PxScale::from(size.max(0.0) as f32));
    let mut pen = 0.0f32;
    let mut previous = None;
    let mut glyphs = Vec::with_capacity(text.len());
    for c in text.chars() {
        let id = scaled.glyph_id(c);
        if let Some(p) = previous {
            pen += scaled.kern(p, id);
        }
        glyphs.push((id, pen));
        pen += scaled.h_advance(id);
        previous = Some(id);
    }
    (glyphs, pen)
}

/// Calls `glyph_pixel(x, y, coverage)` for every pixel the glyphs of `text` touch, in
/// text-box coordinates (origin at the top-left of the box, before any rotation).
fn rasterize(text: &str, size: f64, mut glyph_pixel: impl FnMut(i64, i64, f32)) {
    let Some(font) = font() else { return };
    let scale = PxScale::from(size.max(0.0) as f32);
    let ascent = font.as_scaled(scale).ascent();
    for (id, pen) in layout(font, text, size).0 {
        let glyph = id.with_scale_and_position(scale, point(pen, ascent));
        if let Some(outline) = font.outline_glyph(glyph) {
            let min = outline.px_bounds().min;
            // Coverage to the power 3/4 darkens the anti-aliased edges a little, which
            // keeps the thin strokes of the light font legible at small sizes.
            outline.draw(|x, y, coverage| {
                let alpha = coverage.clamp(0.0, 1.0).powf(0.75);
                glyph_pixel(min.x as i64 + x as i64, min.y as i64 + y as i64, alpha)
            });
        }
    }
}

/// Width and height (`ascent − descent`) in pixels of `text` at `size` pixels, rounded
/// up.
pub fn size(text: &str, size: f64) -> (u32, u32) {
    let Some(font) = font() else { return (0, 0) };
    let scaled = font.as_scaled(PxScale::from(size.max(0.0) as f32));
    let width = layout(font, text, size).1;
    let height = scaled.ascent() - scaled.descent();
    (width.ceil().max(0.0) as u32, height.ceil().max(0.0) as u32)
}

/// Calls `pixel(x, y, coverage)` for every image pixel of `text` drawn with `style`
/// and anchored at `at`: the anchor sits at the text box's point given by the
/// alignment, and the box is rotated about it.
pub fn draw(text: &str, style: &TextStyle, at: (i64, i64), mut pixel: impl FnMut(i64, i64, f32)) {
    let (w, h) = size(text, style.size);
    let (w, h) = (w as i64, h as i64);
    let dx = match style.h_align {
        HAlign::Left => 0,
        HAlign::Center => -w / 2,
        HAlign::Right => -w,
    };
    let dy = match style.v_align {
        VAlign::Top => 0,
        VAlign::Center => -h / 2,
        VAlign::Bottom => -h,
    };
    rasterize(text, style.size, |x, y, coverage| {
        let (rx, ry) = style.rotation.apply(x + dx, y + dy);
        pixel(at.0 + rx, at.1 + ry, coverage)
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Columns of a text line that hold ink, as runs `[start, end)`.
    fn ink_runs(text: &str, size: f64) -> Vec<(i64, i64)> {
        let mut columns = std::collections::BTreeSet::new();
        draw(text, &TextStyle::new(size), (0, 0), |x, _, c| {
            if c > 0.3 {
                columns.insert(x);
            }
        });
        let mut runs: Vec<(i64, i64)> = Vec::new();
        for x in columns {
            match runs.last_mut() {
                Some(r) if r.1 == x => r.1 = x + 1,
                _ => runs.push((x, x + 1)),
            }
        }
        runs
    }

    #[test]
    fn the_embedded_font_parses() {
        assert!(font().is_some());
        let (w, h) = size("Hello", 20.0);
        assert!(w > 30 && w < 70, "{w}");
        assert!((19..=22).contains(&h), "{h}");
        assert_eq!(size("", 20.0).0, 0);
    }

    #[test]
    fn glyph_gaps_follow_the_font_not_the_glyph_bounds() {
        // The gap between the glyphs of "obj" (the j has a negative left bearing) must
        // be no wider than the gap between the o and the b, which have ordinary
        // bearings; with the bearing left out, "obj" read "ob j".
        for size in [15.0, 18.0, 26.0] {
            let runs = ink_runs("obj", size);
            let gaps: Vec<i64> = runs.windows(2).map(|w| w[1].0 - w[0].1).collect();
            assert!(
                gaps.iter().all(|&g| g <= 2 + (size as i64) / 10),
                "{size}: runs {runs:?}"
            );
            // "AL" of "GENERAL": the L starts right after the A's right leg.
            let runs = ink_runs("AL", size);
            assert!(runs.len() <= 2, "{runs:?}");
            if runs.len() == 2 {
                assert!(runs[1].0 - runs[0].1 <= 1 + (size as i64) / 10, "{runs:?}");
            }
        }
    }

    #[test]
    fn alignment_and_rotation_place_the_box() {
        let bounds = |style: &TextStyle| {
            let (mut x0, mut y0, mut x1, mut y1) = (i64::MAX, i64::MAX, i64::MIN, i64::MIN);
            draw("Wide text", style, (100, 100), |x, y, _| {
                (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
            });
            (x0, y0, x1, y1)
        };
        let s = TextStyle::new(16.0);
        let (x0, y0, x1, _) = bounds(&s);
        assert!(x0 >= 99 && y0 >= 100 && x1 > 150);
        let (_, _, x1, y1) = bounds(&s.aligned(HAlign::Right, VAlign::Bottom));
        assert!(x1 <= 100 && y1 <= 100);
        let (x0, y0, x1, y1) = bounds(&s.aligned(HAlign::Center, VAlign::Center));
        assert!(x0 < 100 && x1 > 100 && y0 < 100 && y1 > 100);
        // Counterclockwise: the text runs upwards from the anchor, to its right.
        let (x0, y0, x1, y1) = bounds(&s.rotated(Rotation::Counterclockwise));
        assert!(
            y1 <= 101 && y0 < 60 && x0 >= 100 && x1 < 120,
            "{x0} {y0} {x1} {y1}"
        );
    }
}
