//! Fits with a time delay (McKelvey section 4): the starting delay from the phase slope,
//! a profile of Levy's cost over delays and a scan of candidates by output-error cost
//! ([`delay_start`]), then the joint ML of
//! G_M(θ) e^{−iωτ} ([`Delayed::fit`], [`fit_delayed`]).

use super::delay_profile::{levy_profile, profile_minima};
use super::{FurtherStarts, Pipeline};
use crate::criterion::{Criterion, MaximumLikelihood, output_error_cost_in};
use crate::data::FrequencyData;
use crate::error::{FdidError, Result};
use crate::fit::{Fit, Stage, StageKind};
use crate::model::delay::delay_factor;
use crate::model::{Delayed, ModelStructure, Output, remove_delay};
use crate::scalar::{Complex, Real};
use crate::solver::{GramLevenbergMarquardt, LevenbergMarquardt, Solution, Termination};
use crate::stats::median;
use num_traits::Float;

/// A starting delay from [`delay_start`], with what its search did.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct DelayStart<T: Real> {
    /// τ₀ (s): the candidate with the lowest output-error cost.
    pub tau: T,
    /// Its output-error cost V = Σ_k w_k²|Y_k − G(θ, ω_k) U_k|² (McKelvey eq. 23) after the
    /// ML refinement of the delayed model from that candidate.
    pub cost: T,
    /// τ from the phase slope: after the phase-slope iterations, or the raw slope when the
    /// Levy profile's candidate ended the search before them.
    pub phase_slope: T,
    /// Delay-free fits made (the profile's basis, phase iterations, scan and refinements).
    pub fits: usize,
}

/// Phase-slope iterations after the slope of the raw phase.
pub(super) const PHASE_ITERATIONS: usize = 4;
/// Sanathanan–Koerner iterations of a screening fit in the candidate scan.
pub(super) const SCREEN_ITERATIONS: usize = 3;
/// Local minima of the screening scan refitted in full.
pub(super) const REFINED_MINIMA: usize = 5;
/// Evaluation budget factor of the ML refinements of the search (at most
/// `SEARCH_PATIENCE·(p + 1)` residual evaluations each): they rank candidate delays, the
/// ML from the best one runs with the pipeline's budget.
pub(super) const SEARCH_PATIENCE: usize = 4;
/// The least evaluation budget of a refinement of the search, whatever the order.
pub(super) const SEARCH_EVALUATIONS: usize = 100;
/// Relative cost reduction below which an ML refinement of the search stops (unless the
/// pipeline's ML tolerance is looser): a refinement crawling through a wrong delay's
/// valley ends early, and the next round starts from where it went.
pub(super) const SEARCH_COST_TOLERANCE: f64 = 1e-4;
/// Cap on the candidates of the scan.
pub(super) const MAX_SCAN: usize = 512;
/// The most delays a whole number of samples from the best refined one that are refined
/// too (±1, ±2 sample periods from it; the nearest whole number of samples and ±1, ±2).
pub(super) const SAMPLE_MULTIPLES: usize = 9;
/// The most delays between minima that are refined (the midpoint of the scan's two lowest
/// minima; the midpoint and quarter points towards the best delay's neighbour on each
/// side).
pub(super) const BETWEEN_STARTS: usize = 7;
/// The most lines of the Levy profile's data ([`every_nth_line`]).
pub(super) const PROFILE_LINES: usize = 256;
/// The Levy profile's local minima refined before the phase-slope iterations: those whose
/// cost is within [`PROFILE_WITHIN`] times the lowest, at most this many.
pub(super) const PROFILE_MINIMA: usize = 3;
/// The factor of the lowest Levy cost within which a minimum of the profile is refined:
/// with noise two delays a few standard deviations apart can have nearly the same Levy
/// cost and different ML costs.
pub(super) const PROFILE_WITHIN: f64 = 2.0;
/// Rounds of a refinement of a minimum of the Levy profile: the full round alone. The
/// profile places its minima within a fraction of δ of the ML's where it works; where
/// it does not, the search goes on, and more rounds from its minima would be spent twice.
pub(super) const PROFILE_ROUNDS: usize = 1;
/// Rounds of (delay-free fit, ML on the delayed model) per refined candidate.
pub(super) const CANDIDATE_ROUNDS: usize = 3;

