use super::factor::{factor_at, ShiftedPattern};
use super::mass::Metric;
use super::solve::ShiftInvert;
use super::*;
use crate::mesh::{builtin, topology::Topology, TriMesh};
use crate::operator::OperatorKind;
use crate::operator::OperatorOptions;
use crate::spectral::krylov_schur::BlockOperator;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{factorize_symbolic_cholesky, LdltRef, SymmetricOrdering};

use faer::Side;
use faer::{Col, Conj, Par};

/// `√m_i` (all ones without a mass).
fn msqrt_of(mass: Option<&[f64]>, n: usize) -> Vec<f64> {
    match mass {
        Some(m) => m.iter().map(|x| x.sqrt()).collect(),
        None => vec![1.0; n],
    }
}

fn assemble(kind: OperatorKind, mesh: &TriMesh) -> Operator {
    let topo = Topology::new(mesh).unwrap();
    Operator::assemble(kind, mesh, &topo, &OperatorOptions::default()).unwrap()
}

/// Dense reference: eigenpairs of M^{-1/2} K M^{-1/2}, ascending (w coordinates).
fn dense_reference(k: &SparseMatrix, mass: Option<&[f64]>) -> (Vec<f64>, Mat<f64>) {
    let n = k.nrows();
    let ms = msqrt_of(mass, n);
    let kd = k.to_dense();
    let a = Mat::from_fn(n, n, |i, j| kd[(i, j)] / (ms[i] * ms[j]));
    let evd = a.self_adjoint_eigen(Side::Lower).unwrap();
    let s: Vec<f64> = (0..n).map(|i| evd.S()[i]).collect();
    (s, evd.U().to_owned())
}

/// Checks a partial spectrum against the dense one: eigenvalues to 1e-8,
/// residuals ≤ 1e-9, VᵀMV = I to 1e-9, and every complete cluster of equal
/// eigenvalues spans the dense eigenspace.
fn check_against_dense(k: &SparseMatrix, mass: Option<&[f64]>, ps: &PartialSpectrum) {
    let n = k.nrows();
    let m = ps.eigenvalues.len();
    let (s, u) = dense_reference(k, mass);
    let ms = msqrt_of(mass, n);
    for j in 0..m {
        assert!(
            (ps.eigenvalues[j] - s[j]).abs() < 1e-8,
            "λ_{j}: {} vs dense {}",
            ps.eigenvalues[j],
            s[j]
        );
        assert!(ps.residuals[j] <= 1e-9, "residual {j}: {}", ps.residuals[j]);
    }
    // M-orthonormality.
    let w = Mat::from_fn(n, m, |i, j| ps.eigenvectors[(i, j)] * ms[i]);
    let g = w.transpose() * &w;
    for a in 0..m {
        for b in 0..m {
            let want = if a == b { 1.0 } else { 0.0 };
            assert!(
                (g[(a, b)] - want).abs() < 1e-9,
                "WᵀW[{a},{b}] = {}",
                g[(a, b)]
            );
        }
    }
    // Clusters: [lo, hi) with equal dense eigenvalues, complete inside 0..m.
    let mut lo = 0;
    while lo < m {
        let mut hi = lo + 1;
        while hi < n && (s[hi] - s[lo]).abs() < 1e-7 {
            hi += 1;
        }
        if hi <= m {
            // ‖W_c − U_c U_cᵀ W_c‖ small.
            let uc = u.subcols(lo, hi - lo);
            let wc = w.subcols(lo, hi - lo);
            let proj = uc * (uc.transpose() * wc);
            let err = (&proj - wc).norm_max();
            assert!(err < 1e-7, "cluster {lo}..{hi}: subspace error {err}");
        }
        lo = hi;
    }
}

