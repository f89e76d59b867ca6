//! Similarity transform (the benchmark's "similarity transformation"):
//! `x ↦ s·R·x + t` with `R` uniformly random on SO(3) (Shoemake's unit quaternion from
//! three uniforms), `s` the given scale and `t` uniform in the cube of half-side one
//! bounding-box diagonal. `R` and `t` come from the seed.

use crate::mesh::TriMesh;
use crate::rng::SplitMix64;
use glam::{DQuat, DVec3};

/// The seeded rotation and translation [`similarity`] applies to a mesh with
/// bounding-box diagonal `diagonal`: `(R, t)`.
pub fn random_rotation_translation(seed: u64, diagonal: f64) -> (DQuat, DVec3) {
    let mut rng = SplitMix64::new(seed);
    let (u1, u2, u3) = (rng.next_f64(), rng.next_f64(), rng.next_f64());
    let tau = std::f64::consts::TAU;
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    let q = DQuat::from_xyzw(
        a * (tau * u2).sin(),
        a * (tau * u2).cos(),
        b * (tau * u3).sin(),
        b * (tau * u3).cos(),
    )
    .normalize();
    let t = DVec3::new(rng.next_signed(), rng.next_signed(), rng.next_signed()) * diagonal;
    (q, t)
}

/// `mesh` rotated by a seeded random rotation, scaled by `scale` about the origin and
/// translated by a seeded random offset (connectivity and vertex order unchanged).
pub fn similarity(mesh: &TriMesh, scale: f64, seed: u64) -> TriMesh {
    let (r, t) = random_rotation_translation(seed, mesh.bbox_diagonal());
    let positions = mesh
        .positions
        .iter()
        .map(|&p| (r * DVec3::from(p) * scale + t).to_array())
        .collect();
    TriMesh::new(positions, mesh.faces.clone())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;

    #[test]
    fn distance_ratios_are_preserved_and_the_scale_is_exact() {
        let m = builtin::torus(10, 6).unwrap();
        let s = similarity(&m, 1.7, 3);
        let d = |p: [f64; 3], q: [f64; 3]| (DVec3::from(p) - DVec3::from(q)).length();
        let n = m.n_vertices();
        for (i, j) in [(0, 1), (0, n / 2), (3, n - 1), (n / 3, 2 * n / 3)] {
            let ratio = d(s.positions[i], s.positions[j]) / d(m.positions[i], m.positions[j]);
            assert!((ratio - 1.7).abs() < 1e-12, "{ratio}");
        }
        // Not the identity, and seeded.
        assert!(d(s.positions[0], m.positions[0]) > 1e-3);
        assert_eq!(similarity(&m, 1.7, 3), s);
        assert_ne!(similarity(&m, 1.7, 4), s);
        // Orientation is kept (a proper rotation): signed volume scales by s³.
        let v0 = crate::filter::volume(&m.positions, &m.faces);
        let v1 = crate::filter::volume(&s.positions, &s.faces);
        assert!((v1 / v0 - 1.7f64.powi(3)).abs() < 1e-9);
    }
}
