//! The discrepancy workflow started from a user's model structure
//! ([`Workflow::run_model`]).
//!
//! **Why one concrete augmented type.** The structure grows at run time (a delay, one
//! mode, another mode), so the fitted model is an [`Augmented<M>`]: the user's model times
//! [`FlexibleModes`] (any number, zero included) in a [`Product`], followed by an optional
//! [`crate::Delayed`]. One type keeps the report's fit (and [`crate::estimate::greybox::physical_values`]
//! for described models) independent of the steps taken.
use super::finding::{Context, Effect, Finding};
use super::hypothesis::Hypothesis;
use super::spec::SpecFit;
use super::warm_start::{LIGHT_DAMPING, ratio_peak};
use super::{Report, Workflow, consistent};
use crate::criterion::MaximumLikelihood;
use crate::data::FrequencyData;
use crate::error::{FdidError, Result};
use crate::estimate::estimate;
use crate::estimate::greybox::PhysicalValue;
use crate::estimate::{ModelSpec, causal_delay_limit};
use crate::fit::{Fit, Stage, StageKind};
use crate::greybox::{
    AutoDiff, FlexibleModes, GreyBox, Parameter, PhysicalParameters, Product, Scale, Slot,
};
use crate::model::{Delayed, ModelStructure};
use crate::scalar::{Complex, Real};
use crate::solver::LevenbergMarquardt;
use nalgebra::DMatrix;

/// A user's model with the augmentations the workflow adds by composition:
///
/// ```text
/// G(θ, ω) = G_M(θ_M, ω) · F(θ_F, ω) · e^{−iωτ},   θ = [θ_M…, θ_F…, τ]
/// ```
///
/// F = Π of the [`FlexibleModes`] (4 parameters each, none at first), the delay factor
/// only once added ([`crate::Delayed`], τ in s bounded to the causal range). The Jacobian
/// is analytic in the composition (product rule, ∂G/∂τ = −iωG) over the user's
/// [`ModelStructure::jacobian_into`] and the dual-number Jacobian of F. The user model's
/// transient term, if any, is kept (see [`Product`]).
#[derive(Debug, Clone)]
pub struct Augmented<M> {
    model: Delayed<Product<M, AutoDiff<FlexibleModes>>>,
    delayed: bool,
}

impl<M> Augmented<M> {
    /// The user's model alone (no mode, no delay).
    pub fn new(base: M) -> Self {
        Self {
            model: Delayed::new(Product::new(base, AutoDiff::new(FlexibleModes::new(0)))),
            delayed: false,
        }
    }

    /// The user's model G_M.
    pub fn base(&self) -> &M {
        self.model.inner().first()
    }

    /// The number of flexible modes.
    pub fn modes(&self) -> usize {
        self.model.inner().second().model().modes()
    }

    /// Whether the delay factor is in.
    pub fn has_delay(&self) -> bool {
        self.delayed
    }

    /// The delay τ (s) of a θ of this model, `None` without the delay factor or for a θ
    /// of the wrong length.
    pub fn delay(&self, theta: &[f64]) -> Option<f64>
    where
        M: ModelStructure<f64>,
    {
        (self.delayed && theta.len() == self.n_params())
            .then(|| theta.last().copied())
            .flatten()
    }

    /// The number of parameters of the user's model (θ_M comes first in θ).
    pub fn base_params(&self) -> usize
    where
        M: ModelStructure<f64>,
    {
        ModelStructure::<f64>::n_params(self.base())
    }

    /// The model with one more flexible mode, θ = [θ_M, θ_F, new mode, τ].
    fn with_mode(&self) -> Result<Self>
    where
        M: Clone,
    {
        let product = Product::new(
            self.base().clone(),
            AutoDiff::new(FlexibleModes::new(self.modes() + 1)),
        );
        let mut model = Delayed::new(product);
        if let Some((lo, hi)) = self.model.bounds() {
            model = model.with_bounds(lo, hi)?;
        }
        Ok(Self {
            model,
            delayed: self.delayed,
        })
    }

