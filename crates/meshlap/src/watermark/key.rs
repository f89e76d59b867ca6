//! The secret key's pseudo-random sequences: the ±1 chips that spread each bit and the
//! permutation that scatters the chips over the spectral coefficients (Ohbuchi,
//! Takahashi, Miyazawa, Mukaiyama, GI 2001, §4: "a pseudo-random number sequence
//! generated from the key").
//!
//! Both come from the crate's seeded SplitMix64 ([`crate::rng`]) in two independent
//! streams (the key mixed with two different domain constants), so the chips are
//! independent, uniformly distributed ±1 values **whatever slots the permutation
//! picks**: the hypothesis under which the false-positive probability of
//! [`super::detect()`] is a rigorous bound.

use crate::rng::{mix, SplitMix64};

/// Domain constant of the chip stream ("chips" in ASCII).
const CHIP_DOMAIN: u64 = 0x0000_6368_6970_7300;
/// Domain constant of the permutation stream ("perm" in ASCII).
const PERM_DOMAIN: u64 = 0x0000_7065_726d_0000;

/// `count` chips, each +1 or −1 with probability ½, independent, from `key`.
pub fn chips(key: u64, count: usize) -> Vec<f64> {
    let mut g = SplitMix64::new(mix(key ^ CHIP_DOMAIN));
    let mut out = Vec::with_capacity(count);
    while out.len() < count {
        let mut w = g.next_u64();
        for _ in 0..64.min(count - out.len()) {
            out.push(if w & 1 == 1 { 1.0 } else { -1.0 });
            w >>= 1;
        }
    }
    out
}

/// The first `take` entries of a uniformly random permutation of `0..n` from `key`
/// (a partial Fisher–Yates shuffle; `take` is clamped to `n`).
pub fn permutation(key: u64, n: usize, take: usize) -> Vec<u32> {
    let mut g = SplitMix64::new(mix(key ^ PERM_DOMAIN));
    let mut p: Vec<u32> = (0..n as u32).collect();
    let take = take.min(n);
    for i in 0..take {
        let j = i + g.below((n - i) as u64) as usize;
        p.swap(i, j);
    }
    p.truncate(take);
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chips_are_balanced_signs_and_depend_on_the_key() {
        let a = chips(42, 10_000);
        assert!(a.iter().all(|&c| c == 1.0 || c == -1.0));
        let mean = a.iter().sum::<f64>() / a.len() as f64;
        // 5 standard deviations of a mean of 10,000 signs.
        assert!(mean.abs() < 0.05, "{mean}");
        let b = chips(43, 10_000);
        let agree = a.iter().zip(&b).filter(|(x, y)| x == y).count();
        assert!((4_500..5_500).contains(&agree), "{agree}");
        assert_eq!(a, chips(42, 10_000));
        assert_eq!(&chips(42, 100)[..], &a[..100]);
    }

    #[test]
    fn permutation_has_distinct_entries_in_range() {
        let p = permutation(7, 1000, 300);
        assert_eq!(p.len(), 300);
        let mut s = p.clone();
        s.sort_unstable();
        s.dedup();
        assert_eq!(s.len(), 300);
        assert!(p.iter().all(|&x| x < 1000));
        let full = permutation(7, 50, 99);
        let mut s = full.clone();
        s.sort_unstable();
        assert_eq!(s, (0..50).collect::<Vec<u32>>());
        assert_ne!(permutation(8, 1000, 300), p);
    }
}
