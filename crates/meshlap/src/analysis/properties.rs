//! Matrix-theoretic properties of an operator, measured on the matrix (Zhang 2004 §2).
//!
//! Nothing here is assumed from the operator's kind: symmetry is `max |F − Fᵀ|`,
//! weights are read off the entries (`W_ij = −F_ij`, sign convention `F = D − W`),
//! irreducibility is the connectivity of the nonzero pattern, and the spectrum is
//! computed. For a non-symmetric F the report first looks for a positive diagonal
//! `S` with `S·F` symmetric (the Tutte Laplacian, `T²` and the SDL have one: `S = D`
//! or the weight sums); then `S^{1/2} F S^{-1/2}` is symmetric and similar to F, so
//! its spectrum is real and is computed with the symmetric eigensolver. Otherwise the
//! general (complex) dense eigensolver is used on small matrices.
//!
//! Above [`PropertyOptions::dense_limit`] a symmetric or symmetrizable operator's
//! λ_min (shift-invert), λ_max (Krylov–Schur) and zero multiplicity (Sylvester's
//! inertia) are computed by [`crate::spectral::extremes`], so the report is complete
//! at any n; only a large operator that is neither symmetric nor symmetrizable has its
//! spectral lines skipped (the general dense eigensolver is O(n³)).
//!
//! The smoothing matrix is `H = I − F/k` with the smallest admissible
//! `k = max(λ_max/2, max_i F_ii)`: `k ≥ λ_max/2` makes H smoothing when F is a GSML
//! (§2.5) and `k ≥ max F_ii` keeps H's diagonal nonnegative (§3.7, `k ≥ max D`).

use crate::mesh::topology::UnionFind;
pub use crate::operator::symmetrize::{asymmetry, diagonal_symmetrizer, entry};
use crate::operator::symmetrize::{symmetric_product, symmetrized_dense, Scaling};
use crate::SparseMatrix;
use faer::Side;
use serde::Serialize;

/// Options of [`analyze`].
#[derive(Clone, Copy, Debug)]
pub struct PropertyOptions {
    /// Largest n for which the full spectrum of a symmetric (or symmetrizable)
    /// operator is computed densely; above it λ_min, λ_max and the multiplicity of
    /// the zero eigenvalue come from the sparse solvers
    /// ([`crate::spectral::extremes`]).
    pub dense_limit: usize,
    /// Largest n for the general (non-symmetric) dense eigensolver.
    pub nonsymmetric_dense_limit: usize,
    /// Relative tolerance for "zero" row sums, symmetry and stochasticity.
    pub tolerance: f64,
}

impl Default for PropertyOptions {
    fn default() -> Self {
        Self {
            dense_limit: 5000,
            nonsymmetric_dense_limit: 2500,
            tolerance: 1e-10,
        }
    }
}

/// The most negative weight `W_ij = −F_ij` and where it is.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct WeightAt {
    /// The weight `W_ij`.
    pub weight: f64,
    /// Row.
    pub i: usize,
    /// Column.
    pub j: usize,
}

/// Properties of the smoothing matrix `H = I − F/k`.
#[derive(Clone, Debug, Serialize)]
pub struct SmoothingReport {
    /// The k used: `max(λ_max/2, max F_ii)` (Gershgorin's bound replaces λ_max when
    /// the spectrum was not computed).
    pub k: f64,
    /// All entries of H are ≥ 0.
    pub nonnegative: bool,
    /// H is nonnegative with unit row sums.
    pub row_stochastic: bool,
    /// H is nonnegative with unit row and column sums.
    pub doubly_stochastic: bool,
    /// Estimated `‖P H P‖₂` (P the centring projector), by power iteration: the
    /// largest factor by which one application of H can multiply the variance's
    /// square root. ≤ 1 means variance diminishing; `None` when H has no unit row sum
    /// (then constant meshes gain variance).
    pub variance_gain: Option<f64>,
    /// `variance_gain ≤ 1` (within tolerance).
    pub variance_diminishing: bool,
}

