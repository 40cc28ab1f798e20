//! Warm starts of the structural refits of a rational spec: the poles of the model being
//! augmented, with the poles the finding adds, as the start of the proposal's fit
//! ([`ModelSpec::fit_from_poles`](crate::estimate::ModelSpec::fit_from_poles)).
//!
//! A refit from scratch (Levy → SK → ML) of a high-order, lightly damped model can land in
//! another local minimum than the model it augments, and lose modes that model had (on the
//! F-16 ground vibration FRF an order-14 fit from scratch costs 3.9·10⁶, the order-14
//! model reached by augmenting order 10 5.7·10⁵). Started from the current poles, the
//! refit keeps them unless the data move them; the added pair sits where the finding
//! located the missing resonance.

use super::finding::{Effect, Finding, residual_power};
use super::spec::SpecFit;
use crate::data::FrequencyData;
use crate::estimate::{Method, ModelSpec};
use crate::model::{Domain, positive_band};
use crate::scalar::Complex;

/// The damping of the added pair when the finding's window gives none below it.
const MIN_DAMPING: f64 = 0.005;

/// The second damping of a pair (or flexible mode) started at a resonance peak, beside
/// the detector's width.
pub(crate) const LIGHT_DAMPING: f64 = 0.02;

/// The pole sets (closed under conjugation, na of the proposal) from which to refit
/// `finding.proposal` besides the start from scratch
/// ([`ModelSpec::fit_from_poles`](crate::estimate::ModelSpec::fit_from_poles)):
/// `current`'s poles with
/// - for a missing resonance (na + 2): a pair at the detector's peak ω_p with the
///   window's damping ζ (clamped to [0.005, 0.5]) and with ζ = 0.02, and one with
///   ζ = 0.02 at the peak of the measured-to-modelled ratio ([`ratio_peak`]) when it
///   differs;
/// - for a missing pole (na + 1): a real pole at −√(ω_lo·ω_hi), the band's geometric
///   centre;
/// - for a missing zero (na unchanged): the current poles alone.
///
/// In discrete time an s-plane pole s₀ is placed at z = e^{s₀Ts}. Empty for anything
/// else: specs with a delay, a noise model or another criterion than ML (their refits
/// start from scratch only), user models, or a current model whose poles are not na.
pub(crate) fn starts(
    data: &FrequencyData<f64>,
    current: &SpecFit,
    finding: &Finding,
) -> Vec<Vec<Complex<f64>>> {
    let (spec, proposal) = (&current.spec, &finding.proposal);
    let plain = |s: &ModelSpec| !s.delay && s.noise_order.is_none() && s.criterion == Method::Ml;
    if current.custom.is_some()
        || !plain(spec)
        || !plain(proposal)
        || proposal.domain != spec.domain
        || proposal.transient != spec.transient
        || current.poles.len() != spec.na
    {
        return vec![];
    }
    let place = |s0: Complex<f64>| match spec.domain {
        Domain::Continuous => s0,
        Domain::Discrete { ts } => (s0 * ts).exp(),
    };
    let added: Vec<Vec<Complex<f64>>> = match (finding.effect, proposal.na.checked_sub(spec.na)) {
        (Effect::MissingZero, Some(0)) => vec![vec![]],
        (Effect::MissingPole, Some(1)) => positive_band(&current.omega)
            .map(|(lo, hi)| vec![vec![place(Complex::new(-(lo * hi).sqrt(), 0.0))]])
            .unwrap_or_default(),
        (Effect::MissingResonance, Some(2)) => {
            let Some(detail) = finding.detail.missing_resonance() else {
                return vec![];
            };
            let zeta = detail.damping.clamp(MIN_DAMPING, 0.5);
            let peak = detail.peak_omega();
            let mut modes = vec![(peak, zeta), (peak, LIGHT_DAMPING)];
            if let Some(w) = ratio_peak(data, current)
                && w != peak
            {
                modes.push((w, LIGHT_DAMPING));
            }
            modes
                .iter()
                .map(|&(w, z)| {
                    let q = place(pair(w, z));
                    vec![q, q.conj()]
                })
                .collect()
        }
        _ => vec![],
    };
    let mut out: Vec<Vec<Complex<f64>>> = vec![];
    for extra in added {
        let mut poles = current.poles.clone();
        poles.extend(extra);
        if !out.contains(&poles) {
            out.push(poles);
        }
    }
    out
}

/// The member with im > 0 of the pair with natural frequency `omega` (rad/s) and damping
/// `zeta`: ω(−ζ + i√(1 − ζ²)).
fn pair(omega: f64, zeta: f64) -> Complex<f64> {
    Complex::new(-zeta * omega, omega * (1.0 - zeta * zeta).sqrt())
}

/// The frequency of the largest measured-to-modelled magnitude ratio |Y_k|/|Ŷ_k| among
/// the lines whose residual is significant (|r_k|² > 9 times its null mean): a missing
/// resonance multiplies the response by a factor peaking at ω_p whatever the absolute
/// level, while the residual power peaks where |G| is largest (the detector's
/// `peak_hz`, which at high SNR can sit at the low-frequency end).
pub(crate) fn ratio_peak(data: &FrequencyData<f64>, fit: &SpecFit) -> Option<f64> {
    let (power, mean, _) = residual_power(fit);
    (0..fit.residuals.len())
        .filter(|k| power[*k] > 9.0 * mean && fit.output[*k].norm() > 0.0)
        .map(|k| (data.y()[k].norm() / fit.output[k].norm(), fit.omega[k]))
        .filter(|(r, _)| r.is_finite())
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, w)| w)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pair_has_its_natural_frequency_and_damping() {
        let q = pair(10.0, 0.1);
        assert!((q.norm() - 10.0).abs() < 1e-12);
        assert!((-q.re / q.norm() - 0.1).abs() < 1e-12);
    }
}
