//! The one loop of the discrepancy workflow, over any [`Hypothesis`]: the rational
//! specification ([`SpecFit`], fitted by [`crate::estimate::ModelSpec::fit`]) or a user's
//! model structure augmented by composition ([`super::AugmentedFit`]).
//!
//! Each step first runs the measurement-level detectors ([`Detector::measurement`]) and
//! acts on the most significant finding below α/(2m) (m the number that apply:
//! Bonferroni) whose effect was not acted on yet, by its [`Remedy`]; otherwise, while the
//! fit is not consistent with the noise, the structural findings are added to the
//! hypothesis ([`Hypothesis::augment`]), refitted and judged by the likelihood-ratio
//! test; the one that explains most is kept.

use super::attempt::{Attempt, Outcome};
use super::detectors::TimeVarying;
use super::finding::{Context, Detector, Effect, Finding, Remedy};
use super::spec::SpecFit;
use super::{Acceptance, Step, Workflow, better, consistent, lr_p_value, negative_log_likelihood};
use crate::data::FrequencyData;
use crate::error::Result;

/// A fitted model the workflow can test, refit and augment.
///
/// The rational specification implements it on its [`SpecFit`] (every effect has a
/// proposal in [`crate::estimate::ModelSpec`]); a user's structure through
/// [`super::AugmentedFit`] (a delay and flexible modes added by composition).
pub trait Hypothesis: Sized {
    /// The fit, reduced to what the detectors and the tests use.
    fn fit(&self) -> &SpecFit;

    /// The same structure refitted on `data` (a new noise reference).
    ///
    /// # Errors
    /// The estimator's.
    fn refit(&self, data: &FrequencyData<f64>) -> Result<Self>;

    /// The structure with the effect `finding` names added, fitted on `data`; `None` when
    /// this structure cannot take it (or has it already).
    fn augment(&self, data: &FrequencyData<f64>, finding: &Finding) -> Option<Result<Self>>;

    /// [`Hypothesis::augment`] with each of `findings`, in their order. The default runs
    /// them one after the other; [`SpecFit`]'s runs them in parallel (with the `rayon`
    /// feature), with the outcomes of the default while the workflow's work budget is not
    /// reached.
    fn augment_each(
        &self,
        data: &FrequencyData<f64>,
        findings: &[Finding],
    ) -> Vec<Option<Result<Self>>> {
        findings.iter().map(|f| self.augment(data, f)).collect()
    }

    /// The structure under the criterion `finding` proposes (errors-in-variables), fitted
    /// on `data`; `None` (the default) when the structure does not switch criteria: the
    /// finding is then reported as not added.
    fn switch_criterion(
        &self,
        data: &FrequencyData<f64>,
        finding: &Finding,
    ) -> Option<Result<Self>> {
        let _ = (data, finding);
        None
    }

    /// The piecewise time-invariant model of the structure on `segments` time segments
    /// ([`super::detectors::piecewise_model`]), `None` (the default) when it has none.
    fn piecewise(&self, ctx: &Context, segments: usize) -> Option<TimeVarying> {
        let _ = (ctx, segments);
        None
    }
}

impl Hypothesis for SpecFit {
    fn fit(&self) -> &SpecFit {
        self
    }

    fn refit(&self, data: &FrequencyData<f64>) -> Result<Self> {
        super::fit_spec(&self.spec, data)
    }

    /// The finding's proposal ([`Finding::proposal`]) when it differs from the spec: fitted
    /// from scratch and from the warm starts of `warm_start::starts` (the current
    /// poles with the ones the finding adds); the fit of least cost among those the step
    /// can accept (stable, no new pole on the stability boundary), if any.
    fn augment(&self, data: &FrequencyData<f64>, finding: &Finding) -> Option<Result<Self>> {
        if finding.proposal == self.spec {
            return None;
        }
        let scratch = super::fit_spec(&finding.proposal, data);
        let warm = super::warm_start::starts(data, self, finding)
            .into_iter()
            .filter_map(|poles| {
                super::spec::fit_spec_from_poles(&finding.proposal, data, &poles).ok()
            });
        // the step's own rule (`judge_refit`): unstable or new marginal poles are rejected
        let marginal = self.marginal_poles();
        let rank = |f: &SpecFit| (!f.is_stable() || f.marginal_poles() > marginal, f.cost);
        let best = warm.fold(scratch, |best, fit| match best {
            Ok(b) if rank(&b) <= rank(&fit) => Ok(b),
            _ => Ok(fit),
        });
        Some(best)
    }

