//! The parameter drift test of time variation: the spec refitted on time segments of the
//! record, the homogeneity of the segments' system parameters ([`parameter_drift`]), and
//! its detector [`TimeDrift`].
use crate::data::{FrequencyData, NoiseVariances, TimeData};
use crate::error::Result;
use crate::workflow::finding::{
    Context, Detail, DetailFields, Detector, Effect, Finding, NamedValues, Remedy,
};
use crate::workflow::lrt::f_sf;
use crate::workflow::segments::{
    fit_segment, periodic_groups, segment_spec, segmentable, split, system_params, system_theta,
    transient_params,
};
use crate::workflow::spec::SpecFit;
use nalgebra::{DMatrix, DVector};

/// The homogeneity test of the parameters fitted on time segments
/// ([`parameter_drift`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Drift {
    /// The statistic T = Σ_s (θ̂_s − θ̄)ᵀ C_s⁻¹ (θ̂_s − θ̄).
    pub statistic: f64,
    /// Its degrees of freedom (S − 1) q (q system parameters).
    pub dof: usize,
    /// Degrees of freedom of the noise estimates behind the C_s (the F test's second).
    pub noise_dof: f64,
    /// P(F((S − 1)q, noise_dof) > T/((S − 1)q)).
    pub p_value: f64,
    /// The system parameters θ̂_s of each segment (denominator a₁…a_na, numerator
    /// b₀…b_nb, then τ for a delay).
    pub theta: Vec<Vec<f64>>,
    /// Their covariances C_s.
    pub covariance: Vec<DMatrix<f64>>,
    /// The pooled estimate θ̄ = (Σ C_s⁻¹)⁻¹ Σ C_s⁻¹ θ̂_s.
    pub pooled: Vec<f64>,
    /// Start and end (s) of each segment.
    pub spans: Vec<(f64, f64)>,
}

/// One segment's fit: its data, its θ̂ and C.
struct SegmentFit {
    theta: Vec<f64>,
    covariance: DMatrix<f64>,
    span: (f64, f64),
}

/// The test that the system parameters of `fit`'s spec are the same on `segments`
/// segments of the measurement in `ctx`: a drift of the parameters is a time-varying
/// system.
///
/// The spec is refitted on each segment ([`fit_spec`](crate::workflow::fit_spec), a
/// delayed spec with τ started from the whole fit's; output-error ML, eq. 23, weighted
/// by the whole fit's normalisers 1/|c_k|² — for a periodic record their running mean over
/// 11 lines —, no noise model): for the periodic record
/// ([`Context::with_record`], P ≥ 4) segment g holds P_g whole periods (S groups of ⌊P/S⌋
/// or ⌈P/S⌉ periods, at least 2 each) and is fitted on their averaged spectra at the
/// fitted lines; for a non-periodic record ([`Context::with_time_record`]) segment s is
/// the DFT of the s-th contiguous piece of N/S samples (at the fitted lines on its grid)
/// and the spec is fitted with its transient term (eq. 5). The system parameters θ̂_s
/// (q of them: a₁…a_na, b₀…b_nb, τ) have the first-order covariance
///
/// `C_s = A⁻¹ (Σ_k σ̂²_k/(2|c_k|²) J_kᵀJ_k) A⁻¹`, `A = JᵀJ`
///
/// (the q × q block; J the segment fit's real-stacked residual Jacobian, J_k its rows of
/// line k; McKelvey eqs. 32–34 with the weights not the inverse variances), with σ̂²_k the
/// variance of the segment's error Y_k − G U_k: for a periodic record the pooled
/// within-group sample variance s²_Y + |Ĝ|²s²_U − 2 Re(Ĝ* s_YU), divided by P_g (independent
/// of the group means, 2(P − S) real degrees of freedom per line); for a non-periodic
/// record λ̂_s|c_k|², λ̂_s = V_s/(n − p_s/2) from the segment fit's cost (2n − p_s degrees
/// of freedom). With the pooled θ̄ = (Σ C_s⁻¹)⁻¹ Σ C_s⁻¹ θ̂_s,
///
/// `T = Σ_s (θ̂_s − θ̄)ᵀ C_s⁻¹ (θ̂_s − θ̄) ~ χ²((S − 1)q)`
///
/// under "no drift"; the p-value takes the noise estimates into account with the F
/// approximation T/((S − 1)q) ~ F((S − 1)q, d), d their degrees of freedom (the total over
/// lines for a periodic record, the smallest segment's for a non-periodic one).
///
/// The parameters must mean the same on every segment: true for discrete-time specs
/// (polynomial coefficients in z⁻¹, a₀ = 1); the continuous-time θ is relative to basis
/// poles that move with the data, so continuous-time specs are not tested (`Ok(None)`).
/// Also `Ok(None)` without a record in `ctx`, for a periodic record of fewer than 4
/// periods, when the fitted lines are not on the record's grid, or for a segment fit
/// without a covariance.
///
/// # Errors
/// [`FdidError::InvalidArgument`](crate::FdidError::InvalidArgument) named `"segments"` for
/// fewer than 2 segments (or a non-periodic record whose length S does not divide), or
/// named `"fit"` for a user's model structure;
/// [`FdidError::TooShort`](crate::FdidError::TooShort) when a segment of a periodic record
/// has fewer than 2 periods or a segment of a non-periodic record fewer fitted lines than
/// p_s + 1; the segment fits' errors.
pub fn parameter_drift(fit: &SpecFit, ctx: &Context, segments: usize) -> Result<Option<Drift>> {
    if !segmentable(fit, segments)? {
        return Ok(None);
    }
    let q = system_params(&fit.spec);
    let (fits, noise_dof) = if let Some(rec) = ctx.record.as_ref() {
        if rec.periods() < 4 {
            return Ok(None);
        }
        match periodic_fits(fit, rec.record(), rec.periods(), segments, q)? {
            Some(x) => x,
            None => return Ok(None),
        }
    } else if let Some(record) = ctx.time.as_ref() {
        match record_fits(fit, record, segments, q)? {
            Some(x) => x,
            None => return Ok(None),
        }
    } else {
        return Ok(None);
    };
    Ok(homogeneity(fits, q, noise_dof))
}