/// faer's own solve of what [`ShiftInvert::apply_block`] computes: `S F⁻¹ S x` for the
/// n×p right-hand sides `x`, with `S = diag(msqrt)` and `F` the matrix whose LDLᵀ
/// factor is `values` (pattern `symbolic`).
fn faer_scaled_solve(
    symbolic: &faer::sparse::linalg::cholesky::SymbolicCholesky<usize>,
    values: &[f64],
    x: faer::MatRef<'_, f64>,
    msqrt: &[f64],
) -> Mat<f64> {
    let (n, p) = (x.nrows(), x.ncols());
    let mut y = Mat::from_fn(n, p, |i, j| x[(i, j)] * msqrt[i]);
    let mut buf = MemBuffer::new(symbolic.solve_in_place_scratch::<f64>(p, Par::Seq));
    LdltRef::new(symbolic, values).solve_in_place_with_conj(
        Conj::No,
        y.as_mut(),
        Par::Seq,
        MemStack::new(&mut buf),
    );
    Mat::from_fn(n, p, |i, j| y[(i, j)] * msqrt[i])
}

#[test]
fn interleaved_supernodal_solve_matches_faer_for_both_orderings() {
    use faer::sparse::linalg::cholesky::SymbolicCholeskyRaw;
    // icosphere:5 (10,242 vertices) gets a supernodal factorization.
    let mesh = builtin::icosphere(5).unwrap();
    let op = assemble(OperatorKind::Sql, &mesh);
    let n = mesh.n_vertices();
    let identity = Metric::new(Mass::Identity, n).unwrap();
    let pattern = ShiftedPattern::new(&op.matrix, &identity).unwrap();
    let nd = super::ordering::nested_dissection(&pattern.base).expect("METIS ordering");
    let msqrt: Vec<f64> = (0..n).map(|i| 1.0 + (i % 5) as f64 * 0.1).collect();
    // The solves' scaling alone (the factored matrix is K − σI).
    let scaling = Metric::new(
        Mass::Lumped(&msqrt.iter().map(|s| s * s).collect::<Vec<_>>()),
        n,
    )
    .unwrap();
    let mut x = Mat::<f64>::zeros(n, 29);
    super::super::krylov_schur::random_fill(x.as_mut(), 42);
    for custom in [false, true] {
        let ordering = if custom {
            SymmetricOrdering::Custom(faer::perm::PermRef::new_checked(&nd.0, &nd.1, n))
        } else {
            SymmetricOrdering::Amd
        };
        let symbolic = factorize_symbolic_cholesky(
            pattern.base.symbolic(),
            Side::Lower,
            ordering,
            Default::default(),
        )
        .unwrap();
        assert!(matches!(symbolic.raw(), SymbolicCholeskyRaw::Supernodal(_)));
        // A shift inside the spectrum: K − σI is indefinite.
        let sigma = 0.37;
        let values = factor_at(&pattern, &symbolic, sigma).unwrap();
        // Unsplit, and forest by forest where the tree splits (METIS' nested
        // dissection always does here; AMD's tree may not).
        let split = super::solve::TreeSplit::of(&symbolic, 0);
        if custom {
            assert!(split.is_some(), "nested dissection gives a split tree");
        }
        let mut cases = vec![(None, 1usize)];
        if split.is_some() {
            cases.extend([(split, 1), (split, 2), (split, 3), (split, 4)]);
        }
        let mut split_bits: Vec<Vec<u64>> = Vec::new();
        for (split, threads) in cases {
            let si = ShiftInvert {
                symbolic: &symbolic,
                values: values.clone(),
                metric: &scaling,
                msqrt: &msqrt,
                split,
                scratch: Default::default(),
            };
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            // Groups of 1, 4, 8 and 16 columns (29 = 16 + 8 + 4 + 1).
            for (q, p) in [1usize, 3, 8, 13, 29].into_iter().enumerate() {
                let xb = x.as_ref().subcols(0, p);
                let mut ours = Mat::<f64>::zeros(n, p);
                pool.install(|| si.apply_block(xb, ours.as_mut()));
                if split.is_some() {
                    // The same bits on any pool.
                    let bits: Vec<u64> = (0..p)
                        .flat_map(|j| (0..n).map(move |i| (i, j)))
                        .map(|(i, j)| ours[(i, j)].to_bits())
                        .collect();
                    if split_bits.len() <= q {
                        split_bits.push(bits);
                    } else {
                        assert!(split_bits[q] == bits, "p = {p}, {threads} threads");
                    }
                }
                let reference = faer_scaled_solve(&symbolic, &values, xb, &msqrt);
                let err = (&ours - &reference).norm_max() / reference.norm_max();
                assert!(
                    err < 1e-10,
                    "p = {p}, METIS = {custom}, split = {split:?}: {err}"
                );
                // And it solves (K − σI) y = M^{1/2} x for y = M^{-1/2} out.
                let y = Mat::from_fn(n, p, |i, j| ours[(i, j)] / msqrt[i]);
                let ky = op.matrix.as_ref() * &y;
                let res = Mat::from_fn(n, p, |i, j| {
                    ky[(i, j)] - sigma * y[(i, j)] - msqrt[i] * xb[(i, j)]
                });
                assert!(res.norm_max() < 1e-8 * y.norm_max().max(1.0), "p = {p}");
            }
        }
    }
}

