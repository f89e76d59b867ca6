//! Drawing a [`Chart`] with plotters: axes with ticks, grid, one polyline (and
//! markers) per series in a fixed color cycle, and a legend.

use super::axis::{fmt_tick, keep, range};
use super::{Chart, PlotError, Scale};
use crate::raster::Image;
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

/// Color cycle (Tableau 10), distinguishable in print and for most color-blind readers.
const PALETTE: [(u8, u8, u8); 10] = [
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (127, 127, 127),
    (188, 189, 34),
    (23, 190, 207),
];

/// Registers the embedded font with plotters under the family name `sans-serif`
/// (idempotent).
fn register_fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The embedded font is known to parse (tested in `raster::text`); a failure
        // would only lose text, and is reported by the first draw call.
        let _ = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            crate::raster::text::FONT_BYTES,
        );
    });
}

fn draw_err(title: &str, e: impl std::error::Error + Send + Sync + 'static) -> PlotError {
    PlotError::Draw {
        title: title.to_string(),
        source: Box::new(e),
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
        register_fonts();
        let pts: Vec<Vec<(f64, f64)>> = self
            .series
            .iter()
            .map(|s| {
                s.points
                    .iter()
                    .copied()
                    .filter(|&(x, y)| keep(self.x_scale, x) && keep(self.y_scale, y))
                    .collect()
            })
            .collect();
        let all = || pts.iter().flatten();
        let empty = || PlotError::Empty(self.title.clone());
        let xr = range(all().map(|p| p.0), self.x_scale).ok_or_else(empty)?;
        let yr = range(all().map(|p| p.1), self.y_scale).ok_or_else(empty)?;

        let mut image = Image::filled(self.width, self.height, [255, 255, 255]);
        {
            let root = BitMapBackend::with_buffer(&mut image.rgb, (self.width, self.height))
                .into_drawing_area();
            root.fill(&WHITE).map_err(|e| draw_err(&self.title, e))?;
            // One code path per axis-scale combination: plotters encodes the scale in
            // the coordinate type.
            macro_rules! draw {
                ($xs:expr, $ys:expr) => {{
                    let mut chart = ChartBuilder::on(&root)
                        .caption(&self.title, ("sans-serif", 26))
                        .margin(16)
                        .x_label_area_size(48)
                        .y_label_area_size(80)
                        .build_cartesian_2d($xs, $ys)
                        .map_err(|e| draw_err(&self.title, e))?;
                    chart
                        .configure_mesh()
                        .x_desc(self.x_label.as_str())
                        .y_desc(self.y_label.as_str())
                        .label_style(("sans-serif", 15))
                        .axis_desc_style(("sans-serif", 18))
                        .y_label_formatter(&|v: &f64| fmt_tick(*v))
                        .x_label_formatter(&|v: &f64| fmt_tick(*v))
                        .draw()
                        .map_err(|e| draw_err(&self.title, e))?;
                    for (i, (s, p)) in self.series.iter().zip(&pts).enumerate() {
                        let (r, g, b) = PALETTE[i % PALETTE.len()];
                        let color = RGBColor(r, g, b);
                        let style = color.stroke_width(2);
                        chart
                            .draw_series(LineSeries::new(p.iter().copied(), style))
                            .map_err(|e| draw_err(&self.title, e))?
                            .label(s.name.as_str())
                            .legend(move |(x, y)| {
                                PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                            });
                        if s.markers {
                            chart
                                .draw_series(p.iter().map(|&q| Circle::new(q, 3, color.filled())))
                                .map_err(|e| draw_err(&self.title, e))?;
                        }
                    }
                    if self.series.iter().any(|s| !s.name.is_empty()) {
                        chart
                            .configure_series_labels()
                            .position(SeriesLabelPosition::UpperRight)
                            .background_style(WHITE.mix(0.85))
                            .border_style(BLACK)
                            .label_font(("sans-serif", 15))
                            .draw()
                            .map_err(|e| draw_err(&self.title, e))?;
                    }
                }};
            }
            match (self.x_scale, self.y_scale) {
                (Scale::Linear, Scale::Linear) => draw!(xr.0..xr.1, yr.0..yr.1),
                (Scale::Linear, Scale::Log) => draw!(xr.0..xr.1, (yr.0..yr.1).log_scale()),
                (Scale::Log, Scale::Linear) => draw!((xr.0..xr.1).log_scale(), yr.0..yr.1),
                (Scale::Log, Scale::Log) => {
                    draw!((xr.0..xr.1).log_scale(), (yr.0..yr.1).log_scale())
                }
            }
            root.present().map_err(|e| draw_err(&self.title, e))?;
        }
        Ok(image)
    }

    /// Renders the chart and writes it as a PNG file, atomically.
    pub fn write_png(&self, path: &Path) -> Result<(), PlotError> {
        let rgb = self.render_rgb()?;
        crate::raster::png::write(path, self.width, self.height, &rgb)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plot::Series;

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
            let grey = px
                .iter()
                .filter(|p| p[0] == p[1] && p[1] == p[2] && p[0] > 30 && p[0] < 200)
                .count();
            assert!(grey > 50, "{scale:?}: text pixels {grey}");
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
