//! Which filter, with which parameters: every default and every rule about the
//! parameters lives here, so that the command line and the Python bindings only pass
//! on what the user gave ([`FilterSettings`], every field optional) and
//! [`Filter::new`] fills in the rest and validates.
//!
//! Defaults: implicit fairing λ = 30 (the paper's Table 1), one step, the solver
//! chosen from the operator ([`SolverKind::Auto`]: CG for a symmetric F, BiCG
//! otherwise); explicit and Taubin λ = 0.5 with 10 steps (pairs), Taubin pass-band
//! `k_PB` = 0.1; Butterworth order 2. The Butterworth and ideal filters have no
//! default pass-band: it is an eigenvalue of F, which depends on the operator. The
//! operator F itself defaults to the SQL ([`FilterSettings::DEFAULT_OPERATOR`]).

use super::{FilterError, SolverKind};
use crate::solve::Params;
use serde::Serialize;

/// Which filter (without its parameters); see [`Filter`].
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum FilterKind {
    /// Implicit fairing: N solves of `(I + λF)x' = x`.
    Implicit,
    /// Explicit Laplacian smoothing `x' = (I − λF)ᴺx`.
    Explicit,
    /// Taubin λ|μ smoothing.
    Taubin,
    /// Butterworth low-pass.
    Butterworth,
    /// Ideal low-pass through the dense eigendecomposition.
    Ideal,
}

crate::names::option_names!(FilterKind, FilterError, |s| FilterError::UnknownName {
    what: "filter",
    got: s.to_string(),
}, {
    Implicit => "implicit",
    Explicit => "explicit",
    Taubin => "taubin",
    Butterworth => "butterworth",
    Ideal => "ideal",
});

/// Implicit fairing (Desbrun et al. 1999; Zhang 2004 §4.10): `steps` solves of
/// `(I + λF) x⁽ᵗ⁺¹⁾ = x⁽ᵗ⁾`, response `(1 + λγ)⁻ᴺ`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ImplicitOptions {
    /// λ > 0 (default 30, the paper's Table 1).
    pub lambda: f64,
    /// Solves N ≥ 1 (default 1).
    pub steps: usize,
    /// The linear solver (default [`SolverKind::Auto`]).
    pub solver: SolverKind,
    /// Tolerance, stopping criterion and cap of the iterative solvers.
    pub params: Params,
}

impl Default for ImplicitOptions {
    fn default() -> Self {
        ImplicitOptions {
            lambda: 30.0,
            steps: 1,
            solver: SolverKind::Auto,
            params: Params::default(),
        }
    }
}

/// Explicit Laplacian smoothing `x' = (I − λF)ᴺ x` (Taubin 1995), response
/// `(1 − λγ)ᴺ`; stable for λ·γ_max < 2 (λ ≤ 1 for the Tutte Laplacian).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ExplicitOptions {
    /// λ > 0 (default 0.5).
    pub lambda: f64,
    /// Steps N ≥ 1 (default 10).
    pub steps: usize,
}

impl Default for ExplicitOptions {
    fn default() -> Self {
        ExplicitOptions {
            lambda: 0.5,
            steps: 10,
        }
    }
}

/// Taubin's non-shrinking λ|μ smoothing (Taubin 1995): `steps` pairs
/// `x ← (I − μF)(I − λF) x` with `1/λ + 1/μ = k_PB`, response `((1 − λγ)(1 − μγ))ᴺ`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TaubinOptions {
    /// λ > 0 (default 0.5).
    pub lambda: f64,
    /// Pass-band frequency `k_PB`, 0 < k_PB < 1/λ (default 0.1).
    pub k_pb: f64,
    /// Pairs N ≥ 1 (default 10).
    pub steps: usize,
}

impl Default for TaubinOptions {
    fn default() -> Self {
        TaubinOptions {
            lambda: 0.5,
            k_pb: 0.1,
            steps: 10,
        }
    }
}

