//! Adaptive binary range coding (the LZMA range coder) with context models for bits,
//! small alphabets and unbounded integers.
//!
//! Every symbol is coded as a sequence of binary decisions, each with its own adaptive
//! probability: the mean of two exponentially forgetting estimates, a fast one
//! (`p += (1 − p)/16`) and a slow one (`p += (1 − p)/64`), used at 12 bits (format
//! version 2; version 1 had a single `1/32` estimate at 11 bits). The pair tracks
//! both short bursts and stable statistics, and coded both connectivity and geometry
//! smaller than a single rate or other pairs (BENCHMARKS.md, Compression). A
//! multi-symbol alphabet is a binary tree of such decisions
//! ([`BitTree`]); an integer is its Elias-gamma bit length coded by a bit tree plus
//! its mantissa, the first bits adaptive and the rest equiprobable ([`UintModel`]).
//!
//! Why hand-written: the `constriction` crate's entropy models are static or
//! parametric (categorical models are built once from a histogram), so the
//! per-decision adaptive context modelling a connectivity coder needs would rebuild a
//! model per symbol; a binary adaptive range coder is ~100 lines and exactly the
//! design of LZMA/Draco's `RAnsBitEncoder` family.
//!
//! Decoding never panics on bad input: reading past the end yields zero bytes and is
//! counted, and [`RangeDecoder::finish`] reports an overrun as
//! [`super::CodecError::Truncated`].

use super::CodecError;

/// Bits of the probability used for coding.
const PROB_BITS: u32 = 12;
/// Most binary decisions one byte of range-coded output can hold. A decision costs at
/// least `−log2(1 − 2^−PROB_BITS)` ≈ 3.52e-4 bits (the likelier symbol at the
/// saturated probability), so a byte holds at most ≈ 22,711; the range coder's
/// truncation only adds to the cost. Decoders bound the counts a header asks them to
/// allocate by this before allocating (a test checks it against the formula).
pub(crate) const MAX_DECISIONS_PER_BYTE: u64 = 22_800;
/// Scale of the two internal estimates (15 bits each; their sum has 16).
const EST_ONE: u32 = 1 << 15;
/// Adaptation shifts of the fast and slow estimates (windows of about 16 and 64 bits).
const FAST_SHIFT: u32 = 4;
const SLOW_SHIFT: u32 = 6;
const TOP: u32 = 1 << 24;

/// An adaptive probability that the next bit is 0 (initially ½).
#[derive(Clone, Copy, Debug)]
pub struct BitModel {
    fast: u16,
    slow: u16,
}

impl Default for BitModel {
    fn default() -> Self {
        BitModel {
            fast: (EST_ONE / 2) as u16,
            slow: (EST_ONE / 2) as u16,
        }
    }
}

impl BitModel {
    /// Probability of a 0, in `1..2^PROB_BITS`: the mean of the two estimates.
    #[inline]
    fn p0(&self) -> u32 {
        (self.fast as u32 + self.slow as u32) >> (16 - PROB_BITS)
    }
    /// Cost in bits of coding `bit` now (`−log2` of its probability; no update).
    #[inline]
    pub fn cost(&self, bit: bool) -> f32 {
        let p0 = self.p0() as usize;
        cost_table()[if bit { (1 << PROB_BITS) - p0 } else { p0 }]
    }
    #[inline]
    fn update(&mut self, bit: bool) {
        let (f, s) = (FAST_SHIFT, SLOW_SHIFT);
        let (a, b) = (self.fast as u32, self.slow as u32);
        if !bit {
            self.fast = (a + ((EST_ONE - a) >> f)) as u16;
            self.slow = (b + ((EST_ONE - b) >> s)) as u16;
        } else {
            self.fast = (a - (a >> f)) as u16;
            self.slow = (b - (b >> s)) as u16;
        }
    }
}

