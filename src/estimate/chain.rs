//! The standard estimation chain Levy → Sanathanan–Koerner → ML, and the generic
//! [`estimate`] that composes any criterion with any solver that accepts its problem.

use crate::criterion::{Criterion, Levy, MaximumLikelihood, NoiseWeighting, SanathananKoerner};
use crate::data::{FrequencyData, Normalisation};
use crate::error::Result;
use crate::fit::{Fit, Stage, StageKind};
use crate::model::{EquationError, ModelStructure};
use crate::problem::NonlinearProblem;
use crate::scalar::Real;
use crate::solver::{
    Feasible, FixedPoint, GramLevenbergMarquardt, LevenbergMarquardt, LinearLeastSquares, Solution,
    Solver,
};

/// Minimises `criterion` for `model` on `data` with `solver`, from `start` where the solver
/// iterates. Only combinations where the solver accepts the criterion's problem compile:
///
/// ```compile_fail
/// use fdid::prelude::*;
/// use fdid::estimate::estimate;
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

/// What the linear stages of the chain leave: the Levy estimate (in the model's original
/// basis), the model after SK (relocated for a relocatable basis) with its estimate, the
/// stages, and whether the basis was relocated.
struct LinearStages<T: Real, M> {
    levy: Solution<T>,
    model: M,
    current: Vec<T>,
    stages: Vec<Stage<T>>,
    relocated: bool,
}

/// ML from `start`: the guarded normal-equation LM first, the crate's LM when it fails.
pub(crate) fn ml_solve<T: Real, P: NonlinearProblem<T> + ?Sized>(
    fast: &GramLevenbergMarquardt,
    lm: &LevenbergMarquardt,
    problem: &P,
    start: &[T],
) -> Result<Solution<T>> {
    fast.solve(problem, Some(start))
        .or_else(|_| lm.solve(problem, Some(start)))
}

/// `solve` on `problem` from `start`, restricted with `stable` to the θ where `model` is
/// stable ([`Feasible`], [`ModelStructure::stable_at`]) from a stable `start`; a solution
/// that is not stable (a solver that ended on a rejected trial point) is an error.
fn solve_in<T: Real, M: ModelStructure<T> + ?Sized>(
    model: &M,
    problem: &dyn NonlinearProblem<T>,
    start: &[T],
    stable: bool,
    solve: impl Fn(&dyn NonlinearProblem<T>, &[T]) -> Result<Solution<T>>,
) -> Result<Solution<T>> {
    if !stable || model.stable_at(start).is_none() {
        return solve(problem, start);
    }
    let constrained = Feasible::new(problem, |theta: &[T]| model.stable_at(theta) == Some(true));
    let sol = solve(&constrained, start)?;
    if model.stable_at(&sol.theta) == Some(true) {
        Ok(sol)
    } else {
        Err(crate::error::FdidError::NotConverged {
            method: "stability-constrained Levenberg–Marquardt",
            reason: "the solution left the stable region".into(),
        })
    }
}

/// [`ml_solve`], restricted with `stable` to the θ where `model` is stable
/// ([`solve_in`]).
pub(crate) fn ml_solve_in<T: Real, M: ModelStructure<T> + ?Sized, P: NonlinearProblem<T>>(
    fast: &GramLevenbergMarquardt,
    lm: &LevenbergMarquardt,
    model: &M,
    problem: &P,
    start: &[T],
    stable: bool,
) -> Result<Solution<T>> {
    solve_in(model, problem, start, stable, |p, s| {
        ml_solve(fast, lm, p, s)
    })
}

/// Iterates of [`gram_then_lm`] whose Gram matrix is refused that take damped steps before
/// the hand-over to [`LevenbergMarquardt`]. More lets low-order noise models finish in
/// normal-equation steps but sends order 20 down a longer path (noise model orders
/// 1 / 5 / 10 / 20 on 4 096 samples, `cargo bench --bench mckelvey -- noise_model`: 5 gives
/// 1.3 ms / 55 ms / 0.41 s / 1.26 s, 20 gave 1.3 ms / 26 ms / 0.20 s / 2.8 s).
const DAMPED_REFUSALS: usize = 5;

/// `fast` from `start` until it converges, reaches its cap, or its Gram matrix is refused
/// beyond [`DAMPED_REFUSALS`] iterates ([`GramLevenbergMarquardt::solve_to_refusal`]);
/// unless it converged, `lm` goes on from where it stopped (from `start` when `fast`
/// fails). The cheap
/// normal-equation steps make the first part of the way; MINPACK's QR copes with the
/// ill-conditioning an over-parameterised noise model has near its optimum.
fn gram_then_lm<T: Real, P: NonlinearProblem<T> + ?Sized>(
    fast: &GramLevenbergMarquardt,
    lm: &LevenbergMarquardt,
    problem: &P,
    start: &[T],
) -> Result<Solution<T>> {
    match fast.solve_to_refusal(problem, start, DAMPED_REFUSALS) {
        Ok((solution, false)) if solution.converged() => Ok(solution),
        Ok((so_far, _)) => {
            let mut solution = lm.solve(problem, Some(&so_far.theta))?;
            solution.iterations += so_far.iterations;
            Ok(solution)
        }
        Err(_) => lm.solve(problem, Some(start)),
    }
}

