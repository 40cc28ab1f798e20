use super::delay::two_sided_p;
use crate::workflow::finding::{Context, Detail, Detector, Effect, Finding, residual_power};
use crate::workflow::spec::{SpecDomain, SpecFit};
use crate::{Complex, FrequencyData};
use nalgebra::DVector;

/// Which coefficient an [`OrderIncrease`] test adds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Added {
    /// a_{na+1}: one more pole (`missing_pole`).
    Pole,
    /// b_{nb+1}: one more zero (`missing_zero`).
    Zero,
}

/// The score (Lagrange-multiplier) test of one more denominator or numerator coefficient
/// of a discrete-time model G = B(z⁻¹)/A(z⁻¹): a missing pole or zero.
///
/// At b_{nb+1} = 0 (resp. a_{na+1} = 0) the output derivative is
/// ∂Ŷ_k/∂b = z_k^{−(nb+1)} U_k/Â_k (resp. ∂Ŷ_k/∂a = −Ĝ_k z_k^{−(na+1)} U_k/Â_k), Â from the
/// fitted poles. Normalised and projected off the model's residual Jacobian,
/// d⊥ = (I − P_J)(−∂Ŷ/∂θ_new / c_k) real-stacked; the estimate of the new coefficient is
/// β̂ = −d⊥ᵀr/‖d⊥‖² (one Gauss–Newton step of McKelvey eq. 23 on the larger model), its
/// variance μλ/(2‖d⊥‖²); statistic t = β̂/std β̂, two-sided p = erfc(|t|/√2) (Student's
/// t with 2N − p degrees of freedom when λ is estimated). A
/// broadband slope mismatch at high or low frequency shows up here as a significant
/// added coefficient. Applies to z-domain specs; `None` for s-domain ones.
///
/// Proposal: na + 1 (pole) or nb + 1 (zero); detail: `coefficient` (β̂), `std`, `t`.
#[derive(Debug, Clone, Copy)]
pub struct OrderIncrease(pub Added);

impl Detector for OrderIncrease {
    fn effect(&self) -> Effect {
        match self.0 {
            Added::Pole => Effect::MissingPole,
            Added::Zero => Effect::MissingZero,
        }
    }

    fn detect(&self, data: &FrequencyData<f64>, fit: &SpecFit, _ctx: &Context) -> Option<Finding> {
        let SpecDomain::Z { ts } = fit.spec.domain else {
            return None;
        };
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
        let n = fit.residuals.len();
        let mut d = DVector::<f64>::zeros(2 * n);
        let mut r = DVector::<f64>::zeros(2 * n);
        let one = Complex::new(1.0, 0.0);
        for k in 0..n {
            let zinv = Complex::new(0.0, -fit.omega[k] * ts).exp();
            let a = fit.poles.iter().fold(one, |s, p| s * (one - p * zinv));
            let dyhat = match self.0 {
                Added::Zero => zinv.powu((fit.spec.nb + 1) as u32) * data.u()[k] / a,
                Added::Pole => {
                    -fit.response[k] * zinv.powu((fit.spec.na + 1) as u32) * data.u()[k] / a
                }
            };
            let v = -dyhat / fit.scale[k];
            d[2 * k] = v.re;
            d[2 * k + 1] = v.im;
            r[2 * k] = fit.residuals[k].re;
            r[2 * k + 1] = fit.residuals[k].im;
        }
        let d = super::delay::project_off(&fit.jacobian, d);
        let den = d.norm_squared();
        if !(den > 0.0) || !den.is_finite() {
            return None;
        }
        let coefficient = -d.dot(&r) / den;
        let std = (mean * lambda / (2.0 * den)).sqrt();
        let t = coefficient / std;
        let p_value = two_sided_p(t, fit);
        let mut proposal = fit.spec.clone();
        match self.0 {
            Added::Pole => proposal.na += 1,
            Added::Zero => proposal.nb += 1,
        }
        Some(Finding {
            effect: self.effect(),
            statistic: t,
            p_value,
            detail: Detail::default()
                .with("coefficient", coefficient)
                .with("std", std)
                .with("t", t),
            proposal,
        })
    }
}
