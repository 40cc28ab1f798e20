//! Where in time the model and the measurement disagree: the whole-record model judged on
//! contiguous segments of the time record, each against a refit of the same structure on
//! that segment alone ([`segment_disagreement`]); and the time segments themselves, shared
//! with the parameter drift test and the piecewise time-invariant model
//! ([`detectors`](super::detectors)): contiguous pieces of a record, groups of whole
//! periods of a periodic record, and the spec refitted on them.
use super::lrt::f_sf;
use super::spec::{SpecFit, fit_spec};
use crate::data::{FrequencyData, NoiseVariances, TimeData};
use crate::data::{PeriodicAverage, dft_lines};
use crate::error::{FdidError, Result};
use crate::estimate::Method;
use crate::estimate::ModelSpec;
use crate::model::Domain;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex;

/// The disagreement of a whole-record model with one time segment
/// ([`segment_disagreement`]).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct SegmentResult {
    /// Start of the segment (s), t = first sample · Ts.
    pub t_start: f64,
    /// End of the segment (s), t = (last sample + 1) · Ts.
    pub t_end: f64,
    /// Number n of fitted lines on the segment's DFT grid.
    pub lines: usize,
    /// The segment cost of the whole-record model, V_fixed/λ̂_s: the normalised residual
    /// power Σ|Y_j − Ĝ U_j − T̂_j|²/|c_j|² with the segment's own transient T̂ and its own
    /// noise level λ̂_s (see [`segment_disagreement`]).
    pub cost: f64,
    /// Its expected value when the model holds on the segment, n − n_T/2.
    pub expected: f64,
    /// The p-value of the segment's F test, multiplied by the number of segments
    /// (Bonferroni, capped at 1).
    pub p_value: f64,
}

/// One contiguous piece of a record at the fitted lines of its DFT grid.
pub(crate) struct Piece {
    /// Start and end (s).
    pub t_start: f64,
    pub t_end: f64,
    /// The piece's DFT at the matched lines, with output noise variances |c_k|² (the
    /// whole fit's normalisers: weights, not levels).
    pub data: FrequencyData<f64>,
    /// For each line of `data`, the index of the fitted line it matches.
    pub index: Vec<usize>,
}

/// Checks the level α ∈ (0, 1).
pub(crate) fn check_alpha(alpha: f64) -> Result<()> {
    if alpha > 0.0 && alpha < 1.0 {
        Ok(())
    } else {
        Err(FdidError::InvalidArgument {
            name: "alpha",
            value: alpha.to_string(),
            reason: "the false-alarm level lies in (0, 1)".into(),
        })
    }
}

/// The spec refitted on a segment: the same system (orders, domain, delay), output-error
/// ML with the whole fit's weights, no noise model, with a transient term when asked.
pub(crate) fn segment_spec(spec: &ModelSpec, transient: bool) -> ModelSpec {
    ModelSpec {
        transient,
        noise_order: None,
        criterion: Method::Ml,
        ..spec.clone()
    }
}

/// The fit of `spec` on the data of one time segment of the record `whole` was fitted
/// on: for a delayed spec with the delay started at `whole`'s τ̂
/// (`ModelSpec::fit_near_delay`) rather than searched
/// — the segments share the record's delay up to the changes the segment tests look
/// for, and a search costs tens of fits per segment; otherwise [`fit_spec`].
pub(crate) fn fit_segment(
    spec: &ModelSpec,
    data: &FrequencyData<f64>,
    whole: &SpecFit,
) -> Result<SpecFit> {
    match whole.delay {
        Some((tau, _)) if spec.delay && tau.is_finite() => {
            super::spec::fit_spec_near_delay(spec, data, tau)
        }
        _ => fit_spec(spec, data),
    }
}

/// Number of system parameters of `spec` (denominator, numerator, delay): the parameters
/// whose meaning does not depend on the segment.
pub(crate) fn system_params(spec: &ModelSpec) -> usize {
    spec.na + spec.nb + 1 + usize::from(spec.delay)
}

