//! The band driver: shifts chained upwards from just below zero, each band's window
//! checked complete by inertia (see the module documentation of [`super`]).

use super::factor::{count_below, factor_at, negative_pivots, symbolic_of, ShiftedPattern};
use super::mass::Metric;
use super::polish::{polish, replace_with_refined};
use super::residuals::finish;
use super::solve::{ShiftInvert, TreeSplit, TREE_SPLIT_MIN_DIM};
use super::{BandInfo, PartialParams, PartialSpectrum};
use crate::par::on_worker;
use crate::spectral::krylov_schur::{
    largest_magnitude_in_place, KrylovSchurError, KrylovSchurParams,
};
use crate::spectral::SpectralError;
use crate::SparseMatrix;
use faer::{Col, Mat, MatRef};

/// The `b` eigenpairs of largest |μ| of `A_σ` (on the complement of `deflate`, when
/// given) as (λ = σ + 1/μ, w) with `w` in the symmetric coordinates (`w = M^{1/2} v`),
/// by block Krylov–Schur, with its basis in `basis` (kept from band to band, see
/// [`largest_magnitude_in`](crate::spectral::krylov_schur::largest_magnitude_in)).
/// The iteration leaves the vectors in the basis' first columns
/// ([`largest_magnitude_in_place`]), from which each is copied into a column of its
/// own. Unless `keep_basis`, the basis is then freed: in the last band only the
/// refinement would use it again (as work storage it can allocate anew), and kept
/// alive beside the pairs through the band's inertia count (a second numeric
/// factorization) it raised the million-vertex torus' peak from 6.7 to 7.4 GiB
/// and made the run slower (BENCHMARKS.md, "Partial spectra and partitioning",
/// forty-eighth session).
#[allow(clippy::too_many_arguments)]
fn shift_invert_pairs(
    op: &ShiftInvert<'_>,
    sigma: f64,
    b: usize,
    deflate: Option<MatRef<'_, f64>>,
    opts: &PartialParams,
    seed: u64,
    work: &mut BandWork,
    basis: &mut Mat<f64>,
    keep_basis: bool,
) -> Result<Vec<(f64, Col<f64>)>, SpectralError> {
    let params = krylov_params(opts, b, seed);
    let got = largest_magnitude_in_place(op, b, deflate, &params, basis).map(|got| {
        let pairs: Vec<(f64, Col<f64>)> = got
            .values
            .iter()
            .enumerate()
            .map(|(j, &mu)| (sigma + 1.0 / mu, basis.col(j).to_owned()))
            .collect();
        (got.info, pairs)
    });
    if !keep_basis {
        *basis = Mat::new();
    }
    let (info, pairs) = got.map_err(|e| match e {
        KrylovSchurError::NoConvergence {
            converged,
            wanted,
            restarts,
        } => SpectralError::NotConverged {
            shift: sigma,
            converged,
            wanted,
            restarts,
        },
        source => SpectralError::Krylov {
            shift: sigma,
            source,
        },
    })?;
    work.restarts += info.restarts;
    work.solves += info.applications;
    work.stagnated |= info.stagnated;
    Ok(pairs)
}

/// Work counters of one band (reported in [`BandInfo`]).
#[derive(Default)]
struct BandWork {
    restarts: usize,
    solves: usize,
    factorizations: usize,
    stagnated: bool,
}

/// Size of a band after the first when `need` eigenpairs are still missing: the full
/// band size, or — for the last band — enough for `need` (an interior band keeps
/// about 3/4 of its pairs, the rest overlap the previous window or lie beyond its
/// edge) instead of a full band for a handful of pairs.
fn next_band_size(need: usize, b_max: usize, block: usize) -> usize {
    let enough = need * 3 / 2 + 2 * block.max(1);
    enough.min(b_max).max(1)
}

/// Fraction of the next band's expected radius by which its window should reach
/// below the edge `U`: the margin for a change of the eigenvalue density between two
/// bands (small on meshes: Weyl's law makes the spacing of a surface's Laplacian
/// eigenvalues nearly constant). A window that falls short is redone with a lower
/// shift, so the margin trades overlap (pairs computed twice) against redone bands.
const REACH_MARGIN: f64 = 0.3;

