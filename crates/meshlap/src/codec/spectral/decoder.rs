//! The spectral decoder: rebuilds the encoder's patches and bases from the decoded
//! connectivity, then reads the coefficients and residuals in the encoder's order.

use super::coefficients::Models;
use super::header::Header;
use super::patches::{
    bases_then, border_and_loose, chunks, layout, predictor_owners, stream, Arithmetic, Recipe,
    CHUNK_BYTES,
};
use super::residuals::Residuals;
use crate::codec::container::ByteReader;
use crate::codec::entropy::RangeDecoder;
use crate::codec::CodecError;
use crate::mesh::graph::VertexGraph;

/// Decodes a spectral geometry stream (header and payload, after the mode byte) of
/// an `.mlz` file of format `version` for the vertex graph `topo` of the decoded
/// connectivity: the positions (n×3) in the decoded vertex order. Version 6 on, the
/// coefficient products and the predictor are computed in fixed-order arithmetic (the
/// same bits on every CPU); versions 4 and 5 with faer's, as they were written.
pub fn decode(topo: &VertexGraph, data: &[u8], version: u16) -> Result<Vec<[f64; 3]>, CodecError> {
    decode_chunked(topo, data, version, CHUNK_BYTES)
}

/// [`decode`] computing the bases in chunks of about `chunk` bytes
/// ([`CHUNK_BYTES`]; the result does not depend on it).
pub(super) fn decode_chunked(
    topo: &VertexGraph,
    data: &[u8],
    version: u16,
    chunk: usize,
) -> Result<Vec<[f64; 3]>, CodecError> {
    let mut r = ByteReader::new(data, "geometry header");
    let Header { params, step } = Header::read(&mut r)?;
    let recipe = Recipe::for_version(version);
    let layout = layout(topo, &params, version)?;
    let mut dec = RangeDecoder::new(r.rest());
    let mut models = Models::new();
    let n = topo.n_vertices();
    let mut rec = vec![[0.0f64; 3]; n];
    // The coefficients depend on the stream only (and the patch sizes), the bases on
    // the connectivity only, and the synthesis `E_m X̃` on the patch only:
    // range-decode every patch in order, compute the bases and synthesize in
    // parallel, then add the predictions in order (each reads earlier patches'
    // positions).
    let mut coefs = Vec::with_capacity(layout.len());
    for l in &layout {
        let q = models.code_patch(l.m, step, params.band_slope, |_, _, _, model| {
            model.decode(&mut dec)
        })?;
        if dec.exhausted() {
            return Err(CodecError::Truncated("geometry stream"));
        }
        coefs.push(q);
    }
    // A patch needs the vectors up to its last non-zero coefficient only: `x̃ = E X̃`
    // summed in index order from +0 adds ±0 for a zero coefficient, which changes
    // no partial sum (none is −0), so the shorter sum has the same bits. Format
    // version 6 on (fixed-order products); older files use every vector.
    let need: Vec<usize> = coefs
        .iter()
        .map(|q| match recipe.arith {
            Arithmetic::Fixed => (0..q.nrows())
                .rev()
                .find(|&j| (0..3).any(|k| q[(j, k)] != 0.0))
                .map_or(0, |j| j + 1),
            Arithmetic::Faer => usize::MAX,
        })
        .collect();
    // Bases and syntheses a chunk at a time (bounded memory at any mesh size), the
    // next chunk computed while the predictions of the current one are added.
    let owner = predictor_owners(n, &params, &layout);
    let compute = |r: std::ops::Range<usize>| {
        // Each basis is used once, for its synthesis, right after it is computed.
        let done = bases_then(
            topo,
            &params,
            recipe,
            &layout,
            owner.as_deref(),
            r,
            |p| need[p],
            |p, mut b| {
                let q = &coefs[p];
                let x = if need[p] < q.nrows() {
                    b.synthesize(&q.subrows(0, need[p]).to_owned())?
                } else {
                    b.synthesize(q)?
                };
                b.basis = None;
                Ok((b, x))
            },
        )?;
        Ok(done)
    };
    stream(&chunks(&layout, chunk), compute, |_, done| {
        for (b, x) in &done {
            let xhat = b.pred.as_ref().map(|pr| pr.predict(&rec));
            b.place(xhat.as_ref(), x, &mut rec);
        }
        Ok(())
    })?;
    let (border, loose) = border_and_loose(topo, &layout);
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
