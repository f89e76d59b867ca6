//! The watermarking benchmark's attacks and MSDM2 on the pinned real meshes.

mod common;
use common::*;
use meshlap::mesh::clean::{clean, CleanOptions, MeshReport};
use meshlap::mesh::topology::Topology;
use meshlap::metric::msdm2::{msdm2, Msdm2Params};
use meshlap::watermark::attack::{attack, benchmark_levels, AttackKind, AttackOptions};
use meshlap::TriMesh;

fn report(m: &TriMesh) -> MeshReport {
    let (c, r) = clean(m, &CleanOptions::default()).unwrap();
    assert_eq!(c.n_vertices(), m.n_vertices(), "no unreferenced vertex");
    assert_eq!(c.n_faces(), m.n_faces(), "no degenerate or duplicate face");
    MeshReport::new(&c, &Topology::new(&c).unwrap(), &r)
}

#[test]
fn every_benchmark_level_runs_on_every_test_mesh() {
    for (name, mesh, _) in manifold_meshes() {
        let r0 = report(&mesh);
        for o in benchmark_levels() {
            let out = attack(&mesh, &o).unwrap_or_else(|e| panic!("{name} {}: {e}", o.label()));
            out.validate().unwrap();
            if o.kind == AttackKind::Simplify {
                let r = report(&out);
                let removed = 1.0 - out.n_vertices() as f64 / mesh.n_vertices() as f64;
                assert!(
                    (100.0 * removed - o.amount).abs() <= 1.0,
                    "{name} {}: {removed}",
                    o.label()
                );
                assert_eq!(
                    r.non_manifold_edges + r.non_manifold_vertices,
                    0,
                    "{name} {}",
                    o.label()
                );
                assert_eq!(
                    r.euler_characteristic,
                    r0.euler_characteristic,
                    "{name} {}",
                    o.label()
                );
                assert_eq!(
                    r.boundary_edges == 0,
                    r0.boundary_edges == 0,
                    "{name} {}",
                    o.label()
                );
            }
        }
    }
}

#[test]
fn the_bunny_simplified_and_subdivided_keeps_its_topology() {
    let bunny = load(&shared("stanford-bunny.obj")).mesh;
    let r0 = report(&bunny);
    let s = attack(&bunny, &AttackOptions::new(AttackKind::Simplify, 70.0)).unwrap();
    let r = report(&s);
    assert!((r.vertices as f64 / r0.vertices as f64 - 0.3).abs() <= 0.01);
    assert_eq!(r.non_manifold_edges + r.non_manifold_vertices, 0);
    assert_eq!(
        (r.euler_characteristic, r.boundary_loops, r.components),
        (r0.euler_characteristic, r0.boundary_loops, r0.components)
    );
    assert_eq!(r.inconsistently_oriented_edges, 0);
    let loop_ = attack(
        &bunny,
        &AttackOptions {
            scheme: meshlap::watermark::attack::SubdivisionScheme::Loop,
            ..AttackOptions::new(AttackKind::Subdivide, 1.0)
        },
    )
    .unwrap();
    assert_eq!(loop_.n_vertices(), r0.vertices + r0.edges);
}

#[test]
fn msdm2_grows_with_every_attack_strength_on_the_cow() {
    let cow = load(&data("cow.obj")).mesh;
    let p = Msdm2Params::default();
    for (kind, amounts) in [
        (AttackKind::Noise, &[0.05, 0.1, 0.3, 0.5][..]),
        (AttackKind::Smooth, &[5.0, 10.0, 30.0, 50.0][..]),
        (AttackKind::Quantize, &[11.0, 9.0, 7.0][..]),
    ] {
        let mut last = 0.0;
        for &a in amounts {
            let v = msdm2(
                &cow,
                &attack(&cow, &AttackOptions::new(kind, a)).unwrap(),
                &p,
            )
            .unwrap();
            assert!(v > last && v < 1.0, "{kind} {a}: {v} after {last}");
            last = v;
        }
    }
    assert_eq!(msdm2(&cow, &cow, &p).unwrap(), 0.0);
}
