//! Pictures of meshes: a small software rasteriser (z-buffer, flat or smooth Lambert
//! shading, optional per-vertex scalar colouring) so that the experiments can show what
//! the paper shows in its figures (Fig. 1: GL versus GSML truncated reconstructions;
//! Fig. 4: KL artifacts at low-degree vertices) with no GPU, window system or external
//! renderer.
//!
//! Written by hand because no maintained crate rasterises a triangle mesh to a PNG
//! without a GPU context (`wgpu`/`three-d` need one; `tiny-skia` is a 2-D vector
//! renderer with no depth buffer). The algorithm is the textbook one: vertices are
//! rotated into a camera frame (azimuth about +y, then elevation about +x), projected
//! orthographically to fit the bounding sphere, and each triangle is scan-converted over
//! its pixel bounding box with barycentric coordinates and a depth test, at `supersample²`
//! samples per pixel, box-filtered down.
//!
//! Shading is two-sided (back faces are lit like front faces, so open meshes and
//! inconsistently oriented ones still read well); colours come from the `Colouring`.
//! [`Panel`] composes several renders side by side with captions, using the same
//! embedded font as [`crate::plot`].

use crate::mesh::TriMesh;
use plotters::prelude::*;
use std::path::Path;

/// Errors of rendering.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// Nothing to draw.
    #[error("nothing to render: the mesh has no faces")]
    Empty,
    /// A parameter is out of range.
    #[error("invalid render option: {0}")]
    Invalid(String),
    /// A face index is out of range or a coordinate is not finite.
    #[error(transparent)]
    Mesh(#[from] crate::mesh::MeshError),
    /// Drawing captions failed.
    #[error("cannot draw caption: {0}")]
    Caption(String),
    /// Writing the PNG failed.
    #[error(transparent)]
    Io(#[from] crate::io::IoError),
}

/// How faces are coloured.
#[derive(Clone, Debug, Default)]
pub enum Colouring {
    /// A uniform clay colour.
    #[default]
    Clay,
    /// Per-vertex scalars mapped through a perceptually uniform colour map (viridis-like)
    /// between the given bounds (`None`: the scalars' own min and max).
    Scalar {
        /// One value per vertex.
        values: Vec<f64>,
        /// Colour-map range.
        range: Option<(f64, f64)>,
    },
}

/// Options of [`render`].
#[derive(Clone, Debug)]
pub struct RenderOptions {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Rotation about the vertical (+y) axis, degrees.
    pub azimuth: f64,
    /// Rotation about the horizontal (+x) axis after the azimuth, degrees.
    pub elevation: f64,
    /// Interpolate vertex normals (smooth shading) instead of flat faces.
    pub smooth: bool,
    /// Draw triangle edges darker (only visible when triangles are a few pixels wide).
    pub wireframe: bool,
    /// Samples per pixel along each axis (1–4).
    pub supersample: u32,
    /// Face colours.
    pub colouring: Colouring,
    /// Fit the view to this bounding sphere `(centre, radius)` instead of the mesh's own,
    /// so several renders of the same object share one framing.
    pub frame: Option<([f64; 3], f64)>,
}

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
            colouring: Colouring::Clay,
            frame: None,
        }
    }
}

/// An RGB8 image, row-major, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width·height·3` bytes.
    pub rgb: Vec<u8>,
}

impl Image {
    /// A blank image of one colour.
    pub fn filled(width: u32, height: u32, colour: [u8; 3]) -> Self {
        let rgb = colour
            .iter()
            .copied()
            .cycle()
            .take(width as usize * height as usize * 3)
            .collect();
        Image { width, height, rgb }
    }

    /// The pixel at `(x, y)`.
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 3] {
        let i = 3 * (y as usize * self.width as usize + x as usize);
        [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]]
    }

    /// Writes the image as a PNG, atomically.
    pub fn write_png(&self, path: &Path) -> Result<(), RenderError> {
        write_rgb_png(path, self.width, self.height, &self.rgb)?;
        Ok(())
    }
}

