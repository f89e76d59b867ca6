//! Repeated smoothing `x ← H x` with `H = I − F/k` (Zhang 2004 §2.2–2.4).
//!
//! Measures the paper's limit claims per step: the variance
//! `σ²(x) = Σ_i ‖x_i − x̄‖² / n`, and the largest distance of a vertex to the centroid
//! `x̄` and to the valence-weighted centroid `Σ d_i x_i / Σ d_i` of the *input*. Laplacian
//! smoothing with the Tutte Laplacian (row-stochastic H) converges to the
//! valence-weighted centroid; a doubly stochastic H converges to the centroid and never
//! increases the variance. Sign convention of F: `F = D − W`.

use crate::SparseMatrix;
use glam::DVec3;
use serde::Serialize;

/// Why [`iterate`] failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SmoothingError {
    /// `k` must be positive and finite (`H = I − F/k`).
    #[error("k must be positive and finite, got {0}")]
    K(f64),
    /// The operator, positions and degrees do not describe the same n vertices.
    #[error("the operator is {rows}×{cols}, with {positions} positions and {degrees} degrees")]
    Sizes {
        /// Operator rows.
        rows: usize,
        /// Operator columns.
        cols: usize,
        /// Positions given.
        positions: usize,
        /// Degrees given.
        degrees: usize,
    },
}

/// One row of [`iterate`]'s output.
#[derive(Clone, Debug, PartialEq, Serialize)]
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

/// Options of [`iterate`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IterateOptions {
    /// The k of `H = I − F/k`, positive; `None` (the default) takes
    /// [`gershgorin_k`], which needs no spectrum and is admissible.
    pub k: Option<f64>,
    /// Applications of H (default 100).
    pub steps: usize,
}

impl Default for IterateOptions {
    fn default() -> Self {
        IterateOptions {
            k: None,
            steps: 100,
        }
    }
}

/// What [`iterate`] computed.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Iteration {
    /// The k used.
    pub k: f64,
    /// Step 0 (the input) to `steps`.
    pub steps: Vec<SmoothingStep>,
    /// The positions after the last step.
    pub positions: Vec<[f64; 3]>,
}

/// Applies `H = I − F/k` `opts.steps` times to the n×3 `positions`, recording every
/// step; F is n×n (`F = D − W`) and the n `degrees` define the valence-weighted
/// centroid.
pub fn iterate(
    f: &SparseMatrix,
    positions: &[[f64; 3]],
    degrees: &[u32],
    opts: &IterateOptions,
) -> Result<Iteration, SmoothingError> {
    let n = positions.len();
    if f.nrows() != n || f.ncols() != n || degrees.len() != n {
        return Err(SmoothingError::Sizes {
            rows: f.nrows(),
            cols: f.ncols(),
            positions: n,
            degrees: degrees.len(),
        });
    }
    let k = match opts.k {
        Some(k) if k > 0.0 && k.is_finite() => k,
        Some(k) => return Err(SmoothingError::K(k)),
        None => gershgorin_k(f),
    };
    let centroid = weighted_mean(positions, |_| 1.0);
    let weighted = weighted_mean(positions, |i| degrees[i] as f64);
    let mut x: Vec<DVec3> = positions.iter().copied().map(DVec3::from).collect();
    let mut out = Vec::with_capacity(opts.steps + 1);
    let record = |step: usize, x: &[DVec3]| {
        let mean = weighted_mean_of(x, |_| 1.0);
        let farthest = |c: DVec3| x.iter().map(|p| p.distance(c)).fold(0.0f64, f64::max);
        SmoothingStep {
            step,
            variance: x.iter().map(|p| p.distance(mean).powi(2)).sum::<f64>() / n as f64,
            distance_to_centroid: farthest(centroid),
            distance_to_weighted_centroid: farthest(weighted),
        }
    };
    out.push(record(0, &x));
    let mut y = vec![DVec3::ZERO; n];
    for s in 1..=opts.steps {
        y.copy_from_slice(&x);
        for j in 0..n {
            let xj = x[j];
            for (&i, &v) in f.row_idx_of_col_raw(j).iter().zip(f.val_of_col(j)) {
                y[i] -= (v / k) * xj;
            }
        }
        std::mem::swap(&mut x, &mut y);
        out.push(record(s, &x));
    }
    Ok(Iteration {
        k,
        steps: out,
        positions: x.iter().map(|p| p.to_array()).collect(),
    })
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

fn weighted_mean(x: &[[f64; 3]], w: impl Fn(usize) -> f64) -> DVec3 {
    let points: Vec<DVec3> = x.iter().copied().map(DVec3::from).collect();
    weighted_mean_of(&points, w)
}

fn weighted_mean_of(x: &[DVec3], w: impl Fn(usize) -> f64) -> DVec3 {
    let (mut s, mut total) = (DVec3::ZERO, 0.0);
    for (i, p) in x.iter().enumerate() {
        let wi = w(i);
        total += wi;
        s += wi * *p;
    }
    s / total
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
        let opts = IterateOptions {
            k: Some(1.0),
            steps: 400,
        };
        let run = iterate(&tutte(&t).unwrap(), &m.positions, &t.degrees(), &opts).unwrap();
        let last = run.steps.last().unwrap();
        assert!(last.distance_to_weighted_centroid < 1e-8, "{last:?}");
        assert!(last.distance_to_centroid > 1e-3, "{last:?}");
    }

    #[test]
    fn doubly_stochastic_converges_to_centroid_without_variance_increase() {
        let m = builtin::cube(3).unwrap();
        let t = Topology::new(&m).unwrap();
        let k = *t.degrees().iter().max().unwrap() as f64 + 1.0;
        let opts = IterateOptions {
            k: Some(k),
            steps: 600,
        };
        let run = iterate(&kirchhoff(&t), &m.positions, &t.degrees(), &opts).unwrap();
        for w in run.steps.windows(2) {
            assert!(w[1].variance <= w[0].variance * (1.0 + 1e-12));
        }
        assert!(run.steps.last().unwrap().distance_to_centroid < 1e-8);
        assert_eq!(run.k, k);
    }

    #[test]
    fn default_k_is_gershgorins_and_bad_input_is_an_error() {
        let m = builtin::cube(2).unwrap();
        let t = Topology::new(&m).unwrap();
        let f = kirchhoff(&t);
        let run = iterate(&f, &m.positions, &t.degrees(), &IterateOptions::default()).unwrap();
        assert_eq!(run.k, gershgorin_k(&f));
        assert_eq!(run.steps.len(), 101);
        assert_eq!(run.positions.len(), m.n_vertices());
        for k in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let opts = IterateOptions {
                k: Some(k),
                steps: 1,
            };
            assert!(matches!(
                iterate(&f, &m.positions, &t.degrees(), &opts),
                Err(SmoothingError::K(_))
            ));
        }
        assert!(matches!(
            iterate(
                &f,
                &m.positions[1..],
                &t.degrees(),
                &IterateOptions::default()
            ),
            Err(SmoothingError::Sizes { .. })
        ));
    }
}
