//! The discrepancy workflow on every entry of a frequency response matrix: each entry's
//! cost and whiteness verdict against a common-pole model, the missing-resonance
//! detector on the residual power summed over the entries, and the loop that adds the
//! named pole pair while a likelihood-ratio test accepts it.

use crate::data::FrfMatrix;
use crate::error::{FdidError, Result};
use crate::mimo::{CommonPoleFit, CommonPoleOptions, fit_common_poles};
use crate::validation::Validation;
use crate::workflow::bands::WindowScan;
use crate::workflow::lrt::{LrTest, lr_test};

/// One entry's verdict: the statistics of its normalised residuals.
#[derive(Debug, Clone, PartialEq)]
pub struct EntryCheck {
    /// Output (1-based).
    pub output: usize,
    /// Input (1-based).
    pub input: usize,
    /// Cost, its expected value and p-value (with the entries' variances), and the
    /// Ljung–Box whiteness test across frequency.
    pub validation: Validation,
}

/// A localised excess of residual power shared by the entries: a missing resonance.
#[derive(Debug, Clone, PartialEq)]
pub struct SharedResonance {
    /// Frequency of the window's largest summed power (Hz).
    pub peak_hz: f64,
    /// Width of the window (Hz).
    pub width_hz: f64,
    /// Lines in the window.
    pub lines: usize,
    /// The window's p-value times the number of windows tried (Bonferroni, at most 1).
    pub p_value: f64,
    /// Each entry's share of the window's residual power, column by column.
    pub shares: Vec<f64>,
}

/// The verdicts of one common-pole fit.
#[derive(Debug, Clone, PartialEq)]
pub struct CommonPoleCheck {
    /// Per entry, column by column.
    pub entries: Vec<EntryCheck>,
    /// The strongest shared excess of residual power (reported whatever its p-value).
    pub resonance: Option<SharedResonance>,
    /// True when the entries' noise variances normalise the residuals (else each entry's
    /// residuals are normalised by their own RMS and the cost test is skipped).
    pub noise_known: bool,
    /// ‖G − Ĝ‖/‖G‖ over every entry and line: at the rounding level (below
    /// [`EXACT_FIT`]) the data are reproduced exactly and nothing is left to detect.
    pub relative_misfit: f64,
}

/// The relative misfit below which a model reproduces the data to their printed
/// precision: −100 dB, above the rounding of data written with 6 significant digits
/// (a computed Touchstone file: relative misfit 7·10⁻⁷ at its true order) and below
/// what a user would call a discrepancy. Rounding errors are not white noise, so the
/// tests would otherwise keep adding poles to fit them.
pub const EXACT_FIT: f64 = 1e-5;

impl CommonPoleCheck {
    /// True when the shared resonance is significant at `alpha`.
    pub fn resonance_found(&self, alpha: f64) -> bool {
        self.resonance.as_ref().is_some_and(|r| r.p_value < alpha)
    }
}

