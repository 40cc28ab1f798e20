//! Levenberg–Marquardt through the `levenberg-marquardt` crate.

use super::{Solution, Solver, Termination};
use crate::error::{FdidError, Result};
use crate::problem::NonlinearProblem;
use crate::scalar::Real;
use levenberg_marquardt::{LeastSquaresProblem, TerminationReason};
use nalgebra::{DMatrix, DVector, Dyn, Owned};

/// Levenberg–Marquardt (MINPACK's trust-region variant, via the `levenberg-marquardt`
/// crate) on the real-stacked residuals of a [`NonlinearProblem`]. Needs a start.
///
/// | setting | default | meaning |
/// |---|---|---|
/// | `tolerance` | 30 ε | relative size of the step (xtol) that counts as converged |
/// | `cost_tolerance` | max(1e-10, 30 ε) | relative reduction of the cost (actual and predicted, ftol) that counts as converged: far below any statistically meaningful change of an ML cost, yet it spares the last iterations on noisy data |
/// | `patience` | 100 | at most `patience·(p + 1)` residual evaluations |
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevenbergMarquardt {
    /// Step tolerance (`None`: 30 ε of the scalar type).
    pub tolerance: Option<f64>,
    /// Relative cost-reduction tolerance (`None`: max(1e-10, 30 ε)).
    pub cost_tolerance: Option<f64>,
    /// Evaluation budget factor.
    pub patience: usize,
}

impl Default for LevenbergMarquardt {
    fn default() -> Self {
        Self {
            tolerance: None,
            cost_tolerance: None,
            patience: 100,
        }
    }
}

impl LevenbergMarquardt {
    /// Validates the start (present, `p` long, finite) and the size `m ≥ p` of the
    /// problem, and returns the step and cost-reduction tolerances.
    pub(crate) fn checked<T: Real>(
        &self,
        start: Option<&[T]>,
        p: usize,
        m: usize,
    ) -> Result<(T, T)> {
        let start = start.ok_or(FdidError::InvalidArgument {
            name: "start",
            value: "none".into(),
            reason: "Levenberg–Marquardt needs a starting point (e.g. from SK)".into(),
        })?;
        if start.len() != p {
            return Err(FdidError::LengthMismatch {
                what: "start",
                expected: p,
                got: start.len(),
            });
        }
        crate::error::check_finite("start", start)?;
        if m < p {
            return Err(FdidError::TooFewFrequencies {
                lines: m / 2,
                equations: m,
                parameters: p,
            });
        }
        let floor = T::default_epsilon() * T::lit(30.0);
        let setting = |name: &'static str, v: Option<f64>, default: T| -> Result<T> {
            match v {
                None => Ok(default),
                Some(x) if x.is_finite() && x > 0.0 => Ok(T::lit(x)),
                Some(x) => Err(FdidError::InvalidArgument {
                    name,
                    value: format!("{x}"),
                    reason: "a tolerance must be positive and finite".into(),
                }),
            }
        };
        let tol = setting("tolerance", self.tolerance, floor)?;
        let ftol = setting(
            "cost_tolerance",
            self.cost_tolerance,
            num_traits::Float::max(T::lit(1e-10), floor),
        )?;
        Ok((tol, ftol))
    }
}

/// The adapter the crate's stateful trait needs; kept private.
struct Adapter<'p, T: Real, P: ?Sized> {
    problem: &'p P,
    x: DVector<T>,
    evaluations: std::cell::Cell<usize>,
    /// The cost of one evaluation for the work budget ([`super::work`]).
    evaluation_cost: f64,
    /// Set when an evaluation was refused because the work budget was spent.
    spent: std::cell::Cell<bool>,
    /// The point of lowest cost evaluated, with its cost.
    best: std::cell::RefCell<Option<(T, Vec<T>)>>,
}

