//! Drawing a [`Chart`]: plotters draws the axes, ticks, grid and one polyline (and
//! markers) per series in a fixed color cycle on a [`Canvas`]; the legend is drawn
//! afterwards into the corner of the plot its lines cross least.

use super::axis::{coordinate, keep, range, Axis};
use super::canvas::Canvas;
use super::{Chart, PlotError};
use crate::raster::text::{self, HAlign, TextStyle, VAlign};
use crate::raster::Image;
use plotters::prelude::*;
use std::ops::Range;
use std::path::Path;

/// Color cycle (Tableau 10), distinguishable in print and for most color-blind readers.
const PALETTE: [[u8; 3]; 10] = [
    [31, 119, 180],
    [255, 127, 14],
    [44, 160, 44],
    [214, 39, 40],
    [148, 103, 189],
    [140, 86, 75],
    [227, 119, 194],
    [127, 127, 127],
    [188, 189, 34],
    [23, 190, 207],
];

/// Font sizes (pixels) of the title, the tick labels and the axis descriptions.
const TITLE_FONT: f64 = 26.0;
const LABEL_FONT: f64 = 15.0;
const DESC_FONT: f64 = 18.0;
/// Margin around the chart and the height of the x label area, pixels.
const MARGIN: u32 = 16;
const X_LABEL_AREA: u32 = 48;

fn draw_err(title: &str, e: impl std::error::Error + Send + Sync + 'static) -> PlotError {
    PlotError::Draw {
        title: title.to_string(),
        source: Box::new(e),
    }
}

/// Pixel rectangle of the plotting area and the axes it shows.
struct Frame {
    x_px: Range<i32>,
    y_px: Range<i32>,
    x: Axis,
    y: Axis,
}

impl Frame {
    /// Picture position of a point in drawing coordinates.
    fn pixel(&self, (cx, cy): (f64, f64)) -> (f64, f64) {
        let fx = (cx - self.x.lo) / (self.x.hi - self.x.lo);
        let fy = (cy - self.y.lo) / (self.y.hi - self.y.lo);
        (
            self.x_px.start as f64 + fx * (self.x_px.end - self.x_px.start) as f64,
            self.y_px.end as f64 - fy * (self.y_px.end - self.y_px.start) as f64,
        )
    }
}

impl Chart {
    /// Renders the chart into an RGB8 buffer of `width × height × 3` bytes.
    pub fn render_rgb(&self) -> Result<Vec<u8>, PlotError> {
        Ok(self.render()?.rgb)
    }

    /// Renders the chart into an image.
    pub fn render(&self) -> Result<Image, PlotError> {
        if self.width < 200 || self.height < 150 || self.width > 8192 || self.height > 8192 {
            return Err(PlotError::Size {
                width: self.width,
                height: self.height,
            });
        }
        // The points of each series in drawing coordinates (log10 on a log axis).
        let pts: Vec<Vec<(f64, f64)>> = self
            .series
            .iter()
            .map(|s| {
                s.points
                    .iter()
                    .filter(|&&(x, y)| keep(self.x_scale, x) && keep(self.y_scale, y))
                    .map(|&(x, y)| (coordinate(self.x_scale, x), coordinate(self.y_scale, y)))
                    .collect()
            })
            .collect();
        let kept = |scale, pick: fn(&(f64, f64)) -> f64| {
            self.series
                .iter()
                .flat_map(|s| s.points.iter())
                .filter(|&&(x, y)| keep(self.x_scale, x) && keep(self.y_scale, y))
                .map(pick)
                .filter(move |&v| keep(scale, v))
        };
        let empty = || PlotError::Empty(self.title.clone());
        let xr = range(kept(self.x_scale, |p| p.0), self.x_scale).ok_or_else(empty)?;
        let yr = range(kept(self.y_scale, |p| p.1), self.y_scale).ok_or_else(empty)?;

        // Axes: the y axis first (its labels set the width of the y label area).
        let title_h = if self.title.is_empty() {
            0
        } else {
            text::size(&self.title, TITLE_FONT).1 + 10
        };
        let plot_h = self
            .height
            .saturating_sub(2 * MARGIN + title_h + X_LABEL_AREA) as f64;
        let height_of = |_: &str| LABEL_FONT;
        let y = Axis::new(yr, self.y_scale, plot_h.max(20.0), &height_of, 6.0, 36.0);
        let widest = y
            .ticks
            .iter()
            .map(|(_, s)| text::size(s, LABEL_FONT).0)
            .max()
            .unwrap_or(0);
        let y_area = widest + 10 + text::size("Mg", DESC_FONT).1 + 14;
        let plot_w = self.width.saturating_sub(2 * MARGIN + y_area) as f64;
        let width_of = |s: &str| text::size(s, LABEL_FONT).0 as f64;
        let x = Axis::new(xr, self.x_scale, plot_w.max(20.0), &width_of, 14.0, 60.0);

        let mut image = Image::filled(self.width, self.height, [255, 255, 255]);
        let frame = {
            let root = Canvas::new(&mut image.rgb, (self.width, self.height)).into_drawing_area();
            let err = |e| draw_err(&self.title, e);
            let mut chart = ChartBuilder::on(&root)
                .caption(&self.title, ("sans-serif", TITLE_FONT))
                .margin(MARGIN)
                .x_label_area_size(X_LABEL_AREA)
                .y_label_area_size(y_area)
                .build_cartesian_2d(x.clone(), y.clone())
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_desc(self.x_label.as_str())
                .y_desc(self.y_label.as_str())
                .label_style(("sans-serif", LABEL_FONT))
                .axis_desc_style(("sans-serif", DESC_FONT))
                .x_label_formatter(&|v: &f64| x.label(*v))
                .y_label_formatter(&|v: &f64| y.label(*v))
                .draw()
                .map_err(err)?;
            for (i, (s, p)) in self.series.iter().zip(&pts).enumerate() {
                let [r, g, b] = PALETTE[i % PALETTE.len()];
                let color = RGBColor(r, g, b);
                chart
                    .draw_series(LineSeries::new(p.iter().copied(), color.stroke_width(2)))
                    .map_err(err)?;
                if s.markers {
                    chart
                        .draw_series(p.iter().map(|&q| Circle::new(q, 3, color.filled())))
                        .map_err(err)?;
                }
            }
            root.present().map_err(err)?;
            let (x_px, y_px) = chart.plotting_area().get_pixel_range();
            Frame { x_px, y_px, x, y }
        };
        self.draw_legend(&mut image, &frame, &pts);
        Ok(image)
    }

