//! The discrepancy workflow: fit a model, find where it and the measurement disagree,
//! name the missing effect, add it, and keep it only if a likelihood-ratio test says the
//! gap shrank significantly.
//!
//! Each step runs every [`Detector`] on the normalised residuals r_k of the current fit
//! (the terms of McKelvey's ML cost, eq. 23), refits the proposal of every [`Finding`]
//! below the level α ([`fit_spec`]), keeps those the likelihood-ratio test of
//! [`lrt::lr_test`] accepts at α (for a new noise model the concentrated-likelihood test
//! [`lrt::concentrated_lr_test`] with W = ln(V/N), eq. 26), and takes the one that
//! explains most (smallest LR p-value, then the largest cost drop per added parameter).
//! The loop stops when the fit is consistent with the noise (cost and whiteness tests of
//! [`crate::validation::Validation`] pass at α; without a cost test the proposals are
//! still tried, each LR test at α/m), when nothing is accepted, or after `max_steps`. A
//! revision pass then swaps a delay, pole or zero step for another of the same size that
//! explains the data better once the other effects are in the model.
//!
//! Where the final (or any) fit and the data disagree: in frequency
//! [`disagreement_bands`], in time [`segment_disagreement`].
//!
//! Some effects are properties of the measurement, not missing model terms: input noise
//! (switch to the errors-in-variables criterion, eq. 42), nonlinear distortion (the model
//! stays the best linear approximation; the noise reference becomes noise + distortion)
//! and time variation (outside the LTI model class). Their detectors
//! ([`Detector::measurement`]) run at every step, are acted on first, and each is
//! accepted by its own test ([`Remedy`], [`Acceptance`]), since the nested
//! likelihood-ratio test compares models under one noise reference. The effects a linear
//! time-invariant model cannot absorb are listed in [`Report::unmodelled`]. For time
//! variation of a discrete-time spec the default workflow switches to the piecewise
//! time-invariant model ([`Workflow::naming_time_variation`] only names it)
//! (the spec refitted on the drift test's time segments, [`detectors::piecewise_model`]):
//! the step shows the gap shrink from the common model's cost on the segments to the
//! segment models' cost, kept by the F test of (S − 1)q added parameters, and the report's
//! verdict on the noise is the segment models' ([`Report::time_varying`]). For a
//! continuous-time spec on a time record the workflow fits the Lataire–Pintelon
//! time-varying ODE with the spec's orders instead ([`time_varying_ode`], [`Report::ltv`]):
//! the gap from its time-invariant to its time-varying form, and the frozen poles over
//! the record. The
//! distortion and time-variation detectors need the periodic time record
//! ([`Context::with_record`]) or a distortion analysis ([`Context::with_distortion`]);
//! the parameter-drift test of time variation also works on one non-periodic record
//! ([`Context::with_time_record`]).
//!
//! ```
//! use fdid::prelude::*;
//! use fdid::workflow::{Context, ModelSpec, Workflow};
//! # fn main() -> fdid::Result<()> {
//! // G(z) = 0.5 z⁻¹/(1 − 0.8 z⁻¹) on 64 lines, known noise variances, no noise added
//! let ts = 1.0;
//! let omega: Vec<f64> = (1..=64).map(|k| k as f64 * std::f64::consts::PI / 65.0).collect();
//! let g = |w: f64| {
//!     let zi = Complex::new(0.0, -w * ts).exp();
//!     zi * 0.5 / (Complex::new(1.0, 0.0) - zi * 0.8)
//! };
//! let u = vec![Complex::new(1.0, 0.0); omega.len()];
//! let y: Vec<Complex<f64>> = omega.iter().map(|w| g(*w)).collect();
//! let data = FrequencyData::new(omega.clone(), y, u, Some(ts))?
//!     .with_noise(NoiseVariances::output_only(vec![1e-6; omega.len()]))?;
//! let report = Workflow::default().run(&data, ModelSpec::discrete(1, 1, ts), Context::periodic(0.01))?;
//! assert!(report.effects.is_empty());
//! assert!(report.consistent_with_noise);
//! # Ok(())
//! # }
//! ```
mod attempt;
mod bands;
mod common_poles;
mod custom;
pub mod detectors;
mod eliminate;
mod finding;
mod fork;
mod hypothesis;
pub mod lrt;
mod ltv_step;
mod revise;
mod segments;
mod spec;
mod warm_start;

