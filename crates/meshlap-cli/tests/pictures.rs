//! End-to-end tests of `meshlap render` with scalars and eigenvectors.

mod common;
use common::*;
use std::path::Path;

/// Decodes an RGB8 PNG into (width, height, pixels).
fn decode(path: &Path) -> (u32, u32, Vec<[u8; 3]>) {
    let bytes = std::fs::read(path).unwrap();
    let mut reader = png::Decoder::new(std::io::Cursor::new(bytes))
        .read_info()
        .unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    let px = buf[..info.buffer_size()]
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    (info.width, info.height, px)
}

/// Renders builtin:grid:4 (25 vertices) colored by `count` values 0, 1, … saved to
/// `npy`, into `png`, with the `extra` arguments.
fn render_npy(npy: &Path, count: usize, png: &Path, extra: &[&str]) -> std::process::Output {
    let values = faer::Mat::from_fn(count, 1, |i, _| i as f64);
    meshlap::io::write_npy(npy, values.as_ref()).unwrap();
    let (npy, png) = (npy.to_str().unwrap(), png.to_str().unwrap());
    let mut args = vec!["render", "builtin:grid:4", "--scalars", npy, "-o", png];
    args.extend_from_slice(extra);
    meshlap(&args)
}

#[test]
fn render_scalars_from_npy_and_a_wrong_length_is_one_error_line() {
    let dir = tempfile::tempdir().unwrap();
    let npy = dir.path().join("s.npy");
    let png = dir.path().join("s.png");
    let out = render_npy(&npy, 25, &png, &["--width", "300", "--height", "200"]);
    assert!(out.status.success(), "{out:?}");
    let (w, h, px) = decode(&png);
    assert_eq!((w, h), (300, 200));
    // viridis' yellow end (the legend's top) is there
    assert!(px.contains(&[253, 231, 37]));

    let bad = dir.path().join("bad.png");
    let out = render_npy(&npy, 24, &bad, &[]);
    assert_one_line_error(&out, "24 scalars for 25 vertices");
    assert!(!bad.exists());
}

#[test]
fn render_an_eigenvector_in_blue_and_red() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("e.png");
    let out = meshlap(&[
        "render",
        "builtin:icosphere:2",
        "--eigenvector",
        "1",
        "--kind",
        "sql",
        "--smooth",
        "-o",
        png.to_str().unwrap(),
        "--width",
        "240",
        "--height",
        "200",
    ]);
    assert!(out.status.success(), "{out:?}");
    let (_, _, px) = decode(&png);
    let blue = px.iter().filter(|p| p[2] as i32 > p[0] as i32 + 40).count();
    let red = px.iter().filter(|p| p[0] as i32 > p[2] as i32 + 40).count();
    assert!(blue > 2000 && red > 2000, "blue {blue}, red {red}");
    // --eigenvector needs --kind, and an index past n is one clear line
    let e = meshlap(&[
        "render",
        "builtin:tetrahedron",
        "--eigenvector",
        "1",
        "-o",
        "x.png",
    ]);
    assert_eq!(e.status.code(), Some(2));
    let e = meshlap(&[
        "render",
        "builtin:tetrahedron",
        "--eigenvector",
        "4",
        "--kind",
        "kl",
        "-o",
        dir.path().join("t.png").to_str().unwrap(),
    ]);
    assert_one_line_error(&e, "eigenvector 4");
    // --color and --colour (hidden alias) both work; a colormap can be chosen
    for flag in ["--color", "--colour"] {
        let p = dir.path().join("d.png");
        let out = meshlap(&[
            "render",
            "builtin:torus:12:8",
            flag,
            "height",
            "--colormap",
            "coolwarm",
            "--no-legend",
            "-o",
            p.to_str().unwrap(),
        ]);
        assert!(out.status.success(), "{flag}: {out:?}");
    }
}