/// The split solve (the two forests on their threads, then the top) without METIS:
/// a hand-made dissection of an icosphere (its upper half, its lower half less the
/// separator, then the lower vertices next to the upper half) and a forced
/// supernodal factor. faer's own solve of the same system, to rounding, and the same
/// bits on pools of 1 to 3 threads. Sized for Miri too (icosphere 2 there), which
/// cannot run the METIS ordering the large meshes take (C); but Miri stops inside
/// faer's sparse symbolic Cholesky before the solve (undefined behaviour of faer's
/// and dyn-stack's own, `upstream/faer-amd-miri/`), so `.ci/miri` does not list it.
#[test]
fn split_solve_on_a_hand_made_dissection_matches_faer() {
    use faer::sparse::linalg::cholesky::CholeskySymbolicParams;
    use faer::sparse::linalg::SupernodalThreshold;
    let mesh = builtin::icosphere(if cfg!(miri) { 2 } else { 4 }).unwrap();
    let op = assemble(OperatorKind::Sql, &mesh);
    let topo = Topology::new(&mesh).unwrap();
    let n = mesh.n_vertices();
    let up = |v: usize| mesh.positions[v][2] > 0.0;
    let separator = |v: usize| {
        !up(v)
            && topo
                .neighbors(crate::VertexId(v as u32))
                .iter()
                .any(|&u| up(u as usize))
    };
    let identity = Metric::new(Mass::Identity, n).unwrap();
    let pattern = ShiftedPattern::new(&op.matrix, &identity).unwrap();
    // By part (the upper half, the lower half, the separator), and within each part
    // from the poles towards the equator (|z| descending): a band-like order that
    // needs no fill-reducing ordering. (Not AMD: under Miri faer's AMD reports
    // undefined behaviour of its own, RELIABILITY.md.)
    let part = |v: usize| match (up(v), separator(v)) {
        (true, _) => 0u8,
        (false, false) => 1,
        (false, true) => 2,
    };
    let mut fwd: Vec<usize> = (0..n).collect();
    fwd.sort_by(|&a, &b| {
        let key = |v: usize| (part(v), -mesh.positions[v][2].abs());
        key(a).partial_cmp(&key(b)).unwrap().then(a.cmp(&b))
    });
    let mut inv = vec![0usize; n];
    for (new, &old) in fwd.iter().enumerate() {
        inv[old] = new;
    }
    let symbolic = factorize_symbolic_cholesky(
        pattern.base.symbolic(),
        Side::Lower,
        SymmetricOrdering::Custom(faer::perm::PermRef::new_checked(&fwd, &inv, n)),
        CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        },
    )
    .unwrap();
    let split = super::solve::TreeSplit::of(&symbolic, 0);
    assert!(split.is_some(), "a dissection's tree splits");
    // Inside the spectrum: K − σI is indefinite.
    let sigma = 0.37;
    let values = factor_at(&pattern, &symbolic, sigma).unwrap();
    let msqrt: Vec<f64> = (0..n).map(|i| 1.0 + (i % 5) as f64 * 0.1).collect();
    let scaling = Metric::new(
        Mass::Lumped(&msqrt.iter().map(|s| s * s).collect::<Vec<_>>()),
        n,
    )
    .unwrap();
    let si = ShiftInvert {
        symbolic: &symbolic,
        values: values.clone(),
        metric: &scaling,
        msqrt: &msqrt,
        split,
        scratch: Default::default(),
    };
    // Groups of 16, 8, 4 and 1 columns.
    let p = 29;
    let mut x = Mat::<f64>::zeros(n, p);
    super::super::krylov_schur::random_fill(x.as_mut(), 7);
    let mut first: Option<Mat<f64>> = None;
    for threads in [1, 2, 3] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let mut ours = Mat::<f64>::zeros(n, p);
        pool.install(|| si.apply_block(x.as_ref(), ours.as_mut()));
        match &first {
            None => first = Some(ours),
            Some(f) => assert!(
                (0..p).all(|j| (0..n).all(|i| f[(i, j)].to_bits() == ours[(i, j)].to_bits())),
                "{threads} threads"
            ),
        }
    }
    let ours = first.unwrap();
    let reference = faer_scaled_solve(&symbolic, &values, x.as_ref(), &msqrt);
    let err = (&ours - &reference).norm_max() / reference.norm_max();
    assert!(err < 1e-10, "{err}");
}

