//! Polynomial filters: explicit Laplacian smoothing `x' = (I − λF)ᴺ x` (Taubin 1995,
//! "Laplacian smoothing") and Taubin's non-shrinking λ|μ smoothing
//! `x' = ((I − λF)(I − μF))ᴺ x` with μ < −λ < 0 and pass-band `k_PB = 1/λ + 1/μ`
//! (Taubin 1995, *A signal processing approach to fair surface design*).
//!
//! F is n×n with the sign `F = D − W` (positive semi-definite), so `−F·x` points
//! towards the neighbors and `(I − λF)` averages; positions are the n×3 row-major
//! block. Responses on an eigenvalue γ of F: `(1 − λγ)ᴺ` and `((1 − λγ)(1 − μγ))ᴺ`.
//! Boundary vertices are treated like interior ones (whatever F does at the
//! boundary). For the Tutte Laplacian (γ ∈ [0, 2]) the explicit filter is stable for
//! 0 < λ ≤ 1.

use super::options::positive;
use super::{ExplicitOptions, Filter, FilterError, TaubinOptions};
use crate::solve::{CsrMatrix, LinOp};

/// `x ← (I − t F) x` for each t of `seq`, with F n×n and `x` n×3 row-major.
pub fn polynomial_steps(f: &CsrMatrix, x: &mut [f64], seq: &[f64]) -> Result<(), FilterError> {
    let n = f.nrows();
    if x.len() != 3 * n || f.ncols() != n {
        return Err(FilterError::Positions { len: x.len(), n });
    }
    let mut y = vec![0.0; x.len()];
    for &t in seq {
        f.apply(x, &mut y, 3);
        for (xi, yi) in x.iter_mut().zip(&y) {
            *xi -= t * yi;
        }
    }
    Ok(())
}

/// Taubin's μ for a given λ and pass-band: `1/μ = k_PB − 1/λ`. Requires λ > 0 and
/// 0 < k_PB < 1/λ (so that μ < −λ).
pub fn taubin_mu(lambda: f64, k_pb: f64) -> Result<f64, FilterError> {
    positive(lambda, "λ")?;
    positive(k_pb, "Taubin's pass-band k_PB")?;
    if k_pb >= 1.0 / lambda {
        return Err(FilterError::TaubinPassband {
            k_pb,
            limit: 1.0 / lambda,
        });
    }
    Ok(1.0 / (k_pb - 1.0 / lambda))
}

/// Response of `steps` explicit steps at eigenvalue γ: `(1 − λγ)ᴺ`.
pub fn explicit_response(lambda: f64, steps: usize, gamma: f64) -> f64 {
    (1.0 - lambda * gamma).powi(steps as i32)
}

/// Response of `steps` Taubin pairs at eigenvalue γ: `((1 − λγ)(1 − μγ))ᴺ`.
pub fn taubin_response(lambda: f64, mu: f64, steps: usize, gamma: f64) -> f64 {
    ((1.0 - lambda * gamma) * (1.0 - mu * gamma)).powi(steps as i32)
}

/// Explicit Laplacian smoothing `x ← (I − λF)ᴺ x` of the n×3 row-major `x`.
pub fn explicit(f: &CsrMatrix, x: &mut [f64], opts: &ExplicitOptions) -> Result<(), FilterError> {
    Filter::Explicit(*opts).validate()?;
    polynomial_steps(f, x, &vec![opts.lambda; opts.steps])
}

