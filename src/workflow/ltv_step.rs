//! The time-varying ODE the workflow fits when it names time variation on a
//! continuous-time spec: the Lataire–Pintelon model ([`crate::ltv`]) with the spec's
//! orders on the time record, the order N_p of its coefficients in t chosen by F tests
//! on the TLS costs ([`time_varying_ode`]).
//!
//! The piecewise time-invariant model ([`super::detectors::piecewise_model`]) needs
//! parameters that mean the same on every time segment, which continuous-time specs
//! (basis poles that move with the data) do not offer; a continuous-time system whose
//! coefficients drift is described directly by the ODE with coefficients polynomial in t.

use super::Step;
use super::detectors::TimeVarying;
use super::finding::{Context, Effect};
use super::lrt::f_sf;
use super::spec::SpecFit;
use crate::data::TimeData;
use crate::error::Result;
use crate::ltv::{FrequencyBasis, Lines, LtvFit, LtvOde, TimeBasis, max_time_order};
use crate::model::Domain;
use crate::scalar::Complex;
use std::f64::consts::TAU;

/// Highest order N_p in t tried by [`time_varying_ode`].
pub const MAX_TIME_ORDER: usize = 3;

/// Number of instants t* at which [`LtvStep`] holds the frozen poles: the first sample,
/// the last, and 9 evenly spaced in between.
pub const INSTANTS: usize = 11;

/// The least ratio σ_{p−1}/σ_p of the two smallest singular values for which
/// [`time_varying_ode`] takes the null space as one-dimensional.
pub const MIN_GAP: f64 = 3.0;

/// One candidate order N_p of [`LtvStep`].
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct LtvCandidate {
    /// The order N_p of the coefficients in t.
    pub n_p: usize,
    /// Its number of parameters p = (N_α + 1 + N_β + 1)(N_p + 1) + N_tr + 1.
    pub params: usize,
    /// Its TLS cost V = σ²_min of the column-scaled regressor.
    pub cost: f64,
    /// The p-value of the F test against the previous candidate (N_p − 1); `None` for
    /// N_p = 0.
    pub p_value: Option<f64>,
}

/// The time-varying ODE fitted when the workflow names time variation on a
/// continuous-time spec ([`time_varying_ode`]).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct LtvStep {
    /// Every order tried, N_p = 0 (time-invariant) first.
    pub candidates: Vec<LtvCandidate>,
    /// The chosen N_p.
    pub n_p: usize,
    /// The TLS cost of the time-invariant ODE (N_p = 0): the gap before.
    pub cost_before: f64,
    /// The TLS cost of the chosen N_p: the gap after.
    pub cost_after: f64,
    /// The fit of the chosen N_p (orders, θ̂, singular values, lines).
    pub fit: LtvFit<f64>,
    /// The instants t* (s from the first sample): 11 evenly spaced from the
    /// first sample to the last, (N − 1)T_s.
    pub instants: Vec<f64>,
    /// The frozen poles (rad/s) at each instant (eq. 4), sorted by imaginary then real
    /// part.
    pub poles: Vec<Vec<Complex<f64>>>,
}

