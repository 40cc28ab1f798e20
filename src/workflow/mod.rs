//! The discrepancy workflow: fit a model, find where it and the measurement disagree,
//! name the missing effect, add it, and keep it only if a likelihood-ratio test says the
//! gap shrank significantly.
//!
//! Each step runs every [`Detector`] on the normalised residuals r_k of the current fit
//! (the terms of McKelvey's ML cost, eq. 23), refits the proposal of every [`Finding`]
//! below the level α ([`fit_spec`]), keeps those the likelihood-ratio test of
//! [`lrt::lr_test`] accepts at α (for a new noise model the concentrated-likelihood test
//! [`lrt::concentrated_lr_test`] with W = ln(V/N), eq. 26), and takes the one that explains most (smallest LR
//! p-value, then the largest cost drop per added parameter). The loop
//! stops when the fit is consistent with the noise (cost and whiteness tests of
//! [`crate::validation::Validation`] pass at α), when no detector fires, or after
//! `max_steps`.
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
mod bands;
pub mod detectors;
mod finding;
pub mod lrt;
mod revise;
mod spec;

pub use bands::{Band, disagreement_bands};
pub use finding::{Context, Detail, Detector, Effect, Finding};
pub use spec::{ModelSpec, SpecCriterion, SpecDomain, SpecFit, fit_spec};

use crate::{FdidError, FrequencyData, Result};

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
    /// p-value of the likelihood-ratio test (smaller model vs augmented one).
    pub lr_p: f64,
    /// The detector's named values.
    pub detail: Detail,
}

/// The workflow's outcome: accepted steps, the effects in order, and the final fit.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Report {
    /// Accepted steps in order.
    pub steps: Vec<Step>,
    /// The effects of `steps`, in order.
    pub effects: Vec<Effect>,
    /// Whether the final fit passes the cost and whiteness tests at α.
    pub consistent_with_noise: bool,
    /// The fit of the starting model (before any step).
    pub initial_fit: SpecFit,
    /// The final fit.
    #[cfg_attr(feature = "serde", serde(rename = "final"))]
    pub final_fit: SpecFit,
}

/// The workflow's settings.
///
/// | field | default | meaning |
/// |---|---|---|
/// | `detectors` | [`TimeDelay`](detectors::TimeDelay), [`MissingResonance`](detectors::MissingResonance), [`Transient`](detectors::Transient), [`ColoredNoise`](detectors::ColoredNoise), [`OrderIncrease`](detectors::OrderIncrease) for a pole and a zero | the tests run at each step |
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
            ],
            max_steps: 4,
        }
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
    /// # Errors
    /// [`FdidError::InvalidArgument`] for α outside (0, 1); the start fit's errors (a
    /// proposal whose fit fails is skipped).
    pub fn run(&self, data: &FrequencyData<f64>, start: ModelSpec, ctx: Context) -> Result<Report> {
        let alpha = ctx.alpha;
        if !(alpha > 0.0 && alpha < 1.0) {
            return Err(FdidError::InvalidArgument {
                name: "alpha",
                value: alpha.to_string(),
                reason: "the false-alarm level lies in (0, 1)".into(),
            });
        }
        let initial_fit = fit_spec(&start, data)?;
        let mut current = initial_fit.clone();
        let mut steps = Vec::new();
        while steps.len() < self.max_steps && !current.consistent_with_noise(alpha) {
            let findings: Vec<Finding> = self
                .detectors
                .iter()
                .filter_map(|d| d.detect(data, &current, &ctx))
                .filter(|f| f.p_value < alpha && f.proposal != current.spec)
                .collect();
            // refit every proposal; keep those the likelihood-ratio test accepts and take
            // the one that explains most: smallest LR p-value, then (when p-values
            // underflow) the largest cost drop per added parameter
            let mut accepted: Option<(Finding, SpecFit, f64, f64)> = None;
            for finding in findings {
                let Ok(next) = fit_spec(&finding.proposal, data) else {
                    continue;
                };
                if next.n_params <= current.n_params {
                    continue;
                }
                let test = if next.spec.noise_order != current.spec.noise_order {
                    // a new noise model: concentrated likelihoods W = ln(V/N) (eq. 26)
                    let n = data.len() as f64;
                    lrt::concentrated_lr_test(
                        (current.cost / n).ln(),
                        current.n_params,
                        (next.cost / n).ln(),
                        next.n_params,
                        data.len(),
                    )
                } else {
                    lrt::lr_test(
                        current.cost,
                        current.n_params,
                        next.cost,
                        next.n_params,
                        data.len(),
                        current.noise_known,
                    )
                };
                let Ok(test) = test else {
                    continue;
                };
                if !(test.p_value < alpha) {
                    continue;
                }
                let gain = (current.cost - next.cost) / (next.n_params - current.n_params) as f64;
                let better = accepted.as_ref().is_none_or(|(_, _, p, g)| {
                    test.p_value < *p || (test.p_value == *p && gain > *g)
                });
                if better {
                    accepted = Some((finding, next, test.p_value, gain));
                }
            }
            let Some((finding, next, lr_p, _)) = accepted else {
                break;
            };
            steps.push(Step {
                effect: finding.effect,
                p_value: finding.p_value,
                cost_before: current.cost,
                cost_after: next.cost,
                lr_p,
                detail: finding.detail,
            });
            current = next;
        }
        self.revise(data, &ctx, &mut steps, &mut current);
        Ok(Report {
            effects: steps.iter().map(|s| s.effect).collect(),
            steps,
            consistent_with_noise: current.consistent_with_noise(alpha),
            initial_fit,
            final_fit: current,
        })
    }
}
