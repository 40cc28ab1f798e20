//! Maximum likelihood of a rational model started from given poles: the denominator
//! built from them, the numerator (and transient) fitted by linear least squares, then
//! the output-error ML of McKelvey eq. 23.

use super::chain::{Pipeline, ml_solve_in, stable_start};
use crate::criterion::{Criterion, MaximumLikelihood};
use crate::data::FrequencyData;
use crate::error::{FdidError, Result};
use crate::fit::{Fit, Stage, StageKind};
use crate::model::{ModelStructure, Rational};
use crate::problem::NonlinearProblem;
use crate::scalar::{Complex, Real};
use crate::solver::{GramLevenbergMarquardt, Solution, Termination};
use nalgebra::{DMatrix, DVector};

impl Pipeline {
    /// The ML fit (McKelvey eq. 23, the pipeline's weighting and Levenberg–Marquardt
    /// settings; stable-constrained when `self.stable`) of `model` started from the poles
    /// `roots` (na values, closed under conjugation):
    ///
    /// 1. the denominator A with those roots, formed factor by factor in the model's basis
    ///    (`PolyBasis::from_roots`; in a partial-fraction basis at those poles, D = 1);
    /// 2. the numerator and transient coefficients θ_ℓ, in which the modelled output
    ///    Ŷ = (B U + T)/A is linear once A is fixed: r(θ₀ + Δ) = r(θ₀) + J_ℓ Δ exactly,
    ///    so one least-squares solve of the weighted residual r = (Y − Ŷ)/σ
    ///    (Householder QR and SVD) gives them;
    /// 3. ML from there.
    ///
    /// The start keeps every pole where it was put, so this refines a known model (a
    /// model augmented by a pole pair, a warm start) where a fit from scratch could land
    /// in another local minimum.
    ///
    /// # Errors
    /// [`FdidError::LengthMismatch`] when the roots are not na values;
    /// [`FdidError::InvalidArgument`] without ML in the pipeline; the data's and the
    /// solvers' errors (a singular numerator problem, a stable-constrained ML that leaves
    /// the stable region).
    pub fn fit_from_roots<T: Real>(
        &self,
        model: &Rational<T>,
        data: &FrequencyData<T>,
        roots: &[Complex<T>],
    ) -> Result<Fit<T, Rational<T>>> {
        let Some(lm) = self.ml else {
            return Err(FdidError::InvalidArgument {
                name: "ml",
                value: "none".into(),
                reason: "a start from given poles is refined by maximum likelihood".into(),
            });
        };
        if roots.len() != model.na() {
            return Err(FdidError::LengthMismatch {
                what: "starting poles",
                expected: model.na(),
                got: roots.len(),
            });
        }
        crate::error::check_finite_complex("starting poles", roots)?;
        data.check_output()?;
        model.check_data(data)?;
        let a = model.basis().from_roots(roots, model.na());
        let zeros = vec![T::zero(); model.nb() + 1];
        let theta0 = model.theta_from_polys(&a, &zeros)?;
        let criterion = MaximumLikelihood {
            weighting: self.weighting,
        };
        let problem = criterion.problem(model, data)?;
        let linear = linear_start(&problem, theta0, model.na())?;
        let start = stable_start(model, linear.theta.clone(), self.stable)?;
        let fast = GramLevenbergMarquardt::from(lm);
        let ml = ml_solve_in(&fast, &lm, model, &problem, &start, self.stable)?;
        let stages = vec![
            Stage::new(StageKind::PolesLs, linear),
            Stage::new(StageKind::Ml, ml.clone()),
        ];
        Fit::from_ml_problem(model.clone(), data, ml.theta, &problem, stages)
    }
}

/// θ₀ with its parameters from index `fixed` on (those the residual is linear in) set to
/// the least-squares solution of r(θ₀) + J_ℓ Δ = 0.
fn linear_start<T: Real, P: NonlinearProblem<T> + ?Sized>(
    problem: &P,
    mut theta: Vec<T>,
    fixed: usize,
) -> Result<Solution<T>> {
    let (m, p) = (problem.n_residuals(), problem.n_params());
    let mut r = vec![T::zero(); m];
    let mut jac = DMatrix::zeros(m, p);
    if !problem.jacobian_into(&theta, &mut r, &mut jac) {
        return Err(FdidError::Numerical {
            what: "the residual at the starting poles is not finite".into(),
        });
    }
    let free = jac.columns(fixed, p - fixed).into_owned();
    let rhs = -DVector::from_vec(r);
    let (delta, _) = crate::linalg::least_squares(free, rhs, 1e3)?;
    for (t, d) in theta[fixed..].iter_mut().zip(delta.iter()) {
        *t += *d;
    }
    let mut r = vec![T::zero(); m];
    let finite = problem.residuals_into(&theta, &mut r);
    let cost = if finite {
        r.iter().fold(T::zero(), |s, v| s + *v * *v)
    } else {
        T::infinity()
    };
    Ok(Solution {
        theta,
        cost,
        iterations: 1,
        termination: Termination::Direct,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// G(s) = (s + 2) / ((s² + 0.2 s + 1)(s + 3)) on 100 lines: from its own poles the
    /// numerator is found by the linear step and ML has nothing left to do; from poles
    /// 10 % off, ML recovers them.
    #[test]
    fn from_the_true_poles_and_from_nearby_ones() {
        let omega: Vec<f64> = (1..=100).map(|k| 0.05 * k as f64).collect();
        let g = |w: f64| {
            let s = Complex::new(0.0, w);
            (s + 2.0) / ((s * s + s * 0.2 + 1.0) * (s + 3.0))
        };
        let y = omega.iter().map(|w| g(*w)).collect();
        let data = FrequencyData::from_frf(omega.clone(), y, None).unwrap();
        let pair = Complex::new(-0.1, 0.99f64.sqrt());
        let truth = [pair, pair.conj(), Complex::new(-3.0, 0.0)];
        for model in [
            Rational::polynomial(3, 1, &omega).unwrap(),
            Rational::partial_fractions(vec![pair * 1.1, Complex::new(-2.0, 0.0)], 1).unwrap(),
        ] {
            let pipeline = Pipeline::default();
            let exact = pipeline.fit_from_roots(&model, &data, &truth).unwrap();
            assert!(exact.cost() < 1e-20, "cost {}", exact.cost());
            let off: Vec<Complex<f64>> = truth.iter().map(|p| p * 1.1).collect();
            let near = pipeline.fit_from_roots(&model, &data, &off).unwrap();
            let poles = near.poles().unwrap();
            for p in truth {
                assert!(
                    poles.iter().any(|q| (q - p).norm() < 1e-7),
                    "{p} not among {poles:?}"
                );
            }
            // two roots for a third-order model
            assert!(pipeline.fit_from_roots(&model, &data, &truth[..2]).is_err());
        }
    }
}