/// Number of transient coefficients of `spec`'s rational model with a transient term:
/// max(na, nb) in discrete time (McKelvey eq. 5), na in continuous time (eq. 10).
pub(crate) fn transient_params(spec: &ModelSpec) -> usize {
    match spec.domain {
        Domain::Discrete { .. } => spec.na.max(spec.nb),
        Domain::Continuous => spec.na,
    }
}

/// The system parameters of a segment fit: the first na + nb + 1, then τ (last, as no
/// noise model is fitted on segments).
pub(crate) fn system_theta(seg: &SpecFit, q: usize) -> (Vec<f64>, Vec<usize>) {
    let base = seg.spec.na + seg.spec.nb + 1;
    let mut idx: Vec<usize> = (0..base).collect();
    if seg.spec.delay {
        idx.push(seg.theta.len() - 1);
    }
    debug_assert_eq!(idx.len(), q);
    (idx.iter().map(|i| seg.theta[*i]).collect(), idx)
}

/// Checks that `fit` is of a rational spec (not a user's model structure).
pub(crate) fn check_rational(fit: &SpecFit) -> Result<()> {
    match &fit.custom {
        None => Ok(()),
        Some(label) => Err(FdidError::InvalidArgument {
            name: "fit",
            value: label.clone(),
            reason: "the segment analysis refits the rational spec; a user's model structure \
                     has none"
                .into(),
        }),
    }
}

/// Whether `fit` can be split into `segments` time segments: an error for fewer than 2
/// segments or a user's model structure, `false` for a continuous-time spec (its
/// partial-fraction θ is relative to basis poles that move between segments).
pub(crate) fn segmentable(fit: &SpecFit, segments: usize) -> Result<bool> {
    if segments < 2 {
        return Err(FdidError::InvalidArgument {
            name: "segments",
            value: segments.to_string(),
            reason: "time segments compare at least 2 segments".into(),
        });
    }
    check_rational(fit)?;
    Ok(matches!(fit.spec.domain, Domain::Discrete { .. }))
}

/// Splits `record` into `segments` contiguous pieces of L = N/S samples and takes each
/// piece's DFT (eq. 1, lines at ω_j = 2πj/(L Ts)) at the fitted lines of `fit` that lie on
/// its grid (whole-record line l = jS; lines 0 and L/2 excluded).
///
/// # Errors
/// [`FdidError::InvalidArgument`] named `"segments"` for fewer than 2 segments or when
/// S does not divide N; [`FdidError::TooShort`] when a piece holds fewer fitted lines
/// than `min_lines`.
pub(crate) fn split(
    fit: &SpecFit,
    record: &TimeData<f64>,
    segments: usize,
    min_lines: usize,
) -> Result<Vec<Piece>> {
    let n = record.len();
    if segments < 2 || !n.is_multiple_of(segments) {
        return Err(FdidError::InvalidArgument {
            name: "segments",
            value: segments.to_string(),
            reason: format!(
                "need at least 2 segments of equal length dividing the record length {n}"
            ),
        });
    }
    let l = n / segments;
    let ts = record.ts();
    let step = std::f64::consts::TAU / (n as f64 * ts);
    // (fitted index, segment line j)
    let mut matched = Vec::new();
    for (i, w) in fit.omega.iter().enumerate() {
        let x = w / step;
        let r = x.round();
        if (x - r).abs() > 1e-6 || r < 0.0 {
            continue;
        }
        let line = r as usize;
        if !line.is_multiple_of(segments) {
            continue;
        }
        let j = line / segments;
        if j > 0 && 2 * j < l {
            matched.push((i, j));
        }
    }
    if matched.len() < min_lines {
        return Err(FdidError::TooShort {
            what: "fitted lines per segment",
            needed: min_lines,
            got: matched.len(),
        });
    }
    let weights: Vec<f64> = matched
        .iter()
        .map(|(i, _)| fit.scale[*i].norm_sqr())
        .collect();
    let omega: Vec<f64> = matched
        .iter()
        .map(|(_, j)| std::f64::consts::TAU * *j as f64 / (l as f64 * ts))
        .collect();
    (0..segments)
        .map(|s| {
            let range = s * l..(s + 1) * l;
            let yl = dft_lines(&record.y()[range.clone()]);
            let ul = dft_lines(&record.u()[range]);
            let y = matched.iter().map(|(_, j)| yl[*j]).collect();
            let u = matched.iter().map(|(_, j)| ul[*j]).collect();
            let data = FrequencyData::new(omega.clone(), y, u, Some(ts))?
                .with_noise(NoiseVariances::output_only(weights.clone()))?;
            Ok(Piece {
                t_start: (s * l) as f64 * ts,
                t_end: ((s + 1) * l) as f64 * ts,
                data,
                index: matched.iter().map(|(i, _)| *i).collect(),
            })
        })
        .collect()
}

