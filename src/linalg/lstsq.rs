//! Dense least squares by QR of the column-equilibrated matrix and an SVD of its small
//! triangular factor: never the normal equations.

use crate::error::{FdidError, Result};
use crate::scalar::Real;
use nalgebra::{DMatrix, DVector};
use num_traits::Float;

/// The SVD of the triangular factor of a QR, with the condition check.
pub(crate) fn svd_of_r<T: Real>(
    r: DMatrix<T>,
    what: &'static str,
) -> Result<nalgebra::SVD<T, nalgebra::Dyn, nalgebra::Dyn>> {
    let p = r.ncols();
    if r.iter().any(|v| !Float::is_finite(*v)) {
        return Err(FdidError::Numerical {
            what: format!("{what}: the QR factor overflowed (data too large to scale)"),
        });
    }
    super::try_svd(r, true, true, 100 * p.max(10)).ok_or(FdidError::NotConverged {
        method: "SVD",
        reason: format!("no convergence in {what}"),
    })
}

pub(crate) fn check_shape<T: Real>(a: &DMatrix<T>, what: &'static str) -> Result<()> {
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

/// Divides every nonzero column of `a` by its norm and returns the norms (1 for a zero
/// column): the column equilibration before a QR, whose solution in the scaled columns is
/// divided by them.
pub(crate) fn equilibrate_columns<T: Real>(a: &mut DMatrix<T>) -> Vec<T> {
    let mut scale = vec![T::one(); a.ncols()];
    for (j, s) in scale.iter_mut().enumerate() {
        let n = a.column(j).norm();
        if n > T::zero() {
            *s = n;
            a.column_mut(j).unscale_mut(n);
        }
    }
    scale
}

/// Solves min ‖Aθ − b‖² (see [`crate::solver::LinearLeastSquares`]); returns θ and the residual norm².
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
    let scale = equilibrate_columns(&mut a);
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