/// Largest step above `U`, as a fraction of the last band's radius `r`.
const MAX_STEP: f64 = 0.55;

/// The next shift above the edge `upper`, for a band of `b_next` pairs after a band of
/// radius `r` whose eigenvalues had mean spacing `spacing` (`delta`: the edge margin).
///
/// The `b_next` eigenvalues nearest σ span about `±(b_next/2)·spacing`; σ is placed so
/// that this window reaches [`REACH_MARGIN`] of its radius below `upper`:
/// `σ = U + (1 − REACH_MARGIN)·(b_next/2)·spacing`, at most `U + MAX_STEP·r` (and
/// that step when the spacing is unusable). The cap binds on Igea's k = 1000 (bands
/// of 200) for every band after the second: each window reaches 45 % of its radius
/// below `U` and keeps 156 of 200 pairs; a margin of 0.2 and a cap of 0.85 r keep
/// about 180 (6 bands instead of 7, less CPU time: BENCHMARKS.md) but lowered the
/// refinement's gain on the icosphere's clustered spectrum below the 5x that
/// `refinement_lowers_the_residuals_and_keeps_the_spectrum` requires, so they are
/// not the default yet. The pairs of the window below `U` were kept by the band
/// before; deflating them from the new band's search, or starting its iteration
/// from them, saved solves but no time (BENCHMARKS.md, "Partial spectra and
/// partitioning", forty-fifth session).
pub(super) fn next_shift(upper: f64, r: f64, spacing: f64, b_next: usize, delta: f64) -> f64 {
    let step = (1.0 - REACH_MARGIN) * 0.5 * b_next as f64 * spacing;
    upper
        + if step.is_finite() && step > 2.0 * delta {
            step.min(MAX_STEP * r)
        } else {
            MAX_STEP * r
        }
}

/// Block size and basis size for `b` wanted pairs.
fn krylov_params(opts: &PartialParams, b: usize, seed: u64) -> KrylovSchurParams {
    let p = opts.block_size.max(1);
    KrylovSchurParams {
        block: p,
        max_dim: krylov_dim(b, p),
        tolerance: opts.tolerance,
        max_restarts: opts.max_restarts,
        seed,
    }
}

/// The Krylov–Schur basis size for `b` wanted pairs and blocks of `p`.
pub(super) fn krylov_dim(b: usize, p: usize) -> usize {
    (5 * b / 2).max(b + 2 * p)
}

