//! The attacks of the 3D mesh watermarking benchmark of K. Wang, G. Lavoué, F. Denis
//! and A. Baskurt, "A benchmark for 3D mesh watermarking" (SMI 2010), one file each:
//!
//! | kind | `amount` | what it does |
//! |---|---|---|
//! | [`AttackKind::Noise`] | X % (0–100) | adds to every coordinate uniform noise in `[−a, a]`, `a` = X % of the mean vertex distance to the centroid ([`noise`]) |
//! | [`AttackKind::Smooth`] | X iterations (integer ≥ 0) | umbrella Laplacian smoothing `x ← x + λ(Cx − x)`, `C` the neighbour average, `λ` = [`AttackOptions::lambda`] ([`smooth`]) |
//! | [`AttackKind::Quantize`] | X bits (integer 1–52) | each coordinate rounded to the nearest of `2ˣ` levels spanning its bounding-box side ([`quantize`]) |
//! | [`AttackKind::Similarity`] | the scale factor s (> 0) | a seeded uniformly random rotation, uniform scaling by s and a seeded translation ([`similarity`]) |
//! | [`AttackKind::Simplify`] | X % of the vertices (0–95) | Garland–Heckbert quadric edge collapses, refusing collapses that flip a normal or break manifoldness ([`simplify`]) |
//! | [`AttackKind::Subdivide`] | steps (integer 1–4) | midpoint, Loop (1987) or √3 (Kobbelt 2000) subdivision, [`AttackOptions::scheme`] ([`subdivide`]) |
//! | [`AttackKind::Crop`] | X % of the vertices (0–99) | removes the X % of the vertices lying farthest along the principal axis, then the faces that lose a vertex ([`crop`]) |
//!
//! Every attack is deterministic for a seed ([`AttackOptions::seed`], used by noise,
//! similarity and crop). Noise, smoothing, quantization and similarity keep the
//! connectivity and vertex order; simplification, subdivision and cropping change them
//! (a detector must resample). [`benchmark_levels`] lists the benchmark's strengths.

pub mod crop;
pub mod noise;
pub mod quantize;
pub mod similarity;
pub mod simplify;
pub mod smooth;
pub mod subdivide;

use crate::mesh::{MeshError, TriMesh};
use serde::Serialize;

/// Which attack ([`attack`]); the module documentation gives the meaning of `amount`.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum AttackKind {
    /// Uniform additive noise, amplitude X % of the mean distance to the centroid.
    Noise,
    /// X iterations of umbrella Laplacian smoothing.
    Smooth,
    /// Coordinates quantized to X bits over the bounding box.
    Quantize,
    /// Random rotation, uniform scale X, random translation.
    Similarity,
    /// Quadric edge collapse removing X % of the vertices.
    Simplify,
    /// X steps of midpoint, Loop or √3 subdivision.
    Subdivide,
    /// X % of the vertices removed from one side.
    Crop,
}

impl AttackKind {
    /// Every kind, in the benchmark's order.
    pub const ALL: [AttackKind; 7] = [
        AttackKind::Noise,
        AttackKind::Smooth,
        AttackKind::Quantize,
        AttackKind::Similarity,
        AttackKind::Simplify,
        AttackKind::Subdivide,
        AttackKind::Crop,
    ];

    /// The name on the command line and in JSON.
    pub fn name(self) -> &'static str {
        match self {
            AttackKind::Noise => "noise",
            AttackKind::Smooth => "smooth",
            AttackKind::Quantize => "quantize",
            AttackKind::Similarity => "similarity",
            AttackKind::Simplify => "simplify",
            AttackKind::Subdivide => "subdivide",
            AttackKind::Crop => "crop",
        }
    }

    /// The valid `amount`s, as `(low, high, integer, description)`.
    fn range(self) -> (f64, f64, bool, &'static str) {
        match self {
            AttackKind::Noise => (0.0, 100.0, false, "a percentage in [0, 100]"),
            AttackKind::Smooth => (0.0, 1e6, true, "an iteration count in 0..=1000000"),
            AttackKind::Quantize => (1.0, 52.0, true, "a bit count in 1..=52"),
            AttackKind::Similarity => (f64::MIN_POSITIVE, 1e6, false, "a scale factor in (0, 1e6]"),
            AttackKind::Simplify => (0.0, 95.0, false, "a percentage in [0, 95]"),
            AttackKind::Subdivide => (1.0, 4.0, true, "a step count in 1..=4"),
            AttackKind::Crop => (0.0, 99.0, false, "a percentage in [0, 99]"),
        }
    }
}

impl std::fmt::Display for AttackKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Subdivision scheme of [`AttackKind::Subdivide`] ([`subdivide`]).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum SubdivisionScheme {
    /// 1:4 split at the edge midpoints; old vertices stay (V + E vertices).
    #[default]
    Midpoint,
    /// Loop (1987): 1:4 split with Loop's smoothing masks (V + E vertices).
    Loop,
    /// √3 (Kobbelt 2000): a vertex per face, old edges flipped (V + F vertices).
    Sqrt3,
}