/// Butterworth low-pass `1 / (1 + (γ/γ_PB)^{2s})` (Zhang & Fiume 2003).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ButterworthOptions {
    /// Order s ≥ 1 (default [`ButterworthOptions::DEFAULT_ORDER`]).
    pub order: usize,
    /// Pass-band γ_PB > 0, an eigenvalue of F (no default).
    pub passband: f64,
}

impl ButterworthOptions {
    /// The default order.
    pub const DEFAULT_ORDER: usize = 2;

    /// Order 2 at the given pass-band.
    pub fn new(passband: f64) -> Self {
        ButterworthOptions {
            order: Self::DEFAULT_ORDER,
            passband,
        }
    }
}

/// Default size limit of the dense ideal filter: a 3000×3000 eigendecomposition holds
/// two dense 3000×3000 matrices (about 150 MB); the paper's cow (2,903 vertices) fits.
pub const DEFAULT_DENSE_LIMIT: usize = 3000;

/// Ideal low-pass through the dense eigendecomposition (Zhang 2004 §2.6): keep the
/// components with eigenvalue γ ≤ γ_PB.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct IdealOptions {
    /// Pass-band γ_PB ≥ 0 (no default).
    pub passband: f64,
    /// Largest n (default [`DEFAULT_DENSE_LIMIT`]): O(n²) memory, O(n³) time.
    pub dense_limit: usize,
}

impl IdealOptions {
    /// The default size limit at the given pass-band.
    pub fn new(passband: f64) -> Self {
        IdealOptions {
            passband,
            dense_limit: DEFAULT_DENSE_LIMIT,
        }
    }
}

/// A filter with its parameters; see the module documentation of [`crate::filter`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "filter", rename_all = "kebab-case")]
pub enum Filter {
    /// Implicit fairing.
    Implicit(ImplicitOptions),
    /// Explicit Laplacian smoothing.
    Explicit(ExplicitOptions),
    /// Taubin λ|μ smoothing.
    Taubin(TaubinOptions),
    /// Butterworth low-pass.
    Butterworth(ButterworthOptions),
    /// Ideal low-pass.
    Ideal(IdealOptions),
}

/// What a front end collects for [`Filter::new`]: every field optional (`None` takes
/// the filter's default); fields a filter does not use are ignored.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FilterSettings {
    /// λ (implicit, explicit, Taubin).
    pub lambda: Option<f64>,
    /// Solves, steps or pairs.
    pub steps: Option<usize>,
    /// Implicit fairing's solver.
    pub solver: Option<SolverKind>,
    /// Implicit fairing's iterative-solver parameters.
    pub params: Option<Params>,
    /// Taubin's pass-band `k_PB`.
    pub k_pb: Option<f64>,
    /// Butterworth's order.
    pub order: Option<usize>,
    /// Pass-band γ_PB (Butterworth, ideal; required there).
    pub passband: Option<f64>,
    /// Largest n of the ideal filter.
    pub dense_limit: Option<usize>,
}

impl FilterSettings {
    /// The operator F a front end filters with when none is named (`meshlap smooth`
    /// without `--operator`, Python's `meshlap.smooth`): Zhang's symmetric
    /// quasi-Laplacian (SQL, `F = D − W`, positive semi-definite on meshes without
    /// negative weights), symmetric, so implicit fairing solves it with CG.
    pub const DEFAULT_OPERATOR: crate::operator::OperatorKind = crate::operator::OperatorKind::Sql;
}

pub(crate) fn positive(value: f64, name: &'static str) -> Result<(), FilterError> {
    if value > 0.0 && value.is_finite() {
        Ok(())
    } else {
        Err(FilterError::NotPositive { name, value })
    }
}

fn at_least_one(steps: usize, filter: FilterKind) -> Result<(), FilterError> {
    if steps == 0 {
        Err(FilterError::NoSteps { filter })
    } else {
        Ok(())
    }
}