/// Taubin λ|μ smoothing of the n×3 row-major `x`: `steps` pairs
/// `x ← (I − μF)(I − λF) x`.
pub fn taubin(f: &CsrMatrix, x: &mut [f64], opts: &TaubinOptions) -> Result<(), FilterError> {
    Filter::Taubin(*opts).validate()?;
    let mu = taubin_mu(opts.lambda, opts.k_pb)?;
    let seq: Vec<f64> = (0..opts.steps).flat_map(|_| [opts.lambda, mu]).collect();
    polynomial_steps(f, x, &seq)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::preserve::volume;
    use crate::mesh::{builtin, topology::Topology};
    use crate::operator::tutte::tutte;

    #[test]
    fn responses_match_the_operator_on_eigenvectors() {
        // The Kirchhoff operator is symmetric: check h(γ)·u on its eigenvectors.
        let m = builtin::icosphere(1).unwrap();
        let t = Topology::new(&m).unwrap();
        let k = crate::operator::kirchhoff::kirchhoff(&t);
        let evd = k.to_dense().self_adjoint_eigen(faer::Side::Lower).unwrap();
        let a = CsrMatrix::from_csc(&k);
        let n = m.n_vertices();
        let (lambda, k_pb) = (0.05, 0.02);
        let mu = taubin_mu(lambda, k_pb).unwrap();
        for idx in [0, 5, n / 2, n - 1] {
            let g = evd.S()[idx];
            let u: Vec<f64> = (0..n).flat_map(|i| [evd.U()[(i, idx)], 0.0, 0.0]).collect();
            let mut x = u.clone();
            explicit(&a, &mut x, &ExplicitOptions { lambda, steps: 4 }).unwrap();
            let h = explicit_response(lambda, 4, g);
            let mut y = u.clone();
            let pairs = TaubinOptions {
                lambda,
                k_pb,
                steps: 3,
            };
            taubin(&a, &mut y, &pairs).unwrap();
            let ht = taubin_response(lambda, mu, 3, g);
            for j in 0..3 * n {
                assert!((x[j] - h * u[j]).abs() < 1e-12);
                assert!((y[j] - ht * u[j]).abs() < 1e-12);
            }
        }
    }

    /// The γ where a decreasing response first falls to 1/2 (bisection on [lo, hi]).
    fn half_point(h: impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> f64 {
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if h(mid) > 0.5 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    }

    #[test]
    fn taubin_shrinks_less_than_laplacian_smoothing_at_equal_pass_band() {
        let mut m = builtin::icosphere(3).unwrap();
        for (i, p) in m.positions.iter_mut().enumerate() {
            let s = 1.0 + 0.05 * ((i * 7919) % 13) as f64 / 13.0;
            *p = p.map(|c| c * s);
        }
        let t = Topology::new(&m).unwrap();
        let f = CsrMatrix::from_csc(&tutte(&t).unwrap());
        let (lambda, k_pb, pairs) = (0.5, 0.1, 10);
        let mu = taubin_mu(lambda, k_pb).unwrap();
        // Pass-band = where the response drops to 1/2; give Laplacian smoothing the
        // same one with the same number of operator applications.
        let g_half = half_point(
            |g| taubin_response(lambda, mu, pairs, g),
            k_pb,
            1.0 / lambda,
        );
        let steps = 2 * pairs;
        let lambda_l = (1.0 - 0.5f64.powf(1.0 / steps as f64)) / g_half;
        assert!((explicit_response(lambda_l, steps, g_half) - 0.5).abs() < 1e-9);
        let x0: Vec<f64> = m.positions.iter().flat_map(|p| *p).collect();
        let (mut xl, mut xt) = (x0.clone(), x0.clone());
        let laplacian = ExplicitOptions {
            lambda: lambda_l,
            steps,
        };
        explicit(&f, &mut xl, &laplacian).unwrap();
        let opts = TaubinOptions {
            lambda,
            k_pb,
            steps: pairs,
        };
        taubin(&f, &mut xt, &opts).unwrap();
        let vol = |x: &[f64]| {
            let p: Vec<[f64; 3]> = x.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
            volume(&p, &m.faces)
        };
        let (v0, vl, vt) = (vol(&x0), vol(&xl), vol(&xt));
        // Both smooth (the noise goes), Laplacian smoothing shrinks, Taubin hardly.
        assert!(vl < 0.99 * v0, "laplacian {vl} vs {v0}");
        assert!(
            (vt - v0).abs() < 0.25 * (vl - v0).abs(),
            "taubin {vt}, laplacian {vl}, input {v0}"
        );
    }

    #[test]
    fn taubin_parameters_are_checked() {
        assert!(matches!(
            taubin_mu(0.5, 3.0),
            Err(FilterError::TaubinPassband { .. })
        ));
        assert!(taubin_mu(-0.5, 0.1).is_err());
        assert!(taubin_mu(0.5, f64::NAN).is_err());
        let mu = taubin_mu(0.5, 0.1).unwrap();
        assert!(mu < -0.5);
        assert!((1.0 / 0.5 + 1.0 / mu - 0.1).abs() < 1e-14);
        let f = CsrMatrix::from_csc(&crate::operator::kirchhoff::kirchhoff(
            &Topology::new(&builtin::icosahedron()).unwrap(),
        ));
        let mut short = vec![0.0; 35];
        assert!(matches!(
            explicit(&f, &mut short, &ExplicitOptions::default()),
            Err(FilterError::Positions { .. })
        ));
        let mut x = vec![0.0; 36];
        let zero = ExplicitOptions {
            steps: 0,
            ..Default::default()
        };
        assert!(matches!(
            explicit(&f, &mut x, &zero),
            Err(FilterError::NoSteps { .. })
        ));
    }
}