/// [`gram_then_lm`], restricted with `stable` to the θ where `model` is stable (as
/// [`ml_solve_in`]).
pub(crate) fn gram_then_lm_in<T: Real, M: ModelStructure<T> + ?Sized, P: NonlinearProblem<T>>(
    fast: &GramLevenbergMarquardt,
    lm: &LevenbergMarquardt,
    model: &M,
    problem: &P,
    start: &[T],
    stable: bool,
) -> Result<Solution<T>> {
    solve_in(model, problem, start, stable, |p, s| {
        gram_then_lm(fast, lm, p, s)
    })
}

/// `lm` on `problem` from `start`, restricted with `stable` to the θ where `model` is stable
/// (as [`ml_solve_in`], with the crate's Levenberg–Marquardt alone).
pub(crate) fn lm_solve_in<T: Real, M: ModelStructure<T> + ?Sized, P: NonlinearProblem<T>>(
    lm: &LevenbergMarquardt,
    model: &M,
    problem: &P,
    start: &[T],
    stable: bool,
) -> Result<Solution<T>> {
    solve_in(model, problem, start, stable, |p, s| lm.solve(p, Some(s)))
}

/// `theta` with its unstable poles reflected ([`ModelStructure::stabilised`]) when
/// `stable`, else unchanged.
pub(crate) fn stable_start<T: Real, M: ModelStructure<T> + ?Sized>(
    model: &M,
    theta: Vec<T>,
    stable: bool,
) -> Result<Vec<T>> {
    if !stable {
        return Ok(theta);
    }
    match model.stabilised(&theta) {
        Some(r) => r,
        None => Ok(theta),
    }
}

/// The level of the cost and whiteness tests below which [`Pipeline::fit`] takes a fit
/// for a possible local minimum.
const SUSPICIOUS_P: f64 = 0.01;

/// ML iterations from which [`Pipeline::fit`] takes the path from the start for long
/// enough to have crossed into another basin of the cost (typically 4–20 iterations from a
/// good start).
const LONG_ML: usize = 30;

/// Default of [`Pipeline::start_lines`]: when ML follows, Levy and SK run on at most about
/// this many lines of a longer record. Their estimate only starts ML, which runs on all
/// lines: on 2 048 of them it starts ML as well as on all (measured on 20 000-line records of
/// orders 4 and 10: the same optimum, one or two more ML iterations), at a cost that no longer
/// grows with the record.
pub const START_LINES: usize = 2_048;

/// Lines per coefficient that start ML as well as all lines: the linear stages of a model
/// of q coefficients run on at most max([`MIN_START_LINES`], 64·q) lines (and never more
/// than [`Pipeline::start_lines`]), so a low order starts from fewer lines than a high one.
pub const START_LINES_PER_COEFFICIENT: usize = 64;

/// The relative model change at which SK on the fewer lines of a long record counts as
/// converged, when [`FixedPoint::tolerance`] is left at its default (see [`Pipeline`]):
/// its estimate only starts a relocation on all lines and ML.
pub const FEWER_LINES_TOLERANCE: f64 = 1e-3;

/// The fewest lines the per-coefficient rule of [`START_LINES_PER_COEFFICIENT`] leaves the
/// linear stages.
pub const MIN_START_LINES: usize = 512;

/// Buffers of the Levy/SK solves of one fit.
struct LevyWork<T: Real> {
    weights: Option<Option<Vec<T>>>,
    regressor: nalgebra::DMatrix<crate::scalar::Complex<T>>,
    a: nalgebra::DMatrix<T>,
    b: nalgebra::DVector<T>,
    blocks: crate::linalg::gram::GramBlocks<T>,
}

impl<T: Real> Default for LevyWork<T> {
    fn default() -> Self {
        Self {
            weights: None,
            regressor: nalgebra::DMatrix::zeros(0, 0),
            a: nalgebra::DMatrix::zeros(0, 0),
            b: nalgebra::DVector::zeros(0),
            blocks: Default::default(),
        }
    }
}