/// T, θ̄ and the p-value from the segment fits.
fn homogeneity(fits: Vec<SegmentFit>, q: usize, noise_dof: f64) -> Option<Drift> {
    let mut info = DMatrix::zeros(q, q);
    let mut weighted = DVector::zeros(q);
    let mut inverses = Vec::with_capacity(fits.len());
    for f in &fits {
        let w = f.covariance.clone().cholesky()?.inverse();
        info += &w;
        weighted += &w * DVector::from_column_slice(&f.theta);
        inverses.push(w);
    }
    let pooled = info.cholesky()?.solve(&weighted);
    let statistic: f64 = fits
        .iter()
        .zip(&inverses)
        .map(|(f, w)| {
            let d = DVector::from_column_slice(&f.theta) - &pooled;
            (d.transpose() * w * &d)[(0, 0)]
        })
        .sum();
    let dof = (fits.len() - 1) * q;
    if !statistic.is_finite() {
        return None;
    }
    let p_value = f_sf(statistic / dof as f64, dof as f64, noise_dof);
    Some(Drift {
        statistic,
        dof,
        noise_dof,
        p_value,
        spans: fits.iter().map(|f| f.span).collect(),
        theta: fits.iter().map(|f| f.theta.clone()).collect(),
        covariance: fits.into_iter().map(|f| f.covariance).collect(),
        pooled: pooled.iter().copied().collect(),
    })
}

/// The q × q block of A⁻¹ B A⁻¹ for the segment fit `seg` with per-line error variances
/// `var` (of Y_k − G U_k): A = JᵀJ, B = Σ_k var_k/(2|c_k|²) J_kᵀJ_k. `None` when J has
/// not full column rank.
fn sandwich(seg: &SpecFit, var: &[f64], q: usize) -> Option<DMatrix<f64>> {
    let j = &seg.jacobian;
    let p = j.ncols();
    let qr = j.clone().qr();
    let r = qr.r();
    let scale = r.diagonal().amax();
    if !(scale > 0.0) || r.diagonal().iter().any(|d| d.abs() <= 1e-12 * scale) {
        return None;
    }
    // A⁻¹ = R⁻¹R⁻ᵀ
    let r_inv = r.try_inverse()?;
    let a_inv = &r_inv * r_inv.transpose();
    let mut b = DMatrix::zeros(p, p);
    for (k, v) in var.iter().enumerate() {
        let w = v / (2.0 * seg.scale[k].norm_sqr());
        let rows = j.rows(2 * k, 2);
        b += w * rows.transpose() * rows;
    }
    let c = &a_inv * b * &a_inv;
    Some(c.view((0, 0), (q, q)).into_owned())
}

