//! Tests of the renderer: coverage, depth order, framing across views, scalar colors
//! at known pixels, the legend, panels and errors.

use super::legend::Legend;
use super::*;
use crate::mesh::{builtin, TriMesh};

const WHITE: [u8; 3] = [255, 255, 255];

fn coverage(img: &Image) -> f64 {
    let px = img.rgb.chunks_exact(3).filter(|p| p != &WHITE).count();
    px as f64 / (img.width * img.height) as f64
}

/// Bounding box `(x0, y0, x1, y1)` (inclusive) of the non-white pixels in columns
/// `0..x_end`.
fn drawn_box(img: &Image, x_end: u32) -> (u32, u32, u32, u32) {
    let mut b = (u32::MAX, u32::MAX, 0, 0);
    for y in 0..img.height {
        for x in 0..x_end {
            if img.pixel(x, y) != WHITE {
                b = (b.0.min(x), b.1.min(y), b.2.max(x), b.3.max(y));
            }
        }
    }
    b
}

/// A square `[-1, 1]²` in the plane z = 0, facing the camera at the default view.
fn square() -> TriMesh {
    TriMesh::new(
        vec![
            [-1.0, -1.0, 0.0],
            [1.0, -1.0, 0.0],
            [1.0, 1.0, 0.0],
            [-1.0, 1.0, 0.0],
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    )
}

#[test]
fn a_sphere_covers_a_disc_of_the_expected_area() {
    let m = builtin::icosphere(4).unwrap();
    let o = RenderOptions {
        width: 200,
        height: 200,
        ..Default::default()
    };
    let img = render(&m, &o).unwrap();
    // radius 0.95·100 px → π·95² / 200² ≈ 0.709 (the polyhedron is slightly smaller)
    let c = coverage(&img);
    assert!((c - 0.709).abs() < 0.02, "coverage {c}");
    // center is lit clay, corner is background
    assert_ne!(img.pixel(100, 100), WHITE);
    assert_eq!(img.pixel(2, 2), WHITE);
}

#[test]
fn the_framed_mesh_fills_the_picture_for_every_view() {
    // An elongated, flattened ellipsoid: its bounding sphere would leave most of the
    // picture empty in the views along its long axis.
    let mut m = builtin::icosphere(3).unwrap();
    for p in &mut m.positions {
        *p = [4.0 * p[0] + 10.0, p[1] - 3.0, 0.5 * p[2]];
    }
    for (az, el) in [
        (0.0, 0.0),
        (30.0, 20.0),
        (90.0, 0.0),
        (-60.0, 45.0),
        (0.0, 90.0),
        (180.0, -30.0),
    ] {
        for (w, h) in [(200u32, 160u32), (120, 240)] {
            let o = RenderOptions {
                width: w,
                height: h,
                azimuth: az,
                elevation: el,
                ..Default::default()
            };
            let img = render(&m, &o).unwrap();
            let (x0, y0, x1, y1) = drawn_box(&img, w);
            let fill = ((x1 - x0 + 1) as f64 / w as f64).max((y1 - y0 + 1) as f64 / h as f64);
            assert!(fill > 0.9, "view ({az}, {el}) {w}×{h}: fill {fill}");
            // centered: equal margins (± 2 px) on the two sides of the long direction
            let (mx, my) = ((x0 + x1) as f64 / 2.0, (y0 + y1) as f64 / 2.0);
            assert!(
                (mx - w as f64 / 2.0).abs() < 2.5,
                "({az}, {el}): x center {mx}"
            );
            assert!(
                (my - h as f64 / 2.0).abs() < 2.5,
                "({az}, {el}): y center {my}"
            );
        }
    }
}

#[test]
fn shared_and_sphere_framings() {
    // A window fitted to a large mesh frames a smaller one smaller.
    let big = builtin::icosphere(2).unwrap();
    let mut small = big.clone();
    for p in &mut small.positions {
        *p = p.map(|c| 0.5 * c);
    }
    let w = Window::fit(&big, 20.0, 10.0).unwrap();
    let o = RenderOptions {
        width: 100,
        height: 100,
        azimuth: 20.0,
        elevation: 10.0,
        framing: Framing::Window(w),
        ..Default::default()
    };
    let ratio = coverage(&render(&small, &o).unwrap()) / coverage(&render(&big, &o).unwrap());
    assert!((ratio - 0.25).abs() < 0.03, "{ratio}");
    let (center, radius) = bounding_sphere(&big);
    let s = RenderOptions {
        framing: Framing::Sphere { center, radius },
        ..o.clone()
    };
    assert!(coverage(&render(&big, &s).unwrap()) > 0.6);
    let bad = RenderOptions {
        framing: Framing::Sphere {
            center,
            radius: 0.0,
        },
        ..o
    };
    assert!(matches!(render(&big, &bad), Err(RenderError::Framing)));
}

#[test]
fn depth_test_and_view_rotation() {
    // Two parallel squares at z = ±1 of different colors: the front one wins, and
    // turning the view by 180° shows the other.
    let mut positions = square().positions;
    positions.iter_mut().for_each(|p| p[2] = 1.0);
    positions.extend(square().positions.iter().map(|p| [p[0], p[1], -1.0]));
    let faces = vec![[0, 1, 2], [0, 2, 3], [4, 6, 5], [4, 7, 6]];
    let m = TriMesh::new(positions, faces);
    let values = vec![0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0];
    let mut o = RenderOptions {
        width: 64,
        height: 64,
        coloring: Coloring::Scalar(Scalars::new(values, Colormap::Viridis)),
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

/// The light factor of mapped colors on a face facing the camera (see `zbuffer`).
fn facing_light() -> f64 {
    let key = glam::DVec3::new(-0.4, 0.6, 0.7).normalize();
    0.5 + 0.5 * (0.18 + 0.62 * key.z + 0.25)
}

#[test]
fn a_linear_scalar_gives_the_colormap_at_known_pixels() {
    // values = x on the square: at the picture column of mesh coordinate x the color is
    // the map at (x + 1)/2 (viridis) or at x over [−1, 1] (cool–warm), times the light.
    for colormap in Colormap::ALL {
        let m = square();
        let values: Vec<f64> = m.positions.iter().map(|p| p[0]).collect();
        let o = RenderOptions {
            width: 200,
            height: 200,
            supersample: 1,
            legend: false,
            coloring: Coloring::Scalar(Scalars::new(values, colormap)),
            ..Default::default()
        };
        let img = render(&m, &o).unwrap();
        // The square fills 0.95 of the picture: 95 pixels per unit about the center.
        for col in [10u32, 50, 100, 150, 189] {
            let x = (col as f64 + 0.5 - 100.0) / 95.0;
            let want = colormap
                .map((x + 1.0) / 2.0)
                .map(|c| 255.0 * c * facing_light());
            for row in [20u32, 100, 180] {
                let got = img.pixel(col, row);
                for k in 0..3 {
                    assert!(
                        (got[k] as f64 - want[k]).abs() <= 1.5,
                        "{colormap} ({col}, {row}): {got:?} vs {want:?}"
                    );
                }
            }
        }
        assert_eq!(img.pixel(2, 100), WHITE);
    }
    // an explicit range: everything above it gets the top color
    let m = square();
    let o = RenderOptions {
        width: 100,
        height: 100,
        supersample: 1,
        coloring: Coloring::Scalar(Scalars {
            range: Some((-10.0, -5.0)),
            ..Scalars::new(vec![0.0; 4], Colormap::Viridis)
        }),
        ..Default::default()
    };
    let got = render(&m, &o).unwrap().pixel(50, 50);
    let want = Colormap::Viridis
        .map(1.0)
        .map(|c| 255.0 * c * facing_light());
    assert!(
        (0..3).all(|k| (got[k] as f64 - want[k]).abs() <= 1.5),
        "{got:?}"
    );
}

#[test]
fn the_legend_shows_the_map_from_min_to_max_beside_the_mesh() {
    let m = builtin::icosphere(3).unwrap();
    let values: Vec<f64> = m.positions.iter().map(|p| p[1]).collect();
    let scalars = Scalars::new(values, Colormap::Viridis).with_label("height y");
    let o = RenderOptions {
        width: 400,
        height: 300,
        coloring: Coloring::Scalar(scalars.clone()),
        ..Default::default()
    };
    let img = render(&m, &o).unwrap();
    let (top, bottom) = Legend::bar_rows(300);
    let (hi, lo) = (
        Colormap::Viridis.map_rgb8(1.0),
        Colormap::Viridis.map_rgb8(0.0),
    );
    let bar: Vec<u32> = (0..400)
        .filter(|&x| img.pixel(x, top) == hi && img.pixel(x, bottom) == lo)
        .collect();
    assert!(bar.len() >= 8, "bar columns {bar:?}");
    let strip_start = 400 - Legend::new(&scalars, scalars.effective_range(), 300).width;
    assert!(bar[0] > strip_start, "{bar:?} {strip_start}");
    // the mesh is framed left of the strip
    let (_, _, x1, _) = drawn_box(&img, strip_start);
    assert!(x1 < strip_start);
    // dark label text right of the bar at the tick rows, and the caption left of it
    let dark = |xs: std::ops::Range<u32>, ys: std::ops::Range<u32>| {
        ys.flat_map(|y| xs.clone().map(move |x| (x, y)))
            .filter(|&(x, y)| {
                let p = img.pixel(x, y);
                p[0] < 200 && p[0] == p[1] && p[1] == p[2]
            })
            .count()
    };
    let right = bar.last().unwrap() + 8..400;
    assert!(dark(right.clone(), top - 8..top + 8) > 5);
    assert!(dark(right, bottom - 8..bottom + 8) > 10);
    assert!(dark(strip_start..bar[0], top..bottom) > 20);
    // no legend when disabled
    let plain = render(&m, &RenderOptions { legend: false, ..o }).unwrap();
    assert!((0..400).all(|x| plain.pixel(x, top) != hi || plain.pixel(x, bottom) != lo));
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
    assert!(matches!(render(&m, &bad), Err(RenderError::Supersample(9))));
    let small = RenderOptions {
        width: 3,
        ..o.clone()
    };
    assert!(matches!(render(&m, &small), Err(RenderError::Size { .. })));
    let wrong = RenderOptions {
        coloring: Coloring::Scalar(Scalars::new(vec![0.0; 3], Colormap::Viridis)),
        ..o
    };
    let e = render(&m, &wrong).unwrap_err();
    assert!(
        matches!(
            e,
            RenderError::ScalarCount {
                got: 3,
                expected: 96
            }
        ),
        "{e}"
    );
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
    assert!(matches!(
        Panel::default().compose(),
        Err(RenderError::EmptyPanel)
    ));
}