    /// The model followed by a delay bounded to [0, `hi`], θ = [θ_M, θ_F, τ].
    fn with_delay(&self, hi: f64) -> Result<Self>
    where
        M: Clone,
    {
        Ok(Self {
            model: Delayed::new(self.model.inner().clone()).with_bounds(0.0, hi)?,
            delayed: true,
        })
    }
}

impl<T: Real, M: ModelStructure<T>> ModelStructure<T> for Augmented<M> {
    fn n_params(&self) -> usize {
        if self.delayed {
            self.model.n_params()
        } else {
            self.model.inner().n_params()
        }
    }

    /// G_M · F (· e^{−iωτ}).
    fn response_into(&self, theta: &[T], omega: &[T], out: &mut [Complex<T>]) {
        if self.delayed {
            self.model.response_into(theta, omega, out);
        } else {
            self.model.inner().response_into(theta, omega, out);
        }
    }

    /// The product rule over G_M and F, then ∂G/∂τ = −iωG.
    fn jacobian_into(
        &self,
        theta: &[T],
        omega: &[T],
        g: &mut [Complex<T>],
        jac: &mut DMatrix<Complex<T>>,
    ) {
        if self.delayed {
            self.model.jacobian_into(theta, omega, g, jac);
        } else {
            self.model.inner().jacobian_into(theta, omega, g, jac);
        }
    }

    /// The user model's transient, if any (not delayed, not multiplied by F).
    fn transient_into(
        &self,
        theta: &[T],
        omega: &[T],
        t: &mut [Complex<T>],
        jac: Option<&mut DMatrix<Complex<T>>>,
    ) -> bool {
        if self.delayed {
            self.model.transient_into(theta, omega, t, jac)
        } else {
            self.model.inner().transient_into(theta, omega, t, jac)
        }
    }

    fn check_data(&self, data: &FrequencyData<T>) -> Result<()> {
        if self.delayed {
            self.model.check_data(data)
        } else {
            self.model.inner().check_data(data)
        }
    }
}

impl<M: PhysicalParameters> PhysicalParameters for Augmented<M> {
    /// The user model's parameters, `omega_z1`, `zeta_z1`, `omega_p1`, `zeta_p1`, … (log
    /// scale), then `tau` (s) when delayed.
    fn physical_parameters(&self) -> Vec<(Parameter, Slot)> {
        if self.delayed {
            self.model.physical_parameters()
        } else {
            self.model.inner().physical_parameters()
        }
    }

    fn check_theta(&self, theta: &[f64]) -> Result<()> {
        if self.delayed {
            self.model.check_theta(theta)
        } else {
            self.model.inner().check_theta(theta)
        }
    }
}

/// The outcome of [`Workflow::run_model`]: the workflow's [`Report`] (steps, effects,
/// consistency, the [`SpecFit`] of every stage, marked with [`SpecFit::custom`]), the
/// significant findings the user's model cannot take, and the final fit.
#[derive(Debug, Clone)]
pub struct ModelReport<M> {
    /// Steps, effects and fits, as for [`Workflow::run`].
    pub report: Report,
    /// Structural findings significant on the final fit (at α, or α/m over the m
    /// structural detectors when only the whiteness test judges consistency) whose
    /// augmentation needs the rational parameterisation (missing pole or zero, transient,
    /// noise model), and an input-noise finding (the errors-in-variables criterion is not
    /// applied to a user model), each with its detector p-value. Empty when the final fit
    /// is consistent with a known noise level.
    pub not_added: Vec<Finding>,
    /// The final fit: the user's model with the accepted modes and delay.
    pub fit: Fit<f64, Augmented<M>>,
}