    /// The legend (series with a name): a framed box with a line sample (and marker)
    /// and the name per series, in the corner of the plot whose box the lines cross
    /// least (upper right on a tie).
    fn draw_legend(&self, image: &mut Image, frame: &Frame, pts: &[Vec<(f64, f64)>]) {
        let entries: Vec<(usize, &str, bool)> = self
            .series
            .iter()
            .enumerate()
            .filter(|(_, s)| !s.name.is_empty())
            .map(|(i, s)| (i, s.name.as_str(), s.markers))
            .collect();
        if entries.is_empty() {
            return;
        }
        let row = LABEL_FONT + 7.0;
        let name_w = entries
            .iter()
            .map(|e| text::size(e.1, LABEL_FONT).0)
            .max()
            .unwrap_or(0) as f64;
        let (bw, bh) = (
            8.0 + 24.0 + 8.0 + name_w + 10.0,
            8.0 + row * entries.len() as f64,
        );
        let (x0, x1) = (
            frame.x_px.start as f64 + 10.0,
            frame.x_px.end as f64 - 10.0 - bw,
        );
        let (y0, y1) = (
            frame.y_px.start as f64 + 10.0,
            frame.y_px.end as f64 - 10.0 - bh,
        );
        // Pixels the lines pass through, every 3 pixels along each segment.
        let mut samples = Vec::new();
        for p in pts {
            for w in p.windows(2) {
                let (a, b) = (frame.pixel(w[0]), frame.pixel(w[1]));
                let steps = ((b.0 - a.0).hypot(b.1 - a.1) / 3.0).ceil().max(1.0) as usize;
                samples.extend((0..=steps).map(|k| {
                    let t = k as f64 / steps as f64;
                    (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1))
                }));
            }
            if p.len() == 1 {
                samples.push(frame.pixel(p[0]));
            }
        }
        let crossings = |(bx, by): (f64, f64)| {
            samples
                .iter()
                .filter(|&&(x, y)| {
                    x >= bx - 4.0 && x <= bx + bw + 4.0 && y >= by - 4.0 && y <= by + bh + 4.0
                })
                .count()
        };
        let corners = [(x1, y0), (x0, y0), (x1, y1), (x0, y1)];
        let (bx, by) = corners
            .into_iter()
            .min_by_key(|&c| crossings(c))
            .unwrap_or(corners[0]);
        let (bx, by) = (bx.round() as i64, by.round() as i64);
        let (bw, bh) = (bw.round() as i64, bh.round() as i64);
        for yy in by..by + bh {
            for xx in bx..bx + bw {
                image.blend(xx, yy, [255, 255, 255], 0.85);
            }
        }
        let black = [0, 0, 0];
        image.fill_rect((bx, by), (bx + bw, by + 1), black);
        image.fill_rect((bx, by + bh - 1), (bx + bw, by + bh), black);
        image.fill_rect((bx, by), (bx + 1, by + bh), black);
        image.fill_rect((bx + bw - 1, by), (bx + bw, by + bh), black);
        let style = TextStyle::new(LABEL_FONT).aligned(HAlign::Left, VAlign::Center);
        for (k, &(i, name, markers)) in entries.iter().enumerate() {
            let color = PALETTE[i % PALETTE.len()];
            let cy = by + (4.0 + row * (k as f64 + 0.5)).round() as i64;
            image.fill_rect((bx + 8, cy - 1), (bx + 32, cy + 1), color);
            if markers {
                for dy in -3i64..=3 {
                    for dx in -3i64..=3 {
                        if dx * dx + dy * dy <= 9 {
                            image.blend(bx + 20 + dx, cy + dy, color, 1.0);
                        }
                    }
                }
            }
            image.draw_text(name, (bx + 40, cy), &style);
        }
    }

    /// Renders the chart and writes it as a PNG file, atomically.
    pub fn write_png(&self, path: &Path) -> Result<(), PlotError> {
        self.render()?.write_png(path)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plot::{Scale, Series};

    fn chart(y_scale: Scale) -> Chart {
        Chart {
            title: "test".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            y_scale,
            series: vec![
                Series::new(
                    "a",
                    (0..20).map(|i| (i as f64, (-(i as f64)).exp())).collect(),
                ),
                Series::new("b", vec![(0.0, 0.5), (10.0, 0.05), (19.0, 1e-6)]).with_markers(),
            ],
            width: 400,
            height: 300,
            ..Chart::default()
        }
    }

    #[test]
    fn renders_colored_lines_on_white() {
        for scale in [Scale::Linear, Scale::Log] {
            let rgb = chart(scale).render_rgb().unwrap();
            assert_eq!(rgb.len(), 400 * 300 * 3);
            let px: Vec<&[u8]> = rgb.chunks_exact(3).collect();
            let white = px.iter().filter(|p| p == &&[255, 255, 255]).count();
            let blue = px.iter().filter(|p| p == &&[31, 119, 180]).count();
            let orange = px.iter().filter(|p| p == &&[255, 127, 14]).count();
            assert!(white > px.len() / 2, "{scale:?}: background");
            assert!(blue > 100 && orange > 50, "{scale:?}: {blue} {orange}");
            // text was drawn (dark anti-aliased pixels besides the black axes)
            let gray = px
                .iter()
                .filter(|p| p[0] == p[1] && p[1] == p[2] && p[0] > 30 && p[0] < 200)
                .count();
            assert!(gray > 50, "{scale:?}: text pixels {gray}");
        }
    }

    #[test]
    fn writes_a_png_atomically() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.png");
        chart(Scale::Log).write_png(&path).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
        let dec = png::Decoder::new(std::io::Cursor::new(bytes));
        let reader = dec.read_info().unwrap();
        assert_eq!((reader.info().width, reader.info().height), (400, 300));
        // a failing chart leaves no file behind
        let bad = dir.path().join("bad.png");
        let empty = Chart {
            title: "empty".into(),
            ..Chart::default()
        };
        assert!(matches!(empty.write_png(&bad), Err(PlotError::Empty(_))));
        assert!(!bad.exists());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn legend_goes_where_the_lines_are_not() {
        // Lines falling from the upper left: the upper right corner is free.
        let mut c = chart(Scale::Linear);
        let rgb = c.render().unwrap();
        let frame_pixels = |img: &Image, x0: u32, x1: u32, y0: u32, y1: u32| {
            (y0..y1)
                .flat_map(|y| (x0..x1).map(move |x| (x, y)))
                .filter(|&(x, y)| img.pixel(x, y) == [0, 0, 0])
                .count()
        };
        assert!(frame_pixels(&rgb, 200, 400, 0, 150) > 50);
        // Rising lines: the legend moves to the upper left.
        for s in &mut c.series {
            for p in &mut s.points {
                p.1 = 1.0 - p.1;
            }
        }
        let img = c.render().unwrap();
        assert!(frame_pixels(&img, 200, 400, 0, 150) < frame_pixels(&img, 0, 200, 0, 150));
    }

    #[test]
    fn log_axis_drops_non_positive_values_and_rejects_all_non_positive() {
        let mut c = chart(Scale::Log);
        c.series = vec![Series::new("z", vec![(0.0, 0.0), (1.0, -1.0)])];
        assert!(matches!(c.render_rgb(), Err(PlotError::Empty(_))));
        c.series[0].points.push((2.0, 1.0));
        assert!(c.render_rgb().is_ok());
        c.width = 10;
        assert!(matches!(c.render_rgb(), Err(PlotError::Size { .. })));
    }
}
