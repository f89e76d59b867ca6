//! Tests of the whole codec (file round trips, thread independence, the mode
//! decision, rate control, hostile files) and helpers shared by the coders' tests.

use super::*;
use crate::mesh::builtin;
use glam::DVec3;
use rand::{Rng, SeedableRng};

/// Canonical face set: each face rotated so its smallest index comes first, sorted.
pub(crate) fn canon(faces: &[[u32; 3]]) -> Vec<[u32; 3]> {
    crate::metric::canon_faces(faces, |v| v)
}

/// `data` with one seeded corruption: cut at a random length or one bit flipped.
pub(crate) fn corrupt(data: &[u8], rng: &mut impl Rng) -> Vec<u8> {
    let mut d = data.to_vec();
    if rng.gen_bool(0.5) {
        d.truncate(rng.gen_range(0..d.len()));
    } else {
        let i = rng.gen_range(0..d.len());
        d[i] ^= 1 << rng.gen_range(0..8);
    }
    d
}

/// Root-mean-square vertex distance between two position lists (absolute).
pub(crate) fn rms(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let s: f64 = a
        .iter()
        .zip(b)
        .map(|(&p, &q)| (DVec3::from(p) - DVec3::from(q)).length_squared())
        .sum();
    (s / a.len() as f64).sqrt()
}

fn open(spec: &str) -> (TriMesh, Topology) {
    let m = builtin::from_spec(spec).unwrap();
    let t = Topology::new(&m).unwrap();
    (m, t)
}

#[test]
fn file_round_trip_matches_encoder_prediction() {
    for spec in [
        "builtin:icosphere:3",
        "builtin:cube:8",
        "builtin:torus:12:8",
    ] {
        let (m, t) = open(spec);
        for preserve in [false, true] {
            let c = compress(
                &m,
                &t,
                &CompressOptions {
                    preserve_order: preserve,
                    ..Default::default()
                },
            )
            .unwrap();
            let d = decompress(&c.bytes).unwrap();
            assert_eq!(d, c.decoded, "{spec}");
            if preserve {
                assert_eq!(canon(&d.faces), canon(&m.faces));
                assert!(c.report.permutation_bpv > 0.0);
            }
        }
    }
}

/// A regular mesh's connectivity codes to a few hundredths of a bit per face; the
/// decoder's guard against hostile counts refused such a file (icosphere:6 and up:
/// 81,920 faces in 300 bytes) until the guard was derived from the coder's smallest
/// possible cost per decision.
#[test]
fn very_regular_connectivity_decodes() {
    let (m, t) = open("builtin:icosphere:6");
    let opts = CompressOptions {
        mode: GeometryMode::Spatial,
        ..Default::default()
    };
    let c = compress(&m, &t, &opts).unwrap();
    assert!(
        c.report.connectivity_bpv < 0.05,
        "{}",
        c.report.connectivity_bpv
    );
    let d = decompress(&c.bytes).unwrap();
    assert_eq!(d, c.decoded);
    assert_eq!(d.n_faces(), m.n_faces());
}

#[test]
fn decoding_does_not_depend_on_the_thread_count() {
    // Encoder on 2 threads, decoder on 1 and 3: the bases, the inter-patch
    // predictors and the synthesis must agree bit for bit.
    let (m, t) = open("builtin:torus:40:24");
    let opts = CompressOptions {
        mode: GeometryMode::Spectral,
        spectral: SpectralParams {
            patch_size: 60,
            ..Default::default()
        },
        ..Default::default()
    };
    let pool = |k| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(k)
            .build()
            .unwrap()
    };
    let c = pool(2).install(|| compress(&m, &t, &opts).unwrap());
    assert!(c.report.geometry.patches >= 10);
    for k in [1, 3] {
        let d = pool(k).install(|| decompress(&c.bytes).unwrap());
        assert_eq!(d, c.decoded, "{k} threads");
    }
}

