//! Tests of the spectral coder: exact decoding, the error and rate behavior of its
//! options, hostile streams.

use super::*;
use crate::codec::tests::{corrupt, rms};
use crate::mesh::builtin;
use crate::mesh::topology::Topology;
use crate::operator::OperatorKind;

/// Whether the positions `a` and `b` have the same bits, coordinate by coordinate
/// (over the shorter of the two).
fn same_bits(a: &[[f64; 3]], b: &[[f64; 3]]) -> bool {
    a.iter()
        .flatten()
        .zip(b.iter().flatten())
        .all(|(x, y)| x.to_bits() == y.to_bits())
}

#[test]
fn decoder_reproduces_encoder_exactly_with_repeated_eigenvalues() {
    for spec in ["builtin:icosphere:3", "builtin:cube:8", "builtin:grid:9"] {
        let m = builtin::from_spec(spec).unwrap();
        let topo = Topology::new(&m).unwrap();
        for (op, predicted) in [
            (OperatorKind::Sstl, true),
            (OperatorKind::Sstl, false),
            (OperatorKind::Sql, true),
            (OperatorKind::Tutte, true),
            (OperatorKind::Kirchhoff, false),
            (OperatorKind::Graph, true),
        ] {
            let params = SpectralParams {
                operator: op,
                patch_size: 120,
                keep: Keep::Ratio(0.5),
                border_residuals: true,
                band_slope: 0.5,
                predicted,
                dead_zone: 0.4,
            };
            let enc = SpectralEncoder::new(topo.graph(), &m.positions, params).unwrap();
            let step = m.bbox_diagonal() / 1024.0;
            let EncodedSpectral {
                bytes: data,
                decoded: rec,
                ..
            } = enc.encode(step).unwrap();
            let dec = decode(topo.graph(), &data, crate::codec::container::VERSION).unwrap();
            assert_eq!(dec, rec, "{spec} {op}");
        }
    }
}

#[test]
fn decoder_with_partial_bases_reproduces_encoder_exactly() {
    // The decoder computes each patch's vectors only up to its last non-zero
    // coefficient (none for an all-zero patch): at coarse steps most tails are zero,
    // at fine ones few. Repeated eigenvalues (icosphere, cube) put cluster ends
    // inside the tails.
    for spec in [
        "builtin:icosphere:3",
        "builtin:cube:8",
        "builtin:torus:40:24",
    ] {
        let m = builtin::from_spec(spec).unwrap();
        let topo = Topology::new(&m).unwrap();
        for op in [
            OperatorKind::Kirchhoff,
            OperatorKind::Tutte,
            OperatorKind::Sql,
        ] {
            let params = SpectralParams {
                operator: op,
                patch_size: 80,
                ..Default::default()
            };
            let enc = SpectralEncoder::new(topo.graph(), &m.positions, params).unwrap();
            for div in [4.0, 64.0, 1024.0, 65536.0] {
                let e = enc.encode(m.bbox_diagonal() / div).unwrap();
                let dec = decode(topo.graph(), &e.bytes, crate::codec::container::VERSION).unwrap();
                assert!(same_bits(&dec, &e.decoded), "{spec} {op} diag/{div}");
            }
        }
    }
}

#[test]
fn full_basis_is_lossless_up_to_quantization() {
    let m = builtin::from_spec("builtin:torus:10:8").unwrap();
    let topo = Topology::new(&m).unwrap();
    for op in [OperatorKind::Sstl, OperatorKind::Tutte] {
        let params = SpectralParams {
            operator: op,
            patch_size: 1000,
            keep: Keep::Ratio(1.0),
            border_residuals: false,
            band_slope: 0.0,
            predicted: false,
            dead_zone: 0.5,
        };
        let enc = SpectralEncoder::new(topo.graph(), &m.positions, params).unwrap();
        let step = 1e-6;
        let rec = enc.encode(step).unwrap().decoded;
        // One patch, orthonormal (or D^{1/2}-scaled) basis: error of order the step.
        assert!(rms(&rec, &m.positions) < 1e-5, "{op}");
    }
}

