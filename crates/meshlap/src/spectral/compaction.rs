//! Energy compaction — the paper's *transform efficiency* (Zhang 2004 §4.9): the
//! fraction of the signal energy concentrated in the first m spectral coefficients,
//! for every m.
//!
//! For coefficients `X` (k×c, row j ↔ eigenvalue j ascending, column = coordinate):
//!
//! `η_c(m) = Σ_{j<m} X_jc² / Σ_{j<k} X_jc²` per coordinate, and
//! `η(m) = Σ_c Σ_{j<m} X_jc² / Σ_c Σ_{j<k} X_jc²` in total.
//!
//! For an orthonormal basis (symmetric operators) the denominator is ‖x‖² (Parseval)
//! and `η(m) = ‖x⁽ᵐ⁾‖²/‖x‖²`. For the TL the basis is not orthogonal; with
//! unit-norm columns (as Matlab's `eig` returns them, the paper's setting) the
//! energy is that of the coefficients. A signal with zero energy in a coordinate
//! gets `η_c = 1` for every m.
//!
//! The first coefficient of a GSML carries the centroid (its eigenvector is
//! constant), so translating the mesh changes η; compare operators on centred
//! meshes ([`centre`]) unless the DC term is wanted.

use faer::{Mat, MatRef};
use serde::Serialize;

/// Transform efficiency for every m.
#[derive(Clone, Debug, Serialize)]
pub struct Compaction {
    /// `per_coordinate[c][m−1] = η_c(m)`, m = 1..=k.
    pub per_coordinate: Vec<Vec<f64>>,
    /// `total[m−1] = η(m)`, m = 1..=k.
    pub total: Vec<f64>,
    /// Total coefficient energy per coordinate, `Σ_j X_jc²`.
    pub energy: Vec<f64>,
}

impl Compaction {
    /// Number of coefficients k.
    pub fn len(&self) -> usize {
        self.total.len()
    }

    /// True when there are no coefficients.
    pub fn is_empty(&self) -> bool {
        self.total.is_empty()
    }

    /// The smallest m with `η(m) ≥ fraction` (k if never reached by rounding).
    pub fn coefficients_for(&self, fraction: f64) -> usize {
        self.total
            .iter()
            .position(|&e| e >= fraction)
            .map_or(self.total.len(), |p| p + 1)
    }

    /// Mean of `η(m)` over m = 1..=k: the area under the compaction curve, one
    /// number to rank operators (higher = better compaction).
    pub fn mean_efficiency(&self) -> f64 {
        if self.total.is_empty() {
            return 0.0;
        }
        self.total.iter().sum::<f64>() / self.total.len() as f64
    }
}

/// Transform efficiency of the k×c coefficients `coeffs`, for every m.
pub fn energy_compaction(coeffs: MatRef<'_, f64>) -> Compaction {
    let (k, c) = (coeffs.nrows(), coeffs.ncols());
    let mut cum = vec![vec![0.0f64; k]; c];
    let mut cum_total = vec![0.0f64; k];
    let mut energy = vec![0.0f64; c];
    let mut total = 0.0f64;
    for j in 0..k {
        for col in 0..c {
            let e = coeffs[(j, col)].powi(2);
            energy[col] += e;
            total += e;
            cum[col][j] = energy[col];
        }
        cum_total[j] = total;
    }
    let norm = |v: &mut Vec<f64>, tot: f64| {
        v.iter_mut()
            .for_each(|x| *x = if tot > 0.0 { (*x / tot).min(1.0) } else { 1.0 })
    };
    for col in 0..c {
        norm(&mut cum[col], energy[col]);
    }
    norm(&mut cum_total, total);
    Compaction {
        per_coordinate: cum,
        total: cum_total,
        energy,
    }
}

/// The energy compaction of a mesh's vertex positions (n×3) in the ED basis of `op`
/// (dense, n ≤ [`super::DENSE_LIMIT`]), centred first when `centred`: the one-shot
/// behind `meshlap compaction`. Returns the compaction and the eigensolver path.
pub fn positions_compaction(
    op: &crate::operator::Operator,
    positions: &[[f64; 3]],
    centred: bool,
    opts: &super::BasisOptions,
) -> Result<(Compaction, super::EigenPath), super::SpectralError> {
    let basis = super::EigenBasis::compute(op, opts)?;
    let mut x = super::positions_to_mat(positions);
    if centred {
        x = centre(x.as_ref());
    }
    let coeffs = super::forward(&basis, x.as_ref())?;
    Ok((energy_compaction(coeffs.as_ref()), basis.path()))
}

/// The signal with each column's mean removed (the mesh translated to its centroid).
pub fn centre(x: MatRef<'_, f64>) -> Mat<f64> {
    let n = x.nrows().max(1) as f64;
    let means: Vec<f64> = (0..x.ncols())
        .map(|c| x.col(c).iter().sum::<f64>() / n)
        .collect();
    Mat::from_fn(x.nrows(), x.ncols(), |i, c| x[(i, c)] - means[c])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{builtin, topology::Topology};
    use crate::operator::{Operator, OperatorKind, OperatorOptions};
    use crate::spectral::{forward, positions_to_mat, truncated, BasisOptions, EigenBasis};

    #[test]
    fn hand_computed() {
        let x = Mat::from_fn(3, 2, |i, c| [[3.0, 0.0], [4.0, 0.0], [0.0, 0.0]][i][c]);
        let e = energy_compaction(x.as_ref());
        assert_eq!(e.per_coordinate[0], vec![9.0 / 25.0, 1.0, 1.0]);
        assert_eq!(e.per_coordinate[1], vec![1.0, 1.0, 1.0]);
        assert_eq!(e.total, vec![9.0 / 25.0, 1.0, 1.0]);
        assert_eq!(e.energy, vec![25.0, 0.0]);
        assert_eq!(e.coefficients_for(0.5), 2);
        assert_eq!(e.coefficients_for(0.3), 1);
    }

    #[test]
    fn orthonormal_efficiency_is_reconstruction_energy() {
        // Parseval: for a symmetric operator η(m) = ‖x⁽ᵐ⁾‖²/‖x‖², computed the
        // second way from the truncated reconstruction.
        let m = builtin::icosphere(2).unwrap();
        let t = Topology::new(&m).unwrap();
        let op =
            Operator::assemble(OperatorKind::Sql, &m, &t, &OperatorOptions::default()).unwrap();
        let b = EigenBasis::compute(&op, &BasisOptions::default()).unwrap();
        let x = centre(positions_to_mat(&m.positions).as_ref());
        let comp = energy_compaction(forward(&b, x.as_ref()).unwrap().as_ref());
        let total: f64 = x.col_iter().map(|c| c.squared_norm_l2()).sum();
        for keep in [1, 4, 9, 30, 100, b.len()] {
            let y = truncated(&b, x.as_ref(), keep).unwrap();
            let e: f64 = y.col_iter().map(|c| c.squared_norm_l2()).sum();
            assert!(
                (comp.total[keep - 1] - e / total).abs() < 1e-12,
                "m = {keep}"
            );
        }
        // Monotone, ends at 1; the centred sphere has no DC energy.
        assert!(comp.total.windows(2).all(|w| w[0] <= w[1] + 1e-15));
        assert!((comp.total[b.len() - 1] - 1.0).abs() < 1e-12);
        assert!(comp.total[0] < 1e-20);
        // The sphere's coordinates are the first non-trivial harmonics: 3 of the
        // first 4 coefficients hold almost all the energy.
        assert!(comp.total[3] > 0.99, "{}", comp.total[3]);
    }
}