/// The verdicts of `fit` on `data`: every entry's normalised residuals
/// r_e,k = (G_e,k − Ĝ_e,k)/σ_e,k ([`Validation`], with n + D + n/E parameters per entry,
/// E entries) and the missing-resonance scan of
/// [`MissingResonance`](crate::workflow::detectors::MissingResonance) on their summed power
/// P_k = Σ_e |r_e,k|²: under a correct model each |r_e,k|² has mean and variance 1, so
/// P_k has mean and variance E, and every window of w = 3 … max(3, L/20) lines is
/// compared with the scaled χ² of its sum. Without variances σ_e,k is the entry's RMS
/// residual √(V_e/(L − p_e/2)).
pub fn check_common_poles(data: &FrfMatrix<f64>, fit: &CommonPoleFit<f64>) -> CommonPoleCheck {
    let g = fit.model.response(data.omega());
    let entries = data.entries();
    let ne = entries.len();
    let lines = data.len();
    let order = fit.model.order();
    let per_entry = order + usize::from(fit.model.direct.is_some()) + order.div_ceil(ne);
    let noise_known = data.has_variances();
    let mut residuals = Vec::with_capacity(ne);
    let (mut misfit, mut energy) = (0.0, 0.0);
    for (e, entry) in entries.iter().enumerate() {
        let (i, j) = data.position(e);
        let mut r: Vec<crate::scalar::Complex<f64>> = entry
            .y()
            .iter()
            .zip(&g)
            .map(|(h, m)| h - m[(i, j)])
            .collect();
        misfit += r.iter().map(|v| v.norm_sqr()).sum::<f64>();
        energy += entry.y().iter().map(|v| v.norm_sqr()).sum::<f64>();
        match entry.noise() {
            Some(noise) if noise_known => {
                for (v, var) in r.iter_mut().zip(&noise.var_y) {
                    *v /= var.sqrt();
                }
            }
            _ => {
                let cost: f64 = r.iter().map(|v| v.norm_sqr()).sum();
                let dof = (lines as f64 - per_entry as f64 / 2.0).max(1.0);
                let scale = (cost / dof).sqrt();
                if scale > 0.0 {
                    for v in r.iter_mut() {
                        *v /= scale;
                    }
                }
            }
        }
        residuals.push(r);
    }
    let checks = residuals
        .iter()
        .enumerate()
        .map(|(e, r)| {
            let (i, j) = data.position(e);
            EntryCheck {
                output: i + 1,
                input: j + 1,
                validation: Validation::new(r, per_entry, noise_known, None),
            }
        })
        .collect();
    let power: Vec<f64> = (0..lines)
        .map(|k| residuals.iter().map(|r| r[k].norm_sqr()).sum())
        .collect();
    CommonPoleCheck {
        entries: checks,
        resonance: shared_resonance(data, &residuals, &power),
        noise_known,
        relative_misfit: if energy > 0.0 {
            (misfit / energy).sqrt()
        } else {
            0.0
        },
    }
}

/// The most significant window of the summed residual power.
fn shared_resonance(
    data: &FrfMatrix<f64>,
    residuals: &[Vec<crate::scalar::Complex<f64>>],
    power: &[f64],
) -> Option<SharedResonance> {
    let n = power.len();
    if n < 3 {
        return None;
    }
    let ne = residuals.len() as f64;
    let scan = WindowScan::new(power, ne, ne);
    let plan = scan.plan(3..=(n / 20).max(3).min(n));
    let windows = scan.count(&plan);
    let mut best: Option<(f64, usize, usize)> = None;
    for &(w, stride) in &plan {
        let top = scan
            .starts(w, stride)
            .map(|s| (s, scan.sum(s, w)))
            .max_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((start, sum)) = top {
            let p = scan.p_value(sum, w);
            if best.is_none_or(|(b, _, _)| p < b) {
                best = Some((p, start, w));
            }
        }
    }
    let (p, start, w) = best?;
    let omega = data.omega();
    let peak = (start..start + w)
        .max_by(|a, b| power[*a].total_cmp(&power[*b]))
        .unwrap_or(start);
    let total = scan.sum(start, w);
    let shares = residuals
        .iter()
        .map(|r| {
            let s: f64 = r[start..start + w].iter().map(|v| v.norm_sqr()).sum();
            if total > 0.0 { s / total } else { 0.0 }
        })
        .collect();
    let tau = std::f64::consts::TAU;
    Some(SharedResonance {
        peak_hz: omega[peak] / tau,
        width_hz: (omega[start + w - 1] - omega[start]) / tau,
        lines: w,
        p_value: (p * windows as f64).min(1.0),
        shares,
    })
}

/// One model of [`diagnose_common_poles`].
#[derive(Debug, Clone, PartialEq)]
pub struct CommonPoleStep {
    /// The number of common poles.
    pub order: usize,
    /// The fit.
    pub fit: CommonPoleFit<f64>,
    /// Its verdicts.
    pub check: CommonPoleCheck,
    /// The likelihood-ratio test against the previous step's model (`None` for the first).
    pub lr: Option<LrTest>,
    /// Whether the step was accepted (the first always is).
    pub accepted: bool,
}

/// The outcome of [`diagnose_common_poles`].
#[derive(Debug, Clone, PartialEq)]
pub struct CommonPoleDiagnosis {
    /// Every model tried, in order; the last accepted one is the result.
    pub steps: Vec<CommonPoleStep>,
    /// Why the loop ended.
    pub stop: String,
}

