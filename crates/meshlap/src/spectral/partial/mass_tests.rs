//! The generalized problem with a sparse (non-diagonal) mass matrix `M = C Cᵀ`,
//! cross-checked against a dense Cholesky reduction computed here.

use super::mass::Metric;
use super::*;
use crate::mesh::{builtin, topology::Topology, TriMesh};
use crate::operator::{OperatorKind, OperatorOptions};
use faer::sparse::{SparseColMat, Triplet};
use faer::Side;

/// The consistent (linear finite-element) mass matrix: per triangle of area A,
/// `A/6` on the diagonal and `A/12` off it.
fn consistent_mass(mesh: &TriMesh) -> SparseMatrix {
    let mut trip = Vec::new();
    for f in &mesh.faces {
        let p = f.map(|i| mesh.positions[i as usize]);
        let e1 = [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]];
        let e2 = [p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]];
        let c = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let area = 0.5 * (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        for a in 0..3 {
            for b in 0..3 {
                let v = if a == b { area / 6.0 } else { area / 12.0 };
                trip.push(Triplet::new(f[a] as usize, f[b] as usize, v));
            }
        }
    }
    let n = mesh.n_vertices();
    SparseColMat::try_new_from_triplets(n, n, &trip).unwrap()
}

fn cotan(mesh: &TriMesh) -> SparseMatrix {
    let topo = Topology::new(mesh).unwrap();
    Operator::assemble(
        OperatorKind::Cotan,
        mesh,
        &topo,
        &OperatorOptions::default(),
    )
    .unwrap()
    .matrix
}

/// Eigenvalues of `K v = λ M v` by a dense Cholesky `M = L Lᵀ` and the dense
/// symmetric eigensolver on `L⁻¹ K L⁻ᵀ`.
fn dense_generalized(k: &SparseMatrix, m: &SparseMatrix) -> Vec<f64> {
    let n = k.nrows();
    let l = m.to_dense().llt(Side::Lower).unwrap();
    let lmat = l.L().to_owned();
    let kd = k.to_dense();
    // X = L⁻¹ K, A = L⁻¹ Xᵀ.
    use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
    let mut x = kd.clone();
    solve_lower_triangular_in_place(lmat.as_ref(), x.as_mut(), faer::Par::Seq);
    let mut a = x.transpose().to_owned();
    solve_lower_triangular_in_place(lmat.as_ref(), a.as_mut(), faer::Par::Seq);
    let a = Mat::from_fn(n, n, |i, j| 0.5 * (a[(i, j)] + a[(j, i)]));
    let evd = a.self_adjoint_eigen(Side::Lower).unwrap();
    (0..n).map(|i| evd.S()[i]).collect()
}

/// Eigenvalues against the dense reference, residuals `‖Kv − λMv‖` and `VᵀMV = I`
/// measured with the dense matrices.
fn check(k: &SparseMatrix, m: &SparseMatrix, ps: &PartialSpectrum) {
    let count = ps.eigenvalues.len();
    let reference = dense_generalized(k, m);
    let scale = reference[count - 1].abs().max(1.0);
    for j in 0..count {
        assert!(
            (ps.eigenvalues[j] - reference[j]).abs() < 1e-8 * scale,
            "λ_{j}: {} vs dense {}",
            ps.eigenvalues[j],
            reference[j]
        );
    }
    let (kd, md) = (k.to_dense(), m.to_dense());
    let v = &ps.eigenvectors;
    let gram = v.transpose() * &md * v;
    let id = Mat::<f64>::identity(count, count);
    assert!((&gram - &id).norm_max() < 1e-9, "VᵀMV − I");
    let kv = &kd * v;
    let mv = &md * v;
    for j in 0..count {
        let r = (0..k.nrows())
            .map(|i| kv[(i, j)] - ps.eigenvalues[j] * mv[(i, j)])
            .fold(0.0f64, |a, x| a.max(x.abs()));
        assert!(r < 1e-8 * scale, "pair {j}: |Kv − λMv| = {r:.3e}");
        assert!(ps.residuals[j] < 1e-8 * scale, "reported residual {j}");
    }
}

#[test]
fn the_factor_reproduces_the_mass_matrix() {
    let mesh = crate::spectral::test_util::irregular();
    let m = consistent_mass(&mesh);
    let n = mesh.n_vertices();
    let metric = Metric::new(Mass::Sparse(&m), n).unwrap();
    assert!(metric.diagonal_sqrt().is_none());
    // C as a dense matrix: C I.
    let mut c = Mat::<f64>::identity(n, n);
    metric.mul_c(c.as_mut());
    let cct = &c * c.transpose();
    assert!((&cct - m.to_dense()).norm_max() < 1e-14 * m.to_dense().norm_max() * 10.0);
    // Cᵀ is the transpose of C, and the solves invert the products.
    let mut ct = Mat::<f64>::identity(n, n);
    metric.mul_ct(ct.as_mut());
    assert!((&ct - c.transpose()).norm_max() < 1e-15);
    let mut x = Mat::<f64>::zeros(n, 3);
    crate::spectral::krylov_schur::random_fill(x.as_mut(), 7);
    let mut y = x.clone();
    metric.mul_c(y.as_mut());
    metric.solve_c(y.as_mut());
    assert!((&y - &x).norm_max() < 1e-10);
    let mut y = x.clone();
    metric.mul_ct(y.as_mut());
    metric.solve_ct(y.as_mut());
    assert!((&y - &x).norm_max() < 1e-10);
}

