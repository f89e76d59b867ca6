//! Connected components of a graph given by its edges, labelled in parallel.
//!
//! [`component_labels`] returns, for each of `n` vertices, the number of its
//! component, components numbered `0..count` in the order of their lowest vertex:
//! the numbering a sequential union-find followed by a pass over the vertices in
//! index order gives (`UnionFind` in [`super::topology`]), whatever the thread count
//! and the order in which the edges are visited.
//!
//! **Method.** A concurrent union-find on atomic parents (after Anderson & Woll 1991
//! and Jayanti & Tarjan 2016): a root is only ever linked below a smaller index
//! (compare-and-swap on the larger root), and `find` halves paths by
//! compare-and-swap, so every parent is at most its child and each component's root
//! is its lowest vertex once all unions are done. The labels are then the ranks of
//! the roots (a prefix count over the vertices). The edges are visited in parallel
//! by the caller's closure (rayon). Written by hand: the union-find crates on
//! crates.io are sequential (`petgraph`'s `UnionFind`, `union-find`), and what is
//! needed here is the lowest-vertex numbering as well as speed.

use rayon::prelude::*;
use std::sync::atomic::{AtomicU32, Ordering};

/// The components of the graph on `n` vertices (`n < u32::MAX`) whose edges
/// `edges` sends to the sink it is given, from any number of threads (each edge
/// `(a, b)` with `a, b < n`; repeated edges and loops are allowed): each vertex's
/// component, numbered by lowest vertex, and the number of components.
pub(crate) fn component_labels(
    n: usize,
    edges: impl FnOnce(&(dyn Fn(u32, u32) + Sync)),
) -> (Vec<u32>, usize) {
    let uf = Concurrent::new(n);
    edges(&|a, b| uf.union(a, b));
    // Every vertex's root is now its component's lowest vertex.
    let root: Vec<u32> = (0..n as u32)
        .into_par_iter()
        .with_min_len(1 << 12)
        .map(|v| uf.find(v))
        .collect();
    // The roots' ranks, by a prefix count over the vertices (roots are their own).
    let mut rank = vec![0u32; n];
    let mut count = 0u32;
    for (v, (&r, k)) in root.iter().zip(rank.iter_mut()).enumerate() {
        if r as usize == v {
            *k = count;
            count += 1;
        }
    }
    let labels = root
        .par_iter()
        .with_min_len(1 << 12)
        .map(|&r| rank[r as usize])
        .collect();
    (labels, count as usize)
}

/// The union-find: `parent[x] ≤ x`, a root its own parent.
struct Concurrent {
    parent: Vec<AtomicU32>,
}

impl Concurrent {
    fn new(n: usize) -> Self {
        Self {
            parent: (0..n as u32).map(AtomicU32::new).collect(),
        }
    }

    /// The root of `x`, halving the path on the way.
    fn find(&self, mut x: u32) -> u32 {
        loop {
            let p = self.parent[x as usize].load(Ordering::Acquire);
            if p == x {
                return x;
            }
            let g = self.parent[p as usize].load(Ordering::Acquire);
            if g != p {
                // Another thread may have moved x already: then it points to an
                // ancestor too, and either is fine.
                let _ = self.parent[x as usize].compare_exchange(
                    p,
                    g,
                    Ordering::AcqRel,
                    Ordering::Relaxed,
                );
            }
            x = g;
        }
    }

    /// Merges the sets of `a` and `b`: the larger root goes below the smaller.
    fn union(&self, a: u32, b: u32) {
        let (mut a, mut b) = (a, b);
        loop {
            a = self.find(a);
            b = self.find(b);
            if a == b {
                return;
            }
            let (lo, hi) = (a.min(b), a.max(b));
            // Succeeds only while `hi` is still a root; else retry from its new root.
            if self.parent[hi as usize]
                .compare_exchange(hi, lo, Ordering::AcqRel, Ordering::Relaxed)
                .is_ok()
            {
                return;
            }
            (a, b) = (lo, hi);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::topology::UnionFind;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The sequential numbering: union-find, then labels by first vertex in order.
    fn sequential(n: usize, edges: &[(u32, u32)]) -> (Vec<u32>, usize) {
        let mut uf = UnionFind::new(n);
        for &(a, b) in edges {
            uf.union(a as usize, b as usize);
        }
        let mut label = vec![u32::MAX; n];
        let mut count = 0;
        let out = (0..n)
            .map(|v| {
                let r = uf.find(v);
                if label[r] == u32::MAX {
                    label[r] = count;
                    count += 1;
                }
                label[r]
            })
            .collect();
        (out, count as usize)
    }

    fn parallel(n: usize, edges: &[(u32, u32)], threads: usize) -> (Vec<u32>, usize) {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            component_labels(n, |sink| {
                edges
                    .par_iter()
                    .with_max_len(7)
                    .for_each(|&(a, b)| sink(a, b));
            })
        })
    }

    /// Random graphs from empty to connected, with loops and repeated edges, on 1 to
    /// 4 threads and in shuffled edge orders: the sequential labels exactly.
    #[test]
    fn labels_match_the_sequential_union_find() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for &(n, m) in &[
            (0, 0),
            (1, 0),
            (1, 3),
            (10, 0),
            (10, 4),
            (50, 40),
            (2000, 1500),
            (2000, 4000),
        ] {
            for round in 0..4 {
                let mut edges: Vec<(u32, u32)> = (0..m)
                    .map(|_| (rng.gen_range(0..n as u32), rng.gen_range(0..n as u32)))
                    .collect();
                // A long path too, where a careless find would recurse deeply.
                if round == 3 && n > 1 {
                    edges.extend((1..n as u32).rev().map(|v| (v, v - 1)));
                }
                let want = sequential(n, &edges);
                for threads in [1, 2, 4] {
                    assert_eq!(
                        parallel(n, &edges, threads),
                        want,
                        "n {n} m {m} {threads} threads"
                    );
                    edges.reverse();
                    assert_eq!(parallel(n, &edges, threads), want, "n {n} m {m} reversed");
                }
            }
        }
    }
}