/// The Lataire–Pintelon time-varying ODE (eqs. 1–3, 11, 18–20) of `fit`'s orders on
/// `record`, on every DFT line of the record between the lowest and the highest fitted
/// line (the lines between the excited ones hold the skirts of the time variation, eq.
/// 17), with Legendre bases in t and in ω/ω_max (ω_max the top line) and the transient +
/// alias polynomial of order N_tr = 2 max(N_α, N_β) + 1.
///
/// The order N_p of the coefficients in t: N_p = 0, 1, … up to
/// min(3, ⌊√N⌋) are fitted ([`LtvOde::fit`]); their TLS costs
/// V(N_p) = σ²_min are nested (the columns of N_p − 1 are those of N_p with the same unit
/// scaling, so V cannot grow with N_p). N_p grows while the F test
///
/// `F = ((V(N_p − 1) − V(N_p))/(p(N_p) − p(N_p − 1))) / (V(N_p)/(2L − p(N_p)))`
///
/// against F(p(N_p) − p(N_p − 1), 2L − p(N_p)) (L lines, p parameters) is below `alpha`
/// and the two smallest singular values of the N_p fit stay apart,
/// σ_{p−1}/σ_p ≥ [`MIN_GAP`]; the first order that fails either is not taken. The F
/// distribution is an approximation here: it treats the equation errors of the scaled
/// regressor as of equal variance over the lines, which they are not (the output noise
/// enters multiplied by |A(jω)|, the alias error is not noise), so alone it keeps adding
/// orders. The gap condition is the paper's identifiability argument (section II): an N_p
/// above the system's leaves the null space of the ODE times any polynomial c(t) of the
/// excess order, so the two smallest singular values come together. The gap shown is
/// V(0) → V(N_p).
///
/// Returns `Ok(None)` when the N_p = 0 fit is impossible (too few lines for its
/// parameters); a higher order that cannot be fitted ends the search.
///
/// # Errors
/// Those of [`LtvOde::fit`] for N_p = 0 other than too few lines, and of the frozen poles
/// ([`crate::ltv::InstantaneousModel::poles`]).
pub fn time_varying_ode(
    fit: &SpecFit,
    record: &TimeData<f64>,
    alpha: f64,
) -> Result<Option<LtvStep>> {
    let (na, nb) = (fit.spec.na, fit.spec.nb);
    let n = record.len();
    let ts = record.ts();
    let hz = |w: f64| w / TAU;
    let (lo, hi) = fit
        .omega
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(l, h), w| (l.min(*w), h.max(*w)));
    if !(lo <= hi) || hi <= 0.0 || na == 0 {
        return Ok(None);
    }
    // the edges of the fitted band, widened by a fraction of a line against rounding
    let df = 1.0 / (n as f64 * ts);
    let band = Lines::band(
        (hz(lo) - 0.25 * df).max(0.0),
        (hz(hi) + 0.25 * df).min(0.5 / ts),
    );
    let lines = band.resolve(n, ts)?;
    let omega_max = TAU * *lines.last().unwrap_or(&1) as f64 * df;
    let ntr = 2 * na.max(nb) + 1;
    let ode = |n_p: usize| -> Result<LtvOde<f64>> {
        Ok(LtvOde::new(na, nb, n_p)
            .with_time_basis(TimeBasis::Legendre)
            .with_frequency_basis(FrequencyBasis::legendre(omega_max)?)
            .with_transient(Some(ntr)))
    };
    let equations = 2 * lines.len();
    let top = MAX_TIME_ORDER.min(max_time_order(n));
    let indices = Lines::Indices(lines);
    let mut candidates = Vec::new();
    let mut fits: Vec<LtvFit<f64>> = Vec::new();
    let mut chosen = 0;
    for n_p in 0..=top {
        let model = ode(n_p)?;
        let params = model.n_params();
        if equations <= params {
            if n_p == 0 {
                return Ok(None);
            }
            break;
        }
        let this = match model.fit(record, &indices) {
            Ok(f) => f,
            Err(e) if n_p == 0 => return Err(e),
            Err(_) => break,
        };
        let cost = this.singular_values.last().map_or(f64::NAN, |s| s * s);
        let p_value = candidates.last().map(|prev: &LtvCandidate| {
            let d1 = (params - prev.params) as f64;
            let d2 = (equations - params) as f64;
            let f = ((prev.cost - cost) / d1) / (cost / d2);
            if f.is_finite() {
                f_sf(f.max(0.0), d1, d2)
            } else {
                // a vanishing cost: an exact fit
                0.0
            }
        });
        let gap = match this.singular_values.as_slice() {
            [.., a, b] => *a / *b,
            _ => f64::INFINITY,
        };
        let accept = p_value.is_none_or(|p| p < alpha) && gap >= MIN_GAP;
        candidates.push(LtvCandidate {
            n_p,
            params,
            cost,
            p_value,
        });
        fits.push(this);
        if !accept {
            break;
        }
        chosen = n_p;
    }
    let fit = fits.swap_remove(chosen);
    let last = (n - 1) as f64 * ts;
    let instants: Vec<f64> = (0..INSTANTS)
        .map(|i| last * i as f64 / (INSTANTS - 1) as f64)
        .collect();
    let mut poles = fit.pole_sweep(&instants)?;
    for p in &mut poles {
        p.sort_by(|a, b| a.im.total_cmp(&b.im).then(a.re.total_cmp(&b.re)));
    }
    Ok(Some(LtvStep {
        n_p: chosen,
        cost_before: candidates[0].cost,
        cost_after: candidates[chosen].cost,
        candidates,
        fit,
        instants,
        poles,
    }))
}

/// The workflow's hook: [`time_varying_ode`] when a step named time variation without the
/// piecewise model, on a continuous-time spec, with a time record in `ctx` (the periodic
/// record, else the non-periodic one); `None` otherwise or when the fit fails.
pub(crate) fn after_time_variation(
    steps: &[Step],
    fit: &SpecFit,
    ctx: &Context,
    piecewise: Option<&TimeVarying>,
) -> Option<LtvStep> {
    let named = steps
        .iter()
        .any(|s| s.effect == Effect::TimeVariation && !s.piecewise);
    if !named || piecewise.is_some() || fit.spec.domain != Domain::Continuous {
        return None;
    }
    let record = match (&ctx.record, &ctx.time) {
        (Some(rec), _) => rec.record(),
        (None, Some(time)) => time.as_ref(),
        (None, None) => return None,
    };
    time_varying_ode(fit, record, ctx.alpha).ok().flatten()
}