pub use crate::estimate::{DelayRange, Method, ModelSpec};
pub use attempt::{Attempt, Elimination, Outcome};
pub use bands::{Band, disagreement_bands};
pub use common_poles::{
    CommonPoleCheck, CommonPoleDiagnosis, CommonPoleStep, EXACT_FIT, EntryCheck, SharedResonance,
    check_common_poles, diagnose_common_poles,
};
pub use custom::{Augmented, AugmentedFit, ModelReport};
pub use detectors::TimeVarying;
pub use finding::{Context, Detail, Detector, Effect, Finding, PeriodicRecord, Remedy};
use hypothesis::Exploration;
pub use hypothesis::Hypothesis;
pub use ltv_step::{LtvCandidate, LtvStep, MIN_GAP, time_varying_ode};
pub use segments::{SegmentResult, segment_disagreement};
pub use spec::{BELOW_BAND, MARGINAL_DAMPING, SpecFit, fit_spec};

use crate::data::FrequencyData;
use crate::error::{FdidError, Result};

/// One accepted augmentation.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Step {
    /// The effect named.
    pub effect: Effect,
    /// The detector's p-value.
    pub p_value: f64,
    /// Cost V = Σ|r_k|² before the step.
    pub cost_before: f64,
    /// Cost after the step.
    pub cost_after: f64,
    /// p-value of the test that accepted the step: the likelihood-ratio test (smaller
    /// model vs augmented one) for a structural step, the detector's own test otherwise
    /// ([`Step::acceptance`]).
    pub lr_p: f64,
    /// The detector's named values.
    pub detail: Detail,
    /// Whether the revision pass replaced the step first accepted here (then
    /// `cost_before` is the cost of the final model without this step's augmentation).
    #[cfg_attr(feature = "serde", serde(default))]
    pub revised: bool,
    /// Whether the step switched to the piecewise time-invariant model
    /// ([`Report::time_varying`]): then `cost_before` is the common model's cost on the
    /// time segments and `cost_after` the segment models', and `lr_p` the F test between
    /// them ([`detectors::piecewise_model`]).
    #[cfg_attr(feature = "serde", serde(default))]
    pub piecewise: bool,
}

impl Step {
    /// The step naming `finding`'s effect with its p-value and detail, the costs before
    /// and after, and the p-value `lr_p` of the test that accepted it (not revised).
    pub(crate) fn new(finding: Finding, cost_before: f64, cost_after: f64, lr_p: f64) -> Self {
        Self {
            effect: finding.effect,
            p_value: finding.p_value,
            cost_before,
            cost_after,
            lr_p,
            detail: finding.detail,
            revised: false,
            piecewise: false,
        }
    }

    /// How the step was accepted, from its effect: input noise by a criterion switch,
    /// nonlinear distortion by a new noise reference, time variation by the switch to the
    /// piecewise time-invariant model when [`Step::piecewise`], else not absorbed, every
    /// other effect by the likelihood-ratio test (the remedies of the default detectors).
    pub fn acceptance(&self) -> Acceptance {
        match self.effect {
            Effect::InputNoise => Acceptance::Criterion,
            Effect::NonlinearDistortion => Acceptance::NoiseReference,
            Effect::TimeVariation if self.piecewise => Acceptance::Piecewise,
            Effect::TimeVariation => Acceptance::NotAbsorbed,
            _ => Acceptance::LikelihoodRatio,
        }
    }
}

/// How a [`Step`] was accepted (see [`Remedy`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum Acceptance {
    /// A larger model, kept by the nested likelihood-ratio test.
    #[default]
    LikelihoodRatio,
    /// Another criterion (errors-in-variables), kept by the detector's test and a
    /// decrease of the full negative log-likelihood.
    Criterion,
    /// The same model judged against a new noise reference (noise + nonlinear
    /// distortion), kept by the detector's test: the residual left is the effect, not a
    /// model error.
    NoiseReference,
    /// Named but outside the model class (a time-varying system for an LTI model): the
    /// model is unchanged (`cost_after = cost_before`) and the refinement stops.
    NotAbsorbed,
    /// A time-varying system described by the piecewise time-invariant model (the spec
    /// refitted on S time segments, [`Report::time_varying`]), kept by the F test of the
    /// common model against the segment models ((S − 1)q added parameters); the
    /// refinement stops.
    Piecewise,
}