/// `−log2(p / 2^PROB_BITS)` for every probability `p` (index 0 unused).
fn cost_table() -> &'static [f32; 1 << PROB_BITS] {
    static TABLE: std::sync::OnceLock<Box<[f32; 1 << PROB_BITS]>> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let mut t = Box::new([0f32; 1 << PROB_BITS]);
        for (p, c) in t.iter_mut().enumerate().skip(1) {
            *c = -((p as f64) / (1u32 << PROB_BITS) as f64).log2() as f32;
        }
        t[0] = PROB_BITS as f32;
        t
    })
}

/// Range encoder producing a byte vector.
#[derive(Debug)]
pub struct RangeEncoder {
    low: u64,
    range: u32,
    cache: u8,
    cache_size: u64,
    out: Vec<u8>,
}

impl Default for RangeEncoder {
    fn default() -> Self {
        Self::new()
    }
}

impl RangeEncoder {
    /// An empty encoder.
    pub fn new() -> Self {
        RangeEncoder {
            low: 0,
            range: u32::MAX,
            cache: 0,
            cache_size: 1,
            out: Vec::new(),
        }
    }

    fn shift_low(&mut self) {
        if (self.low as u32) < 0xFF00_0000 || (self.low >> 32) != 0 {
            let carry = (self.low >> 32) as u8;
            let mut temp = self.cache;
            loop {
                self.out.push(temp.wrapping_add(carry));
                temp = 0xFF;
                self.cache_size -= 1;
                if self.cache_size == 0 {
                    break;
                }
            }
            self.cache = (self.low >> 24) as u8;
        }
        self.cache_size += 1;
        self.low = (self.low & 0x00FF_FFFF) << 8;
    }

    fn normalize(&mut self) {
        while self.range < TOP {
            self.range <<= 8;
            self.shift_low();
        }
    }

    /// Codes `bit` with the adaptive probability `m`.
    #[inline]
    pub fn bit(&mut self, m: &mut BitModel, bit: bool) {
        let bound = (self.range >> PROB_BITS) * m.p0();
        if !bit {
            self.range = bound;
        } else {
            self.low += bound as u64;
            self.range -= bound;
        }
        m.update(bit);
        self.normalize();
    }

    /// Codes the low `n ≤ 32` bits of `v` with probability ½ each (most significant
    /// first).
    pub fn direct(&mut self, v: u32, n: u32) {
        for i in (0..n).rev() {
            self.range >>= 1;
            if (v >> i) & 1 == 1 {
                self.low += self.range as u64;
            }
            self.normalize();
        }
    }

    /// Flushes and returns the coded bytes.
    pub fn finish(mut self) -> Vec<u8> {
        for _ in 0..5 {
            self.shift_low();
        }
        self.out
    }
}

/// Range decoder over a byte slice.
#[derive(Debug)]
pub struct RangeDecoder<'a> {
    data: &'a [u8],
    pos: usize,
    range: u32,
    code: u32,
    overrun: usize,
}

impl<'a> RangeDecoder<'a> {
    /// Starts decoding `data` (as produced by [`RangeEncoder::finish`]).
    pub fn new(data: &'a [u8]) -> Self {
        let mut d = RangeDecoder {
            data,
            pos: 0,
            range: u32::MAX,
            code: 0,
            overrun: 0,
        };
        for _ in 0..5 {
            d.code = (d.code << 8) | d.byte() as u32;
        }
        d
    }

    #[inline]
    fn byte(&mut self) -> u8 {
        match self.data.get(self.pos) {
            Some(&b) => {
                self.pos += 1;
                b
            }
            None => {
                self.overrun += 1;
                0
            }
        }
    }

    fn normalize(&mut self) {
        while self.range < TOP {
            self.range <<= 8;
            self.code = (self.code << 8) | self.byte() as u32;
        }
    }

    /// True when the decoder has read more than 8 bytes past the end of its input: the
    /// stream is truncated and further symbols are garbage. Loops driven by decoded
    /// symbols check this to stop early.
    #[inline]
    pub fn exhausted(&self) -> bool {
        self.overrun > 8
    }

