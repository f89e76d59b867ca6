//! `cargo bench -p meshlap --bench core`: connectivity, cleaning and operator assembly
//! on generated meshes (no files needed). Topology on icosphere:8 (655,362 vertices)
//! tracks the "1M-vertex mesh in well under a second" goal; `meshlap-bench topology
//! builtin:icosphere:9` measures 2.6M vertices. `patch_bases_*`: the codec's dense
//! patch eigenbases (Kirchhoff operator of every METIS patch of the cow, patches of
//! about 100 and 150 vertices) through faer and through the reproducible solver.

use meshlap::mesh::{builtin, clean, topology::Topology};
use meshlap::operator::{Operator, OperatorKind, OperatorOptions};
use meshlap::partition::{partition, PartitionOptions};
use meshlap::spectral::{BasisOptions, DenseSolver, EigenBasis};

fn main() {
    divan::main();
}

#[divan::bench(args = [5, 7, 8])]
fn topology(bencher: divan::Bencher, level: usize) {
    let m = builtin::icosphere(level).unwrap();
    bencher.bench(|| Topology::new(divan::black_box(&m)).unwrap());
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

/// Kirchhoff operators of the cow's patches of about `p` vertices.
fn cow_patch_operators(p: usize) -> Vec<Operator> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/cow.obj");
    let m = meshlap::io::read_mesh(std::path::Path::new(path), None)
        .unwrap()
        .mesh;
    let t = Topology::new(&m).unwrap();
    let part = partition(&t, &PartitionOptions::new(p)).unwrap();
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