/// Status as a generalized shrinking mesh Laplacian (§2.5).
#[derive(Clone, Debug, Serialize)]
pub struct GsmlStatus {
    /// All conditions hold.
    pub is_gsml: bool,
    /// Constant zero row sum.
    pub zero_row_sum: bool,
    /// Real spectrum (`None`: spectrum not computed).
    pub real_spectrum: Option<bool>,
    /// The smallest eigenvalue is 0 and simple (`None`: spectrum not computed).
    pub simple_zero_eigenvalue: Option<bool>,
    /// Names of the conditions that fail or could not be checked.
    pub failing: Vec<String>,
}

/// Everything `meshlap operator` reports.
#[derive(Clone, Debug, Serialize)]
pub struct PropertyReport {
    /// Matrix size.
    pub n: usize,
    /// Stored nonzeros.
    pub nnz: usize,
    /// `max |F − Fᵀ|` ≤ tolerance.
    pub symmetric: bool,
    /// `max |F_ij − F_ji|`.
    pub max_asymmetry: f64,
    /// Undirected vertex pairs with a negative weight in either direction.
    pub negative_weights: usize,
    /// The most negative weight, if any.
    pub most_negative_weight: Option<WeightAt>,
    /// The nonzero pattern is connected.
    pub irreducible: bool,
    /// Connected components of the nonzero pattern.
    pub pattern_components: usize,
    /// `max_i |Σ_j F_ij|`.
    pub max_abs_row_sum: f64,
    /// Smallest column sum.
    pub column_sum_min: f64,
    /// Largest column sum.
    pub column_sum_max: f64,
    /// How the spectrum was computed (`dense-symmetric`, `dense-symmetrized`,
    /// `dense-general`, `sparse-symmetric …`, `sparse-symmetrized …`), or why it was
    /// not.
    pub spectrum_method: String,
    /// Smallest eigenvalue (real part).
    pub lambda_min: Option<f64>,
    /// Largest eigenvalue (real part).
    pub lambda_max: Option<f64>,
    /// Largest |imaginary part| among the eigenvalues.
    pub max_imaginary_part: Option<f64>,
    /// Number of eigenvalues with |λ| ≤ 1e-8·max(1, λ_max).
    pub zero_eigenvalue_multiplicity: Option<usize>,
    /// Smallest eigenvalue ≥ −1e-8·max(1, λ_max).
    pub positive_semidefinite: Option<bool>,
    /// Gershgorin upper bound `max_i (F_ii + Σ_{j≠i} |F_ij|)`.
    pub gershgorin_max: f64,
    /// Gershgorin lower bound `min_i (F_ii − Σ_{j≠i} |F_ij|)`.
    pub gershgorin_min: f64,
    /// The computed spectrum lies within the Gershgorin bounds.
    pub gershgorin_holds: Option<bool>,
    /// The smoothing matrix `H = I − F/k`.
    pub smoothing: SmoothingReport,
    /// GSML status with the failing condition named.
    pub gsml: GsmlStatus,
    /// The eigenvalues, ascending by real part (present when computed).
    #[serde(skip)]
    pub eigenvalues: Option<Vec<f64>>,
}