/// Encodes an RGB8 buffer (`width·height·3` bytes, top row first) as PNG and writes it
/// through [`crate::io::write_atomic`].
pub(crate) fn write_rgb_png(
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[u8],
) -> Result<(), crate::io::IoError> {
    crate::io::write_atomic(path, |out| {
        let mut enc = png::Encoder::new(out, width, height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_compression(png::Compression::Best);
        let mut writer = enc.write_header().map_err(std::io::Error::other)?;
        writer
            .write_image_data(rgb)
            .map_err(std::io::Error::other)?;
        writer.finish().map_err(std::io::Error::other)
    })
}

const BACKGROUND: [f64; 3] = [1.0, 1.0, 1.0];
const CLAY: [f64; 3] = [0.80, 0.72, 0.62];

/// Bounding sphere used for framing: the centre of the bounding box and the largest
/// distance of a vertex from it.
pub fn bounding_sphere(mesh: &TriMesh) -> ([f64; 3], f64) {
    let Some((lo, hi)) = mesh.bounding_box() else {
        return ([0.0; 3], 0.0);
    };
    let c = [
        0.5 * (lo[0] + hi[0]),
        0.5 * (lo[1] + hi[1]),
        0.5 * (lo[2] + hi[2]),
    ];
    let r2 = mesh
        .positions
        .iter()
        .map(|p| (p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2))
        .fold(0.0, f64::max);
    (c, r2.sqrt())
}

/// Viridis-like colour map on `t ∈ [0, 1]` (piecewise linear through 6 samples of
/// matplotlib's viridis).
fn colour_map(t: f64) -> [f64; 3] {
    const STOPS: [[f64; 3]; 6] = [
        [0.267, 0.005, 0.329],
        [0.253, 0.265, 0.530],
        [0.164, 0.471, 0.558],
        [0.135, 0.659, 0.518],
        [0.478, 0.821, 0.319],
        [0.993, 0.906, 0.144],
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let s = t * (STOPS.len() - 1) as f64;
    let i = (s.floor() as usize).min(STOPS.len() - 2);
    let f = s - i as f64;
    std::array::from_fn(|k| STOPS[i][k] * (1.0 - f) + STOPS[i + 1][k] * f)
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn normalise(a: [f64; 3]) -> [f64; 3] {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    if l > 0.0 {
        [a[0] / l, a[1] / l, a[2] / l]
    } else {
        [0.0, 0.0, 0.0]
    }
}

/// Renders `mesh` to an image. See the module documentation for the camera and shading.
pub fn render(mesh: &TriMesh, opts: &RenderOptions) -> Result<Image, RenderError> {
    if mesh.faces.is_empty() {
        return Err(RenderError::Empty);
    }
    mesh.validate()?;
    if !(16..=8192).contains(&opts.width) || !(16..=8192).contains(&opts.height) {
        return Err(RenderError::Invalid(format!(
            "size {}×{} outside 16…8192",
            opts.width, opts.height
        )));
    }
    if !(1..=4).contains(&opts.supersample) {
        return Err(RenderError::Invalid(format!(
            "supersample {} outside 1…4",
            opts.supersample
        )));
    }
    if !opts.azimuth.is_finite() || !opts.elevation.is_finite() {
        return Err(RenderError::Invalid("view angles must be finite".into()));
    }
    let n = mesh.n_vertices();
    let colours: Option<Vec<[f64; 3]>> = match &opts.colouring {
        Colouring::Clay => None,
        Colouring::Scalar { values, range } => {
            if values.len() != n {
                return Err(RenderError::Invalid(format!(
                    "{} scalars for {n} vertices",
                    values.len()
                )));
            }
            let (lo, hi) = range.unwrap_or_else(|| {
                values
                    .iter()
                    .filter(|v| v.is_finite())
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                        (a.min(v), b.max(v))
                    })
            });
            let span = if hi > lo { hi - lo } else { 1.0 };
            Some(values.iter().map(|v| colour_map((v - lo) / span)).collect())
        }
    };

    // Camera frame: rotate by azimuth about y, then elevation about x.
    let (sa, ca) = opts.azimuth.to_radians().sin_cos();
    let (se, ce) = opts.elevation.to_radians().sin_cos();
    let (centre, radius) = opts.frame.unwrap_or_else(|| bounding_sphere(mesh));
    let radius = if radius > 0.0 { radius } else { 1.0 };
    let ss = opts.supersample as usize;
    let (w, h) = (opts.width as usize * ss, opts.height as usize * ss);
    let scale = 0.95 * 0.5 * w.min(h) as f64 / radius;
    let view = |p: [f64; 3]| -> [f64; 3] {
        let q = sub(p, centre);
        let x1 = ca * q[0] + sa * q[2];
        let z1 = -sa * q[0] + ca * q[2];
        let y2 = ce * q[1] - se * z1;
        let z2 = se * q[1] + ce * z1;
        [x1, y2, z2]
    };
    let cam: Vec<[f64; 3]> = mesh.positions.iter().map(|&p| view(p)).collect();
    let screen: Vec<[f64; 3]> = cam
        .iter()
        .map(|q| {
            [
                0.5 * w as f64 + scale * q[0],
                0.5 * h as f64 - scale * q[1],
                q[2],
            ]
        })
        .collect();
    let face_normals: Vec<[f64; 3]> = mesh
        .faces
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(|v| cam[v as usize]);
            normalise(cross(sub(b, a), sub(c, a)))
        })
        .collect();
    let vertex_normals: Option<Vec<[f64; 3]>> = opts.smooth.then(|| {
        let mut acc = vec![[0.0; 3]; n];
        for (f, t) in mesh.faces.iter().enumerate() {
            let [a, b, c] = t.map(|v| cam[v as usize]);
            let an = cross(sub(b, a), sub(c, a)); // area-weighted
            for &v in t {
                for k in 0..3 {
                    acc[v as usize][k] += an[k];
                }
            }
            let _ = f;
        }
        acc.into_iter().map(normalise).collect()
    });
    // Key light from the upper left front, fill from the camera.
    let key = normalise([-0.4, 0.6, 0.7]);
    let shade = |nrm: [f64; 3]| -> f64 {
        let d1 = (nrm[0] * key[0] + nrm[1] * key[1] + nrm[2] * key[2]).abs();
        let d2 = nrm[2].abs();
        (0.18 + 0.62 * d1 + 0.25 * d2).min(1.0)
    };

    let mut depth = vec![f64::NEG_INFINITY; w * h];
    let mut colour = vec![BACKGROUND; w * h];
    for (fi, t) in mesh.faces.iter().enumerate() {
        let [p0, p1, p2] = t.map(|v| screen[v as usize]);
        let area = (p1[0] - p0[0]) * (p2[1] - p0[1]) - (p2[0] - p0[0]) * (p1[1] - p0[1]);
        if area.abs() < 1e-12 {
            continue;
        }
        let xmin = p0[0].min(p1[0]).min(p2[0]).floor().max(0.0) as usize;
        let xmax = (p0[0].max(p1[0]).max(p2[0]).ceil() as isize).min(w as isize - 1);
        let ymin = p0[1].min(p1[1]).min(p2[1]).floor().max(0.0) as usize;
        let ymax = (p0[1].max(p1[1]).max(p2[1]).ceil() as isize).min(h as isize - 1);
        if xmax < 0 || ymax < 0 {
            continue;
        }
        let base = match &colours {
            None => [CLAY; 3],
            Some(c) => t.map(|v| c[v as usize]),
        };
        for y in ymin..=ymax as usize {
            let py = y as f64 + 0.5;
            for x in xmin..=xmax as usize {
                let px = x as f64 + 0.5;
                let b0 = ((p1[0] - px) * (p2[1] - py) - (p2[0] - px) * (p1[1] - py)) / area;
                let b1 = ((p2[0] - px) * (p0[1] - py) - (p0[0] - px) * (p2[1] - py)) / area;
                let b2 = 1.0 - b0 - b1;
                if b0 < 0.0 || b1 < 0.0 || b2 < 0.0 {
                    continue;
                }
                let z = b0 * p0[2] + b1 * p1[2] + b2 * p2[2];
                let idx = y * w + x;
                if z <= depth[idx] {
                    continue;
                }
                depth[idx] = z;
                let nrm = match &vertex_normals {
                    None => face_normals[fi],
                    Some(vn) => {
                        let [a, b, c] = t.map(|v| vn[v as usize]);
                        normalise(std::array::from_fn(|k| b0 * a[k] + b1 * b[k] + b2 * c[k]))
                    }
                };
                let s = shade(nrm);
                let edge = opts.wireframe && b0.min(b1).min(b2) < 0.04;
                let e = if edge { 0.55 } else { 1.0 };
                colour[idx] = std::array::from_fn(|k| {
                    s * e * (b0 * base[0][k] + b1 * base[1][k] + b2 * base[2][k])
                });
            }
        }
    }

    // Box filter down to the output size.
    let (ow, oh) = (opts.width as usize, opts.height as usize);
    let mut rgb = vec![0u8; ow * oh * 3];
    let inv = 1.0 / (ss * ss) as f64;
    for y in 0..oh {
        for x in 0..ow {
            let mut acc = [0.0; 3];
            for dy in 0..ss {
                for dx in 0..ss {
                    let c = colour[(y * ss + dy) * w + x * ss + dx];
                    for k in 0..3 {
                        acc[k] += c[k];
                    }
                }
            }
            for k in 0..3 {
                rgb[3 * (y * ow + x) + k] = (255.0 * acc[k] * inv).round().clamp(0.0, 255.0) as u8;
            }
        }
    }
    Ok(Image {
        width: opts.width,
        height: opts.height,
        rgb,
    })
}