/// A starting value τ₀ for the delay of `model` on `data`, from the phase slope, a profile
/// of Levy's cost over candidate delays and, when that does not settle it, a scan of
/// candidate delays by output-error cost, each delay-free fit made with `pipeline`
/// without its ML stage (Levy → SK, every solve by the guarded normal equations — these
/// fits only start the search's MLs — and without a fit's statistics).
///
/// **Method.** With H_k = Y_k/U_k and weights w_k = |Y_k|²/σ_k² (σ_k² the output noise
/// variance, 1 without variances or with flat weighting — the inverse variance of arg H_k
/// for small noise), and V(τ) = Σ_k |Y_k − G_M(ω_k) e^{−iω_kτ} U_k|²/σ_k² the
/// output-error cost (McKelvey eq. 23) of the delay-free model G_M fitted to the
/// delay-compensated data Y_k e^{iω_kτ} ([`remove_delay`]):
/// 1. τ_r ← −slope of the weighted linear regression φ_k ≈ c − τ ω_k of the unwrapped
///    phase φ_k = arg H_k (the intercept c is free: a sign of the gain or a constant phase
///    of G_M goes there);
/// 2. the Levy profile: a screening fit of G_M (Levy → three SK iterations) at τ_r gives
///    a basis (for a partial-fraction model, one relocated to that fit's poles, in which
///    Levy's equation error, eq. 39, is the SK residual of eq. 41 weighted by those
///    poles); in it Levy's cost V_L(τ) is evaluated at the delays τ_r + jδ,
///    δ = π/(4 ω_max) — an eighth of the period of the highest frequency, Ts/4 for
///    discrete time up to Nyquist — over −2h ≤ j ≤ h, h = 4(p_M/2 + 2) (the phase of a
///    rational model of p_M parameters varies by about p_M·π/2 over the band: a few
///    samples for a low-order discrete model; below τ_r twice as far, as the group delay
///    of G_M biases τ_r upwards), for about one Gram matrix per delay from blocks formed
///    once (`levy_profile`). The fit and the profile use at most 256 evenly spaced lines
///    of the data. The profile's lowest local minimum, placed between the grid's delays
///    by a parabola in log V_L, is refined by the first round of step 5. When that reaches
///    the stopping cost (below), the profile's other local minima within twice its lowest
///    cost (at most two; with a sample time, none within δ/2 of a whole number of samples
///    from one before — the numerator of a discrete model absorbs such a shift in Levy's
///    cost, not in the ML's) are refined the same way — with noise two minima a few
///    standard deviations apart can have nearly the same Levy cost and different ML
///    costs — and the search ends at the best;
/// 3. up to four times from τ_r: fit G_M to the data compensated by the current τ,
///    regress the unwrapped phase of H_k e^{iω_kτ}/G_M(ω_k) (the phase of Y/U minus those
///    of the delay and of the delay-free fit) the same way and move τ by the remaining
///    slope; stop when the step is below δ/8;
/// 4. the delay of step 3 is refined (as in step 5); when that reaches the stopping cost
///    the search ends there. Otherwise: the phase slope is biased by the mean group delay
///    of G_M (step 1), a rational fit absorbs much of a residual linear phase (a
///    Padé-like approximation of a delay, step 3) and Levy's cost weights the lines by a
///    basis fitted at a wrong delay (step 2), so a scan by output-error cost follows over
///    the delays of step 2, each screened by V(τ) after three SK iterations; with bounds
///    the scan covers [lo, hi] instead when that is no wider (at most 512 candidates, δ
///    widened if needed);
/// 5. the five lowest local minima of the scan are refined:
///    each by three rounds of a delay-free fit at the current τ — in full (Levy → SK), by
///    Levy alone, and in full on the lower half of the band, whose phase error from a
///    small delay error is halved — followed by output-error ML ([`MaximumLikelihood`],
///    eq. 23) of the delayed model by Levenberg–Marquardt from [θ_M, τ], τ moving to the
///    ML delay. These MLs only rank the candidates: each stops after max(4(p + 1), 100)
///    residual evaluations (p parameters; a lightly damped high-order model crawls for
///    thousands) or once an iteration lowers the cost by less than a relative 10⁻⁴, and a
///    round from a delay already tried (starts clamped to a bound
///    coincide) is not repeated. The three delay-free fits fall into different local solutions when τ is
///    slightly wrong (a discrete model then often takes an unstable pole near z = −1), so
///    the joint ML from one of them usually reaches the true delay;
/// 6. the same refinement at ±1 and ±2 multiples of π/ω_max from the best refined delay
///    (a delay one sample off is the commonest wrong local minimum of a discrete model);
/// 7. the same refinement between minima: the midpoint of the scan's two lowest local
///    minima, and the midpoint and quarter points between the best refined delay and its
///    nearest refined neighbour on either side within 8δ. A rational model absorbs a small
///    delay error on either side of the true delay (zeros in the right or left half
///    plane), so V has a local minimum on each flank of a narrow global one;
///
/// τ₀ is the refined delay of lowest ML cost V. V is jagged in τ (a wrong delay leaves
/// SK in different local solutions), which is why the search scans densely and refines
/// several minima rather than descending from one point.
///
/// The refinements stop as soon as the best ML cost reaches the stopping cost: the noise
/// level — with noise variances its 99.95 % quantile N − p/2 + 3.3√N, without them the
/// level estimated from the residuals of that best round itself by their second
/// differences over the lines (a worse round's residuals overstate the noise) — or round-off on noise-free data. No other delay can lower such a cost
/// significantly. Once the work budget of [`crate::solver::work`] is spent the search
/// ends at its best refined delay.
///
/// **Reliability** (`model_delay::survey`, 500 random noise-free systems of orders 1–6
/// per kind, delays of 0–8 units of π/ω_max): the wrong minimum in 0 of 500 continuous-
/// and 0 of 500 discrete-time cases in f64, 1 of 500 of each in f32.
///
/// Every candidate is clamped into the model's bounds. A refinement whose ML delay leaves
/// them ranks below every one that ends within them (its cost is lowered by leaving
/// them), unless none of those reaches the stopping cost and its cost is lower: then the
/// delay lies outside the bounds, and the joint ML reports it. Without bounds τ may turn
/// out negative (an advance).
///
/// # Errors
/// No positive frequency (the delay is not identifiable), a zero input line, or every
/// delay-free fit failing (the first failure is returned).
pub fn delay_start<T: Real, M: FurtherStarts<T>>(
    pipeline: &Pipeline,
    model: &Delayed<M>,
    data: &FrequencyData<T>,
) -> Result<DelayStart<T>> {
    search_delay(pipeline, model, data).map(|(start, _)| start)
}

/// [`delay_start`], with the refinement round of lowest ML cost.
fn search_delay<T: Real, M: FurtherStarts<T>>(
    pipeline: &Pipeline,
    model: &Delayed<M>,
    data: &FrequencyData<T>,
) -> Result<(DelayStart<T>, BestRound<T, M>)> {
    model.check_data(data)?;
    let h = data.etfe()?;
    let w_max = max_frequency(data.omega());
    if !(w_max > T::zero()) {
        return Err(FdidError::InvalidArgument {
            name: "omega",
            value: format!("max {w_max} rad/s"),
            reason: "a delay needs at least one positive frequency to be identified".into(),
        });
    }
    let line_weights = pipeline.weighting.weights(data)?;
    let phase_weight = phase_weights(data, line_weights.as_deref());
    let mut search = DelaySearch::new(
        pipeline,
        model,
        data,
        &phase_weight,
        line_weights.as_deref(),
        w_max,
    );
    // 1. the slope of the raw phase
    let tau_r = search.raw_phase_slope(&h);
    // 2. the Levy profile's lowest minima, refined first
    if let Some((lowest, others)) = search.profile_minima(tau_r).split_first() {
        search.refine_rounds(*lowest, PROFILE_ROUNDS);
        if search.done() {
            // the competing minima, whose ML may end lower still
            for t in others {
                search.refine_rounds(*t, PROFILE_ROUNDS);
            }
            return search.finish(tau_r);
        }
    }
    // 3. phase-slope iterations on delay-compensated fits, their delay refined first
    let phase_slope = search.phase_iterations(&h, tau_r);
    search.refine(phase_slope);
    if search.done() {
        return search.finish(phase_slope);
    }
    // 4. the screening scan
    let grid = search.scan_grid(tau_r);
    let scan = search.screen(grid);
    // 5. the lowest local minima of the scan, refitted in full and refined by ML on the
    //    delayed model
    let candidates = search.candidates(phase_slope, &scan);
    search.refine_candidates(candidates);
    // 6. multiples of π/ω_max away from the best
    search.refine_sample_multiples();
    // 7. between the two lowest minima
    search.refine_between(&scan);
    search.finish(phase_slope)
}