/// Measures the properties of `f`; see the module documentation.
pub fn analyze(f: &SparseMatrix, opts: &PropertyOptions) -> PropertyReport {
    let n = f.nrows();
    let tol = opts.tolerance;
    let mut row_sum = vec![0.0f64; n];
    let mut col_sum = vec![0.0f64; n];
    let mut diag = vec![0.0f64; n];
    let mut off_abs = vec![0.0f64; n];
    let mut uf = UnionFind::new(n);
    let mut most_negative: Option<WeightAt> = None;
    let mut neg_pairs = std::collections::BTreeSet::new();
    let mut scale = 0.0f64;
    for j in 0..n {
        for (&i, &v) in f.row_idx_of_col_raw(j).iter().zip(f.val_of_col(j)) {
            row_sum[i] += v;
            col_sum[j] += v;
            scale = scale.max(v.abs());
            if i == j {
                diag[i] += v;
            } else {
                off_abs[i] += v.abs();
                if v != 0.0 {
                    uf.union(i, j);
                }
                let w = -v;
                if w < 0.0 {
                    neg_pairs.insert((i.min(j), i.max(j)));
                    if most_negative.as_ref().is_none_or(|m| w < m.weight) {
                        most_negative = Some(WeightAt { weight: w, i, j });
                    }
                }
            }
        }
    }
    let scale = scale.max(f64::MIN_POSITIVE);
    let pattern_components = (0..n).filter(|&v| uf.find(v) == v).count();
    let max_asymmetry = asymmetry(f);
    let symmetric = max_asymmetry <= tol * scale;
    let max_abs_row_sum = row_sum.iter().fold(0.0f64, |a, &b| a.max(b.abs()));
    let zero_row_sum = max_abs_row_sum <= tol * scale;
    let gershgorin_max = (0..n)
        .map(|i| diag[i] + off_abs[i])
        .fold(f64::MIN, f64::max);
    let gershgorin_min = (0..n)
        .map(|i| diag[i] - off_abs[i])
        .fold(f64::MAX, f64::min);

    // Spectrum.
    let sp = spectrum(f, symmetric, gershgorin_min, opts);
    let (spectrum_method, eigenvalues, max_imag) = (sp.method, sp.eigenvalues, sp.max_imag);
    let (lambda_min, lambda_max) = (sp.lambda_min, sp.lambda_max);
    let ztol = 1e-8 * lambda_max.unwrap_or(1.0).abs().max(1.0);
    let zero_mult = sp.zero_multiplicity;
    let psd = lambda_min.map(|l| l >= -ztol);
    let real_spectrum = max_imag.map(|m| m <= 1e-8 * scale);
    let gershgorin_holds = lambda_min
        .zip(lambda_max)
        .map(|(lo, hi)| lo >= gershgorin_min - 1e-9 * scale && hi <= gershgorin_max + 1e-9 * scale);

    // Smoothing matrix.
    let max_diag = diag.iter().copied().fold(f64::MIN, f64::max);
    let lmax_for_k = lambda_max.unwrap_or(gershgorin_max);
    let k = (lmax_for_k / 2.0).max(max_diag).max(f64::MIN_POSITIVE);
    let mut nonnegative = true;
    for j in 0..n {
        for (&i, &v) in f.row_idx_of_col_raw(j).iter().zip(f.val_of_col(j)) {
            let h = if i == j { 1.0 - v / k } else { -v / k };
            if h < -tol {
                nonnegative = false;
            }
        }
    }
    let unit_rows = row_sum
        .iter()
        .all(|s| (s / k).abs() <= tol * scale / k + tol);
    let unit_cols = col_sum
        .iter()
        .all(|s| (s / k).abs() <= tol * scale / k + tol);
    let variance_gain = unit_rows
        .then(|| centred_norm_estimate(f, k, 300))
        .flatten();
    let smoothing = SmoothingReport {
        k,
        nonnegative,
        row_stochastic: nonnegative && unit_rows,
        doubly_stochastic: nonnegative && unit_rows && unit_cols,
        variance_diminishing: variance_gain.is_some_and(|g| g <= 1.0 + 1e-6),
        variance_gain,
    };

    let simple_zero = lambda_min
        .zip(zero_mult)
        .map(|(lmin, m)| lmin >= -ztol && m == 1);
    let mut failing = Vec::new();
    if !zero_row_sum {
        failing.push("zero row sum".to_string());
    }
    match real_spectrum {
        Some(false) => failing.push("real spectrum".into()),
        None => failing.push("real spectrum (not computed)".into()),
        _ => {}
    }
    match simple_zero {
        Some(false) => failing.push("simple zero eigenvalue".into()),
        None => failing.push("simple zero eigenvalue (not computed)".into()),
        _ => {}
    }
    let gsml = GsmlStatus {
        is_gsml: failing.is_empty(),
        zero_row_sum,
        real_spectrum,
        simple_zero_eigenvalue: simple_zero,
        failing,
    };
    PropertyReport {
        n,
        nnz: f.compute_nnz(),
        symmetric,
        max_asymmetry,
        negative_weights: neg_pairs.len(),
        most_negative_weight: most_negative,
        irreducible: pattern_components <= 1,
        pattern_components,
        max_abs_row_sum,
        column_sum_min: col_sum.iter().copied().fold(f64::MAX, f64::min),
        column_sum_max: col_sum.iter().copied().fold(f64::MIN, f64::max),
        spectrum_method,
        lambda_min,
        lambda_max,
        max_imaginary_part: max_imag,
        zero_eigenvalue_multiplicity: zero_mult,
        positive_semidefinite: psd,
        gershgorin_max,
        gershgorin_min,
        gershgorin_holds,
        smoothing,
        gsml,
        eigenvalues,
    }
}