#[test]
fn band_shifts_find_the_dense_smallest_with_multiplicities() {
    // icosphere:3 (642 vertices): highly repeated eigenvalues.
    let mesh = builtin::icosphere(3).unwrap();
    let op = assemble(OperatorKind::Sql, &mesh);
    let mut opts = PartialParams::new(80);
    opts.dense_below = 0;
    opts.band_size = 24; // several bands, overlapping clusters
    let mut calls = 0;
    let ps = operator_partial_spectrum(&op, true, &opts, &mut |_, _| calls += 1).unwrap();
    assert!(!ps.info.dense);
    assert!(ps.info.bands.len() >= 3, "{:?}", ps.info.bands);
    assert!(calls >= ps.info.bands.len());
    assert_eq!(ps.eigenvalues.len(), 80);
    check_against_dense(&op.matrix, None, &ps);
    // The multiplicities are real: some eigenvalue repeats at least 5 times.
    let (s, _) = dense_reference(&op.matrix, None);
    let mut max_mult = 1;
    let mut run = 1;
    for j in 1..80 {
        run = if (s[j] - s[j - 1]).abs() < 1e-7 {
            run + 1
        } else {
            1
        };
        max_mult = max_mult.max(run);
    }
    assert!(max_mult >= 5, "max multiplicity {max_mult}");
}

#[test]
fn single_band_agrees_with_dense_kirchhoff_on_irregular_mesh() {
    let mesh = builtin::cube(9).unwrap();
    let op = assemble(OperatorKind::Kirchhoff, &mesh);
    let mut opts = PartialParams::new(30);
    opts.dense_below = 0;
    let ps = operator_partial_spectrum(&op, true, &opts, &mut |_, _| {}).unwrap();
    assert_eq!(ps.info.bands.len(), 1);
    check_against_dense(&op.matrix, None, &ps);
    assert!(ps.eigenvalues[0].abs() < 1e-10);
}

#[test]
fn generalized_cotangent_problem_matches_dense_mass_normalized() {
    let mesh = builtin::torus(30, 14).unwrap();
    let op = assemble(OperatorKind::Cotan, &mesh);
    let mass = op.mass.clone().unwrap();
    let mut opts = PartialParams::new(45);
    opts.dense_below = 0;
    opts.band_size = 20;
    let ps = operator_partial_spectrum(&op, true, &opts, &mut |_, _| {}).unwrap();
    check_against_dense(&op.matrix, Some(&mass), &ps);
    // L v = λ M v directly.
    let n = mesh.n_vertices();
    for j in 0..45 {
        let v = ps.eigenvectors.col(j);
        let lv = op.matrix.as_ref() * v;
        let err = (0..n)
            .map(|i| (lv[i] - ps.eigenvalues[j] * mass[i] * v[i]).abs())
            .fold(0.0f64, f64::max);
        assert!(err < 1e-8, "pair {j}: {err}");
    }
}