impl<T: Real, P: NonlinearProblem<T> + ?Sized> LeastSquaresProblem<T, Dyn, Dyn>
    for Adapter<'_, T, P>
{
    type ResidualStorage = Owned<T, Dyn>;
    type JacobianStorage = Owned<T, Dyn, Dyn>;
    type ParameterStorage = Owned<T, Dyn>;

    fn set_params(&mut self, x: &DVector<T>) {
        self.x.copy_from(x);
    }

    fn params(&self) -> DVector<T> {
        self.x.clone()
    }

    fn residuals(&self) -> Option<DVector<T>> {
        if !super::work::charge(self.evaluation_cost) {
            self.spent.set(true);
            return None;
        }
        self.evaluations.set(self.evaluations.get() + 1);
        let mut r = DVector::zeros(self.problem.n_residuals());
        if self
            .problem
            .residuals_into(self.x.as_slice(), r.as_mut_slice())
        {
            let cost = r.norm_squared();
            let mut best = self.best.borrow_mut();
            if best.as_ref().is_none_or(|(c, _)| cost < *c) {
                *best = Some((cost, self.x.as_slice().to_vec()));
            }
        } else {
            // a step into a region where the model blows up: make it unattractive so the
            // trust region shrinks, rather than aborting
            let big = num_traits::Float::sqrt(<T as num_traits::Float>::max_value()) / T::lit(1e3);
            r.fill(big / T::from_usize_lossy(r.len().max(1)));
        }
        Some(r)
    }

    fn jacobian(&self) -> Option<DMatrix<T>> {
        let (m, p) = (self.problem.n_residuals(), self.problem.n_params());
        let mut r = vec![T::zero(); m];
        let mut jac = DMatrix::zeros(m, p);
        if self
            .problem
            .jacobian_into(self.x.as_slice(), &mut r, &mut jac)
        {
            Some(jac)
        } else {
            None
        }
    }
}

impl<T: Real, P: NonlinearProblem<T> + ?Sized> Solver<T, P> for LevenbergMarquardt {
    fn solve(&self, problem: &P, start: Option<&[T]>) -> Result<Solution<T>> {
        let (tol, ftol) = self.checked(start, problem.n_params(), problem.n_residuals())?;
        let start = start.unwrap_or_default();
        // xtol = tol, gtol = 0 as MINPACK's LMDER1; ftol separately
        let lm = levenberg_marquardt::LevenbergMarquardt::new()
            .with_tol(tol)
            .with_ftol(ftol)
            .with_patience(self.patience.max(1));
        let adapter = Adapter {
            problem,
            x: DVector::from_column_slice(start),
            evaluations: std::cell::Cell::new(0),
            evaluation_cost: super::work::solve_cost(problem.n_residuals(), problem.n_params()),
            spent: std::cell::Cell::new(false),
            best: std::cell::RefCell::new(None),
        };
        let (adapter, report) = lm.minimize(adapter);
        let termination = if adapter.spent.get() {
            // stopped by the work budget: the best point evaluated (the start if none)
            TerminationReason::LostPatience
        } else {
            report.termination
        };
        let theta = if adapter.spent.get() {
            adapter
                .best
                .into_inner()
                .map_or_else(|| start.to_vec(), |(_, x)| x)
        } else {
            adapter.x.as_slice().to_vec()
        };
        let termination = match termination {
            TerminationReason::ResidualsZero
            | TerminationReason::Orthogonal
            | TerminationReason::Converged { .. }
            | TerminationReason::NoImprovementPossible(_) => Termination::Converged,
            TerminationReason::LostPatience => Termination::MaxIterations,
            other => {
                return Err(FdidError::NotConverged {
                    method: "Levenberg–Marquardt",
                    reason: termination_text(&other),
                });
            }
        };
        let mut r = vec![T::zero(); problem.n_residuals()];
        if !problem.residuals_into(&theta, &mut r) {
            return Err(FdidError::Numerical {
                what: "model response at the Levenberg–Marquardt solution".into(),
            });
        }
        Ok(Solution {
            cost: r.iter().fold(T::zero(), |s, v| s + *v * *v),
            theta,
            iterations: adapter.evaluations.get(),
            termination,
        })
    }
}

/// Why the Levenberg–Marquardt iteration stopped, in words (not the crate's `Debug` text).
fn termination_text(reason: &TerminationReason) -> String {
    match reason {
        TerminationReason::Numerical(_) => "a numerical failure in a step: the model's \
                                             response or Jacobian became non-finite or singular"
            .into(),
        TerminationReason::User(_) => "stopped by the problem".into(),
        TerminationReason::NoParameters => "the problem has no parameters".into(),
        TerminationReason::NoResiduals => "the problem has no residuals".into(),
        TerminationReason::WrongDimensions(_) => "the residual and Jacobian sizes disagree".into(),
        TerminationReason::ResidualsZero
        | TerminationReason::Orthogonal
        | TerminationReason::Converged { .. }
        | TerminationReason::NoImprovementPossible(_) => "converged".into(),
        TerminationReason::LostPatience => "the evaluation budget was used up".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn terminations_are_told_in_words() {
        for reason in [
            TerminationReason::Numerical("subproblem ||Dp||"),
            TerminationReason::User("x"),
            TerminationReason::WrongDimensions("jacobian"),
            TerminationReason::NoParameters,
        ] {
            let text = termination_text(&reason);
            assert!(!text.contains("||") && !text.contains('('), "{text}");
        }
    }
}
