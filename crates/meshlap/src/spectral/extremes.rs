//! The extreme eigenvalues of a large sparse symmetric problem and the multiplicity of
//! its zero eigenvalue, without a dense eigendecomposition: what the property report
//! (Zhang 2004, §2: positive semi-definiteness, the simple zero eigenvalue of a GSML,
//! the smoothing bound `k ≥ λ_max/2`) needs at any n.
//!
//! **Sign convention.** Operators are `F = D − W`, positive semi-definite (libigl and
//! pmp use the negative); nothing here assumes definiteness.
//!
//! For `K v = λ M v` (K symmetric n×n, M a positive diagonal or the identity):
//! - `λ_min`: when the inertia count below says no eigenvalue lies below `−τ` and at
//!   least one lies in `[−τ, τ]`, by inverse iteration at `σ = −10⁻⁶τ` (as
//!   [`super::partial::eigenvalue_nearest`]) — a Krylov band at the solver's usual
//!   first shift cannot separate the smallest pair of a tightly clustered low
//!   spectrum (the SSTL); otherwise the smallest eigenpair by the banded
//!   shift-invert solver ([`super::partial`]);
//! - `λ_max`: block Krylov–Schur ([`super::krylov_schur`]) for the eigenvalue of
//!   largest magnitude of `M^{-1/2} K M^{-1/2} + cI`, with `c = max(0, −g)` for a lower
//!   bound `g` of the spectrum (Gershgorin), so that the largest magnitude is
//!   `λ_max + c`, to a residual of only 10⁻³ (the top of a regular grid's spectrum is
//!   too clustered for a Krylov run on `K` to resolve); its Ritz value is a lower
//!   bound, an inertia count certifies an upper one, and a shift-invert Krylov run
//!   with that count's factorization refines the lower one to 10⁻⁹ relative (see
//!   `certified_top`);
//! - the number of eigenvalues in `[−τ, τ]`, `τ = 10⁻⁸·max(1, |λ_max|)`, by
//!   Sylvester's law of inertia: the negative pivots of the LDLᵀ of `K − τM` minus
//!   those of `K + τM` ([`super::partial::eigenvalues_below`]).
//!
//! Every count and shift-invert step shares one symbolic analysis of `K − xM`
//! (METIS' nested dissection takes about 5 s at a million vertices).

use super::krylov_schur::{largest_magnitude, BlockOperator, KrylovSchurParams};
use super::partial::{partial_spectrum, Inertia, PartialParams};
use super::SpectralError;
use crate::SparseMatrix;
use faer::{MatMut, MatRef};
use serde::Serialize;

/// The inverse iteration's shift for `λ_min` when the spectrum starts at zero, as a
/// fraction of `τ` below zero: `(λ₀ + στ)/(λ₁ + στ)` is then tiny unless `λ₁` is
/// itself within rounding of zero.
const ZERO_SHIFT: f64 = 1e-6;

/// The Krylov–Schur run for `λ_max` stops at this residual relative to `|θ|`: it only
/// has to land near the top; [`certified_top`] then pins the eigenvalue down by
/// inertia and a shift-invert step. (A Krylov run to a residual of 10⁻¹⁰ never
/// converged on the million-vertex torus, whose top eigenvalues are spaced about
/// 10⁻⁵ apart: 2,000 restarts, 13 minutes, and no report; to 10⁻⁶ it took 5,232
/// operator applications, against 184 to 10⁻³.)
const LAMBDA_MAX_RESIDUAL: f64 = 1e-3;

/// Relative accuracy of `λ_max` ([`certified_top`]).
const LAMBDA_MAX_REL: f64 = 1e-9;

/// Residual (relative to `|μ|`) of the shift-invert Krylov run of [`certified_top`].
/// The Rayleigh quotient of its vector converges about twice as fast as the residual
/// (its error is of the order of the squared residual over the gap), and the count
/// that follows checks it: on the million-vertex torus 10⁻⁵ put ρ within 7·10⁻¹² of
/// λ_max, and 10⁻⁴ still within 10⁻⁹ (BENCHMARKS.md, "Partial spectra").
const SHIFT_INVERT_RESIDUAL: f64 = 1e-5;