impl<M: ModelStructure<f64>> ModelReport<M> {
    /// The flexible modes of the final fit in physical units, four entries per mode
    /// (`omega_z`, `zeta_z`, `omega_p`, `zeta_p`), each e^θ̂ with std = value·std(θ̂) (delta
    /// method on [`Fit::covariance`], McKelvey eqs. 32–34).
    pub fn modes(&self) -> Vec<PhysicalValue<f64>> {
        let model = self.fit.model();
        let first = model.base_params();
        let theta = self.fit.theta();
        let std = self.fit.theta_std();
        FlexibleModes::new(model.modes())
            .parameters()
            .into_iter()
            .enumerate()
            .map(|(j, p)| {
                let th = theta[first + j];
                let sd = std.as_ref().map(|s| s[first + j]);
                let value = p.value(th);
                PhysicalValue {
                    name: p.name,
                    unit: p.unit,
                    scale: Scale::Log,
                    value,
                    std: sd.map(|s| value * s),
                    theta: th,
                    theta_std: sd,
                    fixed: false,
                }
            })
            .collect()
    }

    /// The estimated delay τ (s) with its standard deviation, when a delay was added.
    pub fn delay(&self) -> Option<(f64, Option<f64>)> {
        self.report.final_fit.delay
    }
}

/// A user's structure augmented by composition, with its fit and reduction: the
/// [`Hypothesis`] of [`Workflow::run_model`].
pub struct AugmentedFit<M> {
    model: Augmented<M>,
    fit: Fit<f64, Augmented<M>>,
    summary: SpecFit,
    /// The user model's label in the reduced fits ([`SpecFit::custom`]).
    label: String,
}

impl<M> AugmentedFit<M> {
    /// The augmented model.
    pub fn model(&self) -> &Augmented<M> {
        &self.model
    }

    /// Its fit.
    pub fn fitted(&self) -> &Fit<f64, Augmented<M>> {
        &self.fit
    }
}

impl<M: ModelStructure<f64> + Clone> Hypothesis for AugmentedFit<M> {
    fn fit(&self) -> &SpecFit {
        &self.summary
    }

    /// Output-error ML of the same augmented model from the current estimate.
    fn refit(&self, data: &FrequencyData<f64>) -> Result<Self> {
        fit_state(
            self.model.clone(),
            data,
            &[self.fit.theta().to_vec()],
            &self.label,
        )
    }

    /// A delay or a flexible mode, from the starts of [`Workflow::run_model`]; `None` for
    /// the effects that need the rational parameterisation.
    fn augment(&self, data: &FrequencyData<f64>, finding: &Finding) -> Option<Result<Self>> {
        let (model, starts) = proposal(data, self, finding)?;
        Some(fit_state(model, data, &starts, &self.label))
    }
}

/// The ω_z/ω_p ratios of the starts of a new flexible mode.
const ZERO_RATIOS: [f64; 4] = [0.5, 0.7, 0.85, 1.25];

