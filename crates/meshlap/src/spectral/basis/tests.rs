use super::*;
use crate::mesh::{builtin, topology::Topology, TriMesh};
use crate::operator::{OperatorKind, OperatorOptions};
use crate::spectral::test_util::REAL_SPECTRUM_KINDS;

fn op(m: &TriMesh, kind: OperatorKind) -> Operator {
    let t = Topology::new(m).unwrap();
    Operator::assemble(kind, m, &t, &OperatorOptions::default()).unwrap()
}

fn with_path(path: EigenPath) -> BasisOptions {
    BasisOptions {
        path,
        ..Default::default()
    }
}

fn assert_close(a: &[f64], b: &[f64], tol: f64) {
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(b) {
        assert!((x - y).abs() <= tol, "{x} vs {y}");
    }
}

fn max_diff(a: MatRef<'_, f64>, b: MatRef<'_, f64>) -> f64 {
    let mut w = 0.0f64;
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            w = w.max((a[(i, j)] - b[(i, j)]).abs());
        }
    }
    w
}

#[test]
fn platonic_kirchhoff_spectra_in_closed_form() {
    let s5 = 5f64.sqrt();
    let cases: [(TriMesh, Vec<f64>, Vec<usize>); 3] = [
        (builtin::tetrahedron(), vec![0., 4., 4., 4.], vec![1, 3]),
        (
            builtin::octahedron(),
            vec![0., 4., 4., 4., 6., 6.],
            vec![1, 3, 2],
        ),
        (
            builtin::icosahedron(),
            [vec![0.0], vec![5. - s5; 3], vec![6.; 5], vec![5. + s5; 3]].concat(),
            vec![1, 3, 5, 3],
        ),
    ];
    for (m, expected, mult) in cases {
        let b = EigenBasis::compute(&op(&m, OperatorKind::Kirchhoff), &Default::default()).unwrap();
        assert_eq!(b.path(), EigenPath::Symmetric);
        assert_close(b.eigenvalues(), &expected, 1e-12);
        let sizes: Vec<usize> = b.clusters().iter().map(|c| c.1).collect();
        assert_eq!(sizes, mult);
    }
}

#[test]
fn residuals_and_orthonormality() {
    let meshes = [
        builtin::icosphere(2).unwrap(),
        builtin::cube(4).unwrap(),
        builtin::step(6).unwrap(),
        builtin::torus(8, 5).unwrap(),
    ];
    for m in &meshes {
        for kind in REAL_SPECTRUM_KINDS.into_iter().chain([OperatorKind::Sdl]) {
            let o = op(m, kind);
            for norm in [Normalization::Unit, Normalization::Weighted] {
                let b = EigenBasis::compute(
                    &o,
                    &BasisOptions {
                        normalization: norm,
                        ..Default::default()
                    },
                )
                .unwrap();
                let big = b.eigenvalues().last().unwrap().abs().max(1.0);
                let r = b.max_residual(&o.matrix, o.mass.as_deref());
                assert!(r <= 1e-9 * big, "{kind}: residual {r}");
                let orth = b.orthonormality_error().unwrap();
                assert!(orth <= 1e-9, "{kind}: orthonormality {orth}");
                assert!(b.eigenvalues().windows(2).all(|w| w[0] <= w[1]));
                // PSD sign convention: the smallest eigenvalue is 0.
                assert!(b.eigenvalues()[0].abs() < 1e-9 * big, "{kind}");
            }
        }
    }
}

#[test]
fn tl_similarity_path_matches_general_path() {
    // Irregular valences, simple spectrum: eigenvalues and (canonical,
    // unit-norm) eigenvectors must agree between the two paths.
    for m in [
        crate::spectral::test_util::irregular(),
        builtin::icosphere(1).unwrap(),
        builtin::cube(3).unwrap(),
    ] {
        let o = op(&m, OperatorKind::Tutte);
        let s = EigenBasis::compute(&o, &Default::default()).unwrap();
        let g = EigenBasis::compute(&o, &with_path(EigenPath::General)).unwrap();
        assert_eq!(s.path(), EigenPath::Symmetrized);
        assert_close(s.eigenvalues(), g.eigenvalues(), 1e-10);
        assert!(g.max_imaginary() < 1e-10);
        assert_eq!(s.clusters(), g.clusters());
        for &(start, k) in s.clusters() {
            if k == 1 {
                let d = max_diff(s.vectors().subcols(start, 1), g.vectors().subcols(start, 1));
                assert!(d < 1e-8, "eigenvector {start}: {d}");
            }
        }
        assert!(g.max_residual(&o.matrix, None) < 1e-9);
    }
}

