//! `cargo bench -p meshlap --bench core`: connectivity, cleaning, operator assembly and
//! the mesh writers on generated meshes (no input files needed). Topology on
//! icosphere:8 (655,362 vertices) tracks the "1M-vertex mesh in well under a second"
//! goal; `meshlap-bench topology builtin:icosphere:9` measures 2.6M vertices.
//! `patch_bases_*`: the codec's dense patch eigenbases (Kirchhoff operator of every
//! METIS patch of the cow, patches of about 100 and 150 vertices) through faer and
//! through the reproducible solver. `tridiagonal_*`: all eigenpairs of the tridiagonal
//! form of the Kirchhoff matrix of a patch of about n vertices (breadth-first from a
//! vertex of icosphere:5), on one thread, by meshlap's divide and conquer and by
//! faer's.

use meshlap::experiment::eigen_cost::bfs_patch;
use meshlap::input::{open, OpenOptions};
use meshlap::mesh::{builtin, clean, topology::Topology};
use meshlap::operator::{Operator, OperatorKind, OperatorOptions};
use meshlap::partition::{partition, PartitionMethod, PartitionOptions};
use meshlap::spectral::{BasisOptions, DenseSolver, EigenBasis};

fn main() {
    divan::main();
}

/// Patches of 100 on icosphere 7 (163,842 vertices, 1,639 parts), by each method
/// (the repairs included).
#[divan::bench(args = ["metis", "lloyd"], sample_count = 10)]
fn partition_patches(bencher: divan::Bencher, method: &str) {
    let m = builtin::icosphere(7).unwrap();
    let t = Topology::new(&m).unwrap();
    let opts = PartitionOptions {
        method: method.parse::<PartitionMethod>().unwrap(),
        ..PartitionOptions::new(100)
    };
    bencher.bench(|| partition(divan::black_box(t.graph()), &opts).unwrap());
}

#[divan::bench(args = [5, 7, 8])]
fn topology(bencher: divan::Bencher, level: usize) {
    let m = builtin::icosphere(level).unwrap();
    bencher.bench(|| Topology::new(divan::black_box(&m)).unwrap());
}

/// The faces and adjacency alone (what the `.mlz` decoder builds).
#[divan::bench(args = [5, 7, 8])]
fn vertex_graph(bencher: divan::Bencher, level: usize) {
    let m = builtin::icosphere(level).unwrap();
    bencher.bench(|| {
        meshlap::mesh::graph::VertexGraph::from_faces(m.n_vertices(), divan::black_box(&m.faces))
            .unwrap()
    });
}

#[divan::bench(args = [7])]
fn clean_mesh(bencher: divan::Bencher, level: usize) {
    let m = builtin::icosphere(level).unwrap();
    bencher.bench(|| clean::clean(divan::black_box(&m), &Default::default()).unwrap());
}

#[divan::bench(args = ["kirchhoff", "tutte", "graph", "sql", "sstl", "tutte2", "sdl", "cotan", "mean-value"])]
fn assemble(bencher: divan::Bencher, kind: &str) {
    let m = builtin::icosphere(7).unwrap();
    let t = Topology::new(&m).unwrap();
    let kind: OperatorKind = kind.parse().unwrap();
    bencher.bench(|| Operator::assemble(kind, &m, &t, &OperatorOptions::default()).unwrap());
}

/// `write_mesh` of icosphere 7 (163,842 vertices) into a temporary directory, per
/// format (the atomic write: a temporary file renamed over the last output).
#[divan::bench(args = ["obj", "off", "ply", "stl"], sample_count = 20)]
fn write_mesh(bencher: divan::Bencher, ext: &str) {
    let m = builtin::icosphere(7).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(format!("m.{ext}"));
    bencher.bench(|| {
        meshlap::io::write_mesh(&path, divan::black_box(&m), &Default::default()).unwrap()
    });
}

/// Kirchhoff operators of the cow's patches of about `p` vertices.
fn cow_patch_operators(p: usize) -> Vec<Operator> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/cow.obj");
    let m = meshlap::io::read_mesh(std::path::Path::new(path), None)
        .unwrap()
        .mesh;
    let t = Topology::new(&m).unwrap();
    let part = partition(t.graph(), &PartitionOptions::new(p)).unwrap();
    (0..part.n_patches())
        .map(|i| {
            let sub = part.submesh(&m, i).mesh;
            let st = Topology::new(&sub).unwrap();
            Operator::assemble(OperatorKind::Kirchhoff, &sub, &st, &Default::default()).unwrap()
        })
        .collect()
}