/// Levy → Sanathanan–Koerner → maximum likelihood, each stage starting from the previous.
///
/// | setting | default | meaning |
/// |---|---|---|
/// | `weighting` | [`NoiseWeighting::Auto`] | line weights from the data's noise variances |
/// | `sk` | `Some(FixedPoint::default())` | SK iterations; `None` skips SK |
/// | `ml` | `Some(LevenbergMarquardt::default())` | ML refinement; `None` stops after SK |
/// | `linear` | [`LinearLeastSquares::default`] | the Levy solve |
/// | `restarts` | `true` | further starts on evidence of a local minimum |
/// | `stable` | `false` | a stable fit by construction (see below) |
/// | `start_lines` | `Some(`[`START_LINES`]`)` = 2 048 | when ML follows, the most lines Levy and SK run on, whatever the order (see below) |
///
/// If ML fails from the SK estimate it is retried from the Levy estimate (in the model's
/// original basis). When SK or ML stops at its iteration cap, two more ML starts are
/// tried — from the Levy estimate, and (for relocatable bases) from a Levy solve in the
/// basis of the ML poles with unstable ones reflected — and the lowest cost is kept.
///
/// **Further starts.** The ML cost of a rational model is not convex, and from the
/// automatic start ML ends in a local minimum on a fraction of high-order fits. With
/// `restarts`, the fit is checked for evidence of one:
/// - SK or ML stopped at its iteration cap, or ML needed 30 iterations or more (a long
///   path from the start through a non-convex cost);
/// - with known noise variances, the cost test (V against ½χ²(2N − p)) or the
///   whiteness test of [`Fit::validation`] below the 1 % level;
/// - the model's own checks in [`FurtherStarts::further_starts`] — for [`crate::Rational`]:
///   unstable poles, poles the data cannot resolve ([`Fit::unresolved_poles`]), a zero
///   within 10 % of a pole and inside its half-power band (|s_p − s_z| < |Re s_p|), a
///   pole the data barely determine (its standard deviation above half its distance from
///   the stability boundary, |Re s_p|); and a discrete-time model of denominator order
///   [`crate::estimate::multistart::DISCRETE_SEARCH_ORDER`] (9) or more, whatever the
///   evidence.
///
/// Only then does the model run its further starts (for [`crate::Rational`] of
/// denominator order up to [`crate::estimate::multistart::MAX_RESTART_ORDER`], those of
/// [`crate::estimate::multistart::fit_multistart`] or
/// [`crate::estimate::multistart::fit_multistart_discrete`], about ten fits' work, twice
/// that from order [`crate::estimate::multistart::RELOCATION_ORDER`] (5), where every pole
/// of the best fit is also moved in turn over the band; above
/// `MAX_RESTART_ORDER` the start at the resonances of the data alone, two fits' work), and the fit of
/// lowest cost is returned; a fit without such evidence costs what the chain costs, plus
/// the roots of its numerator and denominator.
///
/// **Start on fewer lines** (`start_lines`). When ML follows and the data have more than
/// L = min(`start_lines`, max([`MIN_START_LINES`], [`START_LINES_PER_COEFFICIENT`]·q))
/// lines, q the model's coefficients (L = 512 up to q = 8, as for order 4 over 2, and
/// 1 280 for order 10 over 8), Levy and SK run on every m-th line, m = ⌈N/L⌉ (the
/// highest line kept; all lines when that would leave fewer than twice the model's
/// coefficients): their estimate only starts ML, which runs on all lines, so the result
/// is the ML estimate of all the data either way, while the linear stages' cost no longer
/// grows with N. SK there counts as converged at a relative model change of
/// [`FEWER_LINES_TOLERANCE`] (10⁻³) unless [`FixedPoint::tolerance`] is set. Their
/// [`Stage::lines`](crate::fit::Stage::lines) records the lines they used (their costs are
/// on those). A relocatable basis then takes one more relocation on
/// all lines (an `sk` stage of one direct solve), which starts ML nearer its optimum and
/// builds the basis tables ML reads. When the fit from that start shows evidence of a local
/// minimum (the tests below), the chain runs again with the linear stages on all lines
/// and the lower cost is kept. The further starts of a long record then run on every
/// ⌈N/`start_lines`⌉-th line whatever the order (their ML too), and ML on all lines from
/// the best of them gives the fit that competes with this one (see [`FurtherStarts`] for
/// [`crate::Rational`]).
/// Without ML (`Pipeline::levy`, `Pipeline::sk`) every stage uses all lines.
///
/// **Stability** (`stable`, [`crate::estimate::Stability::Enforced`]). The estimate of
/// every linear stage (Levy, each relocation or SK iteration, the second starts' Levy
/// solves) has its unstable poles reflected into the stable region
/// ([`ModelStructure::stabilised`]: p ↦ −p̄ in s, p ↦ 1/p̄ in z, |G| on the frequency axis
/// unchanged), and ML is solved on the stable set only ([`Feasible`]: a step whose poles
/// are not all stable is rejected like one that raises the cost), so every iterate and the
/// result are stable; further starts are kept only when stable. For a structure without
/// poles ([`ModelStructure::stable_at`] `None`) the setting changes nothing.
///
/// **Speed.** When ML follows, it is solved first by [`GramLevenbergMarquardt`] (the step
/// from the guarded normal equations, with the tolerances of `ml`), falling back to the
/// crate's [`LevenbergMarquardt`] when that fails (ill-conditioned normal equations); and
/// the Levy and SK linear solves, which then only produce ML's start, use the guarded
/// normal equations too (for the partial-fraction relocations and for the re-weighted
/// iterations of [`FixedPoint`] alike), falling back to QR/SVD when the equilibrated Gram matrix is
/// ill-conditioned (see [`crate::solver`]'s `gram` kernels: κ₁ ≤ 10⁸ in f64, 10³ in f32).
/// Without ML (`Pipeline::levy`, `Pipeline::sk`) every solve is QR/SVD.
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
    /// After ML, the model's further starts ([`FurtherStarts::further_starts`]) when the fit
    /// shows evidence of a local minimum (see [`Pipeline::fit`]).
    pub restarts: bool,
    /// Keep every stage's estimate stable (see [`Pipeline`]).
    pub stable: bool,
    /// When ML follows, the most lines the linear stages run on (see [`Pipeline`]);
    /// `None`: all lines.
    pub start_lines: Option<usize>,
}

