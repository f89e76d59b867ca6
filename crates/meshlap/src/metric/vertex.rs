//! Vertex-to-vertex errors between two embeddings of the same connectivity: the one
//! measure used by `meshlap project`, `compare`, the experiments and the filters'
//! reports.

use glam::DVec3;
use serde::Serialize;

/// Errors of `b` against `a` (same vertex count and order).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct VertexErrors {
    /// `‖a − b‖_F / ‖a‖_F` over all coordinates (0 when `a` is all zeros).
    pub relative: f64,
    /// `sqrt(mean_i ‖a_i − b_i‖²)` divided by the normaliser.
    pub rms: f64,
    /// `max_i ‖a_i − b_i‖` divided by the normaliser.
    pub max: f64,
}

/// Vertex errors of `b` against `a`, with `rms` and `max` divided by `normalizer`
/// (usually `a`'s bounding-box diagonal; values ≤ 0 are treated as 1). `a` and `b`
/// are n×3 (n positions each); only the first `min(len)` are compared.
pub fn vertex_errors(a: &[[f64; 3]], b: &[[f64; 3]], normalizer: f64) -> VertexErrors {
    let (mut err2, mut norm2, mut max2) = (0.0f64, 0.0f64, 0.0f64);
    let n = a.len().min(b.len());
    for (p, q) in a.iter().zip(b) {
        let (p, q) = (DVec3::from(*p), DVec3::from(*q));
        let d2 = (p - q).length_squared();
        err2 += d2;
        norm2 += p.length_squared();
        max2 = max2.max(d2);
    }
    let s = if normalizer > 0.0 { normalizer } else { 1.0 };
    VertexErrors {
        relative: if norm2 > 0.0 {
            (err2 / norm2).sqrt()
        } else {
            0.0
        },
        rms: (err2 / n.max(1) as f64).sqrt() / s,
        max: max2.sqrt() / s,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_of_a_known_displacement() {
        let a = [[3.0, 0.0, 0.0], [0.0, 4.0, 0.0]];
        let b = [[3.0, 0.0, 1.0], [0.0, 4.0, 0.0]];
        let e = vertex_errors(&a, &b, 2.0);
        assert_eq!(e.relative, 1.0 / 5.0);
        assert_eq!(e.max, 0.5);
        assert!((e.rms - (0.5f64).sqrt() / 2.0).abs() < 1e-15);
        assert_eq!(vertex_errors(&a, &a, 1.0), VertexErrors::default());
    }
}