fn patch_bases(bencher: divan::Bencher, p: usize, solver: DenseSolver) {
    let ops = cow_patch_operators(p);
    let opts = BasisOptions {
        dense_solver: solver,
        ..Default::default()
    };
    bencher
        .counter(divan::counter::ItemsCount::new(ops.len()))
        .bench(|| {
            for op in &ops {
                divan::black_box(EigenBasis::compute(op, &opts).unwrap());
            }
        });
}

#[divan::bench(args = [100, 150])]
fn patch_bases_faer(bencher: divan::Bencher, p: usize) {
    patch_bases(bencher, p, DenseSolver::Faer);
}

#[divan::bench(args = [100, 150])]
fn patch_bases_reproducible(bencher: divan::Bencher, p: usize) {
    patch_bases(bencher, p, DenseSolver::Reproducible);
}

/// The codec's factored bases (`.mlz` format 8): every vector of each cow patch's
/// Kirchhoff matrix (PSD, `F = D − W`), four patches per batch (their QL iterations
/// interleaved), as `patch_bases_reproducible` computes them explicitly.
#[divan::bench(args = [100, 150])]
fn patch_bases_factored(bencher: divan::Bencher, p: usize) {
    let dense: Vec<_> = cow_patch_operators(p)
        .iter()
        .map(|op| op.matrix.to_dense())
        .collect();
    bencher
        .counter(divan::counter::ItemsCount::new(dense.len()))
        .bench(|| {
            for group in dense.chunks(4) {
                let items: Vec<_> = group.iter().map(|a| (a.as_ref(), a.nrows())).collect();
                divan::black_box(meshlap::spectral::FactoredEvd::batch(&items));
            }
        });
}

/// The tridiagonal form (diagonal n, off-diagonal n − 1) of the Kirchhoff matrix
/// `F = D − W` (PSD) of a breadth-first patch of about `size` vertices of icosphere:5
/// ([`bfs_patch`] from vertex 0), reduced by faer's `tridiag_in_place`.
fn kirchhoff_patch_tridiagonal(size: usize) -> (Vec<f64>, Vec<f64>) {
    use faer::dyn_stack::{MemBuffer, MemStack};
    let input = open("builtin:icosphere:5", &OpenOptions::default()).unwrap();
    let patch = bfs_patch(&input, 0, size).unwrap();
    let op = Operator::assemble(
        OperatorKind::Kirchhoff,
        &patch.mesh,
        &patch.topology,
        &OperatorOptions::default(),
    )
    .unwrap();
    let mut a = op.matrix.to_dense();
    let n = a.nrows();
    let mut h = faer::Mat::<f64>::zeros(1, n - 1);
    let mut mem = MemBuffer::new(faer::linalg::evd::tridiag::tridiag_in_place_scratch::<f64>(
        n,
        faer::Par::Seq,
        Default::default(),
    ));
    faer::linalg::evd::tridiag::tridiag_in_place(
        a.as_mut(),
        h.as_mut(),
        faer::Par::Seq,
        MemStack::new(&mut mem),
        Default::default(),
    );
    let d = (0..n).map(|i| a[(i, i)]).collect();
    let e = (0..n - 1).map(|i| a[(i + 1, i)]).collect();
    (d, e)
}

#[divan::bench(args = [500, 1000, 2000], sample_count = 10)]
fn tridiagonal_dc(bencher: divan::Bencher, size: usize) {
    let (d, e) = kirchhoff_patch_tridiagonal(size);
    bencher.bench(|| {
        meshlap::spectral::tridiagonal_dc::tridiagonal_evd(divan::black_box(&d), &e, faer::Par::Seq)
            .unwrap()
    });
}

#[divan::bench(args = [500, 1000, 2000], sample_count = 10)]
fn tridiagonal_faer(bencher: divan::Bencher, size: usize) {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::linalg::evd::{self, ComputeEigenvectors};
    let (d, mut e) = kirchhoff_patch_tridiagonal(size);
    let n = d.len();
    e.push(0.0);
    bencher.bench(|| {
        let mut z = faer::Mat::<f64>::zeros(n, n);
        let mut s = faer::diag::Diag::<f64>::zeros(n);
        let mut mem = MemBuffer::new(evd::self_adjoint_evd_scratch::<f64>(
            n,
            ComputeEigenvectors::Yes,
            faer::Par::Seq,
            Default::default(),
        ));
        evd::tridiagonal_self_adjoint_evd(
            faer::ColRef::from_slice(divan::black_box(&d)).as_diagonal(),
            faer::ColRef::from_slice(&e).as_diagonal(),
            s.as_mut(),
            Some(z.as_mut()),
            faer::Par::Seq,
            MemStack::new(&mut mem),
            Default::default(),
        )
        .unwrap();
        (s, z)
    });
}
