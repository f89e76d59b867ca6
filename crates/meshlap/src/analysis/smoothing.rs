//! Repeated smoothing `x ← H x` with `H = I − F/k` (Zhang 2004 §2.2–2.4).
//!
//! Measures the paper's limit claims per step: the variance
//! `σ²(x) = Σ_i ‖x_i − x̄‖² / n`, and the largest distance of a vertex to the centroid
//! `x̄` and to the valence-weighted centroid `Σ d_i x_i / Σ d_i` of the *input*. Laplacian
//! smoothing with the Tutte Laplacian (row-stochastic H) converges to the
//! valence-weighted centroid; a doubly stochastic H converges to the centroid and never
//! increases the variance. Sign convention of F: `F = D − W`.

use crate::SparseMatrix;
use serde::Serialize;

/// One row of [`iterate`]'s output.
#[derive(Clone, Debug, Serialize)]
pub struct SmoothingStep {
    /// Number of applications of H so far (0 = input).
    pub step: usize,
    /// `σ²(Hᵖx)`.
    pub variance: f64,
    /// `max_i ‖(Hᵖx)_i − x̄‖`, x̄ the centroid of the input.
    pub distance_to_centroid: f64,
    /// `max_i ‖(Hᵖx)_i − x̃‖`, x̃ the valence-weighted centroid of the input.
    pub distance_to_weighted_centroid: f64,
}

/// Applies `H = I − F/k` `steps` times to the n×3 `positions`, recording every step;
/// `degrees` define the valence-weighted centroid. Returns the steps and the final
/// positions.
pub fn iterate(
    f: &SparseMatrix,
    k: f64,
    positions: &[[f64; 3]],
    degrees: &[u32],
    steps: usize,
) -> (Vec<SmoothingStep>, Vec<[f64; 3]>) {
    let n = positions.len();
    let centroid = weighted_mean(positions, |_| 1.0);
    let weighted = weighted_mean(positions, |i| degrees[i] as f64);
    let mut x = positions.to_vec();
    let mut out = Vec::with_capacity(steps + 1);
    let record = |step: usize, x: &[[f64; 3]]| {
        let mean = weighted_mean(x, |_| 1.0);
        let farthest = |c: [f64; 3]| x.iter().map(|p| dist(*p, c)).fold(0.0f64, f64::max);
        SmoothingStep {
            step,
            variance: x.iter().map(|p| dist(*p, mean).powi(2)).sum::<f64>() / n as f64,
            distance_to_centroid: farthest(centroid),
            distance_to_weighted_centroid: farthest(weighted),
        }
    };
    out.push(record(0, &x));
    let mut y = vec![[0.0; 3]; n];
    for s in 1..=steps {
        y.copy_from_slice(&x);
        for j in 0..n {
            let xj = x[j];
            for (&i, &v) in f.row_idx_of_col_raw(j).iter().zip(f.val_of_col(j)) {
                let c = v / k;
                for d in 0..3 {
                    y[i][d] -= c * xj[d];
                }
            }
        }
        std::mem::swap(&mut x, &mut y);
        out.push(record(s, &x));
    }
    (out, x)
}

/// An admissible k for `H = I − F/k` computed without a spectrum:
/// `max(max_i F_ii, g/2)` with g Gershgorin's bound on λ_max, so `k ≥ λ_max/2` and H's
/// diagonal is nonnegative.
pub fn gershgorin_k(f: &SparseMatrix) -> f64 {
    let n = f.nrows();
    let mut diag = vec![0.0f64; n];
    let mut off = vec![0.0f64; n];
    for j in 0..n {
        for (&i, &v) in f.row_idx_of_col_raw(j).iter().zip(f.val_of_col(j)) {
            if i == j {
                diag[i] += v;
            } else {
                off[i] += v.abs();
            }
        }
    }
    (0..n)
        .map(|i| diag[i].max(0.5 * (diag[i] + off[i])))
        .fold(f64::MIN_POSITIVE, f64::max)
}

fn weighted_mean(x: &[[f64; 3]], w: impl Fn(usize) -> f64) -> [f64; 3] {
    let mut s = [0.0; 3];
    let mut total = 0.0;
    for (i, p) in x.iter().enumerate() {
        let wi = w(i);
        total += wi;
        for d in 0..3 {
            s[d] += wi * p[d];
        }
    }
    s.map(|c| c / total)
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{builtin, topology::Topology};
    use crate::operator::{kirchhoff::kirchhoff, tutte::tutte};

    #[test]
    fn tutte_converges_to_the_valence_weighted_centroid() {
        // The cube has degrees 4..6, so the two centroids differ.
        let mut m = builtin::cube(3).unwrap();
        for p in &mut m.positions {
            p[0] = p[0] * 1.5 + 0.3 * p[1] * p[1];
        }
        let t = Topology::new(&m).unwrap();
        let (steps, _) = iterate(&tutte(&t).unwrap(), 1.0, &m.positions, &t.degrees(), 400);
        let last = steps.last().unwrap();
        assert!(last.distance_to_weighted_centroid < 1e-8, "{last:?}");
        assert!(last.distance_to_centroid > 1e-3, "{last:?}");
    }

    #[test]
    fn doubly_stochastic_converges_to_centroid_without_variance_increase() {
        let m = builtin::cube(3).unwrap();
        let t = Topology::new(&m).unwrap();
        let k = *t.degrees().iter().max().unwrap() as f64 + 1.0;
        let (steps, _) = iterate(&kirchhoff(&t), k, &m.positions, &t.degrees(), 600);
        for w in steps.windows(2) {
            assert!(w[1].variance <= w[0].variance * (1.0 + 1e-12));
        }
        assert!(steps.last().unwrap().distance_to_centroid < 1e-8);
    }
}
