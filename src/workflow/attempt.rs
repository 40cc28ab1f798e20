//! What became of each refit the workflow tried: the record behind its verdict.

use super::finding::Effect;

/// One structural proposal the workflow refitted at a step, and its outcome.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Attempt {
    /// The effect the detector named.
    pub effect: Effect,
    /// The detector's p-value.
    pub p_value: f64,
    /// What happened to the refit.
    pub outcome: Outcome,
}

/// The outcome of one refit ([`Attempt`]).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(tag = "outcome", rename_all = "snake_case"))]
pub enum Outcome {
    /// The estimator failed; its message.
    Failed {
        /// The estimator's error, as text.
        reason: String,
    },
    /// The structure cannot take the effect (it has it already, or the proposal equals
    /// the current structure).
    NotApplicable,
    /// The refit has no more parameters than the current model.
    NotLarger,
    /// The refit is unstable, or it has more poles on the stability boundary than the
    /// current model
    /// ([`crate::workflow::SpecFit::marginal_poles`]): a spurious pole explains the data
    /// (never accepted).
    Unstable,
    /// The likelihood-ratio test did not accept the refit: its p-value `lr_p` is not
    /// below the `level`.
    Rejected {
        /// The likelihood-ratio p-value.
        lr_p: f64,
        /// The level it was compared with (α, or α/m when strict).
        level: f64,
    },
    /// Accepted by the likelihood-ratio test, but another refit explained more.
    Outexplained {
        /// The likelihood-ratio p-value.
        lr_p: f64,
    },
    /// Accepted: the step taken.
    Accepted {
        /// The likelihood-ratio p-value.
        lr_p: f64,
    },
}

impl Outcome {
    /// One line for the verdict, e.g. `LR p = 0.21 >= 0.01` or `unstable`.
    pub fn describe(&self) -> String {
        match self {
            Outcome::Failed { reason } => format!("failed: {reason}"),
            Outcome::NotApplicable => "not applicable to this structure".into(),
            Outcome::NotLarger => "no more parameters than the current model".into(),
            Outcome::Unstable => {
                "the refit is unstable or has a pole on the stability boundary".into()
            }
            Outcome::Rejected { lr_p, level } => {
                format!("LR p = {} >= {}", short(*lr_p), short(*level))
            }
            Outcome::Outexplained { lr_p } => {
                format!("accepted (LR p = {}), another explained more", short(*lr_p))
            }
            Outcome::Accepted { lr_p } => format!("accepted (LR p = {})", short(*lr_p)),
        }
    }
}

/// A p-value with three significant digits.
fn short(p: f64) -> String {
    if p == 0.0 || !p.is_finite() {
        format!("{p}")
    } else if p < 1e-3 {
        format!("{p:.2e}")
    } else {
        format!("{:.3}", p)
    }
}

/// An accepted step the backward-elimination pass removed from the final model: without
/// its augmentation the likelihood-ratio test no longer rejects the smaller model.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Elimination {
    /// The effect removed.
    pub effect: Effect,
    /// The index of the step (0-based, in [`super::Report::steps`]) that added it.
    pub step: usize,
    /// Cost of the model with the effect.
    pub cost_with: f64,
    /// Cost of the model without it.
    pub cost_without: f64,
    /// The likelihood-ratio p-value of the effect given the others (≥ α: not significant).
    pub lr_p: f64,
}
