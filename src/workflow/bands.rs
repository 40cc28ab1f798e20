//! Where the model and the measurement disagree: bands of consecutive lines whose
//! normalised residual power exceeds what the noise explains.
use super::finding::residual_power;
use super::spec::SpecFit;
use crate::error::{FdidError, Result};
use crate::stats::chi2_sf;

/// A band of consecutive lines where the residual exceeds the noise.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Band {
    /// Lowest frequency of the band (rad/s).
    pub omega_lo: f64,
    /// Highest frequency of the band (rad/s).
    pub omega_hi: f64,
    /// Index of the band's first line.
    pub first: usize,
    /// Number of lines.
    pub lines: usize,
    /// The band's normalised residual power Σ|r_k|²/λ.
    pub power: f64,
    /// Its expected value under the noise, lines · E|r_k|²/λ.
    pub expected: f64,
    /// The smallest p-value of a window inside the band, multiplied by the number of
    /// windows tested (Bonferroni, capped at 1).
    pub p_value: f64,
}

/// The most windows scanned exhaustively (every width, every start); a larger scan uses
/// the multi-scale plan of [`WindowScan::plan`]. At this size the exhaustive scan of
/// widths up to N/20 covers records of about 31 600 lines.
const EXHAUSTIVE_WINDOWS: usize = 50_000_000;

/// Windows of consecutive lines of a residual power `power` (per-line mean `mean`, variance
/// `var` under the null), each with the upper-tail p-value of its sum S against the scaled
/// χ² of the same mean and variance, S ≈ g χ²(h), g = var/(2 mean), h = 2 w mean²/var
/// (exact for exact noise variances, where 2|r_k|² ~ χ²(2)).
///
/// The p-value falls as S grows, so the questions asked of a width (its smallest p-value,
/// its windows below a level) need one χ² tail per width, not one per window.
pub(crate) struct WindowScan {
    prefix: Vec<f64>,
    mean: f64,
    var: f64,
}

impl WindowScan {
    pub(crate) fn new(power: &[f64], mean: f64, var: f64) -> Self {
        let mut prefix = vec![0.0; power.len() + 1];
        for (k, p) in power.iter().enumerate() {
            prefix[k + 1] = prefix[k] + p;
        }
        Self { prefix, mean, var }
    }

    /// The number of lines.
    fn len(&self) -> usize {
        self.prefix.len() - 1
    }

    /// The sum of the `w` lines from `start`.
    pub(crate) fn sum(&self, start: usize, w: usize) -> f64 {
        self.prefix[start + w] - self.prefix[start]
    }

    /// The p-value of a window of `w` lines whose sum is `sum`.
    pub(crate) fn p_value(&self, sum: f64, w: usize) -> f64 {
        let g = self.var / (2.0 * self.mean);
        let h = 2.0 * w as f64 * self.mean * self.mean / self.var;
        chi2_sf(sum / g, h)
    }

    /// The windows to test, as (width, stride between starts) over `widths`: every width
    /// and start when that is at most [`EXHAUSTIVE_WINDOWS`] windows; otherwise widths
    /// growing by 10 % and starts `w/8` apart (every window of the exhaustive scan then
    /// overlaps a tested one of about its width by at least 80 %).
    pub(crate) fn plan(&self, widths: std::ops::RangeInclusive<usize>) -> Vec<(usize, usize)> {
        let n = self.len();
        let (lo, hi) = ((*widths.start()).max(1), (*widths.end()).min(n));
        if lo > hi {
            return Vec::new();
        }
        let exhaustive: usize = (lo..=hi).map(|w| n - w + 1).sum();
        if exhaustive <= EXHAUSTIVE_WINDOWS {
            return (lo..=hi).map(|w| (w, 1)).collect();
        }
        let mut plan = Vec::new();
        let mut w = lo;
        while w < hi {
            plan.push((w, (w / 8).max(1)));
            w = (w + 1).max((w as f64 * 1.1) as usize);
        }
        plan.push((hi, (hi / 8).max(1)));
        plan
    }

