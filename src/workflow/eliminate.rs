//! The backward-elimination pass: after the loop, every accepted augmentation is tested
//! again given all the others, and removed when it is no longer significant.
//!
//! A greedy forward search can accept an effect early that a later one explains better
//! (a delay accepted before a missing resonance next to a zero: once the resonance is in,
//! the delay is τ̂ ≈ 0 ± its standard deviation). For each accepted structural step the
//! pass refits the final structure without the step's augmentation and computes the
//! likelihood-ratio p-value of the augmentation given the rest; the least significant one
//! with p ≥ α is removed, the reduced fit becomes the final model, and the pass repeats
//! until every remaining augmentation is significant. A reduced fit that fails or is
//! unstable keeps the augmentation.
use super::attempt::Elimination;
use super::finding::{Detail, Effect};
use super::spec::{SpecFit, fit_spec};
use super::{Acceptance, Step, Workflow, lr_p_value};
use crate::data::FrequencyData;
use crate::estimate::ModelSpec;

/// `spec` without the augmentation the structural `step` added, if it still has it: a
/// delay, one pole (`missing_pole`), one zero, a pole pair with its two zeros (a
/// `missing_resonance` detail, also when relabelled `missing_pole` because the pair came
/// out real), the transient term, or one order of the noise model.
pub(crate) fn without_step(spec: &ModelSpec, step: &Step) -> Option<ModelSpec> {
    let mut reduced = spec.clone();
    if matches!(step.detail, Detail::MissingResonance(_)) {
        if spec.na < 2 || spec.nb < 2 {
            return None;
        }
        reduced.na -= 2;
        reduced.nb -= 2;
        return Some(reduced);
    }
    match step.effect {
        Effect::TimeDelay if spec.delay => reduced.delay = false,
        Effect::MissingPole if spec.na > 0 => reduced.na -= 1,
        Effect::MissingZero if spec.nb > 0 => reduced.nb -= 1,
        Effect::Transient if spec.transient => reduced.transient = false,
        Effect::ColoredNoise => {
            reduced.noise_order = match spec.noise_order? {
                0 | 1 => None,
                n => Some(n - 1),
            }
        }
        _ => return None,
    }
    Some(reduced)
}

impl Workflow {
    /// Removes, one at a time, the least significant accepted structural augmentation
    /// whose likelihood-ratio p-value given the others is at least α (module
    /// documentation); `current` becomes the reduced fit. Returns the removals in order.
    pub(crate) fn eliminate(
        &self,
        data: &FrequencyData<f64>,
        alpha: f64,
        steps: &[Step],
        current: &mut SpecFit,
    ) -> Vec<Elimination> {
        let mut removed: Vec<Elimination> = Vec::new();
        loop {
            let mut weakest: Option<(Elimination, SpecFit)> = None;
            for (i, step) in steps.iter().enumerate() {
                if step.acceptance() != Acceptance::LikelihoodRatio
                    || removed.iter().any(|r| r.step == i)
                {
                    continue;
                }
                let Some(spec) = without_step(&current.spec, step) else {
                    continue;
                };
                let Ok(reduced) = fit_spec(&spec, data) else {
                    continue;
                };
                // the step's own rule (`judge_refit`): no unstable or new marginal pole
                if !reduced.is_stable() || reduced.marginal_poles() > current.marginal_poles() {
                    continue;
                }
                let Some(lr_p) = lr_p_value(&reduced, current, data.len()) else {
                    continue;
                };
                if lr_p < alpha || weakest.as_ref().is_some_and(|(w, _)| w.lr_p >= lr_p) {
                    continue;
                }
                let elimination = Elimination {
                    effect: step.effect,
                    step: i,
                    cost_with: current.cost,
                    cost_without: reduced.cost,
                    lr_p,
                };
                weakest = Some((elimination, reduced));
            }
            let Some((elimination, reduced)) = weakest else {
                return removed;
            };
            *current = reduced;
            removed.push(elimination);
        }
    }
}
