//! Iterations restricted to a feasible set: a problem wrapper whose residuals do not exist
//! outside it.

use crate::problem::NonlinearProblem;
use crate::scalar::Real;
use nalgebra::{DMatrix, DVector};

/// A [`NonlinearProblem`] restricted to an open feasible set S = {θ : `feasible`(θ)}: outside
/// S its residuals are reported as not finite, which both Levenberg–Marquardt solvers
/// treat as a failed step (the damping grows and the step shrinks, as after a step that
/// raises the cost). From a start θ₀ ∈ S every accepted iterate is then in S:
///
/// ```text
/// θ_{k+1} = θ_k + δ_k   only if   θ_k + δ_k ∈ S   and   ‖r(θ_k + δ_k)‖² < ‖r(θ_k)‖²,
/// ```
///
/// a descent method on ‖r‖² over S whose limit is a local minimum of ‖r‖² in S or on its
/// boundary. Since S is open and the damped step δ → 0 as the damping grows, a step
/// inside S is always found while θ_k is in S; near the boundary the steps shorten.
/// The stability-constrained ML of [`crate::estimate::Stability::Enforced`] is this with
/// S the set of θ whose poles are all stable ([`crate::model::ModelStructure::stable_at`]).
///
/// ```
/// use fdid::problem::NonlinearProblem;
/// use fdid::solver::{Feasible, GramLevenbergMarquardt, Solver};
/// // r(x) = x² − 1/4, minimum at x = 1/2; from x = 0.1 the Gauss–Newton step goes to 1.3,
/// // outside S = {x < 0.8}: it is rejected, and shorter steps reach 1/2 inside S
/// struct Square;
/// impl NonlinearProblem<f64> for Square {
///     fn n_params(&self) -> usize { 1 }
///     fn n_residuals(&self) -> usize { 1 }
///     fn residuals_into(&self, x: &[f64], r: &mut [f64]) -> bool { r[0] = x[0] * x[0] - 0.25; true }
///     fn jacobian_into(&self, x: &[f64], r: &mut [f64], j: &mut nalgebra::DMatrix<f64>) -> bool {
///         r[0] = x[0] * x[0] - 0.25;
///         j[(0, 0)] = 2.0 * x[0];
///         true
///     }
/// }
/// let constrained = Feasible::new(&Square, |x: &[f64]| x[0] < 0.8);
/// let sol = GramLevenbergMarquardt::default().solve(&constrained, Some(&[0.1])).unwrap();
/// assert!((sol.theta[0] - 0.5).abs() < 1e-6);
/// ```
#[derive(Debug, Clone, Copy)]
pub struct Feasible<'p, P: ?Sized, F> {
    problem: &'p P,
    feasible: F,
}

impl<'p, P: ?Sized, F> Feasible<'p, P, F> {
    /// `problem` restricted to the θ where `feasible(θ)` holds.
    pub fn new(problem: &'p P, feasible: F) -> Self {
        Self { problem, feasible }
    }

    /// The unconstrained problem.
    pub fn inner(&self) -> &'p P {
        self.problem
    }
}

impl<T: Real, P: NonlinearProblem<T> + ?Sized, F: Fn(&[T]) -> bool> NonlinearProblem<T>
    for Feasible<'_, P, F>
{
    fn n_params(&self) -> usize {
        self.problem.n_params()
    }

    fn n_residuals(&self) -> usize {
        self.problem.n_residuals()
    }

    fn residuals_into(&self, theta: &[T], r: &mut [T]) -> bool {
        (self.feasible)(theta) && self.problem.residuals_into(theta, r)
    }

    fn jacobian_into(&self, theta: &[T], r: &mut [T], jac: &mut DMatrix<T>) -> bool {
        (self.feasible)(theta) && self.problem.jacobian_into(theta, r, jac)
    }

    fn normal_equations_into(
        &self,
        theta: &[T],
        r: &mut [T],
        jac: &mut DMatrix<T>,
        gram: &mut DMatrix<T>,
        grad: &mut DVector<T>,
    ) -> bool {
        (self.feasible)(theta)
            && self
                .problem
                .normal_equations_into(theta, r, jac, gram, grad)
    }
}