    /// The refits on rayon's threads, each under the step's work budget, relocation
    /// setting and memo of fits (see `workflow::fork`).
    fn augment_each(
        &self,
        data: &FrequencyData<f64>,
        findings: &[Finding],
    ) -> Vec<Option<Result<Self>>> {
        super::fork::map_forked(findings, |f| self.augment(data, f))
    }

    fn switch_criterion(
        &self,
        data: &FrequencyData<f64>,
        finding: &Finding,
    ) -> Option<Result<Self>> {
        Some(super::fit_spec(&finding.proposal, data))
    }

    fn piecewise(&self, ctx: &Context, segments: usize) -> Option<TimeVarying> {
        super::detectors::piecewise_model(self, ctx, segments)
            .ok()
            .flatten()
    }
}

/// Where the loop of [`Workflow::explore`] ended.
pub(crate) struct Exploration<H> {
    /// Accepted steps in order.
    pub steps: Vec<Step>,
    /// The fit after each step.
    pub step_fits: Vec<SpecFit>,
    /// The final hypothesis.
    pub current: H,
    /// The data with the final noise reference.
    pub data: FrequencyData<f64>,
    /// Named effects the model does not absorb.
    pub unmodelled: Vec<Effect>,
    /// Whether only the cost test judges consistency (a noise + distortion reference).
    pub cost_only: bool,
    /// The piecewise time-invariant model switched to, with its number of segments.
    pub time_varying: Option<(TimeVarying, usize)>,
    /// Measurement-level findings whose criterion switch the structure does not make.
    pub not_switched: Vec<Finding>,
    /// The refits tried at the last structural step when it accepted none (the loop's
    /// end): why each was rejected. Empty when the loop ended otherwise.
    pub attempts: Vec<Attempt>,
}

impl<H: Hypothesis> Exploration<H> {
    /// Takes the measurement step `measured` (its effect is then acted on); whether the
    /// refinement stops.
    fn take(&mut self, measured: Measured<H>, acted: &mut Vec<Effect>) -> bool {
        match measured {
            Measured::NotSwitched(finding) => {
                acted.push(finding.effect);
                self.not_switched.push(finding);
                false
            }
            Measured::Step(measured) => {
                let MeasurementStep {
                    step,
                    next,
                    data,
                    absorbed,
                    piecewise,
                } = *measured;
                if let Some(tv) = piecewise {
                    let segments = tv.segments.len();
                    self.time_varying = Some((tv, segments));
                }
                acted.push(step.effect);
                self.cost_only |= step.acceptance() == Acceptance::NoiseReference;
                if !absorbed {
                    self.unmodelled.push(step.effect);
                }
                self.steps.push(step);
                if let Some(d) = data {
                    self.data = d;
                }
                let stop = next.is_none();
                if let Some(next) = next {
                    self.current = next;
                }
                self.step_fits.push(self.current.fit().clone());
                stop
            }
        }
    }
}

/// A measurement-level step: the step, the new fit (`None`: the effect is not absorbed
/// and the refinement stops), new data (a new noise reference), whether the model absorbs
/// the effect, and the piecewise model switched to.
struct MeasurementStep<H> {
    step: Step,
    next: Option<H>,
    data: Option<FrequencyData<f64>>,
    absorbed: bool,
    piecewise: Option<TimeVarying>,
}

/// What the measurement step did.
enum Measured<H> {
    /// A step.
    Step(Box<MeasurementStep<H>>),
    /// A criterion switch the structure does not make.
    NotSwitched(Finding),
}

