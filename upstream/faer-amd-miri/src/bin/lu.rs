//! faer's sparse LU (COLAMD ordering, symbolic then numeric factorization, one solve)
//! on a small non-symmetric matrix, for Miri: `cargo +nightly miri run --bin lu`
//! (Stacked Borrows) and with `MIRIFLAGS=-Zmiri-tree-borrows`. meshlap factors its
//! non-symmetric fairing and filter systems this way (`solve::direct::LuSolver`).
use faer::sparse::linalg::solvers::{Lu, SymbolicLu};
use faer::sparse::{SparseColMat, Triplet};
use faer::Mat;

fn main() {
    // n×n: 4 on the diagonal, −1 below it, −2 above it, and a corner entry, so that
    // the pattern is not a band.
    let n: usize = std::env::args().nth(1).map_or(6, |s| s.parse().unwrap());
    let mut t = Vec::new();
    for i in 0..n {
        t.push(Triplet::new(i, i, 4.0));
        if i + 1 < n {
            t.push(Triplet::new(i + 1, i, -1.0));
            t.push(Triplet::new(i, i + 1, -2.0));
        }
    }
    t.push(Triplet::new(n - 1, 0, 0.5));
    let a = SparseColMat::<usize, f64>::try_new_from_triplets(n, n, &t).unwrap();
    let symbolic = SymbolicLu::try_new(a.symbolic()).unwrap();
    let lu = Lu::try_new_with_symbolic(symbolic, a.as_ref()).unwrap();
    // b = A·1, so the solution is 1.
    let ones = Mat::<f64>::from_fn(n, 1, |_, _| 1.0);
    let b = &a * &ones;
    let x = faer::linalg::solvers::Solve::solve(&lu, &b);
    let err = (0..n)
        .map(|i| (x[(i, 0)] - 1.0).abs())
        .fold(0.0f64, f64::max);
    println!("n {n}: max |x − 1| = {err:e}");
    assert!(err < 1e-12);
}