    /// Decodes a bit with the adaptive probability `m`.
    #[inline]
    pub fn bit(&mut self, m: &mut BitModel) -> bool {
        let bound = (self.range >> PROB_BITS) * m.p0();
        let bit = if self.code < bound {
            self.range = bound;
            false
        } else {
            self.code -= bound;
            self.range -= bound;
            true
        };
        m.update(bit);
        self.normalize();
        bit
    }

    /// Decodes `n ≤ 32` equiprobable bits.
    pub fn direct(&mut self, n: u32) -> u32 {
        let mut v = 0u32;
        for _ in 0..n {
            self.range >>= 1;
            let b = if self.code >= self.range {
                self.code -= self.range;
                1
            } else {
                0
            };
            v = (v << 1) | b;
            self.normalize();
        }
        v
    }

    /// Ends decoding: an error if the input ran out (beyond the encoder's 4-byte
    /// flush slack).
    pub fn finish(self) -> Result<(), CodecError> {
        if self.overrun > 4 {
            Err(CodecError::Truncated("range-coded stream"))
        } else {
            Ok(())
        }
    }
}

/// Adaptive model of a symbol in `0..2^bits` as a binary tree of decisions.
#[derive(Clone, Debug)]
pub struct BitTree {
    bits: u32,
    probs: Vec<BitModel>,
}

impl BitTree {
    /// A model for `bits`-bit symbols.
    pub fn new(bits: u32) -> Self {
        BitTree {
            bits,
            probs: vec![BitModel::default(); 1 << bits],
        }
    }

    /// Encodes `sym < 2^bits`.
    pub fn encode(&mut self, enc: &mut RangeEncoder, sym: u32) {
        for (node, b) in tree_path(sym as u64, self.bits) {
            enc.bit(&mut self.probs[node], b);
        }
    }

    /// Cost in bits of coding `sym` now (no update).
    pub fn cost(&self, sym: u32) -> f32 {
        tree_path(sym as u64, self.bits).fold(0.0, |c, (node, b)| c + self.probs[node].cost(b))
    }

    /// Decodes a symbol.
    pub fn decode(&mut self, dec: &mut RangeDecoder) -> u32 {
        let mut node = 1usize;
        for _ in 0..self.bits {
            let b = dec.bit(&mut self.probs[node]);
            node = (node << 1) | b as usize;
        }
        (node - (1 << self.bits)) as u32
    }
}

/// The decisions that code the low `n` bits of `value` (most significant first) in a
/// binary tree of models: each bit with its node's index (the root is 1, the
/// children of node `t` are `2t` and `2t + 1`).
fn tree_path(value: u64, n: u32) -> impl Iterator<Item = (usize, bool)> {
    let mut node = 1usize;
    (0..n).rev().map(move |i| {
        let b = (value >> i) & 1 == 1;
        let at = node;
        node = (node << 1) | b as usize;
        (at, b)
    })
}

/// Number of mantissa bits (below the leading one) coded adaptively.
const ADAPTIVE_MANTISSA: u32 = 2;

/// Adaptive model of an unsigned integer `< 2^32`: Elias-gamma style, the bit length
/// `⌊log2(v+1)⌋ ∈ 0..=32` through a [`BitTree`], then the bits below the leading one,
/// the top two adaptive (per length), the rest direct.
#[derive(Clone, Debug)]
pub struct UintModel {
    len: BitTree,
    mant: Vec<BitModel>,
}

impl Default for UintModel {
    fn default() -> Self {
        UintModel {
            len: BitTree::new(6),
            mant: vec![BitModel::default(); 33 << ADAPTIVE_MANTISSA],
        }
    }
}

impl UintModel {
    /// `(len, rest)` with `v + 1 = 2^len + rest`, `rest < 2^len`.
    fn split(v: u32) -> (u32, u64) {
        let w = v as u64 + 1;
        let len = 63 - w.leading_zeros(); // position of the leading one, 0..=32
        (len, w - (1u64 << len))
    }

    /// The model of mantissa node `node` of the integers of bit length `len`.
    fn mant_index(len: u32, node: usize) -> usize {
        ((len as usize) << ADAPTIVE_MANTISSA) | node
    }