#[test]
fn a_consistent_mass_matrix_on_the_dense_path() {
    let mesh = crate::spectral::test_util::irregular();
    let (k, m) = (cotan(&mesh), consistent_mass(&mesh));
    let ps = partial_spectrum_with_mass(
        &k,
        Mass::Sparse(&m),
        &PartialParams::new(25),
        &mut |_, _| {},
    )
    .unwrap();
    assert!(ps.info.dense);
    check(&k, &m, &ps);
    // λ₀ = 0 on a connected mesh with the constant vector (M-normalised, positive by
    // the sign rule... up to the probe) as its eigenvector.
    assert!(ps.eigenvalues[0].abs() < 1e-10);
}

#[test]
fn a_consistent_mass_matrix_on_the_banded_path() {
    // 642 vertices; bands of 16 chained over 40 pairs (several shifts), multiple
    // eigenvalues of the sphere included.
    let mesh = builtin::icosphere(3).unwrap();
    let (k, m) = (cotan(&mesh), consistent_mass(&mesh));
    let mut opts = PartialParams::new(40);
    opts.dense_below = 0;
    opts.band_size = 16;
    let ps = partial_spectrum_with_mass(&k, Mass::Sparse(&m), &opts, &mut |_, _| {}).unwrap();
    assert!(!ps.info.dense && ps.info.bands.len() > 1, "{:?}", ps.info);
    check(&k, &m, &ps);
    // The inertia count agrees with the dense spectrum.
    let reference = dense_generalized(&k, &m);
    let x = 0.5 * (reference[20] + reference[21]);
    assert_eq!(eigenvalues_below(&k, Mass::Sparse(&m), x).unwrap(), 21);
}

#[test]
fn a_diagonal_matrix_stored_sparse_is_the_lumped_problem() {
    let mesh = crate::spectral::test_util::irregular();
    let k = cotan(&mesh);
    let n = mesh.n_vertices();
    let lumped: Vec<f64> = (0..n).map(|i| 0.5 + (i % 7) as f64 * 0.1).collect();
    let trip: Vec<_> = (0..n).map(|i| Triplet::new(i, i, lumped[i])).collect();
    let m = SparseColMat::try_new_from_triplets(n, n, &trip).unwrap();
    let opts = PartialParams::new(10);
    let a = partial_spectrum_with_mass(&k, Mass::Sparse(&m), &opts, &mut |_, _| {}).unwrap();
    let b = partial_spectrum(&k, Some(&lumped), &opts, &mut |_, _| {}).unwrap();
    assert_eq!(a.eigenvalues, b.eigenvalues);
    assert_eq!(a.eigenvectors, b.eigenvectors);
}

#[test]
fn bad_mass_matrices_are_refused() {
    let mesh = crate::spectral::test_util::irregular();
    let (k, m) = (cotan(&mesh), consistent_mass(&mesh));
    let n = mesh.n_vertices();
    let opts = PartialParams::new(5);
    let run = |m: &SparseMatrix| {
        partial_spectrum_with_mass(&k, Mass::Sparse(m), &opts, &mut |_, _| {}).unwrap_err()
    };
    // Indefinite: −M.
    let neg = SparseColMat::try_new_from_triplets(
        n,
        n,
        &(0..n)
            .flat_map(|j| {
                m.row_idx_of_col_raw(j)
                    .iter()
                    .zip(m.val_of_col(j))
                    .map(move |(&i, &v)| Triplet::new(i, j, -v))
            })
            .collect::<Vec<_>>(),
    )
    .unwrap();
    assert!(matches!(
        run(&neg),
        SpectralError::MassNotPositiveDefinite { .. }
    ));
    // Not symmetric: one off-diagonal entry changed.
    let mut asym = m.clone();
    let p = m
        .row_idx_of_col_raw(0)
        .iter()
        .position(|&i| i != 0)
        .unwrap();
    asym.val_mut()[p] *= 2.0;
    assert!(matches!(
        run(&asym),
        SpectralError::NotSymmetricMatrix { what: "M", .. }
    ));
    // Wrong size.
    let small = SparseColMat::<usize, f64>::try_new_from_triplets(3, 3, &[]).unwrap();
    assert!(matches!(run(&small), SpectralError::ShapeMismatch { .. }));
    // A non-symmetric K.
    let mut kasym = k.clone();
    kasym.val_mut()[1] += 1.0;
    let e =
        partial_spectrum_with_mass(&kasym, Mass::Sparse(&m), &opts, &mut |_, _| {}).unwrap_err();
    assert!(matches!(
        e,
        SpectralError::NotSymmetricMatrix { what: "K", .. }
    ));
}
