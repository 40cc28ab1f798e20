//! The piecewise time-invariant model: the spec refitted on each of S time segments of the
//! record ([`piecewise_model`]), the model the workflow switches to when it names time
//! variation, and the F test of it against the common (time-invariant) model.
use crate::data::{FrequencyData, NoiseVariances, TimeData};
use crate::error::Result;
use crate::workflow::finding::Context;
use crate::workflow::segments::{
    Groups, fit_segment, fixed_model_cost, periodic_groups, segment_spec, segmentable, split,
    system_params, system_theta, transient_params,
};
use crate::workflow::spec::SpecFit;
use num_complex::Complex;

/// The piecewise time-invariant model: the spec refitted on each of S time segments
/// ([`piecewise_model`]), the time-varying model the workflow switches to when it names
/// [`Effect::TimeVariation`](crate::workflow::Effect::TimeVariation) (see
/// [`TimeVariationTests::switching`](super::TimeVariationTests::switching)).
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct TimeVarying {
    /// Start and end (s) of each segment.
    pub segments: Vec<(f64, f64)>,
    /// The system parameters θ̂_s of each segment (a₁…a_na, b₀…b_nb, then τ).
    pub theta: Vec<Vec<f64>>,
    /// Each segment's fit (output-error ML, eq. 23, on the segment's data with its own
    /// noise reference). Not serialised.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub fits: Vec<SpecFit>,
    /// The cost of the common (time-invariant) model on all segments, Σ_s V_s(θ̄).
    pub cost_before: f64,
    /// The cost of the segment models, Σ_s V_s(θ̂_s).
    pub cost_after: f64,
    /// The parameters the segment models add to the common model, (S − 1)q.
    pub extra_params: usize,
    /// The p-value of the F test of the common model against the segment models.
    pub lr_p: f64,
    /// The p-value of the segment models' combined cost test (Σ_s V_s(θ̂_s) against its
    /// distribution when every segment model holds); `None` without a known noise level.
    pub cost_p: Option<f64>,
    /// The p-value of each segment fit's whiteness test.
    pub whiteness_p: Vec<Option<f64>>,
}

impl TimeVarying {
    /// Whether the segment models are consistent with the noise at level α: the combined
    /// cost test at α/2 and each of the S segments' whiteness tests at α/(2S) (Bonferroni,
    /// so that on a piecewise time-invariant system the verdict fails with probability at
    /// most α). Without a known noise level the cost test is skipped.
    pub fn consistent_with_noise(&self, alpha: f64) -> bool {
        let s = self.whiteness_p.len().max(1) as f64;
        self.cost_p.is_none_or(|p| p >= alpha / 2.0)
            && self
                .whiteness_p
                .iter()
                .all(|w| w.is_none_or(|p| p >= alpha / (2.0 * s)))
    }
}