#[test]
fn fewer_coefficients_more_error_and_border_coding_helps() {
    let m = builtin::from_spec("builtin:icosphere:4").unwrap();
    let topo = Topology::new(&m).unwrap();
    let step = m.bbox_diagonal() / 4096.0;
    let mut last = 0.0;
    // Without inter-patch prediction (which pins the borders shared with earlier
    // patches), a truncated SSTL basis errs most on the free patch borders (the
    // Kirchhoff basis need not: at keep ratio 0.8 here its border RMS is half the
    // interior's).
    for r in [0.8, 0.4, 0.1] {
        let params = SpectralParams {
            keep: Keep::Ratio(r),
            patch_size: 200,
            border_residuals: false,
            predicted: false,
            operator: OperatorKind::Sstl,
            ..Default::default()
        };
        let EncodedSpectral {
            decoded: rec,
            stats: st,
            ..
        } = SpectralEncoder::new(topo.graph(), &m.positions, params)
            .unwrap()
            .encode(step)
            .unwrap();
        let e = rms(&rec, &m.positions);
        assert!(e > last, "ratio {r}: {e} ≤ {last}");
        assert!(st.border_rms_before > st.interior_rms);
        last = e;
    }
    let params = SpectralParams {
        keep: Keep::Ratio(0.1),
        patch_size: 200,
        border_residuals: true,
        predicted: false,
        operator: OperatorKind::Sstl,
        ..Default::default()
    };
    let rec = SpectralEncoder::new(topo.graph(), &m.positions, params)
        .unwrap()
        .encode(step)
        .unwrap()
        .decoded;
    assert!(rms(&rec, &m.positions) < last);
}

#[test]
fn prediction_shrinks_the_stream_and_keeps_the_error() {
    let m = builtin::from_spec("builtin:torus:40:24").unwrap();
    let topo = Topology::new(&m).unwrap();
    let step = m.bbox_diagonal() / 2048.0;
    let run = |predicted| {
        let params = SpectralParams {
            patch_size: 100,
            predicted,
            band_slope: 0.0,
            ..Default::default()
        };
        let enc = SpectralEncoder::new(topo.graph(), &m.positions, params).unwrap();
        let EncodedSpectral {
            bytes: data,
            decoded: rec,
            stats: st,
        } = enc.encode(step).unwrap();
        assert_eq!(
            decode(topo.graph(), &data, crate::codec::container::VERSION).unwrap(),
            rec
        );
        assert!(st.patches >= 8);
        (data.len(), rms(&rec, &m.positions))
    };
    let (with, e_with) = run(true);
    let (without, e_without) = run(false);
    assert!(
        (with as f64) < 0.9 * without as f64,
        "{with} vs {without} bytes"
    );
    // Same step, same (uniform) quantization error up to noise.
    assert!(e_with < 1.2 * e_without && e_without < 1.2 * e_with);
}

#[test]
fn corrupt_geometry_never_panics() {
    use rand::SeedableRng;
    let m = builtin::from_spec("builtin:icosphere:2").unwrap();
    let topo = Topology::new(&m).unwrap();
    let data = SpectralEncoder::new(topo.graph(), &m.positions, SpectralParams::default())
        .unwrap()
        .encode(0.01)
        .unwrap()
        .bytes;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
    for _ in 0..200 {
        let _ = decode(
            topo.graph(),
            &corrupt(&data, &mut rng),
            crate::codec::container::VERSION,
        );
    }
}

#[test]
fn interleaved_cholesky_gives_the_reference_bits() {
    // The interleaved kernel (four rows, four columns at a time, AVX2 build where
    // available) against the one-at-a-time loops that define format version 6: every
    // size around the multiples of four, rows and columns.
    use super::prediction::{cholesky_solve_fixed, cholesky_solve_reference};
    use faer::Mat;
    let mut rng = crate::rng::SplitMix64::new(11);
    for n in [1usize, 2, 3, 4, 5, 6, 7, 8, 9, 13, 31, 64, 101] {
        for c in [1usize, 3, 4, 5, 8, 11] {
            let b = Mat::from_fn(n, n, |_, _| rng.next_f64() - 0.5);
            let mut m = b.transpose() * &b;
            for i in 0..n {
                m[(i, i)] += 0.01;
            }
            let g0 = Mat::from_fn(n, c, |_, _| rng.next_f64() - 0.5);
            let (mut g1, mut g2) = (g0.clone(), g0.clone());
            cholesky_solve_fixed(&m, &mut g1).unwrap();
            cholesky_solve_reference(&m, &mut g2).unwrap();
            for j in 0..c {
                for i in 0..n {
                    assert_eq!(g1[(i, j)].to_bits(), g2[(i, j)].to_bits(), "n {n} c {c}");
                }
            }
        }
    }
}

