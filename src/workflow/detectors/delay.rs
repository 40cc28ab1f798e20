use super::score::ScoreTest;
use crate::data::FrequencyData;
use crate::scalar::Complex;
use crate::workflow::finding::{
    Context, Detail, DetailFields, Detector, Effect, Finding, NamedValues,
};
use crate::workflow::spec::SpecFit;

/// A linear phase trend of Y/(ĜU) in ω: a missing delay e^{−iωτ}.
///
/// A small extra delay δ changes the output by Ĝ U (e^{−iωδ} − 1) ≈ −iω δ Ĝ U, so the
/// normalised residual is r_k ≈ δ a_k with a_k = −iω_k Ĝ_k U_k/σ_k: the weighted LS of the
/// phase arg(Y_k/(Ĝ_k U_k)) against ω_k with phase variance σ_k²/(2|Ĝ_k U_k|²) (McKelvey
/// eq. 23 linearised in τ), c_k the line's normaliser. The part of a that the model's own
/// parameters can produce is removed (a⊥ = (I − P_J) a, P_J the projector on the columns of
/// the residual Jacobian J, from its SVD): the score (Lagrange-multiplier) test of an
/// added delay. Estimate δ̂ = a⊥ᵀr/‖a⊥‖², var δ̂ = μλ/(2‖a⊥‖²) (real-stacked; μ = E|r_k|²
/// under the null, λ = 1 for a known noise level, else λ̂ = V/(N − p/2)); statistic
/// t = δ̂/std δ̂, two-sided p = erfc(|t|/√2) (Student's t with 2N − p degrees of
/// freedom when λ is estimated).
///
/// Proposal: the same spec with `delay = true`; detail: [`TimeDelayDetail`].
#[derive(Debug, Clone, Copy, Default)]
pub struct TimeDelay;

impl Detector for TimeDelay {
    fn effect(&self) -> Effect {
        Effect::TimeDelay
    }

    fn detect(&self, data: &FrequencyData<f64>, fit: &SpecFit, _ctx: &Context) -> Option<Finding> {
        if fit.spec.delay {
            return None;
        }
        // a_k = −iω_k Ĝ_k U_k / c_k
        let direction: Vec<Complex<f64>> = (0..fit.residuals.len())
            .map(|k| {
                Complex::new(0.0, -fit.omega[k]) * fit.response[k] * data.u()[k] / fit.scale[k]
            })
            .collect();
        let test = ScoreTest::new(fit, &direction)?;
        let (slope, std, t, p_value) = (test.estimate, test.std, test.t, test.p_value);
        let proposal = crate::workflow::ModelSpec {
            delay: true,
            ..fit.spec.clone()
        };
        Some(Finding {
            effect: Effect::TimeDelay,
            statistic: t,
            p_value,
            detail: Detail::TimeDelay(TimeDelayDetail {
                slope,
                slope_std: std,
                t,
            }),
            proposal,
        })
    }
}

/// The detail of a [`TimeDelay`] finding.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimeDelayDetail {
    /// The estimated extra delay δ̂ (s), named `slope`.
    pub slope: f64,
    /// Its standard deviation (s), named `slope_std`.
    pub slope_std: f64,
    /// The statistic t = δ̂/std δ̂, named `t`.
    pub t: f64,
}

impl DetailFields for TimeDelayDetail {
    fn entries(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("slope", self.slope),
            ("slope_std", self.slope_std),
            ("t", self.t),
        ]
    }

    fn take_from(values: &mut NamedValues) -> Option<Self> {
        Some(Self {
            slope: values.take("slope")?,
            slope_std: values.take("slope_std")?,
            t: values.take("t")?,
        })
    }
}
