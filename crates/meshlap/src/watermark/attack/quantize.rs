//! Coordinate quantization (the benchmark's "quantization"): along each axis the
//! bounding-box side `[lo, hi]` is sampled by `2ˣ` levels `lo + q·s`,
//! `s = (hi − lo)/(2ˣ − 1)`, `q = 0 … 2ˣ − 1`, and each coordinate is replaced by the
//! nearest level (error at most `s/2`). A flat axis (`hi = lo`) is left unchanged.

use crate::mesh::TriMesh;

/// `mesh` with its coordinates quantized to `bits` bits over its bounding box
/// (1 ≤ bits ≤ 52; connectivity and vertex order unchanged).
pub fn quantize(mesh: &TriMesh, bits: u32) -> TriMesh {
    let Some((lo, hi)) = mesh.bounding_box() else {
        return mesh.clone();
    };
    let levels = ((1u64 << bits.clamp(1, 52)) - 1) as f64;
    let step = [0, 1, 2].map(|k| (hi[k] - lo[k]) / levels);
    let positions = mesh
        .positions
        .iter()
        .map(|p| {
            [0, 1, 2].map(|k| {
                if step[k] > 0.0 {
                    let q = ((p[k] - lo[k]) / step[k]).round().clamp(0.0, levels);
                    lo[k] + q * step[k]
                } else {
                    p[k]
                }
            })
        })
        .collect();
    TriMesh::new(positions, mesh.faces.clone())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;

    #[test]
    fn error_is_at_most_half_a_step_and_levels_are_few() {
        let m = builtin::icosphere(3).unwrap();
        for bits in [3, 7, 11] {
            let q = quantize(&m, bits);
            let step = 2.0 / ((1u64 << bits) - 1) as f64; // the unit sphere's side is 2
            let mut xs: Vec<i64> = Vec::new();
            for (p, r) in m.positions.iter().zip(&q.positions) {
                for k in 0..3 {
                    assert!((p[k] - r[k]).abs() <= 0.5 * step * (1.0 + 1e-9));
                }
                xs.push(((r[0] + 1.0) / step).round() as i64);
                assert!((((r[0] + 1.0) / step) - ((r[0] + 1.0) / step).round()).abs() < 1e-6);
            }
            xs.sort_unstable();
            xs.dedup();
            assert!(xs.len() <= 1 << bits);
            assert_eq!(q.faces, m.faces);
        }
        // Already-quantized input is a fixed point.
        let q = quantize(&m, 5);
        let qq = quantize(&q, 5);
        for (a, b) in q.positions.iter().zip(&qq.positions) {
            for k in 0..3 {
                assert!((a[k] - b[k]).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn a_flat_axis_is_kept() {
        let g = builtin::grid(4).unwrap();
        let q = quantize(&g, 2);
        let (lo, hi) = g.bounding_box().unwrap();
        let flat = (0..3).find(|&k| hi[k] == lo[k]).unwrap();
        for (a, b) in g.positions.iter().zip(&q.positions) {
            assert_eq!(a[flat], b[flat]);
        }
    }
}