/// Inertia counts at most in [`certified_top`] (each one LDLᵀ); bisection alone needs
/// about 40 from a bracket of relative width 1 to [`LAMBDA_MAX_REL`].
const MAX_COUNTS: usize = 80;

/// `λ_max` from the top Ritz value `theta` of a Krylov run and its residual norm
/// `residual`, certified by inertia to `10⁻⁹|theta|`. Invariant: `lo ≤ λ_max`, and
/// all n eigenvalues lie below `hi` once it is finite.
/// - `theta` is a Rayleigh quotient, so it starts `lo`.
/// - The first count is at `theta + residual/4`, widened (×4) until all n
///   eigenvalues lie below it: that is `hi`; a count short of n raises `lo`. (The
///   nearer `hi` is to λ_max, the faster the shift-invert run below; the top Ritz
///   value of a Krylov run usually lies much closer to λ_max than its residual.)
/// - At each new `hi`, `K − hi·M` is negative definite and its LDLᵀ, just made for
///   the count, is the shift-invert operator whose largest-magnitude eigenvalue is
///   λ_max's: a short block Krylov–Schur run on it gives a vector whose Rayleigh
///   quotient ρ raises `lo` (fast even for the clustered top of a regular grid,
///   since what matters is the gap relative to `hi − λ_max`, not to the spectrum's
///   width). The next count is at `ρ + 10⁻⁹|theta|`: all n below it certifies ρ.
/// - Otherwise (the run found a lower eigenvalue of a cluster, or did not converge)
///   the counts bisect `[lo, hi]`.
///
/// On the million-vertex torus this takes 2 counts and one shift-invert run; the
/// bisection it replaces took 13 counts after a Krylov run 28 times as long (about
/// 19 after a run to 10⁻³). `shift_invert: false` bisects only (tests).
fn certified_top(
    inertia: &Inertia,
    theta: f64,
    residual: f64,
    shift_invert: bool,
) -> Result<f64, SpectralError> {
    let n = inertia.dim();
    let tol = LAMBDA_MAX_REL * theta.abs().max(f64::MIN_POSITIVE);
    let mut lo = theta;
    let mut hi = f64::INFINITY;
    let mut step = (0.25 * residual).max(tol).max(f64::MIN_POSITIVE);
    let mut probe = theta + step;
    // Width of `[lo, hi]` at the last shift-invert run: another one is worth its
    // solves only once the bracket has narrowed to a quarter of that.
    let mut last_run = f64::INFINITY;
    // The probe is `lo + tol`: all n below it certifies `lo`.
    let mut certifying = false;
    for _ in 0..MAX_COUNTS {
        let factor = inertia.at(probe)?.ok_or(SpectralError::Empty)?;
        let was_certifying = std::mem::take(&mut certifying);
        if factor.below() == n {
            hi = probe;
            if was_certifying || hi - lo <= tol {
                return Ok(lo);
            }
            let run = shift_invert && hi - lo <= 0.25 * last_run;
            if run {
                last_run = hi - lo;
            }
            let rho = if run {
                factor.nearest_by_krylov(SHIFT_INVERT_RESIDUAL)?
            } else {
                None
            };
            if let Some(rho) = rho {
                // A Rayleigh quotient: a lower bound of λ_max (below `hi` up to rounding).
                lo = lo.max(rho.min(hi));
                if hi - lo <= tol {
                    return Ok(lo);
                }
                if rho >= lo {
                    // Try to certify ρ itself.
                    probe = lo + tol;
                    certifying = true;
                    continue;
                }
            }
        } else {
            lo = lo.max(probe);
            if !hi.is_finite() {
                step *= 4.0;
                probe = theta + step;
                if !probe.is_finite() {
                    // Only an unbounded operator gets here (its entries were checked
                    // finite).
                    return Err(SpectralError::NoConvergence {
                        path: "λ_max inertia bracket",
                    });
                }
                continue;
            }
            if hi - lo <= tol {
                return Ok(lo);
            }
        }
        let mid = 0.5 * (lo + hi);
        if !(mid > lo && mid < hi) {
            return Ok(lo);
        }
        probe = mid;
    }
    Err(SpectralError::NoConvergence {
        path: "λ_max inertia bisection",
    })
}

