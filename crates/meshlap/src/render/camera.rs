//! The camera: an orthographic view along −z after turning the mesh by the azimuth
//! (about +y) and then the elevation (about +x), and the framing that maps the view
//! plane to the picture.
//!
//! Framing fits a [`Window`] of the view plane (camera x to the right, y up) into the
//! viewport, keeping the aspect ratio and leaving a margin of [`MARGIN`] of the
//! shorter side. [`Framing::Fit`] takes the window from the projected vertices of the
//! mesh itself, so the mesh fills the picture whatever the view; [`Framing::Sphere`]
//! takes it from a bounding sphere (the same for every view); [`Framing::Window`]
//! reuses a window, so several renders of one object (e.g. truncated
//! reconstructions beside the original) share one framing.

use crate::mesh::TriMesh;
use glam::{DMat3, DVec2, DVec3};

/// Fraction of the viewport's shorter side left empty around the framed window
/// (split evenly between the two sides).
pub const MARGIN: f64 = 0.05;

/// A rectangle of the view plane, in camera coordinates (x right, y up).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Window {
    /// Center `(x, y)`.
    pub center: [f64; 2],
    /// Half width and half height (positive).
    pub half_extent: [f64; 2],
}

/// How the view plane is mapped to the picture.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum Framing {
    /// Fit the bounding rectangle of the mesh's projected vertices (fills the picture
    /// for any azimuth and elevation).
    #[default]
    Fit,
    /// Fit the projection of the sphere `(center, radius)`: the same scale for every
    /// view.
    Sphere {
        /// Center in mesh coordinates.
        center: [f64; 3],
        /// Radius (positive).
        radius: f64,
    },
    /// Fit this window (from [`Window::fit`] on another mesh, for a shared framing).
    Window(Window),
}

/// The rotation into camera coordinates: azimuth (degrees) about +y, then elevation
/// (degrees) about +x.
pub fn rotation(azimuth: f64, elevation: f64) -> DMat3 {
    DMat3::from_rotation_x(elevation.to_radians()) * DMat3::from_rotation_y(azimuth.to_radians())
}

impl Window {
    /// The bounding rectangle of `mesh`'s vertices seen from `(azimuth, elevation)`
    /// (degrees); `None` for a mesh without vertices.
    pub fn fit(mesh: &TriMesh, azimuth: f64, elevation: f64) -> Option<Window> {
        let r = rotation(azimuth, elevation);
        let (lo, hi) =
            mesh.positions
                .iter()
                .fold((DVec2::INFINITY, DVec2::NEG_INFINITY), |(lo, hi), &p| {
                    let q = (r * DVec3::from(p)).truncate();
                    (lo.min(q), hi.max(q))
                });
        (lo.x <= hi.x).then(|| Window {
            center: ((lo + hi) * 0.5).to_array(),
            half_extent: ((hi - lo) * 0.5).to_array(),
        })
    }

    /// The projection of the sphere `(center, radius)` seen from `(azimuth,
    /// elevation)`.
    pub fn of_sphere(center: [f64; 3], radius: f64, azimuth: f64, elevation: f64) -> Window {
        let c = rotation(azimuth, elevation) * DVec3::from(center);
        Window {
            center: [c.x, c.y],
            half_extent: [radius, radius],
        }
    }
}

/// Bounding sphere used for framing: the center of the bounding box and the largest
/// distance of a vertex from it (`([0; 3], 0)` for a mesh without vertices).
pub fn bounding_sphere(mesh: &TriMesh) -> ([f64; 3], f64) {
    let Some((lo, hi)) = mesh.bounding_box() else {
        return ([0.0; 3], 0.0);
    };
    let c = (DVec3::from(lo) + DVec3::from(hi)) * 0.5;
    let r = mesh
        .positions
        .iter()
        .map(|&p| DVec3::from(p).distance(c))
        .fold(0.0, f64::max);
    (c.to_array(), r)
}