/// The largest frequency of `omega` (rad/s), zero when none is positive.
fn max_frequency<T: Real>(omega: &[T]) -> T {
    omega.iter().copied().fold(T::zero(), Float::max)
}

/// The weights of the phase regressions: |Y_k|² capped at its median, so that resonance
/// peaks (where G_M's group delay is largest) do not dominate the regression, times the
/// squared line weight w_k (1 without `line_weights`).
fn phase_weights<T: Real>(data: &FrequencyData<T>, line_weights: Option<&[T]>) -> Vec<T> {
    let mut power: Vec<T> = data.y().iter().map(|y| y.norm_sqr()).collect();
    let cap = median(&mut power.clone());
    for p in power.iter_mut() {
        *p = Float::min(*p, cap);
    }
    power
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let w = line_weights.map_or(T::one(), |w| w[k]);
            *p * w * w
        })
        .collect()
}

/// The ML cost at which the delay search stops: a cost at the noise level (known
/// variances: V ≤ N − p/2 + 3.3√N, the 99.95 % quantile of its asymptotic distribution)
/// or at round-off (noise free: V ≤ (100ε)² Σ|w Y|²) cannot be improved on significantly.
fn stopping_cost<T: Real, M: FurtherStarts<T>>(
    model: &Delayed<M>,
    data: &FrequencyData<T>,
    line_weights: Option<&[T]>,
) -> T {
    let n = T::from_usize_lossy(data.len());
    let p = T::from_usize_lossy(ModelStructure::<T>::n_params(model));
    let good_enough = match line_weights {
        Some(_) => n - p / T::lit(2.0) + T::lit(3.3) * Float::sqrt(n),
        None => T::zero(),
    };
    let floor = data.y().iter().enumerate().fold(T::zero(), |s, (k, y)| {
        let w = line_weights.map_or(T::one(), |w| w[k]);
        s + y.norm_sqr() * w * w
    }) * Float::powi(T::default_epsilon() * T::lit(100.0), 2);
    Float::max(good_enough, floor)
}

/// The fewest lines from which [`noise_level_cost`] estimates the noise level.
const NOISE_LEVEL_LINES: usize = 32;

/// The output-error cost at the noise level of unweighted data, estimated from the
/// residuals of the fit θ of `model`: a cost the best delay cannot improve on
/// significantly, `None` on fewer than 32 lines.
///
/// **Method.** The residual of the FRF, q_k = (Y_k − Ŷ_k)/U_k, is noise of variance
/// σ²/|U_k|² plus the model's error, which is smooth in k wherever the lines resolve the
/// response. Its second differences d_k = q_{k−1} − 2q_k + q_{k+1} cancel the smooth part
/// and keep noise of variance σ² s_k, s_k = 1/|U_{k−1}|² + 4/|U_k|² + 1/|U_{k+1}|²
/// (neighbouring lines' noise independent). |d_k|²/(σ² s_k) is then exponential of mean
/// one, whose median is ln 2, so σ̂² = median_k(|d_k|²/s_k)/ln 2 — the median keeps the
/// few lines where the model's error is not smooth (a missed resonance) from raising it.
/// The returned cost is σ̂²(N − p/2 + 3.3√N)(1 + 6/√N): the 99.95 % quantile of the cost
/// at the noise level (as [`stopping_cost`] with known variances), widened by three
/// standard deviations of σ̂² (about 2/√N relative for the median of correlated
/// differences). A wrong delay's systematic error is smooth, so its cost exceeds the level
/// unless it is insignificant beside the noise.
fn noise_level_cost<T: Real, M: FurtherStarts<T>>(
    model: &Delayed<M>,
    theta: &[T],
    data: &FrequencyData<T>,
) -> Option<T> {
    let n = data.len();
    if n < NOISE_LEVEL_LINES {
        return None;
    }
    let mut out = crate::model::Output::new(n, ModelStructure::<T>::n_params(model));
    out.evaluate(model, theta, data, false);
    let (y, u) = (data.y(), data.u());
    let q: Vec<Complex<T>> = (0..n).map(|k| (y[k] - out.yhat[k]) / u[k]).collect();
    let inv: Vec<T> = u.iter().map(|u| T::one() / u.norm_sqr()).collect();
    let mut ratios: Vec<T> = (1..n - 1)
        .map(|k| {
            let d = q[k - 1] - q[k] * T::lit(2.0) + q[k + 1];
            d.norm_sqr() / (inv[k - 1] + inv[k] * T::lit(4.0) + inv[k + 1])
        })
        .filter(|r| Float::is_finite(*r))
        .collect();
    if ratios.len() < NOISE_LEVEL_LINES / 2 {
        return None;
    }
    let sigma2 = median(&mut ratios) / T::lit(std::f64::consts::LN_2);
    let nf = T::from_usize_lossy(n);
    let p = T::from_usize_lossy(ModelStructure::<T>::n_params(model));
    let root = Float::sqrt(nf);
    let level =
        sigma2 * (nf - p / T::lit(2.0) + T::lit(3.3) * root) * (T::one() + T::lit(6.0) / root);
    Float::is_finite(level).then_some(level)
}

/// The local minima of the screening `scan` (τ, cost), lowest cost first.
fn local_minima<T: Real>(scan: &[(T, T)]) -> Vec<(T, T)> {
    let mut minima: Vec<(T, T)> = (0..scan.len())
        .filter(|&i| {
            let c = scan[i].1;
            (i == 0 || scan[i - 1].1 >= c) && (i + 1 == scan.len() || scan[i + 1].1 >= c)
        })
        .map(|i| scan[i])
        .collect();
    minima.sort_by(|a, b| a.1.partial_cmp(&b.1).unwrap_or(std::cmp::Ordering::Equal));
    minima
}

/// The state of the search of [`delay_start`], one method per step.
struct DelaySearch<'a, T: Real, M> {
    model: &'a Delayed<M>,
    data: &'a FrequencyData<T>,
    /// The delay-free fits at a candidate τ and the phase regressions.
    search: Search<'a, T, M>,
    /// Levy → SK (the pipeline without its ML stage): the phase-slope iterations and the
    /// first and third rounds of a refinement.
    full: Pipeline,
    /// Levy → SK with [`SCREEN_ITERATIONS`] SK iterations: the screening scan.
    screen: Pipeline,
    /// Levy alone: the second round of a refinement.
    levy: Pipeline,
    /// The ML criterion of the refinements on the delayed model.
    ml: MaximumLikelihood,
    /// Its solver: the pipeline's, or the default when it has none.
    lm: LevenbergMarquardt,
    /// δ = π/(4 ω_max).
    step: T,
    /// The ML cost at which the search stops ([`stopping_cost`]); without noise weights
    /// the noise level estimated from the best round's own residuals may raise it
    /// ([`Self::stop_cost`]).
    threshold: T,
    /// The round of lowest ML cost so far whose ML delay lies within the bounds.
    best_round: Option<BestRound<T, M>>,
    /// The round of lowest ML cost among those whose ML delay left the bounds.
    best_outside: Option<BestRound<T, M>>,
    /// Delay-free fits made.
    fits: usize,
    /// The first failure of a fit.
    first_error: Option<FdidError>,
    /// (τ, ML cost) of each refined candidate.
    refined: Vec<(T, T)>,
    /// Every refinement round made.
    rounds: Vec<RoundMade<T>>,
}

