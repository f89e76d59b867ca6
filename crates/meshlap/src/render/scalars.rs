//! Per-vertex scalars for coloring a surface: [`Scalars`] (values, color map, range,
//! legend caption) and where they come from — vertex degrees, height, a NumPy file,
//! or an eigenvector of an operator, so that the operators' eigenvectors can be looked
//! at as the paper's readers would want (Zhang 2004 §2.3: the ED-transform's basis).
//!
//! Eigenvectors use the paper's sign convention: the operator is `F = D − W`, positive
//! semi-definite, and eigenvector 0 belongs to the smallest eigenvalue (constant for a
//! GSML). They are computed by the dense eigenbasis
//! ([`EigenBasis::compute`]) up to [`DENSE_LIMIT`] vertices and by the shift-invert
//! partial eigensolver ([`operator_partial_spectrum`]) above it, with the canonical
//! signs of both, and shown through the diverging [`Colormap::Coolwarm`] over a range
//! symmetric about zero, so that the nodal sets (sign changes) are the gray lines.

use super::RenderError;
use crate::mesh::{topology::Topology, TriMesh};
use crate::operator::Operator;
use crate::raster::Colormap;
use crate::spectral::partial::{operator_partial_spectrum, PartialParams};
use crate::spectral::{BasisOptions, EigenBasis, DENSE_LIMIT};
use std::path::Path;

/// Per-vertex scalars shown through a color map, with a legend.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Scalars {
    /// One value per vertex (NaN gets the map's low end, ±∞ its ends).
    pub values: Vec<f64>,
    /// The color map.
    pub colormap: Colormap,
    /// The values mapped to the two ends of the map (finite, `lo < hi`; values outside
    /// get the ends); `None`: the map's [`default_range`](Colormap::default_range) of
    /// `values` (min to max, or symmetric about zero for a diverging map).
    pub range: Option<(f64, f64)>,
    /// Caption of the legend (may be empty).
    pub label: String,
}

impl Scalars {
    /// `values` through `colormap` over their default range, without a caption.
    pub fn new(values: Vec<f64>, colormap: Colormap) -> Self {
        Scalars {
            values,
            colormap,
            range: None,
            label: String::new(),
        }
    }

    /// Vertex degrees (valences) through viridis: shows irregular connectivity.
    pub fn degree(topology: &Topology) -> Self {
        let values = topology.degrees().iter().map(|&d| d as f64).collect();
        Scalars::new(values, Colormap::Viridis).with_label("vertex degree")
    }

    /// Height (the y coordinate) through viridis.
    pub fn height(mesh: &TriMesh) -> Self {
        let values = mesh.positions.iter().map(|p| p[1]).collect();
        Scalars::new(values, Colormap::Viridis).with_label("height y")
    }

    /// The values of a float64 `.npy` file holding one value per vertex (shape `(n,)`,
    /// `(n, 1)` or `(1, n)`) of a mesh with `n_vertices` vertices, through `colormap`,
    /// captioned with the file name.
    pub fn from_npy(
        path: &Path,
        n_vertices: usize,
        colormap: Colormap,
    ) -> Result<Self, RenderError> {
        let m = crate::io::read_npy(path)?;
        let values: Vec<f64> = match (m.nrows(), m.ncols()) {
            (_, 1) => m.col(0).iter().copied().collect(),
            (1, _) => m.row(0).iter().copied().collect(),
            (rows, cols) => return Err(RenderError::ScalarShape { rows, cols }),
        };
        if values.len() != n_vertices {
            return Err(RenderError::ScalarCount {
                got: values.len(),
                expected: n_vertices,
            });
        }
        let name = path.file_name().map_or_else(
            || path.display().to_string(),
            |s| s.to_string_lossy().into_owned(),
        );
        Ok(Scalars::new(values, colormap).with_label(name))
    }

    /// Eigenvector `k` (counted from 0, eigenvalues ascending) of the operator `op`
    /// (n×n, `F = D − W`; the cotangent operator with its lumped mass, `L v = λ M v`),
    /// through the diverging cool–warm map, captioned with the index, the operator and
    /// the eigenvalue. See the module documentation for the solvers.
    pub fn eigenvector(op: &Operator, k: usize) -> Result<Self, RenderError> {
        let n = op.matrix.nrows();
        if k >= n {
            return Err(RenderError::EigenIndex { k, n });
        }
        let (lambda, values) = if n <= DENSE_LIMIT {
            let basis = EigenBasis::compute(op, &BasisOptions::default())?;
            let v = basis.vectors().col(k).iter().copied().collect::<Vec<f64>>();
            (basis.eigenvalues()[k], v)
        } else {
            let spectrum = operator_partial_spectrum(
                op,
                op.mass.is_some(),
                &PartialParams::new(k + 1),
                &mut |_, _| {},
            )?;
            let v = spectrum.eigenvectors.col(k).iter().copied().collect();
            (spectrum.eigenvalues[k], v)
        };
        let label = format!(
            "eigenvector {k} of {} (λ = {})",
            op.kind.name().to_uppercase(),
            crate::raster::number::compact(lambda, 4)
        );
        Ok(Scalars::new(values, Colormap::Coolwarm).with_label(label))
    }