/// The workflow's outcome: accepted steps, the effects in order, and the final fit.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Report {
    /// Accepted steps in order.
    pub steps: Vec<Step>,
    /// The effects of `steps`, in order.
    pub effects: Vec<Effect>,
    /// Whether the final fit passes the cost and whiteness tests at α against the final
    /// noise reference; when nonlinear distortion was named, the reference is noise +
    /// distortion and only the cost test applies (the distortion of one phase realisation
    /// is not white across frequency). After the switch to the piecewise time-invariant
    /// model, the verdict on the segment models ([`TimeVarying::consistent_with_noise`]).
    pub consistent_with_noise: bool,
    /// Named effects the final model does not absorb (nonlinear distortion, time
    /// variation): its residual holds them, not a model error. Time variation is absent
    /// when the piecewise time-invariant model absorbs it ([`Report::time_varying`]
    /// consistent with the noise).
    #[cfg_attr(feature = "serde", serde(default))]
    pub unmodelled: Vec<Effect>,
    /// The fit of the starting model (before any step).
    pub initial_fit: SpecFit,
    /// The fit after each step, in order (a step swapped by the revision pass holds the
    /// revised model's fit). Not serialised.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub step_fits: Vec<SpecFit>,
    /// The data with the final noise reference, when a step changed it (noise +
    /// nonlinear distortion). Not serialised.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub final_data: Option<FrequencyData<f64>>,
    /// The final fit.
    #[cfg_attr(feature = "serde", serde(rename = "final"))]
    pub final_fit: SpecFit,
    /// The piecewise time-invariant model the workflow switched to when it named time
    /// variation ([`Step::piecewise`], [`detectors::piecewise_model`]): the final
    /// description of a time-varying system, the spec (`final_fit`'s) refitted on each
    /// time segment. When present, `consistent_with_noise` is the verdict on the segment
    /// models ([`TimeVarying::consistent_with_noise`]: their combined cost test at α/2
    /// and each segment's whiteness test at α/(2S)) and `time_variation` is absent from
    /// `unmodelled` when that verdict is positive (the piecewise model absorbs it).
    #[cfg_attr(feature = "serde", serde(default))]
    pub time_varying: Option<TimeVarying>,
    /// The time-varying ODE (Lataire–Pintelon, [`time_varying_ode`]) fitted on the time
    /// record when a step named time variation on a continuous-time spec: the gap
    /// V(N_p = 0) → V(N_p) and the frozen poles over the record. The final LTI model and
    /// the verdict are unchanged.
    #[cfg_attr(feature = "serde", serde(default))]
    pub ltv: Option<LtvStep>,
    /// Every detector's finding on the final fit and the final data, significant or not
    /// (what is left to explain). Not serialised.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub remaining: Vec<Finding>,
    /// When the loop ended because no structural refit was accepted: each refit tried at
    /// that last step and why it was rejected (failed, unstable, likelihood-ratio
    /// p-value). Empty when the loop ended otherwise (consistent, step limit, a
    /// measurement-level effect the model cannot absorb).
    #[cfg_attr(feature = "serde", serde(default))]
    pub attempts: Vec<Attempt>,
    /// The accepted steps the backward-elimination pass removed from the final model (no
    /// longer significant given the other effects), in order of removal. `effects` leaves
    /// them out; `steps` keeps the history.
    #[cfg_attr(feature = "serde", serde(default))]
    pub eliminated: Vec<Elimination>,
    /// Effects named from the measurement alone, below α, that no step acts on: coloured
    /// noise seen in the noise reference's per-line variances
    /// ([`detectors::reference_colour`]; its proposal offers a noise model). Not
    /// serialised.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub named: Vec<Finding>,
}