/// The refinement round of lowest ML cost: the final ML of [`Delayed::fit`] continues from
/// it rather than fitting the inner model again at τ₀.
struct BestRound<T: Real, M> {
    /// The delayed model with the inner model of the round's delay-free fit (a
    /// partial-fraction basis relocated to its poles).
    model: Delayed<M>,
    /// The round's ML solution [θ_M, τ] on the delayed model.
    solution: Solution<T>,
    /// The noise-level cost of its residuals ([`noise_level_cost`], `None` with noise
    /// weights or too few lines).
    level: Option<T>,
    /// The stages of the round's delay-free fit.
    inner_stages: Vec<Stage<T>>,
}

/// An inner model, its estimate θ_M and the stages that made it.
type InnerStart<T, M> = (M, Vec<T>, Vec<Stage<T>>);

/// A refinement round made: its number, its start τ and its outcome (the ML delay and
/// cost, `None` when it failed or diverged).
type RoundMade<T> = (usize, T, Option<(T, T)>);

impl<'a, T: Real, M: FurtherStarts<T>> DelaySearch<'a, T, M> {
    fn new(
        pipeline: &Pipeline,
        model: &'a Delayed<M>,
        data: &'a FrequencyData<T>,
        phase_weight: &'a [T],
        line_weights: Option<&'a [T]>,
        w_max: T,
    ) -> Self {
        Self {
            model,
            data,
            search: Search {
                model: model.inner(),
                data,
                phase_weight,
                weights: line_weights,
            },
            full: Pipeline {
                ml: None,
                ..*pipeline
            },
            screen: Pipeline {
                ml: None,
                sk: Some(crate::solver::FixedPoint {
                    max_iterations: SCREEN_ITERATIONS,
                    ..pipeline.sk.unwrap_or_default()
                }),
                ..*pipeline
            },
            levy: Pipeline {
                sk: None,
                ml: None,
                ..*pipeline
            },
            ml: MaximumLikelihood {
                weighting: pipeline.weighting,
            },
            lm: {
                let lm = pipeline.ml.unwrap_or_default();
                let p = ModelStructure::<T>::n_params(model) + 1;
                LevenbergMarquardt {
                    patience: lm
                        .patience
                        .min(SEARCH_PATIENCE.max(SEARCH_EVALUATIONS.div_ceil(p))),
                    cost_tolerance: Some(
                        lm.cost_tolerance.unwrap_or(0.0).max(SEARCH_COST_TOLERANCE),
                    ),
                    ..lm
                }
            },
            step: T::pi() / (T::lit(4.0) * w_max),
            threshold: stopping_cost(model, data, line_weights),
            best_round: None,
            best_outside: None,
            fits: 0,
            first_error: None,
            refined: vec![],
            rounds: vec![],
        }
    }

    /// Step 1: τ_r, minus the slope of the phase regression of the raw `h` = Y/U (zero
    /// without one), clamped into the bounds.
    fn raw_phase_slope(&self, h: &[Complex<T>]) -> T {
        self.model.clamp(
            self.search
                .residual_slope(h, None)
                .map_or_else(T::zero, |s| -s),
        )
    }

    /// Step 2: the delays of lowest Levy cost ([`levy_profile`]) over the scan's range
    /// ([`Self::scan_range`]) in the basis of a screening fit at `tau_r` (for a
    /// partial-fraction model, relocated to that fit's poles), both on at most
    /// [`PROFILE_LINES`] lines of the data ([`every_nth_line`]): the profile's local minima
    /// within [`PROFILE_WITHIN`] of its lowest, at most [`PROFILE_MINIMA`], lowest first,
    /// located between the grid's delays ([`profile_minima`]); empty when that fit fails
    /// or no delay has a finite cost.
    fn profile_minima(&mut self, tau_r: T) -> Vec<T> {
        self.fits += 1;
        let fewer = every_nth_line(self.data, self.search.weights, PROFILE_LINES);
        let (data, weights) = match &fewer {
            Some((d, w)) => (d, w.as_deref()),
            None => (self.data, self.search.weights),
        };
        let basis = Search {
            data,
            weights,
            ..self.search
        };
        let inner = match basis.fit_full(&self.screen, tau_r, false) {
            Ok((inner, _, _)) => inner,
            Err(e) => {
                self.first_error.get_or_insert(e);
                return vec![];
            }
        };
        let (start, count) = self.scan_range(tau_r);
        let cost = levy_profile(&inner, data, weights, start, self.step, count);
        let minima: Vec<T> = profile_minima(&cost, T::lit(PROFILE_WITHIN), PROFILE_MINIMA)
            .into_iter()
            .map(|m| self.model.clamp(start + self.step * m))
            .collect();
        self.apart_from_sample_shifts(minima)
    }

    /// `minima` without those within δ/2 of a whole number of sample periods from one
    /// kept before (all of them without a sample time). The Levy profile of a discrete
    /// model is nearly flat across whole-sample shifts — its numerator absorbs them, and
    /// Levy's cost is linear in it — while the ML cost is not: the lowest of such minima
    /// stands for them, and step 6 refines the shifts when the search goes on.
    fn apart_from_sample_shifts(&self, minima: Vec<T>) -> Vec<T> {
        let Some(ts) = self.data.ts() else {
            return minima;
        };
        let mut kept: Vec<T> = Vec::with_capacity(minima.len());
        for t in minima {
            let shift = |k: &T| {
                let samples = Float::abs(t - *k) / ts;
                Float::abs(samples - Float::round(samples)) * ts < self.step / T::lit(2.0)
            };
            if !kept.iter().any(shift) {
                kept.push(t);
            }
        }
        kept
    }

