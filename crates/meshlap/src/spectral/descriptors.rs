//! Spectral shape descriptors: the heat kernel signature (HKS) and the wave kernel
//! signature (WKS), per vertex, from the k smallest eigenpairs of a Laplacian.
//!
//! **Sign convention.** The eigenpairs come from a positive semi-definite operator
//! `F = D − W` (or `L v = λ M v` with the cotangent stiffness `L` and its lumped mass
//! `M`), eigenvalues ascending `0 = λ₀ ≤ λ₁ ≤ …`; the eigenvectors `φ_i` are
//! orthonormal (`M`-orthonormal with a mass), as [`crate::spectral::partial`] returns
//! them. libigl's and pmp's negative sign would flip every exponent below.
//!
//! ## Heat kernel signature
//! Sun, Ovsjanikov & Guibas, *A concise and provably informative multi-scale
//! signature based on heat diffusion* (SGP 2009): the heat that stays at vertex x
//! after time t,
//!
//! ```text
//! HKS(x, t) = k_t(x, x) = Σ_i exp(−λ_i t) φ_i(x)²
//! ```
//!
//! over the computed eigenpairs. Default times ([`default_times`]): the paper samples
//! t logarithmically over `[t_min, t_max] = [4 ln 10 / λ_max, 4 ln 10 / λ_1]`, with
//! `λ_1` the smallest non-zero and `λ_max` the largest computed eigenvalue (100 times
//! in the paper; the count is a parameter).
//!
//! ## Wave kernel signature
//! Aubry, Schlickewei & Cremers, *The wave kernel signature: a quantum mechanical
//! approach to shape analysis* (ICCV workshops 2011): the probability of finding a
//! quantum particle with log-energy distribution centred at e at vertex x,
//!
//! ```text
//! WKS(x, e) = Σ_i φ_i(x)² exp(−(e − log λ_i)² / 2σ²) / Σ_i exp(−(e − log λ_i)² / 2σ²)
//! ```
//!
//! over the non-zero eigenvalues (`λ_i > 10⁻⁹·λ_max`; the zero eigenvalue has no
//! logarithm). Default energies ([`default_energies`]): the paper's
//! `e_min = log λ_1 + 2σ`, `e_max = log λ_max − 2σ`, M energies linearly spaced with
//! increment `δ = (e_max − e_min)/(M − 1)` and `σ = 7δ`; solved for δ this is
//! `δ = (log λ_max − log λ_1)/(M + 27)`. For user-given energies σ defaults to seven
//! times their mean increment.

use crate::operator::Operator;
use crate::spectral::partial::{operator_partial_spectrum, PartialParams};
use crate::spectral::SpectralError;
use faer::{Mat, MatRef};

