//! One step of iterative refinement of a symmetric eigendecomposition `T ≈ Q Θ Qᵀ`
//! (Ogita & Aishima 2018, *Iterative refinement for symmetric eigenvalue
//! decomposition*, Japan J. Indust. Appl. Math. 35, Algorithm 1), with the
//! near-multiple eigenvalues it cannot separate diagonalised exactly in their own
//! small subspaces.
//!
//! ## Why
//! The Rayleigh–Ritz step of [`super::krylov_schur`] diagonalises the projected
//! matrix `T` (s×s, s up to 5/2 of the wanted pairs) with faer's dense self-adjoint
//! eigensolver, whose eigenvectors on these thick-restart matrices carry residuals
//! `‖T qᵢ − θᵢ qᵢ‖` hundreds of times above LAPACK's (about `10⁻¹³–10⁻¹²·‖T‖` at
//! s ≈ 500; figures in BENCHMARKS.md, "Python API"). Krylov–Schur never sees that
//! error: its residual estimate `‖R Q_last‖` assumes `T qᵢ = θᵢ qᵢ` exactly, and the
//! restart's `H = diag(θ)` drops it. A wanted pair far from the shift (`|θᵢ|` an
//! order of magnitude below `‖T‖`) is left with a true residual of about
//! `10⁻¹¹·|θᵢ|` however small the tolerance — the floor that kept the generalized
//! problems' residuals far above ARPACK's. One refinement step brings the residual
//! to about `√s·ε·‖T‖` with four s×s products.
//!
//! ## Method
//! With `R = I − QᵀQ`, `S = Qᵀ T Q` (symmetrised), `λ̃ᵢ = Sᵢᵢ / (1 − Rᵢᵢ)`:
//! `Q ← Q (I + E)` with `Eᵢᵢ = Rᵢᵢ/2` and, for `i ≠ j`,
//! `Eᵢⱼ = (Sᵢⱼ + λ̃ⱼ Rᵢⱼ) / (λ̃ⱼ − λ̃ᵢ)` when the two are separated, `Rᵢⱼ/2` when
//! not. Separated: not in the same *cluster*, the runs of sorted `λ̃` whose
//! consecutive gaps are at most `δ = max(2(‖S − Λ̃‖_F + ‖T‖·‖R‖_F), 10⁶·max|Sᵢⱼ|)`
//! (the paper's `δ`, widened so that every first-order correction stays below
//! `10⁻⁶`, where its second-order error is negligible). Each cluster of two or more
//! is then diagonalised exactly: `Q_C ← Q_C U` with `Q_Cᵀ T Q_C = U Θ_C Uᵀ` (a
//! |C|×|C| eigenproblem, accurate relative to its own, small, norm).
//!
//! The products run on the rayon threads by fixed column halves, each sequential,
//! so the result does not depend on scheduling (faer's parallel product may).

use super::thin_products::by_column_halves;
use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, MatMut, MatRef, Par, Side};

