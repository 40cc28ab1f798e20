//! Errors-in-variables fits (McKelvey eq. 42): the output-error chain gives the start,
//! then Levenberg–Marquardt minimises the errors-in-variables cost.

use super::{FurtherStarts, Pipeline};
use crate::criterion::{Criterion, ErrorsInVariables};
use crate::data::FrequencyData;
use crate::error::Result;
use crate::fit::{Fit, NoiseLevel, Stage, StageKind};
use crate::model::{Delayed, ModelStructure};
use crate::scalar::Real;

/// Fits `model` to errors-in-variables data: `pipeline` (Levy → SK → output-error ML
/// weighted by var_y, eq. 23) gives the start, then Levenberg–Marquardt (the pipeline's
/// `ml` settings, or the defaults when it has none) minimises the errors-in-variables cost
/// of eq. 42 ([`ErrorsInVariables`] with the covariance term). The result's statistics are
/// those of the eq. 42 residuals with known noise level (λ = 1): Cov θ̂ = ½(JᵀJ)⁻¹; its
/// stages end with `"eiv"`. The model of the result is the pipeline's (its basis may have
/// been moved to the estimated poles).
///
/// # Errors
/// As [`Criterion::problem`] for [`ErrorsInVariables`] (checked before the pipeline runs:
/// no noise variances, e.g. one period; zero input noise; invalid covariances), then as
/// [`Pipeline::fit`] and the solver.
pub fn fit_eiv<T: Real, M: FurtherStarts<T>>(
    pipeline: &Pipeline,
    model: &M,
    data: &FrequencyData<T>,
) -> Result<Fit<T, M>> {
    let eiv = ErrorsInVariables::default();
    // validate first, so that an unsuitable data set gets the errors-in-variables message
    drop(eiv.problem(model, data)?);
    refine_eiv(pipeline, &pipeline.fit(model, data)?, data)
}

/// [`fit_eiv`] of a delayed model G_M e^{−iωτ}: [`Delayed::fit`] (delay search, pipeline,
/// output-error ML) gives the start, then the errors-in-variables cost of eq. 42 is
/// minimised over [θ_M, τ]; a fitted τ̂ outside the model's bounds is an error.
///
/// # Errors
/// As [`fit_eiv`] (the data are checked on the inner model first), [`Delayed::fit`] and
/// [`Delayed::check_delay`].
pub fn fit_eiv_delayed<T: Real, M: FurtherStarts<T>>(
    pipeline: &Pipeline,
    model: &Delayed<M>,
    data: &FrequencyData<T>,
) -> Result<Fit<T, Delayed<M>>> {
    drop(ErrorsInVariables::default().problem(model.inner(), data)?);
    let fit = refine_eiv(pipeline, &model.fit(pipeline, data)?, data)?;
    if let Some(tau) = fit.model().delay(fit.theta()) {
        fit.model().check_delay(tau)?;
    }
    Ok(fit)
}

/// The errors-in-variables stage (eq. 42) from the output-error fit `start`: Levenberg–
/// Marquardt (the pipeline's `ml` settings, or the defaults) from its θ, statistics with
/// known noise level, stages of `start` followed by `"eiv"`.
fn refine_eiv<T: Real, M: ModelStructure<T> + Clone>(
    pipeline: &Pipeline,
    start: &Fit<T, M>,
    data: &FrequencyData<T>,
) -> Result<Fit<T, M>> {
    let eiv = ErrorsInVariables::default();
    let lm = pipeline.ml.unwrap_or_default();
    let base = start.model().clone();
    let mut stages = start.stages().to_vec();
    let problem = eiv.problem(&base, data)?;
    let theta0 = super::chain::stable_start(&base, start.theta().to_vec(), pipeline.stable)?;
    let sol = super::chain::lm_solve_in(&lm, &base, &problem, &theta0, pipeline.stable)?;
    let theta = sol.theta.clone();
    stages.push(Stage::new(StageKind::Eiv, sol));
    Fit::from_problem(
        base.clone(),
        data,
        theta,
        &problem,
        NoiseLevel::Known,
        stages,
    )
}
