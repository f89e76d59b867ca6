//! Butterworth low-pass filter of order s and pass-band γ_PB (Zhang & Fiume 2003,
//! *Butterworth filtering and implicit fairing of irregular meshes*): response
//! `h(γ) = 1 / (1 + (γ/γ_PB)^{2s})` on the eigenvalues γ of F, applied as a cascade of
//! rational factors solved as sparse systems.
//!
//! Factoring over the 2s roots `r_k = e^{iθ_k}` of `r^{2s} = −1`, θ_k = π(2k+1)/(2s),
//! and pairing conjugate roots gives, with c = γ_PB,
//! `1 + (γ/c)^{2s} = Π_{k<s} (1 − 2cos θ_k γ/c + γ²/c²)`, so the filter is s solves
//! with `Q_k = I − (2cos θ_k/c)F + F²/c²`. As a polynomial in γ each factor is
//! `(γ/c − cos θ_k)² + sin² θ_k > 0`, so for symmetric positive semi-definite F every
//! `Q_k` is SPD: sparse Cholesky, one symbolic analysis for all k (the pattern of F²
//! is shared). A non-symmetric F (TL) is solved with sparse LU, again reusing the
//! symbolic analysis.
//!
//! F is n×n with the sign `F = D − W`; positions are the n×3 row-major block.

use super::{ButterworthOptions, Filter, FilterError};
use crate::solve::{
    relative_residuals, CholeskySolver, CsrMatrix, DirectError, DirectInfo, Info, LuSolver,
    SolveInfo,
};
use crate::SparseMatrix;

/// The analytic response `1 / (1 + (γ/γ_PB)^{2s})`.
pub fn butterworth_response(order: usize, passband: f64, gamma: f64) -> f64 {
    1.0 / (1.0 + (gamma / passband).powi(2 * order as i32))
}

/// The factorization of every factor `Q_k`: Cholesky for a symmetric F, LU otherwise,
/// analyzed once and refactored numerically for each k.
enum Factor {
    Cholesky(CholeskySolver),
    Lu(Box<LuSolver>),
}

impl Factor {
    fn new(q: &SparseMatrix, symmetric: bool) -> Result<Self, DirectError> {
        Ok(if symmetric {
            Factor::Cholesky(CholeskySolver::new(q)?)
        } else {
            Factor::Lu(Box::new(LuSolver::new(q)?))
        })
    }
    fn refactor(&mut self, q: &SparseMatrix) -> Result<(), DirectError> {
        match self {
            Factor::Cholesky(s) => s.refactor(q),
            Factor::Lu(s) => s.refactor(q),
        }
    }
    fn solve_in_place(&self, x: &mut [f64]) -> Result<DirectInfo, DirectError> {
        match self {
            Factor::Cholesky(s) => s.solve_in_place(x, 3),
            Factor::Lu(s) => s.solve_in_place(x, 3),
        }
    }
}