/// Refines the eigenpairs `(θ, Q)` of the symmetric s×s `t` in place (one step; see
/// the module documentation). `theta` (s) and `q` (s×s, columns the eigenvectors)
/// keep their column correspondence; `theta` is not re-sorted. Leaves both
/// untouched when the inputs or the result are not finite.
pub(crate) fn refine_evd(t: MatRef<'_, f64>, theta: &mut [f64], q: &mut Mat<f64>) {
    let s = t.nrows();
    if s < 2 || q.nrows() != s || q.ncols() != s || theta.len() != s {
        return;
    }
    let threads = rayon::current_num_threads();
    let mut tq = Mat::<f64>::zeros(s, s);
    product(tq.as_mut(), t, q.as_ref(), Accum::Replace, threads);
    let mut sm = Mat::<f64>::zeros(s, s);
    product(
        sm.as_mut(),
        q.transpose(),
        tq.as_ref(),
        Accum::Replace,
        threads,
    );
    drop(tq);
    let mut gram = Mat::<f64>::zeros(s, s);
    product(
        gram.as_mut(),
        q.transpose(),
        q.as_ref(),
        Accum::Replace,
        threads,
    );
    // R = I − QᵀQ and S, both symmetrised.
    let r = Mat::from_fn(s, s, |i, j| {
        let g = 0.5 * (gram[(i, j)] + gram[(j, i)]);
        if i == j {
            1.0 - g
        } else {
            -g
        }
    });
    drop(gram);
    let sm = Mat::from_fn(s, s, |i, j| 0.5 * (sm[(i, j)] + sm[(j, i)]));
    let lam: Vec<f64> = (0..s).map(|i| sm[(i, i)] / (1.0 - r[(i, i)])).collect();
    if !lam.iter().all(|x| x.is_finite()) {
        return;
    }
    let norm_t = lam.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let (mut off_f, mut off_max, mut r_f) = (0.0f64, 0.0f64, 0.0f64);
    for j in 0..s {
        for i in 0..s {
            let x = if i == j {
                sm[(i, i)] - lam[i]
            } else {
                sm[(i, j)]
            };
            off_f += x * x;
            if i != j {
                off_max = off_max.max(x.abs());
            }
            r_f += r[(i, j)] * r[(i, j)];
        }
    }
    let delta = (2.0 * (off_f.sqrt() + norm_t * r_f.sqrt())).max(1e6 * off_max);
    // Clusters: runs of sorted λ̃ with consecutive gaps ≤ δ.
    let mut sorted: Vec<usize> = (0..s).collect();
    sorted.sort_by(|&a, &b| lam[a].total_cmp(&lam[b]));
    let mut cluster = vec![0usize; s];
    let mut clusters: Vec<Vec<usize>> = vec![vec![sorted[0]]];
    for w in sorted.windows(2) {
        if lam[w[1]] - lam[w[0]] > delta {
            clusters.push(Vec::new());
        }
        let c = clusters.len() - 1;
        clusters[c].push(w[1]);
        cluster[w[1]] = c;
    }
    let e = Mat::from_fn(s, s, |i, j| {
        if i == j || cluster[i] == cluster[j] {
            0.5 * r[(i, j)]
        } else {
            (sm[(i, j)] + lam[j] * r[(i, j)]) / (lam[j] - lam[i])
        }
    });
    let mut refined = q.clone();
    product(
        refined.as_mut(),
        q.as_ref(),
        e.as_ref(),
        Accum::Add,
        threads,
    );
    let mut new_theta = lam;
    // Each cluster of two or more: the exact eigenvectors of T in its subspace.
    for c in clusters.iter().filter(|c| c.len() > 1) {
        let g = c.len();
        let qc = Mat::from_fn(s, g, |i, j| refined[(i, c[j])]);
        let mut tqc = Mat::<f64>::zeros(s, g);
        matmul(tqc.as_mut(), Accum::Replace, t, qc.as_ref(), 1.0, Par::Seq);
        let sc = qc.transpose() * &tqc;
        let sc = Mat::from_fn(g, g, |i, j| 0.5 * (sc[(i, j)] + sc[(j, i)]));
        let Ok(evd) = sc.self_adjoint_eigen(Side::Lower) else {
            return;
        };
        let rotated = &qc * evd.U();
        for (j, &col) in c.iter().enumerate() {
            new_theta[col] = evd.S()[j];
            refined.col_mut(col).copy_from(rotated.col(j));
        }
    }
    if !(new_theta.iter().all(|x| x.is_finite())
        && (0..s).all(|j| refined.col(j).iter().all(|x| x.is_finite())))
    {
        return;
    }
    theta.copy_from_slice(&new_theta);
    *q = refined;
}