/// Band-by-band shift-invert; see the module documentation.
pub(super) fn banded(
    k: &SparseMatrix,
    metric: &Metric,
    opts: &PartialParams,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<PartialSpectrum, SpectralError> {
    let n = k.nrows();
    let count = opts.count;
    let pattern = ShiftedPattern::new(k, metric)?;
    let mut ones = Vec::new();
    let msqrt = ShiftInvert::scale_of(metric, &mut ones);
    let symbolic = symbolic_of(&pattern)?;
    let split = TreeSplit::of(&symbolic, TREE_SPLIT_MIN_DIM);
    // Scale of the spectrum (mean diagonal of M⁻¹K) and a Gershgorin lower bound
    // (of the diagonally scaled K; a bound for a diagonal M only — for a sparse M it
    // is just a guess, and the inertia checks below catch a shift that is not below
    // the spectrum).
    let mut mean_diag = 0.0;
    let mut gersh = f64::INFINITY;
    for j in 0..n {
        let mj = metric.diag(j);
        let (mut d, mut off) = (0.0, 0.0);
        for (&i, &v) in k.row_idx_of_col_raw(j).iter().zip(k.val_of_col(j)) {
            if i == j {
                d += v;
            } else {
                off += v.abs();
            }
        }
        mean_diag += d / mj / n as f64;
        gersh = gersh.min((d - off) / mj);
    }
    let scale = if mean_diag.is_finite() && mean_diag > 0.0 {
        mean_diag
    } else {
        1.0
    };
    let b_max = opts.band_size.max(1);
    let mut kept: Vec<(f64, Col<f64>)> = Vec::with_capacity(count);
    let mut bands = Vec::new();
    let mut upper = f64::NEG_INFINITY;
    let mut below_upper = 0usize;
    // Below the whole spectrum: every eigenvalue lies above σ₀.
    // σ₀ just below zero, as scipy users do; if K − σ₀M is indefinite (an operator
    // with negative eigenvalues) fall back to below the Gershgorin bound. A shift far
    // below the spectrum compresses the μ = 1/(λ − σ) and slows convergence.
    let mut sigma = -1e-3 * scale;
    let mut first = Some(factor_at(&pattern, &symbolic, sigma)?);
    if first
        .as_ref()
        .is_some_and(|values| negative_pivots(&symbolic, values) > 0)
    {
        sigma = gersh.min(0.0) - 1e-3 * scale;
        first = None;
    }
    let mut band_no = 0usize;
    // The Krylov–Schur basis (n × about 2.5 b), kept from band to band and lent to
    // the refinement as its work space: allocated once instead of once per band
    // (fresh memory is page-faulted and cleared, see `largest_magnitude_in`).
    let mut basis = Mat::<f64>::new();
    // Work of the current band, including redone attempts with a lower shift.
    let mut work = BandWork::default();
    loop {
        let b = if kept.is_empty() {
            count.min(b_max)
        } else {
            next_band_size(count - kept.len(), b_max, opts.block_size)
        };
        work.factorizations += 1;
        let values = match first.take() {
            Some(values) => values,
            None => factor_at(&pattern, &symbolic, sigma)?,
        };
        let op = ShiftInvert {
            symbolic: &symbolic,
            values,
            metric,
            msqrt,
            split,
            scratch: Default::default(),
        };
        let seed = opts.seed.wrapping_add(1_000 * band_no as u64);
        // Whether this band may be the last (it alone can complete the count): then
        // its basis is freed early (see `shift_invert_pairs`).
        let keep_basis = kept.len() + b < count;
        let mut found = on_worker(|| {
            shift_invert_pairs(
                &op, sigma, b, None, opts, seed, &mut work, &mut basis, keep_basis,
            )
        })?;
        band_no += 1;
        let r = found
            .iter()
            .map(|(l, _)| (l - sigma).abs())
            .fold(0.0f64, f64::max);
        let delta = 1e-8 * (sigma.abs() + r).max(1.0);
        let lower_edge = sigma - r + delta;
        if !(kept.is_empty() || lower_edge <= upper) {
            // The window misses eigenvalues just above `upper`: move the shift down.
            let step = (sigma - upper) / 2.0;
            if step <= delta {
                return Err(SpectralError::Stalled {
                    band: band_no,
                    edge: upper,
                });
            }
            sigma = upper + step;
            continue;
        }
        let new_upper = sigma + r - delta;
        // Sylvester inertia: exactly how many eigenvalues [upper, new_upper) holds.
        let below_new = count_below(&pattern, &symbolic, new_upper)?;
        work.factorizations += 1;
        let expected = below_new.saturating_sub(below_upper);
        let in_window = |l: f64| l >= upper && l < new_upper;
        let mut n_in = found.iter().filter(|(l, _)| in_window(*l)).count();
        // The Krylov method may miss copies of a repeated eigenvalue: look for them in the
        // complement of everything this band found.
        let mut tries = 0;
        while n_in < expected && tries < 8 {
            let w = Mat::from_fn(n, found.len(), |i, j| found[j].1[i]);
            let want = (expected - n_in).min(b).max(1);
            let more = on_worker(|| {
                shift_invert_pairs(
                    &op,
                    sigma,
                    want,
                    Some(w.as_ref()),
                    opts,
                    seed + 7 + tries as u64,
                    &mut work,
                    &mut basis,
                    keep_basis,
                )
            })?;
            let mut added = 0;
            for (l, v) in more {
                if in_window(l) {
                    added += 1;
                    found.push((l, v));
                }
            }
            n_in += added;
            tries += 1;
            if added == 0 {
                break;
            }
        }
        if n_in != expected {
            return Err(SpectralError::InertiaMismatch {
                shift: sigma,
                found: n_in,
                expected,
            });
        }
        // Refinement (see `polish`): kept only if the window still holds exactly the
        // inertia's count (the refined eigenvalues move by far less than `delta`).
        if opts.refine {
            work.solves += found.len();
            if let Some(refined) = on_worker(|| polish(&op, k, metric, &found, &mut basis)) {
                if refined.iter().filter(|&&l| in_window(l)).count() == expected {
                    replace_with_refined(&mut found, &refined, basis.as_ref());
                }
            }
        }
        // Mean eigenvalue spacing in this band, for the next shift.
        let (lo, hi) = found
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), (l, _)| {
                (a.min(*l), b.max(*l))
            });
        let spacing = (hi - lo) / (found.len().max(2) - 1) as f64;
        let mut fresh: Vec<(f64, Col<f64>)> = Vec::new();
        let mut edge: Vec<(f64, Col<f64>)> = Vec::new();
        for (l, w) in found {
            if in_window(l) {
                fresh.push((l, w));
            } else if l >= new_upper {
                edge.push((l, w));
            }
        }
        fresh.sort_by(|a, b| a.0.total_cmp(&b.0));
        edge.sort_by(|a, b| a.0.total_cmp(&b.0));
        let n_fresh = fresh.len();
        kept.extend(fresh);
        bands.push(BandInfo {
            shift: sigma,
            found: b,
            kept: n_fresh,
            upper_edge: new_upper,
            restarts: work.restarts,
            solves: work.solves,
            factorizations: work.factorizations,
            stagnated: work.stagnated,
        });
        work = BandWork::default();
        progress(kept.len().min(count), count);
        if kept.len() + edge.len() >= count || kept.len() >= n {
            // The edge eigenvalues are the next ones above the complete window.
            kept.extend(edge);
            kept.truncate(count);
            break;
        }
        if new_upper <= upper {
            return Err(SpectralError::Stalled {
                band: band_no,
                edge: upper,
            });
        }
        upper = new_upper;
        below_upper = below_new;
        let b_next = next_band_size(count - kept.len(), b_max, opts.block_size);
        sigma = next_shift(upper, r, spacing, b_next, delta);
    }
    drop(basis);
    Ok(on_worker(|| finish(k, metric, kept, bands, false)))
}