/// Applies the Butterworth filter `opts` with the n×n operator `f` (`F = D − W`) to
/// the n×3 row-major `x` in place; returns the record of each factor's solve (its
/// relative residual and factorization).
pub fn butterworth(
    f: &SparseMatrix,
    x: &mut [f64],
    opts: &ButterworthOptions,
) -> Result<Vec<SolveInfo>, FilterError> {
    Filter::Butterworth(*opts).validate()?;
    let (order, c) = (opts.order, opts.passband);
    if x.len() != 3 * f.nrows() || f.nrows() != f.ncols() {
        return Err(FilterError::Positions {
            len: x.len(),
            n: f.nrows(),
        });
    }
    let a = CsrMatrix::from_csc(f);
    let a2 = a.matmul(&a);
    let symmetric = super::implicit::is_symmetric(f);
    let ones = vec![1.0; f.nrows()];
    let mut factor: Option<Factor> = None;
    let mut infos = Vec::with_capacity(order);
    let solve_error = |e: DirectError| FilterError::Solve(e.into());
    for k in 0..order {
        let theta = std::f64::consts::PI * (2 * k + 1) as f64 / (2 * order) as f64;
        // Q = I − (2cos θ/c) F + F²/c²
        let q = a2
            .add(1.0 / (c * c), &a, -2.0 * theta.cos() / c)
            .shifted(&ones, 1.0);
        let qc = q.to_csc();
        let solver = match factor.take() {
            Some(mut s) => {
                s.refactor(&qc).map_err(solve_error)?;
                s
            }
            None => Factor::new(&qc, symmetric).map_err(solve_error)?,
        };
        let b = x.to_vec();
        let factorization = solver.solve_in_place(x).map_err(solve_error)?;
        infos.push(SolveInfo::Direct {
            info: Info {
                iterations: vec![0; 3],
                residuals: relative_residuals(&q, x, &b, 3)
                    .map_err(|e| FilterError::Solve(e.into()))?,
                history: vec![Vec::new(); 3],
                seconds: factorization.solve_seconds,
            },
            factorization,
        });
        factor = Some(solver);
    }
    Ok(infos)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{builtin, topology::Topology};
    use crate::operator::{sql::sql, tutte::tutte};

    #[test]
    fn response_on_the_ed_basis_matches_the_analytic_filter() {
        let m = builtin::icosphere(2).unwrap();
        let t = Topology::new(&m).unwrap();
        let f = sql(&t, Default::default()).unwrap();
        let evd = f.to_dense().self_adjoint_eigen(faer::Side::Lower).unwrap();
        let n = m.n_vertices();
        for (order, pb) in [(1usize, 0.4), (3, 0.4), (4, 1.5)] {
            for idx in [1usize, 20, 60, n / 2, n - 1] {
                let gamma = evd.S()[idx];
                // a different eigenvector in each column
                let cols = [idx, (idx + 7) % n, (idx + 31) % n];
                let mut x: Vec<f64> = (0..n).flat_map(|i| cols.map(|c| evd.U()[(i, c)])).collect();
                let x0 = x.clone();
                butterworth(
                    &f,
                    &mut x,
                    &ButterworthOptions {
                        order,
                        passband: pb,
                    },
                )
                .unwrap();
                for (c, &col) in cols.iter().enumerate() {
                    let h = butterworth_response(order, pb, evd.S()[col]);
                    for i in 0..n {
                        let d = (x[3 * i + c] - h * x0[3 * i + c]).abs();
                        assert!(d < 1e-10, "s={order} γ={gamma}: {d}");
                    }
                }
            }
        }
    }

    #[test]
    fn response_of_the_non_symmetric_tutte_laplacian_through_lu() {
        // T = D^{-1/2} G D^{1/2}: right eigenvectors v = D^{-1/2} u of the graph Laplacian.
        let m = builtin::icosphere(1).unwrap();
        let t = Topology::new(&m).unwrap();
        let f = tutte(&t).unwrap();
        let g = crate::operator::graph::graph(&t).unwrap();
        let evd = g.to_dense().self_adjoint_eigen(faer::Side::Lower).unwrap();
        let d: Vec<f64> = t.degrees().iter().map(|&v| v as f64).collect();
        let n = m.n_vertices();
        let (order, pb) = (2usize, 0.7);
        for idx in [1usize, n / 3, n - 1] {
            let v: Vec<f64> = (0..n).map(|i| evd.U()[(i, idx)] / d[i].sqrt()).collect();
            let mut x: Vec<f64> = v.iter().flat_map(|&a| [a, 2.0 * a, -a]).collect();
            let x0 = x.clone();
            let opts = ButterworthOptions {
                order,
                passband: pb,
            };
            butterworth(&f, &mut x, &opts).unwrap();
            let h = butterworth_response(order, pb, evd.S()[idx]);
            for j in 0..3 * n {
                assert!((x[j] - h * x0[j]).abs() < 1e-10);
            }
        }
    }

    #[test]
    fn bad_parameters_are_errors() {
        let m = builtin::icosahedron();
        let t = Topology::new(&m).unwrap();
        let f = tutte(&t).unwrap();
        let mut x = vec![1.0; 36];
        let opts = |order, passband| ButterworthOptions { order, passband };
        assert!(matches!(
            butterworth(&f, &mut x, &opts(0, 0.5)),
            Err(FilterError::ZeroOrder)
        ));
        assert!(matches!(
            butterworth(&f, &mut x, &opts(2, -0.5)),
            Err(FilterError::NotPositive { .. })
        ));
        assert!(butterworth(&f, &mut x, &opts(2, f64::INFINITY)).is_err());
        let mut short = vec![1.0; 35];
        assert!(matches!(
            butterworth(&f, &mut short, &opts(2, 0.5)),
            Err(FilterError::Positions { .. })
        ));
        // One record per factor, each with its factorization.
        let infos = butterworth(&f, &mut x, &opts(3, 0.5)).unwrap();
        assert_eq!(infos.len(), 3);
        assert!(infos.iter().all(|i| i.factorization().is_some()));
    }
}
