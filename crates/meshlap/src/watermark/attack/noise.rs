//! Uniform additive noise (the benchmark's "noise addition").
//!
//! Every coordinate of every vertex gets an independent uniform offset in `[−a, a]`
//! with `a = X/100 · d̄`, `d̄` the mean distance of the vertices to their centroid, so
//! the same X is the same relative strength on any model. Seeded ([`crate::rng`]).

use crate::mesh::TriMesh;
use crate::rng::SplitMix64;

/// `mesh` with uniform noise of amplitude `percent` % of the mean vertex distance to
/// the centroid added to each coordinate (connectivity and vertex order unchanged).
pub fn noise(mesh: &TriMesh, percent: f64, seed: u64) -> TriMesh {
    let a = percent / 100.0 * super::mean_distance_to_centroid(&mesh.positions);
    let mut rng = SplitMix64::new(seed);
    let positions = mesh
        .positions
        .iter()
        .map(|p| p.map(|x| x + a * rng.next_signed()))
        .collect();
    TriMesh::new(positions, mesh.faces.clone())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;

    #[test]
    fn amplitude_is_bounded_and_reached_and_seeded() {
        let m = builtin::icosphere(3).unwrap();
        // Unit sphere: the mean distance to the centroid is 1.
        let d = super::super::mean_distance_to_centroid(&m.positions);
        assert!((d - 1.0).abs() < 1e-12);
        let out = noise(&m, 0.5, 7);
        let a = 0.005;
        let max = m
            .positions
            .iter()
            .zip(&out.positions)
            .flat_map(|(p, q)| (0..3).map(move |k| (p[k] - q[k]).abs()))
            .fold(0.0, f64::max);
        assert!(max <= a && max > 0.95 * a, "{max}");
        assert_eq!(out.faces, m.faces);
        assert_eq!(noise(&m, 0.5, 7), out);
        assert_ne!(noise(&m, 0.5, 8), out);
        assert_eq!(noise(&m, 0.0, 7), m);
    }
}