    /// The range of the candidates of the scan as a uniform grid of step δ: the first delay
    /// and the number of delays ([`Self::scan_grid`]'s range: τ_r − 2hδ … τ_r + hδ, or the
    /// bounds when they are narrower than that, else that range clipped to the bounds).
    fn scan_range(&self, tau_r: T) -> (T, usize) {
        let step = self.step;
        let half = self.scan_half_width();
        let mut lo = tau_r - step * T::from_usize_lossy(2 * half);
        let mut hi = tau_r + step * T::from_usize_lossy(half);
        if let Some((b_lo, b_hi)) = self.model.bounds() {
            let (b_lo, b_hi) = (T::lit(b_lo), T::lit(b_hi));
            if b_hi - b_lo <= step * T::from_usize_lossy(3 * half) {
                (lo, hi) = (b_lo, b_hi);
            } else {
                (lo, hi) = (Float::max(lo, b_lo), Float::min(hi, b_hi));
            }
        }
        let intervals = Float::min(
            Float::floor(Float::max(hi - lo, T::zero()) / step),
            T::from_usize_lossy(MAX_SCAN - 1),
        );
        (lo, intervals.to_f64_lossless() as usize + 1)
    }

    /// Step 3: up to [`PHASE_ITERATIONS`] phase-slope iterations from `tau_r`; returns the
    /// delay of the lowest-cost fit among them (the last τ when every fit failed).
    fn phase_iterations(&mut self, h: &[Complex<T>], tau_r: T) -> T {
        let omega = self.data.omega();
        let mut visited: Vec<(T, T)> = vec![];
        let mut tau = tau_r;
        for _ in 0..PHASE_ITERATIONS {
            self.fits += 1;
            let g = match self.search.fit(&self.full, tau) {
                Ok((cost, g)) => {
                    visited.push((tau, cost));
                    g
                }
                Err(e) => {
                    self.first_error.get_or_insert(e);
                    break;
                }
            };
            let ratio: Vec<Complex<T>> = h
                .iter()
                .zip(omega)
                .zip(&g)
                .map(|((h, w), g)| *h * delay_factor(*w, tau).conj() / *g)
                .collect();
            let Some(slope) = self.search.residual_slope(&ratio, Some(&g)) else {
                break;
            };
            let next = self.model.clamp(tau - slope);
            let moved = Float::abs(next - tau);
            tau = next;
            if moved < self.step / T::lit(8.0) {
                break;
            }
        }
        best(&visited).map_or(tau, |b| b.0)
    }

    /// h = 4(p_M/2 + 2): the scan reaches hδ above τ_r and 2hδ below.
    fn scan_half_width(&self) -> usize {
        4 * (ModelStructure::<T>::n_params(self.model.inner()) / 2 + 2)
    }

    /// Step 4, the candidates of the scan: τ_r + jδ over |j| ≤ 4(p_M/2 + 2), twice as far
    /// below τ_r as above (the group delay of G_M biases τ_r upwards); with bounds, [lo, hi]
    /// when that is no wider (at most [`MAX_SCAN`] candidates), else the candidates
    /// clamped into the bounds.
    fn scan_grid(&self, tau_r: T) -> Vec<T> {
        let step = self.step;
        let half = self.scan_half_width();
        let mut grid: Vec<T> = (0..=3 * half)
            .map(|j| tau_r + step * (T::from_usize_lossy(j) - T::from_usize_lossy(2 * half)))
            .collect();
        if let Some((lo, hi)) = self.model.bounds() {
            let (lo, hi) = (T::lit(lo), T::lit(hi));
            let width = hi - lo;
            if width <= step * T::from_usize_lossy(3 * half) {
                let n = Float::min(Float::ceil(width / step), T::from_usize_lossy(MAX_SCAN - 1))
                    .to_f64_lossless() as usize;
                let n = n.max(1);
                grid = (0..=n)
                    .map(|j| lo + width * T::from_usize_lossy(j) / T::from_usize_lossy(n))
                    .collect();
            } else {
                for t in grid.iter_mut() {
                    *t = self.model.clamp(*t);
                }
                grid.dedup_by(|a, b| Float::abs(*a - *b) < step / T::lit(4.0));
            }
        }
        grid
    }

    /// Step 4: the screening fit at each delay of `grid`; returns (τ, V(τ)) of those with
    /// a finite cost, in the order of `grid`.
    fn screen(&mut self, grid: Vec<T>) -> Vec<(T, T)> {
        let mut scan: Vec<(T, T)> = vec![];
        let n = grid.len();
        for (i, t) in grid.into_iter().enumerate() {
            if crate::solver::work::spent() {
                break;
            }
            if i % 32 == 0 {
                crate::progress::report(|| format!("delay search: candidate {} of {n}", i + 1));
            }
            self.fits += 1;
            match self.search.fit(&self.screen, t) {
                Ok((cost, _)) if Float::is_finite(cost) => scan.push((t, cost)),
                Ok(_) => {}
                Err(e) => {
                    self.first_error.get_or_insert(e);
                }
            }
        }
        scan
    }

    /// Step 5, the candidates to refine: `phase_slope`, then the local minima of `scan`
    /// by increasing cost, each at least δ/2 from those before, [`REFINED_MINIMA`] at most.
    fn candidates(&self, phase_slope: T, scan: &[(T, T)]) -> Vec<T> {
        let mut candidates: Vec<T> = vec![phase_slope];
        for (t, _) in local_minima(scan) {
            if candidates.len() > REFINED_MINIMA {
                break;
            }
            if candidates
                .iter()
                .all(|c| Float::abs(*c - t) >= self.step / T::lit(2.0))
            {
                candidates.push(t);
            }
        }
        // the phase-slope estimate is refined before the scan
        candidates.remove(0);
        candidates
    }

    /// Step 5: refines the `candidates` in turn until one reaches the threshold.
    fn refine_candidates(&mut self, candidates: Vec<T>) {
        for t in candidates {
            self.refine(t);
            if self.done() {
                break;
            }
        }
    }

    /// Step 6: unless the threshold is reached, refines the delays ±1 and ±2 sample periods
    /// from the best refined delay τ_b — the data's sample time T_s when they have one, else
    /// π/ω_max — and, with a sample time, the whole number of samples nearest to τ_b and
    /// ±1, ±2 samples from it (a delay of whole samples is exact for a discrete model),
    /// until one reaches the threshold. A delay wrong by one sample (half a period of the
    /// top frequency) is the commonest local minimum of discrete models. A start within δ/2
    /// of a refined delay is skipped when that delay's cost is already the best: a
    /// refinement that ended in a worse local minimum does not hide its neighbourhood.
    fn refine_sample_multiples(&mut self) {
        let Some((b, best_cost)) = best(&self.refined).filter(|_| !self.done()) else {
            return;
        };
        let ts = self.data.ts();
        let sample = ts.unwrap_or(T::lit(4.0) * self.step);
        let mut starts: Vec<T> = Vec::with_capacity(SAMPLE_MULTIPLES);
        starts.extend(
            [-2.0, -1.0, 1.0, 2.0]
                .iter()
                .map(|k| b + sample * T::lit(*k)),
        );
        if let Some(ts) = ts {
            let whole = Float::round(b / ts) * ts;
            starts.extend(
                [0.0, -1.0, 1.0, -2.0, 2.0]
                    .iter()
                    .map(|k| whole + ts * T::lit(*k)),
            );
        }
        let step = self.step;
        self.refine_starts(starts, |refined, t| {
            refined
                .iter()
                .any(|(r, c)| Float::abs(*r - t) < step / T::lit(2.0) && *c <= best_cost)
        });
    }

