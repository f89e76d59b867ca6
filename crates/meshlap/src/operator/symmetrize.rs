//! Symmetry of an assembled operator and the crate's one symmetrizer.
//!
//! **Sign convention.** Operators are `F = D − W`, positive semi-definite (libigl and
//! pmp use the negative); nothing here depends on the sign.
//!
//! Several of Zhang's (2004) operators are not symmetric but are *symmetrizable*: a
//! positive diagonal `S` makes `S·F` symmetric (the Tutte Laplacian with `S = D`, the
//! second-order Tutte operator `T²`, the scale-dependent Laplacian with the weight
//! sums). Then `S^{1/2} F S^{-1/2}` is symmetric and similar to `F`, so the spectrum is
//! real and symmetric eigensolvers and Krylov methods apply: the dense eigenbasis
//! ([`crate::spectral::basis`]), the partial spectrum
//! ([`crate::spectral::partial::SymmetricProblem`]), implicit fairing
//! ([`crate::filter::implicit`]) and the property report
//! ([`crate::analysis::properties`]) all take their symmetrizer and symmetrized
//! matrices from here.

use crate::SparseMatrix;
use faer::sparse::{CreationError, Triplet};
use faer::Mat;

/// Entry (i, j) of a CSC matrix with sorted row indices (0 if not stored).
pub fn entry(f: &SparseMatrix, i: usize, j: usize) -> f64 {
    let rows = f.row_idx_of_col_raw(j);
    match rows.binary_search(&i) {
        Ok(p) => f.val_of_col(j)[p],
        Err(_) => 0.0,
    }
}

/// `max |F_ij − F_ji|` over the stored entries (binary search in the transposed
/// position; a missing entry counts as 0).
pub fn asymmetry(f: &SparseMatrix) -> f64 {
    let mut worst = 0.0f64;
    for j in 0..f.ncols() {
        for (&i, &v) in f.row_idx_of_col_raw(j).iter().zip(f.val_of_col(j)) {
            worst = worst.max((v - entry(f, j, i)).abs());
        }
    }
    worst
}

/// True when `f` is symmetric up to rounding (`max |F_ij − F_ji| ≤ 1e-12·max |F_ij|`).
pub fn is_symmetric(f: &SparseMatrix) -> bool {
    let scale = f.val().iter().fold(0.0f64, |a, v| a.max(v.abs()));
    asymmetry(f) <= 1e-12 * scale
}

/// A positive diagonal `s` (length n) with `diag(s)·F` symmetric, if one exists:
/// requires a symmetric pattern with `F_ij·F_ji > 0` and consistent ratios
/// `s_j/s_i = F_ij/F_ji` around every cycle (checked on every stored pair, relative
/// tolerance 1e-12). Each connected component of the pattern has its own free scale;
/// its first vertex gets `s = 1`.
pub fn diagonal_symmetrizer(f: &SparseMatrix) -> Option<Vec<f64>> {
    let n = f.nrows();
    let mut s = vec![0.0f64; n];
    let mut queue = std::collections::VecDeque::new();
    for root in 0..n {
        if s[root] != 0.0 {
            continue;
        }
        s[root] = 1.0;
        queue.push_back(root);
        while let Some(i) = queue.pop_front() {
            // Column i holds F_ki; the transposed entry F_ik decides s_k.
            for (&k, &fki) in f.row_idx_of_col_raw(i).iter().zip(f.val_of_col(i)) {
                if k == i || fki == 0.0 {
                    continue;
                }
                let fik = entry(f, i, k);
                if fik * fki <= 0.0 {
                    return None;
                }
                // s_i F_ik = s_k F_ki
                let sk = s[i] * fik / fki;
                if s[k] == 0.0 {
                    s[k] = sk;
                    queue.push_back(k);
                } else if (s[k] - sk).abs() > 1e-12 * s[k].abs() {
                    return None;
                }
            }
        }
    }
    Some(s)
}

/// The positive diagonal S making `S·F` symmetric, scaled so that the off-diagonal
/// entries of `S·F` have mean magnitude 1 (S = D for the Tutte Laplacian). The ratios
/// found by [`diagonal_symmetrizer`] carry rounding from products along paths; when
/// every scaled entry is within 1e-9 (relative) of an integer — the degrees, for the
/// TL — the integers are used, so that `S·F` is exactly the Kirchhoff operator.
pub fn symmetrizer(f: &SparseMatrix) -> Option<Vec<f64>> {
    let mut s = diagonal_symmetrizer(f)?;
    let (mut sum, mut count) = (0.0, 0usize);
    for j in 0..f.ncols() {
        for (&i, &v) in f.row_idx_of_col_raw(j).iter().zip(f.val_of_col(j)) {
            if i != j && v != 0.0 {
                sum += (s[i] * v).abs();
                count += 1;
            }
        }
    }
    if count > 0 && sum > 0.0 {
        let c = count as f64 / sum;
        s.iter_mut().for_each(|v| *v *= c);
    }
    if s.iter()
        .all(|v| (v - v.round()).abs() <= 1e-9 * v.abs() && v.round() >= 1.0)
    {
        s.iter_mut().for_each(|v| *v = v.round());
    }
    Some(s)
}

