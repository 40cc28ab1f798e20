//! Levenberg–Marquardt with the step from the guarded normal equations.

use super::{LevenbergMarquardt, Solution, Solver, Termination};
use crate::error::{FdidError, Result};
use crate::linalg::gram::{equilibrated, max_condition, scaled_cholesky};
use crate::problem::NonlinearProblem;
use crate::scalar::Real;
use nalgebra::{DMatrix, DVector};
use num_traits::Float;

/// Levenberg–Marquardt whose step solves the equilibrated normal equations by Cholesky:
///
/// ```text
/// (Gₛ + μI) δₛ = −D⁻¹Jᵀr,   δ = D⁻¹δₛ,   Gₛ = D⁻¹JᵀJD⁻¹,   D = diag ‖J_j‖,
/// ```
///
/// μ = 0 (Gauss–Newton) first, raised tenfold from 10⁻⁴ while a step does not lower the
/// cost ‖r‖² and lowered tenfold after each accepted one. Forming JᵀJ (one matrix product)
/// costs a fraction of the QR that MINPACK's algorithm ([`LevenbergMarquardt`]) makes of J
/// at every iteration. Normal equations are admissible here because only the step comes
/// from them: the iteration stops where the directly computed residuals stop decreasing
/// (the same relative step and cost-reduction tests as [`LevenbergMarquardt`], with its
/// `tolerance` and `cost_tolerance`), so an inexact step changes the path, not the
/// optimum. The cost-reduction test (MINPACK's ftol: actual and predicted reductions both
/// at most ftol·V, the actual at most twice the predicted) is applied to rejected steps
/// too, as MINPACK does, and for an undamped step without the ratio condition: a
/// Gauss–Newton step that predicts at most ftol·V places θ at the optimum to that
/// tolerance, and near it the actual change of V is rounding of either sign and size.
/// The equilibrated Gram matrix must factor and have κ₁(Gₛ) ≤ 10⁸ in f64 (10³ in f32) at
/// every iterate; otherwise, or when no step lowers the cost, the solve fails with
/// [`FdidError::Singular`] or [`FdidError::NotConverged`] and [`crate::Pipeline`] falls back
/// to [`LevenbergMarquardt`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GramLevenbergMarquardt {
    /// Tolerances (`tolerance`, `cost_tolerance`) as [`LevenbergMarquardt`]; its `patience`
    /// caps the residual evaluations at `patience·(p + 1)`.
    pub settings: LevenbergMarquardt,
    /// Cap on Jacobian evaluations (accepted steps).
    pub max_iterations: usize,
}

impl Default for GramLevenbergMarquardt {
    fn default() -> Self {
        Self::from(LevenbergMarquardt::default())
    }
}

impl From<LevenbergMarquardt> for GramLevenbergMarquardt {
    fn from(settings: LevenbergMarquardt) -> Self {
        Self {
            settings,
            max_iterations: 100,
        }
    }
}

fn sum_sq<T: Real>(r: &[T]) -> T {
    r.iter().fold(T::zero(), |s, v| s + *v * *v)
}

impl<T: Real, P: NonlinearProblem<T> + ?Sized> Solver<T, P> for GramLevenbergMarquardt {
    fn solve(&self, problem: &P, start: Option<&[T]>) -> Result<Solution<T>> {
        self.run(problem, start, None, false)
            .map(|(solution, _)| solution)
    }
}

impl GramLevenbergMarquardt {
    /// [`Solver::solve`], except at iterates whose equilibrated Gram matrix Gₛ is refused:
    /// the first `damped` of them take damped steps, μ ≥ p/κ_max (Gₛ has unit diagonal,
    /// so its eigenvalues are at most p and κ₂(Gₛ + μI) ≤ (p + μ)/μ ≈ κ_max); the next
    /// ends the iteration with the solution so far (`MaxIterations`) and `true`, for a
    /// solver that copes with ill-conditioning to go on from there rather than from the
    /// start. A problem singular at its start (a noise model C/D at C = D = 1, whose
    /// columns for c_k and d_k are opposite) moves off it by the damped steps.
    pub(crate) fn solve_to_refusal<T: Real, P: NonlinearProblem<T> + ?Sized>(
        &self,
        problem: &P,
        start: &[T],
        damped: usize,
    ) -> Result<(Solution<T>, bool)> {
        self.run(problem, Some(start), Some(damped), false)
    }