    /// Refines each of `starts` in turn (clamped into the bounds) until the threshold is
    /// reached, skipping a start within δ/8 of one tried before or `covered` by the
    /// refined (τ, cost) so far.
    fn refine_starts(&mut self, starts: Vec<T>, covered: impl Fn(&[(T, T)], T) -> bool) {
        let mut tried: Vec<T> = Vec::with_capacity(starts.len());
        for t in starts {
            let t = self.model.clamp(t);
            if covered(&self.refined, t)
                || tried
                    .iter()
                    .any(|r| Float::abs(*r - t) < self.step / T::lit(8.0))
            {
                continue;
            }
            tried.push(t);
            self.refine(t);
            if self.done() {
                break;
            }
        }
    }

    /// Step 7: unless the threshold is reached, refines the delays between minima: the
    /// midpoint of the two lowest local minima of the screening `scan`, then the
    /// midpoint and quarter points between the best refined delay and its nearest refined
    /// neighbour on each side (at least δ/2 and at most 8δ away), until one reaches the
    /// threshold. A rational model absorbs a small delay error on either side of the true
    /// delay (zeros in the right or left half plane): the ML cost then has a local minimum
    /// on each side, and the narrow global one between them is missed by refinements that
    /// start at the flanks.
    fn refine_between(&mut self, scan: &[(T, T)]) {
        if self.done() {
            return;
        }
        let step = self.step;
        let apart = |a: T, b: T| {
            let d = Float::abs(a - b);
            d >= step / T::lit(2.0) && d <= step * T::lit(8.0)
        };
        let mut starts: Vec<T> = Vec::with_capacity(BETWEEN_STARTS);
        let minima = local_minima(scan);
        if let Some(a) = minima.first().map(|m| m.0)
            && let Some(b) = minima.iter().skip(1).map(|m| m.0).find(|b| apart(a, *b))
        {
            starts.push((a + b) / T::lit(2.0));
        }
        if let Some((a, _)) = best(&self.refined) {
            let neighbours = [true, false].map(|below| {
                self.refined
                    .iter()
                    .filter(|(t, c)| Float::is_finite(*c) && (*t < a) == below && apart(a, *t))
                    .map(|(t, _)| *t)
                    .min_by(|x, y| {
                        Float::abs(*x - a)
                            .partial_cmp(&Float::abs(*y - a))
                            .unwrap_or(std::cmp::Ordering::Equal)
                    })
            });
            for b in neighbours.into_iter().flatten() {
                starts.extend([0.5, 0.25, 0.75].iter().map(|f| a + (b - a) * T::lit(*f)));
            }
        }
        self.refine_starts(starts, |_, _| false);
    }

    /// Whether the best refined delay reaches the threshold, or the work budget
    /// ([`crate::solver::work`]) is spent with a delay refined.
    fn done(&self) -> bool {
        best(&self.refined).is_some_and(|b| b.1 <= self.stop_cost() || crate::solver::work::spent())
    }

    /// The cost at which the search stops: [`stopping_cost`], or the noise level estimated
    /// from the residuals of the best round itself when that is higher. Only the best
    /// round's own estimate counts: a worse fit's residuals (a wrong delay's error
    /// varying from line to line near a resonance) overstate the noise.
    fn stop_cost(&self) -> T {
        match self.best_round.as_ref().and_then(|b| b.level) {
            Some(level) => Float::max(self.threshold, level),
            None => self.threshold,
        }
    }

    /// Refines the candidate delay `t` by up to [`CANDIDATE_ROUNDS`] rounds
    /// ([`Self::refine_round`]), each from the ML delay of the one before, stopping at the
    /// threshold or at a failure, and records the (τ, cost) of lowest ML cost.
    fn refine(&mut self, t: T) {
        self.refine_rounds(t, CANDIDATE_ROUNDS);
    }

    /// [`Self::refine`] with at most `rounds` rounds.
    fn refine_rounds(&mut self, t: T, rounds: usize) {
        let mut t = t;
        let mut last: Option<(T, T)> = None;
        for round in 0..rounds.min(CANDIDATE_ROUNDS) {
            let Some((tau, cost)) = self.round(t, round) else {
                break;
            };
            if last.is_none_or(|l| cost < l.1) {
                last = Some((tau, cost));
            }
            t = tau;
            if cost <= self.stop_cost() {
                break;
            }
        }
        self.refined.extend(last);
    }

    /// Round `round` of a refinement from `t` ([`Self::refine_round`]): the ML delay
    /// (clamped into the bounds) and cost, `None` when the round failed or diverged. An ML
    /// delay outside the bounds is no candidate — its cost is lowered by leaving them, and
    /// the joint ML from it would leave them again — so its cost counts as infinite and
    /// its round is kept apart ([`Self::finish`]). A round already made from the same
    /// delay (starts clamped to a bound coincide) is looked up, not repeated.
    fn round(&mut self, t: T, round: usize) -> Option<(T, T)> {
        if let Some((_, _, done)) = self.rounds.iter().find(|(r, s, _)| *r == round && *s == t) {
            return *done;
        }
        self.fits += 1;
        let outcome = match self.refine_round(t, round) {
            Ok(made) if Float::is_finite(made.solution.theta[made.solution.theta.len() - 1]) => {
                let sol = &made.solution;
                let tau = sol.theta[sol.theta.len() - 1];
                let inside = self.model.clamp(tau) == tau;
                let outcome = Some((
                    self.model.clamp(tau),
                    if inside { sol.cost } else { T::infinity() },
                ));
                let best = if inside {
                    &mut self.best_round
                } else {
                    &mut self.best_outside
                };
                if best.as_ref().is_none_or(|b| sol.cost < b.solution.cost) {
                    *best = Some(made);
                }
                outcome
            }
            Ok(_) => None,
            Err(e) => {
                self.first_error.get_or_insert(e);
                None
            }
        };
        self.rounds.push((round, t, outcome));
        outcome
    }

