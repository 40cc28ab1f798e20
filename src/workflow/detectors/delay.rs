use crate::FrequencyData;
use crate::stats::erfc;
use crate::workflow::finding::{Context, Detail, Detector, Effect, Finding, residual_power};
use crate::workflow::spec::SpecFit;

/// A linear phase trend of Y/(ĜU) in ω: a missing delay e^{−iωτ}.
///
/// A small extra delay δ changes the output by Ĝ U (e^{−iωδ} − 1) ≈ −iω δ Ĝ U, so the
/// normalised residual is r_k ≈ δ a_k with a_k = −iω_k Ĝ_k U_k/σ_k: the weighted LS of the
/// phase arg(Y_k/(Ĝ_k U_k)) against ω_k with phase variance σ_k²/(2|Ĝ_k U_k|²) (McKelvey
/// eq. 23 linearised in τ). Estimate δ̂ = Σ Re(ā_k r_k)/Σ|a_k|², var δ̂ = μ/(2Σ|a_k|²)
/// (μ = E|r_k|² under the null, λ̂ when the noise level is estimated); statistic
/// t = δ̂/std δ̂, two-sided p = erfc(|t|/√2). Not projected on the model's own Jacobian, so
/// the test is conservative (part of a delay is absorbed by the rational fit).
///
/// Proposal: the same spec with `delay = true`; detail: `slope` (δ̂, s), `slope_std`, `t`.
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
        let (power, mean, _) = residual_power(fit);
        let lambda = if fit.noise_known {
            1.0
        } else {
            fit.residuals
                .iter()
                .zip(&power)
                .find(|(r, _)| r.norm_sqr() > 0.0)
                .map(|(r, p)| r.norm_sqr() / p)?
        };
        let (mut num, mut den) = (0.0, 0.0);
        for k in 0..fit.residuals.len() {
            let gu = fit.response[k] * data.u()[k];
            let a = crate::Complex::new(0.0, -fit.omega[k]) * gu / fit.scale[k];
            num += (a.conj() * fit.residuals[k]).re;
            den += a.norm_sqr();
        }
        if !(den > 0.0) {
            return None;
        }
        let slope = num / den;
        let std = (mean * lambda / (2.0 * den)).sqrt();
        let t = slope / std;
        let p_value = erfc(t.abs() / std::f64::consts::SQRT_2);
        let proposal = crate::workflow::ModelSpec {
            delay: true,
            ..fit.spec.clone()
        };
        Some(Finding {
            effect: Effect::TimeDelay,
            statistic: t,
            p_value,
            detail: Detail::default()
                .with("slope", slope)
                .with("slope_std", std)
                .with("t", t),
            proposal,
        })
    }
}