/// Extreme eigenvalues and the zero multiplicity of `K v = λ M v`.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Extremes {
    /// Smallest eigenvalue.
    pub lambda_min: f64,
    /// Largest eigenvalue.
    pub lambda_max: f64,
    /// Eigenvalues with `|λ| ≤ zero_tolerance`, by inertia.
    pub zero_multiplicity: usize,
    /// `τ = 10⁻⁸·max(1, |λ_max|)`.
    pub zero_tolerance: f64,
}

/// `M^{-1/2} K M^{-1/2} + cI` applied to blocks.
struct Shifted<'a> {
    k: &'a SparseMatrix,
    inv_sqrt_mass: Option<Vec<f64>>,
    c: f64,
}

impl BlockOperator for Shifted<'_> {
    fn dim(&self) -> usize {
        self.k.nrows()
    }

    /// In parallel over blocks of rows, without temporaries: `K` is symmetric
    /// (checked), so row i of `K y` gathers column i.
    fn apply_block(&self, x: MatRef<'_, f64>, out: MatMut<'_, f64>) {
        use rayon::prelude::*;
        const ROWS: usize = 4096;
        let p = x.ncols();
        let s = self.inv_sqrt_mass.as_deref();
        let scale = |i: usize| s.map_or(1.0, |s| s[i]);
        out.par_row_chunks_mut(ROWS)
            .enumerate()
            .for_each(|(b, mut rows)| {
                for q in 0..rows.nrows() {
                    let i = b * ROWS + q;
                    let (idx, val) = (self.k.row_idx_of_col_raw(i), self.k.val_of_col(i));
                    for t in 0..p {
                        let mut acc = 0.0;
                        for (&r, &v) in idx.iter().zip(val) {
                            acc += v * (x[(r, t)] * scale(r));
                        }
                        rows[(q, t)] = acc * scale(i) + self.c * x[(i, t)];
                    }
                }
            });
    }
}

/// The extremes of `K v = λ M v` (see the module documentation); `lower_bound` is any
/// lower bound of the spectrum (e.g. Gershgorin's `min_i (F_ii − Σ_{j≠i} |F_ij|)`
/// of the operator), used only to shift the largest eigenvalue to the top of the
/// magnitudes.
pub fn extremes(
    k: &SparseMatrix,
    mass: Option<&[f64]>,
    lower_bound: f64,
) -> Result<Extremes, SpectralError> {
    // On a pool worker (see `crate::par::on_worker`): the Lanczos run's many short
    // parallel passes and the factorizations.
    crate::par::on_worker(|| extremes_on_worker(k, mass, lower_bound))
}

