use crate::data::FrequencyData;
use crate::workflow::bands::WindowScan;
use crate::workflow::finding::{
    Context, Detail, DetailFields, Detector, Effect, Finding, NamedValues, residual_power,
};
use crate::workflow::spec::SpecFit;

/// A localised excess of normalised residual power: a missing lightly damped pole pair.
///
/// Under the null each |r_k|² has mean μ and variance v (μ = v = 1 for exact noise
/// variances, where 2|r_k|² ~ χ²(2), the terms of the ML cost of McKelvey eq. 23; the
/// F(2, 2ν) moments for sample variances). For every window of w consecutive lines,
/// w = 3 … max(3, N/20), the window sum S is compared with the scaled χ² of the same mean
/// and variance, S ≈ g χ²(h), g = v/(2μ), h = 2wμ²/v; the statistic is the smallest
/// upper-tail probability, the p-value that times the number of windows tried
/// (Bonferroni, capped at 1). Beyond 5·10⁷ windows the multi-scale plan of
/// `WindowScan::plan` bounds the scan (linear in the lines).
///
/// Proposal: na + 2, nb + 2; detail: [`MissingResonanceDetail`]. Starting the refit from
/// a pole pair at the peak is a later refinement.
#[derive(Debug, Clone, Copy, Default)]
pub struct MissingResonance;

impl Detector for MissingResonance {
    fn effect(&self) -> Effect {
        Effect::MissingResonance
    }

    fn detect(&self, _data: &FrequencyData<f64>, fit: &SpecFit, _ctx: &Context) -> Option<Finding> {
        let (power, mean, var) = residual_power(fit);
        let n = power.len();
        let w_max = (n / 20).max(3);
        if n < 3 || !(var > 0.0) {
            return None;
        }
        let scan = WindowScan::new(&power, mean, var);
        let plan = scan.plan(3..=w_max.min(n));
        let windows = scan.count(&plan);
        // at each width the smallest p-value is that of the largest sum (the first one)
        let (mut best, mut best_at) = (1.0_f64, (0, 3));
        for &(w, stride) in &plan {
            let mut top: Option<(usize, f64)> = None;
            for start in scan.starts(w, stride) {
                let sum = scan.sum(start, w);
                if top.is_none_or(|(_, t)| sum > t) {
                    top = Some((start, sum));
                }
            }
            if let Some((start, sum)) = top {
                let p = scan.p_value(sum, w);
                if p < best {
                    best = p;
                    best_at = (start, w);
                }
            }
        }
        let (start, w) = best_at;
        let peak = (start..start + w)
            .max_by(|a, b| power[*a].total_cmp(&power[*b]))
            .unwrap_or(start);
        let peak_omega = fit.omega[peak];
        let width = fit.omega[start + w - 1] - fit.omega[start];
        let proposal = crate::workflow::ModelSpec {
            na: fit.spec.na + 2,
            nb: fit.spec.nb + 2,
            ..fit.spec.clone()
        };
        Some(Finding {
            effect: Effect::MissingResonance,
            statistic: best,
            p_value: (best * windows as f64).min(1.0),
            detail: Detail::MissingResonance(MissingResonanceDetail {
                peak_hz: peak_omega / std::f64::consts::TAU,
                width_hz: width / std::f64::consts::TAU,
                damping: width / (2.0 * peak_omega),
                lines: w,
            }),
            proposal,
        })
    }
}

/// The detail of a [`MissingResonance`] finding.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MissingResonanceDetail {
    /// The frequency f_p = ω_p/2π (Hz) of the largest |r_k| in the best window, named
    /// `peak_hz`.
    pub peak_hz: f64,
    /// The window's span (Hz), named `width_hz`.
    pub width_hz: f64,
    /// The damping ratio ≈ width/(2 f_p), named `damping`.
    pub damping: f64,
    /// The window's number of lines w, named `lines`.
    pub lines: usize,
}

impl MissingResonanceDetail {
    /// The peak's angular frequency ω_p = 2π f_p (rad/s).
    pub fn peak_omega(&self) -> f64 {
        self.peak_hz * std::f64::consts::TAU
    }
}

impl DetailFields for MissingResonanceDetail {
    fn entries(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("peak_hz", self.peak_hz),
            ("width_hz", self.width_hz),
            ("damping", self.damping),
            ("lines", self.lines as f64),
        ]
    }

    fn take_from(values: &mut NamedValues) -> Option<Self> {
        Some(Self {
            peak_hz: values.take("peak_hz")?,
            width_hz: values.take("width_hz")?,
            damping: values.take("damping")?,
            lines: values.take_count("lines")?,
        })
    }
}
