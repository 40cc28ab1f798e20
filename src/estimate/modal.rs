//! Modal fits of continuous-time models to sampled data through the zero-order hold
//! (McKelvey section 2.3): [`fit_modal`] from a rational start.

use super::{Pipeline, estimate};
use crate::basis::PolyBasis;
use crate::criterion::MaximumLikelihood;
use crate::data::FrequencyData;
use crate::error::{FdidError, Result};
use crate::fit::{Fit, Stage, StageKind};
use crate::model::{Domain, Modal, ModelStructure, Rational};
use crate::scalar::Real;
use crate::solver::{Solution, Termination};

/// Settings of [`fit_modal`].
///
/// | setting | default | meaning |
/// |---|---|---|
/// | `domain` | [`Domain::Continuous`] | s = iω (band-limited data) or ZOH-sampled |
/// | `direct` | false | estimate a direct term d |
/// | `transient` | false | estimate the transient term T (McKelvey eqs. 4–5, 9–10) |
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModalOptions<T: Real> {
    /// Continuous-time or ZOH-sampled evaluation.
    pub domain: Domain<T>,
    /// Estimate a direct term d.
    pub direct: bool,
    /// Estimate the transient term; its sample time is the ZOH model's or, in continuous
    /// time, the data's.
    pub transient: bool,
}

impl<T: Real> Default for ModalOptions<T> {
    fn default() -> Self {
        Self::continuous()
    }
}

impl<T: Real> ModalOptions<T> {
    /// Continuous time (s = iω), no direct term, no transient.
    pub fn continuous() -> Self {
        Self {
            domain: Domain::Continuous,
            direct: false,
            transient: false,
        }
    }

    /// ZOH-sampled with sample time `ts` (s), no direct term, no transient.
    pub fn zoh(ts: T) -> Self {
        Self {
            domain: Domain::Discrete { ts },
            ..Self::continuous()
        }
    }

    /// With a direct term d.
    #[must_use]
    pub fn with_direct(mut self) -> Self {
        self.direct = true;
        self
    }

    /// With the transient term T(z) = Σ τ/(1 − e^{pTs}z⁻¹).
    #[must_use]
    pub fn with_transient(mut self) -> Self {
        self.transient = true;
        self
    }
}

/// Fits a [`Modal`] model with `n_real` real poles and `n_pairs` complex pairs to `data`:
///
/// 1. the matching rational model by `pipeline`'s Levy and SK stages (its ML stage is
///    left for the modal model): [`Rational::continuous`] of order n = n_real + 2 n_pairs
///    for [`Domain::Continuous`], [`Rational::discrete`] of order n with Ts for
///    [`Domain::Discrete`] (numerator degree n: the ZOH model of a strictly proper mode
///    starts with z⁻¹, with d the constant term), without transient;
/// 2. its poles converted to s and the residues, d and τ by linear least squares
///    ([`Modal::start_from_rational`]; a discrete-time pole z on the negative real axis,
///    which the misfit of an unmodelled transient can produce, starts as the real pole
///    ln|z|/Ts of the same decay rate instead of failing);
/// 3. maximum likelihood (McKelvey eq. 23) on all parameters with `pipeline.ml`
///    (Levenberg–Marquardt; skipped when `None`), the transient included in Ŷ = GU + T;
///    when it stops at its evaluation cap, it is retried from the poles of the rational
///    model refined by its own ML stage and the lower cost kept;
/// 4. the statistics by [`Fit::new`].
///
/// # Errors
/// Invalid orders or sample time ([`Modal::new`]); a transient requested in continuous
/// time for data without a sample time; as [`ModelStructure::check_data`],
/// [`Pipeline::fit`], [`Modal::start_from_rational`] and the ML solve.
pub fn fit_modal<T: Real>(
    pipeline: &Pipeline,
    data: &FrequencyData<T>,
    n_real: usize,
    n_pairs: usize,
    options: ModalOptions<T>,
) -> Result<Fit<T, Modal<T>>> {
    let mut model = Modal::new(n_real, n_pairs, options.direct, options.domain)?;
    if options.transient {
        let ts = match options.domain {
            Domain::Discrete { ts } => ts,
            Domain::Continuous => data.ts().ok_or_else(|| FdidError::InvalidArgument {
                name: "ts",
                value: "none".into(),
                reason: "the transient term of a continuous-time model needs the data's \
                         sample time"
                    .into(),
            })?,
        };
        model = model.with_transient(ts)?;
    }
    model.check_data(data)?;
    let n = model.order();
    // the rational start carries the transient too (it shares the poles), so that the
    // leakage of a short record does not bend the starting poles
    let rational = match (options.domain, model.transient_ts()) {
        (Domain::Continuous, t) => {
            let r = Rational::continuous(n, if options.direct { n } else { n - 1 }, data.omega())?;
            match t {
                Some(ts)
                    if r.basis().max_degree() > 0
                        && matches!(r.basis(), PolyBasis::PartialFractions { .. }) =>
                {
                    r.with_sampled_transient(ts)?
                }
                _ => r,
            }
        }
        (Domain::Discrete { ts }, Some(_)) => Rational::discrete(n, n, ts)?.with_transient()?,
        (Domain::Discrete { ts }, None) => Rational::discrete(n, n, ts)?,
    };
    let linear_stages = Pipeline {
        ml: None,
        ..*pipeline
    };
    let rfit = linear_stages.fit(&rational, data)?;
    let w = pipeline.weighting;
    let start = model.start_from_rational_with(rfit.model(), rfit.theta(), data, w, true)?;
    let mut stages: Vec<Stage<T>> = rfit
        .stages()
        .iter()
        .map(|s| Stage {
            kind: StageKind::RationalStart(Box::new(s.kind.clone())),
            solution: s.solution.clone(),
            lines: s.lines,
        })
        .collect();
    let ml = MaximumLikelihood { weighting: w };
    let start_cost = crate::criterion::MlProblem::new(&model, data, w)?.cost(&start);
    stages.push(Stage::new(
        StageKind::ModalLs,
        Solution {
            theta: start.clone(),
            cost: start_cost,
            iterations: 1,
            termination: Termination::Direct,
        },
    ));
    let mut theta = start;
    if let Some(lm) = &pipeline.ml {
        let mut sol = estimate(&model, data, &ml, lm, Some(&theta))?;
        if !sol.converged() {
            // a poor start (e.g. poles bent by the unmodelled transient): retry from the
            // poles of the rational model refined by ML, keep the lower cost
            let retry = pipeline
                .fit(&rational, data)
                .and_then(|r| model.start_from_rational_with(r.model(), r.theta(), data, w, true))
                .and_then(|t| estimate(&model, data, &ml, lm, Some(&t)));
            if let Ok(other) = retry
                && other.cost < sol.cost
            {
                sol = other;
            }
        }
        theta = sol.theta.clone();
        stages.push(Stage::new(StageKind::Ml, sol));
    }
    Fit::new(model, data, theta, w, stages)
}
