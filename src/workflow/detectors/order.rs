use super::score::ScoreTest;
use crate::workflow::finding::{Context, Detail, Detector, Effect, Finding};
use crate::workflow::spec::{SpecDomain, SpecFit};
use crate::{Complex, FrequencyData};

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
/// d⊥ = (I − P_J)(∂Ŷ/∂θ_new / c_k) real-stacked; the estimate of the new coefficient is
/// β̂ = d⊥ᵀr/‖d⊥‖² (one Gauss–Newton step of McKelvey eq. 23 on the larger model), its
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
        let one = Complex::new(1.0, 0.0);
        // d_k = ∂Ŷ_k/∂θ_new / c_k
        let direction: Vec<Complex<f64>> = (0..fit.residuals.len())
            .map(|k| {
                let zinv = Complex::new(0.0, -fit.omega[k] * ts).exp();
                let a = fit.poles.iter().fold(one, |s, p| s * (one - p * zinv));
                let dyhat = match self.0 {
                    Added::Zero => zinv.powu((fit.spec.nb + 1) as u32) * data.u()[k] / a,
                    Added::Pole => {
                        -fit.response[k] * zinv.powu((fit.spec.na + 1) as u32) * data.u()[k] / a
                    }
                };
                dyhat / fit.scale[k]
            })
            .collect();
        let test = ScoreTest::new(fit, &direction)?;
        let (coefficient, std, t, p_value) = (test.estimate, test.std, test.t, test.p_value);
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