/// Errors of [`hks`], [`wks`] and [`descriptors`].
#[derive(Debug, thiserror::Error)]
pub enum DescriptorError {
    /// The eigenvalues and eigenvectors do not match (k values against an n×k' matrix).
    /// Pass the matrix whose column j belongs to eigenvalue j.
    #[error("{values} eigenvalues for an eigenvector matrix with {columns} columns")]
    Shape {
        /// Eigenvalues given.
        values: usize,
        /// Eigenvector columns given.
        columns: usize,
    },
    /// An eigenvalue, time, energy or σ is NaN or infinite, or an eigenvalue is
    /// negative beyond rounding (`< −10⁻⁹·λ_max`): the operator was not positive
    /// semi-definite (libigl's sign? negate it).
    #[error("{what} {index} is {value}; {expected}")]
    BadValue {
        /// Which input.
        what: &'static str,
        /// Its position.
        index: usize,
        /// The value.
        value: f64,
        /// What is required.
        expected: &'static str,
    },
    /// The default sampling needs at least two distinct non-zero eigenvalues.
    /// Compute more eigenpairs.
    #[error("the default {what} need at least two distinct non-zero eigenvalues; compute more eigenpairs")]
    TooFewEigenvalues {
        /// `times` or `energies`.
        what: &'static str,
    },
    /// A count (of times, energies or eigenpairs) is zero or more than the matrix has.
    #[error("{what} must be in 1..={max}, got {got}")]
    Count {
        /// Which count.
        what: &'static str,
        /// The value given.
        got: usize,
        /// The largest allowed.
        max: usize,
    },
    /// The eigenpairs could not be computed.
    #[error(transparent)]
    Eigen(#[from] SpectralError),
}

/// Eigenvalues below this fraction of the largest are treated as zero by the WKS and
/// skipped when choosing `λ_1` for the default samplings.
pub const ZERO_EIGENVALUE: f64 = 1e-9;

fn check(evals: &[f64], evecs: MatRef<'_, f64>) -> Result<f64, DescriptorError> {
    if evals.len() != evecs.ncols() {
        return Err(DescriptorError::Shape {
            values: evals.len(),
            columns: evecs.ncols(),
        });
    }
    let lmax = evals.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
    for (index, &value) in evals.iter().enumerate() {
        if !value.is_finite() || value < -ZERO_EIGENVALUE * lmax.max(1.0) {
            return Err(DescriptorError::BadValue {
                what: "eigenvalue",
                index,
                value,
                expected: "eigenvalues must be finite and non-negative (sign F = D − W)",
            });
        }
    }
    Ok(lmax)
}

fn check_finite(what: &'static str, xs: &[f64], positive: bool) -> Result<(), DescriptorError> {
    for (index, &value) in xs.iter().enumerate() {
        if !value.is_finite() || (positive && value <= 0.0) {
            return Err(DescriptorError::BadValue {
                what,
                index,
                value,
                expected: if positive {
                    "it must be positive and finite"
                } else {
                    "it must be finite"
                },
            });
        }
    }
    Ok(())
}

/// The smallest and largest non-zero eigenvalues (`λ_1`, `λ_max`), if distinct.
fn positive_range(
    evals: &[f64],
    lmax: f64,
    what: &'static str,
) -> Result<(f64, f64), DescriptorError> {
    let lo = evals
        .iter()
        .copied()
        .filter(|&l| l > ZERO_EIGENVALUE * lmax)
        .fold(f64::INFINITY, f64::min);
    if !(lo.is_finite() && lmax > lo) {
        return Err(DescriptorError::TooFewEigenvalues { what });
    }
    Ok((lo, lmax))
}

/// Sun et al.'s default HKS times: `count` values log-spaced over
/// `[4 ln 10 / λ_max, 4 ln 10 / λ_1]`, ascending.
pub fn default_times(evals: &[f64], count: usize) -> Result<Vec<f64>, DescriptorError> {
    if count == 0 {
        return Err(DescriptorError::Count {
            what: "the number of times",
            got: 0,
            max: usize::MAX,
        });
    }
    let lmax = evals.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
    let (lo, hi) = positive_range(evals, lmax, "times")?;
    let c = 4.0 * std::f64::consts::LN_10;
    let (a, b) = ((c / hi).ln(), (c / lo).ln());
    Ok(linspace(a, b, count).into_iter().map(f64::exp).collect())
}

/// Aubry et al.'s default WKS log-energies and σ: `count` energies from
/// `log λ_1 + 2σ` to `log λ_max − 2σ`, `σ = 7δ`, δ their increment.
pub fn default_energies(evals: &[f64], count: usize) -> Result<(Vec<f64>, f64), DescriptorError> {
    if count == 0 {
        return Err(DescriptorError::Count {
            what: "the number of energies",
            got: 0,
            max: usize::MAX,
        });
    }
    let lmax = evals.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
    let (lo, hi) = positive_range(evals, lmax, "energies")?;
    let delta = (hi.ln() - lo.ln()) / (count as f64 + 27.0);
    let sigma = 7.0 * delta;
    let e_min = lo.ln() + 2.0 * sigma;
    Ok((
        (0..count).map(|i| e_min + i as f64 * delta).collect(),
        sigma,
    ))
}

/// σ for user-given energies: seven times their mean increment (1 for one energy).
pub fn default_sigma(energies: &[f64]) -> f64 {
    match energies {
        [] | [_] => 1.0,
        [first, .., last] => 7.0 * ((last - first) / (energies.len() - 1) as f64).abs(),
    }
}

fn linspace(a: f64, b: f64, count: usize) -> Vec<f64> {
    if count == 1 {
        return vec![0.5 * (a + b)];
    }
    (0..count)
        .map(|i| a + (b - a) * i as f64 / (count - 1) as f64)
        .collect()
}

/// The heat kernel signature, n×T: `HKS(x, t) = Σ_i exp(−λ_i t) φ_i(x)²` (see the
/// module documentation). `evals` (k, ascending, `F = D − W`), `evecs` n×k (column i
/// belongs to `evals[i]`), `times` (T, positive).
pub fn hks(
    evals: &[f64],
    evecs: MatRef<'_, f64>,
    times: &[f64],
) -> Result<Mat<f64>, DescriptorError> {
    check(evals, evecs)?;
    check_finite("time", times, true)?;
    let n = evecs.nrows();
    let mut out = Mat::zeros(n, times.len());
    for (i, &lambda) in evals.iter().enumerate() {
        let col = evecs.col(i);
        for (t, &time) in times.iter().enumerate() {
            let w = (-lambda.max(0.0) * time).exp();
            for x in 0..n {
                out[(x, t)] += w * col[x] * col[x];
            }
        }
    }
    Ok(out)
}

/// The wave kernel signature, n×E: `WKS(x, e)` of the module documentation, for
/// log-energies `energies` and Gaussian width `sigma` (positive). Zero eigenvalues
/// (`≤ 10⁻⁹·λ_max`) are skipped.
pub fn wks(
    evals: &[f64],
    evecs: MatRef<'_, f64>,
    energies: &[f64],
    sigma: f64,
) -> Result<Mat<f64>, DescriptorError> {
    let lmax = check(evals, evecs)?;
    check_finite("energy", energies, false)?;
    check_finite("sigma", &[sigma], true)?;
    let n = evecs.nrows();
    let mut out = Mat::zeros(n, energies.len());
    let mut norm = vec![0.0f64; energies.len()];
    for (i, &lambda) in evals.iter().enumerate() {
        if lambda <= ZERO_EIGENVALUE * lmax {
            continue;
        }
        let log_l = lambda.ln();
        let col = evecs.col(i);
        for (e, &energy) in energies.iter().enumerate() {
            let w = (-(energy - log_l).powi(2) / (2.0 * sigma * sigma)).exp();
            norm[e] += w;
            for x in 0..n {
                out[(x, e)] += w * col[x] * col[x];
            }
        }
    }
    for (e, &c) in norm.iter().enumerate() {
        let s = if c > 0.0 { 1.0 / c } else { 0.0 };
        for x in 0..n {
            out[(x, e)] *= s;
        }
    }
    Ok(out)
}

/// Parameters of [`descriptors`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DescriptorParams {
    /// Eigenpairs computed (k, at most n): Sun et al. use 300; the default 100 keeps
    /// large meshes fast.
    pub eigenpairs: usize,
    /// HKS columns (default times).
    pub hks: usize,
    /// WKS columns (default energies).
    pub wks: usize,
}