#[test]
fn tl_eigenvectors_are_d_scaled_gl_eigenvectors() {
    // T = D^{-1/2} G D^{1/2}: e_j ∝ D^{-1/2} u_j for the GL's u_j.
    let m = builtin::step(5).unwrap();
    let t = Topology::new(&m).unwrap();
    let d: Vec<f64> = t.degrees().iter().map(|&x| x as f64).collect();
    let tl = EigenBasis::compute(&op(&m, OperatorKind::Tutte), &Default::default()).unwrap();
    let gl = EigenBasis::compute(&op(&m, OperatorKind::Graph), &Default::default()).unwrap();
    assert_close(tl.eigenvalues(), gl.eigenvalues(), 1e-12);
    let w = tl.weights().unwrap();
    for i in 0..d.len() {
        assert!((w[i] / w[0] - d[i] / d[0]).abs() < 1e-12);
    }
    for &(j, k) in tl.clusters() {
        if k > 1 {
            continue;
        }
        let u = gl.vectors().col(j);
        let e = tl.vectors().col(j);
        // e_i·√d_i ∝ u_i with a positive factor (both canonical: e·r_0 > 0 and
        // u·(D^{-1/2}r_0)… differ, so compare up to sign).
        let ratio: Vec<f64> = (0..d.len())
            .filter(|&i| u[i].abs() > 1e-6)
            .map(|i| e[i] * d[i].sqrt() / u[i])
            .collect();
        for r in &ratio {
            assert!((r.abs() - ratio[0].abs()).abs() < 1e-8 * ratio[0].abs());
        }
    }
}

/// Orthonormal basis of each cluster rotated by a seeded random orthogonal
/// matrix, then canonicalised again: must give back the same vectors.
#[test]
fn canonical_basis_is_independent_of_the_eigensolvers_choice() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
    for m in [
        builtin::icosphere(1).unwrap(),
        builtin::icosphere(2).unwrap(),
        builtin::cube(4).unwrap(),
    ] {
        for kind in [
            OperatorKind::Kirchhoff,
            OperatorKind::Sql,
            OperatorKind::Sstl,
        ] {
            let b = EigenBasis::compute(&op(&m, kind), &Default::default()).unwrap();
            let biggest = b.clusters().iter().map(|c| c.1).max().unwrap();
            assert!(biggest >= 3, "{kind}: no repeated eigenvalue found");
            let mut v = b.vectors().to_owned();
            for &(start, k) in b.clusters() {
                let mut o = Mat::from_fn(k, k, |_, _| rng.gen_range(-1.0..1.0));
                assert!(orthonormalize(&mut o));
                let rotated = v.as_ref().subcols(start, k) * &o;
                v.as_mut().subcols_mut(start, k).copy_from(&rotated);
            }
            canonicalize(&mut v, b.clusters(), None);
            let d = max_diff(v.as_ref(), b.vectors());
            assert!(d < 1e-12, "{kind}: {d}");
        }
    }
}