#[test]
fn tutte_through_its_symmetrizer_has_the_graph_spectrum() {
    let mesh = builtin::step(16).unwrap();
    let tl = assemble(OperatorKind::Tutte, &mesh);
    let gl = assemble(OperatorKind::Graph, &mesh);
    let mut opts = PartialParams::new(25);
    opts.dense_below = 0;
    let pt = operator_partial_spectrum(&tl, true, &opts, &mut |_, _| {}).unwrap();
    let pg = operator_partial_spectrum(&gl, true, &opts, &mut |_, _| {}).unwrap();
    for j in 0..25 {
        assert!((pt.eigenvalues[j] - pg.eigenvalues[j]).abs() < 1e-9);
        // T v = λ v for the returned (D-normalised) vectors.
        let v = pt.eigenvectors.col(j);
        let tv = tl.matrix.as_ref() * v;
        let err = (&tv - v * faer::Scale(pt.eigenvalues[j])).norm_max();
        assert!(err < 1e-9 * v.norm_max().max(1.0), "pair {j}: {err}");
    }
}

/// The partial solver's vectors equal the dense canonical basis (one sign and
/// cluster rule on both paths), on the dense fallback and on the banded path, with
/// the icosphere's 3-, 5- and 7-fold eigenvalues complete among the returned pairs.
#[test]
fn both_paths_give_the_dense_canonical_basis() {
    use crate::spectral::{BasisOptions, EigenBasis};
    for (level, want, dense_below) in [(1usize, 9usize, 600usize), (3, 16, 100)] {
        let mesh = builtin::icosphere(level).unwrap();
        let op = assemble(OperatorKind::Graph, &mesh);
        let basis = EigenBasis::compute(&op, &BasisOptions::default()).unwrap();
        // The largest count ≤ want that ends a cluster (the returned set must hold
        // whole clusters for their bases to be unique).
        let k = basis
            .clusters()
            .iter()
            .map(|c| c.0 + c.1)
            .filter(|&end| end <= want)
            .max()
            .unwrap();
        assert!(k >= want - 7 && basis.clusters().iter().any(|c| c.1 > 1));
        let mut params = PartialParams::new(k);
        params.dense_below = dense_below;
        let ps = operator_partial_spectrum(&op, true, &params, &mut |_, _| {}).unwrap();
        assert_eq!(ps.info.dense, level == 1);
        check_against_dense(&op.matrix, None, &ps);
        let e = basis.vectors();
        for j in 0..k {
            let err = (0..mesh.n_vertices())
                .map(|i| (ps.eigenvectors[(i, j)] - e[(i, j)]).abs())
                .fold(0.0f64, f64::max);
            assert!(err < 1e-7, "icosphere {level}, vector {j}: {err}");
        }
    }
}

#[test]
fn bad_input_is_an_error() {
    let mesh = builtin::icosahedron();
    let op = assemble(OperatorKind::Kirchhoff, &mesh);
    let opts = PartialParams::new(3);
    assert!(matches!(
        partial_spectrum(&op.matrix, Some(&[1.0; 5]), &opts, &mut |_, _| {}),
        Err(SpectralError::ShapeMismatch { what: "mass", .. })
    ));
    let mut bad = vec![1.0; 12];
    bad[4] = 0.0;
    assert!(matches!(
        partial_spectrum(&op.matrix, Some(&bad), &opts, &mut |_, _| {}),
        Err(SpectralError::InvalidMass { vertex: 4, .. })
    ));
    assert!(matches!(
        partial_spectrum(&op.matrix, None, &PartialParams::new(13), &mut |_, _| {}),
        Err(SpectralError::TooMany { count: 13, n: 12 })
    ));
    for (band_size, block_size) in [(200, 0), (0, 0), (4, 8)] {
        let opts = PartialParams {
            band_size,
            block_size,
            ..PartialParams::new(3)
        };
        assert!(matches!(
            partial_spectrum(&op.matrix, None, &opts, &mut |_, _| {}),
            Err(SpectralError::InvalidBlocking { band_size: b, block_size: p })
                if b == band_size && p == block_size
        ));
    }
    // F_01 F_10 < 0: no positive diagonal symmetrizer.
    let m = crate::operator::symmetrize::tests::opposite_signs();
    let op = Operator {
        kind: OperatorKind::MeanValue,
        matrix: m,
        mass: None,
    };
    assert!(matches!(
        operator_partial_spectrum(&op, true, &opts, &mut |_, _| {}),
        Err(SpectralError::NoRealSpectrum(OperatorKind::MeanValue))
    ));
}