impl Workflow {
    /// Runs the discrepancy workflow from the user's model structure `model` (e.g. a
    /// grey-box physical model with some parameters held by [`crate::greybox::Fixed`]) and
    /// start `theta0`.
    ///
    /// The user's model G_M(θ_M) is fitted by output-error maximum likelihood (McKelvey
    /// eq. 23) from the user's θ₀, reduced to a [`SpecFit`] ([`SpecFit::from_fit`]) and
    /// handed to the same detectors as [`Workflow::run`]. Two effects can be added to *any*
    /// model structure by composition, and are, judged by the same likelihood-ratio test:
    ///
    /// - `time_delay`: G_M · e^{−iωτ} ([`crate::Delayed`]), τ started at the detector's slope
    ///   (clamped to the causal range 0 ≤ τ < 2π/Δω) and at half and twice it;
    /// - `missing_resonance`: G_M · F with F a flexible mode of unit DC gain
    ///   ([`FlexibleModes`]: (1 + 2ζ_z s/ω_z + (s/ω_z)²)/(1 + 2ζ_p s/ω_p + (s/ω_p)²)), the
    ///   shape a second mass on a compliant shaft adds, started at ω_p = the detector's
    ///   `peak_hz` and at the peak of the measured-to-modelled ratio |Y_k|/|Ŷ_k| over the
    ///   lines of significant residual, ζ_p = the detector's `damping` (clamped to
    ///   [0.005, 0.5]) and 0.02, ζ_z = ζ_p and ω_z ∈ {0.5, 0.7, 0.85, 1.25}·ω_p, keeping the
    ///   start of least cost.
    ///
    /// Every other structural effect (a missing pole or zero, a transient term, a noise model)
    /// needs the rational parameterisation of [`ModelSpec`]: a user model has no coefficient
    /// to add. Such findings are named with their detector p-values in
    /// [`ModelReport::not_added`] (those significant on the final fit) but never added. The
    /// order-increase detectors see a user model without its poles (Â = 1 in their score
    /// direction), so their finding says that the residual holds a broadband term the model
    /// cannot produce, not where the missing pole or zero lies. Of the measurement-level
    /// effects, nonlinear distortion (a new noise reference: the augmented model is refitted on
    /// it) and time variation (named, unmodelled, the refinement stops) act as in
    /// [`Workflow::run`]; input noise would switch the criterion to errors-in-variables, which
    /// this route does not do: it is listed in `not_added`. The revision pass of
    /// [`Workflow::run`] (swapping a delay for a pole or zero) has nothing to swap with here.
    ///
    /// The loop is that of [`Workflow::run`] (measurement step, then while the fit is not
    /// consistent with the noise a structural step, at most `max_steps` steps); the
    /// result is a [`ModelReport`].
    ///
    /// ```
    /// use fdid::prelude::*;
    /// use fdid::greybox::{AutoDiff, physical::MassSpringDamper};
    /// use fdid::workflow::{Context, Effect, Workflow};
    /// # fn main() -> fdid::Result<()> {
    /// // 1/(2s² + 0.8s + 50) · e^{−0.05 s}, fitted from the delay-free mass–spring–damper
    /// let msd = AutoDiff::new(MassSpringDamper::new());
    /// let truth: Vec<f64> = msd.theta_from_physical(&[2.0, 0.8, 50.0])?;
    /// let omega: Vec<f64> = (1..=100).map(|k| 0.1 * k as f64).collect();
    /// let y: Vec<Complex<f64>> = msd.response(&truth, &omega).iter().zip(&omega)
    ///     .map(|(g, w)| g * Complex::new(0.0, -0.05 * w).exp())
    ///     .collect();
    /// let u = vec![Complex::new(1.0, 0.0); omega.len()];
    /// let data = FrequencyData::new(omega.clone(), y, u, None)?
    ///     .with_noise(NoiseVariances::output_only(vec![1e-8; omega.len()]))?;
    /// let start = msd.theta_from_physical(&[1.5, 1.0, 40.0])?;
    /// let out = Workflow::default().run_model(&data, msd, &start, Context::periodic(0.01))?;
    /// assert_eq!(out.report.effects, vec![Effect::TimeDelay]);
    /// let (tau, _) = out.delay().unwrap();
    /// assert!((tau - 0.05).abs() < 1e-6);
    /// assert!(out.report.consistent_with_noise);
    /// # Ok(())
    /// # }
    /// ```
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] for α outside (0, 1); [`FdidError::LengthMismatch`]
    /// (what `"theta0"`) when θ₀ does not have the model's p entries;
    /// [`FdidError::NonFinite`] (what `"theta0"`) for a non-finite entry; the model's
    /// [`ModelStructure::check_data`] error; the errors of the ML fit from θ₀ (a proposal
    /// whose fit fails is skipped).
    pub fn run_model<M: ModelStructure<f64> + Clone>(
        &self,
        data: &FrequencyData<f64>,
        model: M,
        theta0: &[f64],
        ctx: Context,
    ) -> Result<ModelReport<M>> {
        let alpha = ctx.alpha;
        if !(alpha > 0.0 && alpha < 1.0) {
            return Err(FdidError::InvalidArgument {
                name: "alpha",
                value: alpha.to_string(),
                reason: "the false-alarm level lies in (0, 1)".into(),
            });
        }
        if theta0.len() != model.n_params() {
            return Err(FdidError::LengthMismatch {
                what: "theta0",
                expected: model.n_params(),
                got: theta0.len(),
            });
        }
        crate::error::check_finite("theta0", theta0)?;
        model.check_data(data)?;
        let label = short_type_name(std::any::type_name::<M>());
        let start = fit_state(Augmented::new(model), data, &[theta0.to_vec()], &label)?;
        let initial_fit = start.summary.clone();
        let run = self.explore(data, start, &ctx);
        let current = run.current;
        let consistent_now = consistent(&current.summary, alpha, run.cost_only);
        let mut not_added = run.not_switched;
        if !(consistent_now && (current.summary.validation.cost_p.is_some() || run.cost_only)) {
            let structural: Vec<Finding> = self
                .detectors
                .iter()
                .filter(|d| !d.measurement())
                .filter_map(|d| d.detect(&run.data, &current.summary, &ctx))
                .collect();
            let level = if consistent_now {
                alpha / structural.len().max(1) as f64
            } else {
                alpha
            };
            not_added.extend(
                structural
                    .into_iter()
                    .filter(|f| f.p_value < level && !addable(f.effect)),
            );
        }
        let remaining = self.findings(&run.data, &current.summary, &ctx);
        let named = super::detectors::reference_colour(data, &ctx, &initial_fit.spec)
            .filter(|f| f.p_value < alpha)
            .into_iter()
            .collect();
        Ok(ModelReport {
            report: Report {
                effects: run.steps.iter().map(|s| s.effect).collect(),
                steps: run.steps,
                consistent_with_noise: consistent_now,
                unmodelled: run.unmodelled,
                initial_fit,
                step_fits: run.step_fits,
                final_data: (run.data.noise() != data.noise()).then_some(run.data),
                final_fit: current.summary,
                time_varying: None,
                ltv: None,
                remaining,
                attempts: run.attempts,
                eliminated: Vec::new(),
                named,
            },
            not_added,
            fit: current.fit,
        })
    }
}

