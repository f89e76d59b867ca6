//! Axes: the drawn range and the tick marks with their labels.
//!
//! A logarithmic axis is drawn as a linear one over `log10` of the values, so both
//! kinds share one coordinate type; ticks and labels are chosen here rather than by
//! plotters, so that no two labels overlap:
//!
//! - linear: multiples of a step `{1, 2, 5} × 10ᵉ`, the smallest whose labels (with
//!   as many digits as the step needs) are spaced at least their own extent plus a
//!   gap apart; light grid lines subdivide the step;
//! - logarithmic: `m × 10ᵉ` for the densest mantissa set of `{1, 2, 3, 5}`,
//!   `{1, 2, 5}`, `{1, 3}`, `{1}` whose labels fit, then every 2nd, 5th, 10th, …
//!   decade; light lines at `2 … 9 × 10ᵉ` when decades are wide enough. A range of
//!   less than about a decade falls back to linear steps placed on the log axis.

use super::Scale;
use crate::raster::number::compact;
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};

/// True when `v` can be drawn on an axis of this scale.
pub(super) fn keep(scale: Scale, v: f64) -> bool {
    v.is_finite() && (scale == Scale::Linear || v > 0.0)
}

/// The drawing coordinate of a value: the value, or its `log10`.
pub(super) fn coordinate(scale: Scale, v: f64) -> f64 {
    match scale {
        Scale::Linear => v,
        Scale::Log => v.log10(),
    }
}

/// Range of the kept values, padded so that a constant series still has an extent.
pub(super) fn range(values: impl Iterator<Item = f64>, scale: Scale) -> Option<(f64, f64)> {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    if !lo.is_finite() || !hi.is_finite() {
        return None;
    }
    Some(match scale {
        Scale::Linear => {
            let pad = if hi > lo {
                0.04 * (hi - lo)
            } else {
                lo.abs().max(1.0) * 0.5
            };
            (lo - pad, hi + pad)
        }
        Scale::Log => {
            if hi > lo {
                (lo / 1.25, hi * 1.25)
            } else {
                (lo / 2.0, hi * 2.0)
            }
        }
    })
}

/// One axis, in drawing coordinates.
#[derive(Clone, Debug)]
pub(super) struct Axis {
    /// Drawn range `[lo, hi]` (drawing coordinates).
    pub lo: f64,
    /// See `lo`.
    pub hi: f64,
    /// Labeled ticks: drawing coordinate and label.
    pub ticks: Vec<(f64, String)>,
    /// Light grid lines (drawing coordinates).
    pub light: Vec<f64>,
}

impl Axis {
    /// The axis over the values `(lo, hi)` (already padded, positive on a log axis),
    /// `length` pixels long, with labels of extent `extent(label)` pixels along the
    /// axis that must stay `gap` pixels apart, and ticks at least `min_spacing` pixels
    /// apart.
    pub fn new(
        (lo, hi): (f64, f64),
        scale: Scale,
        length: f64,
        extent: &dyn Fn(&str) -> f64,
        gap: f64,
        min_spacing: f64,
    ) -> Axis {
        let (clo, chi) = (coordinate(scale, lo), coordinate(scale, hi));
        let px = |c: f64| (c - clo) / (chi - clo) * length;
        let fits = |ticks: &[(f64, String)]| {
            ticks.len() >= 2
                && ticks.windows(2).all(|w| {
                    let need = (0.5 * (extent(&w[0].1) + extent(&w[1].1)) + gap).max(min_spacing);
                    px(w[1].0) - px(w[0].0) >= need
                })
        };
        let (ticks, light) = match scale {
            Scale::Linear => linear(lo, hi, &fits, &|v| v),
            Scale::Log => log(lo, hi, length / (chi - clo), &fits),
        };
        Axis {
            lo: clo,
            hi: chi,
            ticks,
            light,
        }
    }

    /// The label of the tick at drawing coordinate `c` (empty between ticks).
    pub fn label(&self, c: f64) -> String {
        let tol = 1e-9 * (self.hi - self.lo).abs().max(f64::MIN_POSITIVE);
        self.ticks
            .iter()
            .find(|(t, _)| (t - c).abs() <= tol)
            .map_or_else(String::new, |(_, s)| s.clone())
    }
}

