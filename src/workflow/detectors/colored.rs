use crate::data::FrequencyData;
use crate::stats::chi2_sf;
use crate::workflow::finding::{
    Context, Detail, DetailFields, Detector, Effect, Finding, NamedValues,
};
use crate::workflow::spec::SpecFit;

/// Residual variance that changes with frequency: coloured noise (a missing noise model
/// H = C/D, McKelvey eq. 26).
///
/// For a fit with the noise level estimated (flat weighting, λ̂), the residual power of
/// white noise is the same on every line: |r_k|²/λ ~ ½χ²(2). The lines are cut into B
/// contiguous blocks (B = clamp(N/16, 2, 12)) of n_b lines; block b gives the variance
/// estimate s_b² = Σ|r_k|²/n_b with ν_b = 2n_b degrees of freedom. Bartlett's
/// homogeneity statistic
/// M = ν ln s² − Σ_b ν_b ln s_b², ν = Σν_b, s² = Σ ν_b s_b²/ν, corrected by
/// C = 1 + (Σ 1/ν_b − 1/ν)/(3(B − 1)), is ~ χ²(B − 1) under white noise.
///
/// Applies to non-periodic time records whose fit has no noise model and an estimated
/// noise level. Proposal: `noise_order = Some(1)`; detail: [`ColoredNoiseDetail`].
#[derive(Debug, Clone, Copy, Default)]
pub struct ColoredNoise;

impl Detector for ColoredNoise {
    fn effect(&self) -> Effect {
        Effect::ColoredNoise
    }

    fn detect(&self, data: &FrequencyData<f64>, fit: &SpecFit, ctx: &Context) -> Option<Finding> {
        if ctx.periodic || !ctx.time_record || fit.noise_known || fit.spec.noise_order.is_some() {
            return None;
        }
        data.ts()?;
        let n = fit.residuals.len();
        let blocks = (n / 16).clamp(2, 12);
        if n < 2 * blocks {
            return None;
        }
        let mut s = Vec::with_capacity(blocks);
        let mut nu = Vec::with_capacity(blocks);
        for b in 0..blocks {
            let (lo, hi) = (b * n / blocks, (b + 1) * n / blocks);
            let sum: f64 = fit.residuals[lo..hi].iter().map(|r| r.norm_sqr()).sum();
            s.push(sum / (hi - lo) as f64);
            nu.push(2.0 * (hi - lo) as f64);
        }
        if s.iter().any(|v| !(*v > 0.0)) {
            return None;
        }
        let nu_total: f64 = nu.iter().sum();
        let pooled = s.iter().zip(&nu).map(|(s, v)| s * v).sum::<f64>() / nu_total;
        let m = nu_total * pooled.ln() - s.iter().zip(&nu).map(|(s, v)| v * s.ln()).sum::<f64>();
        let c = 1.0
            + (nu.iter().map(|v| 1.0 / v).sum::<f64>() - 1.0 / nu_total)
                / (3.0 * (blocks - 1) as f64);
        let statistic = m / c;
        let p_value = chi2_sf(statistic, (blocks - 1) as f64);
        let (lo, hi) = s.iter().fold((f64::INFINITY, 0.0_f64), |(lo, hi), v| {
            (lo.min(*v), hi.max(*v))
        });
        let proposal = crate::workflow::ModelSpec {
            noise_order: Some(1),
            ..fit.spec.clone()
        };
        Some(Finding {
            effect: Effect::ColoredNoise,
            statistic,
            p_value,
            detail: Detail::ColoredNoise(ColoredNoiseDetail {
                blocks,
                ratio: hi / lo,
            }),
            proposal,
        })
    }
}

/// The detail of a [`ColoredNoise`] finding.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColoredNoiseDetail {
    /// The number B of blocks, named `blocks`.
    pub blocks: usize,
    /// The largest over the smallest block variance, named `ratio`.
    pub ratio: f64,
}

impl DetailFields for ColoredNoiseDetail {
    fn entries(&self) -> Vec<(&'static str, f64)> {
        vec![("blocks", self.blocks as f64), ("ratio", self.ratio)]
    }

    fn take_from(values: &mut NamedValues) -> Option<Self> {
        Some(Self {
            blocks: values.take_count("blocks")?,
            ratio: values.take("ratio")?,
        })
    }
}