impl Default for Pipeline {
    fn default() -> Self {
        Self {
            weighting: NoiseWeighting::Auto,
            linear: LinearLeastSquares::default(),
            sk: Some(FixedPoint::default()),
            ml: Some(LevenbergMarquardt::default()),
            restarts: true,
            stable: false,
            start_lines: Some(START_LINES),
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

    /// Runs the chain on `model` and `data`, then (with `restarts` and ML) the model's
    /// further starts when the fit shows evidence of a local minimum (see [`Pipeline`]).
    /// Data far from order one (beyond 2^±16, [`Normalisation::of_far`]) are normalised by
    /// powers of two first and the fit mapped back ([`Fit::denormalised`]) when the model
    /// has a
    /// [`ModelStructure::normalisation_map`](crate::model::ModelStructure::normalisation_map),
    /// so the poles do not depend on the data's units.
    ///
    /// # Errors
    /// [`FdidError::ZeroOutput`](crate::FdidError::ZeroOutput) when the output is zero on
    /// every line; invalid data for the model, singular linear problems, numerical failure.
    pub fn fit<T: Real, M: FurtherStarts<T>>(
        &self,
        model: &M,
        data: &FrequencyData<T>,
    ) -> Result<Fit<T, M>> {
        data.check_output()?;
        // the model's own checks first (its size against the lines) bound the map's length
        model.check_data(data)?;
        let n = Normalisation::of_far(data);
        if !n.is_identity() && model.normalisation_map(n.output(), n.input()).is_some() {
            return self.fit_as_given(model, &n.apply(data))?.denormalised(&n);
        }
        self.fit_as_given(model, data)
    }

    /// [`Pipeline::fit`] without the normalisation.
    fn fit_as_given<T: Real, M: FurtherStarts<T>>(
        &self,
        model: &M,
        data: &FrequencyData<T>,
    ) -> Result<Fit<T, M>> {
        let (fit, suspicious) = self.run(model, data)?;
        Ok(match suspicious {
            Some(suspicious) if self.restarts => {
                match fit.model().further_starts(self, data, &fit, suspicious) {
                    Some(better)
                        if better.cost() < fit.cost()
                            && (!self.stable
                                || better.model().stable_at(better.theta()) != Some(false)) =>
                    {
                        better
                    }
                    _ => fit,
                }
            }
            _ => fit,
        })
    }

    /// The chain without the further starts of [`FurtherStarts`] (the starts of the
    /// multistart fits themselves), and with the linear stages on the lines of
    /// `start_lines` alone.
    pub(crate) fn chain<T: Real, M: EquationError<T> + Clone>(
        &self,
        model: &M,
        data: &FrequencyData<T>,
    ) -> Result<Fit<T, M>> {
        // the search's starts are many and often end in local minima: each on the lines of
        // `start_data` alone, without the second chain from all lines of `run`
        let fewer = self.start_data(model, data);
        self.run_from(model, data, fewer.as_ref())
            .map(|(fit, _)| fit)
    }

    /// The chain, with (when ML ran) the evidence that its fit may be a local minimum: a
    /// cap, a long ML path, or residuals the noise does not explain.
    fn run<T: Real, M: EquationError<T> + Clone>(
        &self,
        model: &M,
        data: &FrequencyData<T>,
    ) -> Result<(Fit<T, M>, Option<bool>)> {
        let Some(fewer) = self.start_data(model, data) else {
            return self.run_from(model, data, None);
        };
        let first = self.run_from(model, data, Some(&fewer));
        if let Ok((_, Some(false))) = &first {
            return first;
        }
        // evidence of a local minimum (or a failure) from the start on fewer lines: ML from
        // the linear stages on all lines too, the lower cost kept
        match (first, self.run_from(model, data, None)) {
            (Ok(a), Ok(b)) => Ok(if b.0.cost() < a.0.cost() { b } else { a }),
            (Ok(a), Err(_)) => Ok(a),
            (Err(_), b) => b,
        }
    }

    /// The most lines the linear stages of `model` run on when ML follows:
    /// min(`start_lines`, max([`MIN_START_LINES`], [`START_LINES_PER_COEFFICIENT`]·q)) for
    /// q coefficients; `None` without a limit.
    pub(crate) fn start_lines_for<T: Real, M: EquationError<T>>(&self, model: &M) -> Option<usize> {
        let per_coefficient = START_LINES_PER_COEFFICIENT
            .saturating_mul(model.n_coefficients())
            .max(MIN_START_LINES);
        self.start_lines.map(|most| most.min(per_coefficient))
    }

    /// The lines the linear stages run on when ML follows and the data have more than
    /// m = [`Pipeline::start_lines_for`] lines: every ⌈N/m⌉-th line, the highest kept;
    /// `None` (all lines) otherwise, or when those would be fewer than twice the model's
    /// coefficients.
    pub(crate) fn start_data<T: Real, M: EquationError<T>>(
        &self,
        model: &M,
        data: &FrequencyData<T>,
    ) -> Option<FrequencyData<T>> {
        self.fewer_lines(model, data, self.start_lines_for(model)?)
    }

    /// The lines the further starts of a long record run on
    /// ([`FurtherStarts::further_starts`] for [`crate::Rational`]): as
    /// [`Pipeline::start_data`] with at most `start_lines` lines, whatever the order. The
    /// starts search for another optimum, which a low order's few start lines can miss.
    pub(crate) fn search_data<T: Real, M: EquationError<T>>(
        &self,
        model: &M,
        data: &FrequencyData<T>,
    ) -> Option<FrequencyData<T>> {
        self.fewer_lines(model, data, self.start_lines?)
    }

    /// Every ⌈N/`most`⌉-th line of `data` when ML follows and N > `most` (`None`
    /// otherwise, or when they would be fewer than twice the model's coefficients).
    fn fewer_lines<T: Real, M: EquationError<T>>(
        &self,
        model: &M,
        data: &FrequencyData<T>,
        most: usize,
    ) -> Option<FrequencyData<T>> {
        if self.ml.is_none() || data.len() <= most {
            return None;
        }
        let (fewer, _) = data.every_nth_line(most)?;
        (fewer.len() >= 2 * model.n_coefficients()).then_some(fewer)
    }

    /// The linear stages on `fewer` lines (on all when `None`), their stages marked with
    /// the number of lines; after relocations on fewer lines, one more on all lines (see
    /// [`Pipeline::relocate_on_all`]).
    fn linear_stages_on<T: Real, M: EquationError<T> + Clone>(
        &self,
        model: &M,
        data: &FrequencyData<T>,
        fewer: Option<&FrequencyData<T>>,
        gram: bool,
    ) -> Result<LinearStages<T, M>> {
        let Some(fewer) = fewer else {
            return self.linear_stages(model, data, gram);
        };
        // SK there only starts the relocation on all lines: converged at a smaller change
        let start = Pipeline {
            sk: self.sk.map(|fp| FixedPoint {
                tolerance: fp.tolerance.or(Some(FEWER_LINES_TOLERANCE)),
                ..fp
            }),
            ..*self
        };
        let mut l = start.linear_stages(model, fewer, gram)?;
        for s in &mut l.stages {
            s.lines = Some(fewer.len());
        }
        if l.relocated
            && let Some(fp) = &self.sk
            && let Some((model, stage)) = self.relocate_on_all(&l.model, &l.current, data, fp, gram)
        {
            l.current = stage.solution.theta.clone();
            l.model = model;
            l.stages.push(stage);
        }
        Ok(l)
    }

    /// One relocation on all lines after those on fewer (the SK stage of a long record):
    /// the Levy solve in the basis of the fewer lines' poles. Its estimate starts ML from
    /// nearer the optimum (on the peers' order-4 and order-10 cases, 4 ML evaluations
    /// instead of 6), and its basis tables, built on ML's grid, serve ML. An SK stage of
    /// one direct solve, on all lines, with the output-error cost there; `None` when the
    /// basis or the solve fails (ML then starts from the fewer lines' estimate).
    fn relocate_on_all<T: Real, M: EquationError<T> + Clone>(
        &self,
        model: &M,
        theta: &[T],
        data: &FrequencyData<T>,
        fp: &FixedPoint,
        gram: bool,
    ) -> Option<(M, Stage<T>)> {
        let next = model.relocated(theta)?.ok()?;
        let linear = LinearLeastSquares {
            rcond_eps: fp.rcond_eps,
        };
        let mut work = LevyWork::default();
        let theta = if gram {
            self.levy_normal_equations(&next, data, &linear, &mut work, false)
                .ok()?
                .0
        } else {
            self.levy_solve(&next, data, &linear, &mut work, false)
                .ok()?
                .theta
        };
        let theta = stable_start(&next, theta, self.stable).ok()?;
        let weights = self.weighting.weights(data).ok()?;
        let mut out = crate::model::Output::new(data.len(), next.n_params());
        let cost = crate::criterion::output_error_cost_in(
            &mut out,
            &next,
            &theta,
            data,
            weights.as_deref(),
        );
        // (its buffers, of the record's length, serve the ML problem's next)
        out.recycle();
        if !num_traits::Float::is_finite(cost) {
            return None;
        }
        Some((
            next,
            Stage::new(
                StageKind::Sk,
                Solution {
                    theta,
                    cost,
                    iterations: 1,
                    termination: crate::solver::Termination::Direct,
                },
            ),
        ))
    }

    /// [`Pipeline::run`] with the linear stages on `fewer` lines (all when `None`).
    fn run_from<T: Real, M: EquationError<T> + Clone>(
        &self,
        model: &M,
        data: &FrequencyData<T>,
        fewer: Option<&FrequencyData<T>>,
    ) -> Result<(Fit<T, M>, Option<bool>)> {
        let w = self.weighting;
        let stable = self.stable;
        let original = model;
        let LinearStages {
            levy,
            model,
            mut current,
            mut stages,
            relocated,
        } = self.linear_stages_on(model, data, fewer, self.ml.is_some())?;
        if let Some(lm) = &self.ml {
            let ml = MaximumLikelihood { weighting: w };
            let fast = GramLevenbergMarquardt::from(*lm);
            // ML in another basis than `model`'s (the second starts)
            let solve_in = |m: &M, start: &[T]| -> Result<Solution<T>> {
                let problem = ml.problem(m, data)?;
                ml_solve_in(&fast, lm, m, &problem, start, stable)
            };
            let problem = ml.problem(&model, data)?;
            // (the relocation on all lines after those on fewer is a direct solve)
            let sk_capped = stages.iter().any(|s| !s.solution.converged());
            let first = ml_solve_in(&fast, lm, &model, &problem, &current, stable);
            // the Levy estimate belongs to the original basis
            let from_levy = || solve_in(original, &levy.theta);
            let suspicious = |a: &Solution<T>| sk_capped || !a.converged();
            // the basis the ML estimate belongs to, when it is not `model`'s
            let mut replaced: Option<M> = None;
            let capped = sk_capped || first.as_ref().is_ok_and(|a| !a.converged());
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
                        && let Ok(l2) = stable_start(&m2, l2.theta, stable)
                        && let Ok(b) = solve_in(&m2, &l2)
                        && b.cost < best.1.cost
                    {
                        best = (Some(m2), b);
                    }
                    replaced = best.0;
                    best.1
                }
                Ok(a) => a,
                Err(e) if current != levy.theta => {
                    if relocated {
                        replaced = Some(original.clone());
                    }
                    from_levy().map_err(|_| e)?
                }
                Err(e) => return Err(e),
            };
            // a cap, or a long way from the start through a non-convex cost
            let capped = capped || !best.converged() || best.iterations >= LONG_ML;
            current = best.theta.clone();
            stages.push(Stage::new(StageKind::Ml, best));
            let fit = match replaced {
                // the statistics from the ML problem's own work space
                None => Fit::from_ml_problem(model.clone(), data, current, &problem, stages)?,
                Some(m) => Fit::new(m, data, current, w, stages)?,
            };
            // evidence of a local minimum: a cap, or residuals the noise does not explain
            // (cost or whiteness test at the 1 % level; only with known noise variances)
            let v = fit.validation();
            let poor = v.cost_p.is_some_and(|p| p < SUSPICIOUS_P)
                || (fit.noise_known() && v.whiteness_p.is_some_and(|p| p < SUSPICIOUS_P));
            return Ok((fit, Some(capped || poor)));
        }
        Ok((Fit::new(model, data, current, w, stages)?, None))
    }