/// The piecewise time-invariant model of `fit`'s spec on `segments` time segments of the
/// measurement in `ctx`, and the test that it explains the data better than the common
/// (time-invariant) model.
///
/// The segments are those of the drift test ([`parameter_drift`](super::parameter_drift)):
///
/// - a periodic record ([`Context::with_record`], P ≥ 4): S groups of P_g whole periods;
///   segment s holds the averaged spectra of its group at the fitted lines, with the
///   noise variances of a group mean from the periods' deviations e_g,j,k from a straight
///   line in the period index j within each group (a slow drift inside a segment is not
///   taken for noise), σ²_s,k = Σ_g Σ_j |e_g,j,k|² / ((P − 2S) P_s) for the output, the
///   input and their covariance (independent of the group means; `variance_dof` =
///   P − 2S); with fewer than 3 periods per group, the plain pooled within-group sample
///   (co)variances Σ_g (P_g − 1) s²_g,k / ((P − S) P_s) (`variance_dof` = P − S), which
///   also hold the drift inside each segment and so make the cost test lenient. The segment
///   cost is McKelvey's ML cost (eq. 23),
///   `V_s(θ) = Σ_k |Y_s,k − G(ω_k, θ) U_s,k|² / (σ²_Y + |G|²σ²_U − 2 Re(G* σ_YU))_s,k`.
///   The common model minimises Σ_s V_s(θ) over one θ (one fit to the segments' lines
///   side by side): `cost_before` = min_θ Σ_s V_s(θ);
/// - a non-periodic record ([`Context::with_time_record`]): S contiguous pieces of N/S
///   samples, each the DFT (eq. 1) at the fitted lines on its grid, with the whole fit's
///   normalisers |c_k|² as noise variances and its own transient term (eq. 5, n_T
///   coefficients). `cost_before` = Σ_s min_T V_s(θ̄, T_s), θ̄ the whole-record fit (the
///   common system with each segment's own transient, refitted by linear least squares);
///   θ̄ minimises the whole record's cost, not Σ_s V_s, so `cost_before` is slightly above
///   the common model's minimum and the test slightly liberal.
///
/// `cost_after` = Σ_s V_s(θ̂_s) with θ̂_s the spec refitted on segment s
/// ([`fit_spec`](crate::workflow::fit_spec); a delayed spec from the whole fit's τ̂).
/// With p₀ the common model's parameters and p₁ = Σ_s p_s, p₁ − p₀ = (S − 1)q (q system
/// parameters; the same hypothesis as the drift test), the F form of the
/// likelihood-ratio test ([`lr_test`](crate::workflow::lrt::lr_test) with an unknown
/// noise level, robust to sample-variance weights),
///
/// `F = ((cost_before − cost_after)/(p₁ − p₀)) / (cost_after/(2n − p₁)) ~ F(p₁ − p₀, 2n − p₁)`,
///
/// n = Σ_s n_s lines, gives `lr_p`. The combined cost test of the segment models
/// ([`Validation`](crate::validation::Validation) of all segment residuals with p₁
/// parameters: E Σ_s V_s = n − p₁/2, F(2, 2ν) line moments for sample variances of ν
/// degrees of freedom) gives `cost_p` when the noise level is known (always for a periodic
/// record; for a non-periodic one when the whole fit's noise level is known); each segment
/// fit's whiteness test gives `whiteness_p` ([`TimeVarying::consistent_with_noise`]).
///
/// Discrete-time specs only (the parameters must mean the same on every segment, see
/// [`parameter_drift`](super::parameter_drift)): `Ok(None)` for continuous-time specs, without a record, for a
/// periodic record of fewer than 4 periods or fitted lines off its grid, or when the
/// common fit fails.
///
/// ```
/// use fdid::prelude::*;
/// use fdid::simulate::SplitMix64;
/// use fdid::workflow::detectors::piecewise_model;
/// use fdid::workflow::{Context, ModelSpec, fit_spec};
/// # fn main() -> fdid::Result<()> {
/// // y(t) = 0.5 u(t) + a y(t − 1), a = 0.5 for the first half, 0.55 for the second
/// let n = 2048;
/// let mut rng = SplitMix64::new(2);
/// let u: Vec<f64> = (0..n).map(|_| rng.gaussian()).collect();
/// let mut y = vec![0.0; n];
/// for t in 1..n {
///     let a = if t < n / 2 { 0.5 } else { 0.55 };
///     y[t] = 0.5 * u[t] + a * y[t - 1];
/// }
/// let y: Vec<f64> = y.iter().map(|v| v + 0.01 * rng.gaussian()).collect();
/// let record = TimeData::new(u, y, 1.0)?;
/// let all = record.dft();
/// let keep: Vec<bool> = (0..all.len()).map(|k| k > 0 && 2 * k < n).collect();
/// let data = all.select_lines(&keep)?;
/// let fit = fit_spec(&ModelSpec { transient: true, ..ModelSpec::discrete(1, 0, 1.0) }, &data)?;
/// let ctx = Context::non_periodic(0.05).with_time_record(record);
/// let tv = piecewise_model(&fit, &ctx, 2)?.unwrap();
/// assert!(tv.cost_after < tv.cost_before && tv.lr_p < 1e-3);
/// // the segment models see a = 0.5, then 0.55 (a₁ = −a)
/// assert!((tv.theta[0][0] + 0.5).abs() < 0.01 && (tv.theta[1][0] + 0.55).abs() < 0.01);
/// assert!(tv.consistent_with_noise(0.05));
/// # Ok(())
/// # }
/// ```
///
/// # Errors
/// As [`parameter_drift`](super::parameter_drift).
pub fn piecewise_model(
    fit: &SpecFit,
    ctx: &Context,
    segments: usize,
) -> Result<Option<TimeVarying>> {
    if !segmentable(fit, segments)? {
        return Ok(None);
    }
    let q = system_params(&fit.spec);
    if let Some(rec) = ctx.record.as_ref() {
        if rec.periods() < 4 {
            return Ok(None);
        }
        periodic_piecewise(fit, rec.record(), rec.periods(), segments, q)
    } else if let Some(record) = ctx.time.as_ref() {
        record_piecewise(fit, record, segments, q)
    } else {
        Ok(None)
    }
}