/// The spectrum as far as the report needs it.
struct Spectrum {
    method: String,
    eigenvalues: Option<Vec<f64>>,
    lambda_min: Option<f64>,
    lambda_max: Option<f64>,
    zero_multiplicity: Option<usize>,
    max_imag: Option<f64>,
}

impl Spectrum {
    fn failed(method: String) -> Self {
        Self {
            method,
            eigenvalues: None,
            lambda_min: None,
            lambda_max: None,
            zero_multiplicity: None,
            max_imag: None,
        }
    }

    /// From a full spectrum (ascending real parts).
    fn dense(method: &str, ev: Vec<f64>, max_imag: f64) -> Self {
        let lambda_min = ev.first().copied();
        let lambda_max = ev.last().copied();
        let ztol = 1e-8 * lambda_max.unwrap_or(1.0).abs().max(1.0);
        Self {
            method: method.into(),
            zero_multiplicity: Some(ev.iter().filter(|x| x.abs() <= ztol).count()),
            lambda_min,
            lambda_max,
            eigenvalues: Some(ev),
            max_imag: Some(max_imag),
        }
    }

    /// Above the dense limit: the extremes and the zero multiplicity by the sparse
    /// solvers ([`crate::spectral::extremes`]).
    fn sparse(method: &str, k: &SparseMatrix, mass: Option<&[f64]>, lower: f64) -> Self {
        match crate::spectral::extremes::extremes(k, mass, lower) {
            Ok(e) => Self {
                method: method.into(),
                eigenvalues: None,
                lambda_min: Some(e.lambda_min),
                lambda_max: Some(e.lambda_max),
                zero_multiplicity: Some(e.zero_multiplicity),
                max_imag: Some(0.0),
            },
            Err(e) => Self::failed(format!("failed: {e}")),
        }
    }
}

fn spectrum(f: &SparseMatrix, symmetric: bool, lower: f64, opts: &PropertyOptions) -> Spectrum {
    let n = f.nrows();
    if symmetric {
        if n > opts.dense_limit {
            return Spectrum::sparse("sparse-symmetric (Krylov–Schur, inertia)", f, None, lower);
        }
        return match f.to_dense().self_adjoint_eigenvalues(Side::Lower) {
            Ok(ev) => Spectrum::dense("dense-symmetric", ev, 0.0),
            Err(_) => Spectrum::failed("failed: the dense eigensolver did not converge".into()),
        };
    }
    if let Some(s) = diagonal_symmetrizer(f) {
        if n > opts.dense_limit {
            return match symmetric_product(f, &s) {
                Ok(k) => Spectrum::sparse(
                    "sparse-symmetrized (Krylov–Schur, inertia)",
                    &k,
                    Some(&s),
                    lower,
                ),
                Err(e) => Spectrum::failed(format!("failed: {e}")),
            };
        }
        let d = symmetrized_dense(f, Scaling::Similarity(&s));
        return match d.self_adjoint_eigenvalues(Side::Lower) {
            Ok(ev) => Spectrum::dense("dense-symmetrized", ev, 0.0),
            Err(_) => Spectrum::failed("failed: the dense eigensolver did not converge".into()),
        };
    }
    if n > opts.nonsymmetric_dense_limit {
        return Spectrum::failed(format!(
            "skipped: neither symmetric nor symmetrizable, and n = {n} > the general dense limit {}",
            opts.nonsymmetric_dense_limit
        ));
    }
    match f.to_dense().eigenvalues() {
        Ok(ev) => {
            let max_imag = ev.iter().map(|c| c.im.abs()).fold(0.0, f64::max);
            let mut re: Vec<f64> = ev.iter().map(|c| c.re).collect();
            re.sort_by(f64::total_cmp);
            Spectrum::dense("dense-general", re, max_imag)
        }
        Err(_) => Spectrum::failed("failed: the dense eigensolver did not converge".into()),
    }
}

