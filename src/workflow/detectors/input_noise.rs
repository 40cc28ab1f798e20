use crate::data::FrequencyData;
use crate::estimate::Method;
use crate::scalar::Complex;
use crate::stats::chi2_sf;
use crate::workflow::finding::{
    Context, Detail, DetailFields, Detector, Effect, Finding, NamedValues, Remedy, residual_power,
};
use crate::workflow::spec::SpecFit;
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
/// e_k = max(|Ĝ_k|² σ̂²_U,k − 2 Re(conj(Ĝ_k) σ̂_YU,k), 0) / σ̄²_Y,k
///
/// (Ĝ the fitted response, σ̂ the noise (co)variances the data carry, e.g. the sample
/// variances of [`TimeData::average_periods`](crate::TimeData::average_periods);
/// σ̄²_Y,k the mean of σ̂²_Y over up to 5 lines on each side, line k left out, so that
/// e_k does not depend on the line's own σ̂²_Y, which normalises r_k). The statistic is
/// the score test of a factor γ on that excess, E|r_k|² = μ(1 + γ e_k), at γ = 0 (the
/// output-error model) against γ > 0 (γ = 1 is eq. 42):
///
/// S = Σ_k e_k |r_k|²,  E₀S = μ Σ_k e_k (1 − h_k),  var₀S ≈ v Σ_k e_k²,
///
/// (μ, v the null moments of |r_k|²: 1 and 1 for exact variances, those of F(2, 2ν) for
/// sample variances of ν degrees of freedom; h_k the leverage of line k in the fit,
/// Σ h_k = p/2), compared with the scaled χ² of the same mean and variance,
/// S ≈ g χ²(f), g = var S/(2 E S), f = 2(E S)²/var S: one-sided p₀ = P(χ²(f) > S/g).
///
/// A score test is blind to the size of e_k: a residual excess from another cause (a
/// model error, nonlinear distortion) that happens to grow with |Ĝ|² would also reject
/// γ = 0 with a negligible input noise. So the excess must also agree with the eq. 42
/// prediction, E₁S = μ Σ e_k(1 − h_k)(1 + e_k), var₁S ≈ v Σ e_k²(1 + e_k)²: when the
/// two-sided scaled-χ² test of γ = 1 rejects at level 10⁻³ the finding's p-value is 1
/// (the excess is not the input noise's), else p₀. This only lowers the false-alarm rate
/// below that of the score test (≤ α under the output-error model).
///
/// Applies to output-error ML fits (no noise model) normalised by given noise variances
/// whose input noise is not zero on every line (input variances below (10³ε)²|U_k|², the
/// rounding of exact periodic samples, count as zero); `None` otherwise.
///
/// Proposal: the same spec with `criterion = Eiv` ([`Remedy::Criterion`]: the weighting
/// changes, so the step is accepted on this test and on a decrease of the full negative
/// log-likelihood, not on the nested likelihood-ratio test). Detail: [`InputNoiseDetail`].
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
        if fit.spec.criterion != Method::Ml || fit.spec.noise_order.is_some() || !fit.noise_known {
            return None;
        }
        let noise = data.noise()?;
        let n = fit.residuals.len();
        if n != data.len() {
            return None;
        }
        // input variances at the rounding level of exact periodic samples count as zero
        let floor = (1e3 * f64::EPSILON).powi(2);
        let var_u: Vec<f64> = (0..n)
            .map(|k| {
                let v = noise.var_u[k];
                if v > floor * data.u()[k].norm_sqr() {
                    v
                } else {
                    0.0
                }
            })
            .collect();
        if var_u.iter().all(|v| *v == 0.0) {
            return None;
        }
        let ref_y = neighbour_mean(&noise.var_y, 5);
        let e: Vec<f64> = (0..n)
            .map(|k| {
                let g = fit.response[k];
                let cov = if var_u[k] > 0.0 {
                    noise.cov_yu[k]
                } else {
                    Complex::new(0.0, 0.0)
                };
                let excess = g.norm_sqr() * var_u[k] - 2.0 * (g.conj() * cov).re;
                if ref_y[k] > 0.0 {
                    (excess / ref_y[k]).max(0.0)
                } else {
                    0.0
                }
            })
            .collect();
        let h = leverage(&fit.jacobian, n);
        let (power, mean, var) = residual_power(fit);
        let s: f64 = e.iter().zip(&power).map(|(w, p)| w * p).sum();
        let wh: f64 = e.iter().zip(&h).map(|(w, h)| w * (1.0 - h)).sum();
        // null γ = 0 (output noise only) and the eq. 42 prediction γ = 1
        let (m0, v0) = (mean * wh, var * e.iter().map(|w| w * w).sum::<f64>());
        let m1 = mean
            * e.iter()
                .zip(&h)
                .map(|(w, h)| w * (1.0 - h) * (1.0 + w))
                .sum::<f64>();
        let v1 = var * e.iter().map(|w| (w * (1.0 + w)).powi(2)).sum::<f64>();
        if !(m0 > 0.0 && v0 > 0.0 && m1 > 0.0 && v1 > 0.0 && s.is_finite()) {
            return None;
        }
        let upper = |m: f64, v: f64| chi2_sf(s * 2.0 * m / v, 2.0 * m * m / v);
        let p0 = upper(m0, v0);
        let tail1 = upper(m1, v1);
        let p1 = (2.0 * tail1.min(1.0 - tail1)).min(1.0);
        let p_value = if p1 >= ALPHA_CONSISTENT { p0 } else { 1.0 };
        let u_power = data.u().iter().map(Complex::norm_sqr).sum::<f64>() / n as f64;
        let u_noise = var_u.iter().sum::<f64>() / n as f64;
        let proposal = crate::workflow::ModelSpec {
            criterion: Method::Eiv,
            ..fit.spec.clone()
        };
        Some(Finding {
            effect: Effect::InputNoise,
            statistic: s * 2.0 * m0 / v0,
            p_value,
            detail: Detail::InputNoise(InputNoiseDetail {
                excess: s / m0 - 1.0,
                predicted_excess: m1 / m0 - 1.0,
                score_p: p0,
                consistent_p: p1,
                input_to_output: e.iter().sum::<f64>() / n as f64,
                input_snr_db: 10.0 * (u_power / u_noise).log10(),
            }),
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

/// The detail of an [`InputNoise`] finding.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InputNoiseDetail {
    /// S/E₀S − 1, the observed relative excess of the weighted residual power, named
    /// `excess`.
    pub excess: f64,
    /// E₁S/E₀S − 1, its value under eq. 42, named `predicted_excess`.
    pub predicted_excess: f64,
    /// The score test's p-value p₀, named `score_p`.
    pub score_p: f64,
    /// The p-value of the test of γ = 1, named `consistent_p`.
    pub consistent_p: f64,
    /// The mean e_k (the input noise's share of the residual variance relative to the
    /// output noise), named `input_to_output`.
    pub input_to_output: f64,
    /// 10 log₁₀ of the mean |U_k|² over the mean σ̂²_U,k, named `input_snr_db`.
    pub input_snr_db: f64,
}

impl DetailFields for InputNoiseDetail {
    fn entries(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("excess", self.excess),
            ("predicted_excess", self.predicted_excess),
            ("score_p", self.score_p),
            ("consistent_p", self.consistent_p),
            ("input_to_output", self.input_to_output),
            ("input_snr_db", self.input_snr_db),
        ]
    }

    fn take_from(values: &mut NamedValues) -> Option<Self> {
        Some(Self {
            excess: values.take("excess")?,
            predicted_excess: values.take("predicted_excess")?,
            score_p: values.take("score_p")?,
            consistent_p: values.take("consistent_p")?,
            input_to_output: values.take("input_to_output")?,
            input_snr_db: values.take("input_snr_db")?,
        })
    }
}

