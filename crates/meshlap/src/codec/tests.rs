//! Tests of the whole codec (file round trips, thread independence, the mode
//! decision, rate control, hostile files) and helpers shared by the coders' tests.

use super::*;
use crate::mesh::builtin;
use glam::DVec3;
use rand::{Rng, SeedableRng};

/// Canonical face set: each face rotated so its smallest index comes first, sorted.
pub(crate) fn canon(faces: &[[u32; 3]]) -> Vec<[u32; 3]> {
    let mut v: Vec<[u32; 3]> = faces
        .iter()
        .map(|f| {
            let k = (0..3).min_by_key(|&k| f[k]).unwrap();
            [f[k], f[(k + 1) % 3], f[(k + 2) % 3]]
        })
        .collect();
    v.sort_unstable();
    v
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