impl Workflow {
    /// The loop of the workflow from the fitted hypothesis `start` (see the module
    /// documentation of [`super`] for the rules): at most `max_steps` steps.
    pub(crate) fn explore<H: Hypothesis>(
        &self,
        data: &FrequencyData<f64>,
        start: H,
        ctx: &Context,
    ) -> Exploration<H> {
        let alpha = ctx.alpha;
        let mut run = Exploration {
            steps: Vec::new(),
            step_fits: Vec::new(),
            current: start,
            data: data.clone(),
            unmodelled: Vec::new(),
            cost_only: false,
            time_varying: None,
            not_switched: Vec::new(),
            attempts: Vec::new(),
        };
        let mut acted: Vec<Effect> = Vec::new();
        while run.steps.len() < self.max_steps {
            crate::progress::report(|| {
                format!("step {}: running the detectors", run.steps.len() + 1)
            });
            // the structural detectors first: while those of the system's structure fire,
            // the model may be missing a term, and a measurement test that assumes an
            // adequate model is deferred
            let structural = self.structural_findings(&run.data, &run.current, ctx);
            let firing = structural
                .iter()
                .any(|f| f.p_value < alpha && f.effect != Effect::ColoredNoise);
            if let Some(measured) =
                self.measurement_step(&run.data, &run.current, ctx, &acted, firing)
            {
                if run.take(measured, &mut acted) {
                    break;
                }
                continue;
            }
            // what the deferred model-based findings would do now
            let deferred = if firing {
                self.measurement_step(&run.data, &run.current, ctx, &acted, false)
            } else {
                None
            };
            // without a cost test (the noise level estimated, or sample variances of too
            // few periods) a passing whiteness test is weak evidence (a missing delay
            // leaves white residuals): the structural proposals are still tried, each
            // likelihood-ratio test at α/m (Bonferroni over the m proposals)
            let fit = run.current.fit();
            let strict = if consistent(fit, alpha, run.cost_only) {
                if fit.validation.cost_p.is_some() || run.cost_only {
                    if let Some(measured) = deferred
                        && !run.take(measured, &mut acted)
                    {
                        continue;
                    }
                    break;
                }
                true
            } else {
                false
            };
            let (chosen, attempts) =
                self.structural_step(&run.data, &run.current, ctx, strict, structural);
            match (chosen, deferred) {
                (Some((step, next)), Some(measured))
                    if step.effect == Effect::ColoredNoise
                        || explains_more(&measured, &step, run.current.fit(), next.fit()) =>
                {
                    // a noise model does not explain a drift of the system, and the
                    // piecewise model explains more than the best structural refit
                    if run.take(measured, &mut acted) {
                        break;
                    }
                }
                (Some((step, next)), _) => {
                    run.steps.push(step);
                    run.current = next;
                    run.step_fits.push(run.current.fit().clone());
                }
                (None, Some(measured)) => {
                    // no structural refit is accepted: the deferred findings act
                    run.attempts = attempts;
                    if run.take(measured, &mut acted) {
                        break;
                    }
                }
                (None, None) => {
                    run.attempts = attempts;
                    break;
                }
            }
        }
        run
    }