/// One group of whole periods of a periodic record: its averaged spectra at the fitted
/// lines, its number of periods P_g and its span (s).
pub(crate) struct Group {
    pub y: Vec<Complex<f64>>,
    pub u: Vec<Complex<f64>>,
    pub periods: usize,
    pub span: (f64, f64),
}

/// A periodic record cut into S groups of whole periods (the first P mod S groups hold
/// ⌊P/S⌋ + 1 periods, the others ⌊P/S⌋), at the fitted lines of `fit`.
pub(crate) struct Groups {
    pub groups: Vec<Group>,
    /// The pooled within-group sums Σ_g (P_g − 1) s²_g of the output, input and
    /// output–input sample (co)variances per line (2(P − S) real degrees of freedom).
    var_y: Vec<f64>,
    var_u: Vec<f64>,
    cov_yu: Vec<Complex<f64>>,
    /// P − S.
    pub within: usize,
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
    pub(crate) fn reference_noise(&self, periods: usize) -> (NoiseVariances<f64>, usize) {
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
    pub(crate) fn error_variance(&self, response: &[Complex<f64>], periods: usize) -> Vec<f64> {
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
pub(crate) fn periodic_groups(
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
    let Some(lines) = inner_period_lines(&fit.omega, m, record.ts()) else {
        return Ok(None);
    };
    let n = lines.len();
    let extra = periods % segments;
    let mut start = 0;
    let mut groups = Vec::with_capacity(segments);
    let (mut var_y, mut var_u) = (vec![0.0; n], vec![0.0; n]);
    let mut cov_yu = vec![Complex::new(0.0, 0.0); n];
    let mut trend = NoiseVariances {
        var_y: vec![0.0; n],
        var_u: vec![0.0; n],
        cov_yu: vec![Complex::new(0.0, 0.0); n],
    };
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
            add_detrended(record, &lines, start..start + pg, m, &mut trend);
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
        detrended: (per_group >= 3).then_some(trend),
        detrended_dof: periods.saturating_sub(2 * segments),
    }))
}

/// The period-grid lines k (ω = 2πk/(M Ts), M = `m` samples per period) of `omega`,
/// `None` when one is off the grid or is line 0 or at or beyond the Nyquist line M/2.
fn inner_period_lines(omega: &[f64], m: usize, ts: f64) -> Option<Vec<usize>> {
    let step = std::f64::consts::TAU / (m as f64 * ts);
    omega
        .iter()
        .map(|w| {
            let k = w / step;
            let r = k.round();
            if (k - r).abs() > 1e-6 || r < 1.0 || 2.0 * r >= m as f64 {
                return None;
            }
            Some(r as usize)
        })
        .collect()
}

/// Adds to `sums`, per line of `lines`, the squared deviations of the spectra of the
/// periods `group` of `record` (M = `m` samples each) from the group's straight line in
/// the period index j (centred c_j = j − (P_g − 1)/2): |e_Y|², |e_U|² and e_Y e_U*.
fn add_detrended(
    record: &TimeData<f64>,
    lines: &[usize],
    group: std::ops::Range<usize>,
    m: usize,
    sums: &mut NoiseVariances<f64>,
) {
    let pg = group.len();
    let at = |x: &[f64], j: usize| -> Vec<Complex<f64>> {
        let full = dft_lines(&x[j * m..(j + 1) * m]);
        lines.iter().map(|k| full[*k]).collect()
    };
    let ys: Vec<_> = group.clone().map(|j| at(record.y(), j)).collect();
    let us: Vec<_> = group.map(|j| at(record.u(), j)).collect();
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
    for i in 0..lines.len() {
        let (ey, eu) = (detrend(&ys, i), detrend(&us, i));
        for (a, b) in ey.iter().zip(&eu) {
            sums.var_y[i] += a.norm_sqr();
            sums.var_u[i] += b.norm_sqr();
            sums.cov_yu[i] += a * b.conj();
        }
    }
}