/// Several images side by side, each with a caption underneath: the layout of the
/// paper's figures.
#[derive(Clone, Debug, Default)]
pub struct Panel {
    /// `(image, caption)` pairs, left to right. Images may differ in size.
    pub cells: Vec<(Image, String)>,
    /// Optional title above the row.
    pub title: Option<String>,
}

impl Panel {
    /// Composes the row into one image.
    pub fn compose(&self) -> Result<Image, RenderError> {
        if self.cells.is_empty() {
            return Err(RenderError::Invalid(
                "a panel needs at least one image".into(),
            ));
        }
        let caption_h = 40u32;
        let title_h = if self.title.is_some() { 44 } else { 0 };
        let gap = 8u32;
        let width: u32 =
            self.cells.iter().map(|c| c.0.width).sum::<u32>() + gap * (self.cells.len() as u32 + 1);
        let height = title_h + self.cells.iter().map(|c| c.0.height).max().unwrap_or(0) + caption_h;
        if width > 16384 || height > 16384 {
            return Err(RenderError::Invalid(format!(
                "panel {width}×{height} too large"
            )));
        }
        let mut out = Image::filled(width, height, [255, 255, 255]);
        let mut x0 = gap;
        let mut captions = Vec::new();
        for (img, caption) in &self.cells {
            for y in 0..img.height {
                let src =
                    &img.rgb[(y * img.width * 3) as usize..((y + 1) * img.width * 3) as usize];
                let dst = 3 * (((title_h + y) * width + x0) as usize);
                out.rgb[dst..dst + src.len()].copy_from_slice(src);
            }
            captions.push((x0 + img.width / 2, caption.clone()));
            x0 += img.width + gap;
        }
        crate::plot::register_fonts();
        {
            let root =
                BitMapBackend::with_buffer(&mut out.rgb, (width, height)).into_drawing_area();
            let err = |e: &dyn std::fmt::Display| RenderError::Caption(e.to_string());
            let centred = |size: u32| {
                TextStyle::from(("sans-serif", size).into_font())
                    .color(&BLACK)
                    .pos(plotters::style::text_anchor::Pos::new(
                        plotters::style::text_anchor::HPos::Center,
                        plotters::style::text_anchor::VPos::Center,
                    ))
            };
            if let Some(t) = &self.title {
                root.draw_text(t, &centred(26), ((width / 2) as i32, (title_h / 2) as i32))
                    .map_err(|e| err(&e))?;
            }
            let y = (height - caption_h / 2) as i32;
            for (x, c) in &captions {
                root.draw_text(c, &centred(20), (*x as i32, y))
                    .map_err(|e| err(&e))?;
            }
            root.present().map_err(|e| err(&e))?;
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;

    fn coverage(img: &Image) -> f64 {
        let px = img
            .rgb
            .chunks_exact(3)
            .filter(|p| p != &[255, 255, 255])
            .count();
        px as f64 / (img.width * img.height) as f64
    }

    #[test]
    fn a_sphere_covers_a_disc_of_the_expected_area() {
        let m = builtin::icosphere(4).unwrap();
        let img = render(
            &m,
            &RenderOptions {
                width: 200,
                height: 200,
                ..Default::default()
            },
        )
        .unwrap();
        // radius 0.95·100 px → π·95² / 200² ≈ 0.709 (the polyhedron is slightly smaller)
        let c = coverage(&img);
        assert!((c - 0.709).abs() < 0.02, "coverage {c}");
        // centre is lit clay, corner is background
        assert_ne!(img.pixel(100, 100), [255, 255, 255]);
        assert_eq!(img.pixel(2, 2), [255, 255, 255]);
    }

    #[test]
    fn depth_test_and_view_rotation() {
        // Two parallel squares at z = ±1 of different colours: the front one wins, and
        // turning the view by 180° shows the other.
        let positions = vec![
            [-1.0, -1.0, 1.0],
            [1.0, -1.0, 1.0],
            [1.0, 1.0, 1.0],
            [-1.0, 1.0, 1.0],
            [-1.0, -1.0, -1.0],
            [1.0, -1.0, -1.0],
            [1.0, 1.0, -1.0],
            [-1.0, 1.0, -1.0],
        ];
        let faces = vec![[0, 1, 2], [0, 2, 3], [4, 6, 5], [4, 7, 6]];
        let m = TriMesh::new(positions, faces);
        let values = vec![0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0];
        let mut o = RenderOptions {
            width: 64,
            height: 64,
            colouring: Colouring::Scalar {
                values,
                range: None,
            },
            supersample: 1,
            ..Default::default()
        };
        let front = render(&m, &o).unwrap().pixel(32, 32);
        o.azimuth = 180.0;
        let back = render(&m, &o).unwrap().pixel(32, 32);
        // value 0 maps to dark purple, 1 to yellow
        assert!(front[2] > front[1], "front {front:?}");
        assert!(
            back[0] > 150 && back[1] > 150 && back[2] < 100,
            "back {back:?}"
        );
    }

    #[test]
    fn deterministic_and_errors() {
        let m = builtin::torus(12, 8).unwrap();
        let o = RenderOptions {
            width: 96,
            height: 64,
            azimuth: 30.0,
            elevation: 20.0,
            smooth: true,
            ..Default::default()
        };
        assert_eq!(render(&m, &o).unwrap(), render(&m, &o).unwrap());
        assert!(matches!(
            render(&TriMesh::default(), &o),
            Err(RenderError::Empty)
        ));
        let bad = RenderOptions {
            supersample: 9,
            ..o.clone()
        };
        assert!(matches!(render(&m, &bad), Err(RenderError::Invalid(_))));
        let wrong = RenderOptions {
            colouring: Colouring::Scalar {
                values: vec![0.0; 3],
                range: None,
            },
            ..o
        };
        assert!(matches!(render(&m, &wrong), Err(RenderError::Invalid(_))));
    }

    #[test]
    fn panel_composes_and_writes() {
        let m = builtin::icosahedron();
        let o = RenderOptions {
            width: 80,
            height: 60,
            ..Default::default()
        };
        let a = render(&m, &o).unwrap();
        let p = Panel {
            cells: vec![(a.clone(), "one".into()), (a, "two".into())],
            title: Some("t".into()),
        };
        let img = p.compose().unwrap();
        assert_eq!(img.width, 80 * 2 + 8 * 3);
        assert_eq!(img.height, 44 + 60 + 40);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.png");
        img.write_png(&path).unwrap();
        assert_eq!(&std::fs::read(&path).unwrap()[..4], b"\x89PNG");
        assert!(Panel::default().compose().is_err());
    }
}