/// Level of the two-sided test of the eq. 42 prediction below which the excess is not
/// attributed to the input noise.
const ALPHA_CONSISTENT: f64 = 1e-3;

/// Leave-one-out mean of `x` over the up to `half` lines on each side of each line (the
/// line itself when it has no neighbour): a reference that does not depend on the line's
/// own sample variance.
fn neighbour_mean(x: &[f64], half: usize) -> Vec<f64> {
    let n = x.len();
    (0..n)
        .map(|k| {
            let (lo, hi) = (k.saturating_sub(half), (k + half + 1).min(n));
            let count = hi - lo - 1;
            if count == 0 {
                x[k]
            } else {
                (x[lo..hi].iter().sum::<f64>() - x[k]) / count as f64
            }
        })
        .collect()
}

/// Leverage h_k of each complex line in a real-stacked Jacobian J (2N × p):
/// h_k = (‖Q_{2k}‖² + ‖Q_{2k+1}‖²)/2 with Q an orthonormal basis of the column space of
/// the column-scaled J (`column_space`: singular values below 10⁻¹⁰ of the largest dropped), so that
/// Σ h_k = rank/2 and E|r_k|² = μ(1 − h_k) at a least-squares fit.
pub(crate) fn leverage(j: &DMatrix<f64>, n: usize) -> Vec<f64> {
    let mut h = vec![0.0; n];
    if j.nrows() != 2 * n {
        return h;
    }
    let Some(q) = super::score::column_space(j) else {
        return h;
    };
    for col in q.column_iter() {
        for (k, hk) in h.iter_mut().enumerate() {
            *hk += (col[2 * k].powi(2) + col[2 * k + 1].powi(2)) / 2.0;
        }
    }
    h
}