    /// Levy, then SK (by relocation for a relocatable basis) when the pipeline has it,
    /// each estimate stabilised with `stable`; with `gram` every solve by the guarded
    /// normal equations (QR/SVD when they are refused), else by QR/SVD.
    fn linear_stages<T: Real, M: EquationError<T> + Clone>(
        &self,
        model: &M,
        data: &FrequencyData<T>,
        gram: bool,
    ) -> Result<LinearStages<T, M>> {
        let mut work = LevyWork::default();
        let mut levy = self.levy_solve(model, data, &self.linear, &mut work, gram)?;
        let stable = self.stable;
        levy.theta = stable_start(model, levy.theta, stable)?;
        let mut stages = vec![Stage::new(StageKind::Levy, levy.clone())];
        let mut current = levy.theta.clone();
        let mut model = model.clone();
        let relocated = self.sk.is_some() && model.relocated(&levy.theta).is_some();
        if let (Some(fp), true) = (&self.sk, relocated) {
            let (m, sk) = self.relocate(model, data, levy.theta.clone(), fp, &mut work, gram)?;
            model = m;
            current = sk.theta.clone();
            stages.push(Stage::new(StageKind::Sk, sk));
        } else if let Some(fp) = &self.sk {
            let criterion = SanathananKoerner {
                weighting: self.weighting,
            };
            let problem = criterion.problem(&model, data)?;
            let mut sk = fp.solve_with(&problem, Some(&levy.theta), gram)?;
            sk.theta = stable_start(&model, sk.theta, stable)?;
            current = sk.theta.clone();
            stages.push(Stage::new(StageKind::Sk, sk));
        }
        Ok(LinearStages {
            levy,
            model,
            current,
            stages,
            relocated,
        })
    }