/// The workflow's settings.
///
/// | field | default | meaning |
/// |---|---|---|
/// | `detectors` | [`TimeDelay`](detectors::TimeDelay), [`MissingResonance`](detectors::MissingResonance), [`Transient`](detectors::Transient), [`ColoredNoise`](detectors::ColoredNoise), [`OrderIncrease`](detectors::OrderIncrease) for a pole and a zero; the measurement-level [`InputNoise`](detectors::InputNoise), [`NonlinearDistortion`](detectors::NonlinearDistortion), [`TimeVariationTests`](detectors::TimeVariationTests) (the skirt test [`TimeVariation`](detectors::TimeVariation) and the parameter drift [`TimeDrift`](detectors::TimeDrift); switching to the piecewise model on 2 segments) (these return `None` without the information they need) | the tests run at each step |
/// | `max_steps` | 4 | most augmentations accepted |
///
/// The level α comes from the [`Context`].
pub struct Workflow {
    /// The detectors run at each step.
    pub detectors: Vec<Box<dyn Detector>>,
    /// The most augmentations accepted.
    pub max_steps: usize,
}

impl Default for Workflow {
    fn default() -> Self {
        Self {
            detectors: vec![
                Box::new(detectors::TimeDelay),
                Box::new(detectors::MissingResonance),
                Box::new(detectors::Transient),
                Box::new(detectors::ColoredNoise),
                Box::new(detectors::OrderIncrease(detectors::Added::Pole)),
                Box::new(detectors::OrderIncrease(detectors::Added::Zero)),
                Box::new(detectors::InputNoise),
                Box::new(detectors::NonlinearDistortion),
                Box::new(detectors::TimeVariationTests::switching(2)),
            ],
            max_steps: 4,
        }
    }
}

impl Workflow {
    /// The default workflow, spelled out: its time-variation detector switches to the
    /// piecewise time-invariant model on 2 time segments
    /// ([`detectors::TimeVariationTests::switching`]) when it names time variation: the
    /// step reports the common model's cost on the segments and the segment models' cost,
    /// the F test between them, and [`Report::time_varying`] holds the segment models
    /// ([`detectors::piecewise_model`]). Discrete-time specs only; for a continuous-time
    /// spec the effect stays unmodelled by the LTI model and [`Report::ltv`] holds the
    /// time-varying ODE fitted on the time record ([`time_varying_ode`]).
    /// [`Workflow::naming_time_variation`] names the
    /// effect without switching.
    ///
    /// ```
    /// use fdid::prelude::*;
    /// use fdid::simulate::SplitMix64;
    /// use fdid::workflow::{Acceptance, Context, Effect, ModelSpec, Workflow};
    /// # fn main() -> fdid::Result<()> {
    /// // y(t) = 0.5 u(t) + a y(t − 1), a = 0.5 for the first half, 0.55 for the second
    /// let n = 2048;
    /// let mut rng = SplitMix64::new(2);
    /// let u: Vec<f64> = (0..n).map(|_| rng.gaussian()).collect();
    /// let mut y = vec![0.0; n];
    /// for t in 1..n {
    ///     let a = if t < n / 2 { 0.5 } else { 0.55 };
    ///     y[t] = 0.5 * u[t] + a * y[t - 1];
    /// }
    /// let y: Vec<f64> = y.iter().map(|v| v + 0.01 * rng.gaussian()).collect();
    /// let record = TimeData::new(u, y, 1.0)?;
    /// let all = record.dft();
    /// let keep: Vec<bool> = (0..all.len()).map(|k| k > 0 && 2 * k < n).collect();
    /// let data = all.select_lines(&keep)?;
    /// let spec = ModelSpec { transient: true, ..ModelSpec::discrete(1, 0, 1.0) };
    /// let ctx = Context::non_periodic(0.05).with_time_record(record);
    /// let report = Workflow::time_varying().run(&data, spec, ctx)?;
    /// assert_eq!(report.effects, vec![Effect::TimeVariation]);
    /// let step = &report.steps[0];
    /// assert_eq!(step.acceptance(), Acceptance::Piecewise);
    /// assert!(step.cost_after < step.cost_before && step.lr_p < 1e-3);
    /// let tv = report.time_varying.as_ref().unwrap();
    /// assert_eq!(tv.segments, vec![(0.0, 1024.0), (1024.0, 2048.0)]);
    /// # Ok(())
    /// # }
    /// ```
    pub fn time_varying() -> Self {
        Self::default()
    }

