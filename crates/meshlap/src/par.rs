//! Running parallel work from inside rayon's pool.

/// Runs `f` on a worker thread of rayon's current pool (directly when already on
/// one). An algorithm that makes many short parallel passes — a Krylov solve's two to
/// four per iteration, the blocked tridiagonalisation's one per column — called from
/// a thread outside the pool would hand each pass to the pool, put the caller to
/// sleep and wake it when done: measured on 2 threads, 4.5 context switches per pass
/// against 0.4 on a worker, where the passes are shared out by work stealing. faer's
/// parallel routines behave the same way: its sparse LDLᵀ ran 40 % slower from the
/// main thread than on a worker (figures in BENCHMARKS.md, "Implicit fairing
/// solvers").
pub(crate) fn on_worker<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    if rayon::current_thread_index().is_some() {
        f()
    } else {
        rayon::scope(|_| f())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_on_a_pool_worker() {
        assert!(rayon::current_thread_index().is_none());
        assert!(on_worker(|| rayon::current_thread_index().is_some()));
        let inside = rayon::scope(|_| on_worker(rayon::current_thread_index));
        assert!(inside.is_some());
    }
}
