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
        let power: Vec<f64> = fit.residuals.iter().map(|r| r.norm_sqr()).collect();
        let (statistic, p_value, ratio) = bartlett(&power, 2.0, blocks)?;
        let proposal = crate::workflow::ModelSpec {
            noise_order: Some(1),
            ..fit.spec.clone()
        };
        Some(Finding {
            effect: Effect::ColoredNoise,
            statistic,
            p_value,
            detail: Detail::ColoredNoise(ColoredNoiseDetail { blocks, ratio }),
            proposal,
        })
    }
}

/// Bartlett's test of equal variance over `blocks` contiguous blocks of `values`, each
/// value a variance estimate with `nu` degrees of freedom (|r_k|² of a complex residual:
/// ν = 2): block b pools its n_b values into s_b² with ν_b = ν·n_b degrees of freedom;
/// M = ν_t ln s² − Σ_b ν_b ln s_b² (ν_t = Σν_b, s² = Σ ν_b s_b²/ν_t), corrected by
/// C = 1 + (Σ 1/ν_b − 1/ν_t)/(3(B − 1)), is ~ χ²(B − 1) under equal variances. Returns
/// (M/C, its p-value, the largest over the smallest block variance); `None` with fewer
/// than two values a block or a block variance that is not positive.
fn bartlett(values: &[f64], nu: f64, blocks: usize) -> Option<(f64, f64, f64)> {
    let n = values.len();
    if blocks < 2 || n < 2 * blocks {
        return None;
    }
    let mut s = Vec::with_capacity(blocks);
    let mut nus = Vec::with_capacity(blocks);
    for b in 0..blocks {
        let (lo, hi) = (b * n / blocks, (b + 1) * n / blocks);
        let sum: f64 = values[lo..hi].iter().sum();
        s.push(sum / (hi - lo) as f64);
        nus.push(nu * (hi - lo) as f64);
    }
    if s.iter().any(|v| !(*v > 0.0 && v.is_finite())) {
        return None;
    }
    let nu_total: f64 = nus.iter().sum();
    let pooled = s.iter().zip(&nus).map(|(s, v)| s * v).sum::<f64>() / nu_total;
    let m = nu_total * pooled.ln() - s.iter().zip(&nus).map(|(s, v)| v * s.ln()).sum::<f64>();
    let c = 1.0
        + (nus.iter().map(|v| 1.0 / v).sum::<f64>() - 1.0 / nu_total) / (3.0 * (blocks - 1) as f64);
    let statistic = m / c;
    let (lo, hi) = s.iter().fold((f64::INFINITY, 0.0_f64), |(lo, hi), v| {
        (lo.min(*v), hi.max(*v))
    });
    Some((statistic, chi2_sf(statistic, (blocks - 1) as f64), hi / lo))
}

/// The lines apart at which the default local polynomial method
/// ([`crate::data::Lpm::new`]: 11-line windows) gives independent variance estimates.
const LPM_STRIDE: usize = 11;

/// Coloured noise named from the noise reference itself: the per-line output noise
/// variances σ̂²_k of a time record (sample variances over periods, or the local
/// polynomial method's) vary across frequency beyond chance.
///
/// White output noise has the same variance on every DFT line. Each σ̂²_k is a sample
/// variance with ν = 2q real degrees of freedom (q = [`FrequencyData::variance_dof`]:
/// P − 1 over P periods, the LPM's q), so Bartlett's statistic over B contiguous blocks
/// (B = clamp(n/8, 2, 12) of the n lines used) is ~ χ²(B − 1) under white noise. The
/// LPM estimates of neighbouring lines share their windows: every 11th line is used (the
/// default window), so that the estimates are independent. A residual-based test cannot
/// see this colour: the reference already weights each line by it, which is the right
/// weighting, but the report should say that the noise is coloured, and a parametric
/// noise model (McKelvey eq. 26) is then an option (the proposal: `noise_order = 1`).
///
/// Applies to time records whose variances are sample estimates (`None` otherwise).
/// Detail: [`ColoredNoiseDetail`] (blocks, largest over smallest block variance).
pub fn reference_colour(
    data: &FrequencyData<f64>,
    ctx: &Context,
    spec: &crate::workflow::ModelSpec,
) -> Option<Finding> {
    if !ctx.time_record {
        return None;
    }
    let q = data.variance_dof()?;
    let var = &data.noise()?.var_y;
    let stride = if ctx.periodic { 1 } else { LPM_STRIDE };
    let values: Vec<f64> = var.iter().step_by(stride).copied().collect();
    let blocks = (values.len() / 8).clamp(2, 12);
    let (statistic, p_value, ratio) = bartlett(&values, 2.0 * q as f64, blocks)?;
    Some(Finding {
        effect: Effect::ColoredNoise,
        statistic,
        p_value,
        detail: Detail::ColoredNoise(ColoredNoiseDetail { blocks, ratio }),
        proposal: crate::workflow::ModelSpec {
            noise_order: Some(1),
            ..spec.clone()
        },
    })
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
