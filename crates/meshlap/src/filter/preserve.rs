//! Rescaling after filtering, as pmp-library (`preserve volume`) and libigl offer:
//! low-pass filters shrink a shape; these undo the global shrinkage.

use super::FilterError;
use crate::mesh::TriMesh;
use glam::DVec3;

/// Rescaling after filtering.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub enum Preserve {
    /// No rescaling.
    #[default]
    None,
    /// Scale about the centroid to the input's enclosed volume (signed volume of the
    /// triangles; meaningful for closed meshes; skipped when either volume is 0).
    Volume,
    /// Scale uniformly to the input's bounding-box diagonal and re-center on its
    /// bounding-box center.
    BBox,
}

crate::names::option_names!(Preserve, FilterError, |s| FilterError::UnknownName {
    what: "rescaling",
    got: s.to_string(),
}, {
    None => "none",
    Volume => "volume",
    BBox => "bbox",
});

/// Centroid (mean of the points).
pub fn centroid(p: &[[f64; 3]]) -> [f64; 3] {
    let sum: DVec3 = p.iter().copied().map(DVec3::from).sum();
    (sum / p.len().max(1) as f64).to_array()
}

/// Signed volume enclosed by the triangles (divergence theorem, measured about the
/// centroid for accuracy; translation-invariant for closed meshes).
pub fn volume(p: &[[f64; 3]], faces: &[[u32; 3]]) -> f64 {
    let c = DVec3::from(centroid(p));
    faces
        .iter()
        .map(|f| {
            let [a, b, d] = f.map(|v| DVec3::from(p[v as usize]) - c);
            a.dot(b.cross(d)) / 6.0
        })
        .sum()
}

/// Rescales the filtered positions `out` of `input` (same faces) as `how` says.
pub fn rescale(input: &TriMesh, out: &mut [[f64; 3]], how: Preserve) {
    let (center, scale) = match how {
        Preserve::None => return,
        Preserve::Volume => {
            let (v0, v) = (
                volume(&input.positions, &input.faces),
                volume(out, &input.faces),
            );
            if !(v.abs() > 0.0 && v0.abs() > 0.0) {
                return;
            }
            let c = DVec3::from(centroid(out));
            ((c, c), (v0 / v).abs().cbrt())
        }
        Preserve::BBox => {
            let after = TriMesh::new(out.to_vec(), vec![]);
            let (d0, d1) = (input.bbox_diagonal(), after.bbox_diagonal());
            let (Some((l0, h0)), Some((l1, h1))) = (input.bounding_box(), after.bounding_box())
            else {
                return;
            };
            let mid = |l: [f64; 3], h: [f64; 3]| 0.5 * (DVec3::from(l) + DVec3::from(h));
            let s = if d1 > 0.0 { d0 / d1 } else { 1.0 };
            ((mid(l1, h1), mid(l0, h0)), s)
        }
    };
    // p ← to + s·(p − from).
    let (from, to) = center;
    for p in out.iter_mut() {
        *p = (to + scale * (DVec3::from(*p) - from)).to_array();
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
