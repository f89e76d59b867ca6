//! What a render shows and how: [`RenderOptions`] and the surface [`Coloring`].

use super::camera::Framing;
use super::scalars::Scalars;

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

impl RenderOptions {
    /// Default width and height in pixels (`meshlap render` and `meshlap.render`).
    pub const DEFAULT_SIZE: u32 = 800;
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            width: Self::DEFAULT_SIZE,
            height: Self::DEFAULT_SIZE,
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