    /// One round of a refinement at τ = `t`: the delay-free fit at `t` (round 0: in full;
    /// round 1: Levy alone; round 2: in full on the lower half of the band), then ML on the
    /// delayed model from [θ_M, t]. A second round from the ML delay has a better inner
    /// start when `t` was a fraction of δ off. Without noise weights, the noise-level cost
    /// of the fit's residuals ([`noise_level_cost`]) comes with the solution.
    fn refine_round(&self, t: T, round: usize) -> Result<BestRound<T, M>> {
        let inner_pipeline = if round == 1 { &self.levy } else { &self.full };
        let (inner, theta, inner_stages) = self.search.fit_full(inner_pipeline, t, round == 2)?;
        let model = Delayed {
            inner,
            bounds: self.model.bounds,
        };
        let start = Delayed::<M>::theta(&theta, t);
        let problem = self.ml.problem(&model, self.data)?;
        let fast = GramLevenbergMarquardt::from(self.lm);
        let solution = super::chain::ml_solve(&fast, &self.lm, &problem, &start)?;
        drop(problem);
        // without noise weights the noise level is estimated from the residuals
        let level = if self.search.weights.is_none() {
            noise_level_cost(&model, &solution.theta, self.data)
        } else {
            None
        };
        Ok(BestRound {
            model,
            solution,
            level,
            inner_stages,
        })
    }

    /// The refined delay of lowest ML cost with the round that reached it, or the first
    /// failure when none was refined.
    fn finish(self, phase_slope: T) -> Result<(DelayStart<T>, BestRound<T, M>)> {
        let stop = self.stop_cost();
        let start = |tau, cost| DelayStart {
            tau,
            cost,
            phase_slope,
            fits: self.fits,
        };
        // a round that left the bounds at a lower cost than every one within them, none of
        // which reached the stopping cost: the delay lies outside the bounds, which its
        // joint ML then reports
        let outside = match (&self.best_round, &self.best_outside) {
            (Some(b), Some(o)) => b.solution.cost > stop && o.solution.cost < b.solution.cost,
            (None, Some(_)) => true,
            _ => false,
        };
        match (best(&self.refined), self.best_round, self.best_outside) {
            (_, _, Some(round)) if outside => {
                let sol = &round.solution;
                let tau = self.model.clamp(sol.theta[sol.theta.len() - 1]);
                Ok((start(tau, sol.cost), round))
            }
            (Some((tau, cost)), Some(round), _) => Ok((start(tau, cost), round)),
            _ => Err(self.first_error.unwrap_or(FdidError::Numerical {
                what: "delay-free fits of the delay search".into(),
            })),
        }
    }
}

/// The visited (τ, cost) with the lowest finite cost.
fn best<T: Real>(visited: &[(T, T)]) -> Option<(T, T)> {
    visited
        .iter()
        .copied()
        .filter(|(_, c)| Float::is_finite(*c))
        .min_by(|a, b| a.1.partial_cmp(&b.1).unwrap_or(std::cmp::Ordering::Equal))
}

/// Every ⌈N/`most`⌉-th line of `data` (with its line weight), counted down from the last
/// so that the highest line stays; `None` when the data have at most `most` lines. For
/// the Levy profile: its resolution in τ is set by the highest frequency, which stays,
/// and the kept lines' spacing (⌈N/most⌉ times the data's) puts the period in τ of evenly
/// spaced lines (2π over that spacing, more than `most`·8δ) far beyond the scan.
fn every_nth_line<T: Real>(
    data: &FrequencyData<T>,
    weights: Option<&[T]>,
    most: usize,
) -> Option<(FrequencyData<T>, Option<Vec<T>>)> {
    let (fewer, keep) = data.every_nth_line(most)?;
    let weights = weights.map(|w| {
        w.iter()
            .zip(&keep)
            .filter(|(_, k)| **k)
            .map(|(w, _)| *w)
            .collect()
    });
    Some((fewer, weights))
}

/// What the delay search needs at every candidate.
struct Search<'a, T: Real, M> {
    model: &'a M,
    data: &'a FrequencyData<T>,
    phase_weight: &'a [T],
    /// The pipeline's line weights (`None`: unweighted).
    weights: Option<&'a [T]>,
}

impl<T: Real, M: FurtherStarts<T>> Search<'_, T, M> {
    /// The linear stages of `pipeline` ([`Pipeline::linear_start`]) for the inner model on
    /// the data with τ removed (on the lower half of the band with `lower_half`, when that
    /// leaves enough lines): the model, θ_M and the stages.
    fn fit_full(&self, pipeline: &Pipeline, tau: T, lower_half: bool) -> Result<InnerStart<T, M>> {
        let mut compensated = remove_delay(self.data, tau)?;
        if lower_half {
            let w_max = max_frequency(self.data.omega());
            let band = compensated.band(T::zero(), w_max / T::lit(2.0))?;
            if band.len() >= self.model.n_params() + 2 {
                compensated = band;
            }
        }
        pipeline.linear_start(self.model, &compensated)
    }

    /// The linear stages of `pipeline` for the inner model on the data with τ removed:
    /// the output-error cost V(τ) of the delayed model and G_M on the lines.
    fn fit(&self, pipeline: &Pipeline, tau: T) -> Result<(T, Vec<Complex<T>>)> {
        let compensated = remove_delay(self.data, tau)?;
        let (model, theta, _) = pipeline.linear_start(self.model, &compensated)?;
        let mut out = Output::new(compensated.len(), model.n_params());
        let cost = output_error_cost_in(&mut out, &model, &theta, &compensated, self.weights);
        Ok((cost, out.g))
    }

    /// The slope of the weighted linear regression of the unwrapped phase of `ratio`
    /// against ω, over the lines where `ratio` (and `g`, when given) is finite and non-zero.
    fn residual_slope(&self, ratio: &[Complex<T>], g: Option<&[Complex<T>]>) -> Option<T> {
        let omega = self.data.omega();
        let usable = |k: usize| {
            let r = ratio[k];
            let ok = Float::is_finite(r.re) && Float::is_finite(r.im) && r.norm_sqr() > T::zero();
            ok && g.is_none_or(|g| g[k].norm_sqr() > T::zero())
        };
        let two_pi = T::two_pi();
        let mut phase = vec![T::zero(); ratio.len()];
        let mut prev: Option<T> = None;
        let mut unwrapped = T::zero();
        for k in 0..ratio.len() {
            if !usable(k) {
                continue;
            }
            let a = ratio[k].arg();
            unwrapped = match prev {
                None => a,
                Some(p) => {
                    let mut d = a - p;
                    d = d - two_pi * Float::round(d / two_pi);
                    unwrapped + d
                }
            };
            prev = Some(a);
            phase[k] = unwrapped;
        }
        let (mut sw, mut sx, mut sy) = (T::zero(), T::zero(), T::zero());
        for k in (0..ratio.len()).filter(|k| usable(*k)) {
            let w = self.phase_weight[k];
            sw += w;
            sx += w * omega[k];
            sy += w * phase[k];
        }
        if !(sw > T::zero()) {
            return None;
        }
        let (mx, my) = (sx / sw, sy / sw);
        let (mut sxx, mut sxy) = (T::zero(), T::zero());
        for k in (0..ratio.len()).filter(|k| usable(*k)) {
            let w = self.phase_weight[k];
            let dx = omega[k] - mx;
            sxx += w * dx * dx;
            sxy += w * dx * (phase[k] - my);
        }
        let slope = sxy / sxx;
        if Float::is_finite(slope) {
            Some(slope)
        } else {
            None
        }
    }
}

