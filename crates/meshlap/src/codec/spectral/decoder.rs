//! The spectral decoder: rebuilds the encoder's patches and bases from the decoded
//! connectivity, then reads the coefficients and residuals in the encoder's order.

use super::coefficients::Models;
use super::header::Header;
use super::patches::{
    bases_then, border_and_loose, chunks, layout, predictor_owners, stream, Arithmetic, Progress,
    Recipe, StopOnDrop, CHUNK_BYTES,
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
    let n = topo.n_vertices();
    let mut rec = vec![[0.0f64; 3]; n];
    // The coefficients depend on the stream only (and the patch sizes), the bases on
    // the connectivity only, and the synthesis `E_m X̃` on the patch only:
    // range-decode every patch in order (on a thread of its own when the pool has
    // more than one, so that the bases start at once and wait only for coefficients
    // not decoded yet), compute the bases and synthesize in parallel, then add the
    // predictions in order (each reads earlier patches' positions).
    let coefs = Coefficients::new(layout.len());
    let data = r.rest();
    let decode_all = || {
        let mut dec = RangeDecoder::new(data);
        let mut models = Models::new();
        let mut failed = StopOnDrop(Some(&coefs.progress));
        for (p, l) in layout.iter().enumerate() {
            let q = models.code_patch(l.m, step, params.band_slope, |_, _, _, model| {
                model.decode(&mut dec)
            })?;
            if dec.exhausted() {
                return Err(CodecError::Truncated("geometry stream"));
            }
            // A patch needs the vectors up to its last non-zero coefficient only:
            // `x̃ = E X̃` summed in index order from +0 adds ±0 for a zero
            // coefficient, which changes no partial sum (none is −0), so the shorter
            // sum has the same bits. Format version 6 on (fixed-order products);
            // older files use every vector.
            let need = match recipe.arith {
                Arithmetic::Fixed => (0..q.nrows())
                    .rev()
                    .find(|&j| (0..3).any(|k| q[(j, k)] != 0.0))
                    .map_or(0, |j| j + 1),
                Arithmetic::Faer => usize::MAX,
            };
            coefs.publish(p, q, need);
        }
        failed.0 = None;
        Ok((dec, models))
    };
    let owner = predictor_owners(n, &params, &layout);
    let mut synthesize = || {
        let need = |p: usize| coefs.wait(p).map_or(usize::MAX, |&(_, m)| m);
        // Bases and syntheses a chunk at a time (bounded memory at any mesh size),
        // each patch's prediction added as soon as every earlier patch is placed.
        let compute = |r: std::ops::Range<usize>, sink: &(dyn Fn(usize, _) + Sync)| {
            // Each basis is used once, for its synthesis, right after it is computed.
            bases_then(
                topo,
                &params,
                recipe,
                &layout,
                owner.as_deref(),
                r,
                need,
                |p, mut b| {
                    let (q, m) = coefs
                        .wait(p)
                        .ok_or(CodecError::Truncated("geometry stream"))?;
                    let m = *m;
                    let x = if m < q.nrows() {
                        b.synthesize(&q.subrows(0, m).to_owned())?
                    } else {
                        b.synthesize(q)?
                    };
                    b.basis = None;
                    sink(p, (b, x));
                    Ok(())
                },
            )?;
            Ok(())
        };
        stream(&chunks(&layout, chunk), compute, |_, (b, x)| {
            let xhat = b.pred.as_ref().map(|pr| pr.predict(&rec));
            b.place(xhat.as_ref(), &x, &mut rec);
            Ok(())
        })
    };
    let (mut dec, mut models) = if rayon::current_num_threads() > 1 {
        let (decoded, synthesized) = std::thread::scope(|sc| {
            let coder = sc.spawn(decode_all);
            let synthesized = synthesize();
            let decoded = coder
                .join()
                .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
            (decoded, synthesized)
        });
        // A stream error stops the bases at the patch it hit: report it first.
        let decoded = decoded?;
        synthesized?;
        decoded
    } else {
        let decoded = decode_all()?;
        synthesize()?;
        decoded
    };
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

/// Each patch's decoded coefficients and how many of its vectors they need,
/// published one patch at a time by the range decoder and awaited by the bases that
/// need them.
struct Coefficients {
    slots: Vec<std::sync::OnceLock<(faer::Mat<f64>, usize)>>,
    /// Patches published so far, and whether the decoder stopped early.
    progress: Progress,
}

impl Coefficients {
    fn new(patches: usize) -> Self {
        Self {
            slots: (0..patches).map(|_| std::sync::OnceLock::new()).collect(),
            progress: Progress::new(0),
        }
    }

    /// Publishes patch `p`'s coefficients and the vectors they need (patches in
    /// order).
    fn publish(&self, p: usize, q: faer::Mat<f64>, need: usize) {
        let _ = self.slots[p].set((q, need));
        self.progress.advance(p + 1);
    }

    /// Patch `p`'s coefficients and the vectors they need, once published; `None`
    /// if the decoder stopped before it.
    fn wait(&self, p: usize) -> Option<&(faer::Mat<f64>, usize)> {
        match self.slots[p].get() {
            Some(c) => Some(c),
            None => {
                self.progress.wait_past(p);
                self.slots[p].get()
            }
        }
    }
}
