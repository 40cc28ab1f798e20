//! Direct linear solvers: least squares and the homogeneous (TLS) null vector.

use super::{Solution, Solver, Termination};
use crate::Real;
use crate::error::{FdidError, Result};
use crate::problem::{HomogeneousProblem, LinearProblem};
use nalgebra::{DMatrix, DVector};
use num_traits::Float;

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

/// The SVD of the triangular factor of a QR, with the condition check.
fn svd_of_r<T: Real>(
    r: DMatrix<T>,
    what: &'static str,
) -> Result<nalgebra::SVD<T, nalgebra::Dyn, nalgebra::Dyn>> {
    let p = r.ncols();
    if r.iter().any(|v| !Float::is_finite(*v)) {
        return Err(FdidError::Numerical {
            what: format!("{what}: the QR factor overflowed (data too large to scale)"),
        });
    }
    crate::problem::try_svd(r, true, true, 100 * p.max(10)).ok_or(FdidError::NotConverged {
        method: "SVD",
        reason: format!("no convergence in {what}"),
    })
}

fn check_shape<T: Real>(a: &DMatrix<T>, what: &'static str) -> Result<()> {
    let (m, p) = a.shape();
    if p == 0 || m < p {
        return Err(FdidError::TooFewFrequencies {
            lines: m / 2,
            equations: m,
            parameters: p,
        });
    }
    if a.iter().any(|v| !Float::is_finite(*v)) {
        return Err(FdidError::Numerical {
            what: format!("{what}: non-finite entries"),
        });
    }
    Ok(())
}

/// Solves min ‖Aθ − b‖² (see [`LinearLeastSquares`]); returns θ and the residual norm².
///
/// # Errors
/// Fewer rows than columns, non-finite entries, A = 0.
pub fn least_squares<T: Real>(
    mut a: DMatrix<T>,
    mut b: DVector<T>,
    rcond_eps: f64,
) -> Result<(DVector<T>, T)> {
    check_shape(&a, "least squares")?;
    let p = a.ncols();
    // equilibrate columns
    let mut scale = vec![T::one(); p];
    for (j, s) in scale.iter_mut().enumerate() {
        let n = a.column(j).norm();
        if n > T::zero() {
            *s = n;
            a.column_mut(j).unscale_mut(n);
        }
    }
    let a_copy_norm = b.norm_squared();
    let qr = a.qr();
    qr.q_tr_mul(&mut b);
    let r = qr.unpack_r();
    let svd = svd_of_r(r, "least squares")?;
    let sv = &svd.singular_values;
    let (smax, smin) = sv.iter().fold((T::zero(), T::infinity()), |(mx, mn), s| {
        (Float::max(mx, *s), Float::min(mn, *s))
    });
    if !(smax > T::zero()) {
        return Err(FdidError::Singular {
            what: "linear least-squares problem (zero matrix)",
            condition: (smax / smin).to_f64_lossless(),
        });
    }
    let cut = smax * T::lit(rcond_eps) * T::default_epsilon();
    let qtb = b.rows(0, p).into_owned();
    let x = svd.solve(&qtb, cut).map_err(|e| FdidError::Numerical {
        what: e.to_string(),
    })?;
    // residual: ‖b‖² minus the part of Q₁ᵀb explained by the kept singular directions
    let fitted = svd.u.as_ref().map_or(qtb.norm_squared(), |u| {
        (u.transpose() * &qtb)
            .iter()
            .zip(sv.iter())
            .filter(|(_, s)| **s > cut)
            .fold(T::zero(), |acc, (v, _)| acc + *v * *v)
    });
    let resid = Float::max(a_copy_norm - fitted, T::zero());
    let theta = DVector::from_iterator(p, x.iter().zip(&scale).map(|(v, s)| *v / *s));
    if theta.iter().any(|v| !Float::is_finite(*v)) {
        return Err(FdidError::Numerical {
            what: "least squares: the solution overflowed (data too large to scale)".into(),
        });
    }
    Ok((theta, resid))
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