/// The poles of `fit`'s system as poles of z⁻¹ polynomials: p in discrete time, e^{p Ts}
/// in continuous time (the transient of sampled data, eq. 10).
fn z_poles(fit: &SpecFit, ts: f64) -> Vec<Complex<f64>> {
    match fit.spec.domain {
        Domain::Discrete { .. } => fit.poles.clone(),
        Domain::Continuous => fit.poles.iter().map(|p| (p * ts).exp()).collect(),
    }
}

/// V_fixed: the cost Σ_j |Y_j − Ĝ_j U_j − T_j|²/|c_j|² of the whole-record response Ĝ on
/// `piece`, minimised over the transient T = (t₀ + t₁z⁻¹ + … + t_{n−1}z⁻⁽ⁿ⁻¹⁾)/Â(z⁻¹)
/// (eq. 5, Â with the fitted poles, real t, n = `n_t`) by a real-stacked least-squares
/// solve (SVD).
pub(crate) fn fixed_model_cost(fit: &SpecFit, piece: &Piece, n_t: usize) -> f64 {
    let d = &piece.data;
    let ts = d.ts().unwrap_or(1.0);
    let poles = z_poles(fit, ts);
    let n = d.len();
    let mut r0 = DVector::zeros(2 * n);
    let mut basis = DMatrix::zeros(2 * n, n_t);
    for (j, &i) in piece.index.iter().enumerate() {
        let c = fit.scale[i].norm();
        let e = (d.y()[j] - fit.response[i] * d.u()[j]) / c;
        r0[2 * j] = e.re;
        r0[2 * j + 1] = e.im;
        let zi = Complex::new(0.0, -d.omega()[j] * ts).exp();
        let a: Complex<f64> = poles
            .iter()
            .fold(Complex::new(1.0, 0.0), |acc, p| acc * (1.0 - p * zi));
        let mut zk = Complex::new(1.0, 0.0);
        for m in 0..n_t {
            let b = zk / a / c;
            basis[(2 * j, m)] = b.re;
            basis[(2 * j + 1, m)] = b.im;
            zk *= zi;
        }
    }
    if n_t == 0 {
        return r0.norm_squared();
    }
    // bounded iterations: a basis with non-finite entries fails instead of looping
    let iterations = 100 * basis.ncols().max(10);
    let Some(svd) = crate::linalg::try_svd(basis.clone(), true, true, iterations) else {
        return r0.norm_squared();
    };
    match svd.solve(&r0, 1e-12 * svd.singular_values.max()) {
        Ok(t) => (r0 - basis * t).norm_squared(),
        Err(_) => r0.norm_squared(),
    }
}