/// plotters draws the axis in drawing coordinates: bold lines and labels at the ticks,
/// light lines at the light points.
impl Ranged for Axis {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let f = (value - self.lo) / (self.hi - self.lo);
        let length = (limit.1 - limit.0) as f64;
        if f.is_nan() {
            return limit.0;
        }
        // As plotters' own f64 coordinates round.
        if length >= 0.0 {
            limit.0 + (length * f + 1e-3).floor() as i32
        } else {
            limit.0 + (length * f - 1e-3).ceil() as i32
        }
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            self.light.clone()
        } else {
            self.ticks.iter().map(|t| t.0).collect()
        }
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.lo..self.hi
    }
}

/// Labeled ticks (drawing coordinate, label) and light grid lines.
type Ticks = (Vec<(f64, String)>, Vec<f64>);

/// Whether a tick sequence is spaced widely enough for its labels.
type Fits<'a> = &'a dyn Fn(&[(f64, String)]) -> bool;

/// Linear steps over `[lo, hi]` (values); `to_coord` maps a value to its drawing
/// coordinate. The first step whose ticks `fit` wins; if none does, the two ends.
fn linear(lo: f64, hi: f64, fit: Fits, to_coord: &dyn Fn(f64) -> f64) -> Ticks {
    let span = hi - lo;
    let magnitude = lo.abs().max(hi.abs());
    let mut e = (span / 100.0).log10().floor() as i32;
    for _ in 0..40 {
        for (mantissa, subdivisions) in [(1.0, 5), (2.0, 4), (5.0, 5)] {
            let step = mantissa * 10f64.powi(e);
            if span / step > 100.0 {
                continue;
            }
            let digits = (magnitude.log10().floor() as i32 - e + 1).clamp(1, 12) as usize;
            let first = (lo / step).ceil() as i64;
            let last = (hi / step).floor() as i64;
            let ticks: Vec<(f64, String)> = (first..=last)
                .map(|k| {
                    let v = k as f64 * step;
                    (to_coord(v), compact(v, digits))
                })
                .collect();
            if fit(&ticks) {
                let sub = step / subdivisions as f64;
                let light = ((lo / sub).ceil() as i64..=(hi / sub).floor() as i64)
                    .filter(|k| k % subdivisions != 0)
                    .map(|k| to_coord(k as f64 * sub))
                    .collect();
                return (ticks, light);
            }
        }
        e += 1;
    }
    let ends = vec![
        (to_coord(lo), compact(lo, 3)),
        (to_coord(hi), compact(hi, 3)),
    ];
    (ends, Vec::new())
}

