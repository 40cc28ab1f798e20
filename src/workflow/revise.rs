//! The revision pass: an accepted one-parameter augmentation (a delay, a pole, a zero)
//! is swapped for another of the same size when, with the other effects in the model, the
//! other explains the data better.
//!
//! The greedy loop of [`Workflow::run`] can name a pole where the truth has a delay when
//! a larger effect (a missing resonance) is still unmodelled: one more pole or zero also
//! bends the phase. Once the other effects are in, the comparison is fair. For each such
//! step, the pass removes its augmentation from the final model (the reduced model), runs
//! the other one-parameter detectors on the reduced fit, refits their proposals, and
//! among those whose likelihood-ratio test against the reduced model is significant at α
//! keeps the one of largest likelihood when it beats the current model and has no more
//! unstable or marginal poles ([`SpecFit::marginal_poles`]) than it (same
//! number of parameters: the larger likelihood is the better model, as AIC or BIC would
//! say; no test level is involved). The step then reports the new effect with its
//! detector's p-value on the reduced fit, the reduced and new costs, and the
//! likelihood-ratio p-value of the augmentation.
use super::finding::{Context, Effect};
use super::spec::{SpecFit, fit_spec};
use super::{Step, Workflow, lrt};
use crate::data::FrequencyData;
use crate::estimate::ModelSpec;

/// The effects that add one parameter to the system part and can stand in for each other.
fn swappable(effect: Effect) -> bool {
    matches!(
        effect,
        Effect::TimeDelay | Effect::MissingPole | Effect::MissingZero
    )
}

/// `spec` without the augmentation that `effect` added, if it has it.
fn without(spec: &ModelSpec, effect: Effect) -> Option<ModelSpec> {
    let mut reduced = spec.clone();
    match effect {
        Effect::TimeDelay if spec.delay => reduced.delay = false,
        Effect::MissingPole if spec.na > 0 => reduced.na -= 1,
        Effect::MissingZero if spec.nb > 0 => reduced.nb -= 1,
        _ => return None,
    }
    Some(reduced)
}

impl Workflow {
    /// Swaps accepted delay/pole/zero steps for a better one-parameter alternative
    /// (module documentation); at most `steps.len()` passes.
    pub(crate) fn revise(
        &self,
        data: &FrequencyData<f64>,
        ctx: &Context,
        steps: &mut [Step],
        step_fits: &mut [SpecFit],
        current: &mut SpecFit,
    ) {
        for _ in 0..steps.len() {
            let mut improved = false;
            for (slot, slot_fit) in steps.iter_mut().zip(step_fits.iter_mut()) {
                let effect = slot.effect;
                if !swappable(effect) {
                    continue;
                }
                let Some(spec) = without(&current.spec, effect) else {
                    continue;
                };
                let Ok(reduced) = fit_spec(&spec, data) else {
                    continue;
                };
                let mut best: Option<(Step, SpecFit)> = None;
                for detector in &self.detectors {
                    let other = detector.effect();
                    if other == effect || !swappable(other) {
                        continue;
                    }
                    let Some(finding) = detector.detect(data, &reduced, ctx) else {
                        continue;
                    };
                    let Ok(next) = fit_spec(&finding.proposal, data) else {
                        continue;
                    };

                    let bar = best.as_ref().map_or(current.cost, |(_, f)| f.cost);
                    if next.n_params != current.n_params
                        || !(next.cost < bar * (1.0 - 1e-9))
                        || (current.is_stable() && !next.is_stable())
                        || next.marginal_poles() > current.marginal_poles()
                    {
                        continue;
                    }
                    let Ok(test) = lrt::lr_test(
                        reduced.cost,
                        reduced.n_params,
                        next.cost,
                        next.n_params,
                        data.len(),
                        reduced.noise_known,
                    ) else {
                        continue;
                    };
                    if !(test.p_value < ctx.alpha) {
                        continue;
                    }
                    let step = Step {
                        revised: true,
                        ..Step::new(finding, reduced.cost, next.cost, test.p_value)
                    };
                    best = Some((step, next));
                }
                if let Some((step, next)) = best {
                    *slot = step;
                    *slot_fit = next.clone();
                    *current = next;
                    improved = true;
                }
            }
            if !improved {
                break;
            }
        }
    }
}