    /// The starts of the windows of width `w` with stride `stride`.
    pub(crate) fn starts(&self, w: usize, stride: usize) -> impl Iterator<Item = usize> {
        (0..=(self.len() - w)).step_by(stride)
    }

    /// The number of windows of `plan`.
    pub(crate) fn count(&self, plan: &[(usize, usize)]) -> usize {
        plan.iter()
            .map(|&(w, stride)| (self.len() - w) / stride + 1)
            .sum()
    }

    /// The smallest sum whose p-value at width `w` lies below `level` (bisection on the
    /// monotone tail), or ∞ when none does in the range of f64.
    fn threshold(&self, w: usize, level: f64) -> f64 {
        let mut hi = (w as f64 * self.mean).max(f64::MIN_POSITIVE);
        while !(self.p_value(hi, w) < level) {
            hi *= 2.0;
            if !hi.is_finite() {
                return f64::INFINITY;
            }
        }
        let mut lo = 0.0;
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if mid <= lo || mid >= hi {
                break;
            }
            if self.p_value(mid, w) < level {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        hi
    }
}

/// The bands where `fit`'s residuals disagree with the noise at family-wise level `alpha`.
///
/// Every window of w = 1 … max(3, N/20) consecutive lines is tested with the scaled χ² of
/// `WindowScan` (the terms |r_k|² of McKelvey's ML cost, eq. 23, each of mean μ and
/// variance v under the null: 1 and 1 for exact noise variances, the F(2, 2ν) moments for
/// sample variances, scaled by λ̂ when the level is estimated). A window is flagged when
/// its p-value times the number of windows is below α (Bonferroni: on a correct model no
/// band is reported with probability at least 1 − α); overlapping or adjacent flagged
/// windows merge into one band. Beyond 5·10⁷ windows (about 31 600 lines) the widths
/// grow by 10 % and the starts stride w/8 (`WindowScan::plan`), so that the scan of 10⁶
/// lines stays linear in the lines; the Bonferroni count is that of the windows tested.
///
/// # Errors
/// [`FdidError::InvalidArgument`] for α outside (0, 1).
pub fn disagreement_bands(fit: &SpecFit, alpha: f64) -> Result<Vec<Band>> {
    if !(alpha > 0.0 && alpha < 1.0) {
        return Err(FdidError::InvalidArgument {
            name: "alpha",
            value: alpha.to_string(),
            reason: "the false-alarm level lies in (0, 1)".into(),
        });
    }
    let (power, mean, var) = residual_power(fit);
    let n = power.len();
    if n == 0 || !(var > 0.0) || !power.iter().all(|p| p.is_finite()) {
        return Ok(Vec::new());
    }
    let scan = WindowScan::new(&power, mean, var);
    let plan = scan.plan(1..=(n / 20).max(3));
    let total = scan.count(&plan) as f64;
    // a window is flagged when p · total < α, that is when its sum reaches the width's
    // threshold: only those windows need their p-value
    let mut flagged: Vec<(usize, usize, f64)> = Vec::new();
    for &(w, stride) in &plan {
        let threshold = scan.threshold(w, alpha / total);
        for s in scan.starts(w, stride) {
            let sum = scan.sum(s, w);
            if sum >= threshold {
                let p = (scan.p_value(sum, w) * total).min(1.0);
                if p < alpha {
                    flagged.push((s, s + w, p));
                }
            }
        }
    }
    flagged.sort_by_key(|(s, e, _)| (*s, *e));
    let mut bands: Vec<(usize, usize, f64)> = Vec::new();
    for (s, e, p) in flagged {
        match bands.last_mut() {
            Some(last) if s <= last.1 => {
                last.1 = last.1.max(e);
                last.2 = last.2.min(p);
            }
            _ => bands.push((s, e, p)),
        }
    }
    Ok(bands
        .into_iter()
        .map(|(s, e, p)| Band {
            omega_lo: fit.omega[s],
            omega_hi: fit.omega[e - 1],
            first: s,
            lines: e - s,
            power: power[s..e].iter().sum(),
            expected: (e - s) as f64 * mean,
            p_value: p,
        })
        .collect())
}