/// The map from mesh coordinates to picture coordinates `(x, y, depth)`: x to the
/// right, y down, larger depth nearer the viewer.
#[derive(Copy, Clone, Debug)]
pub struct Projection {
    rotation: DMat3,
    /// Pixels per mesh unit.
    scale: f64,
    /// Picture position of the camera origin.
    offset: DVec2,
}

impl Projection {
    /// Fits `window` into the `viewport` rectangle `(x0, y0, width, height)` of the
    /// picture (pixels), centered, with the [`MARGIN`]. A degenerate window (a point
    /// or a segment seen end-on) is widened to the other side's extent, or to 1.
    pub fn new(
        azimuth: f64,
        elevation: f64,
        window: &Window,
        viewport: (f64, f64, f64, f64),
    ) -> Projection {
        let (x0, y0, w, h) = viewport;
        let [mut hx, mut hy] = window.half_extent;
        let largest = hx.max(hy);
        let fallback = if largest > 0.0 { largest } else { 1.0 };
        if hx <= 0.0 {
            hx = fallback;
        }
        if hy <= 0.0 {
            hy = fallback;
        }
        let usable = 1.0 - MARGIN;
        let scale = (usable * w / (2.0 * hx)).min(usable * h / (2.0 * hy));
        let c = DVec2::from(window.center);
        let offset = DVec2::new(x0 + 0.5 * w - scale * c.x, y0 + 0.5 * h + scale * c.y);
        Projection {
            rotation: rotation(azimuth, elevation),
            scale,
            offset,
        }
    }

    /// The camera-frame direction of a mesh-frame vector (for normals).
    pub fn rotate(&self, v: DVec3) -> DVec3 {
        self.rotation * v
    }

    /// Picture `(x, y, depth)` of a mesh point.
    pub fn project(&self, p: [f64; 3]) -> DVec3 {
        let q = self.rotation * DVec3::from(p);
        DVec3::new(
            self.offset.x + self.scale * q.x,
            self.offset.y - self.scale * q.y,
            q.z,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_matches_the_documented_turns() {
        // Azimuth 90°: +x turns to −z (away from the viewer); elevation 90°: +y turns
        // towards the viewer (+z).
        let r = rotation(90.0, 0.0) * DVec3::X;
        assert!((r - DVec3::new(0.0, 0.0, -1.0)).length() < 1e-12, "{r}");
        let r = rotation(0.0, 90.0) * DVec3::Y;
        assert!((r - DVec3::Z).length() < 1e-12, "{r}");
    }

    #[test]
    fn a_window_fills_the_viewport_with_the_margin() {
        let w = Window {
            center: [1.0, 2.0],
            half_extent: [2.0, 1.0],
        };
        let p = Projection::new(0.0, 0.0, &w, (0.0, 0.0, 200.0, 100.0));
        // The wide window fits the width exactly (less the margin), centered.
        let a = p.project([-1.0, 2.0, 0.0]);
        let b = p.project([3.0, 2.0, 0.0]);
        assert!(
            (a.x - 5.0).abs() < 1e-9 && (b.x - 195.0).abs() < 1e-9,
            "{a} {b}"
        );
        assert!((a.y - 50.0).abs() < 1e-9);
        // y up in the view is y down in the picture
        assert!(p.project([1.0, 3.0, 0.0]).y < 50.0);
    }

    #[test]
    fn fit_and_sphere_windows() {
        let m = crate::mesh::builtin::icosahedron();
        let w = Window::fit(&m, 30.0, 10.0).unwrap();
        let (c, r) = bounding_sphere(&m);
        assert!(w.half_extent[0] <= r + 1e-12 && w.half_extent[1] <= r + 1e-12);
        let s = Window::of_sphere(c, r, 30.0, 10.0);
        assert_eq!(s.half_extent, [r, r]);
        assert!(Window::fit(&TriMesh::default(), 0.0, 0.0).is_none());
    }
}
