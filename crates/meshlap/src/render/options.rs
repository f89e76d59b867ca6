//! What a render shows and how: [`RenderOptions`] and the surface [`Coloring`].

use super::camera::Framing;
use crate::raster::Colormap;

/// Per-vertex scalars shown through a color map, with a legend.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Scalars {
    /// One value per vertex (non-finite values get the map's low end).
    pub values: Vec<f64>,
    /// The color map.
    pub colormap: Colormap,
    /// The values mapped to the two ends of the map; `None`: the map's
    /// [`default_range`](Colormap::default_range) of `values` (min to max, or
    /// symmetric about zero for a diverging map).
    pub range: Option<(f64, f64)>,
    /// Caption of the legend (may be empty).
    pub label: String,
}

impl Scalars {
    /// `values` through `colormap` over their default range, without a caption.
    pub fn new(values: Vec<f64>, colormap: Colormap) -> Self {
        Scalars {
            values,
            colormap,
            range: None,
            label: String::new(),
        }
    }

    /// The same scalars with a legend caption.
    pub fn with_label(mut self, label: impl Into<String>) -> Self {
        self.label = label.into();
        self
    }

    /// The range mapped to the ends of the color map: [`Scalars::range`] or the
    /// default; `(0, 1)` when no value is finite. A range of zero width is widened to
    /// `lo ± ½` so that a constant gets the middle color.
    pub fn effective_range(&self) -> (f64, f64) {
        let (lo, hi) = self
            .range
            .or_else(|| self.colormap.default_range(&self.values))
            .unwrap_or((0.0, 1.0));
        if hi > lo {
            (lo, hi)
        } else {
            (lo - 0.5, lo + 0.5)
        }
    }
}

/// How faces are colored.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum Coloring {
    /// A uniform clay color.
    #[default]
    Clay,
    /// Per-vertex scalars through a color map, interpolated across faces.
    Scalar(Scalars),
}

/// Options of [`render`](super::render).
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// Picture width in pixels (16 … 8192).
    pub width: u32,
    /// Picture height in pixels (16 … 8192).
    pub height: u32,
    /// Rotation about the vertical (+y) axis, degrees.
    pub azimuth: f64,
    /// Rotation about the horizontal (+x) axis after the azimuth, degrees.
    pub elevation: f64,
    /// Interpolate vertex normals (smooth shading) instead of flat faces.
    pub smooth: bool,
    /// Draw triangle edges darker (only visible when triangles are a few pixels wide).
    pub wireframe: bool,
    /// Samples per pixel along each axis (1 … 4).
    pub supersample: u32,
    /// Face colors.
    pub coloring: Coloring,
    /// How the view is fitted to the picture.
    pub framing: Framing,
    /// Draw a color bar for [`Coloring::Scalar`] at the right (pictures at least
    /// [`LEGEND_MIN_SIZE`] in both directions; smaller ones get none).
    pub legend: bool,
}

/// The smallest width and height, in pixels, of a picture that gets a legend.
pub const LEGEND_MIN_SIZE: (u32, u32) = (160, 120);

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            width: 640,
            height: 640,
            azimuth: 0.0,
            elevation: 0.0,
            smooth: false,
            wireframe: false,
            supersample: 2,
            coloring: Coloring::Clay,
            framing: Framing::Fit,
            legend: true,
        }
    }
}