/// Format 7's factored predictor, `x̂ = −M⁻¹(L_Uᵀ(L_S y))`, and format 8's banded one
/// predict what the formed `G` of formats 4–6 does (up to rounding), for every
/// predicted patch of a torus.
#[test]
fn factored_prediction_matches_the_formed_matrix() {
    use super::patches::{layout, predictor_owners, Arithmetic};
    use super::prediction::{patch_prediction, PredictorForm};
    let mesh = crate::mesh::builtin::torus(24, 16).unwrap();
    let topo = crate::mesh::topology::Topology::new(&mesh).unwrap();
    let params = SpectralParams {
        patch_size: 40,
        ..Default::default()
    };
    let lay = layout(topo.graph(), &params, crate::codec::container::VERSION).unwrap();
    let owner = predictor_owners(topo.n_vertices(), &params, &lay).unwrap();
    let mut compared = 0;
    for (p, l) in lay.iter().enumerate() {
        let make = |form| {
            patch_prediction(
                topo.graph(),
                &owner,
                &l.verts,
                p as u32,
                Arithmetic::Fixed,
                form,
            )
        };
        match (
            make(PredictorForm::Matrix),
            make(PredictorForm::Factored),
            make(PredictorForm::Banded),
        ) {
            (Some(a), Some(b), Some(c)) => {
                let (xa, xb) = (a.predict(&mesh.positions), b.predict(&mesh.positions));
                let xc = c.predict(&mesh.positions);
                let scale = xa.norm_max().max(1.0);
                assert!((&xa - &xb).norm_max() <= 1e-9 * scale, "patch {p}");
                assert!((&xa - &xc).norm_max() <= 1e-9 * scale, "patch {p} (banded)");
                compared += 1;
            }
            (None, None, None) => {}
            _ => panic!("patch {p}: one form predicts, another does not"),
        }
    }
    assert!(compared >= lay.len() / 2, "{compared} of {}", lay.len());
}

#[test]
fn fixed_order_cholesky_matches_faer() {
    use super::prediction::cholesky_solve_fixed;
    use faer::Mat;
    let mut rng = crate::rng::SplitMix64::new(7);
    for &(n, c) in &[(1usize, 1usize), (5, 3), (37, 8), (120, 41)] {
        let b = Mat::from_fn(n, n, |_, _| rng.next_f64() - 0.5);
        let mut m = b.transpose() * &b;
        for i in 0..n {
            m[(i, i)] += 0.1;
        }
        let g0 = Mat::from_fn(n, c, |_, _| rng.next_f64() - 0.5);
        let mut g = g0.clone();
        cholesky_solve_fixed(&m, &mut g).unwrap();
        let residual = (&m * &g - &g0).norm_max();
        assert!(residual < 1e-10, "n = {n}: residual {residual}");
    }
    // Not positive definite: refused.
    let mut m = Mat::<f64>::identity(3, 3);
    m[(1, 1)] = -1.0;
    assert!(cholesky_solve_fixed(&m, &mut Mat::zeros(3, 1)).is_none());
}

#[test]
fn streamed_bases_give_the_same_stream_and_decoding() {
    // Above the cache budget the encoder computes the bases again on every encode, a
    // chunk at a time, overlapping the next chunk with the current one's coding; the
    // decoder always streams. Neither may change a bit: chunks of one patch (1 byte),
    // of a few patches, and one chunk of everything, against the kept bases.
    for (spec, op) in [
        ("builtin:torus:40:24", OperatorKind::Kirchhoff),
        ("builtin:icosphere:3", OperatorKind::Sql),
        ("builtin:grid:20", OperatorKind::Tutte),
    ] {
        let m = builtin::from_spec(spec).unwrap();
        let topo = Topology::new(&m).unwrap();
        let params = SpectralParams {
            operator: op,
            patch_size: 60,
            ..Default::default()
        };
        let kept = SpectralEncoder::new(topo.graph(), &m.positions, params).unwrap();
        assert!(!kept.streams());
        for div in [64.0, 4096.0] {
            let step = m.bbox_diagonal() / div;
            let want = kept.encode(step).unwrap();
            for chunk in [1, 200_000, usize::MAX] {
                let streamed =
                    SpectralEncoder::with_budgets(topo.graph(), &m.positions, params, 0, chunk)
                        .unwrap();
                assert!(streamed.streams());
                let got = streamed.encode(step).unwrap();
                assert_eq!(got.bytes, want.bytes, "{spec} diag/{div} chunk {chunk}");
                assert!(
                    same_bits(&got.decoded, &want.decoded),
                    "{spec} diag/{div} chunk {chunk}"
                );
                assert_eq!(got.stats.patches, want.stats.patches);
                assert_eq!(got.stats.coefficients, want.stats.coefficients);
                assert_eq!(got.stats.octave_bpv, want.stats.octave_bpv);
                let dec = super::decoder::decode_chunked(
                    topo.graph(),
                    &want.bytes,
                    crate::codec::container::VERSION,
                    chunk,
                )
                .unwrap();
                assert!(
                    same_bits(&dec, &want.decoded),
                    "{spec} diag/{div} decoder chunk {chunk}"
                );
            }
        }
    }
}