/// Power-iteration estimate of `‖P H P‖₂`, `H = I − F/k`, `P = I − 11ᵀ/n`.
///
/// `H x` and `Hᵀ x` are computed row by row in parallel (rows of `F` from a
/// transposed copy, rows of `Fᵀ` from `F`'s columns), each row summed in ascending
/// column order: the same bits as the serial column-wise scatter, on any pool.
fn centred_norm_estimate(f: &SparseMatrix, k: f64, iters: usize) -> Option<f64> {
    use rayon::prelude::*;
    let n = f.nrows();
    // Column i of `by_rows` is row i of F.
    let by_rows: SparseMatrix = f.as_ref().transpose().to_col_major().ok()?;
    // y_i = x_i − Σ_r (m_ri / k) x_r over column i of `m`, rows ascending.
    let apply = |m: &SparseMatrix, x: &[f64]| -> Vec<f64> {
        const ROWS: usize = 4096;
        let mut y = vec![0.0; n];
        y.par_chunks_mut(ROWS).enumerate().for_each(|(c, ys)| {
            for (q, yi) in ys.iter_mut().enumerate() {
                let i = c * ROWS + q;
                let mut acc = x[i];
                for (&r, &v) in m.row_idx_of_col_raw(i).iter().zip(m.val_of_col(i)) {
                    acc -= v / k * x[r];
                }
                *yi = acc;
            }
        });
        y
    };
    let apply_h = |x: &[f64], transpose: bool| -> Vec<f64> {
        if transpose {
            apply(f, x)
        } else {
            apply(&by_rows, x)
        }
    };
    Some(centred_power_iteration(n, iters, apply_h))
}