/// Whether the workflow can add `effect` to any model structure.
fn addable(effect: Effect) -> bool {
    matches!(effect, Effect::TimeDelay | Effect::MissingResonance)
}

/// The augmented model and its starts for a finding, `None` when the effect is not
/// addable (or the delay is in already).
fn proposal<M: ModelStructure<f64> + Clone>(
    data: &FrequencyData<f64>,
    current: &AugmentedFit<M>,
    finding: &Finding,
) -> Option<(Augmented<M>, Vec<Vec<f64>>)> {
    let theta = current.fit.theta();
    match finding.effect {
        Effect::TimeDelay if !current.model.has_delay() => {
            let hi = causal_delay_limit(data);
            let slope = finding.detail.time_delay()?.slope;
            let tau = slope.clamp(0.0, 0.99 * hi);
            let mut taus = vec![tau];
            for t in [0.5 * tau, 2.0 * tau] {
                if t < hi && !taus.contains(&t) {
                    taus.push(t);
                }
            }
            let starts = taus
                .into_iter()
                .map(|t| {
                    let mut s = theta.to_vec();
                    s.push(t);
                    s
                })
                .collect();
            Some((current.model.with_delay(hi).ok()?, starts))
        }
        Effect::MissingResonance => {
            let resonance = finding.detail.missing_resonance()?;
            let peak = resonance.peak_omega();
            let zeta = resonance.damping.clamp(0.005, 0.5);
            let mut modes = vec![(peak, zeta), (peak, LIGHT_DAMPING)];
            if let Some(w) = ratio_peak(data, &current.summary) {
                modes.extend([(w, zeta), (w, LIGHT_DAMPING)]);
            }
            modes.dedup();
            let at = current.model.base_params() + 4 * current.model.modes();
            let starts = modes
                .iter()
                .flat_map(|&(wp, zeta)| {
                    ZERO_RATIOS
                        .iter()
                        .filter_map(move |r| FlexibleModes::mode_theta(r * wp, zeta, wp, zeta).ok())
                })
                .map(|mode| {
                    let mut s = theta[..at].to_vec();
                    s.extend_from_slice(&mode);
                    s.extend_from_slice(&theta[at..]);
                    s
                })
                .collect::<Vec<_>>();
            if starts.is_empty() {
                return None;
            }
            Some((current.model.with_mode().ok()?, starts))
        }
        _ => None,
    }
}

