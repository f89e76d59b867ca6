//! Scan conversion with a depth buffer, and the box filter down to the picture.
//!
//! Each triangle is scan-converted over its pixel bounding box with barycentric
//! coordinates at pixel centers; a sample is kept when it is nearer than the depth
//! stored there. Colors are interpolated from the corners (per-vertex colors), and
//! shaded by two-sided Lambert lighting — a key light from the upper left front and a
//! fill from the camera, with the absolute cosine so that back faces are lit like
//! front faces (open and inconsistently oriented meshes still read well) — of the
//! face normal (flat) or of the interpolated vertex normals (smooth).

use glam::DVec3;

/// Background color (white).
pub const BACKGROUND: [f64; 3] = [1.0, 1.0, 1.0];

/// What the rasterizer needs of a mesh, already projected.
pub(super) struct Scene<'a> {
    /// Triangles (vertex indices).
    pub faces: &'a [[u32; 3]],
    /// Picture position `(x, y, depth)` of each vertex, in samples.
    pub screen: Vec<DVec3>,
    /// Camera-frame position of each vertex (for normals).
    pub camera: Vec<DVec3>,
    /// The surface colors.
    pub colors: Colors,
    /// Interpolate vertex normals instead of shading faces flat.
    pub smooth: bool,
    /// Darken the samples near triangle edges.
    pub wireframe: bool,
}

/// Surface colors.
pub(super) enum Colors {
    /// One color (linear RGB in [0, 1]) everywhere.
    Uniform(DVec3),
    /// A position `t` on a color map per vertex. `t` is interpolated across each face
    /// and mapped per sample, so that every color shown is one of the map's (mapping
    /// at the vertices and interpolating colors would blend across the map).
    Mapped {
        /// Per vertex, 0 and 1 being the map's ends.
        t: Vec<f64>,
        /// The map.
        colormap: crate::raster::Colormap,
    },
}

fn normalize(v: DVec3) -> DVec3 {
    v.try_normalize().unwrap_or(DVec3::ZERO)
}

fn shade(normal: DVec3) -> f64 {
    let key = DVec3::new(-0.4, 0.6, 0.7).normalize();
    (0.18 + 0.62 * normal.dot(key).abs() + 0.25 * normal.z.abs()).min(1.0)
}

/// A `width × height` buffer of samples.
pub(super) struct Samples {
    width: usize,
    height: usize,
    color: Vec<DVec3>,
}

impl Samples {
    /// Rasterizes `scene` into a new `width × height` buffer on the background.
    pub fn rasterize(scene: &Scene, width: usize, height: usize) -> Samples {
        let faces = scene.faces;
        let cam = &scene.camera;
        let area_normal = |t: &[u32; 3]| {
            let [a, b, c] = t.map(|v| cam[v as usize]);
            (b - a).cross(c - a)
        };
        let face_normals: Vec<DVec3> = faces.iter().map(|t| normalize(area_normal(t))).collect();
        let vertex_normals: Option<Vec<DVec3>> = scene.smooth.then(|| {
            // area-weighted sums of the incident faces' normals
            let mut acc = vec![DVec3::ZERO; cam.len()];
            for t in faces {
                let n = area_normal(t);
                for &v in t {
                    acc[v as usize] += n;
                }
            }
            acc.into_iter().map(normalize).collect()
        });
        let mut depth = vec![f64::NEG_INFINITY; width * height];
        let mut color = vec![DVec3::from(BACKGROUND); width * height];
        for (fi, t) in faces.iter().enumerate() {
            let [p0, p1, p2] = t.map(|v| scene.screen[v as usize]);
            let area = (p1.x - p0.x) * (p2.y - p0.y) - (p2.x - p0.x) * (p1.y - p0.y);
            if area.abs() < 1e-12 {
                continue;
            }
            let xmin = p0.x.min(p1.x).min(p2.x).floor().max(0.0) as usize;
            let xmax = (p0.x.max(p1.x).max(p2.x).ceil() as isize).min(width as isize - 1);
            let ymin = p0.y.min(p1.y).min(p2.y).floor().max(0.0) as usize;
            let ymax = (p0.y.max(p1.y).max(p2.y).ceil() as isize).min(height as isize - 1);
            if xmax < 0 || ymax < 0 {
                continue;
            }
            let corner_t = match &scene.colors {
                Colors::Uniform(_) => [0.0; 3],
                Colors::Mapped { t: values, .. } => t.map(|v| values[v as usize]),
            };
            for y in ymin..=ymax as usize {
                let py = y as f64 + 0.5;
                for x in xmin..=xmax as usize {
                    let px = x as f64 + 0.5;
                    let b0 = ((p1.x - px) * (p2.y - py) - (p2.x - px) * (p1.y - py)) / area;
                    let b1 = ((p2.x - px) * (p0.y - py) - (p0.x - px) * (p2.y - py)) / area;
                    let b2 = 1.0 - b0 - b1;
                    if b0 < 0.0 || b1 < 0.0 || b2 < 0.0 {
                        continue;
                    }
                    let z = b0 * p0.z + b1 * p1.z + b2 * p2.z;
                    let idx = y * width + x;
                    if z <= depth[idx] {
                        continue;
                    }
                    depth[idx] = z;
                    let normal = match &vertex_normals {
                        None => face_normals[fi],
                        Some(vn) => {
                            let [a, b, c] = t.map(|v| vn[v as usize]);
                            normalize(b0 * a + b1 * b + b2 * c)
                        }
                    };
                    let edge = scene.wireframe && b0.min(b1).min(b2) < 0.04;
                    let light = shade(normal) * if edge { 0.55 } else { 1.0 };
                    color[idx] = match &scene.colors {
                        Colors::Uniform(c) => light * *c,
                        Colors::Mapped { colormap, .. } => {
                            let t = b0 * corner_t[0] + b1 * corner_t[1] + b2 * corner_t[2];
                            (0.5 + 0.5 * light) * DVec3::from(colormap.map(t))
                        }
                    };
                }
            }
        }
        Samples {
            width,
            height,
            color,
        }
    }

    /// Averages `factor × factor` blocks into 8-bit pixels written into `rgb` (an
    /// image `image_width` pixels wide) at `(x0, y0)`.
    pub fn downsample_into(
        &self,
        factor: usize,
        rgb: &mut [u8],
        image_width: usize,
        (x0, y0): (usize, usize),
    ) {
        let (ow, oh) = (self.width / factor, self.height / factor);
        let inv = 1.0 / (factor * factor) as f64;
        for y in 0..oh {
            for x in 0..ow {
                let mut acc = DVec3::ZERO;
                for dy in 0..factor {
                    for dx in 0..factor {
                        acc += self.color[(y * factor + dy) * self.width + x * factor + dx];
                    }
                }
                let i = 3 * ((y0 + y) * image_width + x0 + x);
                for (k, c) in (acc * inv).to_array().into_iter().enumerate() {
                    rgb[i + k] = (255.0 * c).round().clamp(0.0, 255.0) as u8;
                }
            }
        }
    }
}
