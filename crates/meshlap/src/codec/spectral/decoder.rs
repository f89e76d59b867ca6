//! The spectral decoder: rebuilds the encoder's patches and bases from the decoded
//! connectivity, then reads the coefficients and residuals in the encoder's order.

use super::coefficients::Models;
use super::header::Header;
use super::patches::{bases, border_and_loose, Arithmetic};
use super::residuals::Residuals;
use crate::codec::container::ByteReader;
use crate::codec::entropy::RangeDecoder;
use crate::codec::CodecError;
use crate::mesh::topology::Topology;
use rayon::prelude::*;

/// Decodes a spectral geometry stream (header and payload, after the mode byte) of
/// an `.mlz` file of format `version` for the decoded connectivity `topo`: the
/// positions (n×3) in the decoded vertex order. Version 6 on, the coefficient
/// products and the predictor are computed in fixed-order arithmetic (the same bits
/// on every CPU); versions 4 and 5 with faer's, as they were written.
pub fn decode(topo: &Topology, data: &[u8], version: u16) -> Result<Vec<[f64; 3]>, CodecError> {
    let mut r = ByteReader::new(data, "geometry header");
    let Header { params, step } = Header::read(&mut r)?;
    let bases = bases(topo, &params, Arithmetic::for_version(version))?;
    let mut dec = RangeDecoder::new(r.rest());
    let mut models = Models::new();
    let n = topo.n_vertices();
    let mut rec = vec![[0.0f64; 3]; n];
    // The coefficients depend on the stream only and the synthesis `E_m X̃` on the
    // patch only: range-decode every patch in order, synthesize in parallel, then
    // add the predictions in order (each reads earlier patches' positions).
    let mut coefs = Vec::with_capacity(bases.len());
    for b in &bases {
        let q = models.code_patch(b.m, step, params.band_slope, |_, _, _, model| {
            model.decode(&mut dec)
        })?;
        if dec.exhausted() {
            return Err(CodecError::Truncated("geometry stream"));
        }
        coefs.push(q);
    }
    let synth = bases
        .par_iter()
        .zip(coefs.par_iter())
        .map(|(b, q)| b.synthesize(q))
        .collect::<Result<Vec<_>, _>>()?;
    for (b, x) in bases.iter().zip(&synth) {
        let xhat = b.pred.as_ref().map(|pr| pr.predict(&rec));
        b.place(xhat.as_ref(), x, &mut rec);
    }
    let (border, loose) = border_and_loose(topo, &bases);
    Residuals::new(&border, &loose, params.border_residuals).code(
        topo,
        &mut rec,
        step,
        &mut models.resid,
        |_, _, _, model| model.decode(&mut dec),
    )?;
    dec.finish()?;
    if rec.iter().flatten().any(|x| !x.is_finite()) {
        return Err(CodecError::Corrupt("non-finite decoded coordinate"));
    }
    Ok(rec)
}
