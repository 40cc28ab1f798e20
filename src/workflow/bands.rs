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

/// Upper-tail p-values of every window of `widths` consecutive lines of `power` (per-line
/// mean `mean`, variance `var` under the null): the window sum S against the scaled χ² of
/// the same mean and variance, S ≈ g χ²(h), g = var/(2 mean), h = 2 w mean²/var (exact
/// for exact noise variances, where 2|r_k|² ~ χ²(2)). Calls `visit(start, w, p)`; returns
/// the number of windows.
pub(crate) fn scan_windows(
    power: &[f64],
    mean: f64,
    var: f64,
    widths: std::ops::RangeInclusive<usize>,
    mut visit: impl FnMut(usize, usize, f64),
) -> usize {
    let n = power.len();
    let mut prefix = vec![0.0; n + 1];
    for (k, p) in power.iter().enumerate() {
        prefix[k + 1] = prefix[k] + p;
    }
    let g = var / (2.0 * mean);
    let mut windows = 0;
    for w in widths {
        if w == 0 || w > n {
            continue;
        }
        let h = 2.0 * w as f64 * mean * mean / var;
        for start in 0..=(n - w) {
            windows += 1;
            visit(
                start,
                w,
                chi2_sf((prefix[start + w] - prefix[start]) / g, h),
            );
        }
    }
    windows
}

/// The bands where `fit`'s residuals disagree with the noise at family-wise level `alpha`.
///
/// Every window of w = 1 … max(3, N/20) consecutive lines is tested with the scaled χ² of
/// `scan_windows` (the terms |r_k|² of McKelvey's ML cost, eq. 23, each of mean μ and
/// variance v under the null: 1 and 1 for exact noise variances, the F(2, 2ν) moments for
/// sample variances, scaled by λ̂ when the level is estimated). A window is flagged when
/// its p-value times the number of windows is below α (Bonferroni: on a correct model no
/// band is reported with probability at least 1 − α); overlapping or adjacent flagged
/// windows merge into one band.
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
    let mut windows = Vec::new();
    let total = scan_windows(&power, mean, var, 1..=(n / 20).max(3), |s, w, p| {
        windows.push((s, w, p));
    });
    let mut flagged: Vec<(usize, usize, f64)> = windows
        .into_iter()
        .map(|(s, w, p)| (s, s + w, (p * total as f64).min(1.0)))
        .filter(|(_, _, p)| *p < alpha)
        .collect();
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
