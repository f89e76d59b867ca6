//! `SplitMix64` (Steele, Lea & Flood 2014): the crate's one seeded pseudo-random
//! generator. Deterministic for a seed on every platform, so sampled metrics, probe
//! vectors, Krylov start blocks and the codec's bases are reproducible bit for bit.
//! Written here rather than taken from `rand`: the library needs only these few lines,
//! and the exact output sequence is part of the `.mlz` format (the canonical probe
//! vectors), so it must never change with a dependency upgrade.

/// The SplitMix64 finaliser: a bijective 64-bit mix of `z + γ` (γ = the golden-ratio
/// increment). `mix(seed)` is the first output of a generator seeded with `seed`.
#[inline]
pub fn mix(z: u64) -> u64 {
    let mut z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A seeded SplitMix64 stream.
#[derive(Clone, Debug)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    /// A generator whose first output is [`mix`]`(seed)`.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// The next 64 random bits.
    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        let out = mix(self.0);
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        out
    }

    /// Uniform in [0, 1), 53 random bits.
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        unit(self.next_u64())
    }

    /// Uniform in [−1, 1), 53 random bits.
    #[inline]
    pub fn next_signed(&mut self) -> f64 {
        2.0 * self.next_f64() - 1.0
    }

    /// Uniform in `0..n` (n ≥ 1; Lemire's multiply-shift, bias below 2⁻⁶⁴·n).
    #[inline]
    pub fn below(&mut self, n: u64) -> u64 {
        ((self.next_u64() as u128 * n as u128) >> 64) as u64
    }
}

/// The top 53 bits of `bits` as a float in [0, 1).
#[inline]
pub fn unit(bits: u64) -> f64 {
    (bits >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_the_reference_sequence() {
        // First outputs of SplitMix64 seeded with 1234567 (reference C implementation).
        let mut g = SplitMix64::new(1234567);
        assert_eq!(g.next_u64(), 6457827717110365317);
        assert_eq!(g.next_u64(), 3203168211198807973);
        assert_eq!(g.next_u64(), 9817491932198370423);
    }

    #[test]
    fn floats_lie_in_their_ranges() {
        let mut g = SplitMix64::new(7);
        for _ in 0..10_000 {
            let u = g.next_f64();
            assert!((0.0..1.0).contains(&u));
            let s = g.next_signed();
            assert!((-1.0..1.0).contains(&s));
            assert!(g.below(10) < 10);
        }
    }
}