/// `‖P H P‖₂` by `iters` steps of the power iteration on `(PHP)ᵀ(PHP)` from a fixed
/// start, with `apply_h(x, transpose)` = `H x` or `Hᵀ x` (length n each).
fn centred_power_iteration(
    n: usize,
    iters: usize,
    apply_h: impl Fn(&[f64], bool) -> Vec<f64>,
) -> f64 {
    let centre = |x: &mut [f64]| {
        let m = x.iter().sum::<f64>() / n as f64;
        x.iter_mut().for_each(|v| *v -= m);
    };
    // Deterministic, non-special start vector.
    let mut x: Vec<f64> = (0..n)
        .map(|i| ((i as f64 + 1.0) * 0.618_033_988_75).fract() - 0.5)
        .collect();
    centre(&mut x);
    let mut sigma = 0.0;
    for _ in 0..iters {
        let nx = x.iter().map(|v| v * v).sum::<f64>().sqrt();
        if nx == 0.0 {
            return 0.0;
        }
        x.iter_mut().for_each(|v| *v /= nx);
        let mut y = apply_h(&x, false);
        centre(&mut y);
        sigma = y.iter().map(|v| v * v).sum::<f64>().sqrt();
        let mut z = apply_h(&y, true);
        centre(&mut z);
        x = z;
    }
    sigma
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{builtin, topology::Topology};
    use crate::operator::{Operator, OperatorKind, OperatorOptions};

    /// The serial column-wise definition of [`centred_norm_estimate`] (before its
    /// products were parallel): `H x` scattered column by column.
    fn centred_norm_serial(f: &SparseMatrix, k: f64, iters: usize) -> f64 {
        let n = f.nrows();
        centred_power_iteration(n, iters, |x: &[f64], transpose: bool| {
            let mut y = x.to_vec();
            for j in 0..n {
                for (&i, &v) in f.row_idx_of_col_raw(j).iter().zip(f.val_of_col(j)) {
                    if transpose {
                        y[j] -= v / k * x[i];
                    } else {
                        y[i] -= v / k * x[j];
                    }
                }
            }
            y
        })
    }

    /// The parallel row-wise products give the serial scatter's bits on any pool, for a
    /// non-symmetric operator (the TL) and a symmetric one.
    #[test]
    fn centred_norm_estimate_matches_the_serial_definition() {
        // Degrees 5 and 6: the TL is not symmetric.
        let mesh = builtin::icosphere(3).unwrap();
        let topo = Topology::new(&mesh).unwrap();
        for kind in [OperatorKind::Tutte, OperatorKind::Sql] {
            let op = Operator::assemble(kind, &mesh, &topo, &OperatorOptions::default()).unwrap();
            let want = centred_norm_serial(&op.matrix, 1.0, 40);
            for threads in [1, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let got = pool
                    .install(|| centred_norm_estimate(&op.matrix, 1.0, 40))
                    .unwrap();
                assert_eq!(got.to_bits(), want.to_bits(), "{kind}, {threads} threads");
            }
        }
    }

    fn report(kind: OperatorKind, m: &crate::TriMesh) -> PropertyReport {
        let t = Topology::new(m).unwrap();
        let op = Operator::assemble(kind, m, &t, &OperatorOptions::default()).unwrap();
        analyze(&op.matrix, &PropertyOptions::default())
    }

    #[test]
    fn kirchhoff_is_a_gsml_with_the_paper_properties() {
        let m = builtin::icosphere(2).unwrap();
        let r = report(OperatorKind::Kirchhoff, &m);
        assert!(
            r.symmetric && r.irreducible && r.gsml.is_gsml,
            "{:?}",
            r.gsml
        );
        assert_eq!(r.negative_weights, 0);
        assert_eq!(r.zero_eigenvalue_multiplicity, Some(1));
        assert_eq!(r.gershgorin_holds, Some(true));
        assert!(r.smoothing.doubly_stochastic && r.smoothing.variance_diminishing);
        assert!(r.lambda_max.unwrap() <= 2.0 * 6.0);
    }

    #[test]
    fn graph_laplacian_is_not_a_gsml() {
        let r = report(OperatorKind::Graph, &builtin::cube(3).unwrap());
        assert!(!r.gsml.is_gsml);
        assert_eq!(r.gsml.failing, vec!["zero row sum".to_string()]);
        assert_eq!(r.zero_eigenvalue_multiplicity, Some(1));
    }

    #[test]
    fn tutte_is_symmetrizable_row_stochastic_not_doubly() {
        let m = builtin::cube(3).unwrap();
        let r = report(OperatorKind::Tutte, &m);
        assert!(!r.symmetric);
        assert_eq!(r.spectrum_method, "dense-symmetrized");
        assert!(r.gsml.is_gsml, "{:?}", r.gsml);
        assert!(r.smoothing.row_stochastic && !r.smoothing.doubly_stochastic);
        // Cross-check the symmetrized spectrum with the general eigensolver.
        let t = Topology::new(&m).unwrap();
        let op = crate::operator::tutte::tutte(&t).unwrap();
        let mut general: Vec<f64> = op
            .to_dense()
            .eigenvalues()
            .unwrap()
            .iter()
            .map(|c| c.re)
            .collect();
        general.sort_by(f64::total_cmp);
        for (a, b) in general.iter().zip(r.eigenvalues.as_ref().unwrap()) {
            assert!((a - b).abs() < 1e-9);
        }
    }

    #[test]
    fn mean_value_uses_the_general_solver() {
        let mut m = builtin::icosphere(1).unwrap();
        m.positions[0][0] *= 1.3; // break the symmetry of the weights
        let r = report(OperatorKind::MeanValue, &m);
        assert_eq!(r.spectrum_method, "dense-general");
        assert!(r.max_abs_row_sum < 1e-12);
    }

    #[test]
    fn zero_multiplicity_counts_components() {
        // Two disjoint tetrahedra.
        let a = builtin::tetrahedron();
        let mut m = a.clone();
        m.positions
            .extend(a.positions.iter().map(|p| [p[0] + 5.0, p[1], p[2]]));
        m.faces.extend(a.faces.iter().map(|f| f.map(|v| v + 4)));
        let r = report(OperatorKind::Kirchhoff, &m);
        assert_eq!(r.zero_eigenvalue_multiplicity, Some(2));
        assert!(!r.irreducible);
        assert_eq!(r.gsml.failing, vec!["simple zero eigenvalue".to_string()]);
    }

    #[test]
    fn sql_negative_weight_is_found_with_its_edge() {
        // A vertex of degree 3 next to high-degree vertices gives a negative weight.
        let m = builtin::cube(1).unwrap();
        let t = Topology::new(&m).unwrap();
        let d: Vec<f64> = t.degrees().iter().map(|&x| x as f64).collect();
        let w = crate::operator::sql::sql_edge_weights(&t, &d).unwrap();
        let negatives = w.iter().filter(|&&x| x < 0.0).count();
        let r = report(OperatorKind::Sql, &m);
        assert_eq!(r.negative_weights, negatives);
        if let Some(at) = r.most_negative_weight {
            let e = t.find_edge(crate::VertexId(at.i as u32), crate::VertexId(at.j as u32));
            assert!((w[e.unwrap().idx()] - at.weight).abs() < 1e-15);
        }
    }
}
