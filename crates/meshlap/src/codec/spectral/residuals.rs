//! Residual-coded vertices: after the patches are synthesized, some vertices are
//! coded directly, each coordinate's residual from a prediction rounded with the
//! global step `Δ` (so its error is at most `Δ/2` per coordinate).
//!
//! * **Loose vertices** — vertices on no face of their own patch (rare, from the
//!   partition) have no basis; they are always coded, predicted by the mean of their
//!   decoded neighbours that are not loose.
//! * **Patch borders** — a truncated basis on a patch with a free border reconstructs
//!   the border vertices worst (the basis functions have no constraint there). With
//!   border-aware coding on (`border_residuals`), the border vertices' residuals from
//!   their spectral reconstruction are coded too.

use crate::codec::entropy::IntModel;
use crate::codec::CodecError;
use crate::mesh::graph::VertexGraph;
use glam::DVec3;

/// The residual-coded vertices and how to predict them.
pub(super) struct Residuals {
    /// Vertices in coding order: border vertices (ascending) if border-aware coding is
    /// on, then loose vertices (ascending).
    pub targets: Vec<u32>,
    /// `loose[v]`: `v` is on no face of its patch.
    loose: Vec<bool>,
}

impl Residuals {
    /// The residual-coded vertices given the patch `border` flags, the `loose`
    /// vertices (ascending) and whether border-aware coding is on.
    pub fn new(border: &[bool], loose: &[u32], border_on: bool) -> Self {
        let mut targets: Vec<u32> = if border_on {
            (0..border.len() as u32)
                .filter(|&v| border[v as usize])
                .collect()
        } else {
            Vec::new()
        };
        targets.extend_from_slice(loose);
        let mut set = vec![false; border.len()];
        for &v in loose {
            set[v as usize] = true;
        }
        Residuals {
            targets,
            loose: set,
        }
    }

    /// Prediction of a residual-coded vertex: its own spectral reconstruction, or for
    /// a loose vertex the mean of its decoded non-loose neighbours (origin if none).
    fn prediction(&self, topo: &VertexGraph, v: u32, rec: &[[f64; 3]]) -> DVec3 {
        if !self.loose[v as usize] {
            return DVec3::from(rec[v as usize]);
        }
        let mut s = DVec3::ZERO;
        let mut c = 0usize;
        for &w in topo.neighbors(crate::mesh::VertexId(v)) {
            if !self.loose[w as usize] {
                s += DVec3::from(rec[w as usize]);
                c += 1;
            }
        }
        if c > 0 {
            s / c as f64
        } else {
            s
        }
    }

    /// Codes every target in order: for each coordinate, `code(v, k, prediction,
    /// model)` encodes or decodes the residual's integer, and `rec` becomes
    /// `prediction + q·step`, as the decoder will have it.
    pub fn code(
        &self,
        topo: &VertexGraph,
        rec: &mut [[f64; 3]],
        step: f64,
        models: &mut [IntModel],
        mut code: impl FnMut(u32, usize, f64, &mut IntModel) -> Result<i64, CodecError>,
    ) -> Result<(), CodecError> {
        for &v in &self.targets {
            let pred = self.prediction(topo, v, rec);
            for k in 0..3 {
                let qi = code(v, k, pred[k], &mut models[k])?;
                rec[v as usize][k] = pred[k] + qi as f64 * step;
            }
        }
        Ok(())
    }
}
