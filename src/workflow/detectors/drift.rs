use super::TimeVariationDetail;
use crate::data::{PeriodicAverage, dft_lines};
use crate::workflow::finding::{
    Context, Detail, DetailFields, Detector, Effect, Finding, NamedValues, Remedy,
};
use crate::workflow::lrt::f_sf;
use crate::workflow::segments::{
    check_rational, fixed_model_cost, segment_spec, split, system_params, transient_params,
};
use crate::workflow::spec::{SpecDomain, SpecFit, fit_spec};
use crate::{FdidError, FrequencyData, NoiseVariances, Result, TimeData};
use nalgebra::{DMatrix, DVector};
use num_complex::Complex;

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
/// The spec is refitted on each segment ([`fit_spec`], output-error ML, eq. 23, weighted
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
/// [`FdidError::InvalidArgument`] named `"segments"` for fewer than 2 segments (or a
/// non-periodic record whose length S does not divide), or named `"fit"` for a user's model
/// structure; [`FdidError::TooShort`] when a segment of a periodic record has fewer than
/// 2 periods or a segment of a non-periodic record fewer fitted lines than p_s + 1; the
/// segment fits' errors.
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

/// The system parameters of a segment fit: the first na + nb + 1, then τ (last, as no
/// noise model is fitted on segments).
fn system_theta(seg: &SpecFit, q: usize) -> (Vec<f64>, Vec<usize>) {
    let base = seg.spec.na + seg.spec.nb + 1;
    let mut idx: Vec<usize> = (0..base).collect();
    if seg.spec.delay {
        idx.push(seg.theta.len() - 1);
    }
    debug_assert_eq!(idx.len(), q);
    (idx.iter().map(|i| seg.theta[*i]).collect(), idx)
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

/// One group of whole periods of a periodic record: its averaged spectra at the fitted
/// lines, its number of periods P_g and its span (s).
struct Group {
    y: Vec<Complex<f64>>,
    u: Vec<Complex<f64>>,
    periods: usize,
    span: (f64, f64),
}

/// A periodic record cut into S groups of whole periods (the first P mod S groups hold
/// ⌊P/S⌋ + 1 periods, the others ⌊P/S⌋), at the fitted lines of `fit`.
struct Groups {
    groups: Vec<Group>,
    /// The pooled within-group sums Σ_g (P_g − 1) s²_g of the output, input and
    /// output–input sample (co)variances per line (2(P − S) real degrees of freedom).
    var_y: Vec<f64>,
    var_u: Vec<f64>,
    cov_yu: Vec<Complex<f64>>,
    /// P − S.
    within: usize,
    /// The pooled sums of the periods' deviations from a straight line in the period
    /// index within each group (output, input, output–input; P − 2S complex degrees of
    /// freedom), when every group holds at least 3 periods.
    detrended: Option<NoiseVariances<f64>>,
    /// P − 2S.
    detrended_dof: usize,
}

impl Groups {
    /// The pooled within-group sample variance of the group mean of P_g periods
    /// (`periods`) at line i: (Σ_g (P_g − 1) s²_g)/((P − S) P_g), for y, u and cov_yu.
    fn mean_noise(&self, periods: usize) -> NoiseVariances<f64> {
        let d = (self.within * periods) as f64;
        NoiseVariances {
            var_y: self.var_y.iter().map(|v| v / d).collect(),
            var_u: self.var_u.iter().map(|v| v / d).collect(),
            cov_yu: self.cov_yu.iter().map(|v| v / d).collect(),
        }
    }

    /// The noise (co)variances of a group mean of P_g periods (`periods`) from the
    /// detrended sums when available (with their P − 2S degrees of freedom), else
    /// [`Groups::mean_noise`] (P − S).
    fn reference_noise(&self, periods: usize) -> (NoiseVariances<f64>, usize) {
        match &self.detrended {
            Some(sums) => {
                let d = (self.detrended_dof * periods) as f64;
                let noise = NoiseVariances {
                    var_y: sums.var_y.iter().map(|v| v / d).collect(),
                    var_u: sums.var_u.iter().map(|v| v / d).collect(),
                    cov_yu: sums.cov_yu.iter().map(|v| v / d).collect(),
                };
                (noise, self.detrended_dof)
            }
            None => (self.mean_noise(periods), self.within),
        }
    }

    /// The pooled within-group variance of the error Y − Ĝ U of a group mean of P_g
    /// periods: s²_Y + |Ĝ|²s²_U − 2 Re(Ĝ* s_YU) from [`Groups::mean_noise`].
    fn error_variance(&self, response: &[Complex<f64>], periods: usize) -> Vec<f64> {
        let d = (self.within * periods) as f64;
        response
            .iter()
            .enumerate()
            .map(|(i, g)| {
                let s2 = self.var_y[i] + g.norm_sqr() * self.var_u[i]
                    - 2.0 * (g.conj() * self.cov_yu[i]).re;
                s2.max(0.0) / d
            })
            .collect()
    }
}

/// Cuts a periodic record of `periods` periods into `segments` groups of whole periods
/// at the fitted lines of `fit` (`None` when a fitted line is not on the period grid).
fn periodic_groups(
    fit: &SpecFit,
    record: &TimeData<f64>,
    periods: usize,
    segments: usize,
) -> Result<Option<Groups>> {
    let per_group = periods / segments;
    if per_group < 2 {
        return Err(FdidError::TooShort {
            what: "periods per segment",
            needed: 2,
            got: per_group,
        });
    }
    let m = record.len() / periods;
    let step = std::f64::consts::TAU / (m as f64 * record.ts());
    let mut lines = Vec::with_capacity(fit.omega.len());
    for w in &fit.omega {
        let k = w / step;
        let r = k.round();
        if (k - r).abs() > 1e-6 || r < 1.0 || 2.0 * r >= m as f64 {
            return Ok(None);
        }
        lines.push(r as usize);
    }
    let n = lines.len();
    let extra = periods % segments;
    let mut start = 0;
    let mut groups = Vec::with_capacity(segments);
    let (mut var_y, mut var_u) = (vec![0.0; n], vec![0.0; n]);
    let mut cov_yu = vec![Complex::new(0.0, 0.0); n];
    let mut trend_y = vec![0.0; n];
    let mut trend_u = vec![0.0; n];
    let mut trend_c = vec![Complex::new(0.0, 0.0); n];
    for g in 0..segments {
        let pg = per_group + usize::from(g < extra);
        let range = start * m..(start + pg) * m;
        let sub = TimeData::new(
            record.u()[range.clone()].to_vec(),
            record.y()[range].to_vec(),
            record.ts(),
        )?;
        let avg = PeriodicAverage::new(&sub, pg)?;
        let all = avg.data();
        let sample = avg.sample_variances().ok_or(FdidError::TooShort {
            what: "periods per segment",
            needed: 2,
            got: pg,
        })?;
        let w = (pg - 1) as f64;
        for (i, &k) in lines.iter().enumerate() {
            var_y[i] += w * sample.var_y[k];
            var_u[i] += w * sample.var_u[k];
            cov_yu[i] += sample.cov_yu[k] * w;
        }
        if per_group >= 3 {
            // the periods' spectra at the lines, less the group's straight line in the
            // period index j (centred c_j = j − (P_g − 1)/2)
            let at = |x: &[f64], j: usize| -> Vec<Complex<f64>> {
                let full = dft_lines(&x[(start + j) * m..(start + j + 1) * m]);
                lines.iter().map(|k| full[*k]).collect()
            };
            let ys: Vec<_> = (0..pg).map(|j| at(record.y(), j)).collect();
            let us: Vec<_> = (0..pg).map(|j| at(record.u(), j)).collect();
            let c: Vec<f64> = (0..pg).map(|j| j as f64 - (pg - 1) as f64 / 2.0).collect();
            let cc: f64 = c.iter().map(|x| x * x).sum();
            let detrend = |x: &[Vec<Complex<f64>>], i: usize| -> Vec<Complex<f64>> {
                let mean = x.iter().map(|v| v[i]).sum::<Complex<f64>>() / pg as f64;
                let slope = x
                    .iter()
                    .zip(&c)
                    .map(|(v, cj)| v[i] * *cj)
                    .sum::<Complex<f64>>()
                    / cc;
                x.iter()
                    .zip(&c)
                    .map(|(v, cj)| v[i] - mean - slope * *cj)
                    .collect()
            };
            for i in 0..n {
                let (ey, eu) = (detrend(&ys, i), detrend(&us, i));
                for (a, b) in ey.iter().zip(&eu) {
                    trend_y[i] += a.norm_sqr();
                    trend_u[i] += b.norm_sqr();
                    trend_c[i] += a * b.conj();
                }
            }
        }
        let t0 = (start * m) as f64 * record.ts();
        groups.push(Group {
            y: lines.iter().map(|k| all.y()[*k]).collect(),
            u: lines.iter().map(|k| all.u()[*k]).collect(),
            periods: pg,
            span: (t0, t0 + (pg * m) as f64 * record.ts()),
        });
        start += pg;
    }
    Ok(Some(Groups {
        groups,
        var_y,
        var_u,
        cov_yu,
        within: periods - segments,
        detrended: (per_group >= 3).then_some(NoiseVariances {
            var_y: trend_y,
            var_u: trend_u,
            cov_yu: trend_c,
        }),
        detrended_dof: periods.saturating_sub(2 * segments),
    }))
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
        let seg = fit_spec(&spec, &data)?;
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
        let seg = fit_spec(&spec, &piece.data)?;
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
/// [`TimeVariationTests`]. An LTI model cannot absorb the effect
/// ([`Remedy::NotAbsorbed`]). Proposal: the current spec unchanged. Detail:
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

/// Both tests of time variation as one measurement-level detector: the skirts around the
/// excited lines ([`TimeVariation`](super::TimeVariation), periodic records) and the parameter drift between
/// time segments ([`TimeDrift`], periodic or non-periodic records).
///
/// With the p-values p₁ … p_m of the tests that apply (m ≤ 2), the finding's p-value is
/// min(1, m · min_i p_i) (Bonferroni), so that on a time-invariant system it falls below
/// any level α with probability at most α; the workflow then tests it at α/(2m′) among its
/// m′ measurement-level detectors, as any other. Statistic: that of the smaller p-value's
/// test. Detail: [`TimeVariationTestsDetail`]. `None` when neither applies. Remedy:
/// [`Remedy::NotAbsorbed`]: an LTI model cannot absorb the effect; with `piecewise` the
/// workflow then switches to the piecewise time-invariant model
/// ([`piecewise_model`], [`TimeVariationTests::switching`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct TimeVariationTests {
    /// The drift test (its number of segments).
    pub drift: TimeDrift,
    /// Whether the workflow switches to the piecewise time-invariant model on the drift
    /// test's S segments when it names the effect ([`Detector::piecewise_segments`],
    /// [`piecewise_model`]); `false` by default (the effect is
    /// named and not absorbed).
    pub piecewise: bool,
}

impl TimeVariationTests {
    /// Both tests, with the switch to the piecewise time-invariant model on
    /// `segments` segments (≥ 2) when the workflow names time variation
    /// ([`Workflow::time_varying`](crate::workflow::Workflow::time_varying)).
    pub fn switching(segments: usize) -> Self {
        Self {
            drift: TimeDrift { segments },
            piecewise: true,
        }
    }
}

impl Detector for TimeVariationTests {
    fn effect(&self) -> Effect {
        Effect::TimeVariation
    }

    fn measurement(&self) -> bool {
        true
    }

    fn piecewise_segments(&self) -> Option<usize> {
        self.piecewise.then_some(self.drift.segments)
    }

    fn detect(&self, data: &FrequencyData<f64>, fit: &SpecFit, ctx: &Context) -> Option<Finding> {
        let skirt = super::TimeVariation.detect(data, fit, ctx);
        let drift = self.drift.detect(data, fit, ctx);
        let m = usize::from(skirt.is_some()) + usize::from(drift.is_some());
        let detail = TimeVariationTestsDetail {
            skirt: skirt
                .as_ref()
                .and_then(|f| f.detail.time_variation().copied()),
            skirt_p: skirt.as_ref().map(|f| f.p_value),
            drift: drift.as_ref().and_then(|f| f.detail.time_drift().copied()),
            drift_p: drift.as_ref().map(|f| f.p_value),
        };
        let best = [skirt, drift]
            .into_iter()
            .flatten()
            .min_by(|a, b| a.p_value.total_cmp(&b.p_value))?;
        Some(Finding {
            p_value: (best.p_value * m as f64).min(1.0),
            detail: Detail::TimeVariationTests(detail),
            ..best
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

/// The detail of a [`TimeVariationTests`] finding: each test's detail and p-value, when
/// the test applies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimeVariationTestsDetail {
    /// The skirt test's detail (its values under their own names).
    pub skirt: Option<TimeVariationDetail>,
    /// The skirt test's p-value, named `skirt_p`.
    pub skirt_p: Option<f64>,
    /// The drift test's detail (its values under their own names).
    pub drift: Option<TimeDriftDetail>,
    /// The drift test's p-value, named `drift_p`.
    pub drift_p: Option<f64>,
}

impl DetailFields for TimeVariationTestsDetail {
    /// The skirt test's values and `skirt_p`, then the drift test's values and `drift_p`.
    fn entries(&self) -> Vec<(&'static str, f64)> {
        let mut entries = self.skirt.map(|d| d.entries()).unwrap_or_default();
        entries.extend(self.skirt_p.map(|p| ("skirt_p", p)));
        entries.extend(self.drift.iter().flat_map(|d| d.entries()));
        entries.extend(self.drift_p.map(|p| ("drift_p", p)));
        entries
    }

    fn take_from(values: &mut NamedValues) -> Option<Self> {
        let skirt_p = values.take("skirt_p");
        let drift_p = values.take("drift_p");
        if skirt_p.is_none() && drift_p.is_none() {
            return None;
        }
        let skirt = match skirt_p {
            Some(_) => Some(TimeVariationDetail::take_from(values)?),
            None => None,
        };
        let drift = match drift_p {
            Some(_) => Some(TimeDriftDetail::take_from(values)?),
            None => None,
        };
        Some(Self {
            skirt,
            skirt_p,
            drift,
            drift_p,
        })
    }
}

/// The piecewise time-invariant model: the spec refitted on each of S time segments
/// ([`piecewise_model`]), the time-varying model the workflow switches to when it names
/// [`Effect::TimeVariation`] (see [`TimeVariationTests::switching`]).
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
/// The segments are those of the drift test ([`parameter_drift`]):
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
/// `cost_after` = Σ_s V_s(θ̂_s) with θ̂_s the spec refitted on segment s ([`fit_spec`]).
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
/// [`parameter_drift`]): `Ok(None)` for continuous-time specs, without a record, for a
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
/// As [`parameter_drift`].
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
    let n = fit.omega.len();
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
        fits.push(fit_spec(&spec, &data)?);
    }
    // the common model: one θ on the segments' lines side by side (line k of every group)
    let mut omega = Vec::with_capacity(n * segments);
    let (mut y, mut u) = (
        Vec::with_capacity(n * segments),
        Vec::with_capacity(n * segments),
    );
    let mut joint = NoiseVariances {
        var_y: Vec::with_capacity(n * segments),
        var_u: Vec::with_capacity(n * segments),
        cov_yu: Vec::with_capacity(n * segments),
    };
    for k in 0..n {
        for (group, noise) in groups.groups.iter().zip(&noises) {
            omega.push(fit.omega[k]);
            y.push(group.y[k]);
            u.push(group.u[k]);
            joint.var_y.push(noise.var_y[k]);
            joint.var_u.push(noise.var_u[k]);
            joint.cov_yu.push(noise.cov_yu[k]);
        }
    }
    let data = FrequencyData::new(omega, y, u, ts)?
        .with_noise(joint)?
        .with_variance_dof(dof)?;
    let Ok(common) = fit_spec(&spec, &data) else {
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
        fits.push(fit_spec(&spec, &piece.data)?);
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

/// Whether `fit` can be split into `segments` time segments: an error for fewer than 2
/// segments or a user's model structure, `false` for a continuous-time spec (its
/// partial-fraction θ is relative to basis poles that move between segments).
fn segmentable(fit: &SpecFit, segments: usize) -> Result<bool> {
    if segments < 2 {
        return Err(FdidError::InvalidArgument {
            name: "segments",
            value: segments.to_string(),
            reason: "time segments compare at least 2 segments".into(),
        });
    }
    check_rational(fit)?;
    Ok(matches!(fit.spec.domain, SpecDomain::Z { .. }))
}