#[test]
fn encoding_does_not_depend_on_the_thread_count() {
    // The same bytes twice in a row and on 1 and 2 threads, in every mode, at a
    // fixed step and under rate control (the per-patch work runs in parallel and is
    // combined in order).
    let (m, t) = open("builtin:torus:40:24");
    let pool = |k| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(k)
            .build()
            .unwrap()
    };
    for mode in [
        GeometryMode::Auto,
        GeometryMode::Spectral,
        GeometryMode::Spatial,
    ] {
        for quantization in [Quantization::Bits(9.0), Quantization::TargetBpv(5.0)] {
            let opts = CompressOptions {
                mode,
                spectral: SpectralParams {
                    patch_size: 60,
                    ..Default::default()
                },
                quantization,
                ..Default::default()
            };
            let a = pool(2).install(|| compress(&m, &t, &opts).unwrap().bytes);
            let b = pool(2).install(|| compress(&m, &t, &opts).unwrap().bytes);
            let c = pool(1).install(|| compress(&m, &t, &opts).unwrap().bytes);
            assert_eq!(a, b, "{mode} {quantization:?}: twice");
            assert_eq!(a, c, "{mode} {quantization:?}: 1 vs 2 threads");
        }
    }
}

#[test]
fn auto_mode_keeps_the_better_coder() {
    // A smooth surface: spectral wins at a low rate, spatial at a high one; auto
    // picks the lower vertex × normal RMS under rate control, and every mode
    // decodes exactly.
    let (m, t) = open("builtin:icosphere:4");
    let run = |mode, b| {
        let c = compress(
            &m,
            &t,
            &CompressOptions {
                mode,
                quantization: Quantization::TargetBpv(b),
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(decompress(&c.bytes).unwrap(), c.decoded, "{mode} {b}");
        assert!(c.report.bits_per_vertex <= b);
        c.report
    };
    for b in [3.0, 9.0] {
        let spec = run(GeometryMode::Spectral, b);
        let spat = run(GeometryMode::Spatial, b);
        let auto = run(GeometryMode::Auto, b);
        let better = if spec.vertex_rms * spec.normal_rms < spat.vertex_rms * spat.normal_rms {
            GeometryMode::Spectral
        } else {
            GeometryMode::Spatial
        };
        assert_eq!(auto.geometry_mode, better, "{b} bpv");
        // Rate control may land a hair apart (the spatial search starts from the
        // spectral answer in auto mode, from 10 bits alone).
        let kept = if better == GeometryMode::Spectral {
            &spec
        } else {
            &spat
        };
        assert!(
            (auto.vertex_rms / kept.vertex_rms - 1.0).abs() < 0.1,
            "{} vs {}",
            auto.vertex_rms,
            kept.vertex_rms
        );
        assert!(auto.normal_rms <= auto.vertex_rms);
    }
    let low = run(GeometryMode::Auto, 3.0);
    let high = run(GeometryMode::Auto, 9.0);
    assert_eq!(low.geometry_mode, GeometryMode::Spectral);
    assert_eq!(high.geometry_mode, GeometryMode::Spatial);
    assert_eq!(
        "spatial".parse::<GeometryMode>().unwrap(),
        GeometryMode::Spatial
    );
    assert!("fractal".parse::<GeometryMode>().is_err());
}

#[test]
fn rate_control_meets_the_target() {
    let (m, t) = open("builtin:icosphere:4");
    for b in [4.0, 8.0] {
        let c = compress(
            &m,
            &t,
            &CompressOptions {
                quantization: Quantization::TargetBpv(b),
                ..Default::default()
            },
        )
        .unwrap();
        assert!(
            c.report.bits_per_vertex <= b,
            "{} > {b}",
            c.report.bits_per_vertex
        );
        assert!(
            c.report.bits_per_vertex > 0.8 * b,
            "{} ≪ {b}",
            c.report.bits_per_vertex
        );
    }
}

#[test]
fn hostile_files_give_typed_errors() {
    let (m, t) = open("builtin:torus:9:7");
    let c = compress(&m, &t, &CompressOptions::default()).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(21);
    for _ in 0..300 {
        let mut d = c.bytes.clone();
        match rng.gen_range(0..3) {
            0 => d.truncate(rng.gen_range(0..d.len())),
            1 => {
                let i = rng.gen_range(0..d.len());
                d[i] ^= 1 << rng.gen_range(0..8);
            }
            _ => {
                // Forge a valid container around garbage with huge counts.
                let mut hdr = vec![0xFF; 8];
                hdr[..4].copy_from_slice(&rng.gen::<u32>().to_le_bytes());
                let junk: Vec<u8> = (0..rng.gen_range(0..40)).map(|_| rng.gen()).collect();
                d = container::write(&[
                    (SectionKind::Header, &hdr),
                    (SectionKind::Connectivity, &junk),
                    (SectionKind::Geometry, &junk),
                ])
                .unwrap();
            }
        }
        assert!(decompress(&d).is_err());
    }
}

/// Compresses `m` with and without the stored vertex order and checks the round trip
/// through the file: the decoder reproduces the encoder's prediction, the decoded
/// faces mapped through the vertex order are exactly `m`'s (oriented, as a sorted
/// set), and with the stored order the faces are `m`'s in `m`'s numbering and every
/// vertex is within the quantization of its input position. Returns the report of the
/// run without the stored order.
pub(crate) fn assert_exact_round_trip(
    m: &TriMesh,
    mode: GeometryMode,
    name: &str,
) -> CompressReport {
    let t = Topology::new(m).unwrap();
    let mut first = None;
    for preserve in [false, true] {
        let opts = CompressOptions {
            mode,
            preserve_order: preserve,
            ..Default::default()
        };
        let c = compress(m, &t, &opts).unwrap_or_else(|e| panic!("{name} {mode}: {e}"));
        let d = decompress(&c.bytes).unwrap_or_else(|e| panic!("{name} {mode}: {e}"));
        assert_eq!(
            d, c.decoded,
            "{name} {mode}: decoder disagrees with the encoder"
        );
        assert_eq!(d.n_vertices(), m.n_vertices(), "{name}");
        let mapped: Vec<[u32; 3]> = d
            .faces
            .iter()
            .map(|f| f.map(|v| c.order[v as usize]))
            .collect();
        assert_eq!(canon(&mapped), canon(&m.faces), "{name} {mode} faces");
        // Every decoded vertex sits where its input vertex is, to the step (RMS step/2
        // per coordinate at most for the spatial coder; the spectral coder's error is
        // bounded here loosely by a few steps).
        let input: Vec<[f64; 3]> = c.order.iter().map(|&v| m.positions[v as usize]).collect();
        assert!(
            rms(&d.positions, &input) < 4.0 * c.report.step,
            "{name} {mode}"
        );
        if preserve {
            assert_eq!(canon(&d.faces), canon(&m.faces), "{name} {mode} order");
            assert!(c.order.iter().enumerate().all(|(i, &v)| v as usize == i));
        } else {
            first = Some(c.report);
        }
    }
    first.unwrap()
}

#[test]
fn every_non_manifold_configuration_round_trips_exactly() {
    use crate::mesh::nonmanifold::{non_manifold, NonManifoldKind};
    for (kind, name) in NonManifoldKind::ALL {
        let m = non_manifold(kind);
        for mode in [GeometryMode::Spatial, GeometryMode::Spectral] {
            let r = assert_exact_round_trip(&m, mode, name);
            assert!(
                r.vertex_copies > 0 && r.rejoin_bpv > 0.0,
                "{name}: nothing cut"
            );
        }
    }
    // A manifold mesh is not cut: no re-join section, as version 4 wrote it.
    let (m, t) = open("builtin:grid:5");
    let c = compress(&m, &t, &CompressOptions::default()).unwrap();
    let secs = container::read(&c.bytes).unwrap();
    assert!(container::section(&secs, SectionKind::Rejoin).is_none());
    assert_eq!((c.report.vertex_copies, c.report.rejoin_bpv), (0, 0.0));
}

#[test]
fn unreferenced_vertices_are_refused_in_every_mode() {
    // `compress` needs every vertex in a face; `clean` drops the others (as every
    // command does), and the cleaned mesh round-trips.
    use crate::mesh::nonmanifold::{non_manifold, NonManifoldKind};
    let mut m = non_manifold(NonManifoldKind::Fin);
    m.positions.insert(0, [0.3, 0.2, 0.1]);
    for f in &mut m.faces {
        for v in f.iter_mut() {
            *v += 1;
        }
    }
    m.positions.push([-0.5, 0.4, 0.9]);
    let t = Topology::new(&m).unwrap();
    for mode in [
        GeometryMode::Auto,
        GeometryMode::Spatial,
        GeometryMode::Spectral,
    ] {
        let opts = CompressOptions {
            mode,
            ..Default::default()
        };
        let e = compress(&m, &t, &opts).unwrap_err();
        assert!(
            matches!(
                e,
                CodecError::Unreferenced {
                    vertex: 0,
                    count: 2
                }
            ),
            "{e}"
        );
    }
    let (c, _) = crate::mesh::clean::clean(&m, &Default::default()).unwrap();
    assert_eq!(c.n_vertices(), m.n_vertices() - 2);
    // A face using a vertex twice is refused before the codec: its connectivity
    // cannot be built.
    let mut d = c.clone();
    d.faces.push([1, 1, 2]);
    assert!(matches!(
        Topology::new(&d),
        Err(crate::mesh::MeshError::RepeatedCorner { face, vertex: 1 }) if face == c.n_faces()
    ));
    assert_exact_round_trip(&c, GeometryMode::Auto, "fin, cleaned");
}

#[test]
fn hostile_rejoin_sections_give_typed_errors() {
    let m =
        crate::mesh::nonmanifold::non_manifold(crate::mesh::nonmanifold::NonManifoldKind::Mixed);
    let t = Topology::new(&m).unwrap();
    let c = compress(&m, &t, &CompressOptions::default()).unwrap();
    let secs = container::read(&c.bytes).unwrap();
    let rj = container::section(&secs, SectionKind::Rejoin).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(23);
    let mut refused = 0;
    for _ in 0..300 {
        // A changed re-join payload under a valid checksum.
        let bad = corrupt(rj, &mut rng);
        let forged: Vec<(SectionKind, &[u8])> = secs
            .iter()
            .map(|&(k, p)| {
                (
                    k,
                    if k == SectionKind::Rejoin {
                        &bad[..]
                    } else {
                        p
                    },
                )
            })
            .collect();
        let d = container::write(&forged).unwrap();
        match decompress(&d) {
            Err(_) => refused += 1,
            // A flip the adaptive coder absorbs still gives a well-formed mesh.
            Ok(x) => x.validate().unwrap(),
        }
    }
    assert!(refused > 150, "{refused} of 300 refused");
}

#[test]
fn real_non_manifold_meshes_round_trip_exactly() {
    // cow: one pinched vertex; beetle: 47 non-manifold edges; suzanne: one. The
    // re-join section's cost is printed (BENCHMARKS.md, "Compressing non-manifold
    // meshes"; run with --nocapture).
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data");
    for name in ["cow.obj", "beetle.obj", "suzanne.obj"] {
        let input =
            crate::input::open(dir.join(name).to_str().unwrap(), &Default::default()).unwrap();
        let r = assert_exact_round_trip(&input.mesh, GeometryMode::Spatial, name);
        assert!(r.vertex_copies > 0, "{name}");
        eprintln!(
            "{name}: {} vertices, {} copies, re-join {:.4} bits/vertex ({:.3} of {:.3} total; connectivity {:.3})",
            r.vertices,
            r.vertex_copies,
            r.rejoin_bpv,
            r.rejoin_bpv,
            r.bits_per_vertex,
            r.connectivity_bpv
        );
        // Cheaper than the plain coding: a flag bit per cut-mesh vertex and a
        // ⌈log2 n⌉-bit index per copy (plus the 32-bit count).
        let (n, k) = (r.vertices as f64, r.vertex_copies as f64);
        let plain = 32.0 + (n + k) + k * n.log2().ceil();
        assert!(
            r.rejoin_bpv * n < plain,
            "{name}: {} bits",
            r.rejoin_bpv * n
        );
    }
}

#[test]
fn compress_owned_writes_the_same_file_as_compress() {
    // `compress_owned` frees the input connectivity early; the file must not change,
    // at a fixed step (streamed bases) and under rate control (kept bases), for a
    // manifold mesh and for one the re-join section cuts apart.
    for spec in ["builtin:torus:40:24", "builtin:nm-mixed"] {
        let (m, topo) = open(spec);
        for quantization in [Quantization::Bits(10.0), Quantization::TargetBpv(6.0)] {
            let opts = CompressOptions {
                quantization,
                ..Default::default()
            };
            let a = compress(&m, &topo, &opts).unwrap();
            let b = compress_owned(&m, topo.clone(), &opts).unwrap();
            assert_eq!(a.bytes, b.bytes, "{spec} {quantization:?}");
        }
    }
}