    /// The default workflow whose time-variation detector names the effect and stops the
    /// refinement without switching to the piecewise model (the effect is then listed in
    /// [`Report::unmodelled`]).
    pub fn naming_time_variation() -> Self {
        let mut w = Self::default();
        for d in &mut w.detectors {
            if d.effect() == Effect::TimeVariation {
                *d = Box::new(detectors::TimeVariationTests::default());
            }
        }
        w
    }
}

impl std::fmt::Debug for Workflow {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let names: Vec<&str> = self.detectors.iter().map(|d| d.effect().as_str()).collect();
        f.debug_struct("Workflow")
            .field("detectors", &names)
            .field("max_steps", &self.max_steps)
            .finish()
    }
}

impl Workflow {
    /// Runs the workflow on `data` from the model `start`.
    ///
    /// Each step first runs the measurement-level detectors ([`Detector::measurement`]:
    /// input noise, nonlinear distortion, time variation), whatever the fit's consistency,
    /// and acts on the most significant finding below α/(2m) (m the number of them that
    /// apply: Bonferroni, so that together they raise a false alarm with probability at
    /// most α/2) whose effect was not acted on yet, by its [`Remedy`]: a criterion switch is kept when the detector's test is
    /// significant and the full negative log-likelihood Σ(ln|c_k|² + |r_k|²) decreases; a
    /// new noise reference is kept on the detector's test and the loop continues on the
    /// new data; an effect the model class cannot absorb is named and ends the refinement
    /// (time variation: when the detector names S segments,
    /// [`Detector::piecewise_segments`], the piecewise time-invariant model is fitted and
    /// kept when its F test against the common model is below α, [`Step::piecewise`]).
    /// Otherwise, while the fit is not consistent with the noise, the structural findings
    /// are refitted and judged by the likelihood-ratio test (see the module
    /// documentation).
    ///
    /// The fits run without the relocation starts of the multistart search
    /// ([`crate::estimate::without_relocation`]), which would double the cost of every
    /// search from order 5 on.
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] for α outside (0, 1); the start fit's errors (a
    /// proposal whose fit fails is skipped).
    pub fn run(&self, data: &FrequencyData<f64>, start: ModelSpec, ctx: Context) -> Result<Report> {
        crate::estimate::without_relocation(|| spec::memoised(|| self.run_fits(data, start, ctx)))
    }

    /// [`Workflow::run`] (on the thread's relocation setting).
    fn run_fits(
        &self,
        data: &FrequencyData<f64>,
        start: ModelSpec,
        ctx: Context,
    ) -> Result<Report> {
        let alpha = ctx.alpha;
        if !(alpha > 0.0 && alpha < 1.0) {
            return Err(FdidError::InvalidArgument {
                name: "alpha",
                value: alpha.to_string(),
                reason: "the false-alarm level lies in (0, 1)".into(),
            });
        }
        let initial_fit = fit_spec(&start, data)?;
        let named: Vec<Finding> = detectors::reference_colour(data, &ctx, &start)
            .filter(|f| f.p_value < alpha)
            .into_iter()
            .collect();
        let original = data;
        let Exploration {
            mut steps,
            mut step_fits,
            mut current,
            data,
            mut unmodelled,
            cost_only,
            mut time_varying,
            attempts,
            ..
        } = self.explore(data, initial_fit.clone(), &ctx);
        let spec_before = current.spec.clone();
        crate::progress::report(|| "revising the accepted steps".into());
        self.revise(&data, &ctx, &mut steps, &mut step_fits, &mut current);
        crate::progress::report(|| "backward elimination".into());
        let eliminated = self.eliminate(&data, alpha, &steps, &mut current);
        // a revised structure: the segment models of the final spec
        if let Some((tv, segments)) = time_varying.as_mut()
            && current.spec != spec_before
            && let Ok(Some(new)) = detectors::piecewise_model(&current, &ctx, *segments)
        {
            *tv = new;
            if let Some(step) = steps.iter_mut().find(|s| s.piecewise) {
                step.cost_before = tv.cost_before;
                step.cost_after = tv.cost_after;
                step.lr_p = tv.lr_p;
            }
            let absorbed = tv.consistent_with_noise(alpha);
            unmodelled.retain(|e| *e != Effect::TimeVariation || !absorbed);
            if !absorbed && !unmodelled.contains(&Effect::TimeVariation) {
                unmodelled.push(Effect::TimeVariation);
            }
        }
        let time_varying = time_varying.map(|(tv, _)| tv);
        let ltv = ltv_step::after_time_variation(&steps, &current, &ctx, time_varying.as_ref());
        crate::progress::report(|| "the detectors on the final model".into());
        let remaining = self.findings(&data, &current, &ctx);
        Ok(Report {
            effects: steps
                .iter()
                .enumerate()
                .filter(|(i, _)| !eliminated.iter().any(|e| e.step == *i))
                .map(|(_, s)| s.effect)
                .collect(),
            steps,
            consistent_with_noise: match &time_varying {
                Some(tv) => tv.consistent_with_noise(alpha),
                None => consistent(&current, alpha, cost_only),
            },
            unmodelled,
            initial_fit,
            step_fits,
            final_data: (data.noise() != original.noise()).then_some(data),
            final_fit: current,
            time_varying,
            ltv,
            remaining,
            attempts,
            eliminated,
            named,
        })
    }

    /// Every detector's finding on `fit`.
    pub(crate) fn findings(
        &self,
        data: &FrequencyData<f64>,
        fit: &SpecFit,
        ctx: &Context,
    ) -> Vec<Finding> {
        self.detectors
            .iter()
            .filter_map(|d| d.detect(data, fit, ctx))
            .collect()
    }
}