fn extremes_on_worker(
    k: &SparseMatrix,
    mass: Option<&[f64]>,
    lower_bound: f64,
) -> Result<Extremes, SpectralError> {
    super::partial::check_problem(k, mass.into())?;
    let n = k.nrows();
    if n == 0 {
        return Err(SpectralError::Empty);
    }
    let c = if lower_bound.is_finite() {
        (-lower_bound).max(0.0)
    } else {
        0.0
    };
    let op = Shifted {
        k,
        inv_sqrt_mass: mass.map(|m| m.iter().map(|x| 1.0 / x.sqrt()).collect()),
        c,
    };
    let inertia = Inertia::new(k, mass)?;
    let lambda_max = if n <= 2 {
        let dense = partial_spectrum(k, mass, &PartialParams::new(n), &mut |_, _| {})?;
        dense.eigenvalues[n - 1]
    } else {
        let block = 2.min(n - 1);
        let params = KrylovSchurParams {
            block,
            max_dim: 48.min(n - block),
            tolerance: LAMBDA_MAX_RESIDUAL,
            max_restarts: 2000,
            seed: 0x6c6d_6178,
        };
        let top = largest_magnitude(&op, 1, None, &params)
            .map_err(|source| SpectralError::Krylov { shift: 0.0, source })?;
        let shifted = top.values[0];
        // The estimate is relative to the largest |θ|: this one.
        let residual = top
            .info
            .residual_history
            .last()
            .map_or(shifted.abs(), |r| r * shifted.abs());
        certified_top(&inertia, shifted - c, residual, true)?
    };
    let tau = 1e-8 * lambda_max.abs().max(1.0);
    // The count at τ, then the factorization just below zero: when nothing lies
    // below −10⁻⁶τ, nothing lies below −τ either, and the same LDLᵀ serves λ_min's
    // inverse iteration (one factorization fewer than counting at −τ separately;
    // one factor alive at a time).
    let below_tau = inertia.below(tau)?;
    let near_zero = inertia.at(-ZERO_SHIFT * tau)?.ok_or(SpectralError::Empty)?;
    let (negative, near_zero) = if near_zero.below() == 0 {
        (0, Some(near_zero))
    } else {
        drop(near_zero);
        (inertia.below(-tau)?, None)
    };
    let zero_multiplicity = below_tau.saturating_sub(negative);
    // λ_min: when the inertia says the spectrum starts in [−τ, τ], by inverse
    // iteration just below zero (fast however clustered the low spectrum is);
    // otherwise the smallest pair of the banded solver.
    let lambda_min = match near_zero.filter(|_| zero_multiplicity > 0) {
        Some(factor) => factor.nearest_by_inverse_iteration()?.0,
        None => partial_spectrum(k, mass, &PartialParams::new(1), &mut |_, _| {})?.eigenvalues[0],
    };
    Ok(Extremes {
        lambda_min,
        lambda_max,
        zero_multiplicity,
        zero_tolerance: tau,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{builtin, topology::Topology, TriMesh};
    use crate::operator::{Operator, OperatorKind, OperatorOptions};
    use crate::spectral::partial::SymmetricProblem;

    fn problem(mesh: &TriMesh, kind: OperatorKind) -> SymmetricProblem {
        let t = Topology::new(mesh).unwrap();
        let op = Operator::assemble(kind, mesh, &t, &OperatorOptions::default()).unwrap();
        SymmetricProblem::from_operator(&op, true).unwrap()
    }

    /// Every eigenvalue of the problem, ascending (the partial solver asked for all).
    fn full_spectrum(p: &SymmetricProblem) -> Vec<f64> {
        let n = p.stiffness.nrows();
        partial_spectrum(
            &p.stiffness,
            p.mass.as_deref(),
            &PartialParams::new(n),
            &mut |_, _| {},
        )
        .unwrap()
        .eigenvalues
    }

    /// The inertia certificate from a poor Ritz value: a value 10⁻³ below the top
    /// with a residual bound of 10⁻², one 10⁻¹² below, and the clustered top of a
    /// regular torus grid (spacing far below the residual). The shift-invert step
    /// needs a handful of counts where bisection alone needs twenty or more, and
    /// both land within the tolerance.
    #[test]
    fn certified_top_brackets_the_largest_eigenvalue() {
        for (mesh, kind) in [
            (builtin::icosphere(2).unwrap(), OperatorKind::Cotan),
            (builtin::torus(30, 24).unwrap(), OperatorKind::Sql),
        ] {
            let p = problem(&mesh, kind);
            let n = p.stiffness.nrows();
            let all = full_spectrum(&p);
            let top = all[n - 1];
            for shift_invert in [true, false] {
                let inertia = Inertia::new(&p.stiffness, p.mass.as_deref()).unwrap();
                let got =
                    certified_top(&inertia, top - 1e-3 * top, 1e-2 * top, shift_invert).unwrap();
                assert!((got - top).abs() <= 2e-9 * top, "{kind}: {got} vs {top}");
                let counts = inertia.factorizations();
                if shift_invert {
                    assert!(counts <= 3, "{kind}: {counts} counts");
                } else {
                    assert!(counts >= 20, "{kind}: {counts} counts");
                }
                let close = top * (1.0 - 1e-12);
                let got = certified_top(&inertia, close, 1e-6, shift_invert).unwrap();
                assert!(
                    got >= close && (got - top).abs() <= 2e-9 * top,
                    "{kind}: {got} vs {top}"
                );
            }
        }
    }

    /// Cross-check against the full dense spectrum, on a closed mesh (simple zero),
    /// two components (double zero), the symmetrized TL and the cotangent with mass.
    #[test]
    fn extremes_match_the_dense_spectrum() {
        let mut two = builtin::icosphere(2).unwrap();
        let shift = two.n_vertices() as u32;
        let copy = builtin::icosphere(2).unwrap();
        two.positions
            .extend(copy.positions.iter().map(|p| [p[0] + 3.0, p[1], p[2]]));
        two.faces.extend(
            copy.faces
                .iter()
                .map(|f| [f[0] + shift, f[1] + shift, f[2] + shift]),
        );
        let cases = [
            (builtin::torus(12, 9).unwrap(), OperatorKind::Sql, 1),
            (two, OperatorKind::Kirchhoff, 2),
            (builtin::icosphere(2).unwrap(), OperatorKind::Tutte, 1),
            (builtin::icosphere(2).unwrap(), OperatorKind::Cotan, 1),
            // TᵀT: the squared, tightly clustered low spectrum (λ_min by inverse
            // iteration), above the dense threshold of the partial solver.
            (builtin::torus(30, 24).unwrap(), OperatorKind::Sstl, 1),
        ];
        for (mesh, kind, zeros) in cases {
            let p = problem(&mesh, kind);
            let n = p.stiffness.nrows();
            let all = full_spectrum(&p);
            let e = extremes(&p.stiffness, p.mass.as_deref(), -1e3).unwrap();
            let (lo, hi) = (all[0], all[n - 1]);
            assert!(
                (e.lambda_min - lo).abs() < 1e-9,
                "{kind}: {} vs {lo}",
                e.lambda_min
            );
            assert!(
                (e.lambda_max - hi).abs() < 1e-7 * hi,
                "{kind}: {} vs {hi}",
                e.lambda_max
            );
            assert_eq!(e.zero_multiplicity, zeros, "{kind}");
        }
    }

    /// An indefinite problem (the torus' SQL shifted down by 0.3): eigenvalues below
    /// zero, none at it, so the zero count and λ_min take their other paths (a count
    /// at −τ, the banded solver's smallest pair).
    #[test]
    fn indefinite_problem_counts_no_zero_and_finds_the_negative_minimum() {
        let p = problem(&builtin::torus(12, 9).unwrap(), OperatorKind::Sql);
        let k = &p.stiffness;
        let n = k.nrows();
        let mut trip = Vec::new();
        for j in 0..n {
            for (&i, &v) in k.row_idx_of_col_raw(j).iter().zip(k.val_of_col(j)) {
                trip.push(faer::sparse::Triplet::new(
                    i,
                    j,
                    v - if i == j { 0.3 } else { 0.0 },
                ));
            }
        }
        let shifted = SparseMatrix::try_new_from_triplets(n, n, &trip).unwrap();
        let q = SymmetricProblem {
            stiffness: shifted,
            mass: None,
        };
        let all = full_spectrum(&q);
        let e = extremes(&q.stiffness, None, -1e3).unwrap();
        assert!(
            (e.lambda_min - all[0]).abs() < 1e-9,
            "{} vs {}",
            e.lambda_min,
            all[0]
        );
        assert!((e.lambda_max - all[n - 1]).abs() < 1e-7 * all[n - 1]);
        assert!(all[0] < -0.29);
        assert_eq!(e.zero_multiplicity, 0);
    }
}
