//! [`render`]: a mesh to a picture — checks, framing, colors, scan conversion at
//! `supersample²` samples per pixel, the box filter, and the legend.

use super::camera::{Framing, Projection, Window};
use super::legend::Legend;
use super::options::{Coloring, RenderOptions, LEGEND_MIN_SIZE};
use super::zbuffer::{Colors, Samples, Scene, BACKGROUND};
use super::RenderError;
use crate::mesh::TriMesh;
use crate::raster::Image;
use glam::DVec3;

/// Uniform clay color (linear RGB).
const CLAY: [f64; 3] = [0.80, 0.72, 0.62];

fn check(mesh: &TriMesh, opts: &RenderOptions) -> Result<(), RenderError> {
    if mesh.faces.is_empty() {
        return Err(RenderError::Empty);
    }
    mesh.validate()?;
    if !(16..=8192).contains(&opts.width) || !(16..=8192).contains(&opts.height) {
        return Err(RenderError::Size {
            width: opts.width,
            height: opts.height,
        });
    }
    if !(1..=4).contains(&opts.supersample) {
        return Err(RenderError::Supersample(opts.supersample));
    }
    if !opts.azimuth.is_finite() || !opts.elevation.is_finite() {
        return Err(RenderError::ViewAngle);
    }
    match &opts.framing {
        Framing::Sphere { center, radius }
            if !(radius.is_finite() && *radius > 0.0 && center.iter().all(|c| c.is_finite())) =>
        {
            Err(RenderError::Framing)
        }
        Framing::Window(w)
            if !w.center.iter().chain(&w.half_extent).all(|c| c.is_finite())
                || w.half_extent.iter().any(|&h| h < 0.0) =>
        {
            Err(RenderError::Framing)
        }
        _ => Ok(()),
    }
}

/// Renders `mesh` (n vertices, triangles indexing them) to an RGB picture of
/// `opts.width × opts.height` pixels.
///
/// The view is orthographic along −z after turning the mesh by the azimuth about +y
/// and then the elevation about +x ([`super::camera`]); the framing fits the mesh (by
/// default its projected bounding rectangle) into the picture less a 5 % margin, and
/// less the legend's strip at the right when scalars are shown. Faces are shaded with
/// two-sided Lambert lighting, flat or smooth (the `zbuffer` module), on white.
///
/// Errors: a mesh without faces or with bad indices or coordinates; a size, supersampling,
/// view angle or framing out of range; scalars not one per vertex.
pub fn render(mesh: &TriMesh, opts: &RenderOptions) -> Result<Image, RenderError> {
    check(mesh, opts)?;
    let n = mesh.n_vertices();
    let (colors, legend) = match &opts.coloring {
        Coloring::Clay => (Colors::Uniform(DVec3::from(CLAY)), None),
        Coloring::Scalar(s) => {
            if s.values.len() != n {
                return Err(RenderError::ScalarCount {
                    got: s.values.len(),
                    expected: n,
                });
            }
            if let Some((lo, hi)) = s.range {
                if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                    return Err(RenderError::ScalarRange { lo, hi });
                }
            }
            let (lo, hi) = s.effective_range();
            let colors = Colors::Mapped {
                t: s.values.iter().map(|v| (v - lo) / (hi - lo)).collect(),
                colormap: s.colormap,
            };
            let room = opts.width >= LEGEND_MIN_SIZE.0 && opts.height >= LEGEND_MIN_SIZE.1;
            let legend = (opts.legend && room).then(|| Legend::new(s, (lo, hi), opts.height));
            (colors, legend)
        }
    };
    // The legend never takes more than a third of the width.
    let strip = legend.as_ref().map_or(0, |l| l.width.min(opts.width / 3));
    let window = match &opts.framing {
        Framing::Fit => {
            Window::fit(mesh, opts.azimuth, opts.elevation).ok_or(RenderError::Empty)?
        }
        Framing::Sphere { center, radius } => {
            Window::of_sphere(*center, *radius, opts.azimuth, opts.elevation)
        }
        Framing::Window(w) => *w,
    };
    let ss = opts.supersample as usize;
    let (w, h) = (opts.width as usize * ss, opts.height as usize * ss);
    let viewport = (
        0.0,
        0.0,
        ((opts.width - strip) as usize * ss) as f64,
        h as f64,
    );
    let projection = Projection::new(opts.azimuth, opts.elevation, &window, viewport);
    let scene = Scene {
        faces: &mesh.faces,
        screen: mesh
            .positions
            .iter()
            .map(|&p| projection.project(p))
            .collect(),
        camera: mesh
            .positions
            .iter()
            .map(|&p| projection.rotate(DVec3::from(p)))
            .collect(),
        colors,
        smooth: opts.smooth,
        wireframe: opts.wireframe,
    };
    let samples = Samples::rasterize(&scene, w, h);
    let background = BACKGROUND.map(|c| (255.0 * c) as u8);
    let mut image = Image::filled(opts.width, opts.height, background);
    samples.downsample_into(ss, &mut image.rgb, opts.width as usize, (0, 0));
    if let Some(legend) = legend {
        image.fill_rect(
            ((opts.width - strip) as i64, 0),
            (opts.width as i64, opts.height as i64),
            background,
        );
        legend.draw(&mut image, opts.width - strip);
    }
    Ok(image)
}
