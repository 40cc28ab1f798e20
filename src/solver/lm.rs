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
///
/// It hands the crate a compressed problem of p + 1 residuals: at each point θ it
/// evaluates r and J together, factors J = QR by Householder reflections and returns
/// r̃ = [Q₁ᵀr; ‖Q₂ᵀr‖] with the Jacobian J̃ = [R; 0]. Then ‖r̃‖ = ‖r‖, J̃ᵀJ̃ = JᵀJ,
/// J̃ᵀr̃ = Jᵀr and ‖r̃ + J̃δ‖ = ‖r + Jδ‖ for every step δ, and the column norms are J's:
/// the crate's iteration (steps, trust region, ratio and convergence tests) is the one
/// on (r, J), while its pivoted QR factors a (p + 1) × p matrix instead of an m × p one.
/// (Problems with m ≤ p + 1 are handed over as they are.)
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
    /// The compressed Jacobian J̃ of the last point whose residuals were evaluated, with
    /// that point (`None` when that evaluation failed).
    compressed: std::cell::RefCell<Option<(DVector<T>, DMatrix<T>)>>,
}

impl<T: Real, P: NonlinearProblem<T> + ?Sized> Adapter<'_, T, P> {
    /// Whether the adapter hands the crate the compressed problem.
    fn compresses(&self) -> bool {
        self.problem.n_residuals() > self.problem.n_params() + 1
    }

    /// r̃ and J̃ at the current point (see the type's docs), or `None` when r or J is not
    /// finite; r's cost is offered to `best`.
    fn compressed_at(&self) -> Option<(DVector<T>, DMatrix<T>)> {
        let (m, p) = (self.problem.n_residuals(), self.problem.n_params());
        let mut r = DVector::zeros(m);
        let mut jac = DMatrix::zeros(m, p);
        if !self
            .problem
            .jacobian_into(self.x.as_slice(), r.as_mut_slice(), &mut jac)
        {
            return None;
        }
        self.offer(r.norm_squared());
        let qr = jac.qr();
        qr.q_tr_mul(&mut r);
        let mut rt = DVector::zeros(p + 1);
        rt.rows_mut(0, p).copy_from(&r.rows(0, p));
        rt[p] = r.rows(p, m - p).norm();
        let mut jt = DMatrix::zeros(p + 1, p);
        jt.view_mut((0, 0), (p, p)).copy_from(&qr.r());
        if !(rt
            .iter()
            .chain(jt.iter())
            .all(|v| num_traits::Float::is_finite(*v)))
        {
            return None;
        }
        Some((rt, jt))
    }

    /// Records the current point when its cost is the lowest evaluated.
    fn offer(&self, cost: T) {
        let mut best = self.best.borrow_mut();
        if best.as_ref().is_none_or(|(c, _)| cost < *c) {
            *best = Some((cost, self.x.as_slice().to_vec()));
        }
    }

    /// Residuals that make a step into a region where the model blows up unattractive, so
    /// that the trust region shrinks rather than the iteration aborting.
    fn blown_up(len: usize) -> DVector<T> {
        let big = num_traits::Float::sqrt(<T as num_traits::Float>::max_value()) / T::lit(1e3);
        DVector::from_element(len, big / T::from_usize_lossy(len.max(1)))
    }
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
        if self.compresses() {
            let (rt, kept) = match self.compressed_at() {
                Some((rt, jt)) => (rt, Some((self.x.clone(), jt))),
                None => (Self::blown_up(self.problem.n_params() + 1), None),
            };
            *self.compressed.borrow_mut() = kept;
            return Some(rt);
        }
        let mut r = DVector::zeros(self.problem.n_residuals());
        if self
            .problem
            .residuals_into(self.x.as_slice(), r.as_mut_slice())
        {
            self.offer(r.norm_squared());
            Some(r)
        } else {
            Some(Self::blown_up(r.len()))
        }
    }

    fn jacobian(&self) -> Option<DMatrix<T>> {
        if self.compresses() {
            // the crate asks for J̃ at the point whose residuals it last evaluated
            return match self.compressed.borrow().as_ref() {
                Some((x, jt)) if *x == self.x => Some(jt.clone()),
                _ => self.compressed_at().map(|(_, jt)| jt),
            };
        }
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
            compressed: std::cell::RefCell::new(None),
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

    /// r = Aθ − b with the monomials tᵏ on [0, 1] for the columns of A: an
    /// ill-conditioned linear problem (κ(A) ≈ 10⁷ for p = 10).
    struct Monomials {
        a: DMatrix<f64>,
        b: DVector<f64>,
    }

    impl Monomials {
        fn new(m: usize, p: usize, theta: &[f64]) -> Self {
            let a = DMatrix::from_fn(m, p, |i, k| (i as f64 / (m - 1) as f64).powi(k as i32));
            let b = &a * DVector::from_column_slice(theta);
            Self { a, b }
        }
    }

    impl NonlinearProblem<f64> for Monomials {
        fn n_params(&self) -> usize {
            self.a.ncols()
        }
        fn n_residuals(&self) -> usize {
            self.a.nrows()
        }
        fn residuals_into(&self, theta: &[f64], r: &mut [f64]) -> bool {
            let v = &self.a * DVector::from_column_slice(theta) - &self.b;
            r.copy_from_slice(v.as_slice());
            true
        }
        fn jacobian_into(&self, theta: &[f64], r: &mut [f64], jac: &mut DMatrix<f64>) -> bool {
            jac.copy_from(&self.a);
            self.residuals_into(theta, r)
        }
    }

    #[test]
    fn the_compressed_problem_keeps_the_accuracy_of_a_qr_solve() {
        // κ(A) ≈ 4·10⁶: normal equations would lose about 13 digits (an error near 10⁻³),
        // QR about 7
        let truth = [1.0, -2.0, 3.0, 0.5, -1.5, 2.5, -0.75, 1.25, 2.0, -1.0];
        let problem = Monomials::new(60, truth.len(), &truth);
        let sv = problem.a.clone().svd(false, false).singular_values;
        let kappa = sv.max() / sv.min();
        assert!(kappa > 1e6, "condition {kappa:e}");
        let sol = LevenbergMarquardt::default()
            .solve(&problem, Some(&[0.0; 10]))
            .unwrap();
        let err = truth
            .iter()
            .zip(&sol.theta)
            .map(|(t, x)| (t - x).abs())
            .fold(0.0, f64::max);
        assert!(
            err <= 10.0 * kappa * f64::EPSILON,
            "error {err:e}, κ {kappa:e}"
        );
        assert!(sol.cost <= 1e-20, "cost {:e}", sol.cost);
    }

    #[test]
    fn small_problems_are_handed_over_as_they_are() {
        // m = p + 1: nothing to compress; the solution still solves the problem
        let truth = [1.0, -2.0, 3.0];
        let problem = Monomials::new(4, 3, &truth);
        let sol = LevenbergMarquardt::default()
            .solve(&problem, Some(&[0.0; 3]))
            .unwrap();
        for (t, x) in truth.iter().zip(&sol.theta) {
            assert!((t - x).abs() <= 1e-10, "{x} vs {t}");
        }
    }

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