impl<M: Clone> Delayed<M> {
    /// Fits the delayed model end to end:
    /// 1. τ₀ from [`delay_start`] (phase slope and candidate search, within the bounds),
    ///    whose best refinement round gives [θ_M, τ₀]: the inner model fitted by Levy → SK
    ///    (or Levy) to the delay-compensated data Y e^{iωτ₀} ([`remove_delay`]; for a
    ///    partial-fraction model, the basis relocated to its poles), then refined by an ML
    ///    of the delayed model with a small evaluation budget;
    /// 2. output-error maximum likelihood ([`MaximumLikelihood`], McKelvey eq. 23, with the
    ///    pipeline's weighting) of the full model G_M(θ_M) e^{−iωτ} on the original data by
    ///    Levenberg–Marquardt (the pipeline's, or the default when it has none) from that
    ///    round's [θ_M, τ], continued to convergence.
    ///
    /// The statistics are those of [`Fit::new`] with the pipeline's weighting; the stages
    /// are `delay` (θ = \[τ₀\], the search's cost, its number of fits), the stages of the
    /// best round's delay-free fit on the compensated data (`levy`, `sk`), and
    /// `ml-delayed`.
    ///
    /// # Errors
    /// As [`delay_start`] and [`Pipeline::fit`]; [`FdidError::InvalidArgument`] naming τ̂
    /// when the fitted delay lies outside the bounds.
    pub fn fit<T: Real>(
        &self,
        pipeline: &Pipeline,
        data: &FrequencyData<T>,
    ) -> Result<Fit<T, Delayed<M>>>
    where
        M: FurtherStarts<T>,
    {
        let (start, best) = search_delay(pipeline, self, data)?;
        let tau0 = start.tau;
        let mut stages = vec![Stage::new(
            StageKind::Delay,
            Solution {
                theta: vec![tau0],
                cost: start.cost,
                iterations: start.fits,
                termination: Termination::Converged,
            },
        )];
        stages.extend(best.inner_stages);
        joint_ml(best.model, best.solution.theta, stages, pipeline, data)
    }

    /// Fits the delayed model from the delay `tau0` (clamped into the bounds) without a
    /// search: the inner model by `pipeline`'s linear stages on the delay-compensated data
    /// Y e^{iωτ₀} ([`remove_delay`], [`Pipeline::linear_start`]), then the joint ML of
    /// [`Delayed::fit`]'s step 2 from [θ_M, τ₀]. For data whose delay is known to lie
    /// near τ₀ — a segment of a record whose whole fit gave τ₀ — at the cost of one fit
    /// with the delay known; the stages are those of the linear fit and `ml-delayed`.
    ///
    /// # Errors
    /// As [`Pipeline::fit`]; [`FdidError::InvalidArgument`] naming τ̂ when the fitted
    /// delay lies outside the bounds.
    pub(crate) fn fit_from_delay<T: Real>(
        &self,
        pipeline: &Pipeline,
        data: &FrequencyData<T>,
        tau0: T,
    ) -> Result<Fit<T, Delayed<M>>>
    where
        M: FurtherStarts<T>,
    {
        let tau0 = self.clamp(tau0);
        let compensated = remove_delay(data, tau0)?;
        let (inner, theta, stages) = pipeline.linear_start(&self.inner, &compensated)?;
        let model = Delayed {
            inner,
            bounds: self.bounds,
        };
        joint_ml(
            model,
            Delayed::<M>::theta(&theta, tau0),
            stages,
            pipeline,
            data,
        )
    }
}

/// The joint output-error ML of a delayed model from `theta0` ([θ_M, τ], τ clamped into
/// the bounds; with `pipeline.stable` the start stabilised and the ML constrained), by
/// the guarded normal-equation steps then MINPACK's LM, appended to `stages` as
/// `ml-delayed`, with the statistics of [`Fit::new`].
fn joint_ml<T: Real, M: FurtherStarts<T>>(
    model: Delayed<M>,
    mut theta0: Vec<T>,
    mut stages: Vec<Stage<T>>,
    pipeline: &Pipeline,
    data: &FrequencyData<T>,
) -> Result<Fit<T, Delayed<M>>> {
    let last = theta0.len() - 1;
    theta0[last] = model.clamp(theta0[last]);
    let theta0 = super::chain::stable_start(&model, theta0, pipeline.stable)?;
    let lm = pipeline.ml.unwrap_or_default();
    let ml = MaximumLikelihood {
        weighting: pipeline.weighting,
    };
    let problem = ml.problem(&model, data)?;
    let fast = GramLevenbergMarquardt::from(lm);
    let solution =
        super::chain::ml_solve_in(&fast, &lm, &model, &problem, &theta0, pipeline.stable)?;
    drop(problem);
    let theta = solution.theta.clone();
    stages.push(Stage::new(StageKind::MlDelayed, solution));
    model.check_delay(theta[theta.len() - 1])?;
    Fit::new(model, data, theta, pipeline.weighting, stages)
}

/// Fits `model` followed by an unbounded delay τ end to end: [`Delayed::fit`] of
/// `Delayed::new(model.clone())` (McKelvey section 4, G_θ(iω)e^{−iωτ}, by eq. 23).
///
/// # Errors
/// As [`Delayed::fit`].
pub fn fit_delayed<T: Real, M: FurtherStarts<T>>(
    pipeline: &Pipeline,
    model: &M,
    data: &FrequencyData<T>,
) -> Result<Fit<T, Delayed<M>>> {
    Delayed::new(model.clone()).fit(pipeline, data)
}