#[test]
fn refinement_lowers_the_residuals_and_keeps_the_spectrum() {
    // SQL of a sphere (M = I, several bands) and the cotangent operator with its
    // lumped mass: the refined pairs have residuals at least 5x smaller (17x and more
    // measured), the same eigenvalues, and still pass the dense comparison; for M = I
    // the reported residual is ‖Fv − λv‖ computed here.
    let cases = [
        (OperatorKind::Sql, builtin::icosphere(4).unwrap(), 60, 25),
        (OperatorKind::Cotan, builtin::torus(40, 18).unwrap(), 50, 50),
    ];
    for (kind, mesh, count, band) in cases {
        let op = assemble(kind, &mesh);
        let mass = op.mass.clone();
        let mut opts = PartialParams::new(count);
        opts.dense_below = 0;
        opts.band_size = band;
        opts.tolerance = 1e-10;
        let refined = operator_partial_spectrum(&op, true, &opts, &mut |_, _| {}).unwrap();
        opts.refine = false;
        let plain = operator_partial_spectrum(&op, true, &opts, &mut |_, _| {}).unwrap();
        check_against_dense(&op.matrix, mass.as_deref(), &refined);
        let worst = |r: &[f64]| r.iter().fold(0.0f64, |a, &b| a.max(b));
        let (rr, rp) = (worst(&refined.residuals), worst(&plain.residuals));
        assert!(rr < rp / 5.0, "{kind:?}: refined {rr:e} vs plain {rp:e}");
        for j in 0..count {
            let scale = refined.eigenvalues[j].abs().max(1.0);
            assert!(
                (refined.eigenvalues[j] - plain.eigenvalues[j]).abs() < 1e-9 * scale,
                "{kind:?} λ_{j}"
            );
        }
        if mass.is_none() {
            let n = mesh.n_vertices();
            for j in 0..count {
                let v = refined.eigenvectors.col(j);
                let fv = op.matrix.as_ref() * v;
                let r: f64 = (0..n)
                    .map(|i| (fv[i] - refined.eigenvalues[j] * v[i]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                // The reported residual is this norm (cross-check of the two ways).
                let reported = refined.residuals[j];
                assert!(
                    (r - reported).abs() <= 0.01 * reported + 1e-15,
                    "{kind:?} pair {j}: ‖Fv − λv‖ = {r:e}, reported {reported:e}"
                );
            }
        }
    }
}

#[test]
fn repeated_calls_give_the_same_bits_on_both_paths() {
    // Run-to-run determinism: the dense path and the banded path (several bands,
    // parallel solves, refinement) return identical bits on every call. Before the
    // ordered block sums, the Rayleigh quotients changed in the last bit in about
    // one call in ten.
    let mesh = crate::spectral::test_util::irregular();
    let op = assemble(OperatorKind::Cotan, &mesh);
    let mass: Vec<f64> = (0..mesh.n_vertices())
        .map(|i| 0.5 + (i % 7) as f64 * 0.1)
        .collect();
    let sphere = assemble(OperatorKind::Sql, &builtin::icosphere(3).unwrap());
    let mut banded = PartialParams::new(40);
    banded.dense_below = 0;
    banded.band_size = 16;
    let cases: [(&SparseMatrix, Option<&[f64]>, PartialParams); 2] = [
        (&op.matrix, Some(&mass[..]), PartialParams::new(10)),
        (&sphere.matrix, None, banded),
    ];
    for (k, m, opts) in cases {
        let first = partial_spectrum(k, m, &opts, &mut |_, _| {}).unwrap();
        for _ in 0..12 {
            let again = partial_spectrum(k, m, &opts, &mut |_, _| {}).unwrap();
            assert_eq!(again.eigenvalues, first.eigenvalues);
            assert_eq!(again.eigenvectors, first.eigenvectors);
            assert_eq!(again.residuals, first.residuals);
        }
    }
}

#[test]
fn refinement_on_a_reused_work_matrix_gives_the_same_bits() {
    // `polish` writes every entry of its work storage it reads: a NaN-filled,
    // wider-than-needed work matrix (what the band driver lends it: the previous
    // Krylov–Schur basis) gives the bits of a fresh one.
    let mesh = builtin::icosphere(3).unwrap();
    let op = assemble(OperatorKind::Sql, &mesh);
    let n = mesh.n_vertices();
    let identity = Metric::new(Mass::Identity, n).unwrap();
    let pattern = ShiftedPattern::new(&op.matrix, &identity).unwrap();
    let symbolic = factorize_symbolic_cholesky(
        pattern.base.symbolic(),
        Side::Lower,
        SymmetricOrdering::Amd,
        Default::default(),
    )
    .unwrap();
    let sigma = -1e-3;
    let mut ones = Vec::new();
    let si = ShiftInvert {
        symbolic: &symbolic,
        values: factor_at(&pattern, &symbolic, sigma).unwrap(),
        metric: &identity,
        msqrt: ShiftInvert::scale_of(&identity, &mut ones),
        split: None,
        scratch: Default::default(),
    };
    // The 12 lowest eigenpairs, slightly perturbed (seeded), as a band's pairs.
    let (values, vectors) = dense_reference(&op.matrix, None);
    let mut noise = Mat::<f64>::zeros(n, 12);
    super::super::krylov_schur::random_fill(noise.as_mut(), 7);
    let found: Vec<(f64, Col<f64>)> = (0..12)
        .map(|j| {
            let v = Col::from_fn(n, |i| vectors[(i, j)] + 1e-9 * noise[(i, j)]);
            (values[j], v)
        })
        .collect();
    // The refined pairs, moved into a copy of the band's pairs as the driver does.
    let refine = |work: &mut Mat<f64>| {
        let values =
            super::polish::polish(&si, &op.matrix, &identity, &found, work).expect("refined");
        let mut pairs = found.clone();
        super::polish::replace_with_refined(&mut pairs, &values, work.as_ref());
        pairs
    };
    let fresh = refine(&mut Mat::new());
    let mut reused = Mat::from_fn(n, 31, |_, _| f64::NAN);
    let again = refine(&mut reused);
    let bits = |c: &Col<f64>| c.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    for ((l0, v0), (l1, v1)) in fresh.iter().zip(&again) {
        assert_eq!(l0.to_bits(), l1.to_bits());
        assert_eq!(bits(v0), bits(v1));
    }
    // Ascending values, unit vectors.
    assert!(fresh.windows(2).all(|p| p[0].0 <= p[1].0));
    for (_, v) in &fresh {
        assert!((v.norm_l2() - 1.0).abs() < 1e-14);
    }
    // And the refinement did its job: residuals below the perturbation's.
    for (l, v) in &fresh {
        let r = op.matrix.as_ref() * v - Col::from_fn(n, |i| l * v[i]);
        assert!(r.norm_l2() < 1e-9, "residual {:e}", r.norm_l2());
    }
}

#[test]
fn blocked_symmetric_product_matches_column_products() {
    // icosphere:4's SQL (2,562 vertices: more than one block of rows) and a grid's
    // cotan (boundary rows); 21 = 8 + 8 + 5 columns: full and partial groups.
    let sphere = builtin::icosphere(4).unwrap();
    let grid = builtin::grid(40).unwrap();
    for (name, k) in [
        (
            "icosphere:4 SQL",
            assemble(OperatorKind::Sql, &sphere).matrix,
        ),
        ("grid cotan", assemble(OperatorKind::Cotan, &grid).matrix),
    ] {
        let n = k.nrows();
        let mut x = Mat::<f64>::zeros(n, 21);
        super::super::krylov_schur::random_fill(x.as_mut(), 7);
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let mut y = Mat::<f64>::from_fn(n, 21, |_, _| f64::NAN);
            pool.install(|| super::mass::symmetric_mul_block(&k, x.as_ref(), y.as_mut()));
            for j in 0..21 {
                let xj: Vec<f64> = x.col(j).iter().copied().collect();
                // The one-vector product sums in the same order: the same bits.
                let want = super::mass::symmetric_mul(&k, &xj);
                for i in 0..n {
                    assert_eq!(
                        y[(i, j)].to_bits(),
                        want[i].to_bits(),
                        "{name}, {threads} threads, ({i}, {j})"
                    );
                }
            }
            // And it is K X.
            let kx = k.as_ref() * &x;
            let err = (&kx - &y).norm_max() / kx.norm_max();
            assert!(err < 1e-14, "{name}: {err}");
        }
    }
}
