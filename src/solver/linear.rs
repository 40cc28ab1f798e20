//! Direct linear solvers: least squares and the homogeneous (TLS) null vector.

use super::{Solution, Solver, Termination};
use crate::error::{FdidError, Result};
use crate::linalg::{check_shape, least_squares, svd_of_r};
use crate::problem::{HomogeneousProblem, LinearProblem};
use crate::scalar::Real;

/// Least squares min ‖Aθ − b‖² by QR of the column-equilibrated A followed by an SVD of the
/// small triangular factor R: never the normal equations.
///
/// Singular values below `rcond_eps · ε · σ_max` are truncated (the minimum-norm solution
/// along directions the data do not determine, as `numpy.linalg.lstsq` does); the solve
/// fails with [`FdidError::Singular`] only when nothing is left (A = 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearLeastSquares {
    /// Truncation threshold in units of ε (default 1000).
    pub rcond_eps: f64,
}

impl Default for LinearLeastSquares {
    fn default() -> Self {
        Self { rcond_eps: 1e3 }
    }
}

impl<T: Real, P: LinearProblem<T> + ?Sized> Solver<T, P> for LinearLeastSquares {
    fn solve(&self, problem: &P, _start: Option<&[T]>) -> Result<Solution<T>> {
        let (a, b) = problem.system();
        let (theta, cost) = least_squares(a, b, self.rcond_eps)?;
        Ok(Solution {
            theta: theta.as_slice().to_vec(),
            cost,
            iterations: 1,
            termination: Termination::Direct,
        })
    }
}

/// The unit vector c minimising ‖M c‖: the right singular vector of the smallest singular
/// value, from a QR of M followed by the SVD of its small triangular factor.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SvdNullVector;

impl<T: Real, P: HomogeneousProblem<T> + ?Sized> Solver<T, P> for SvdNullVector {
    fn solve(&self, problem: &P, _start: Option<&[T]>) -> Result<Solution<T>> {
        let m = problem.matrix();
        check_shape(&m, "total least squares")?;
        let r = m.qr().unpack_r();
        let svd = svd_of_r(r, "total least squares")?;
        let (imin, smin) =
            svd.singular_values
                .iter()
                .enumerate()
                .fold(
                    (0, T::infinity()),
                    |(i, s), (j, v)| if *v < s { (j, *v) } else { (i, s) },
                );
        let v_t = svd.v_t.as_ref().ok_or(FdidError::Numerical {
            what: "SVD without right singular vectors".into(),
        })?;
        let c: Vec<T> = v_t.row(imin).iter().copied().collect();
        let theta = problem
            .theta_from_null_vector(&c)
            .ok_or(FdidError::Singular {
                what: "total least squares: the null vector has a zero normalising coefficient",
                condition: f64::INFINITY,
            })?;
        Ok(Solution {
            theta,
            cost: smin * smin,
            iterations: 1,
            termination: Termination::Direct,
        })
    }
}
