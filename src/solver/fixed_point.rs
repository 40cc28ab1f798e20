//! The fixed-point loop of iteratively re-weighted least squares (Sanathanan–Koerner).

use super::{Solution, Solver, Termination, least_squares};
use crate::Real;
use crate::error::Result;
use crate::problem::ReweightedProblem;

/// Repeats weighted linear least-squares solves θ^(m) = argmin V_m(θ; θ^(m−1)) until the
/// relative change of the model, [`ReweightedProblem::change`], drops below `tolerance`
/// or `max_iterations` solves have been made. The first solve is unweighted (Levy) unless a
/// start is given.
///
/// | setting | default | meaning |
/// |---|---|---|
/// | `max_iterations` | 30 | cap on linear solves |
/// | `tolerance` | 1e-9 (f64), 1e-5 (f32) | relative model change that counts as converged; `None` picks by type |
/// | `max_condition_eps` | 0.1 | as [`super::LinearLeastSquares`] |
///
/// SK may oscillate rather than converge (McKelvey ref. [20]); the solver then returns the
/// iterate with the lowest cost and [`Termination::MaxIterations`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FixedPoint {
    /// Cap on linear solves.
    pub max_iterations: usize,
    /// Convergence tolerance on the relative model change (`None`: √ε·10 by type).
    pub tolerance: Option<f64>,
    /// See [`super::LinearLeastSquares::max_condition_eps`].
    pub max_condition_eps: f64,
}

impl Default for FixedPoint {
    fn default() -> Self {
        Self {
            max_iterations: 30,
            tolerance: None,
            max_condition_eps: 0.1,
        }
    }
}

impl<T: Real, P: ReweightedProblem<T> + ?Sized> Solver<T, P> for FixedPoint {
    fn solve(&self, problem: &P, start: Option<&[T]>) -> Result<Solution<T>> {
        let tol = match self.tolerance {
            Some(t) => T::lit(t),
            None => num_traits::Float::sqrt(T::default_epsilon()) * T::lit(0.1),
        };
        let mut previous: Option<Vec<T>> = start.map(<[T]>::to_vec);
        let mut best: Option<(Vec<T>, T)> = None;
        for it in 1..=self.max_iterations.max(1) {
            let (a, b) = problem.system(previous.as_deref());
            let (theta, _) = least_squares(a, b, self.max_condition_eps)?;
            let theta = theta.as_slice().to_vec();
            let cost = problem.cost(&theta);
            let change = previous.as_deref().map(|old| problem.change(old, &theta));
            if best.as_ref().is_none_or(|(_, c)| cost < *c) {
                best = Some((theta.clone(), cost));
            }
            if let Some(ch) = change {
                if ch < tol {
                    return Ok(Solution {
                        theta,
                        cost,
                        iterations: it,
                        termination: Termination::Converged,
                    });
                }
            }
            previous = Some(theta);
        }
        let (theta, cost) = best.unwrap_or_default();
        Ok(Solution {
            theta,
            cost,
            iterations: self.max_iterations.max(1),
            termination: Termination::MaxIterations,
        })
    }
}