#[test]
fn chunks_cover_every_patch_in_order_within_the_budget() {
    let m = builtin::from_spec("builtin:torus:40:24").unwrap();
    let topo = Topology::new(&m).unwrap();
    let params = SpectralParams {
        patch_size: 50,
        ..Default::default()
    };
    let layout =
        super::patches::layout(topo.graph(), &params, crate::codec::container::VERSION).unwrap();
    let bytes = |r: &std::ops::Range<usize>| -> usize {
        layout[r.clone()]
            .iter()
            .map(super::patches::PatchLayout::basis_bytes)
            .sum()
    };
    let largest = layout
        .iter()
        .map(super::patches::PatchLayout::basis_bytes)
        .max()
        .unwrap();
    for budget in [0, 1, largest, 3 * largest, usize::MAX] {
        let r = super::patches::chunks(&layout, budget);
        assert_eq!(r.first().unwrap().start, 0);
        assert_eq!(r.last().unwrap().end, layout.len());
        assert!(r
            .windows(2)
            .all(|w| w[0].end == w[1].start && !w[0].is_empty()));
        // Within the budget unless a single patch exceeds it.
        assert!(
            r.iter().all(|c| c.len() == 1 || bytes(c) <= budget),
            "{budget}"
        );
        // Greedy: a chunk ends only where the next patch would not fit.
        assert!(r
            .windows(2)
            .all(|w| bytes(&(w[0].start..w[0].end + 1)) > budget));
        if budget == usize::MAX {
            assert_eq!(r.len(), 1);
        }
        if budget <= 1 {
            assert_eq!(r.len(), layout.len());
        }
    }
}

/// Format 8 builds the Kirchhoff operator of a patch straight from its faces: the
/// same values as `Operator::assemble`, on a closed mesh and on one with boundary.
#[test]
fn direct_kirchhoff_matches_the_assembled_operator() {
    use super::patches::{kirchhoff_dense, layout, patch_operator};
    use crate::operator::OperatorKind;
    let meshes = [
        crate::mesh::builtin::torus(24, 16).unwrap(),
        crate::mesh::builtin::grid(14).unwrap(),
    ];
    for mesh in &meshes {
        let topo = crate::mesh::topology::Topology::new(mesh).unwrap();
        let params = SpectralParams {
            patch_size: 40,
            ..Default::default()
        };
        let lay = layout(topo.graph(), &params, crate::codec::container::VERSION).unwrap();
        assert!(lay.len() > 2);
        for l in &lay {
            let op = patch_operator(l, OperatorKind::Kirchhoff).unwrap().unwrap();
            let n = l.verts.len();
            let k = kirchhoff_dense(l);
            assert_eq!(
                op.matrix.to_dense(),
                faer::Mat::from_fn(n, n, |i, j| k[i + j * n])
            );
        }
    }
}

