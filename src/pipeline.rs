//! The standard estimation chain Levy → Sanathanan–Koerner → ML, and the generic
//! [`estimate`] that composes any criterion with any solver that accepts its problem.

use crate::Real;
use crate::criterion::{Criterion, Levy, MaximumLikelihood, NoiseWeighting, SanathananKoerner};
use crate::data::FrequencyData;
use crate::error::Result;
use crate::fit::{Fit, Stage};
use crate::model::EquationError;
use crate::solver::{FixedPoint, LevenbergMarquardt, LinearLeastSquares, Solution, Solver};

/// Minimises `criterion` for `model` on `data` with `solver`, from `start` where the solver
/// iterates. Only combinations where the solver accepts the criterion's problem compile:
///
/// ```compile_fail
/// use fdid::prelude::*;
/// use fdid::pipeline::estimate;
/// let data = FrequencyData::<f64>::from_frf(vec![1.0, 2.0], vec![Complex::new(1.0, 0.0); 2], None).unwrap();
/// let model = Rational::continuous(1, 0, data.omega()).unwrap();
/// // Levy is a linear problem: Levenberg–Marquardt does not accept it
/// let _ = estimate(&model, &data, &Levy::default(), &LevenbergMarquardt::default(), None);
/// ```
///
/// # Errors
/// As the criterion's [`Criterion::problem`] and the solver's [`Solver::solve`].
pub fn estimate<'a, T, M, C, S>(
    model: &'a M,
    data: &'a FrequencyData<T>,
    criterion: &'a C,
    solver: &S,
    start: Option<&[T]>,
) -> Result<Solution<T>>
where
    T: Real,
    M: ?Sized,
    C: Criterion<T, M>,
    S: Solver<T, C::Problem<'a>>,
{
    let problem = criterion.problem(model, data)?;
    solver.solve(&problem, start)
}

/// Levy → Sanathanan–Koerner → maximum likelihood, each stage starting from the previous.
///
/// | setting | default | meaning |
/// |---|---|---|
/// | `weighting` | [`NoiseWeighting::Auto`] | line weights from the data's noise variances |
/// | `sk` | `Some(FixedPoint::default())` | SK iterations; `None` skips SK |
/// | `ml` | `Some(LevenbergMarquardt::default())` | ML refinement; `None` stops after SK |
/// | `linear` | [`LinearLeastSquares::default`] | the Levy solve |
///
/// If ML fails from the SK estimate it is retried from the Levy estimate (in the model's
/// original basis). When SK or ML stops at its iteration cap, two more ML starts are
/// tried — from the Levy estimate, and (for relocatable bases) from a Levy solve in the
/// basis of the ML poles with unstable ones reflected — and the lowest cost is kept.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pipeline {
    /// Line weighting used by every stage.
    pub weighting: NoiseWeighting,
    /// The Levy solve.
    pub linear: LinearLeastSquares,
    /// SK iterations (`None`: skip).
    pub sk: Option<FixedPoint>,
    /// ML refinement (`None`: skip).
    pub ml: Option<LevenbergMarquardt>,
}

impl Default for Pipeline {
    fn default() -> Self {
        Self {
            weighting: NoiseWeighting::Auto,
            linear: LinearLeastSquares::default(),
            sk: Some(FixedPoint::default()),
            ml: Some(LevenbergMarquardt::default()),
        }
    }
}

impl Pipeline {
    /// Only Levy.
    pub fn levy() -> Self {
        Self {
            sk: None,
            ml: None,
            ..Self::default()
        }
    }

    /// Levy then SK.
    pub fn sk() -> Self {
        Self {
            ml: None,
            ..Self::default()
        }
    }