#[cfg(test)]
mod planning_tests {
    use super::*;

    /// Uniformly spaced eigenvalues (Weyl's law on a surface): the next window of
    /// `b` pairs around the new shift reaches below the edge by the margin, and keeps
    /// more than 80 % of it.
    #[test]
    fn next_window_reaches_below_the_edge_by_the_margin() {
        let spacing = 1e-5;
        let b = 200;
        // The first band (its window starts at the bottom of the spectrum, so its
        // radius spans all its b pairs): the cap does not bind.
        let r = b as f64 * spacing;
        let upper = 0.01 + r - 1e-10;
        let sigma = next_shift(upper, r, spacing, b, 1e-10);
        assert!(sigma > upper && sigma < upper + r);
        // The b eigenvalues nearest the new shift span ±(b/2)·spacing.
        let reach = sigma - 0.5 * b as f64 * spacing;
        let below = upper - reach;
        let radius = 0.5 * b as f64 * spacing;
        assert!(
            (below / radius - REACH_MARGIN).abs() < 1e-9,
            "reaches {below} below the edge"
        );
        let kept = (sigma + radius - upper) / (2.0 * radius);
        assert!(kept > 0.8, "keeps {kept} of the window");
    }

    /// The step is capped by the last band's radius, and falls back to half of it
    /// when the spacing is unusable (a band of one pair, or a non-finite value).
    #[test]
    fn step_is_capped_and_falls_back() {
        let sigma = next_shift(1.0, 0.1, 1.0, 200, 1e-8);
        assert!((sigma - (1.0 + MAX_STEP * 0.1)).abs() < 1e-15);
        let fallback = 1.0 + MAX_STEP * 0.1;
        assert_eq!(next_shift(1.0, 0.1, f64::NAN, 200, 1e-8), fallback);
        assert_eq!(next_shift(1.0, 0.1, 0.0, 200, 1e-8), fallback);
    }

    /// The last band is sized for what is missing, never above the band size.
    #[test]
    fn last_band_is_sized_for_the_missing_pairs() {
        assert_eq!(next_band_size(10, 200, 8), 31);
        assert_eq!(next_band_size(500, 200, 8), 200);
        assert_eq!(next_band_size(0, 200, 8), 16);
        assert_eq!(next_band_size(0, 0, 0), 1);
    }
}
