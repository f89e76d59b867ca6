//! Rescaling after filtering, as pmp-library (`preserve volume`) and libigl offer:
//! low-pass filters shrink a shape; these undo the global shrinkage.

use crate::mesh::TriMesh;
use serde::Serialize;

/// Rescaling after filtering.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Preserve {
    /// No rescaling.
    #[default]
    None,
    /// Scale about the centroid to the input's enclosed volume (signed volume of the
    /// triangles; meaningful for closed meshes; skipped when either volume is 0).
    Volume,
    /// Scale uniformly to the input's bounding-box diagonal and re-centre on its
    /// bounding-box centre.
    BBox,
}

impl std::str::FromStr for Preserve {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "none" => Ok(Preserve::None),
            "volume" => Ok(Preserve::Volume),
            "bbox" => Ok(Preserve::BBox),
            _ => Err(format!("unknown --preserve `{s}` (volume, bbox, none)")),
        }
    }
}

/// Centroid (mean of the points).
pub fn centroid(p: &[[f64; 3]]) -> [f64; 3] {
    let mut c = [0.0; 3];
    for v in p {
        for k in 0..3 {
            c[k] += v[k];
        }
    }
    c.map(|s| s / p.len().max(1) as f64)
}

/// Signed volume enclosed by the triangles (divergence theorem, measured about the
/// centroid for accuracy; translation-invariant for closed meshes).
pub fn volume(p: &[[f64; 3]], faces: &[[u32; 3]]) -> f64 {
    let c = centroid(p);
    faces
        .iter()
        .map(|f| {
            let [a, b, d] = f.map(|v| {
                let q = p[v as usize];
                [q[0] - c[0], q[1] - c[1], q[2] - c[2]]
            });
            (a[0] * (b[1] * d[2] - b[2] * d[1]) - a[1] * (b[0] * d[2] - b[2] * d[0])
                + a[2] * (b[0] * d[1] - b[1] * d[0]))
                / 6.0
        })
        .sum()
}

/// Rescales the filtered positions `out` of `input` (same faces) as `how` says.
pub fn rescale(input: &TriMesh, out: &mut [[f64; 3]], how: Preserve) {
    match how {
        Preserve::None => {}
        Preserve::Volume => {
            let (v0, v) = (
                volume(&input.positions, &input.faces),
                volume(out, &input.faces),
            );
            if v.abs() > 0.0 && v0.abs() > 0.0 {
                let s = (v0 / v).abs().cbrt();
                let c = centroid(out);
                for p in out.iter_mut() {
                    for k in 0..3 {
                        p[k] = c[k] + s * (p[k] - c[k]);
                    }
                }
            }
        }
        Preserve::BBox => {
            let after = TriMesh::new(out.to_vec(), vec![]);
            let (d0, d1) = (input.bbox_diagonal(), after.bbox_diagonal());
            if let (Some((l0, h0)), Some((l1, h1))) = (input.bounding_box(), after.bounding_box()) {
                let s = if d1 > 0.0 { d0 / d1 } else { 1.0 };
                for p in out.iter_mut() {
                    for k in 0..3 {
                        let c0 = 0.5 * (l0[k] + h0[k]);
                        let c1 = 0.5 * (l1[k] + h1[k]);
                        p[k] = c0 + s * (p[k] - c1);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;

    #[test]
    fn volume_of_a_cube_and_rescaling() {
        let m = builtin::cube(2).unwrap();
        let v = volume(&m.positions, &m.faces).abs();
        let bb = m.bounding_box().unwrap();
        let side = bb.1[0] - bb.0[0];
        assert!(
            (v - side * side * side).abs() < 1e-12,
            "{v} vs {}",
            side.powi(3)
        );
        let shrunk: Vec<[f64; 3]> = m
            .positions
            .iter()
            .map(|p| p.map(|c| 0.5 * c + 0.1))
            .collect();
        let mut a = shrunk.clone();
        rescale(&m, &mut a, Preserve::Volume);
        assert!((volume(&a, &m.faces) - volume(&m.positions, &m.faces)).abs() < 1e-12);
        let mut b = shrunk.clone();
        rescale(&m, &mut b, Preserve::BBox);
        for (p, q) in b.iter().zip(&m.positions) {
            for k in 0..3 {
                assert!((p[k] - q[k]).abs() < 1e-12);
            }
        }
        let mut c = shrunk.clone();
        rescale(&m, &mut c, Preserve::None);
        assert_eq!(c, shrunk);
    }
}
