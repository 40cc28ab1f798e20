use crate::stats::chi2_sf;
use crate::workflow::finding::{Context, Detail, Detector, Effect, Finding, Remedy, residual_power};
use crate::workflow::spec::{SpecCriterion, SpecFit};
use crate::{Complex, FrequencyData};
use nalgebra::DMatrix;

/// Significant input noise in a periodic measurement: switch from output-error ML
/// (McKelvey eq. 23) to errors-in-variables ML (eq. 42).
///
/// With the input measured with noise N_U, the output-error residual of line k is
/// Y_k − G U_k = N_Y − G N_U, of variance
/// σ²_E,k = σ²_Y + |G|²σ²_U − 2 Re(Ḡ σ_YU) (the denominator of eq. 42), whereas
/// the output-error fit normalises it by σ_Y alone. So under input noise the normalised
/// residual power has mean μ(1 + e_k) instead of μ, with
///
/// e_k = (|Ĝ_k|² σ̂²_U,k − 2 Re(conj(Ĝ_k) σ̂_YU,k)) / σ̂²_Y,k
///
/// (Ĝ the fitted response, σ̂ the noise (co)variances the data carry, e.g. the sample
/// variances of [`TimeData::average_periods`](crate::TimeData::average_periods)). The
/// statistic is the score test of a factor γ on that excess, E|r_k|² = μ(1 + γ e_k),
/// at γ = 0 (the output-error model) against γ > 0 (γ = 1 is eq. 42): with weights
/// w_k = max(e_k, 0),
///
/// S = Σ_k w_k |r_k|²,  E S = μ Σ_k w_k (1 − h_k),  var S ≈ v Σ_k w_k²,
///
/// (μ, v the null moments of |r_k|²: 1 and 1 for exact variances, those of F(2, 2ν) for
/// sample variances of ν degrees of freedom; h_k the leverage of line k in the fit,
/// Σ h_k = p/2), compared with the scaled χ² of the same mean and variance,
/// S ≈ g χ²(f), g = var S/(2 E S), f = 2(E S)²/var S: one-sided p = P(χ²(f) > S/g).
///
/// Applies to output-error ML fits (no noise model) normalised by given noise variances
/// whose input noise is not zero on every line; `None` otherwise (e.g. for exact input
/// samples, whose sample input variance is zero).
///
/// Proposal: the same spec with `criterion = Eiv` ([`Remedy::Criterion`]: the weighting
/// changes, so the step is accepted on this test and on a decrease of the full negative
/// log-likelihood, not on the nested likelihood-ratio test). Detail: `excess` (S/E S − 1,
/// the observed relative excess of the weighted residual power), `predicted_excess`
/// (Σ w_k e_k(1 − h_k)/Σ w_k(1 − h_k), its expectation under eq. 42), `input_to_output`
/// (mean e_k: the input noise's share of the residual variance relative to the output
/// noise), `input_snr_db` (10 log₁₀ of mean |U_k|² over mean σ̂²_U,k).
#[derive(Debug, Clone, Copy, Default)]
pub struct InputNoise;

impl Detector for InputNoise {
    fn effect(&self) -> Effect {
        Effect::InputNoise
    }

    fn measurement(&self) -> bool {
        true
    }

    fn detect(&self, data: &FrequencyData<f64>, fit: &SpecFit, _ctx: &Context) -> Option<Finding> {
        if fit.spec.criterion != SpecCriterion::Ml
            || fit.spec.noise_order.is_some()
            || !fit.noise_known
        {
            return None;
        }
        let noise = data.noise()?;
        let n = fit.residuals.len();
        if n != data.len() || noise.var_u.iter().all(|v| !(*v > 0.0)) {
            return None;
        }
        let e: Vec<f64> = (0..n)
            .map(|k| {
                let g = fit.response[k];
                let vy = noise.var_y[k];
                let excess = g.norm_sqr() * noise.var_u[k] - 2.0 * (g.conj() * noise.cov_yu[k]).re;
                if vy > 0.0 { excess / vy } else { 0.0 }
            })
            .collect();
        let w: Vec<f64> = e.iter().map(|v| v.max(0.0)).collect();
        let h = leverage(&fit.jacobian, n);
        let (power, mean, var) = residual_power(fit);
        let s: f64 = w.iter().zip(&power).map(|(w, p)| w * p).sum();
        let expected: f64 = mean * w.iter().zip(&h).map(|(w, h)| w * (1.0 - h)).sum::<f64>();
        let variance: f64 = var * w.iter().map(|w| w * w).sum::<f64>();
        if !(expected > 0.0 && variance > 0.0) || !s.is_finite() {
            return None;
        }
        let g = variance / (2.0 * expected);
        let f = 2.0 * expected * expected / variance;
        let p_value = chi2_sf(s / g, f);
        let wh: f64 = w.iter().zip(&h).map(|(w, h)| w * (1.0 - h)).sum();
        let predicted = w
            .iter()
            .zip(e.iter().zip(&h))
            .map(|(w, (e, h))| w * e * (1.0 - h))
            .sum::<f64>()
            / wh;
        let u_power = data.u().iter().map(Complex::norm_sqr).sum::<f64>() / n as f64;
        let u_noise = noise.var_u.iter().sum::<f64>() / n as f64;
        let proposal = crate::workflow::ModelSpec {
            criterion: SpecCriterion::Eiv,
            ..fit.spec.clone()
        };
        Some(Finding {
            effect: Effect::InputNoise,
            statistic: s / g,
            p_value,
            detail: Detail::default()
                .with("excess", s / expected - 1.0)
                .with("predicted_excess", predicted)
                .with("input_to_output", e.iter().sum::<f64>() / n as f64)
                .with("input_snr_db", 10.0 * (u_power / u_noise).log10()),
            proposal,
        })
    }

    fn remedy(
        &self,
        _data: &FrequencyData<f64>,
        _fit: &SpecFit,
        _ctx: &Context,
        _finding: &Finding,
    ) -> Option<Remedy> {
        Some(Remedy::Criterion)
    }
}

/// Leverage h_k of each complex line in a real-stacked Jacobian J (2N × p):
/// h_k = (‖Q_{2k}‖² + ‖Q_{2k+1}‖²)/2 with Q an orthonormal basis of the column space of
/// the column-scaled J (SVD, singular values below 10⁻¹⁰ of the largest dropped), so that
/// Σ h_k = rank/2 and E|r_k|² = μ(1 − h_k) at a least-squares fit.
pub(crate) fn leverage(j: &DMatrix<f64>, n: usize) -> Vec<f64> {
    let mut h = vec![0.0; n];
    if j.ncols() == 0 || j.nrows() != 2 * n {
        return h;
    }
    let mut js = j.clone();
    for mut c in js.column_iter_mut() {
        let norm = c.norm();
        if norm > 0.0 {
            c /= norm;
        }
    }
    let svd = js.svd(true, false);
    let Some(u) = svd.u else {
        return h;
    };
    let smax = svd.singular_values.max();
    for (i, s) in svd.singular_values.iter().enumerate() {
        if *s > 1e-10 * smax {
            for (k, hk) in h.iter_mut().enumerate() {
                *hk += (u[(2 * k, i)].powi(2) + u[(2 * k + 1, i)].powi(2)) / 2.0;
            }
        }
    }
    h
}