/// Where in time `fit`'s model disagrees with `record`: the cost of the whole-record model
/// on each of `segments` contiguous segments, relative to the segment's own fit.
///
/// `fit` is the fit of the DFT lines of `record` (eq. 1; the averaged spectra of a
/// periodic record are on the same grid). Each segment s of L = N/S samples is
/// transformed (lines ω_j = 2πj/(L Ts) = the whole record's lines jS; a fitted line k
/// supplies Ĝ_k and the normaliser c_k, |c_k|² ∝ the noise variance, eq. 23). Two costs
/// of the same normalised residuals r_j = (Y_j − Ŷ_j)/|c_k|:
///
/// - V_fixed: the whole-record Ĝ with the segment's own transient T (n_T real coefficients
///   over the fitted denominator, eq. 5; eq. 10 for continuous time), refitted by linear
///   least squares — a segment cut from a record always leaks;
/// - V_own: the spec refitted on the segment (output-error ML, eq. 23, same weights, with
///   a transient; p_own parameters).
///
/// If the model holds on the segment, V_fixed − V_own ≈ (λ_s/2) χ²(q), q = p_own − n_T,
/// independent of V_own ≈ (λ_s/2) χ²(d), d = 2n − p_own, so
/// F = ((V_fixed − V_own)/q)/(V_own/d) ~ F(q, d), conservative since the whole-record
/// model was fitted on this segment too. The result reports the segment cost
/// V_fixed/λ̂_s with λ̂_s = V_own/(n − p_own/2) against its expected value n − n_T/2, and
/// the p-value S · P(F(q, d) > F) (Bonferroni over the segments, capped at 1): on a
/// time-invariant system no segment is below α with probability at least 1 − α.
///
/// ```
/// use fdid::prelude::*;
/// use fdid::simulate::SplitMix64;
/// use fdid::workflow::{ModelSpec, fit_spec, segment_disagreement};
/// # fn main() -> fdid::Result<()> {
/// // y(t) = 0.5 u(t) + a y(t − 1), a = 0.5 for the first half, 0.6 for the second
/// let n = 2048;
/// let mut rng = SplitMix64::new(1);
/// let u: Vec<f64> = (0..n).map(|_| rng.gaussian()).collect();
/// let mut y = vec![0.0; n];
/// for t in 0..n {
///     let a = if t < n / 2 { 0.5 } else { 0.6 };
///     y[t] = 0.5 * u[t] + if t > 0 { a * y[t - 1] } else { 0.0 };
/// }
/// let y: Vec<f64> = y.iter().map(|v| v + 0.01 * rng.gaussian()).collect();
/// let record = TimeData::new(u, y, 1.0)?;
/// let all = record.dft();
/// let keep: Vec<bool> = (0..all.len()).map(|k| k > 0 && 2 * k < n).collect();
/// let data = all.select_lines(&keep)?;
/// let spec = ModelSpec { transient: true, ..ModelSpec::discrete(1, 0, 1.0) };
/// let fit = fit_spec(&spec, &data)?;
/// let segments = segment_disagreement(&fit, &record, 2, 0.05)?;
/// assert_eq!(segments.len(), 2);
/// assert!(segments.iter().all(|s| s.p_value < 0.05 && s.cost > s.expected));
/// # Ok(())
/// # }
/// ```
///
/// # Errors
/// [`FdidError::InvalidArgument`] for α outside (0, 1), fewer than 2 segments, S not
/// dividing N, or a fit of a user's model structure; [`FdidError::TooShort`] when a segment
/// holds fewer than p_own + 1 fitted lines; the segment fits' errors.
pub fn segment_disagreement(
    fit: &SpecFit,
    record: &TimeData<f64>,
    segments: usize,
    alpha: f64,
) -> Result<Vec<SegmentResult>> {
    check_alpha(alpha)?;
    check_rational(fit)?;
    let spec = segment_spec(&fit.spec, true);
    let n_t = transient_params(&spec);
    let p_own = system_params(&spec) + n_t;
    let pieces = split(fit, record, segments, p_own + 1)?;
    pieces
        .iter()
        .map(|piece| {
            let own = fit_segment(&spec, &piece.data, fit)?;
            let n = piece.data.len();
            let v_fixed = fixed_model_cost(fit, piece, n_t);
            let v_own = own.cost;
            let q = (own.n_params - n_t) as f64;
            let d = (2 * n - own.n_params) as f64;
            let lambda = v_own / (n as f64 - own.n_params as f64 / 2.0);
            let f = ((v_fixed - v_own) / q) / (v_own / d);
            let p = if f > 0.0 && f.is_finite() {
                f_sf(f, q, d)
            } else if f.is_finite() || v_fixed <= v_own {
                1.0
            } else {
                0.0
            };
            Ok(SegmentResult {
                t_start: piece.t_start,
                t_end: piece.t_end,
                lines: n,
                cost: v_fixed / lambda,
                expected: n as f64 - n_t as f64 / 2.0,
                p_value: (p * segments as f64).min(1.0),
            })
        })
        .collect()
}
