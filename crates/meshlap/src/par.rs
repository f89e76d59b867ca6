//! Running parallel work from inside rayon's pool, and combining its per-chunk
//! results in a fixed order. Public: [`on_worker`], with which the front ends (the
//! CLI's command, the Python package's calls on the default pool) run a whole call
//! on a worker.

/// Runs `f` on a worker thread of rayon's current pool (directly when already on
/// one). An algorithm that makes many short parallel passes — a Krylov solve's two to
/// four per iteration, the blocked tridiagonalisation's one per column — called from
/// a thread outside the pool would hand each pass to the pool, put the caller to
/// sleep and wake it when done, several context switches per pass where a worker
/// shares the passes out by work stealing. faer's parallel routines behave the same
/// way: its sparse LDLᵀ is slower from the main thread than on a worker (figures in
/// BENCHMARKS.md, "Implicit fairing solvers").
///
/// The public entry points that make several parallel passes run on a worker for the
/// same reason: opening a mesh ([`crate::input`]), its connectivity
/// ([`crate::mesh::topology::Topology::from_faces`]), cleaning, reading a file and
/// assembling an operator. Called from a program's main thread, opening a large mesh
/// is faster on a worker (BENCHMARKS.md, "Connectivity"); from a worker (a caller's
/// own pool, the Python package's calls) nothing changes.
pub fn on_worker<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    if rayon::current_thread_index().is_some() {
        f()
    } else {
        rayon::scope(|_| f())
    }
}

/// Combines the items of an indexed parallel iterator in their order: `zero`, then
/// item 0, item 1, …, each added with `add`.
///
/// Rayon's `reduce` combines items in the shape of its work-stealing splits, which
/// changes from call to call, so floating-point sums came out with different last
/// bits on the same input (BENCHMARKS.md, "Sums folded in chunk order"). Collected
/// first (one item per chunk of rows: a few dozen) and folded in order, a pass's sums
/// have the same bits on every call and on any number of threads, the chunks being
/// fixed.
pub(crate) trait FoldInOrder: rayon::iter::IndexedParallelIterator + Sized {
    /// See the trait.
    fn fold_in_order(
        self,
        zero: Self::Item,
        add: impl Fn(Self::Item, Self::Item) -> Self::Item,
    ) -> Self::Item {
        let items: Vec<Self::Item> = self.collect();
        items.into_iter().fold(zero, add)
    }
}

impl<I: rayon::iter::IndexedParallelIterator> FoldInOrder for I {}

/// Index of the first item of `items` for which `bad` holds, as a sequential scan
/// would find it; in parallel over chunks of 4,096 items, each scanned sequentially,
/// and only the first chunk with a hit searched for its position.
///
/// Rayon's `par_iter().position_first` checks a shared atomic at every item, which
/// made a mesh's validation several times slower than a sequential scan (figures in
/// BENCHMARKS.md, "Python API", fifty-fourth session).
pub(crate) fn position_first<T: Sync>(
    items: &[T],
    bad: impl Fn(&T) -> bool + Sync,
) -> Option<usize> {
    use rayon::prelude::*;
    const CHUNK: usize = 1 << 12;
    let c = items
        .par_chunks(CHUNK)
        .position_first(|c| c.iter().any(&bad))?;
    let start = c * CHUNK;
    items[start..].iter().position(&bad).map(|k| start + k)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn folds_in_order_on_any_thread_count() {
        use rayon::prelude::*;
        // Sums whose value depends on the order of the additions.
        let v: Vec<f64> = (0..100_000)
            .map(|i| ((i as f64) * 0.7).sin() * 10f64.powi(i % 17 - 8))
            .collect();
        let want = v
            .chunks(1000)
            .map(|c| c.iter().sum::<f64>())
            .fold(0.0, |a, b| a + b);
        for threads in [1, 2, 3, 8] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            for _ in 0..20 {
                let got = pool.install(|| {
                    v.par_chunks(1000)
                        .map(|c| c.iter().sum::<f64>())
                        .fold_in_order(0.0, |a, b| a + b)
                });
                assert_eq!(got.to_bits(), want.to_bits(), "{threads} threads");
            }
        }
    }

    #[test]
    fn position_first_finds_the_first_hit_on_any_thread_count() {
        let n = 50_000;
        for hits in [
            vec![],
            vec![0],
            vec![n - 1],
            vec![4095, 4096],
            vec![9000, 30_000, 4097],
        ] {
            let mut v = vec![false; n];
            for &h in &hits {
                v[h] = true;
            }
            let want = v.iter().position(|&b| b);
            for threads in [1, 2, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                assert_eq!(
                    pool.install(|| position_first(&v, |&b| b)),
                    want,
                    "{hits:?}"
                );
            }
        }
        assert_eq!(position_first(&[] as &[bool], |&b| b), None);
    }

    #[test]
    fn runs_on_a_pool_worker() {
        assert!(rayon::current_thread_index().is_none());
        assert!(on_worker(|| rayon::current_thread_index().is_some()));
        let inside = rayon::scope(|_| on_worker(rayon::current_thread_index));
        assert!(inside.is_some());
    }
}