impl Filter {
    /// The filter `kind` with the given settings and the defaults for the rest,
    /// validated ([`Filter::validate`]).
    ///
    /// # Errors
    /// [`FilterError::MissingPassband`] for a Butterworth or ideal filter without a
    /// pass-band, and the errors of [`Filter::validate`].
    pub fn new(kind: FilterKind, s: &FilterSettings) -> Result<Filter, FilterError> {
        let passband = || {
            s.passband
                .ok_or(FilterError::MissingPassband { filter: kind })
        };
        let filter = match kind {
            FilterKind::Implicit => {
                let d = ImplicitOptions::default();
                Filter::Implicit(ImplicitOptions {
                    lambda: s.lambda.unwrap_or(d.lambda),
                    steps: s.steps.unwrap_or(d.steps),
                    solver: s.solver.unwrap_or(d.solver),
                    params: s.params.unwrap_or(d.params),
                })
            }
            FilterKind::Explicit => {
                let d = ExplicitOptions::default();
                Filter::Explicit(ExplicitOptions {
                    lambda: s.lambda.unwrap_or(d.lambda),
                    steps: s.steps.unwrap_or(d.steps),
                })
            }
            FilterKind::Taubin => {
                let d = TaubinOptions::default();
                Filter::Taubin(TaubinOptions {
                    lambda: s.lambda.unwrap_or(d.lambda),
                    k_pb: s.k_pb.unwrap_or(d.k_pb),
                    steps: s.steps.unwrap_or(d.steps),
                })
            }
            FilterKind::Butterworth => Filter::Butterworth(ButterworthOptions {
                order: s.order.unwrap_or(ButterworthOptions::DEFAULT_ORDER),
                passband: passband()?,
            }),
            FilterKind::Ideal => Filter::Ideal(IdealOptions {
                passband: passband()?,
                dense_limit: s.dense_limit.unwrap_or(DEFAULT_DENSE_LIMIT),
            }),
        };
        filter.validate()?;
        Ok(filter)
    }

    /// Which filter.
    pub fn kind(&self) -> FilterKind {
        match self {
            Filter::Implicit(_) => FilterKind::Implicit,
            Filter::Explicit(_) => FilterKind::Explicit,
            Filter::Taubin(_) => FilterKind::Taubin,
            Filter::Butterworth(_) => FilterKind::Butterworth,
            Filter::Ideal(_) => FilterKind::Ideal,
        }
    }

    /// λ of the implicit, explicit and Taubin filters.
    pub fn lambda(&self) -> Option<f64> {
        match self {
            Filter::Implicit(o) => Some(o.lambda),
            Filter::Explicit(o) => Some(o.lambda),
            Filter::Taubin(o) => Some(o.lambda),
            Filter::Butterworth(_) | Filter::Ideal(_) => None,
        }
    }

