//! The permutation section: the input vertex of each decoded vertex, stored when the
//! input vertex order must be kept (`preserve_order`).

use super::entropy::{RangeDecoder, RangeEncoder};
use super::CodecError;
use crate::mesh::TriMesh;

/// The stream of `order` (a permutation of `0..n`): each entry in `⌈log2 n⌉`
/// equiprobable bits.
pub(super) fn encode(order: &[u32]) -> Vec<u8> {
    let n = order.len();
    let bits = usize::BITS - n.saturating_sub(1).leading_zeros();
    let mut enc = RangeEncoder::new();
    for &v in order {
        enc.direct(v, bits);
    }
    enc.finish()
}

/// Decodes a permutation of `0..n`; an error unless every entry is in range and
/// appears once.
pub(super) fn decode(data: &[u8], n: usize) -> Result<Vec<u32>, CodecError> {
    let bits = usize::BITS - n.saturating_sub(1).leading_zeros();
    // Each entry takes `bits` bits: bound the count by the data before allocating.
    if (n as u64) * (bits as u64) > (data.len() as u64 + 8) * 8 {
        return Err(CodecError::Truncated("permutation"));
    }
    let mut dec = RangeDecoder::new(data);
    let mut seen = vec![false; n];
    let mut order = Vec::with_capacity(n);
    for _ in 0..n {
        let v = dec.direct(bits) as usize;
        if v >= n || seen[v] {
            return Err(CodecError::Corrupt("permutation is not a permutation"));
        }
        seen[v] = true;
        order.push(v as u32);
    }
    dec.finish()?;
    Ok(order)
}

/// The mesh in the input vertex order: decoded vertex `i` (position `pos[i]`) becomes
/// vertex `order[i]`, and the faces are renumbered alike.
pub(super) fn apply(order: &[u32], pos: &[[f64; 3]], faces: &[[u32; 3]]) -> TriMesh {
    let mut out = vec![[0.0; 3]; order.len()];
    for (i, &v) in order.iter().enumerate() {
        out[v as usize] = pos[i];
    }
    let faces = faces.iter().map(|f| f.map(|v| order[v as usize])).collect();
    TriMesh::new(out, faces)
}