/// The factored bases of format 8 give the explicit bases' coefficients up to
/// rounding and sign (per vector), for each symmetric operator.
#[test]
fn factored_bases_match_the_explicit_ones() {
    use super::patches::{bases_then, layout, Recipe};
    use crate::operator::OperatorKind;
    let mesh = crate::mesh::builtin::torus(20, 12).unwrap();
    let topo = crate::mesh::topology::Topology::new(&mesh).unwrap();
    for kind in [
        OperatorKind::Kirchhoff,
        OperatorKind::Graph,
        OperatorKind::Sql,
        OperatorKind::Sstl,
    ] {
        let params = SpectralParams {
            patch_size: 30,
            operator: kind,
            predicted: false,
            ..Default::default()
        };
        let lay = layout(topo.graph(), &params, 8).unwrap();
        let n = lay.len();
        let old = bases_then(
            topo.graph(),
            &params,
            Recipe::for_version(7),
            &lay,
            None,
            0..n,
            |_| usize::MAX,
            |_, b| Ok(b),
        )
        .unwrap();
        let new = bases_then(
            topo.graph(),
            &params,
            Recipe::for_version(8),
            &lay,
            None,
            0..n,
            |_| usize::MAX,
            |_, b| Ok(b),
        )
        .unwrap();
        for (a, b) in old.iter().zip(&new) {
            let x = faer::Mat::from_fn(a.verts.len(), 3, |i, k| {
                mesh.positions[a.verts[i] as usize][k]
            });
            let (ca, cb) = (a.analyze(&x).unwrap(), b.analyze(&x).unwrap());
            let scale = x.norm_max().max(1.0) * (a.verts.len() as f64).sqrt();
            let Some(super::patches::Basis::Factored(f)) = &b.basis else {
                panic!("{kind}: format 8 keeps a symmetric operator's basis factored");
            };
            let lam = f.eigenvalues();
            let mut compared = 0;
            for j in 0..ca.nrows() {
                // A simple eigenvalue's coefficients agree up to the vector's sign
                // (inside a cluster the vectors may differ by a rotation).
                let gap = [j.checked_sub(1), Some(j + 1)]
                    .into_iter()
                    .flatten()
                    .filter(|&i| i < lam.len())
                    .map(|i| (lam[i] - lam[j]).abs())
                    .fold(f64::INFINITY, f64::min);
                if gap < 1e-6 * lam[lam.len() - 1] {
                    continue;
                }
                let sign = if (0..3).map(|k| ca[(j, k)] * cb[(j, k)]).sum::<f64>() < 0.0 {
                    -1.0
                } else {
                    1.0
                };
                for k in 0..3 {
                    let d = (ca[(j, k)] - sign * cb[(j, k)]).abs();
                    assert!(d <= 1e-8 * scale, "{kind}: row {j}: {d:e}");
                }
                compared += 1;
            }
            assert!(
                compared * 2 >= ca.nrows(),
                "{kind}: {compared} of {}",
                ca.nrows()
            );
            // Parseval: the energies agree, and synthesis gives the positions back.
            let energy = |c: &faer::Mat<f64>| -> f64 {
                let mut e = 0.0;
                for j in 0..c.nrows() {
                    for k in 0..3 {
                        e += c[(j, k)].powi(2);
                    }
                }
                e
            };
            let (ea, eb) = (energy(&ca), energy(&cb));
            assert!(
                (ea - eb).abs() <= 1e-10 * ea.max(1.0),
                "{kind}: {ea} vs {eb}"
            );
            let back = b.synthesize(&cb).unwrap();
            assert!((&back - &x).norm_max() <= 1e-12 * scale, "{kind}");
        }
    }
}