    /// Runs the chain on `model` and `data`.
    ///
    /// # Errors
    /// Invalid data for the model, singular linear problems, numerical failure.
    pub fn fit<T: Real, M: EquationError<T> + Clone>(
        &self,
        model: &M,
        data: &FrequencyData<T>,
    ) -> Result<Fit<T, M>> {
        let w = self.weighting;
        let levy = estimate(model, data, &Levy { weighting: w }, &self.linear, None)?;
        let mut stages = vec![Stage {
            name: "levy".into(),
            solution: levy.clone(),
        }];
        let mut current = levy.theta.clone();
        let original = model;
        let mut model = model.clone();
        let relocated = self.sk.is_some() && model.relocated(&levy.theta).is_some();
        if let (Some(fp), true) = (&self.sk, relocated) {
            let (m, sk) = self.relocate(model, data, levy.theta.clone(), fp)?;
            model = m;
            current = sk.theta.clone();
            stages.push(Stage {
                name: "sk".into(),
                solution: sk,
            });
        } else if let Some(fp) = &self.sk {
            let sk = estimate(
                &model,
                data,
                &SanathananKoerner { weighting: w },
                fp,
                Some(&levy.theta),
            )?;
            current = sk.theta.clone();
            stages.push(Stage {
                name: "sk".into(),
                solution: sk,
            });
        }
        if let Some(lm) = &self.ml {
            let ml = MaximumLikelihood { weighting: w };
            let sk_capped = stages.last().is_some_and(|s| !s.solution.converged());
            let first = estimate(&model, data, &ml, lm, Some(&current));
            // the Levy estimate belongs to the original basis
            let from_levy = || estimate(original, data, &ml, lm, Some(&levy.theta));
            let suspicious = |a: &Solution<T>| sk_capped || !a.converged();
            let best = match first {
                Ok(a) if suspicious(&a) && current != levy.theta => {
                    // SK or ML stopped at its cap: typically the relocation traded a
                    // heavily damped pole for a spurious lightly damped one. Second starts:
                    // ML from the Levy estimate, and (relocatable bases) one relocation to
                    // the ML poles with unstable ones reflected, then ML; the lowest cost wins
                    let mut best = (None, a);
                    if let Ok(b) = from_levy()
                        && b.cost < best.1.cost
                    {
                        best = (relocated.then(|| original.clone()), b);
                    }
                    // relocated from the basis the best estimate belongs to
                    if let Some(Ok(m2)) = best.0.as_ref().unwrap_or(&model).relocated(&best.1.theta)
                        && let Ok(l2) =
                            estimate(&m2, data, &Levy { weighting: w }, &self.linear, None)
                        && let Ok(b) = estimate(&m2, data, &ml, lm, Some(&l2.theta))
                        && b.cost < best.1.cost
                    {
                        best = (Some(m2), b);
                    }
                    if let Some(m) = best.0 {
                        model = m;
                    }
                    best.1
                }
                Ok(a) => a,
                Err(e) if current != levy.theta => {
                    if relocated {
                        model = original.clone();
                    }
                    from_levy().map_err(|_| e)?
                }
                Err(e) => return Err(e),
            };
            current = best.theta.clone();
            stages.push(Stage {
                name: "ml".into(),
                solution: best,
            });
        }
        Fit::new(model, data, current, w, stages)
    }

    /// Sanathanan–Koerner by basis relocation (vector fitting): a Levy solve in a basis
    /// whose poles are the previous estimate's, until the model stops changing (the tests
    /// of [`FixedPoint`]). Returns the lowest-cost model seen (the start included) in its
    /// basis and the estimate in it.
    fn relocate<T: Real, M: EquationError<T> + Clone>(
        &self,
        mut model: M,
        data: &FrequencyData<T>,
        mut theta: Vec<T>,
        fp: &FixedPoint,
    ) -> Result<(M, Solution<T>)> {
        let w = self.weighting;
        let tol = fp
            .tolerance
            .map_or_else(|| num_traits::Float::sqrt(T::default_epsilon()), T::lit);
        let ctol = T::lit(fp.cost_tolerance);
        let weights = w.weights(data)?;
        let oe_cost = |m: &M, theta: &[T]| {
            crate::criterion::output_error_cost(m, theta, data, weights.as_deref())
        };
        let (mut cost, mut g_old) = oe_cost(&model, &theta);
        let mut best = (model.clone(), theta.clone(), cost);
        let linear = LinearLeastSquares {
            rcond_eps: fp.rcond_eps,
        };
        for it in 1..=fp.max_iterations.max(1) {
            let Some(next) = model.relocated(&theta) else {
                break;
            };
            let next = next?;
            let sol = estimate(&next, data, &Levy { weighting: w }, &linear, None)?;
            let (new_cost, g_new) = oe_cost(&next, &sol.theta);
            let change = crate::criterion::relative_change(&g_old, &g_new);
            let stalled = num_traits::Float::abs(new_cost - cost)
                <= ctol * num_traits::Float::max(new_cost, cost);
            model = next;
            theta = sol.theta;
            cost = new_cost;
            g_old = g_new;
            if cost < best.2 {
                best = (model.clone(), theta.clone(), cost);
            }
            if change < tol || stalled {
                let (model, theta, cost) = best;
                return Ok((
                    model,
                    Solution {
                        theta,
                        cost,
                        iterations: it,
                        termination: crate::solver::Termination::Converged,
                    },
                ));
            }
        }
        let (model, theta, cost) = best;
        Ok((
            model,
            Solution {
                theta,
                cost,
                iterations: fp.max_iterations.max(1),
                termination: crate::solver::Termination::MaxIterations,
            },
        ))
    }
}