/// The covariance block of the indices `idx` of a full p × p matrix computed on the
/// first q columns: reorders J so that the system parameters come first.
fn system_covariance(seg: &SpecFit, var: &[f64], idx: &[usize]) -> Option<DMatrix<f64>> {
    let p = seg.jacobian.ncols();
    let mut order: Vec<usize> = idx.to_vec();
    order.extend((0..p).filter(|i| !idx.contains(i)));
    let mut reordered = seg.clone();
    reordered.jacobian = seg.jacobian.select_columns(&order);
    sandwich(&reordered, var, idx.len())
}

/// Half-width of the running mean of [`smoothed_weights`] (lines).
const SMOOTHING: usize = 5;

/// The whole fit's |c_k|² averaged over the fitted lines k − 5 … k + 5 (clipped at the
/// ends): for a periodic record |c_k|² is a sample variance that shares the group means'
/// between-group deviation; weights from it alone make the sandwich covariance about 6 %
/// too small in standard deviation (measured, P = 8), the running mean removes that
/// dependence while following a coloured noise spectrum.
fn smoothed_weights(fit: &SpecFit) -> Vec<f64> {
    let power: Vec<f64> = fit.scale.iter().map(|c| c.norm_sqr()).collect();
    let n = power.len();
    (0..n)
        .map(|k| {
            let window = &power[k.saturating_sub(SMOOTHING)..(k + SMOOTHING + 1).min(n)];
            window.iter().sum::<f64>() / window.len() as f64
        })
        .collect()
}

/// Segment fits of a periodic record: S groups of whole periods, averaged.
fn periodic_fits(
    fit: &SpecFit,
    record: &TimeData<f64>,
    periods: usize,
    segments: usize,
    q: usize,
) -> Result<Option<(Vec<SegmentFit>, f64)>> {
    let Some(groups) = periodic_groups(fit, record, periods, segments)? else {
        return Ok(None);
    };
    let spec = segment_spec(&fit.spec, fit.spec.transient);
    let weights = smoothed_weights(fit);
    let mut fits = Vec::with_capacity(segments);
    for group in &groups.groups {
        let data = FrequencyData::new(
            fit.omega.clone(),
            group.y.clone(),
            group.u.clone(),
            Some(record.ts()),
        )?
        .with_noise(NoiseVariances::output_only(weights.clone()))?;
        let seg = fit_segment(&spec, &data, fit)?;
        let var = groups.error_variance(&fit.response, group.periods);
        let (theta, idx) = system_theta(&seg, q);
        let Some(covariance) = system_covariance(&seg, &var, &idx) else {
            return Ok(None);
        };
        fits.push(SegmentFit {
            theta,
            covariance,
            span: group.span,
        });
    }
    Ok(Some((
        fits,
        2.0 * groups.within as f64 * fit.omega.len() as f64,
    )))
}

/// Segment fits of a non-periodic record: S contiguous pieces with their transient.
fn record_fits(
    fit: &SpecFit,
    record: &TimeData<f64>,
    segments: usize,
    q: usize,
) -> Result<Option<(Vec<SegmentFit>, f64)>> {
    let spec = segment_spec(&fit.spec, true);
    let p = q + transient_params(&spec);
    let pieces = split(fit, record, segments, p + 1)?;
    let mut fits = Vec::with_capacity(segments);
    let mut noise_dof = f64::INFINITY;
    for piece in &pieces {
        let seg = fit_segment(&spec, &piece.data, fit)?;
        let n = piece.data.len() as f64;
        let lambda = seg.cost / (n - seg.n_params as f64 / 2.0);
        noise_dof = noise_dof.min(2.0 * n - seg.n_params as f64);
        let var: Vec<f64> = seg.scale.iter().map(|c| lambda * c.norm_sqr()).collect();
        let (theta, idx) = system_theta(&seg, q);
        let Some(covariance) = system_covariance(&seg, &var, &idx) else {
            return Ok(None);
        };
        fits.push(SegmentFit {
            theta,
            covariance,
            span: (piece.t_start, piece.t_end),
        });
    }
    Ok(Some((fits, noise_dof)))
}