    /// The pipeline's linear stages (Levy, then SK when it has them; its ML is not run) as
    /// the start of another estimator, on the lines of `start_lines` (see [`Pipeline`]):
    /// every solve by the guarded normal equations
    /// (QR/SVD when they are refused) and no statistics of a [`Fit`]. Data far from order
    /// one are normalised first as by [`Pipeline::fit`], and the estimates mapped back.
    /// Returns the model (a partial-fraction basis relocated to the estimate's poles), θ
    /// and the stages.
    ///
    /// # Errors
    /// As [`Pipeline::fit`].
    pub(crate) fn linear_start<T: Real, M: EquationError<T> + Clone>(
        &self,
        model: &M,
        data: &FrequencyData<T>,
    ) -> Result<(M, Vec<T>, Vec<Stage<T>>)> {
        data.check_output()?;
        model.check_data(data)?;
        let n = Normalisation::of_far(data);
        let map = (!n.is_identity())
            .then(|| model.normalisation_map(n.output(), n.input()))
            .flatten();
        let Some(d) = map else {
            let fewer = self.start_data(model, data);
            let l = self.linear_stages_on(model, data, fewer.as_ref(), true)?;
            return Ok((l.model, l.current, l.stages));
        };
        let scaled = n.apply(data);
        let fewer = self.start_data(model, &scaled);
        let mut l = self.linear_stages_on(model, &scaled, fewer.as_ref(), true)?;
        let noise_known = self.weighting.weights(data)?.is_some();
        crate::fit::denormalise_theta(&mut l.current, &d);
        crate::fit::denormalise_stages(&mut l.stages, &d, n.cost_scale(noise_known));
        Ok((l.model, l.current, l.stages))
    }