    /// The most significant measurement-level finding not acted on yet whose remedy
    /// succeeds: each applicable test at α/(2m) over the m that apply (Bonferroni), so
    /// that together they raise a false alarm with probability at most α/2, the other half
    /// going to the structural steps (gated by the consistency tests). With `defer`
    /// (structural detectors fire), findings of tests that assume an adequate model
    /// ([`Detector::model_based`]) wait, and so does a finding the model class cannot
    /// absorb (no piecewise model kept: naming it would end the refinement); with a
    /// waiting finding every less significant one waits too (it may be a side effect of
    /// the waiting one), and the structural step runs.
    fn measurement_step<H: Hypothesis>(
        &self,
        data: &FrequencyData<f64>,
        current: &H,
        ctx: &Context,
        acted: &[Effect],
        defer: bool,
    ) -> Option<Measured<H>> {
        let fit = current.fit();
        let applicable: Vec<(&dyn Detector, Finding)> = self
            .detectors
            .iter()
            .filter(|d| d.measurement() && !acted.contains(&d.effect()))
            .filter_map(|d| Some((d.as_ref(), d.detect(data, fit, ctx)?)))
            .collect();
        let level = ctx.alpha / (2 * applicable.len().max(1)) as f64;
        let mut findings: Vec<(&dyn Detector, Finding)> = applicable
            .into_iter()
            .filter(|(_, f)| f.p_value < level)
            .collect();
        findings.sort_by(|a, b| a.1.p_value.total_cmp(&b.1.p_value));
        for (detector, finding) in findings {
            if defer && detector.model_based(&finding) {
                // the less significant findings wait with it: they may be its side
                // effects (time variation also raises the detection lines)
                return None;
            }
            // the detector's own test accepts a measurement-level step
            let step =
                |cost_after: f64| Step::new(finding.clone(), fit.cost, cost_after, finding.p_value);
            let measured = |step, next, data, absorbed| {
                Measured::Step(Box::new(MeasurementStep {
                    step,
                    next,
                    data,
                    absorbed,
                    piecewise: None,
                }))
            };
            match detector.remedy(data, fit, ctx, &finding) {
                Some(Remedy::Criterion) => {
                    // kept when the full negative log-likelihood Σ(ln|c_k|² + |r_k|²)
                    // decreases
                    let Some(switched) = current.switch_criterion(data, &finding) else {
                        return Some(Measured::NotSwitched(finding));
                    };
                    let Ok(next) = switched else { continue };
                    if !(negative_log_likelihood(next.fit()) < negative_log_likelihood(fit)) {
                        continue;
                    }
                    let cost = next.fit().cost;
                    return Some(measured(step(cost), Some(next), None, true));
                }
                Some(Remedy::NoiseReference(new_data)) => {
                    let Ok(next) = current.refit(&new_data) else {
                        continue;
                    };
                    let cost = next.fit().cost;
                    return Some(measured(step(cost), Some(next), Some(new_data), false));
                }
                Some(Remedy::NotAbsorbed) => {
                    // the switch to the piecewise time-invariant model, kept by the F test
                    // of the common model against the segment models at α
                    if let Some(segments) = detector.piecewise_segments()
                        && let Some(tv) = current.piecewise(ctx, segments)
                        && tv.lr_p < ctx.alpha
                    {
                        let mut step =
                            Step::new(finding.clone(), tv.cost_before, tv.cost_after, tv.lr_p);
                        step.piecewise = true;
                        return Some(Measured::Step(Box::new(MeasurementStep {
                            step,
                            next: None,
                            data: None,
                            absorbed: tv.consistent_with_noise(ctx.alpha),
                            piecewise: Some(tv),
                        })));
                    }
                    // an effect the model class cannot absorb ends the refinement: while
                    // structural detectors fire it waits, as the model-based tests do
                    if defer {
                        return None;
                    }
                    return Some(measured(step(fit.cost), None, None, false));
                }
                Some(Remedy::Refit) | None => {}
            }
        }
        None
    }

    /// Every structural detector's finding on the current fit, significant or not.
    fn structural_findings<H: Hypothesis>(
        &self,
        data: &FrequencyData<f64>,
        current: &H,
        ctx: &Context,
    ) -> Vec<Finding> {
        let now = current.fit();
        self.detectors
            .iter()
            .filter(|d| !d.measurement())
            .filter_map(|d| d.detect(data, now, ctx))
            .collect()
    }

    /// Adds every significant structural finding (of `all`, the structural detectors'
    /// findings on the current fit) to the hypothesis; keeps those the likelihood-ratio
    /// test accepts (at α, or α/m over the m detectors when `strict`) and takes the one
    /// that explains most: smallest LR p-value, then (when p-values underflow) the largest
    /// cost drop per added parameter. An unstable refit explains the data with a spurious
    /// pole (e.g. a peak at the band edge): never an acceptable step. Returns the step
    /// taken, if any, and what became of every refit tried.
    fn structural_step<H: Hypothesis>(
        &self,
        data: &FrequencyData<f64>,
        current: &H,
        ctx: &Context,
        strict: bool,
        all: Vec<Finding>,
    ) -> (Option<(Step, H)>, Vec<Attempt>) {
        let now = current.fit();
        // the fit fails the consistency tests but no detector fires (with the noise level
        // estimated from the residuals the score tests lose their power): every proposal
        // is still tried, each likelihood-ratio test at α/m
        let silent = !strict && !all.iter().any(|f| f.p_value < ctx.alpha);
        let alpha = if strict || silent {
            ctx.alpha / all.len().max(1) as f64
        } else {
            ctx.alpha
        };
        let mut attempts = Vec::new();
        let mut candidates: Vec<(usize, Finding, H, f64, f64)> = Vec::new();
        let tried: Vec<Finding> = all
            .into_iter()
            .filter(|f| silent || f.p_value < ctx.alpha)
            .collect();
        crate::progress::report(|| {
            let effects: Vec<String> = tried.iter().map(|f| f.effect.to_string()).collect();
            format!("refitting for {}", effects.join(", "))
        });
        let refits = current.augment_each(data, &tried);
        for (finding, next) in tried.into_iter().zip(refits) {
            let (outcome, candidate) = judge_refit(current, next, data, alpha);
            if let Some((next, p, gain)) = candidate {
                candidates.push((attempts.len(), finding.clone(), next, p, gain));
            }
            attempts.push(Attempt {
                effect: finding.effect,
                p_value: finding.p_value,
                outcome,
            });
        }
        let mut best: Option<usize> = None;
        for (j, (_, _, _, p, gain)) in candidates.iter().enumerate() {
            let so_far = best.map(|b| (candidates[b].3, candidates[b].4));
            if better(so_far, *p, *gain) {
                best = Some(j);
            }
        }
        let Some(best) = best else {
            return (None, attempts);
        };
        for (j, (i, _, _, lr_p, _)) in candidates.iter().enumerate() {
            if j != best {
                attempts[*i].outcome = Outcome::Outexplained { lr_p: *lr_p };
            }
        }
        let (_, finding, next, lr_p, _) = candidates.swap_remove(best);
        let cost_after = next.fit().cost;
        let finding = relabel(finding, now, next.fit());
        (
            Some((Step::new(finding, now.cost, cost_after, lr_p), next)),
            attempts,
        )
    }
}

