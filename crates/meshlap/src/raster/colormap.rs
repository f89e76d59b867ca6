//! Color maps for scalar data on `t ∈ [0, 1]`, piecewise linear through samples of
//! the published maps:
//!
//! - [`Colormap::Viridis`] (van der Walt & Smith, matplotlib's default; CC0): dark
//!   purple to yellow, perceptually uniform and monotone in lightness, readable in
//!   gray print and by most color-blind readers — for data of one sign;
//! - [`Colormap::Coolwarm`] (Moreland 2009, *Diverging color maps for scientific
//!   visualization*): blue through light gray to red, for signed data such as
//!   eigenvectors, with zero mapped to the middle gray when the range is symmetric
//!   about zero (see [`Colormap::default_range`]).

use std::fmt;
use std::str::FromStr;

/// A color map.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub enum Colormap {
    /// Sequential dark purple → yellow (matplotlib's `viridis`).
    #[default]
    Viridis,
    /// Diverging blue → gray → red (Moreland's cool–warm, matplotlib's `coolwarm`).
    Coolwarm,
}

/// Every 16th of matplotlib's 256 viridis samples, and the last.
const VIRIDIS: [[f64; 3]; 17] = [
    [0.267004, 0.004874, 0.329415],
    [0.282327, 0.094955, 0.417331],
    [0.278826, 0.175490, 0.483397],
    [0.258965, 0.251537, 0.524736],
    [0.229739, 0.322361, 0.545706],
    [0.199430, 0.387607, 0.554642],
    [0.172719, 0.448791, 0.557885],
    [0.149039, 0.508051, 0.557250],
    [0.127568, 0.566949, 0.550556],
    [0.120081, 0.622161, 0.534946],
    [0.157851, 0.683765, 0.501686],
    [0.246070, 0.738910, 0.452024],
    [0.369214, 0.788888, 0.382914],
    [0.515992, 0.831158, 0.294279],
    [0.678489, 0.863742, 0.189503],
    [0.845561, 0.887322, 0.099702],
    [0.993248, 0.906157, 0.143936],
];

/// Moreland's cool–warm table at t = 0, 1/16, …, 1 (8-bit RGB).
const COOLWARM: [[u8; 3]; 17] = [
    [59, 76, 192],
    [77, 104, 215],
    [98, 130, 234],
    [119, 154, 247],
    [141, 176, 254],
    [163, 194, 255],
    [184, 208, 249],
    [204, 217, 238],
    [221, 221, 221],
    [236, 211, 197],
    [245, 196, 173],
    [247, 177, 148],
    [244, 154, 123],
    [236, 127, 99],
    [222, 96, 77],
    [203, 62, 56],
    [180, 4, 38],
];

impl Colormap {
    /// Every map, in the order of their names.
    pub const ALL: [Colormap; 2] = [Colormap::Viridis, Colormap::Coolwarm];

    /// The map's name (`viridis`, `coolwarm`), as [`FromStr`] reads it.
    pub fn name(self) -> &'static str {
        match self {
            Colormap::Viridis => "viridis",
            Colormap::Coolwarm => "coolwarm",
        }
    }

    /// True for a diverging map (its middle marks zero).
    pub fn is_diverging(self) -> bool {
        self == Colormap::Coolwarm
    }

    /// The color of `t`, clamped to `[0, 1]` (NaN maps to 0), as linear RGB in `[0, 1]`.
    pub fn map(self, t: f64) -> [f64; 3] {
        let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
        let s = t * 16.0;
        let i = (s.floor() as usize).min(15);
        let f = s - i as f64;
        let (a, b) = match self {
            Colormap::Viridis => (VIRIDIS[i], VIRIDIS[i + 1]),
            Colormap::Coolwarm => (
                COOLWARM[i].map(|c| c as f64 / 255.0),
                COOLWARM[i + 1].map(|c| c as f64 / 255.0),
            ),
        };
        std::array::from_fn(|k| a[k] * (1.0 - f) + b[k] * f)
    }

    /// The color of `t` as 8-bit RGB.
    pub fn map_rgb8(self, t: f64) -> [u8; 3] {
        self.map(t).map(|c| (255.0 * c).round() as u8)
    }

    /// The range the map spans by default for `values` (non-finite values ignored):
    /// their minimum and maximum for a sequential map, and `[−m, m]` with `m` the
    /// largest magnitude for a diverging one, so that zero gets the middle color.
    /// `None` when no value is finite.
    pub fn default_range(self, values: &[f64]) -> Option<(f64, f64)> {
        let (lo, hi) = values
            .iter()
            .filter(|v| v.is_finite())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        if lo > hi {
            return None;
        }
        Some(if self.is_diverging() {
            let m = lo.abs().max(hi.abs());
            (-m, m)
        } else {
            (lo, hi)
        })
    }
}

impl fmt::Display for Colormap {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A color-map name that is not one of [`Colormap::ALL`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown colormap `{0}` (expected viridis or coolwarm)")]
pub struct UnknownColormap(pub String);

impl FromStr for Colormap {
    type Err = UnknownColormap;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Colormap::ALL
            .into_iter()
            .find(|c| c.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| UnknownColormap(s.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_are_hit_exactly_and_ends_clamp() {
        assert_eq!(Colormap::Viridis.map_rgb8(0.0), [68, 1, 84]);
        assert_eq!(Colormap::Viridis.map_rgb8(1.0), [253, 231, 37]);
        assert_eq!(Colormap::Viridis.map_rgb8(0.5), [33, 145, 140]);
        assert_eq!(Colormap::Viridis.map_rgb8(7.0), [253, 231, 37]);
        assert_eq!(Colormap::Viridis.map_rgb8(f64::NAN), [68, 1, 84]);
        assert_eq!(Colormap::Coolwarm.map_rgb8(0.0), [59, 76, 192]);
        assert_eq!(Colormap::Coolwarm.map_rgb8(0.5), [221, 221, 221]);
        assert_eq!(Colormap::Coolwarm.map_rgb8(1.0), [180, 4, 38]);
    }

    #[test]
    fn viridis_lightness_increases() {
        let luma = |c: [f64; 3]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
        let l: Vec<f64> = (0..=64)
            .map(|i| luma(Colormap::Viridis.map(i as f64 / 64.0)))
            .collect();
        assert!(l.windows(2).all(|w| w[1] > w[0]));
    }

    #[test]
    fn ranges_and_names() {
        let v = [-1.0, 3.0, f64::NAN];
        assert_eq!(Colormap::Viridis.default_range(&v), Some((-1.0, 3.0)));
        assert_eq!(Colormap::Coolwarm.default_range(&v), Some((-3.0, 3.0)));
        assert_eq!(Colormap::Viridis.default_range(&[f64::NAN]), None);
        for c in Colormap::ALL {
            assert_eq!(c.name().parse::<Colormap>().unwrap(), c);
        }
        assert!("jet".parse::<Colormap>().is_err());
    }
}
