use super::score::ScoreTest;
use crate::data::FrequencyData;
use crate::model::Domain;
use crate::scalar::Complex;
use crate::workflow::finding::{
    Context, Detail, DetailFields, Detector, Effect, Finding, NamedValues,
};
use crate::workflow::spec::SpecFit;

/// Which coefficient an [`OrderIncrease`] test adds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Added {
    /// a_{na+1}: one more pole (`missing_pole`).
    Pole,
    /// b_{nb+1}: one more zero (`missing_zero`).
    Zero,
}

/// The score (Lagrange-multiplier) test of one more denominator or numerator coefficient
/// of G = B(x)/A(x): a missing pole or zero.
///
/// With x_k = z_k⁻¹ (discrete time) or x_k = iω_k/ω_max (continuous time, the highest
/// power of the scaled Laplace variable), at b_{nb+1} = 0 (resp. a_{na+1} = 0) the output
/// derivative is ∂Ŷ_k/∂b = e^{−iω_kτ̂} x_k^{nb+1} U_k/Â_k (resp. ∂Ŷ_k/∂a = −Ŷ_k x_k^{na+1}/Â_k
/// with Ŷ_k = Ĝ_k U_k + T_k, the transient sharing the denominator),
/// Â = Π(1 − p̂ x) (discrete) or Π(x − p̂/ω_max) (continuous) from the fitted poles (its
/// constant factor cancels in t). Normalised and projected off the model's residual Jacobian,
/// d⊥ = (I − P_J)(∂Ŷ/∂θ_new / c_k) real-stacked; the estimate of the new coefficient is
/// β̂ = d⊥ᵀr/‖d⊥‖² (one Gauss–Newton step of McKelvey eq. 23 on the larger model), its
/// variance μλ/(2‖d⊥‖²); statistic t = β̂/std β̂, two-sided p = erfc(|t|/√2) (Student's
/// t with 2N − p degrees of freedom when λ is estimated). A
/// broadband slope mismatch at high or low frequency shows up here as a significant
/// added coefficient.
///
/// Proposal: na + 1 (pole) or nb + 1 (zero); detail: [`OrderIncreaseDetail`].
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
        let one = Complex::new(1.0, 0.0);
        // x_k: z_k⁻¹ in discrete time; iω_k/ω_max in continuous time (scaled so that the
        // powers stay O(1); the t statistic does not depend on the scale)
        let (x, poles): (Vec<Complex<f64>>, Vec<Complex<f64>>) = match fit.spec.domain {
            Domain::Discrete { ts } => (
                fit.omega
                    .iter()
                    .map(|w| Complex::new(0.0, -w * ts).exp())
                    .collect(),
                fit.poles.clone(),
            ),
            Domain::Continuous => {
                let w_max = fit.omega.iter().fold(0.0_f64, |m, w| m.max(w.abs()));
                if !(w_max > 0.0) {
                    return None;
                }
                (
                    fit.omega
                        .iter()
                        .map(|w| Complex::new(0.0, w / w_max))
                        .collect(),
                    fit.poles.iter().map(|p| p / w_max).collect(),
                )
            }
        };
        let discrete = matches!(fit.spec.domain, Domain::Discrete { .. });
        // d_k = ∂Ŷ_k/∂θ_new / c_k
        let direction: Vec<Complex<f64>> = (0..fit.residuals.len())
            .map(|k| {
                let a = if discrete {
                    poles.iter().fold(one, |s, p| s * (one - p * x[k]))
                } else {
                    poles.iter().fold(one, |s, p| s * (x[k] - p))
                };
                let dyhat = match self.0 {
                    Added::Zero => {
                        let delay = fit
                            .delay
                            .map_or(one, |(tau, _)| Complex::new(0.0, -fit.omega[k] * tau).exp());
                        delay * x[k].powu((fit.spec.nb + 1) as u32) * data.u()[k] / a
                    }
                    // Ŷ = (B U e^{−iωτ} + t)/A: the transient shares the denominator
                    Added::Pole => -fit.output[k] * x[k].powu((fit.spec.na + 1) as u32) / a,
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
            detail: Detail::OrderIncrease(OrderIncreaseDetail {
                coefficient,
                std,
                t,
            }),
            proposal,
        })
    }
}

/// The detail of an [`OrderIncrease`] finding.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrderIncreaseDetail {
    /// The estimate β̂ of the added coefficient, named `coefficient`.
    pub coefficient: f64,
    /// Its standard deviation, named `std`.
    pub std: f64,
    /// The statistic t = β̂/std β̂, named `t`.
    pub t: f64,
}

impl DetailFields for OrderIncreaseDetail {
    fn entries(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("coefficient", self.coefficient),
            ("std", self.std),
            ("t", self.t),
        ]
    }

    fn take_from(values: &mut NamedValues) -> Option<Self> {
        Some(Self {
            coefficient: values.take("coefficient")?,
            std: values.take("std")?,
            t: values.take("t")?,
        })
    }
}