/// Parameters drifting between time segments: a time-varying system
/// ([`parameter_drift`] on `segments` segments, default 2).
///
/// The second test of time variation beside the skirts of
/// [`TimeVariation`](super::TimeVariation): it needs no periodic excitation (a
/// non-periodic record, [`Context::with_time_record`]) and sees slow changes of the
/// dynamics whose skirts are buried in the noise. Both name
/// [`Effect::TimeVariation`]; the workflow's default runs both as one detector,
/// [`TimeVariationTests`](super::TimeVariationTests). An LTI model cannot absorb the
/// effect ([`Remedy::NotAbsorbed`]). Proposal: the current spec unchanged. Detail:
/// [`TimeDriftDetail`].
///
/// ```
/// use fdid::prelude::*;
/// use fdid::simulate::SplitMix64;
/// use fdid::workflow::detectors::TimeDrift;
/// use fdid::workflow::{Context, Detector, Effect, ModelSpec, fit_spec};
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
/// let finding = TimeDrift::default().detect(&data, &fit, &ctx).unwrap();
/// assert_eq!(finding.effect, Effect::TimeVariation);
/// assert!(finding.p_value < 1e-3);
/// # Ok(())
/// # }
/// ```
#[derive(Debug, Clone, Copy)]
pub struct TimeDrift {
    /// Number S of segments (≥ 2).
    pub segments: usize,
}

impl Default for TimeDrift {
    fn default() -> Self {
        Self { segments: 2 }
    }
}

impl Detector for TimeDrift {
    fn effect(&self) -> Effect {
        Effect::TimeVariation
    }

    fn measurement(&self) -> bool {
        true
    }

    /// The drift of the segment fits assumes the model structure is adequate.
    fn model_based(&self, _finding: &Finding) -> bool {
        true
    }

    fn detect(&self, _data: &FrequencyData<f64>, fit: &SpecFit, ctx: &Context) -> Option<Finding> {
        let drift = parameter_drift(fit, ctx, self.segments).ok()??;
        let largest = drift
            .theta
            .iter()
            .zip(&drift.covariance)
            .flat_map(|(t, c)| {
                t.iter()
                    .zip(&drift.pooled)
                    .enumerate()
                    .map(move |(i, (x, m))| (x - m).abs() / c[(i, i)].sqrt())
            })
            .fold(0.0, f64::max);
        Some(Finding {
            effect: Effect::TimeVariation,
            statistic: drift.statistic,
            p_value: drift.p_value,
            detail: Detail::TimeDrift(TimeDriftDetail {
                drift_statistic: drift.statistic,
                drift_dof: drift.dof,
                segments: self.segments,
                largest_shift: largest,
            }),
            proposal: fit.spec.clone(),
        })
    }

    fn remedy(
        &self,
        _data: &FrequencyData<f64>,
        _fit: &SpecFit,
        _ctx: &Context,
        _finding: &Finding,
    ) -> Option<Remedy> {
        Some(Remedy::NotAbsorbed)
    }
}

/// The detail of a [`TimeDrift`] finding.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimeDriftDetail {
    /// The statistic T ([`Drift::statistic`]), named `drift_statistic`.
    pub drift_statistic: f64,
    /// Its degrees of freedom (S − 1)q, named `drift_dof`.
    pub drift_dof: usize,
    /// The number S of segments, named `segments`.
    pub segments: usize,
    /// The largest |θ̂_s,i − θ̄_i|/√(C_s)_ii, named `largest_shift`.
    pub largest_shift: f64,
}

impl DetailFields for TimeDriftDetail {
    fn entries(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("drift_statistic", self.drift_statistic),
            ("drift_dof", self.drift_dof as f64),
            ("segments", self.segments as f64),
            ("largest_shift", self.largest_shift),
        ]
    }

    fn take_from(values: &mut NamedValues) -> Option<Self> {
        Some(Self {
            drift_statistic: values.take("drift_statistic")?,
            drift_dof: values.take_count("drift_dof")?,
            segments: values.take_count("segments")?,
            largest_shift: values.take("largest_shift")?,
        })
    }
}
