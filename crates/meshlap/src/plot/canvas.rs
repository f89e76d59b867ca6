//! The plotters drawing backend of the charts: plotters' bitmap backend over an
//! [`Image`]'s pixels, with text measured and drawn by [`crate::raster::text`] instead
//! of plotters' own ab_glyph code (which leaves the glyphs' bearings out and so spaces
//! letters unevenly: "ob j", "GENER AL").

use crate::raster::text::{self, HAlign, Rotation, TextStyle, VAlign};
use plotters::backend::BitMapBackend;
use plotters_backend::text_anchor::{HPos, VPos};
use plotters_backend::{
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingBackend, DrawingErrorKind,
    FontTransform,
};

/// A bitmap backend whose text goes through [`crate::raster::text`].
pub(super) struct Canvas<'a> {
    inner: BitMapBackend<'a>,
}

impl<'a> Canvas<'a> {
    /// A canvas over an RGB8 buffer of `size.0 × size.1` pixels.
    pub fn new(rgb: &'a mut [u8], size: (u32, u32)) -> Self {
        Canvas {
            inner: BitMapBackend::with_buffer(rgb, size),
        }
    }
}

/// The raster text style of a plotters text style.
fn style_of<S: BackendTextStyle>(style: &S) -> TextStyle {
    let anchor = style.anchor();
    let c = style.color();
    TextStyle {
        size: style.size(),
        color: [c.rgb.0, c.rgb.1, c.rgb.2],
        h_align: match anchor.h_pos {
            HPos::Left => HAlign::Left,
            HPos::Center => HAlign::Center,
            HPos::Right => HAlign::Right,
        },
        v_align: match anchor.v_pos {
            VPos::Top => VAlign::Top,
            VPos::Center => VAlign::Center,
            VPos::Bottom => VAlign::Bottom,
        },
        rotation: match style.transform() {
            FontTransform::None => Rotation::None,
            FontTransform::Rotate90 => Rotation::Clockwise,
            FontTransform::Rotate180 => Rotation::Half,
            FontTransform::Rotate270 => Rotation::Counterclockwise,
        },
    }
}

type Result<E> = std::result::Result<(), DrawingErrorKind<E>>;

impl DrawingBackend for Canvas<'_> {
    type ErrorType = <BitMapBackend<'static> as DrawingBackend>::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.inner.get_size()
    }

    fn ensure_prepared(&mut self) -> Result<Self::ErrorType> {
        self.inner.ensure_prepared()
    }

    fn present(&mut self) -> Result<Self::ErrorType> {
        self.inner.present()
    }

    fn draw_pixel(&mut self, point: BackendCoord, color: BackendColor) -> Result<Self::ErrorType> {
        self.inner.draw_pixel(point, color)
    }

    fn draw_line<S: BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> Result<Self::ErrorType> {
        self.inner.draw_line(from, to, style)
    }

    fn draw_rect<S: BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> Result<Self::ErrorType> {
        self.inner.draw_rect(upper_left, bottom_right, style, fill)
    }

    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> Result<Self::ErrorType> {
        self.inner.draw_path(path, style)
    }

    fn draw_circle<S: BackendStyle>(
        &mut self,
        center: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> Result<Self::ErrorType> {
        self.inner.draw_circle(center, radius, style, fill)
    }

    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> Result<Self::ErrorType> {
        self.inner.fill_polygon(vert, style)
    }

    fn blit_bitmap(
        &mut self,
        pos: BackendCoord,
        size: (u32, u32),
        src: &[u8],
    ) -> Result<Self::ErrorType> {
        self.inner.blit_bitmap(pos, size, src)
    }

    fn draw_text<S: BackendTextStyle>(
        &mut self,
        label: &str,
        style: &S,
        pos: BackendCoord,
    ) -> Result<Self::ErrorType> {
        let alpha = style.color().alpha;
        if alpha == 0.0 {
            return Ok(());
        }
        let raster = style_of(style);
        let (w, h) = self.get_size();
        let mut result = Ok(());
        text::draw(
            label,
            &raster,
            (pos.0 as i64, pos.1 as i64),
            |x, y, coverage| {
                if result.is_ok() && x >= 0 && y >= 0 && x < w as i64 && y < h as i64 {
                    let color = BackendColor {
                        alpha: alpha * coverage as f64,
                        rgb: (raster.color[0], raster.color[1], raster.color[2]),
                    };
                    result = self.inner.draw_pixel((x as i32, y as i32), color);
                }
            },
        );
        result
    }

    fn estimate_text_size<S: BackendTextStyle>(
        &self,
        label: &str,
        style: &S,
    ) -> std::result::Result<(u32, u32), DrawingErrorKind<Self::ErrorType>> {
        Ok(text::size(label, style.size()))
    }
}