    /// [`Solver::solve`] that neither fails on ill-conditioning nor discards its progress:
    /// every iterate whose equilibrated Gram matrix is refused takes damped steps (as in
    /// [`Self::solve_to_refusal`]), and an iterate no step lowers (the damping grown to
    /// 10¹² with the cost unchanged: the cost's working precision in the normal equations)
    /// ends the iteration there (`MaxIterations`) instead of with an error. For a
    /// refinement whose result is compared with its start, where a full-Jacobian solver
    /// after a failure would cost far more than the refinement is worth.
    pub(crate) fn solve_damped<T: Real, P: NonlinearProblem<T> + ?Sized>(
        &self,
        problem: &P,
        start: &[T],
    ) -> Result<Solution<T>> {
        self.run(problem, Some(start), Some(usize::MAX), true)
            .map(|(solution, _)| solution)
    }

    /// The iteration; with `refusals` = `Some(k)` a refused Gram matrix is handled as in
    /// [`Self::solve_to_refusal`], with `None` it is an error; with `keep_stalled` an iterate
    /// no step lowers ends it as in [`Self::solve_damped`].
    fn run<T: Real, P: NonlinearProblem<T> + ?Sized>(
        &self,
        problem: &P,
        start: Option<&[T]>,
        refusals: Option<usize>,
        keep_stalled: bool,
    ) -> Result<(Solution<T>, bool)> {
        let mut damped_left = refusals.unwrap_or(0);
        let (m, p) = (problem.n_residuals(), problem.n_params());
        let (tol, ftol) = self.settings.checked(start, p, m)?;
        let mut x: Vec<T> = start.map(<[T]>::to_vec).unwrap_or_default();
        // (kept for the next solve: on a long record each is of the record's size)
        let mut r = crate::recycle::Kept::filled(m, T::zero());
        let mut r_try = crate::recycle::Kept::filled(m, T::zero());
        let mut x_try = vec![T::zero(); p];
        // J itself only for problems that do not accumulate JᵀJ and Jᵀr by blocks
        let mut jac = DMatrix::zeros(0, 0);
        let mut gram = DMatrix::zeros(p, p);
        let mut grad = DVector::zeros(p);
        let max_cond = max_condition::<T>();
        let budget = self.settings.patience.max(1) * (p + 1);
        let evaluation_cost = super::work::solve_cost(m, p);
        let mut evaluations = 1usize;
        if !problem.normal_equations_into(&x, &mut r, &mut jac, &mut gram, &mut grad) {
            return Err(FdidError::Numerical {
                what: "residuals or Jacobian at the start of Levenberg–Marquardt".into(),
            });
        }
        let mut cost = sum_sq(&r);
        let mut mu = T::zero();
        let mu_min = T::lit(1e-4);
        let done = |x: Vec<T>, cost: T, evaluations: usize, termination| {
            Ok((
                Solution {
                    theta: x,
                    cost,
                    iterations: evaluations,
                    termination,
                },
                false,
            ))
        };
        for _ in 0..self.max_iterations.max(1) {
            if cost == T::zero() {
                return done(x, cost, evaluations, Termination::Converged);
            }
            let refused = FdidError::Singular {
                what: "equilibrated normal equations of the Levenberg–Marquardt step",
                condition: f64::INFINITY,
            };
            // D, Gₛ and the Cholesky factor of Gₛ for the undamped step, when it is accepted
            let (scale, scaled, chol) = match scaled_cholesky(&gram, max_cond) {
                Some(sc) => (sc.d, sc.gs, Some(sc.chol)),
                None if refusals.is_some() && damped_left > 0 => {
                    damped_left -= 1;
                    let (d, gs) = equilibrated(&gram).ok_or(refused)?;
                    (d, gs, None)
                }
                None if refusals.is_some() => {
                    let solution = Solution {
                        theta: x,
                        cost,
                        iterations: evaluations,
                        termination: Termination::MaxIterations,
                    };
                    return Ok((solution, true));
                }
                None => return Err(refused),
            };
            // the least damping of an iterate whose Gₛ was refused
            let mu_floor = if chol.is_some() {
                T::zero()
            } else {
                T::from_usize_lossy(p) / max_cond
            };
            let gs: DVector<T> =
                DVector::from_iterator(p, grad.iter().zip(&scale).map(|(g, d)| *g / *d));
            if gs.iter().all(|v| *v == T::zero()) {
                return done(x, cost, evaluations, Termination::Converged);
            }
            let xnorm = Float::sqrt(
                x.iter()
                    .zip(&scale)
                    .fold(T::zero(), |s, (v, d)| s + (*v * *d) * (*v * *d)),
            );
            loop {
                let damping = Float::max(mu, mu_floor);
                let step = if let (true, Some(chol)) = (damping == T::zero(), &chol) {
                    -chol.solve(&gs)
                } else {
                    let mut a = scaled.clone();
                    for i in 0..p {
                        a[(i, i)] += damping;
                    }
                    match nalgebra::Cholesky::new(a) {
                        Some(c) => -c.solve(&gs),
                        None => {
                            return Err(FdidError::Numerical {
                                what: "damped normal equations of the Levenberg–Marquardt step"
                                    .into(),
                            });
                        }
                    }
                };
                // predicted reduction of ‖r + Jδ‖²: −2δₛᵀgₛ − δₛᵀGₛδₛ
                let gsd = &scaled * &step;
                let predicted = -(step.dot(&gs) * T::lit(2.0) + step.dot(&gsd));
                let snorm = step.norm();
                for ((xt, xv), (s, d)) in x_try.iter_mut().zip(&x).zip(step.iter().zip(&scale)) {
                    *xt = *xv + *s / *d;
                }
                if !super::work::charge(evaluation_cost) {
                    return done(x, cost, evaluations, Termination::MaxIterations);
                }
                evaluations += 1;
                let new_cost = if problem.residuals_into(&x_try, &mut r_try) {
                    sum_sq(&r_try)
                } else {
                    T::infinity()
                };
                let small_step = snorm <= tol * xnorm;
                if new_cost < cost {
                    let actual = cost - new_cost;
                    // MINPACK's ftol test, without its ratio condition for an undamped step
                    let converged = small_step
                        || (actual <= ftol * cost
                            && Float::abs(predicted) <= ftol * cost
                            && (damping == T::zero()
                                || actual <= T::lit(2.0) * Float::abs(predicted)));
                    std::mem::swap(&mut x, &mut x_try);
                    cost = new_cost;
                    mu = if mu <= mu_min {
                        T::zero()
                    } else {
                        mu / T::lit(10.0)
                    };
                    if converged {
                        return done(x, cost, evaluations, Termination::Converged);
                    }
                    evaluations += 1;
                    if !problem.normal_equations_into(&x, &mut r, &mut jac, &mut gram, &mut grad) {
                        return Err(FdidError::Numerical {
                            what: "Jacobian at an accepted Levenberg–Marquardt step".into(),
                        });
                    }
                    break;
                }
                // no step lowers the cost any more: a step too small to move θ, or the ftol
                // test on an undamped rejected step (both changes at most ftol·V)
                let flat = damping == T::zero()
                    && Float::abs(predicted) <= ftol * cost
                    && Float::abs(cost - new_cost) <= ftol * cost;
                if small_step || flat {
                    return done(x, cost, evaluations, Termination::Converged);
                }
                if evaluations >= budget {
                    return done(x, cost, evaluations, Termination::MaxIterations);
                }
                mu = if mu == T::zero() {
                    mu_min
                } else {
                    mu * T::lit(10.0)
                };
                if !(mu < T::lit(1e12)) {
                    if keep_stalled {
                        return done(x, cost, evaluations, Termination::MaxIterations);
                    }
                    return Err(FdidError::NotConverged {
                        method: "Levenberg–Marquardt (normal equations)",
                        reason: format!("no step lowers the cost (damping {mu})"),
                    });
                }
            }
            if evaluations >= budget {
                return done(x, cost, evaluations, Termination::MaxIterations);
            }
        }
        done(x, cost, evaluations, Termination::MaxIterations)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// r_k = a·exp(−b t_k) + c − y_k, with y from (2, 0.7, 0.3) plus a deterministic ripple.
    struct Exp {
        t: Vec<f64>,
        y: Vec<f64>,
        /// a copy of b's column in c's place: the Jacobian is rank deficient
        degenerate: bool,
    }

    impl NonlinearProblem<f64> for Exp {
        fn n_params(&self) -> usize {
            3
        }
        fn n_residuals(&self) -> usize {
            self.t.len()
        }
        fn residuals_into(&self, x: &[f64], r: &mut [f64]) -> bool {
            for (k, (t, y)) in self.t.iter().zip(&self.y).enumerate() {
                let c = if self.degenerate { x[2] * t } else { x[2] };
                r[k] = x[0] * (-x[1] * t).exp() + c - y;
            }
            true
        }
        fn jacobian_into(&self, x: &[f64], r: &mut [f64], jac: &mut DMatrix<f64>) -> bool {
            self.residuals_into(x, r);
            for (k, t) in self.t.iter().enumerate() {
                let e = (-x[1] * t).exp();
                jac[(k, 0)] = e;
                jac[(k, 1)] = -x[0] * t * e;
                jac[(k, 2)] = if self.degenerate { *t } else { 1.0 };
            }
            true
        }
    }

    fn exp_problem(degenerate: bool) -> Exp {
        let t: Vec<f64> = (0..200).map(|k| k as f64 * 0.05).collect();
        let y = t
            .iter()
            .map(|t| 2.0 * (-0.7 * t).exp() + 0.3 + 0.01 * (13.0 * t).sin())
            .collect();
        Exp { t, y, degenerate }
    }

    #[test]
    fn reaches_the_optimum_of_the_qr_solver() {
        let p = exp_problem(false);
        let start = [1.0, 0.3, 0.0];
        let fast = GramLevenbergMarquardt::default()
            .solve(&p, Some(&start))
            .expect("fast");
        let reference = LevenbergMarquardt::default()
            .solve(&p, Some(&start))
            .expect("crate");
        assert!(fast.converged());
        assert!((fast.cost - reference.cost).abs() <= 1e-9 * reference.cost);
        for (a, b) in fast.theta.iter().zip(&reference.theta) {
            assert!((a - b).abs() <= 1e-6 * b.abs().max(1.0), "{a} vs {b}");
        }
        // the gradient Jᵀr vanishes at the returned point
        let mut r = vec![0.0; p.n_residuals()];
        let mut j = DMatrix::zeros(p.n_residuals(), 3);
        p.jacobian_into(&fast.theta, &mut r, &mut j);
        let g = j.transpose() * DVector::from_vec(r);
        assert!(g.norm() < 1e-8, "gradient {g}");
    }

    #[test]
    fn refuses_ill_conditioned_normal_equations_and_bad_starts() {
        // columns e^{-bt}, -a t e^{-bt}, t: fine; make b = 0 so that column 1 is −a·t = a·(−col 2)
        let p = exp_problem(true);
        let err = GramLevenbergMarquardt::default()
            .solve(&p, Some(&[1.0, 0.0, -1.0]))
            .unwrap_err();
        assert!(matches!(err, FdidError::Singular { .. }), "{err:?}");
        let p = exp_problem(false);
        assert!(GramLevenbergMarquardt::default().solve(&p, None).is_err());
        assert!(
            GramLevenbergMarquardt::default()
                .solve(&p, Some(&[1.0, f64::NAN, 0.0]))
                .is_err()
        );
    }
    #[test]
    fn solve_to_refusal_hands_over_where_it_stopped() {
        // singular at the start (b = 0): no damped step allowed ends there at once
        let p = exp_problem(true);
        let start = [1.0, 0.0, -1.0];
        let fast = GramLevenbergMarquardt::default();
        let (s0, refused) = fast.solve_to_refusal(&p, &start, 0).expect("stop");
        assert!(refused);
        assert_eq!(s0.theta, start);
        assert_eq!(s0.termination, Termination::MaxIterations);
        // damped steps move off the singular start and lower the cost
        let (s1, _) = fast.solve_to_refusal(&p, &start, 5).expect("damped");
        assert!(s1.cost < s0.cost, "{} vs {}", s1.cost, s0.cost);
        assert_ne!(s1.theta, start);
        // a well-conditioned problem never refuses: the same optimum as Solver::solve
        let p = exp_problem(false);
        let start = [1.0, 0.3, 0.0];
        let (s2, refused) = fast.solve_to_refusal(&p, &start, 0).expect("fast");
        assert!(!refused);
        let reference = fast.solve(&p, Some(&start)).expect("solve");
        assert_eq!(s2, reference);
    }

    /// r_k = x₀ + x₁t_k − y_k with residuals of order 10³ at the optimum.
    struct Line {
        t: Vec<f64>,
        y: Vec<f64>,
    }

    impl NonlinearProblem<f64> for Line {
        fn n_params(&self) -> usize {
            2
        }
        fn n_residuals(&self) -> usize {
            self.t.len()
        }
        fn residuals_into(&self, x: &[f64], r: &mut [f64]) -> bool {
            for ((r, t), y) in r.iter_mut().zip(&self.t).zip(&self.y) {
                *r = x[0] + x[1] * t - y;
            }
            true
        }
        fn jacobian_into(&self, x: &[f64], r: &mut [f64], jac: &mut DMatrix<f64>) -> bool {
            self.residuals_into(x, r);
            for (k, t) in self.t.iter().enumerate() {
                jac[(k, 0)] = 1.0;
                jac[(k, 1)] = *t;
            }
            true
        }
    }

    /// Near the optimum, where a Gauss–Newton step predicts a reduction far below the
    /// rounding of the cost (its actual change is rounding, of either sign), the solver
    /// stops at that step instead of damping it down to the step tolerance.
    #[test]
    fn stops_where_the_cost_changes_only_by_rounding() {
        let t: Vec<f64> = (0..100).map(|k| k as f64 * 0.01).collect();
        let y = t
            .iter()
            .enumerate()
            .map(|(k, t)| 2.0 - t + 1e3 * (k as f64 * 1.7).sin())
            .collect();
        let p = Line { t, y };
        let fast = GramLevenbergMarquardt::default();
        let opt = fast.solve(&p, Some(&[0.0, 0.0])).expect("optimum");
        assert!(opt.converged());
        // 10⁻⁷ away: predicted reduction about 10⁻¹², the cost (about 5·10⁷) rounds at 10⁻⁸
        for offset in [1e-7, -1e-7] {
            let start = [opt.theta[0] + offset, opt.theta[1] - offset];
            let near = fast.solve(&p, Some(&start)).expect("near");
            assert!(near.converged());
            assert!(near.iterations <= 3, "{} evaluations", near.iterations);
            assert!(near.cost <= opt.cost * (1.0 + 1e-12));
        }
    }

    /// Residuals that no step changes, with a Jacobian that promises descent: the cost
    /// cannot be lowered (as at the working precision of an ML cost).
    struct Flat;

    impl NonlinearProblem<f64> for Flat {
        fn n_params(&self) -> usize {
            2
        }
        fn n_residuals(&self) -> usize {
            3
        }
        fn residuals_into(&self, _x: &[f64], r: &mut [f64]) -> bool {
            r.copy_from_slice(&[1.0, -2.0, 0.5]);
            true
        }
        fn jacobian_into(&self, x: &[f64], r: &mut [f64], jac: &mut DMatrix<f64>) -> bool {
            self.residuals_into(x, r);
            jac.copy_from(&DMatrix::from_row_slice(
                3,
                2,
                &[1.0, 0.0, 0.0, 1.0, 1.0, 1.0],
            ));
            true
        }
    }

    #[test]
    fn solve_damped_keeps_a_stalled_iterate_and_damps_refusals() {
        let start = [0.4, -0.2];
        let fast = GramLevenbergMarquardt::default();
        assert!(matches!(
            fast.solve(&Flat, Some(&start)),
            Err(FdidError::NotConverged { .. })
        ));
        let stalled = fast.solve_damped(&Flat, &start).expect("stalled");
        assert_eq!(stalled.theta, start);
        assert_eq!(stalled.termination, Termination::MaxIterations);
        assert_eq!(stalled.cost, 5.25);
        // singular at the start: damped steps instead of the refusal
        let p = exp_problem(true);
        let singular = [1.0, 0.0, -1.0];
        assert!(fast.solve(&p, Some(&singular)).is_err());
        let damped = fast.solve_damped(&p, &singular).expect("damped");
        let r0: f64 = {
            let mut r = vec![0.0; p.n_residuals()];
            p.residuals_into(&singular, &mut r);
            r.iter().map(|v| v * v).sum()
        };
        assert!(damped.cost < r0, "{} vs {r0}", damped.cost);
    }
}