#[test]
fn canonical_basis_survives_a_different_computation_order() {
    // Sequential faer (different blocking and reduction order) or the reproducible
    // solver (a different algorithm), on the symmetric matrix permuted then
    // unpermuted: the same canonical basis up to rounding. Rounding in the
    // eigensolver perturbs eigenvectors by ≈ ε‖A‖/gap (gaps between clusters are
    // ≈1e-3 here), so 1e-10, not bitwise.
    for (m, solver) in [
        (builtin::icosphere(2).unwrap(), DenseSolver::Faer),
        (builtin::cube(4).unwrap(), DenseSolver::Faer),
        (builtin::icosphere(2).unwrap(), DenseSolver::Reproducible),
        (builtin::cube(4).unwrap(), DenseSolver::Reproducible),
    ] {
        let o = op(&m, OperatorKind::Sql);
        let b = EigenBasis::compute(&o, &Default::default()).unwrap();
        let n = b.n();
        let a = o.matrix.to_dense();
        let p = [7, 11, 13]
            .into_iter()
            .find(|p| !n.is_multiple_of(*p))
            .unwrap();
        let perm: Vec<usize> = (0..n).map(|i| (i * p + 3) % n).collect();
        let pa = Mat::from_fn(n, n, |i, j| a[(perm[i], perm[j])]);
        let (lam, pu) = dense_symmetric(
            pa,
            Par::Seq,
            solver,
            usize::MAX,
            BasisOptions::DEFAULT_CLUSTER_TOLERANCE,
        )
        .unwrap();
        let mut u = Mat::<f64>::zeros(n, n);
        for i in 0..n {
            for j in 0..n {
                u[(perm[i], j)] = pu[(i, j)];
            }
        }
        let cl = clusters(&lam, 1e-10);
        assert_eq!(cl, b.clusters());
        canonicalize(&mut u, &cl, None);
        let d = max_diff(u.as_ref(), b.vectors());
        assert!(d < 1e-10, "{d}");
    }
}

#[test]
fn bitwise_identical_across_thread_counts() {
    let m = builtin::icosphere(3).unwrap();
    for kind in [OperatorKind::Sql, OperatorKind::Tutte] {
        let o = op(&m, kind);
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| EigenBasis::compute(&o, &Default::default()).unwrap())
        };
        let (b1, b3) = (run(1), run(3));
        assert_eq!(b1.eigenvalues(), b3.eigenvalues());
        assert!(b1.vectors() == b3.vectors(), "{kind}");
    }
}

#[test]
fn cotan_basis_is_the_generalized_problem() {
    // L v = λ M v: check the generalized residual and M-orthonormality directly.
    let m = builtin::icosphere(2).unwrap();
    let o = op(&m, OperatorKind::Cotan);
    let mass = o.mass.clone().unwrap();
    let b = EigenBasis::compute(
        &o,
        &BasisOptions {
            normalization: Normalization::Weighted,
            ..Default::default()
        },
    )
    .unwrap();
    let e = b.vectors();
    let l = o.matrix.to_dense();
    let le = &l * e;
    for j in [0, 1, 5, 100, b.len() - 1] {
        for i in 0..b.n() {
            let r = le[(i, j)] - b.eigenvalues()[j] * mass[i] * e[(i, j)];
            assert!(r.abs() < 1e-9);
        }
    }
    let g = Mat::from_fn(b.n(), b.n(), |i, j| mass[i] * e[(i, j)]);
    let gram = e.transpose() * &g;
    for i in 0..b.n() {
        for j in 0..b.n() {
            let d = if i == j { 1.0 } else { 0.0 };
            assert!((gram[(i, j)] - d).abs() < 1e-9);
        }
    }
    // The general path on M⁻¹L agrees on the spectrum.
    let gen = EigenBasis::compute(&o, &with_path(EigenPath::General)).unwrap();
    let big = b.eigenvalues().last().unwrap().abs();
    assert_close(b.eigenvalues(), gen.eigenvalues(), 1e-9 * big);
}

