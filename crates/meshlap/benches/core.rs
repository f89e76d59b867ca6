//! `cargo bench -p meshlap --bench core`: connectivity, cleaning and operator assembly
//! on generated meshes (no files needed). Topology on icosphere:8 (655,362 vertices)
//! tracks the "1M-vertex mesh in well under a second" goal; `meshlap-bench topology
//! builtin:icosphere:9` measures 2.6M vertices.

use meshlap::mesh::{builtin, clean, topology::Topology};
use meshlap::operator::{Operator, OperatorKind, OperatorOptions};

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