/// Logarithmic ticks over the values `[lo, hi]`, `per_decade` pixels per decade.
fn log(lo: f64, hi: f64, per_decade: f64, fit: Fits) -> Ticks {
    let (e0, e1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let candidates = |mantissas: &[f64], stride: i32| -> Vec<(f64, String)> {
        (e0..=e1)
            .filter(|e| e.rem_euclid(stride) == 0)
            .flat_map(|e| mantissas.iter().map(move |m| m * 10f64.powi(e)))
            .filter(|&v| v >= lo && v <= hi)
            .map(|v| (v.log10(), compact(v, 3)))
            .collect()
    };
    let decades_light = |ticks: &[(f64, String)]| -> Vec<f64> {
        let mut light = Vec::new();
        for e in e0..=e1 {
            let ms: &[f64] = if per_decade >= 60.0 {
                &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]
            } else {
                &[1.0]
            };
            for m in ms {
                let v = m * 10f64.powi(e);
                let c = v.log10();
                if v >= lo && v <= hi && !ticks.iter().any(|(t, _)| (t - c).abs() < 1e-12) {
                    light.push(c);
                }
            }
        }
        light
    };
    let sets: [&[f64]; 4] = [&[1.0, 2.0, 3.0, 5.0], &[1.0, 2.0, 5.0], &[1.0, 3.0], &[1.0]];
    for set in sets {
        let ticks = candidates(set, 1);
        if ticks.len() >= 2 && fit(&ticks) {
            let light = decades_light(&ticks);
            return (ticks, light);
        }
    }
    if e1 - e0 >= 3 {
        for stride in [2, 3, 5, 10, 20, 50, 100] {
            let ticks = candidates(&[1.0], stride);
            if ticks.len() >= 2 && fit(&ticks) {
                let light = decades_light(&ticks);
                return (ticks, light);
            }
        }
    }
    // Less than about a decade: linear steps, placed on the log axis.
    linear(lo, hi, fit, &|v: f64| v.log10())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Label extent of about 8 px per character (the chart font at 15 px).
    fn width(s: &str) -> f64 {
        8.0 * s.chars().count() as f64
    }

    fn labels(a: &Axis) -> Vec<&str> {
        a.ticks.iter().map(|(_, s)| s.as_str()).collect()
    }

    /// No two labels closer than their half extents plus the gap.
    fn no_overlap(a: &Axis, length: f64, gap: f64) {
        let px = |c: f64| (c - a.lo) / (a.hi - a.lo) * length;
        for w in a.ticks.windows(2) {
            let d = px(w[1].0) - px(w[0].0);
            assert!(
                d >= 0.5 * (width(&w[0].1) + width(&w[1].1)) + gap,
                "{:?}",
                a.ticks
            );
        }
    }

    #[test]
    fn linear_ticks_are_round_and_spaced() {
        let a = Axis::new((-0.52, 13.52), Scale::Linear, 800.0, &width, 12.0, 0.0);
        assert_eq!(
            labels(&a),
            ["0", "1", "2", "3", "4", "5", "6", "7", "8", "9", "10", "11", "12", "13"]
        );
        no_overlap(&a, 800.0, 12.0);
        let a = Axis::new((-0.52, 13.52), Scale::Linear, 800.0, &width, 12.0, 60.0);
        assert_eq!(labels(&a), ["0", "2", "4", "6", "8", "10", "12"]);
        let a = Axis::new((-0.52, 13.52), Scale::Linear, 150.0, &width, 12.0, 0.0);
        assert_eq!(labels(&a), ["0", "5", "10"]);
        let a = Axis::new((0.98, 1.02), Scale::Linear, 800.0, &width, 12.0, 0.0);
        assert!(labels(&a).contains(&"1.01"), "{:?}", labels(&a));
        no_overlap(&a, 800.0, 12.0);
        assert!(!a.light.is_empty());
        assert_eq!(a.label(a.ticks[1].0), a.ticks[1].1);
        assert_eq!(a.label(0.5 * (a.ticks[0].0 + a.ticks[1].0)), "");
    }

    #[test]
    fn log_ticks_thin_out_instead_of_overlapping() {
        // The range of the eigendecomposition-cost chart: 900 and 1000 used to collide.
        let a = Axis::new((80.0, 2000.0), Scale::Log, 820.0, &width, 12.0, 0.0);
        no_overlap(&a, 820.0, 12.0);
        assert_eq!(labels(&a), ["100", "200", "300", "500", "1000", "2000"]);
        // Many decades: powers of ten, every other one when space is short.
        let a = Axis::new((5e-13, 20.0), Scale::Log, 400.0, &|_| 14.0, 6.0, 0.0);
        assert_eq!(labels(&a).len(), 14);
        let a = Axis::new((5e-13, 20.0), Scale::Log, 120.0, &|_| 14.0, 6.0, 0.0);
        assert!(
            labels(&a).len() < 8 && labels(&a).len() >= 2,
            "{:?}",
            labels(&a)
        );
        no_overlap(
            &Axis::new((5e-13, 20.0), Scale::Log, 120.0, &width, 6.0, 0.0),
            120.0,
            6.0,
        );
        // The decade below the first power of ten is labeled too (it was not).
        let a = Axis::new((1.8e-5, 1.5), Scale::Log, 400.0, &|_| 14.0, 6.0, 0.0);
        assert_eq!(labels(&a)[0], "2e-5");
        // Within one decade: linear steps.
        let a = Axis::new((0.42, 0.83), Scale::Log, 500.0, &width, 12.0, 0.0);
        assert!(labels(&a).len() >= 3, "{:?}", labels(&a));
        no_overlap(&a, 500.0, 12.0);
    }
}