#[test]
fn errors_not_panics() {
    let m = builtin::octahedron();
    let tl = op(&builtin::step(3).unwrap(), OperatorKind::Tutte);
    assert!(matches!(
        EigenBasis::compute(&tl, &with_path(EigenPath::Symmetric)),
        Err(SpectralError::NotSymmetric)
    ));
    // A non-symmetrizable matrix: a directed 3-cycle.
    let f = SparseMatrix::try_new_from_triplets(
        3,
        3,
        &[
            faer::sparse::Triplet::new(0, 0, 1.0),
            faer::sparse::Triplet::new(1, 1, 1.0),
            faer::sparse::Triplet::new(2, 2, 1.0),
            faer::sparse::Triplet::new(0, 1, -1.0),
            faer::sparse::Triplet::new(1, 2, -1.0),
            faer::sparse::Triplet::new(2, 0, -1.0),
        ],
    )
    .unwrap();
    assert!(matches!(
        EigenBasis::from_matrix(&f, None, &Default::default()),
        Err(SpectralError::NotSymmetrizable)
    ));
    // Its spectrum is complex: the general path refuses it.
    assert!(matches!(
        EigenBasis::from_matrix(&f, None, &with_path(EigenPath::General)),
        Err(SpectralError::ComplexSpectrum { .. })
    ));
    let k = op(&m, OperatorKind::Kirchhoff);
    assert!(matches!(
        EigenBasis::from_matrix(&k.matrix, Some(&[1.0; 5]), &Default::default()),
        Err(SpectralError::ShapeMismatch { .. })
    ));
    assert!(matches!(
        EigenBasis::from_matrix(
            &k.matrix,
            Some(&[1.0, 1.0, 0.0, 1.0, 1.0, 1.0]),
            &Default::default()
        ),
        Err(SpectralError::InvalidMass { vertex: 2, .. })
    ));
    let mut bad = k.matrix.clone();
    bad.val_mut()[0] = f64::NAN;
    assert!(matches!(
        EigenBasis::from_matrix(&bad, None, &Default::default()),
        Err(SpectralError::NonFinite { .. })
    ));
    assert!("nope".parse::<EigenPath>().is_err());
    assert_eq!("general".parse::<EigenPath>().unwrap(), EigenPath::General);
}

#[test]
fn probes_are_fixed() {
    // The decoder's contract: these values must never change.
    assert!((-1.0..1.0).contains(&probe(0, 0)));
    let v: Vec<f64> = (0..1000).map(|i| probe(i, 0)).collect();
    let mean = v.iter().sum::<f64>() / 1000.0;
    assert!(mean.abs() < 0.1);
    assert_ne!(probe(5, 0), probe(5, 1));
    // Pinned bits (computed independently from the documented hash).
    assert_eq!(probe(0, 0).to_bits(), 0xbfe4_97a6_4023_16e8); // −0.6435118916203608
    assert_eq!(probe(17, 2).to_bits(), 0x3fd0_3522_5633_e96c); // 0.2532430497955349
    assert_eq!(probe(5, 1).to_bits(), 0xbfe9_2ade_0f62_40a8); // −0.7864828396286798
}

#[test]
fn lowest_basis_is_the_first_columns_bit_for_bit() {
    // The reproducible solver's partial basis (the codec's decoder): the first k
    // columns, eigenvalues and scales of the full basis, k = count extended to the
    // end of its eigenvalue cluster; symmetric (Kirchhoff, SQL) and symmetrized
    // (Tutte) paths, with repeated eigenvalues (icosphere, cube).
    let opts = BasisOptions {
        dense_solver: DenseSolver::Reproducible,
        ..Default::default()
    };
    for m in [
        builtin::icosphere(2).unwrap(),
        builtin::cube(4).unwrap(),
        builtin::torus(9, 7).unwrap(),
    ] {
        for kind in [
            OperatorKind::Kirchhoff,
            OperatorKind::Sql,
            OperatorKind::Tutte,
        ] {
            let o = op(&m, kind);
            let full = EigenBasis::compute(&o, &opts).unwrap();
            let n = full.n();
            for count in [0, 1, 2, 3, 4, 5, 9, 17, n / 2, n - 1, n, n + 5] {
                let low = EigenBasis::compute_lowest(&o, &opts, count).unwrap();
                let k = low.len();
                assert!(k >= count.min(n) && k <= n, "{kind} count {count}: k {k}");
                assert!(
                    k == 0 || full.clusters().iter().any(|&(s, l)| s + l == k),
                    "{kind} count {count}: k {k} inside a cluster"
                );
                assert_eq!(low.path(), full.path());
                assert_eq!(low.eigenvalues(), &full.eigenvalues()[..k]);
                assert_eq!(low.coefficient_scale(), &full.coefficient_scale()[..k]);
                for j in 0..k {
                    for i in 0..n {
                        assert_eq!(
                            low.vectors()[(i, j)].to_bits(),
                            full.vectors()[(i, j)].to_bits(),
                            "{kind} count {count}"
                        );
                    }
                }
            }
        }
    }
}

