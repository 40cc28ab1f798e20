//! Solvers: how a problem produced by a [`crate::Criterion`] is minimised.
//!
//! | solver | solves | method |
//! |---|---|---|
//! | [`LinearLeastSquares`] | [`LinearProblem`](crate::problem::LinearProblem) | column-equilibrated QR, then SVD of R with a rank test |
//! | [`SvdNullVector`] | [`HomogeneousProblem`](crate::problem::HomogeneousProblem) | QR, then the right singular vector of R's smallest singular value |
//! | [`FixedPoint`] | [`ReweightedProblem`](crate::problem::ReweightedProblem) | repeated weighted linear solves until the model stops changing |
//! | [`LevenbergMarquardt`] | [`NonlinearProblem`](crate::problem::NonlinearProblem) | the `levenberg-marquardt` crate (MINPACK's trust region) |
//! | [`Feasible`] | a [`NonlinearProblem`](crate::problem::NonlinearProblem) restricted to a feasible set | steps leaving the set are rejected like steps that raise the cost |
//! | [`GramLevenbergMarquardt`] | [`NonlinearProblem`](crate::problem::NonlinearProblem) | damped Gauss–Newton with the step from the guarded, equilibrated normal equations (fails rather than lose accuracy when they are ill-conditioned) |

mod feasible;
mod fixed_point;
mod gram_lm;
mod linear;
mod lm;
pub mod work;

pub use crate::linalg::least_squares;
pub use feasible::Feasible;
pub use fixed_point::FixedPoint;
pub use gram_lm::GramLevenbergMarquardt;
pub use linear::{LinearLeastSquares, SvdNullVector};
pub use lm::LevenbergMarquardt;

use crate::error::Result;
use crate::scalar::Real;

/// A method that minimises problems of kind `P`.
pub trait Solver<T: Real, P: ?Sized> {
    /// Solves `problem`, starting from `start` where the method iterates (required by
    /// Levenberg–Marquardt, ignored by direct solvers).
    ///
    /// # Errors
    /// Missing or wrong-length start, singular or ill-conditioned systems, numerical
    /// failure.
    fn solve(&self, problem: &P, start: Option<&[T]>) -> Result<Solution<T>>;
}

/// Why a solver stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Termination {
    /// A direct method solved the problem.
    Direct,
    /// An iterative method met its convergence test.
    Converged,
    /// The iteration or evaluation cap was reached first.
    MaxIterations,
}

/// The outcome of a solve.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Solution<T: Real> {
    /// The estimate θ̂.
    pub theta: Vec<T>,
    /// The problem's cost at θ̂ (sum of squared real residuals).
    pub cost: T,
    /// Iterations (linear solves or function evaluations).
    pub iterations: usize,
    /// Why the solver stopped.
    pub termination: Termination,
}

impl<T: Real> Solution<T> {
    /// True unless an iteration cap stopped the solver.
    pub fn converged(&self) -> bool {
        self.termination != Termination::MaxIterations
    }
}
