//! The property report of an assembled operator as `meshlap operator` prints it: the
//! [`PropertyReport`] of the matrix and, for the Tutte Laplacian and the normalized
//! graph Laplacian, the comparison of their spectra (Zhang 2004 §3.3: TL and GL are
//! similar, `G = D^{1/2} T D^{-1/2}`, so their spectra agree). Sign convention of
//! every operator: `F = D − W`, positive semi-definite.

use super::properties::{analyze, PropertyOptions, PropertyReport};
use crate::input::Input;
use crate::operator::{Operator, OperatorError, OperatorKind, OperatorOptions};
use serde::Serialize;

/// What [`operator_report`] returns.
#[derive(Clone, Debug, Serialize)]
pub struct OperatorReport {
    /// The operator.
    pub kind: OperatorKind,
    /// Where the mesh came from.
    pub source: String,
    /// The matrix-theoretic properties, measured on the matrix.
    #[serde(flatten)]
    pub report: PropertyReport,
    /// For TL and GL: `max |λ_TL − λ_GL|` over the sorted spectra, measured on both
    /// matrices (`None` for other kinds or when the spectrum was not computed).
    pub same_spectrum_max_difference: Option<f64>,
}

/// The kind whose spectrum equals `kind`'s by similarity (TL ↔ GL), if any.
pub fn similar_kind(kind: OperatorKind) -> Option<OperatorKind> {
    match kind {
        OperatorKind::Tutte => Some(OperatorKind::Graph),
        OperatorKind::Graph => Some(OperatorKind::Tutte),
        _ => None,
    }
}

/// Analyzes `op` (assembled on `input` with `opts`) with [`analyze`]; for TL and GL
/// also assembles the [`similar_kind`] and reports the largest difference of the two
/// sorted spectra.
///
/// # Errors
/// [`OperatorError`] when the similar operator cannot be assembled on the mesh.
pub fn operator_report(
    input: &Input,
    op: &Operator,
    opts: &OperatorOptions,
    popts: &PropertyOptions,
) -> Result<OperatorReport, OperatorError> {
    let report = analyze(&op.matrix, popts);
    let same = match (similar_kind(op.kind), &report.eigenvalues) {
        (Some(p), Some(ev)) => {
            let other = Operator::assemble(p, &input.mesh, &input.topology, opts)?;
            analyze(&other.matrix, popts).eigenvalues.map(|ov| {
                ev.iter()
                    .zip(&ov)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max)
            })
        }
        _ => None,
    };
    Ok(OperatorReport {
        kind: op.kind,
        source: input.source.clone(),
        report,
        same_spectrum_max_difference: same,
    })
}
