//! An operator as the symmetric generalized problem `K v = λ M v`.

use crate::operator::symmetrize::{diagonal_symmetrizer, symmetric_product};
use crate::operator::Operator;
use crate::spectral::SpectralError;
use crate::SparseMatrix;

/// The generalized problem `K v = λ M v` an operator's spectrum is computed from
/// (sign convention `F = D − W`: K is positive semi-definite for the paper's
/// operators).
#[derive(Clone, Debug)]
pub struct SymmetricProblem {
    /// Symmetric stiffness `K` (both triangles stored).
    pub stiffness: SparseMatrix,
    /// Positive diagonal `M`; `None` for the identity.
    pub mass: Option<Vec<f64>>,
}

impl SymmetricProblem {
    /// The problem of an assembled operator: symmetric kinds as they are, the
    /// cotangent operator with its lumped mass when `use_mass`, and a non-symmetric
    /// operator through its positive diagonal symmetrizer `S` (`K = SF`, `M = S`).
    pub fn from_operator(op: &Operator, use_mass: bool) -> Result<Self, SpectralError> {
        if op.kind.is_symmetric() {
            let mass = if use_mass { op.mass.clone() } else { None };
            return Ok(Self {
                stiffness: op.matrix.clone(),
                mass,
            });
        }
        let s = diagonal_symmetrizer(&op.matrix).ok_or(SpectralError::NoRealSpectrum(op.kind))?;
        let k = symmetric_product(&op.matrix, &s).map_err(SpectralError::SparseCreation)?;
        Ok(Self {
            stiffness: k,
            mass: Some(s),
        })
    }
}