/// Whether the deferred measurement step `measured`, a switch to the piecewise
/// time-invariant model, explains more than the structural `step` from `now` to `next`:
/// the smaller p-value of its F test, then (p-values underflow) the larger cost drop per
/// added parameter ((S − 1)q for S segments of a q-parameter model).
fn explains_more<H>(measured: &Measured<H>, step: &Step, now: &SpecFit, next: &SpecFit) -> bool {
    let Measured::Step(m) = measured else {
        return false;
    };
    let Some(tv) = &m.piecewise else {
        return false;
    };
    let added = next.n_params.saturating_sub(now.n_params).max(1) as f64;
    let gain = (step.cost_before - step.cost_after) / added;
    let extra = ((tv.segments.len().max(2) - 1) * now.n_params).max(1) as f64;
    let tv_gain = (m.step.cost_before - m.step.cost_after) / extra;
    better(Some((step.lr_p, gain)), m.step.lr_p, tv_gain)
}

/// Judges at `level` the refit `next` of `current` with a finding's effect
/// ([`Hypothesis::augment`]): the outcome, and when accepted the refit with its LR p-value
/// and cost drop per added parameter.
fn judge_refit<H: Hypothesis>(
    current: &H,
    next: Option<Result<H>>,
    data: &FrequencyData<f64>,
    level: f64,
) -> (Outcome, Option<(H, f64, f64)>) {
    let now = current.fit();
    let next = match next {
        None => return (Outcome::NotApplicable, None),
        Some(Err(e)) => {
            return (
                Outcome::Failed {
                    reason: e.to_string(),
                },
                None,
            );
        }
        Some(Ok(next)) => next,
    };
    let fit = next.fit();
    if fit.n_params <= now.n_params {
        return (Outcome::NotLarger, None);
    }
    if !fit.is_stable() || fit.marginal_poles() > now.marginal_poles() {
        return (Outcome::Unstable, None);
    }
    let Some(lr_p) = lr_p_value(now, fit, data.len()) else {
        return (
            Outcome::Failed {
                reason: "the likelihood-ratio test cannot be computed".into(),
            },
            None,
        );
    };
    if !(lr_p < level) {
        return (Outcome::Rejected { lr_p, level }, None);
    }
    let added = (fit.n_params - now.n_params) as f64;
    let gain = (now.cost - fit.cost) / added;
    (Outcome::Accepted { lr_p }, Some((next, lr_p, gain)))
}

/// A missing-resonance finding whose refit added no complex pole pair (the added poles
/// are real) is relabelled a missing pole: the effect names what the data took.
fn relabel(mut finding: Finding, before: &SpecFit, after: &SpecFit) -> Finding {
    if finding.effect == Effect::MissingResonance
        && after.custom.is_none()
        && complex_pairs(&after.poles) <= complex_pairs(&before.poles)
    {
        finding.effect = Effect::MissingPole;
    }
    finding
}

/// The number of complex-conjugate pole pairs (|Im p| above 10⁻⁸·|p|).
pub(crate) fn complex_pairs(poles: &[crate::scalar::Complex<f64>]) -> usize {
    poles.iter().filter(|p| p.im > 1e-8 * p.norm()).count()
}