    /// The same scalars with a legend caption.
    pub fn with_label(mut self, label: impl Into<String>) -> Self {
        self.label = label.into();
        self
    }

    /// The range mapped to the ends of the color map: [`Scalars::range`] or the
    /// default; `(0, 1)` when no value is finite. A range of zero width is widened to
    /// `lo ± ½` so that a constant gets the middle color.
    pub fn effective_range(&self) -> (f64, f64) {
        let (lo, hi) = self
            .range
            .or_else(|| self.colormap.default_range(&self.values))
            .unwrap_or((0.0, 1.0));
        if hi > lo {
            (lo, hi)
        } else {
            (lo - 0.5, lo + 0.5)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::{open, OpenOptions};
    use crate::operator::{OperatorKind, OperatorOptions};

    #[test]
    fn eigenvectors_are_the_spectral_ones_with_a_diverging_map() {
        let input = open("builtin:icosphere:2", &OpenOptions::default()).unwrap();
        let op = Operator::assemble(
            OperatorKind::Sql,
            &input.mesh,
            &input.topology,
            &OperatorOptions::default(),
        )
        .unwrap();
        let basis = EigenBasis::compute(&op, &BasisOptions::default()).unwrap();
        let s = Scalars::eigenvector(&op, 3).unwrap();
        assert_eq!(s.colormap, Colormap::Coolwarm);
        let want: Vec<f64> = basis.vectors().col(3).iter().copied().collect();
        assert_eq!(s.values, want);
        assert!(
            s.label.starts_with("eigenvector 3 of SQL (λ = "),
            "{}",
            s.label
        );
        // F v = λ v
        let lambda = basis.eigenvalues()[3];
        let fv = &op.matrix * faer::ColRef::from_slice(&s.values);
        let r: f64 = (0..s.values.len())
            .map(|i| (fv[i] - lambda * s.values[i]).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(r < 1e-10, "{r}");
        // symmetric range: zero is the middle gray
        let (lo, hi) = s.effective_range();
        assert_eq!(lo, -hi);
        let n = input.mesh.n_vertices();
        assert!(matches!(
            Scalars::eigenvector(&op, n),
            Err(RenderError::EigenIndex { .. })
        ));
    }

    #[test]
    fn npy_scalars_are_checked_against_the_vertex_count() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.npy");
        let col = faer::Mat::from_fn(12, 1, |i, _| i as f64);
        crate::io::write_npy(&path, col.as_ref()).unwrap();
        let s = Scalars::from_npy(&path, 12, Colormap::Viridis).unwrap();
        assert_eq!(s.values[5], 5.0);
        assert_eq!(s.label, "s.npy");
        let row = faer::Mat::from_fn(1, 12, |_, j| j as f64);
        crate::io::write_npy(&path, row.as_ref()).unwrap();
        assert_eq!(
            Scalars::from_npy(&path, 12, Colormap::Viridis)
                .unwrap()
                .values[7],
            7.0
        );
        let e = Scalars::from_npy(&path, 13, Colormap::Viridis).unwrap_err();
        assert!(
            matches!(
                e,
                RenderError::ScalarCount {
                    got: 12,
                    expected: 13
                }
            ),
            "{e}"
        );
        let block = faer::Mat::from_fn(4, 3, |i, j| (i + j) as f64);
        crate::io::write_npy(&path, block.as_ref()).unwrap();
        assert!(matches!(
            Scalars::from_npy(&path, 12, Colormap::Viridis),
            Err(RenderError::ScalarShape { rows: 4, cols: 3 })
        ));
        assert!(matches!(
            Scalars::from_npy(&dir.path().join("missing.npy"), 12, Colormap::Viridis),
            Err(RenderError::Io(_))
        ));
    }

    #[test]
    fn degree_and_height() {
        let input = open("builtin:grid:3", &OpenOptions::default()).unwrap();
        let d = Scalars::degree(&input.topology);
        assert_eq!(d.values.len(), input.mesh.n_vertices());
        assert!(d.values.iter().all(|&v| (2.0..=6.0).contains(&v)));
        let h = Scalars::height(&input.mesh);
        assert_eq!(h.values[4], input.mesh.positions[4][1]);
    }
}