/// How [`symmetrized_dense`] scales `F` (n×n) into a symmetric matrix `A`.
#[derive(Clone, Copy, Debug)]
pub enum Scaling<'a> {
    /// `A = F` (F already symmetric up to rounding).
    None,
    /// `A = S^{1/2} F S^{-1/2}` for a diagonal symmetrizer `s` of F: similar to F,
    /// so `A`'s eigenvectors `u` give F's as `S^{-1/2} u`.
    Similarity(&'a [f64]),
    /// `A = M^{-1/2} K M^{-1/2}` for a symmetric K and a positive diagonal `m`: the
    /// generalized problem `K v = λ M v` as a standard one, `v = M^{-1/2} u`.
    Congruence(&'a [f64]),
}

/// The dense symmetric matrix of `f` under `scaling` (n×n, both triangles stored):
/// entries `a_ij = f_ij·√s_i/√s_j` (similarity) or `f_ij/(√m_i·√m_j)` (congruence),
/// then `(a_ij + a_ji)/2` in both triangles, so that rounding asymmetry is averaged
/// away and a symmetric eigensolver may read either triangle.
///
/// Scaling and averaging visit the stored entries only (O(n² + nnz·log d), one
/// zero-filled n×n allocation): the entries outside the pattern of `F + Fᵀ` are 0 and
/// stay 0, so the result is the same, bit for bit, as scaling and averaging the whole
/// dense matrix.
pub fn symmetrized_dense(f: &SparseMatrix, scaling: Scaling<'_>) -> Mat<f64> {
    let n = f.nrows();
    let (weights, congruence) = match scaling {
        Scaling::None => (None, false),
        Scaling::Similarity(s) => (Some(s), false),
        Scaling::Congruence(m) => (Some(m), true),
    };
    let r: Option<Vec<f64>> = weights.map(|s| s.iter().map(|x| x.sqrt()).collect());
    let mut a = Mat::<f64>::zeros(n, f.ncols());
    for j in 0..f.ncols() {
        for (&i, &x) in f.row_idx_of_col_raw(j).iter().zip(f.val_of_col(j)) {
            a[(i, j)] += match &r {
                None => x,
                Some(r) if congruence => x / (r[i] * r[j]),
                Some(r) => x * r[i] / r[j],
            };
        }
    }
    // Each off-diagonal pair once: from its lower entry when that is stored, else
    // from its upper one.
    for j in 0..f.ncols() {
        for &i in f.row_idx_of_col_raw(j) {
            if i == j || (i < j && f.row_idx_of_col_raw(i).binary_search(&j).is_ok()) {
                continue;
            }
            let (p, q) = (i.max(j), i.min(j));
            let m = 0.5 * (a[(p, q)] + a[(q, p)]);
            a[(p, q)] = m;
            a[(q, p)] = m;
        }
    }
    a
}

/// `K = (SF + (SF)ᵀ)/2` as a sparse matrix (pattern of F, both triangles stored) for a
/// diagonal symmetrizer `s` of F: `F v = λ v ⇔ K v = λ S v`, a symmetric generalized
/// problem. The average removes the rounding asymmetry of the products `s_i F_ij`.
pub fn symmetric_product(f: &SparseMatrix, s: &[f64]) -> Result<SparseMatrix, CreationError> {
    let n = f.nrows();
    let mut trip = Vec::with_capacity(f.compute_nnz());
    for j in 0..n {
        for (&i, &v) in f.row_idx_of_col_raw(j).iter().zip(f.val_of_col(j)) {
            trip.push(Triplet::new(i, j, s[i] * v));
        }
    }
    let mut k = SparseMatrix::try_new_from_triplets(n, n, &trip)?;
    let copy = k.clone();
    for j in 0..n {
        let rows: Vec<usize> = copy.row_idx_of_col_raw(j).to_vec();
        let vals = k.val_of_col_mut(j);
        for (p, &i) in rows.iter().enumerate() {
            vals[p] = 0.5 * (entry(&copy, i, j) + entry(&copy, j, i));
        }
    }
    Ok(k)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::mesh::{builtin, topology::Topology};
    use crate::operator::{Operator, OperatorKind, OperatorOptions};

    fn op(kind: OperatorKind) -> Operator {
        let m = builtin::icosphere(1).unwrap();
        let t = Topology::new(&m).unwrap();
        Operator::assemble(kind, &m, &t, &OperatorOptions::default()).unwrap()
    }

    #[test]
    fn tutte_symmetrizer_is_the_degree_and_gives_kirchhoff() {
        let tl = op(OperatorKind::Tutte);
        let kl = op(OperatorKind::Kirchhoff);
        assert!(!is_symmetric(&tl.matrix));
        let s = symmetrizer(&tl.matrix).unwrap();
        let k = symmetric_product(&tl.matrix, &s).unwrap();
        assert!(is_symmetric(&k));
        for j in 0..k.ncols() {
            assert_eq!(s[j], kl.matrix.val_of_col(j).len() as f64 - 1.0);
            for i in 0..k.nrows() {
                assert!((entry(&k, i, j) - entry(&kl.matrix, i, j)).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn similarity_and_congruence_are_symmetric_and_keep_the_spectrum() {
        let tl = op(OperatorKind::Tutte);
        let s = diagonal_symmetrizer(&tl.matrix).unwrap();
        let a = symmetrized_dense(&tl.matrix, Scaling::Similarity(&s));
        let k = symmetric_product(&tl.matrix, &s).unwrap();
        let b = symmetrized_dense(&k, Scaling::Congruence(&s));
        // S^{1/2} T S^{-1/2} = S^{-1/2} (S T) S^{-1/2}: the two routes agree.
        assert!((&a - &b).norm_max() < 1e-12);
        assert!((&a - a.transpose()).norm_max() == 0.0);
        let ev = a.self_adjoint_eigenvalues(faer::Side::Lower).unwrap();
        assert!(ev[0].abs() < 1e-12 && ev[1] > 1e-3);
    }

    /// The whole-matrix formula [`symmetrized_dense`] reproduces from the stored
    /// entries only: scale every entry, then average every pair.
    fn symmetrized_dense_reference(f: &SparseMatrix, scaling: Scaling<'_>) -> Mat<f64> {
        let n = f.nrows();
        let mut a = f.to_dense();
        let (r, congruence) = match scaling {
            Scaling::None => (None, false),
            Scaling::Similarity(s) => (Some(s), false),
            Scaling::Congruence(m) => (Some(m), true),
        };
        let r: Option<Vec<f64>> = r.map(|s| s.iter().map(|x| x.sqrt()).collect());
        for j in 0..n {
            for i in 0..n {
                let x = a[(i, j)];
                if let (Some(r), true) = (&r, x != 0.0) {
                    a[(i, j)] = if congruence {
                        x / (r[i] * r[j])
                    } else {
                        x * r[i] / r[j]
                    };
                }
            }
        }
        for j in 0..n {
            for i in j + 1..n {
                let m = 0.5 * (a[(i, j)] + a[(j, i)]);
                a[(i, j)] = m;
                a[(j, i)] = m;
            }
        }
        a
    }

    #[test]
    fn symmetrized_dense_is_the_whole_matrix_formula_bit_for_bit() {
        let tl = op(OperatorKind::Tutte);
        let s = diagonal_symmetrizer(&tl.matrix).unwrap();
        let k = symmetric_product(&tl.matrix, &s).unwrap();
        // An asymmetric pattern too: (0, 2) stored, (2, 0) not; (1, 0) only below.
        let trip = [
            Triplet::new(0usize, 0usize, 2.0),
            Triplet::new(0, 2, -0.7),
            Triplet::new(1, 0, 0.3),
            Triplet::new(1, 1, 1.5),
            Triplet::new(2, 1, -0.1),
            Triplet::new(1, 2, -0.2),
            Triplet::new(2, 2, 0.9),
        ];
        let odd = SparseMatrix::try_new_from_triplets(3, 3, &trip).unwrap();
        let w = [0.5, 2.0, 3.0];
        let cases: [(&SparseMatrix, Scaling<'_>); 5] = [
            (&tl.matrix, Scaling::Similarity(&s)),
            (&k, Scaling::Congruence(&s)),
            (&tl.matrix, Scaling::None),
            (&odd, Scaling::Similarity(&w)),
            (&odd, Scaling::None),
        ];
        for (f, scaling) in cases {
            let a = symmetrized_dense(f, scaling);
            let b = symmetrized_dense_reference(f, scaling);
            for j in 0..a.ncols() {
                for i in 0..a.nrows() {
                    assert_eq!(a[(i, j)].to_bits(), b[(i, j)].to_bits(), "({i}, {j})");
                }
            }
        }
    }

    /// A 2×2 matrix with `F_01 F_10 < 0` (as the mean-value operator can have): no
    /// positive diagonal symmetrizer exists.
    pub(crate) fn opposite_signs() -> SparseMatrix {
        let trip = [
            Triplet::new(0usize, 0usize, 1.0),
            Triplet::new(0, 1, -1.0),
            Triplet::new(1, 0, 1.0),
            Triplet::new(1, 1, 1.0),
        ];
        SparseMatrix::try_new_from_triplets(2, 2, &trip).unwrap()
    }

    #[test]
    fn mean_value_like_sign_pattern_has_no_symmetrizer() {
        let m = opposite_signs();
        assert!(diagonal_symmetrizer(&m).is_none());
        assert!(asymmetry(&m) == 2.0);
    }
}