/// Reverse Cuthill–McKee gives a permutation that narrows a grid's band, and the band
/// Cholesky solves as a dense solve does.
#[test]
fn band_cholesky_solves_an_rcm_ordered_grid() {
    use super::prediction::{band_cholesky, band_solve, rcm_order};
    // A 9×7 grid graph numbered column-major with a shuffle, plus an isolated vertex.
    let (w, h) = (9usize, 7usize);
    let n = w * h + 1;
    let mut rng = crate::rng::SplitMix64::new(3);
    let mut label: Vec<usize> = (0..w * h).collect();
    for i in (1..label.len()).rev() {
        let j = (rng.next_u64() % (i as u64 + 1)) as usize;
        label.swap(i, j);
    }
    let mut adj: Vec<Vec<u32>> = vec![Vec::new(); n];
    for x in 0..w {
        for y in 0..h {
            let v = label[x * h + y];
            for (dx, dy) in [(1usize, 0usize), (0, 1)] {
                if x + dx < w && y + dy < h {
                    let u = label[(x + dx) * h + y + dy];
                    adj[v].push(u as u32);
                    adj[u].push(v as u32);
                }
            }
        }
    }
    adj.iter_mut().for_each(|a| a.sort_unstable());
    let mut at = vec![0usize];
    let mut flat = Vec::new();
    for a in &adj {
        flat.extend_from_slice(a);
        at.push(flat.len());
    }
    let perm = rcm_order(&at, &flat);
    let mut sorted = perm.clone();
    sorted.sort_unstable();
    assert_eq!(sorted, (0..n as u32).collect::<Vec<_>>());
    let b = (0..n)
        .flat_map(|a| adj[a].iter().map(move |&c| (a, c as usize)))
        .map(|(a, c)| (perm[a] as usize).abs_diff(perm[c] as usize))
        .max()
        .unwrap();
    assert!(b <= 2 * h, "band {b} (grid side {h})");
    // M = 5I − A (diagonally dominant), in the new numbering.
    let mut dense = faer::Mat::<f64>::zeros(n, n);
    for a in 0..n {
        dense[(perm[a] as usize, perm[a] as usize)] = 5.0;
        for &c in &adj[a] {
            dense[(perm[a] as usize, perm[c as usize] as usize)] = -1.0;
        }
    }
    let mut band = vec![0.0f64; n * (b + 1)];
    for i in 0..n {
        for j in i.saturating_sub(b)..=i {
            band[i * (b + 1) + j + b - i] = dense[(i, j)];
        }
    }
    band_cholesky(&mut band, n, b).unwrap();
    let rhs: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).cos()).collect();
    let mut x = rhs.clone();
    band_solve(&band, n, b, &mut x);
    let r = &dense * faer::Mat::from_fn(n, 1, |i, _| x[i]);
    for i in 0..n {
        assert!((r[(i, 0)] - rhs[i]).abs() < 1e-12, "row {i}");
    }
    // Not positive definite: refused.
    let mut bad = vec![0.0f64; 2 * (b + 1)];
    bad[b] = 1.0;
    bad[(b + 1) + b - 1] = 2.0;
    bad[(b + 1) + b] = 1.0;
    assert!(band_cholesky(&mut bad, 2, b).is_none());
}

