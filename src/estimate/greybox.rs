//! Fits of grey-box (physical) models: output-error ML and errors-in-variables ML from a
//! user's start θ₀.

use super::estimate;
use crate::criterion::{ErrorsInVariables, MaximumLikelihood};
use crate::data::FrequencyData;
use crate::error::Result;
use crate::fit::{Fit, NoiseLevel, Stage, StageKind};
use crate::greybox::{Parameter, PhysicalParameters, Scale, Slot, check_theta_common};
use crate::model::ModelStructure;
use crate::scalar::Real;
use crate::solver::LevenbergMarquardt;

/// Checks a start θ₀ against a model: length, finite entries, model-specific checks.
fn check_start<T: Real, M: ModelStructure<T> + PhysicalParameters>(
    model: &M,
    start: &[T],
) -> Result<()> {
    check_theta_common(model.n_params(), start)?;
    let t: Vec<f64> = start.iter().map(|v| v.to_f64_lossless()).collect();
    model.check_theta(&t)
}

/// Output-error maximum likelihood (McKelvey eq. 23, lines weighted by the data's output
/// noise variances when present, else flat with λ estimated by eq. 25) from the start θ₀,
/// solved by Levenberg–Marquardt; the statistics of the result are those of
/// [`Fit::new`] (Cov θ̂ = (λ/2)(JᵀJ)⁻¹). Works for any described model: [`crate::greybox::AutoDiff`],
/// `Delayed<AutoDiff<_>>`, `Fixed<…>`.
///
/// # Errors
/// [`crate::FdidError::LengthMismatch`] / [`crate::FdidError::NonFinite`] (what `"theta"`) for a bad
/// start, the model's [`PhysicalParameters::check_theta`] error (e.g. a delay outside its
/// bounds), then as [`crate::criterion::MlProblem::new`] and the solver.
pub fn fit_ml_from<T: Real, M: ModelStructure<T> + PhysicalParameters + Clone>(
    model: &M,
    data: &FrequencyData<T>,
    start: &[T],
) -> Result<Fit<T, M>> {
    check_start(model, start)?;
    let ml = MaximumLikelihood::default();
    let sol = estimate(
        model,
        data,
        &ml,
        &LevenbergMarquardt::default(),
        Some(start),
    )?;
    let theta = sol.theta.clone();
    let t: Vec<f64> = theta.iter().map(|v| v.to_f64_lossless()).collect();
    model.check_theta(&t)?;
    let stages = vec![Stage::new(StageKind::Ml, sol)];
    Fit::new(model.clone(), data, theta, ml.weighting, stages)
}

/// Errors-in-variables maximum likelihood (McKelvey eq. 42, [`ErrorsInVariables`] with the
/// input–output covariance) from the start θ₀ by Levenberg–Marquardt; the statistics are
/// those of the eq. 42 residuals with known noise level (Cov θ̂ = ½(JᵀJ)⁻¹).
///
/// # Errors
/// As [`fit_ml_from`] for the start; as [`ErrorsInVariables`]'s problem (no noise variances,
/// zero input noise, invalid covariances) and the solver.
pub fn fit_eiv_from<T: Real, M: ModelStructure<T> + PhysicalParameters + Clone>(
    model: &M,
    data: &FrequencyData<T>,
    start: &[T],
) -> Result<Fit<T, M>> {
    use crate::criterion::Criterion;
    check_start(model, start)?;
    let eiv = ErrorsInVariables::default();
    let problem = eiv.problem(model, data)?;
    let sol = crate::solver::Solver::solve(&LevenbergMarquardt::default(), &problem, Some(start))?;
    let theta = sol.theta.clone();
    let t: Vec<f64> = theta.iter().map(|v| v.to_f64_lossless()).collect();
    model.check_theta(&t)?;
    let stages = vec![Stage::new(StageKind::Eiv, sol)];
    Fit::from_problem(
        model.clone(),
        data,
        theta,
        &problem,
        NoiseLevel::Known,
        stages,
    )
}

/// One parameter of a fit in physical units.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct PhysicalValue<T: Real> {
    /// Name.
    pub name: String,
    /// Unit of `value` and `std`.
    pub unit: String,
    /// How θ maps to the value.
    pub scale: Scale,
    /// The estimate: e^θ̂ (log scale) or θ̂.
    pub value: T,
    /// Its standard deviation by the delta method: value·std(θ̂) (log scale) or std(θ̂);
    /// zero for a fixed parameter, `None` without a covariance.
    pub std: Option<T>,
    /// θ̂ of this parameter.
    pub theta: T,
    /// std(θ̂) (from [`Fit::covariance`]); zero when fixed.
    pub theta_std: Option<T>,
    /// True when held at a known value ([`crate::greybox::Fixed`]).
    pub fixed: bool,
}

impl<T: Real> PhysicalValue<T> {
    /// The confidence interval at `level` (e.g. 0.95): the normal interval
    /// θ̂ ± z·std(θ̂), z = Φ⁻¹((1 + level)/2), mapped to physical units (e^{θ̂ ± zσ} on the
    /// log scale: positive and asymmetric). `None` without a covariance or for `level`
    /// outside (0, 1).
    pub fn interval(&self, level: f64) -> Option<(T, T)> {
        let s = self.theta_std?;
        if !(level > 0.0 && level < 1.0) {
            return None;
        }
        let z = T::lit(crate::stats::normal_quantile(0.5 + level / 2.0));
        let p = Parameter {
            name: String::new(),
            unit: String::new(),
            scale: self.scale,
        };
        Some((p.value(self.theta - z * s), p.value(self.theta + z * s)))
    }
}

/// The parameters of a fit in physical units, one per physical parameter (fixed ones
/// included), with standard deviations by the delta method: for θᵢ = ln(vᵢ),
/// v̂ᵢ = e^θ̂ᵢ and std(v̂ᵢ) = v̂ᵢ·std(θ̂ᵢ), std(θ̂ᵢ) = √Cov(θ̂)ᵢᵢ from [`Fit::covariance`]
/// (McKelvey eqs. 32–34).
pub fn physical_values<T: Real, M: ModelStructure<T> + PhysicalParameters>(
    fit: &Fit<T, M>,
) -> Vec<PhysicalValue<T>> {
    let theta = fit.theta();
    let std = fit.theta_std();
    fit.model()
        .physical_parameters()
        .into_iter()
        .map(|(p, slot)| {
            let (th, sd, fixed) = match slot {
                Slot::Free(i) => (
                    theta.get(i).copied().unwrap_or_else(T::nan),
                    std.as_ref()
                        .map(|s| s.get(i).copied().unwrap_or_else(T::nan)),
                    false,
                ),
                Slot::Fixed(v) => (T::lit(v), Some(T::zero()), true),
            };
            let value = p.value(th);
            let vstd = sd.map(|s| match p.scale {
                Scale::Linear => s,
                Scale::Log => value * s,
            });
            PhysicalValue {
                name: p.name,
                unit: p.unit,
                scale: p.scale,
                value,
                std: vstd,
                theta: th,
                theta_std: sd,
                fixed,
            }
        })
        .collect()
}