    /// Encodes `v`.
    pub fn encode(&mut self, enc: &mut RangeEncoder, v: u32) {
        let (len, rest) = Self::split(v);
        self.len.encode(enc, len);
        let na = len.min(ADAPTIVE_MANTISSA);
        for (node, b) in tree_path(rest >> (len - na), na) {
            enc.bit(&mut self.mant[Self::mant_index(len, node)], b);
        }
        let nd = len - na;
        if nd > 0 {
            enc.direct((rest & ((1u64 << nd) - 1)) as u32, nd);
        }
    }

    /// Cost in bits of coding `v` now (no update).
    pub fn cost(&self, v: u32) -> f32 {
        let (len, rest) = Self::split(v);
        let na = len.min(ADAPTIVE_MANTISSA);
        let c = tree_path(rest >> (len - na), na).fold(self.len.cost(len), |c, (node, b)| {
            c + self.mant[Self::mant_index(len, node)].cost(b)
        });
        c + (len - na) as f32
    }

    /// Decodes a value; an error if the coded length exceeds 32 bits.
    pub fn decode(&mut self, dec: &mut RangeDecoder) -> Result<u32, CodecError> {
        let len = self.len.decode(dec);
        if len > 32 {
            return Err(CodecError::Corrupt("integer longer than 32 bits"));
        }
        let na = len.min(ADAPTIVE_MANTISSA);
        let mut node = 1usize;
        let mut rest = 0u64;
        for _ in 0..na {
            let b = dec.bit(&mut self.mant[Self::mant_index(len, node)]);
            node = (node << 1) | b as usize;
            rest = (rest << 1) | b as u64;
        }
        let nd = len - na;
        if nd > 0 {
            rest = (rest << nd) | dec.direct(nd) as u64;
        }
        let w = (1u64 << len) + rest;
        u32::try_from(w - 1).map_err(|_| CodecError::Corrupt("integer out of range"))
    }
}

/// Adaptive model of a signed integer: a zero flag, a sign and a [`UintModel`] of
/// `|v| − 1`.
#[derive(Clone, Debug, Default)]
pub struct IntModel {
    zero: BitModel,
    sign: BitModel,
    mag: UintModel,
}

impl IntModel {
    /// Encodes `v` (`|v| < 2^32`).
    pub fn encode(&mut self, enc: &mut RangeEncoder, v: i64) {
        enc.bit(&mut self.zero, v != 0);
        if v != 0 {
            enc.bit(&mut self.sign, v < 0);
            self.mag.encode(enc, (v.unsigned_abs() - 1) as u32);
        }
    }

    /// Cost in bits of coding `v` now (no update).
    pub fn cost(&self, v: i64) -> f32 {
        if v == 0 {
            return self.zero.cost(false);
        }
        self.zero.cost(true)
            + self.sign.cost(v < 0)
            + self
                .mag
                .cost((v.unsigned_abs() - 1).min(u32::MAX as u64) as u32)
    }