/// The band Cholesky's blocked order (and, on a CPU with AVX2, its masked-tail dot
/// products) gives the bits of the row-by-row order, on random positive definite
/// band matrices of every size around the block (n < 4 included) and half-widths 0
/// to past n, and refuses the same indefinite matrices.
#[test]
fn blocked_band_cholesky_gives_the_row_order_bits() {
    use super::prediction::{band_cholesky, band_cholesky_by_rows};
    let mut rng = crate::rng::SplitMix64::new(17);
    let mut unit = || (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
    for n in [1usize, 2, 3, 4, 5, 7, 8, 9, 31, 100] {
        for b in [0usize, 1, 2, 3, 4, 5, 6, 13, 27, 40, 120] {
            let mut m = vec![0.0f64; n * (b + 1)];
            for i in 0..n {
                for j in i.saturating_sub(b)..i {
                    m[i * (b + 1) + j + b - i] = unit() - 0.5;
                }
                // Dominant diagonal: positive definite.
                m[i * (b + 1) + b] = 1.0 + (2 * b) as f64 * (0.5 + unit());
            }
            let (mut by_rows, mut blocked) = (m.clone(), m.clone());
            assert!(band_cholesky_by_rows(&mut by_rows, n, b).is_some());
            assert!(band_cholesky(&mut blocked, n, b).is_some());
            assert!(
                by_rows
                    .iter()
                    .zip(&blocked)
                    .all(|(x, y)| x.to_bits() == y.to_bits()),
                "n {n}, b {b}"
            );
            // An indefinite pivot in the last row: both refuse.
            if n >= 2 && b >= 1 {
                let mut bad = m.clone();
                bad[(n - 1) * (b + 1) + b] = -1.0;
                assert!(band_cholesky_by_rows(&mut bad.clone(), n, b).is_none());
                assert!(band_cholesky(&mut bad, n, b).is_none());
            }
        }
    }
}

/// The reverse Cuthill–McKee numbering with its kept buffers is the reference's, on
/// random graphs with several components, isolated vertices and repeated degrees.
#[test]
fn rcm_order_matches_its_reference() {
    use super::prediction::{rcm_order, rcm_order_reference};
    let mut rng = crate::rng::SplitMix64::new(23);
    for n in [1usize, 2, 5, 17, 64, 150] {
        for density in [0u64, 2, 5] {
            let mut adj: Vec<Vec<u32>> = vec![Vec::new(); n];
            for _ in 0..density * n as u64 / 2 {
                let (a, c) = (
                    (rng.next_u64() % n as u64) as usize,
                    (rng.next_u64() % n as u64) as usize,
                );
                if a != c && !adj[a].contains(&(c as u32)) {
                    adj[a].push(c as u32);
                    adj[c].push(a as u32);
                }
            }
            let mut at = vec![0usize];
            let mut flat = Vec::new();
            for a in &adj {
                flat.extend_from_slice(a);
                at.push(flat.len());
            }
            assert_eq!(
                rcm_order(&at, &flat),
                rcm_order_reference(&at, &flat),
                "n {n}, density {density}"
            );
        }
    }
}

/// With more than one thread the coefficients are range-decoded on a thread of
/// their own while the bases wait for them, and the coding takes each patch as soon
/// as it is computed ([`super::patches::stream`]): the same bits as on one thread, and a
/// stream cut short anywhere (the bases then wait for patches that never come) or
/// corrupted gives an error or a decoding, never a hang or a panic.
#[test]
fn coefficients_decoded_beside_the_bases() {
    use rand::SeedableRng;
    let m = builtin::from_spec("builtin:torus:40:24").unwrap();
    let topo = Topology::new(&m).unwrap();
    let params = SpectralParams {
        patch_size: 40,
        ..Default::default()
    };
    let step = m.bbox_diagonal() / 512.0;
    let enc = SpectralEncoder::new(topo.graph(), &m.positions, params)
        .unwrap()
        .encode(step)
        .unwrap();
    let version = crate::codec::container::VERSION;
    let pool = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
    };
    let on =
        |threads: usize, data: &[u8]| pool(threads).install(|| decode(topo.graph(), data, version));
    for threads in [1, 2, 3] {
        // The streamed encoder (a chunk per patch, or a few) gives the same bytes.
        for chunk in [1, 50_000] {
            let streamed = pool(threads).install(|| {
                SpectralEncoder::with_budgets(topo.graph(), &m.positions, params, 0, chunk)
                    .unwrap()
                    .encode(step)
                    .unwrap()
            });
            assert_eq!(
                streamed.bytes, enc.bytes,
                "{threads} threads, chunk {chunk}"
            );
        }
        let dec = on(threads, &enc.bytes).unwrap();
        assert!(same_bits(&dec, &enc.decoded), "{threads} threads");
    }
    for cut in (0..enc.bytes.len()).step_by(7) {
        assert!(on(3, &enc.bytes[..cut]).is_err(), "cut at {cut}");
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    for _ in 0..50 {
        let _ = on(2, &corrupt(&enc.bytes, &mut rng));
    }
}

/// Format 9 relaxes the Lloyd cells two steps, 7 and 8 five: the same method with the
/// version's step count (and so other patches on a mesh with many of them), each
/// version's patches a partition of the vertices.
#[test]
fn lloyd_steps_follow_the_format_version() {
    use super::patches::{layout, lloyd_iterations};
    use crate::partition::PartitionMethod;
    assert_eq!(lloyd_iterations(7), PartitionMethod::LLOYD_ITERATIONS);
    assert_eq!(lloyd_iterations(8), PartitionMethod::LLOYD_ITERATIONS);
    assert_eq!(lloyd_iterations(9), PartitionMethod::LLOYD_ITERATIONS_FAST);
    assert_eq!(crate::codec::container::VERSION, 9);
    let mesh = builtin::icosphere(4).unwrap();
    let topo = Topology::new(&mesh).unwrap();
    let params = SpectralParams {
        patch_size: 40,
        ..Default::default()
    };
    let cells = |version: u16| {
        let lay = layout(topo.graph(), &params, version).unwrap();
        let mut seen = vec![false; topo.n_vertices()];
        for l in &lay {
            for &v in &l.verts {
                assert!(
                    !std::mem::replace(&mut seen[v as usize], true),
                    "v{version}"
                );
            }
        }
        assert!(
            seen.iter().all(|&s| s),
            "v{version}: every vertex in a patch"
        );
        lay.into_iter().map(|l| l.verts).collect::<Vec<_>>()
    };
    assert_ne!(cells(8), cells(9));
}