/// The piecewise model's summary from the segment fits and the common model's cost.
fn summarise(
    fits: Vec<SpecFit>,
    segments: Vec<(f64, f64)>,
    cost_before: f64,
    p0: usize,
    q: usize,
    noise_known: bool,
    dof: Option<usize>,
) -> Result<TimeVarying> {
    let cost_after: f64 = fits.iter().map(|f| f.cost).sum();
    let p1: usize = fits.iter().map(|f| f.n_params).sum();
    let residuals: Vec<Complex<f64>> = fits.iter().flat_map(|f| f.residuals.clone()).collect();
    let n = residuals.len();
    let test = crate::workflow::lrt::lr_test(cost_before, p0, cost_after, p1, n, false)?;
    let cost_p = crate::validation::Validation::new(&residuals, p1, noise_known, dof).cost_p;
    Ok(TimeVarying {
        segments,
        theta: fits.iter().map(|f| system_theta(f, q).0).collect(),
        whiteness_p: fits.iter().map(|f| f.validation.whiteness_p).collect(),
        fits,
        cost_before,
        cost_after,
        extra_params: p1 - p0,
        lr_p: test.p_value,
        cost_p,
    })
}

/// The piecewise model of a periodic record: S groups of whole periods.
fn periodic_piecewise(
    fit: &SpecFit,
    record: &TimeData<f64>,
    periods: usize,
    segments: usize,
    q: usize,
) -> Result<Option<TimeVarying>> {
    let Some(groups) = periodic_groups(fit, record, periods, segments)? else {
        return Ok(None);
    };
    let spec = segment_spec(&fit.spec, fit.spec.transient);
    let ts = Some(record.ts());
    let mut fits = Vec::with_capacity(segments);
    let (noises, dofs): (Vec<NoiseVariances<f64>>, Vec<usize>) = groups
        .groups
        .iter()
        .map(|g| groups.reference_noise(g.periods))
        .unzip();
    let dof = dofs[0];
    for (group, noise) in groups.groups.iter().zip(&noises) {
        let data = FrequencyData::new(fit.omega.clone(), group.y.clone(), group.u.clone(), ts)?
            .with_noise(noise.clone())?
            .with_variance_dof(dof)?;
        fits.push(fit_segment(&spec, &data, fit)?);
    }
    let data = side_by_side(&fit.omega, &groups, &noises, ts)?.with_variance_dof(dof)?;
    let Ok(common) = fit_segment(&spec, &data, fit) else {
        return Ok(None);
    };
    let spans = groups.groups.iter().map(|g| g.span).collect();
    summarise(
        fits,
        spans,
        common.cost,
        common.n_params,
        q,
        true,
        Some(dof),
    )
    .map(Some)
}

/// The data of the common model of a periodic record: the groups' lines side by side
/// (line k of every group, in group order, at `omega[k]`), each with its group's noise
/// (co)variances from `noises`, so that one θ fitted on them minimises Σ_s V_s(θ).
fn side_by_side(
    omega: &[f64],
    groups: &Groups,
    noises: &[NoiseVariances<f64>],
    ts: Option<f64>,
) -> Result<FrequencyData<f64>> {
    let size = omega.len() * groups.groups.len();
    let mut w = Vec::with_capacity(size);
    let (mut y, mut u) = (Vec::with_capacity(size), Vec::with_capacity(size));
    let mut joint = NoiseVariances {
        var_y: Vec::with_capacity(size),
        var_u: Vec::with_capacity(size),
        cov_yu: Vec::with_capacity(size),
    };
    for (k, wk) in omega.iter().enumerate() {
        for (group, noise) in groups.groups.iter().zip(noises) {
            w.push(*wk);
            y.push(group.y[k]);
            u.push(group.u[k]);
            joint.var_y.push(noise.var_y[k]);
            joint.var_u.push(noise.var_u[k]);
            joint.cov_yu.push(noise.cov_yu[k]);
        }
    }
    FrequencyData::new(w, y, u, ts)?.with_noise(joint)
}

/// The piecewise model of a non-periodic record: S contiguous pieces, each with its own
/// transient.
fn record_piecewise(
    fit: &SpecFit,
    record: &TimeData<f64>,
    segments: usize,
    q: usize,
) -> Result<Option<TimeVarying>> {
    let spec = segment_spec(&fit.spec, true);
    let n_t = transient_params(&spec);
    let pieces = split(fit, record, segments, q + n_t + 1)?;
    let mut fits = Vec::with_capacity(segments);
    let mut before = 0.0;
    for piece in &pieces {
        fits.push(fit_segment(&spec, &piece.data, fit)?);
        before += fixed_model_cost(fit, piece, n_t);
    }
    let spans = pieces.iter().map(|p| (p.t_start, p.t_end)).collect();
    summarise(
        fits,
        spans,
        before,
        q + segments * n_t,
        q,
        fit.noise_known,
        fit.variance_dof,
    )
    .map(Some)
}
