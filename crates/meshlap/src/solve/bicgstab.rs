//! BiCGSTAB (van der Vorst 1992) through faer's `matrix_free::bicgstab`, as a further
//! reference for the non-symmetric Tutte system. Stops on the relative residual
//! (the strong criterion); all columns are solved in one call.

use super::{relative_residuals, Info, LinearOperator, Params, SolveError, SparseOperator};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::matrix_free::bicgstab::{
    bicgstab as faer_bicgstab, bicgstab_scratch, BicgError, BicgParams,
};
use faer::matrix_free::{IdentityPrecond, InitialGuessStatus};
use faer::{Mat, Par};
use std::time::Instant;

/// Solves `A x = b` (A given as a faer CSC matrix) for the n×k row-major block `b`,
/// starting from `x`, with faer's BiCGSTAB and the tolerance of `params`.
pub fn bicgstab(
    a: &crate::SparseMatrix,
    b: &[f64],
    x: &mut [f64],
    k: usize,
    params: &Params,
) -> Result<Info, SolveError> {
    let n = a.nrows();
    let op = SparseOperator::new(a, false);
    super::check_dims(&op, b, k)?;
    let start = Instant::now();
    let rhs = Mat::from_fn(n, k, |i, c| b[i * k + c]);
    let mut out = Mat::from_fn(n, k, |i, c| x[i * k + c]);
    let par = Par::rayon(0);
    let id = IdentityPrecond { dim: n };
    let mut mem = MemBuffer::new(bicgstab_scratch::<f64>(id, id, a.as_ref(), k, par));
    let fp = BicgParams {
        initial_guess: InitialGuessStatus::MaybeNonZero,
        abs_tolerance: 0.0,
        rel_tolerance: params.tolerance,
        max_iters: params.max_iterations,
        ..Default::default()
    };
    let result = faer_bicgstab(
        out.as_mut(),
        id,
        id,
        a.as_ref(),
        rhs.as_ref(),
        fp,
        |_| {},
        par,
        MemStack::new(&mut mem),
    );
    for i in 0..n {
        for c in 0..k {
            x[i * k + c] = out[(i, c)];
        }
    }
    let mut info = Info {
        residuals: relative_residuals(&op as &dyn LinearOperator, x, b, k),
        seconds: start.elapsed().as_secs_f64(),
        plateau_at: vec![None; k],
        ..Default::default()
    };
    match result {
        Ok(i) => {
            info.iterations = vec![i.iter_count; k];
            Ok(info)
        }
        Err(BicgError::NoConvergence { .. }) => {
            info.iterations = vec![params.max_iterations; k];
            Err(SolveError::NoConvergence {
                info: Box::new(info),
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solve::{direct::LuSolver, shifted_system, test_util::*};

    #[test]
    fn agrees_with_lu() {
        let (m, tl, ..) = irregular(3);
        let a = shifted_system(&tl, None, 30.0).to_csc();
        let b = flat(&m);
        let mut want = b.clone();
        LuSolver::new(&a)
            .unwrap()
            .solve_in_place(&mut want, 3)
            .unwrap();
        let mut x = b.clone();
        let p = Params {
            tolerance: 1e-11,
            ..Default::default()
        };
        let info = bicgstab(&a, &b, &mut x, 3, &p).unwrap();
        assert!(
            info.residuals.iter().all(|&r| r < 1e-9),
            "{:?}",
            info.residuals
        );
        let err = x
            .iter()
            .zip(&want)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-8);
    }

    #[test]
    fn iteration_cap_is_no_convergence() {
        let (m, tl, ..) = irregular(3);
        let a = shifted_system(&tl, None, 100.0).to_csc();
        let b = flat(&m);
        let mut x = vec![0.0; b.len()];
        let p = Params {
            tolerance: 1e-14,
            max_iterations: 2,
            ..Default::default()
        };
        assert!(matches!(
            bicgstab(&a, &b, &mut x, 3, &p),
            Err(SolveError::NoConvergence { .. })
        ));
    }
}