    /// One Levy solve: through the guarded normal equations when ML follows (falling back
    /// to `linear`'s QR/SVD when they are ill-conditioned), else by `linear`. `work` holds
    /// the regressor and the real-stacked system, reused across the relocations so that the
    /// large buffers are allocated once per fit.
    fn levy_solve<T: Real, M: EquationError<T>>(
        &self,
        model: &M,
        data: &FrequencyData<T>,
        linear: &LinearLeastSquares,
        work: &mut LevyWork<T>,
        gram: bool,
    ) -> Result<Solution<T>> {
        let levy = Levy {
            weighting: self.weighting,
        };
        if !gram {
            return estimate(model, data, &levy, linear, None);
        }
        let (theta, cost) = self.levy_normal_equations(model, data, linear, work, true)?;
        Ok(Solution {
            theta,
            cost: cost.unwrap_or_else(T::zero),
            iterations: 1,
            termination: crate::solver::Termination::Direct,
        })
    }

    /// The Levy θ through the guarded normal equations (QR/SVD by `linear` when they are
    /// refused), and with `want_cost` its residual norm². Small systems are stacked in
    /// `work` and stay in cache; for large ones the Gram matrix is accumulated over blocks of
    /// lines whose rows of the regressor are formed one block at a time
    /// ([`EquationError::regressor_lines_into`]), so no N × q matrix is formed unless the
    /// QR fallback needs it.
    fn levy_normal_equations<T: Real, M: EquationError<T>>(
        &self,
        model: &M,
        data: &FrequencyData<T>,
        linear: &LinearLeastSquares,
        work: &mut LevyWork<T>,
        want_cost: bool,
    ) -> Result<(Vec<T>, Option<T>)> {
        use crate::linalg::gram;
        model.check_data(data)?;
        crate::criterion::check_input(data)?;
        if work.weights.is_none() {
            work.weights = Some(self.weighting.weights(data)?);
        }
        let (n, q) = (data.len(), model.n_coefficients());
        let norm = model.normalising_index();
        let max_cond = gram::max_condition::<T>();
        let stack = |work: &mut LevyWork<T>| {
            if work.regressor.shape() != (n, q) {
                work.regressor = nalgebra::DMatrix::zeros(n, q);
            }
            model.regressor_into(data, &mut work.regressor);
            crate::linalg::normalised_into(
                &work.regressor,
                work.weights.as_ref().and_then(|w| w.as_deref()),
                norm,
                &mut work.a,
                &mut work.b,
            );
        };
        let gram = if gram::small_problem(n, q) {
            stack(work);
            gram::least_squares_gram(&work.a, &work.b, max_cond).map(|(t, c)| (t, Some(c)))
        } else {
            let weights = work.weights.as_ref().and_then(|w| w.as_deref());
            let fill = |k0: usize, rows: &mut nalgebra::DMatrix<crate::scalar::Complex<T>>| {
                model.regressor_lines_into(data, k0, rows);
            };
            let blocks = &mut work.blocks;
            gram::lines_least_squares_gram(n, q, fill, weights, norm, max_cond, blocks).map(|t| {
                let cost = want_cost
                    .then(|| gram::lines_least_squares_cost(n, q, fill, weights, norm, &t, blocks));
                (t, cost)
            })
        };
        Ok(match gram {
            Some((theta, cost)) => (theta.as_slice().to_vec(), cost),
            None => {
                stack(work);
                let (theta, cost) =
                    crate::linalg::least_squares(work.a.clone(), work.b.clone(), linear.rcond_eps)?;
                (theta.as_slice().to_vec(), Some(cost))
            }
        })
    }