    /// Checks the parameters: λ positive and finite; at least one step; Taubin's
    /// `0 < k_PB < 1/λ`; Butterworth's order ≥ 1 and pass-band > 0; the ideal
    /// filter's pass-band ≥ 0; the iterative-solver parameters.
    pub fn validate(&self) -> Result<(), FilterError> {
        let kind = self.kind();
        match *self {
            Filter::Implicit(o) => {
                positive(o.lambda, "λ")?;
                at_least_one(o.steps, kind)?;
                o.params
                    .validate()
                    .map_err(|e| FilterError::Solve(e.into()))
            }
            Filter::Explicit(o) => {
                positive(o.lambda, "λ")?;
                at_least_one(o.steps, kind)
            }
            Filter::Taubin(o) => {
                super::polynomial::taubin_mu(o.lambda, o.k_pb)?;
                at_least_one(o.steps, kind)
            }
            Filter::Butterworth(o) => {
                if o.order == 0 {
                    return Err(FilterError::ZeroOrder);
                }
                positive(o.passband, "the Butterworth pass-band")
            }
            Filter::Ideal(o) => {
                if o.passband >= 0.0 {
                    Ok(())
                } else {
                    Err(FilterError::NotNonNegative {
                        name: "the ideal pass-band",
                        value: o.passband,
                    })
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_fill_what_the_settings_leave_out() {
        let none = FilterSettings::default();
        assert_eq!(
            Filter::new(FilterKind::Implicit, &none).unwrap(),
            Filter::Implicit(ImplicitOptions {
                lambda: 30.0,
                steps: 1,
                solver: SolverKind::Auto,
                params: Params::default(),
            })
        );
        assert_eq!(
            Filter::new(FilterKind::Explicit, &none).unwrap(),
            Filter::Explicit(ExplicitOptions {
                lambda: 0.5,
                steps: 10
            })
        );
        assert_eq!(
            Filter::new(FilterKind::Taubin, &none).unwrap(),
            Filter::Taubin(TaubinOptions {
                lambda: 0.5,
                k_pb: 0.1,
                steps: 10
            })
        );
        let given = FilterSettings {
            lambda: Some(2.0),
            steps: Some(3),
            solver: Some(SolverKind::Lu),
            ..Default::default()
        };
        let f = Filter::new(FilterKind::Implicit, &given).unwrap();
        assert_eq!(f.lambda(), Some(2.0));
        assert!(matches!(f, Filter::Implicit(o) if o.steps == 3 && o.solver == SolverKind::Lu));
        let pb = FilterSettings {
            passband: Some(0.3),
            ..Default::default()
        };
        assert_eq!(
            Filter::new(FilterKind::Butterworth, &pb).unwrap(),
            Filter::Butterworth(ButterworthOptions::new(0.3))
        );
        assert_eq!(
            Filter::new(FilterKind::Ideal, &pb).unwrap(),
            Filter::Ideal(IdealOptions::new(0.3))
        );
    }

    #[test]
    fn the_rules_are_checked_with_typed_errors() {
        let with = |f: fn(&mut FilterSettings)| {
            let mut s = FilterSettings::default();
            f(&mut s);
            s
        };
        for kind in [FilterKind::Butterworth, FilterKind::Ideal] {
            assert!(matches!(
                Filter::new(kind, &FilterSettings::default()),
                Err(FilterError::MissingPassband { filter }) if filter == kind
            ));
        }
        for kind in [FilterKind::Implicit, FilterKind::Explicit] {
            let e = Filter::new(kind, &with(|s| s.lambda = Some(-3.0))).unwrap_err();
            assert!(matches!(e, FilterError::NotPositive { .. }), "{e}");
            assert!(e.to_string().contains("λ"), "{e}");
        }
        for kind in [
            FilterKind::Implicit,
            FilterKind::Explicit,
            FilterKind::Taubin,
        ] {
            assert!(matches!(
                Filter::new(kind, &with(|s| s.steps = Some(0))),
                Err(FilterError::NoSteps { .. })
            ));
        }
        assert!(matches!(
            Filter::new(FilterKind::Taubin, &with(|s| s.k_pb = Some(3.0))),
            Err(FilterError::TaubinPassband { .. })
        ));
        let e = Filter::new(
            FilterKind::Butterworth,
            &with(|s| {
                s.passband = Some(0.2);
                s.order = Some(0)
            }),
        );
        assert!(matches!(e, Err(FilterError::ZeroOrder)));
        for (kind, pb) in [
            (FilterKind::Butterworth, 0.0),
            (FilterKind::Butterworth, f64::INFINITY),
            (FilterKind::Ideal, -0.1),
            (FilterKind::Ideal, f64::NAN),
        ] {
            let s = FilterSettings {
                passband: Some(pb),
                ..Default::default()
            };
            assert!(Filter::new(kind, &s).is_err(), "{kind} {pb}");
        }
        let bad_tol = with(|s| {
            s.params = Some(Params {
                tolerance: -1.0,
                ..Default::default()
            })
        });
        assert!(matches!(
            Filter::new(FilterKind::Implicit, &bad_tol),
            Err(FilterError::Solve(_))
        ));
    }
}