impl Default for DescriptorParams {
    fn default() -> Self {
        Self {
            eigenpairs: 100,
            hks: 16,
            wks: 0,
        }
    }
}

/// The descriptors of an operator and the eigenpairs they came from.
#[derive(Clone, Debug)]
pub struct Descriptors {
    /// n×(hks + wks): the HKS columns (ascending t), then the WKS columns (ascending e).
    pub values: Mat<f64>,
    /// The HKS times.
    pub times: Vec<f64>,
    /// The WKS log-energies.
    pub energies: Vec<f64>,
    /// The WKS σ (0 without WKS columns).
    pub sigma: f64,
    /// The eigenvalues used (ascending).
    pub eigenvalues: Vec<f64>,
}

/// HKS and WKS of an assembled operator with the default samplings: the
/// `min(eigenpairs, n)` smallest eigenpairs by [`operator_partial_spectrum`] (the
/// cotangent operator with its mass, the TL through its symmetrizer), then [`hks`]
/// and [`wks`].
pub fn descriptors(
    op: &Operator,
    params: &DescriptorParams,
) -> Result<Descriptors, DescriptorError> {
    let n = op.matrix.nrows();
    if params.eigenpairs < 2 {
        return Err(DescriptorError::Count {
            what: "eigenpairs",
            got: params.eigenpairs,
            max: n,
        });
    }
    if params.hks + params.wks == 0 {
        return Err(DescriptorError::Count {
            what: "hks + wks columns",
            got: 0,
            max: usize::MAX,
        });
    }
    let k = params.eigenpairs.min(n);
    let ps = operator_partial_spectrum(op, true, &PartialParams::new(k), &mut |_, _| {})?;
    let vecs = ps.eigenvectors.as_ref();
    let times = if params.hks > 0 {
        default_times(&ps.eigenvalues, params.hks)?
    } else {
        vec![]
    };
    let (energies, sigma) = if params.wks > 0 {
        default_energies(&ps.eigenvalues, params.wks)?
    } else {
        (vec![], 0.0)
    };
    let h = hks(&ps.eigenvalues, vecs, &times)?;
    let w = if energies.is_empty() {
        Mat::zeros(n, 0)
    } else {
        wks(&ps.eigenvalues, vecs, &energies, sigma)?
    };
    let values = Mat::from_fn(n, h.ncols() + w.ncols(), |i, j| {
        if j < h.ncols() {
            h[(i, j)]
        } else {
            w[(i, j - h.ncols())]
        }
    });
    Ok(Descriptors {
        values,
        times,
        energies,
        sigma,
        eigenvalues: ps.eigenvalues,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{builtin, topology::Topology};
    use crate::operator::{OperatorKind, OperatorOptions};
    use crate::spectral::{BasisOptions, EigenBasis};

    fn sphere_op(kind: OperatorKind) -> Operator {
        let m = builtin::icosphere(2).unwrap();
        let t = Topology::new(&m).unwrap();
        Operator::assemble(kind, &m, &t, &OperatorOptions::default()).unwrap()
    }

    /// On the full spectrum of a symmetric operator the HKS is the diagonal of
    /// `exp(−tF)`; cross-checked against a Taylor series of the matrix exponential.
    #[test]
    fn hks_full_spectrum_is_the_heat_kernel_diagonal() {
        let op = sphere_op(OperatorKind::Kirchhoff);
        let basis = EigenBasis::compute(&op, &BasisOptions::default()).unwrap();
        let t = 0.05;
        let h = hks(basis.eigenvalues(), basis.vectors(), &[t]).unwrap();
        let f = op.matrix.to_dense();
        let n = f.nrows();
        // exp(−tF) by scaling and squaring of a Taylor series.
        let s = 8;
        let a = &f * faer::Scale(-t / f64::from(1 << s));
        let mut e = Mat::<f64>::identity(n, n);
        let mut term = Mat::<f64>::identity(n, n);
        for j in 1..20 {
            term = &term * &a * faer::Scale(1.0 / j as f64);
            e += &term;
        }
        for _ in 0..s {
            e = &e * &e;
        }
        for x in 0..n {
            assert!(
                (h[(x, 0)] - e[(x, x)]).abs() < 1e-10,
                "{x}: {} vs {}",
                h[(x, 0)],
                e[(x, x)]
            );
        }
    }

    /// WKS columns are convex combinations of the φ_i(x)², so each sums to 1 over x
    /// for orthonormal eigenvectors; HKS at t → 0 sums to k.
    #[test]
    fn wks_columns_sum_to_one_and_defaults_follow_the_papers() {
        let op = sphere_op(OperatorKind::Cotan);
        let d = descriptors(
            &op,
            &DescriptorParams {
                eigenpairs: 40,
                hks: 5,
                wks: 6,
            },
        )
        .unwrap();
        assert_eq!(d.values.ncols(), 11);
        let mass = op.mass.as_ref().unwrap();
        for j in 5..11 {
            let s: f64 = (0..d.values.nrows())
                .map(|x| mass[x] * d.values[(x, j)])
                .sum();
            assert!((s - 1.0).abs() < 1e-9, "WKS column {j} sums to {s}");
        }
        let l1 = d.eigenvalues[1];
        let lmax = *d.eigenvalues.last().unwrap();
        let c = 4.0 * std::f64::consts::LN_10;
        assert!((d.times[0] - c / lmax).abs() < 1e-12 * d.times[0]);
        assert!((d.times[4] - c / l1).abs() < 1e-9 * d.times[4]);
        let delta = d.energies[1] - d.energies[0];
        assert!((d.sigma - 7.0 * delta).abs() < 1e-12);
        assert!((d.energies[0] - (l1.ln() + 2.0 * d.sigma)).abs() < 1e-12);
        assert!((d.energies[5] - (lmax.ln() - 2.0 * d.sigma)).abs() < 1e-9);
    }

    #[test]
    fn bad_inputs_are_typed_errors() {
        let v = Mat::<f64>::zeros(4, 2);
        assert!(matches!(
            hks(&[0.0, 1.0, 2.0], v.as_ref(), &[1.0]),
            Err(DescriptorError::Shape { .. })
        ));
        assert!(matches!(
            hks(&[0.0, -1.0], v.as_ref(), &[1.0]),
            Err(DescriptorError::BadValue { .. })
        ));
        assert!(matches!(
            hks(&[0.0, 1.0], v.as_ref(), &[-1.0]),
            Err(DescriptorError::BadValue { .. })
        ));
        assert!(matches!(
            wks(&[0.0, 1.0], v.as_ref(), &[f64::NAN], 1.0),
            Err(DescriptorError::BadValue { .. })
        ));
        assert!(matches!(
            default_times(&[0.0, 0.0], 3),
            Err(DescriptorError::TooFewEigenvalues { .. })
        ));
    }
}
