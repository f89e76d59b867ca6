//! faer's AMD ordering (`amd::order_maybe_unsorted`) on a small symmetric pattern, for
//! Miri: `cargo +nightly miri run` (Stacked Borrows) and with
//! `MIRIFLAGS=-Zmiri-tree-borrows`.
use dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::amd;
use faer::sparse::SymbolicSparseColMat;

fn main() {
    // A path graph of n vertices with its diagonal: both triangles stored.
    let n: usize = std::env::args().nth(1).map_or(6, |s| s.parse().unwrap());
    let mut col_ptr = vec![0usize];
    let mut row_idx = Vec::new();
    for j in 0..n {
        for i in j.saturating_sub(1)..(j + 2).min(n) {
            row_idx.push(i);
        }
        col_ptr.push(row_idx.len());
    }
    let nnz = row_idx.len();
    let a = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
    let (mut perm, mut perm_inv) = (vec![0usize; n], vec![0usize; n]);
    let mut mem = MemBuffer::new(amd::order_maybe_unsorted_scratch::<usize>(n, nnz));
    let flops = amd::order_maybe_unsorted(
        &mut perm,
        &mut perm_inv,
        a.as_ref(),
        Default::default(),
        MemStack::new(&mut mem),
    )
    .unwrap();
    println!("n {n}, nnz {nnz}: perm {perm:?}, {flops:?}");
}