impl CommonPoleDiagnosis {
    /// The last accepted step.
    pub fn result(&self) -> &CommonPoleStep {
        self.steps
            .iter()
            .rev()
            .find(|s| s.accepted)
            .expect("the first step is accepted")
    }
}

/// The discrepancy workflow on every entry with common poles: fit `order` poles
/// ([`fit_common_poles`]), check it ([`check_common_poles`]); unless the model reproduces
/// the data to [`EXACT_FIT`] relative (their printed precision: nothing to detect), while the
/// residual power
/// summed over the entries holds a resonance significant at `alpha` (and at most
/// `max_steps` times), fit two more poles and keep them when the likelihood-ratio test
/// ([`lr_test`]: 2ΔV ~ χ²(ΔP) with the entries' variances, else the F-test; P = n +
/// E(n + D) real parameters, on the E·L lines) rejects the smaller model at `alpha` — and,
/// under `options.stable`, when the larger model is stable. The result's checks show
/// whether the gap shrank: the cost, each entry's whiteness and the shared resonance's
/// p-value before and after.
///
/// # Errors
/// `alpha` outside (0, 1), the first fit's errors; a failed larger fit ends the loop
/// (its reason in `stop`).
pub fn diagnose_common_poles(
    data: &FrfMatrix<f64>,
    order: usize,
    options: &CommonPoleOptions<f64>,
    alpha: f64,
    max_steps: usize,
) -> Result<CommonPoleDiagnosis> {
    if !(alpha > 0.0 && alpha < 1.0) {
        return Err(FdidError::InvalidArgument {
            name: "alpha",
            value: alpha.to_string(),
            reason: "a significance level lies strictly between 0 and 1".into(),
        });
    }
    let fit = fit_common_poles(data, order, options)?;
    let check = check_common_poles(data, &fit);
    let mut steps = vec![CommonPoleStep {
        order,
        fit,
        check,
        lr: None,
        accepted: true,
    }];
    let ne = data.entries().len();
    let params = |n: usize| n + ne * (n + usize::from(options.direct));
    let stop = loop {
        let current = steps.iter().rev().find(|s| s.accepted).expect("accepted");
        if current.check.relative_misfit < EXACT_FIT {
            break format!(
                "the model reproduces the data to {:.1e} relative, their printed precision: \
                 nothing left to detect",
                current.check.relative_misfit
            );
        }
        let Some(resonance) = current.check.resonance.as_ref() else {
            break "too few lines for the resonance scan".to_string();
        };
        if resonance.p_value >= alpha {
            break format!(
                "no shared resonance left (p = {:.3} at {:.6} Hz, alpha {alpha})",
                resonance.p_value, resonance.peak_hz
            );
        }
        if steps.len() > max_steps {
            break format!("the step limit ({max_steps}) was reached with a resonance left");
        }
        let n = current.order + 2;
        let (v0, p0) = (current.fit.cost, params(current.order));
        let fit = match fit_common_poles(data, n, options) {
            Ok(f) => f,
            Err(e) => break format!("the fit of {n} poles failed: {e}"),
        };
        let lr = lr_test(
            v0,
            p0,
            fit.cost.min(v0),
            params(n),
            data.len() * ne,
            data.has_variances(),
        )
        .ok();
        let stable = !options.stable || fit.model.poles.is_stable(fit.model.domain);
        let accepted = stable && lr.as_ref().is_some_and(|t| t.p_value < alpha);
        let check = check_common_poles(data, &fit);
        let peak = resonance.peak_hz;
        steps.push(CommonPoleStep {
            order: n,
            fit,
            check,
            lr,
            accepted,
        });
        if !accepted {
            let last = steps.last().expect("pushed");
            break if last.fit.cost >= v0 {
                format!(
                    "two more poles for the resonance at {peak:.6} Hz were not accepted (the fit \
                     of {n} poles did not lower the cost: {:.6e} against {v0:.6e})",
                    last.fit.cost
                )
            } else if !stable {
                format!(
                    "two more poles for the resonance at {peak:.6} Hz were not accepted (the \
                     model of {n} poles is unstable)"
                )
            } else {
                format!(
                    "two more poles for the resonance at {peak:.6} Hz were not accepted \
                     (likelihood-ratio test not significant)"
                )
            };
        }
    };
    Ok(CommonPoleDiagnosis { steps, stop })
}