/// The p-value of the likelihood-ratio test of `next` (more parameters) against
/// `current` on `n` lines: the concentrated test (W = ln(V/N), eq. 26) when the noise
/// model changes, else [`lrt::lr_test`]; `None` when `next` is not larger or the test
/// cannot be computed.
pub(crate) fn lr_p_value(current: &SpecFit, next: &SpecFit, n: usize) -> Option<f64> {
    next.n_params
        .checked_sub(current.n_params)
        .filter(|a| *a > 0)?;
    let test = if next.spec.noise_order != current.spec.noise_order {
        let lines = n as f64;
        lrt::concentrated_lr_test(
            (current.cost / lines).ln(),
            current.n_params,
            (next.cost / lines).ln(),
            next.n_params,
            n,
        )
    } else {
        lrt::lr_test(
            current.cost,
            current.n_params,
            next.cost,
            next.n_params,
            n,
            current.noise_known,
        )
    }
    .ok()?;
    Some(test.p_value)
}

/// Whether an accepted proposal (p-value `p`, cost drop per parameter `gain`) explains
/// more than the best so far: the smaller p-value, then (p-values underflow) the larger
/// gain.
pub(crate) fn better(best: Option<(f64, f64)>, p: f64, gain: f64) -> bool {
    best.is_none_or(|(bp, bg)| p < bp || (p == bp && gain > bg))
}

/// Whether `fit` is consistent with its noise reference at level α: the cost and
/// whiteness tests at α/2 each ([`SpecFit::consistent_with_noise`]), or with `cost_only`
/// the cost test alone at α. The latter is used once the reference holds nonlinear
/// distortion: the stochastic distortion of one phase realisation is not white across
/// frequency (a cubic term is dominated by the few peaks of the signal, whose spectrum is
/// smooth), so the whiteness test would reject it as a model error while the residual
/// power matches noise + distortion.
pub(crate) fn consistent(fit: &SpecFit, alpha: f64, cost_only: bool) -> bool {
    if cost_only {
        fit.validation.cost_p.is_none_or(|p| p >= alpha)
    } else {
        fit.consistent_with_noise(alpha)
    }
}

/// The negative log-likelihood of a fit under its own noise reference, up to a constant:
/// Σ_k (ln|c_k|² + |r_k|²) with c_k the line's normaliser (σ_k of eq. 23 or 42), so that
/// fits under different weightings compare.
pub(crate) fn negative_log_likelihood(fit: &SpecFit) -> f64 {
    fit.scale
        .iter()
        .zip(&fit.residuals)
        .map(|(c, r)| c.norm_sqr().ln() + r.norm_sqr())
        .sum()
}