impl SubdivisionScheme {
    /// Every scheme.
    pub const ALL: [SubdivisionScheme; 3] = [
        SubdivisionScheme::Midpoint,
        SubdivisionScheme::Loop,
        SubdivisionScheme::Sqrt3,
    ];

    /// The name on the command line and in JSON.
    pub fn name(self) -> &'static str {
        match self {
            SubdivisionScheme::Midpoint => "midpoint",
            SubdivisionScheme::Loop => "loop",
            SubdivisionScheme::Sqrt3 => "sqrt3",
        }
    }
}

/// Options of [`attack`]: the kind, its strength `amount` (meaning per kind in the
/// module documentation) and the parameters some kinds use.
#[derive(Copy, Clone, Debug, PartialEq, Serialize)]
pub struct AttackOptions {
    /// Which attack.
    pub kind: AttackKind,
    /// Its strength (percentage, iterations, bits, scale or steps).
    pub amount: f64,
    /// Subdivision scheme ([`AttackKind::Subdivide`] only; default midpoint).
    pub scheme: SubdivisionScheme,
    /// Step λ of umbrella smoothing ([`AttackKind::Smooth`] only; default
    /// [`AttackOptions::DEFAULT_LAMBDA`] = 0.1, the benchmark's), in (0, 1].
    pub lambda: f64,
    /// Seed of the noise, the similarity and the cropping side (default 0).
    pub seed: u64,
}

impl AttackOptions {
    /// The benchmark's smoothing step λ.
    pub const DEFAULT_LAMBDA: f64 = 0.1;
    /// The default seed of the random attacks.
    pub const DEFAULT_SEED: u64 = 0;

    /// `kind` at strength `amount`, with the library's defaults: midpoint scheme,
    /// λ = 0.1, seed 0.
    pub fn new(kind: AttackKind, amount: f64) -> Self {
        AttackOptions {
            kind,
            amount,
            scheme: SubdivisionScheme::default(),
            lambda: Self::DEFAULT_LAMBDA,
            seed: Self::DEFAULT_SEED,
        }
    }

    /// A short label such as `noise 0.3`, `subdivide loop` (tables and charts).
    pub fn label(&self) -> String {
        match self.kind {
            AttackKind::Subdivide if self.amount == 1.0 => {
                format!("subdivide {}", self.scheme.name())
            }
            AttackKind::Subdivide => format!("subdivide {} ×{}", self.scheme.name(), self.amount),
            k => format!("{} {}", k.name(), self.amount),
        }
    }
}

/// Why an attack could not run. Causes and fixes are on each variant.
#[derive(Debug, thiserror::Error)]
pub enum AttackError {
    /// `amount` is out of range for the kind (the message names the valid range):
    /// pass a value in it.
    #[error("invalid amount {amount} for the {kind} attack: expected {expected}")]
    InvalidAmount {
        /// The attack.
        kind: AttackKind,
        /// The amount given.
        amount: f64,
        /// The valid range.
        expected: &'static str,
    },
    /// The smoothing step λ is not in (0, 1]: umbrella smoothing with λ > 1
    /// overshoots the neighbour average and diverges.
    #[error("invalid smoothing step λ = {0}: expected a value in (0, 1]")]
    InvalidLambda(f64),
    /// The input mesh is unusable (no faces, bad indices, NaN coordinates; for
    /// simplification and √3 subdivision also non-manifold edges — run `meshlap clean
    /// --split-nonmanifold` first).
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// Simplification ran out of legal collapses before removing the requested
    /// number of vertices (every remaining collapse would flip a normal or break
    /// manifoldness): ask for less.
    #[error("simplification stopped after removing {removed} of the {requested} vertices requested: no legal collapse is left")]
    SimplifyStalled {
        /// Vertices removed.
        removed: usize,
        /// Vertices requested.
        requested: usize,
    },
    /// Cropping left no face: crop less.
    #[error("cropping {percent} % of the vertices leaves no face")]
    CropEmpty {
        /// The amount given.
        percent: f64,
    },
}

/// Applies the attack `opts` to `mesh` and returns the attacked mesh. The input must
/// be valid ([`TriMesh::validate`]); `amount` must be in the kind's range (module
/// documentation), else [`AttackError::InvalidAmount`].
pub fn attack(mesh: &TriMesh, opts: &AttackOptions) -> Result<TriMesh, AttackError> {
    mesh.validate()?;
    let (lo, hi, integer, expected) = opts.kind.range();
    let a = opts.amount;
    if !a.is_finite() || a < lo || a > hi || (integer && a.fract() != 0.0) {
        return Err(AttackError::InvalidAmount {
            kind: opts.kind,
            amount: a,
            expected,
        });
    }
    match opts.kind {
        AttackKind::Noise => Ok(noise::noise(mesh, a, opts.seed)),
        AttackKind::Smooth => {
            if !(opts.lambda > 0.0 && opts.lambda <= 1.0) {
                return Err(AttackError::InvalidLambda(opts.lambda));
            }
            smooth::smooth(mesh, a as usize, opts.lambda)
        }
        AttackKind::Quantize => Ok(quantize::quantize(mesh, a as u32)),
        AttackKind::Similarity => Ok(similarity::similarity(mesh, a, opts.seed)),
        AttackKind::Simplify => simplify::simplify(mesh, a),
        AttackKind::Subdivide => {
            let mut m = mesh.clone();
            for _ in 0..a as usize {
                m = subdivide::subdivide(&m, opts.scheme)?;
            }
            Ok(m)
        }
        AttackKind::Crop => crop::crop(mesh, a, opts.seed),
    }
}