    /// Sanathanan–Koerner by basis relocation (vector fitting): a Levy solve in a basis
    /// whose poles are the previous estimate's, until the model stops changing (the tests
    /// of [`FixedPoint`]). Returns the lowest-cost model seen (the start included) in its
    /// basis and the estimate in it.
    fn relocate<T: Real, M: EquationError<T> + Clone>(
        &self,
        model: M,
        data: &FrequencyData<T>,
        theta: Vec<T>,
        fp: &FixedPoint,
        work: &mut LevyWork<T>,
        gram: bool,
    ) -> Result<(M, Solution<T>)> {
        let w = self.weighting;
        let tol = fp
            .tolerance
            .map_or_else(|| num_traits::Float::sqrt(T::default_epsilon()), T::lit);
        let ctol = T::lit(fp.cost_tolerance);
        let weights = w.weights(data)?;
        // one set of response buffers for every iterate: G of the latest in `g_old`
        let mut out = crate::model::Output::new(data.len(), model.n_params());
        let mut oe_cost = |m: &M, theta: &[T], g: &mut Vec<crate::scalar::Complex<T>>| {
            let cost = crate::criterion::output_error_cost_in(
                &mut out,
                m,
                theta,
                data,
                weights.as_deref(),
            );
            std::mem::swap(&mut out.g, g);
            cost
        };
        let mut g_old = vec![];
        let mut cost = oe_cost(&model, &theta, &mut g_old);
        let mut g_new = vec![];
        // the best iterate, and the latest when it is not the best (moved, not cloned, so
        // that the model keeps its basis tables for the ML stage)
        let mut best = (model, theta, cost);
        let mut latest: Option<(M, Vec<T>)> = None;
        let linear = LinearLeastSquares {
            rcond_eps: fp.rcond_eps,
        };
        for it in 1..=fp.max_iterations.max(1) {
            // no basis from the estimate's poles (two met, or one is not finite): the
            // iteration ends with the best model seen, as when it stalls
            let (from, from_theta) = latest.as_ref().map_or((&best.0, &best.1), |l| (&l.0, &l.1));
            let Some(Ok(next)) = from.relocated(from_theta) else {
                break;
            };
            // only θ is needed: the SK cost is the output-error one
            let next_theta = if gram {
                self.levy_normal_equations(&next, data, &linear, work, false)?
                    .0
            } else {
                self.levy_solve(&next, data, &linear, work, false)?.theta
            };
            let next_theta = stable_start(&next, next_theta, self.stable)?;
            let new_cost = oe_cost(&next, &next_theta, &mut g_new);
            let change = crate::criterion::relative_change(&g_old, &g_new);
            let stalled = num_traits::Float::abs(new_cost - cost)
                <= ctol * num_traits::Float::max(new_cost, cost);
            cost = new_cost;
            std::mem::swap(&mut g_old, &mut g_new);
            if cost < best.2 {
                best = (next, next_theta, cost);
                latest = None;
            } else {
                latest = Some((next, next_theta));
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

/// Structures whose fits [`Pipeline::fit`] may search from further starts.
///
/// The ML cost of a rational model is not convex: from the chain's automatic start a
/// fraction of high-order fits end in a local minimum. After the chain, [`Pipeline::fit`]
/// hands its fit to [`FurtherStarts::further_starts`] with the chain's own evidence of a
/// local minimum; the structure may add its own checks and run a search. The default has
/// no further starts, so a user's [`EquationError`] structure needs only
/// `impl FurtherStarts<f64> for MyModel {}`; [`crate::model::Rational`] runs the searches
/// of [`crate::estimate::multistart`].
pub trait FurtherStarts<T: Real>: EquationError<T> + Clone {
    /// The lowest-cost fit that further starts reach, or `None` when this structure has
    /// no further starts or judges `fit` not worth them. `suspicious` carries the chain's
    /// evidence that `fit` may be a local minimum (Sanathanan–Koerner or ML at its
    /// iteration cap, a long ML path, a cost the noise does not explain).
    fn further_starts(
        &self,
        pipeline: &Pipeline,
        data: &FrequencyData<T>,
        fit: &Fit<T, Self>,
        suspicious: bool,
    ) -> Option<Fit<T, Self>> {
        let _ = (pipeline, data, fit, suspicious);
        None
    }
}