/// Output-error ML (McKelvey eq. 23, the data's noise weighting) of `model` from each
/// start by Levenberg–Marquardt; the solution of least cost whose delay lies in its causal
/// range, with its statistics ([`Fit::new`]) and reduction.
fn fit_state<M: ModelStructure<f64> + Clone>(
    model: Augmented<M>,
    data: &FrequencyData<f64>,
    starts: &[Vec<f64>],
    label: &str,
) -> Result<AugmentedFit<M>> {
    let ml = MaximumLikelihood::default();
    let lm = LevenbergMarquardt::default();
    let mut best: Option<crate::solver::Solution<f64>> = None;
    let mut error = None;
    for start in starts {
        let solution = estimate(&model, data, &ml, &lm, Some(start)).and_then(|s| {
            if let Some(tau) = model.delay(&s.theta) {
                model.model.check_delay(tau)?;
            }
            Ok(s)
        });
        match solution {
            Ok(s) if best.as_ref().is_none_or(|b| s.cost < b.cost) => best = Some(s),
            Ok(_) => {}
            Err(e) => error = Some(e),
        }
    }
    let Some(solution) = best else {
        return Err(error.unwrap_or(FdidError::InvalidArgument {
            name: "starts",
            value: "none".into(),
            reason: "no starting value to fit from".into(),
        }));
    };
    let theta = solution.theta.clone();
    let stages = vec![Stage::new(StageKind::Ml, solution)];
    let fit = Fit::new(model.clone(), data, theta, ml.weighting, stages)?;
    let spec = ModelSpec {
        delay: model.has_delay(),
        ..ModelSpec::continuous(0, 0)
    };
    let mut name = label.to_string();
    if model.modes() > 0 {
        name.push_str(&format!(" × {} flexible mode(s)", model.modes()));
    }
    if model.has_delay() {
        name.push_str(" × delay");
    }
    let summary = SpecFit::from_fit(&spec, &fit, data)?.with_custom(&name);
    Ok(AugmentedFit {
        model,
        fit,
        summary,
        label: label.to_string(),
    })
}

/// A type name without module paths (`a::B<c::D>` → `B<D>`).
fn short_type_name(full: &str) -> String {
    let mut out = String::new();
    let mut token = String::new();
    let flush = |token: &mut String, out: &mut String| {
        out.push_str(token.rsplit("::").next().unwrap_or(token));
        token.clear();
    };
    for c in full.chars() {
        if c.is_alphanumeric() || c == '_' || c == ':' {
            token.push(c);
        } else {
            flush(&mut token, &mut out);
            out.push(c);
        }
    }
    flush(&mut token, &mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::short_type_name;

    #[test]
    fn type_names_lose_their_paths() {
        assert_eq!(
            short_type_name("fdid::greybox::Fixed<fdid::greybox::AutoDiff<t::RigidBody>>"),
            "Fixed<AutoDiff<RigidBody>>"
        );
    }
}
