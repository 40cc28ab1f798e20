//! The fixed-point loop of iteratively re-weighted least squares (Sanathanan–Koerner).

use super::{Solution, Solver, Termination, least_squares};
use crate::error::Result;
use crate::problem::ReweightedProblem;
use crate::scalar::Real;

/// Repeats weighted linear least-squares solves θ^(m) = argmin V_m(θ; θ^(m−1)) until the
/// relative change of the model, [`ReweightedProblem::change`], drops below `tolerance`,
/// or the cost changes by less than `cost_tolerance` relative (the iterates no longer move
/// the model by more than the noise does), or `max_iterations` solves have been made. The
/// first solve is unweighted (Levy) unless a start is given.
///
/// | setting | default | meaning |
/// |---|---|---|
/// | `max_iterations` | 30 | cap on linear solves |
/// | `tolerance` | `None`: √ε (1.5e-8 for f64, 3.5e-4 for f32); 10⁻³ on the fewer lines of [`crate::estimate::Pipeline`]'s start | relative model change that counts as converged (SK is a start for ML, which refines further) |
/// | `cost_tolerance` | 1e-4 | relative cost change that counts as converged |
/// | `rcond_eps` | 1 | as [`super::LinearLeastSquares`]; smaller than Levy's default because the re-weighted systems are better scaled and truncation there degrades the fixed point |
///
/// SK may oscillate rather than converge (McKelvey ref. 20), or a step may make a good
/// start worse: the solver always returns the iterate (or start) with the lowest cost, with
/// [`Termination::MaxIterations`] when the cap stopped it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FixedPoint {
    /// Cap on linear solves.
    pub max_iterations: usize,
    /// Convergence tolerance on the relative model change (`None`: √ε of the scalar type).
    pub tolerance: Option<f64>,
    /// Relative change of the cost between iterations that counts as converged.
    pub cost_tolerance: f64,
    /// See [`super::LinearLeastSquares::rcond_eps`].
    pub rcond_eps: f64,
}

impl Default for FixedPoint {
    fn default() -> Self {
        Self {
            max_iterations: 30,
            tolerance: None,
            cost_tolerance: 1e-4,
            rcond_eps: 1.0,
        }
    }
}

impl<T: Real, P: ReweightedProblem<T> + ?Sized> Solver<T, P> for FixedPoint {
    fn solve(&self, problem: &P, start: Option<&[T]>) -> Result<Solution<T>> {
        self.solve_with(problem, start, false)
    }
}

impl FixedPoint {
    /// The iterations of [`Solver::solve`]; with `gram` the linear solves go through the
    /// guarded normal equations (falling back to QR/SVD when they are ill-conditioned), for
    /// iterations that only produce the start of a maximum-likelihood refinement.
    pub(crate) fn solve_with<T: Real, P: ReweightedProblem<T> + ?Sized>(
        &self,
        problem: &P,
        start: Option<&[T]>,
        gram: bool,
    ) -> Result<Solution<T>> {
        let tol = match self.tolerance {
            Some(t) => T::lit(t),
            None => num_traits::Float::sqrt(T::default_epsilon()),
        };
        let mut previous: Option<Vec<T>> = start.map(<[T]>::to_vec);
        // the start competes too: a re-weighted step must not make a good start worse
        let mut best: Option<(Vec<T>, T)> = start.map(|s| (s.to_vec(), problem.cost(s)));
        let mut last_cost: Option<T> = None;
        let ctol = T::lit(self.cost_tolerance);
        let solve_cost = super::work::solve_cost(problem.rows(), start.map_or(0, <[T]>::len));
        for it in 1..=self.max_iterations.max(1) {
            // a spent work budget stops the iteration at its best estimate (one solve at least)
            if it > 1 && best.is_some() && !super::work::charge(solve_cost) {
                let (theta, cost) = best.unwrap_or_default();
                return Ok(Solution {
                    theta,
                    cost,
                    iterations: it - 1,
                    termination: Termination::MaxIterations,
                });
            }
            let fast = if gram {
                problem.solve_normal_equations(previous.as_deref())
            } else {
                None
            };
            let theta = match fast {
                Some((theta, _)) => theta,
                None => {
                    let (a, b) = problem.system(previous.as_deref());
                    least_squares(a, b, self.rcond_eps)?.0.as_slice().to_vec()
                }
            };
            let cost = problem.cost(&theta);
            let change = previous.as_deref().map(|old| problem.change(old, &theta));
            if best.as_ref().is_none_or(|(_, c)| cost < *c) {
                best = Some((theta.clone(), cost));
            }
            let stalled = last_cost.is_some_and(|c| {
                num_traits::Float::abs(c - cost) <= ctol * num_traits::Float::max(c, cost)
            });
            last_cost = Some(cost);
            if let Some(ch) = change
                && (ch < tol || stalled)
            {
                let (theta, cost) = best.unwrap_or((theta, cost));
                return Ok(Solution {
                    theta,
                    cost,
                    iterations: it,
                    termination: Termination::Converged,
                });
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