    /// Decodes a value.
    pub fn decode(&mut self, dec: &mut RangeDecoder) -> Result<i64, CodecError> {
        if !dec.bit(&mut self.zero) {
            return Ok(0);
        }
        let neg = dec.bit(&mut self.sign);
        let m = self.mag.decode(dec)? as i64 + 1;
        Ok(if neg { -m } else { m })
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn decisions_per_byte_bound_holds() {
        let one = (1u64 << super::PROB_BITS) as f64;
        let min_bits = -((one - 1.0) / one).log2();
        assert!(8.0 / min_bits <= super::MAX_DECISIONS_PER_BYTE as f64);
        assert!(8.0 / min_bits > 0.99 * super::MAX_DECISIONS_PER_BYTE as f64);
        // The saturated probability is the one the bound assumes.
        let mut m = super::BitModel::default();
        for _ in 0..10_000 {
            m.update(false);
        }
        assert!(m.p0() < (1 << super::PROB_BITS));
    }

    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn round_trip_mixed_symbols() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let n = 20_000;
        let bits: Vec<bool> = (0..n).map(|_| rng.gen_bool(0.9)).collect();
        let syms: Vec<u32> = (0..n).map(|_| rng.gen_range(0..6)).collect();
        let uints: Vec<u32> = (0..n)
            .map(|i| match i % 4 {
                0 => 0,
                1 => rng.gen_range(0..10),
                2 => rng.gen(),
                _ => u32::MAX,
            })
            .collect();
        let ints: Vec<i64> = (0..n).map(|_| rng.gen_range(-5000..5000)).collect();
        let direct: Vec<u32> = (0..n).map(|_| rng.gen_range(0..1 << 13)).collect();
        // The same fresh models on both sides.
        let models = || {
            (
                BitModel::default(),
                BitTree::new(3),
                UintModel::default(),
                IntModel::default(),
            )
        };
        let mut enc = RangeEncoder::new();
        let (mut bm, mut bt, mut um, mut im) = models();
        for i in 0..n {
            enc.bit(&mut bm, bits[i]);
            bt.encode(&mut enc, syms[i]);
            um.encode(&mut enc, uints[i]);
            im.encode(&mut enc, ints[i]);
            enc.direct(direct[i], 13);
        }
        let data = enc.finish();
        let mut dec = RangeDecoder::new(&data);
        let (mut bm, mut bt, mut um, mut im) = models();
        for i in 0..n {
            assert_eq!(dec.bit(&mut bm), bits[i]);
            assert_eq!(bt.decode(&mut dec), syms[i]);
            assert_eq!(um.decode(&mut dec).unwrap(), uints[i]);
            assert_eq!(im.decode(&mut dec).unwrap(), ints[i]);
            assert_eq!(dec.direct(13), direct[i]);
        }
        dec.finish().unwrap();
    }

    #[test]
    fn skewed_bits_compress_near_entropy() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let n = 100_000;
        let p1 = 0.05f64;
        let mut enc = RangeEncoder::new();
        let mut m = BitModel::default();
        for _ in 0..n {
            enc.bit(&mut m, rng.gen_bool(p1));
        }
        let bytes = enc.finish().len() as f64;
        let h = -(p1 * p1.log2() + (1.0 - p1) * (1.0 - p1).log2());
        let ideal = n as f64 * h / 8.0;
        assert!(bytes < ideal * 1.08, "{bytes} bytes vs ideal {ideal}");
    }

    #[test]
    fn costs_predict_the_coded_size() {
        // The summed costs of a stream of adaptive symbols match its coded size.
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut enc = RangeEncoder::new();
        let mut im = IntModel::default();
        let mut total = 0.0f64;
        for _ in 0..50_000 {
            let v: i64 = if rng.gen_bool(0.6) {
                0
            } else {
                rng.gen_range(-40..40)
            };
            total += im.cost(v) as f64;
            im.encode(&mut enc, v);
        }
        let bits = enc.finish().len() as f64 * 8.0;
        assert!(
            (bits - total).abs() < 0.01 * bits + 64.0,
            "{bits} vs {total}"
        );
        // A fresh bit costs one bit; a well-predicted one much less.
        let mut m = BitModel::default();
        assert!((m.cost(true) - 1.0).abs() < 1e-3);
        let mut e = RangeEncoder::new();
        for _ in 0..200 {
            e.bit(&mut m, false);
        }
        assert!(m.cost(false) < 0.05 && m.cost(true) > 4.0);
    }

    #[test]
    fn truncated_stream_is_reported_not_panicking() {
        let mut enc = RangeEncoder::new();
        let mut um = UintModel::default();
        for v in 0..1000u32 {
            um.encode(&mut enc, v * 7919);
        }
        let data = enc.finish();
        let cut = &data[..data.len() / 2];
        let mut dec = RangeDecoder::new(cut);
        let mut um = UintModel::default();
        for _ in 0..1000 {
            let _ = um.decode(&mut dec);
        }
        assert!(dec.finish().is_err());
    }
}