/// Above the parallel thresholds (the blocked solver's threaded product from 384,
/// faer's tridiagonalisation in parallel below rem²/2 ≥ 192·256, divide and conquer
/// above 128, canonicalisation and normalisation in parallel chunks): residuals
/// `‖F e − λ e‖`, orthonormality in the basis' inner product, the default (blocked)
/// solver reproducing the basis' eigenvalues bit for bit, and agreement with faer's
/// own `self_adjoint_evd` of the same symmetric matrix `A` (= F, or
/// `S^{1/2} F S^{-1/2}` for the TL): the same eigenvalues to 1e-12·λ_max, and per
/// cluster the same eigenspace (`‖U_cᵀ W_c‖²_F = k` for the
/// Euclidean-orthonormal `w_j = g_j^{1/2} S^{1/2} e_j`).
#[test]
fn large_bases_match_faer_and_are_orthonormal() {
    use crate::operator::symmetrize::{symmetrized_dense, Scaling};
    for m in [
        builtin::icosphere(3).unwrap(),
        builtin::torus(32, 20).unwrap(),
    ] {
        assert!(m.n_vertices() >= 640);
        for kind in [
            OperatorKind::Kirchhoff,
            OperatorKind::Sql,
            OperatorKind::Tutte,
        ] {
            let o = op(&m, kind);
            let b = EigenBasis::compute(&o, &Default::default()).unwrap();
            let big = b.eigenvalues().last().unwrap().abs().max(1.0);
            let r = b.max_residual(&o.matrix, None);
            assert!(r <= 1e-10 * big, "{kind}: residual {r}");
            let orth = b.orthonormality_error().unwrap();
            assert!(orth <= 1e-10, "{kind}: orthonormality {orth}");
            let s = b.weights().map(<[f64]>::to_vec);
            let a = match &s {
                None => o.matrix.to_dense(),
                Some(s) => symmetrized_dense(&o.matrix, Scaling::Similarity(s)),
            };
            // The default solver (blocked) again, bit for bit; faer's own solver to
            // rounding, with the same eigenspace per cluster.
            for solver in [DenseSolver::Blocked, DenseSolver::Faer] {
                let (lam, u) = dense_symmetric(
                    a.clone(),
                    parallelism(),
                    solver,
                    a.nrows(),
                    BasisOptions::default().cluster_tolerance,
                )
                .unwrap();
                if solver == DenseSolver::Blocked {
                    assert_eq!(lam, b.eigenvalues(), "{kind}");
                } else {
                    for (x, y) in lam.iter().zip(b.eigenvalues()) {
                        assert!((x - y).abs() <= 1e-12 * big, "{kind}: {x} vs faer {y}");
                    }
                }
                let n = b.n();
                let w = Mat::from_fn(n, n, |i, j| {
                    b.coefficient_scale()[j].sqrt()
                        * s.as_ref().map_or(1.0, |s| s[i].sqrt())
                        * b.vectors()[(i, j)]
                });
                for &(start, k) in b.clusters() {
                    let g = u.as_ref().subcols(start, k).transpose() * w.as_ref().subcols(start, k);
                    let f2 = g.norm_l2().powi(2);
                    assert!(
                        (f2 - k as f64).abs() < 1e-9,
                        "{kind} ({solver}): cluster {start}+{k}: {f2}"
                    );
                }
            }
        }
    }
}

/// The option names of the CLI's `--path`, `--normalization` and `--dense-solver` and
/// of the Python package's `spectrum`, parsed by the library (any case), and unknown
/// names rejected with the choices listed.
#[test]
fn option_names_parse() {
    assert_eq!(
        "UNIT".parse::<Normalization>().unwrap(),
        Normalization::Unit
    );
    assert_eq!(
        "weighted".parse::<Normalization>().unwrap(),
        Normalization::Weighted
    );
    let e = "euclid".parse::<Normalization>().unwrap_err().to_string();
    assert!(e.contains("unit or weighted"), "{e}");
    for s in [
        DenseSolver::Blocked,
        DenseSolver::Faer,
        DenseSolver::Reproducible,
    ] {
        assert_eq!(s.name().parse::<DenseSolver>().unwrap(), s);
    }
    assert!("lapack".parse::<DenseSolver>().is_err());
    assert_eq!("general".parse::<EigenPath>().unwrap(), EigenPath::General);
}