/// The strengths of the SMI 2010 benchmark (Wang, Lavoué, Denis, Baskurt), in order:
/// noise 0.05/0.1/0.3/0.5 %, smoothing 5/10/30/50 iterations (λ = 0.1), quantization
/// 11/10/9/8/7 bits, one similarity (scale 1.5, seeded rotation and translation),
/// simplification 10/30/50/70 %, one step of midpoint, Loop and √3 subdivision,
/// cropping 10/30/50 %. Every entry has seed 0.
pub fn benchmark_levels() -> Vec<AttackOptions> {
    let mut v = Vec::new();
    let mut add = |kind, amounts: &[f64]| {
        v.extend(amounts.iter().map(|&a| AttackOptions::new(kind, a)));
    };
    add(AttackKind::Noise, &[0.05, 0.1, 0.3, 0.5]);
    add(AttackKind::Smooth, &[5.0, 10.0, 30.0, 50.0]);
    add(AttackKind::Quantize, &[11.0, 10.0, 9.0, 8.0, 7.0]);
    add(AttackKind::Similarity, &[1.5]);
    add(AttackKind::Simplify, &[10.0, 30.0, 50.0, 70.0]);
    for scheme in SubdivisionScheme::ALL {
        v.push(AttackOptions {
            scheme,
            ..AttackOptions::new(AttackKind::Subdivide, 1.0)
        });
    }
    v.extend([10.0, 30.0, 50.0].map(|a| AttackOptions::new(AttackKind::Crop, a)));
    v
}

/// Mean distance of the vertices to their centroid (the noise amplitude's unit).
pub(crate) fn mean_distance_to_centroid(p: &[[f64; 3]]) -> f64 {
    use glam::DVec3;
    let c = DVec3::from(crate::filter::preserve::centroid(p));
    p.iter()
        .map(|&x| (DVec3::from(x) - c).length())
        .sum::<f64>()
        / p.len().max(1) as f64
}

/// Test helper: the report of `m`, checking that cleaning removes nothing (no
/// unreferenced vertex, degenerate or duplicate face).
#[cfg(test)]
pub(crate) fn checked_report(m: &TriMesh) -> crate::mesh::clean::MeshReport {
    use crate::mesh::clean::{clean, CleanOptions, MeshReport};
    let (c, r) = clean(m, &CleanOptions::default()).unwrap();
    assert_eq!((c.n_vertices(), c.n_faces()), (m.n_vertices(), m.n_faces()));
    MeshReport::new(&c, &crate::mesh::topology::Topology::new(&c).unwrap(), &r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::builtin;

    #[test]
    fn benchmark_levels_are_the_published_ones_and_all_valid() {
        let levels = benchmark_levels();
        assert_eq!(levels.len(), 4 + 4 + 5 + 1 + 4 + 3 + 3);
        let m = builtin::icosphere(2).unwrap();
        for o in &levels {
            let out = attack(&m, o).unwrap_or_else(|e| panic!("{}: {e}", o.label()));
            out.validate().unwrap();
        }
        let q: Vec<f64> = levels
            .iter()
            .filter(|o| o.kind == AttackKind::Quantize)
            .map(|o| o.amount)
            .collect();
        assert_eq!(q, [11.0, 10.0, 9.0, 8.0, 7.0]);
    }

    #[test]
    fn out_of_range_amounts_are_typed_errors_naming_the_range() {
        let m = builtin::icosahedron();
        for (kind, bad) in [
            (AttackKind::Noise, -1.0),
            (AttackKind::Smooth, 2.5),
            (AttackKind::Quantize, 0.0),
            (AttackKind::Similarity, 0.0),
            (AttackKind::Simplify, 99.0),
            (AttackKind::Subdivide, 0.0),
            (AttackKind::Crop, f64::NAN),
        ] {
            let e = attack(&m, &AttackOptions::new(kind, bad)).unwrap_err();
            assert!(matches!(e, AttackError::InvalidAmount { .. }), "{e}");
            assert!(e.to_string().contains("expected"), "{e}");
        }
        let o = AttackOptions {
            lambda: 1.5,
            ..AttackOptions::new(AttackKind::Smooth, 3.0)
        };
        assert!(matches!(attack(&m, &o), Err(AttackError::InvalidLambda(_))));
        let empty = TriMesh::default();
        assert!(matches!(
            attack(&empty, &AttackOptions::new(AttackKind::Noise, 1.0)),
            Err(AttackError::Mesh(_))
        ));
    }
}