/// `out ← a b` (`Accum::Replace`) or `out ← out + a b` (`Accum::Add`), split by
/// columns of `b` ([`by_column_halves`]; each half a sequential faer product).
fn product(
    out: MatMut<'_, f64>,
    a: MatRef<'_, f64>,
    b: MatRef<'_, f64>,
    accum: Accum,
    threads: usize,
) {
    by_column_halves(out, b, threads, 64, &|out, b| {
        matmul(out, accum, a, b, 1.0, Par::Seq)
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A symmetric matrix with the given eigenvalues and a seeded orthogonal basis.
    fn with_spectrum(values: &[f64], seed: u64) -> (Mat<f64>, Mat<f64>) {
        let s = values.len();
        let mut x = Mat::<f64>::zeros(s, s);
        crate::spectral::krylov_schur::random_fill(x.as_mut(), seed);
        let qr = x.qr();
        let u = qr.compute_Q();
        let t =
            &u * Mat::from_fn(s, s, |i, j| if i == j { values[i] } else { 0.0 }) * u.transpose();
        let t = Mat::from_fn(s, s, |i, j| 0.5 * (t[(i, j)] + t[(j, i)]));
        (t, u)
    }

    fn worst_residual(t: &Mat<f64>, theta: &[f64], q: &Mat<f64>) -> f64 {
        let tq = t * q;
        (0..q.ncols())
            .map(|j| {
                (0..q.nrows())
                    .map(|i| (tq[(i, j)] - theta[j] * q[(i, j)]).powi(2))
                    .sum::<f64>()
                    .sqrt()
            })
            .fold(0.0, f64::max)
    }

    fn worst_orthogonality(q: &Mat<f64>) -> f64 {
        let g = q.transpose() * q;
        let mut w = 0.0f64;
        for j in 0..g.ncols() {
            for i in 0..g.nrows() {
                w = w.max((g[(i, j)] - if i == j { 1.0 } else { 0.0 }).abs());
            }
        }
        w
    }

    /// A thick-restart projected matrix: `diag(θ)` of the kept Ritz values, their
    /// coupling to the residual block, and a block-tridiagonal expansion (p = 8).
    fn thick_restart_matrix(kept: usize, blocks: usize, seed: u64) -> Mat<f64> {
        let p = 8;
        let s = kept + blocks * p;
        let mut rng = crate::rng::SplitMix64::new(seed);
        let mut t = Mat::<f64>::zeros(s, s);
        for i in 0..kept {
            t[(i, i)] = 3.8e-4 * (1e-3f64).powf(i as f64 / kept as f64);
        }
        for b in 0..blocks {
            let r0 = kept + b * p;
            for i in 0..p {
                for j in 0..=i {
                    let x = 1e-6 * (2.0 * rng.next_f64() - 1.0);
                    t[(r0 + i, r0 + j)] = x;
                    t[(r0 + j, r0 + i)] = x;
                }
                let (c0, width) = if b == 0 { (0, kept) } else { (r0 - p, p) };
                for j in c0..c0 + width {
                    let x = 1e-5 * (2.0 * rng.next_f64() - 1.0);
                    t[(r0 + i, j)] = x;
                    t[(j, r0 + i)] = x;
                }
            }
        }
        t
    }

    /// faer's eigenvectors of a thick-restart projected matrix (s = 338 … 498, the
    /// Krylov–Schur shape) have residuals of about 10⁻¹²·‖T‖ (3–5e-16 with ‖T‖ =
    /// 3.8e-4 when this was written; LAPACK's `dsyevd` gives 7e-16·‖T‖ on the bunny's
    /// matrix of this shape); refined, they are at rounding level.
    #[test]
    fn refinement_brings_thick_restart_eigenvectors_to_rounding_level() {
        for (kept, blocks) in [(290, 6), (290, 20), (290, 26)] {
            let t = thick_restart_matrix(kept, blocks, 3);
            let evd = t.self_adjoint_eigen(Side::Lower).unwrap();
            let mut q = evd.U().to_owned();
            let mut theta: Vec<f64> = (0..t.nrows()).map(|i| evd.S()[i]).collect();
            refine_evd(t.as_ref(), &mut theta, &mut q);
            let after = worst_residual(&t, &theta, &q);
            assert!(after < 1e-14 * 3.8e-4, "s = {}: {after:e}", t.nrows());
            assert!(worst_orthogonality(&q) < 1e-14);
        }
    }

    /// A perturbed decomposition (residual and orthogonality errors of 1e-10, far
    /// above rounding) comes back to rounding level, with a double eigenvalue and a
    /// spectrum spread over eight orders of magnitude like a shift-invert projection.
    #[test]
    fn refinement_restores_a_perturbed_decomposition() {
        let s = 120;
        let mut values: Vec<f64> = (0..s).map(|i| 1e-8 * 1.17f64.powi(i as i32)).collect();
        values[50] = values[51];
        let (t, u) = with_spectrum(&values, 11);
        let mut noise = Mat::<f64>::zeros(s, s);
        crate::spectral::krylov_schur::random_fill(noise.as_mut(), 12);
        let mut q = Mat::from_fn(s, s, |i, j| u[(i, j)] + 1e-10 * noise[(i, j)]);
        let mut theta: Vec<f64> = values.iter().map(|v| v * (1.0 + 1e-10)).collect();
        let before = worst_residual(&t, &theta, &q);
        let norm = values.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(
            before > 1e-11 * norm,
            "the perturbation is visible: {before:e}"
        );
        refine_evd(t.as_ref(), &mut theta, &mut q);
        let after = worst_residual(&t, &theta, &q);
        assert!(
            after < 1e-14 * norm,
            "residual {after:e} against ‖T‖ = {norm:e}"
        );
        assert!(
            worst_orthogonality(&q) < 1e-14,
            "{:e}",
            worst_orthogonality(&q)
        );
        let mut got = theta.clone();
        got.sort_by(f64::total_cmp);
        for (g, v) in got.iter().zip(&values) {
            assert!((g - v).abs() < 1e-14 * norm, "{g:e} vs {v:e}");
        }
    }

    /// On faer's own decomposition of a well-separated spectrum the refinement does
    /// not make the residual or the orthogonality worse.
    #[test]
    fn refinement_does_not_worsen_an_accurate_decomposition() {
        let s = 200;
        let values: Vec<f64> = (0..s).map(|i| 1e-9 + 1e-6 * (i as f64).powi(2)).collect();
        let (t, _) = with_spectrum(&values, 5);
        let evd = t.self_adjoint_eigen(Side::Lower).unwrap();
        let mut q = evd.U().to_owned();
        let mut theta: Vec<f64> = (0..s).map(|i| evd.S()[i]).collect();
        let before = worst_residual(&t, &theta, &q);
        refine_evd(t.as_ref(), &mut theta, &mut q);
        let after = worst_residual(&t, &theta, &q);
        assert!(
            after <= before.max(1e-15 * values[s - 1]),
            "{after:e} > {before:e}"
        );
        assert!(worst_orthogonality(&q) < 1e-14);
    }
}
