//! Several automatic starts for rational fits, and the poles a fit cannot resolve.
//!
//! The ML cost of a rational model is not convex: from its automatic start (Levy → SK,
//! with lightly damped starting poles) the chain ends in a local minimum on a fraction of
//! random high-order systems, typically with a spurious lightly damped (or unstable) pole
//! pair in place of heavily damped or real poles. [`fit_multistart`] runs the chain from
//! several starting pole sets and from a reduced higher-order fit, replaces the spurious
//! poles of the best fit, and keeps the lowest cost; [`fit_multistart_discrete`] does the
//! same in z. [`crate::Pipeline::fit`] runs these starts itself when its fit shows
//! evidence of a local minimum (see [`crate::Pipeline`]).
//! [`Fit::unresolved_poles`] names poles whose damping the frequency grid cannot determine.

use super::chain::estimate;
use super::{FurtherStarts, Pipeline};
use crate::basis::PolyBasis;
use crate::criterion::{Criterion, Levy, MaximumLikelihood, NoiseWeighting};
use crate::data::FrequencyData;
use crate::error::{FdidError, Result};
use crate::fit::{Fit, Stage, StageKind};
use crate::model::{
    Domain, EquationError, ModelStructure, Rational, log_spread_poles, positive_band,
};
use crate::scalar::{Complex, Real};
use crate::solver::LevenbergMarquardt;
use crate::validation::{lines_in_band, s_plane};
use nalgebra::{DMatrix, DVector};
use num_traits::Float;
use std::cell::Cell;

/// The starting basis poles of [`fit_multistart`] for order `na` on `omega` (rad/s), with
/// ω_lo, ω_hi the smallest positive and the largest frequency: pairs −ζωₖ ± iωₖ with ωₖ
/// log-spread over [ω_lo, ω_hi] for ζ = 0.1 and ζ = 0.5 (plus −ω_hi for odd `na`), and
/// `na` real poles −ω_lo (ω_hi/ω_lo)^((k + ½)/na).
fn starting_poles<T: Real>(na: usize, omega: &[T]) -> Vec<Vec<Complex<T>>> {
    let Some((lo, hi)) = positive_band(omega) else {
        return vec![];
    };
    let (llo, lhi) = (Float::ln(lo), Float::ln(hi));
    let mut out: Vec<Vec<Complex<T>>> = [0.1, 0.5]
        .iter()
        .map(|zeta| log_spread_poles(na, lo, hi, T::lit(*zeta)))
        .collect();
    out.push(
        (0..na)
            .map(|k| {
                let f = (T::from_usize_lossy(k) + T::lit(0.5)) / T::from_usize_lossy(na);
                Complex::new(-Float::exp(llo + (lhi - llo) * f), T::zero())
            })
            .collect(),
    );
    out
}

/// Every way of dropping one conjugate pair or two real poles from `poles` (closed under
/// conjugation), as basis poles (upper half-plane and real, reflected into the left
/// half-plane).
fn reduced_poles<T: Real>(poles: &[Complex<T>]) -> Vec<Vec<Complex<T>>> {
    let stable = |q: Complex<T>| {
        let re = -Float::abs(q.re);
        let re = if re == T::zero() {
            -T::default_epsilon()
        } else {
            re
        };
        Complex::new(re, q.im)
    };
    let pairs: Vec<Complex<T>> = poles.iter().copied().filter(|q| q.im > T::zero()).collect();
    let real: Vec<Complex<T>> = poles
        .iter()
        .copied()
        .filter(|q| q.im == T::zero())
        .collect();
    let mut out = vec![];
    for i in 0..pairs.len() {
        let mut b: Vec<Complex<T>> = pairs
            .iter()
            .enumerate()
            .filter(|(k, _)| *k != i)
            .map(|(_, q)| stable(*q))
            .collect();
        b.extend(real.iter().map(|q| stable(*q)));
        out.push(b);
    }
    for i in 0..real.len() {
        for j in i + 1..real.len() {
            let mut b: Vec<Complex<T>> = pairs.iter().map(|q| stable(*q)).collect();
            b.extend(
                real.iter()
                    .enumerate()
                    .filter(|(k, _)| *k != i && *k != j)
                    .map(|(_, q)| stable(*q)),
            );
            out.push(b);
        }
    }
    out
}

/// Fits a continuous-time partial-fraction model of orders (`na`, `nb`), `nb ≤ na`, with
/// `pipeline` from several starts and returns the fit of lowest cost V:
/// - four starting pole sets — [`Rational::continuous`]'s lightly damped pairs
///   (ζ = 0.01), pairs with ζ = 0.1 and ζ = 0.5, and real poles, all log-spread over the
///   data's band — each followed by the whole chain (Levy → SK → ML);
/// - order reduction: the chain at orders (na + 2, nb + 2), then, for every way of
///   dropping one pole pair or two real poles of that fit, a Levy solve in the basis of
///   the remaining poles and ML from it;
/// - spurious poles: when the best fit so far has unstable poles or poles the data cannot
///   resolve, starts that replace them — by damped pairs (ζ = 0.05, 0.3, 0.7) at their
///   frequencies, by two real poles, or by damped pairs moved into the largest gaps
///   between the other poles — each followed by the chain and by Levy → ML (twice at most,
///   while the cost falls);
/// - resonances: a partial-fraction basis at the peaks of the nonparametric FRF |Y/U|
///   (the most prominent local maxima, damping from their half-power
///   bands), followed by the chain and by Levy → ML;
/// - relocation: every pole (pair) of the best fit in turn moved to each of ten
///   frequencies log-spread over the band (pairs with ζ = 0.02 and ζ = 0.3, or a real
///   pole), the others kept; a Levy solve and a short ML rank these starts and ML goes on
///   from the three best (twice at most, while the cost falls);
/// - when the best fit's ML stopped at its cap, ML again from it.
///
/// With [`Pipeline::stable`] every start is stable and only stable fits are kept.
/// About twenty times the work of one chain. [`Pipeline::fit`] runs these starts itself (all
/// but its own automatic one) when its fit shows evidence of a local minimum (see
/// [`Pipeline`]); here they always run, and the starts use the chain without them. On
/// random stable systems of order ≤ 10 at 40 dB SNR this reaches the best optimum found
/// far more often than the chain from its automatic start alone (see docs/testing.md,
/// "Numerical stress and optimisation robustness", for the figures).
///
/// # Errors
/// `na = 0` or `nb > na`; when every start fails, the error of the first.
pub fn fit_multistart<T: Real>(
    pipeline: &Pipeline,
    na: usize,
    nb: usize,
    data: &FrequencyData<T>,
) -> Result<Fit<T, Rational<T>>> {
    if na == 0 || nb > na {
        return Err(FdidError::InvalidArgument {
            name: "nb",
            value: format!("{nb} (na = {na})"),
            reason: "multiple starts need a partial-fraction model: na ≥ 1 and nb ≤ na".into(),
        });
    }
    let model = Rational::continuous(na, nb, data.omega())?;
    let mut search = Search::new(model.n_params(), pipeline.stable);
    search.keep(pipeline.chain(&model, data));
    search.continuous(pipeline, na, nb, data);
    search.replace_spurious(pipeline, data);
    search.relocate_each(pipeline, data);
    search.polish(pipeline, data);
    search.finish()
}

/// The lowest-cost fit of several starts, and the first error.
struct Search<T: Real> {
    /// Number of parameters of the model asked for: a start's fit of another size (a
    /// basis that lost or gained a pole) is not kept.
    n_params: usize,
    best: Option<Fit<T, Rational<T>>>,
    first_error: Option<FdidError>,
    /// Keep stable fits only, and constrain the ML of the discrete and polishing starts
    /// ([`Pipeline::stable`]).
    stable: bool,
}

impl<T: Real> Search<T> {
    fn new(n_params: usize, stable: bool) -> Self {
        Self {
            n_params,
            best: None,
            first_error: None,
            stable,
        }
    }

    /// A fit of the size asked for with a finite θ and cost (and stable when asked for).
    fn valid(&self, f: &Fit<T, Rational<T>>) -> bool {
        f.theta().len() == self.n_params
            && f.theta().iter().all(|v| Float::is_finite(*v))
            && Float::is_finite(f.cost())
            && (!self.stable || f.model().is_stable(f.theta()).unwrap_or(false))
    }

    /// Replaces the best fit by `f` when `f` is valid and of lower cost.
    fn offer(&mut self, f: Fit<T, Rational<T>>) {
        if self.valid(&f) && self.best.as_ref().is_none_or(|b| f.cost() < b.cost()) {
            self.best = Some(f);
        }
    }

    fn keep(&mut self, fit: Result<Fit<T, Rational<T>>>) {
        match fit {
            Ok(f) => self.offer(f),
            Err(e) => {
                self.first_error.get_or_insert(e);
            }
        }
    }

    /// When the best fit's last stage stopped at its iteration cap, ML again from it (at
    /// most twice), keeping the result while it lowers the cost.
    fn polish(&mut self, pipeline: &Pipeline, data: &FrequencyData<T>) {
        let Some(lm) = pipeline.ml else {
            return;
        };
        let ml = MaximumLikelihood {
            weighting: pipeline.weighting,
        };
        for _ in 0..2 {
            let Some(b) = self.best.as_ref() else {
                return;
            };
            if b.stages().last().is_none_or(|s| s.solution.converged()) {
                return;
            }
            let sol = ml.problem(b.model(), data).and_then(|problem| {
                super::chain::lm_solve_in(&lm, b.model(), &problem, b.theta(), self.stable)
            });
            let Ok(sol) = sol else {
                return;
            };
            if !(sol.cost < b.cost()) {
                return;
            }
            let mut stages = b.stages().to_vec();
            stages.push(Stage::new(StageKind::MlPolish, sol.clone()));
            match Fit::new(
                b.model().clone(),
                data,
                sol.theta,
                pipeline.weighting,
                stages,
            ) {
                Ok(f) if self.valid(&f) => self.best = Some(f),
                _ => return,
            }
        }
    }

    /// Starts that replace the best fit's spurious poles — unstable ones and those the
    /// data cannot resolve ([`Fit::unresolved_poles`]) — keeping the others (reflected
    /// into the stable region): with s = p (continuous time) or s = ln(p)/Ts, |s| = ω, a
    /// spurious pair becomes a pair −ζω ± iω√(1 − ζ²) for ζ = 0.3 and ζ = 0.7, or two
    /// real poles −ω/2 and −2ω; a spurious real pole becomes −ω. Continuous time: the chain
    /// (Levy → SK → ML) and Levy → ML in each such basis; discrete time: the start of
    /// [`discrete_start`], then ML. Repeated (twice at most) while it lowers the cost and
    /// the best fit has spurious poles.
    fn replace_spurious(&mut self, pipeline: &Pipeline, data: &FrequencyData<T>) {
        let Some(discrete_ml) = DiscreteMl::new(pipeline, data) else {
            return;
        };
        for _ in 0..2 {
            let Some(b) = self.best.as_ref() else {
                return;
            };
            let cost = b.cost();
            let (na, nb) = (b.model().na(), b.model().nb());
            let Some(spurious) = SpuriousPoles::of(b, data) else {
                return;
            };
            match spurious.domain {
                Domain::Continuous => self.replaced_continuous(pipeline, &spurious, nb, data),
                Domain::Discrete { ts } => {
                    let Ok(model) = Rational::discrete(na, nb, ts) else {
                        return;
                    };
                    for k in 0..REPLACEMENT_VARIANTS {
                        let poles = spurious.z_poles(k, ts);
                        self.offer_discrete(&discrete_ml, &model, &poles, StageKind::MlReplaced);
                    }
                }
            }
            if !self.best.as_ref().is_some_and(|b| b.cost() < cost) {
                return;
            }
        }
    }

    /// The continuous-time starts of [`Self::replace_spurious`]: the chain and Levy → ML
    /// in the basis of each variant of the replaced poles, with `nb` zeros.
    fn replaced_continuous(
        &mut self,
        pipeline: &Pipeline,
        spurious: &SpuriousPoles<T>,
        nb: usize,
        data: &FrequencyData<T>,
    ) {
        let linear_ml = Pipeline {
            sk: None,
            ..*pipeline
        };
        for k in 0..REPLACEMENT_VARIANTS {
            if let Ok(m) = Rational::partial_fractions(spurious.basis(k), nb) {
                self.keep(pipeline.chain(&m, data));
                self.keep(linear_ml.chain(&m, data));
            }
        }
    }

    /// Relocation starts (denominator order [`RELOCATION_ORDER`] or more): every pole of
    /// the best fit in turn — a pair, or a real pole — moved to each of
    /// [`RELOCATION_POINTS`] frequencies ωₖ log-spread over the band (as
    /// the pair s = −ζωₖ ± iωₖ√(1 − ζ²) for each ζ of [`RELOCATION_DAMPING`], or as the real
    /// pole s = −ωₖ; z = exp(s Ts) in discrete time, below the Nyquist frequency), the
    /// others kept. Continuous time: a Levy solve in the partial-fraction basis of those
    /// poles (the others reflected into the left half-plane); discrete time: the start of
    /// [`discrete_start`]. A short ML ([`RELOCATION_SCREEN`] steps) from each ranks the
    /// starts, and full ML goes on from the [`RELOCATION_KEEP`] lowest. Repeated (twice at
    /// most) while it lowers the cost.
    ///
    /// The minima this escapes differ from the optimum in where one pole (pair) sits: a
    /// heavily damped pair traded for a lightly damped one, or a pole–zero pair that
    /// absorbs a noise feature at another frequency. A fit that gains a pole a single line
    /// determines is not kept unless it stays flagged ([`hides_thin_pole`]): a sharp
    /// resonance on one noisy line may lower the cost without describing the system, and
    /// no check would name it.
    fn relocate_each(&mut self, pipeline: &Pipeline, data: &FrequencyData<T>) {
        if NO_RELOCATION.get() {
            return;
        }
        let Some(lm) = pipeline.ml else {
            return;
        };
        let Some((lo, hi)) = positive_band(data.omega()) else {
            return;
        };
        let Ok(weights) = pipeline.weighting.weights(data) else {
            return;
        };
        let ml = MaximumLikelihood {
            weighting: pipeline.weighting,
        };
        let levy = Levy {
            weighting: pipeline.weighting,
        };
        // the short ML: a few Gram steps, or (when their Gram matrix is refused) the
        // crate's LM with the least patience
        let short_lm = LevenbergMarquardt { patience: 1, ..lm };
        let screen = crate::solver::GramLevenbergMarquardt {
            settings: lm,
            max_iterations: RELOCATION_SCREEN,
        };
        let fast = crate::solver::GramLevenbergMarquardt::from(lm);
        // the s-plane poles of the fit before any relocation: a pole near none of them is
        // new to every round
        let Some((Ok(first), domain)) = self.best.as_ref().map(|b| (b.poles(), b.model().domain()))
        else {
            return;
        };
        let before: Vec<Complex<T>> = first.iter().map(|p| s_plane(domain, *p)).collect();
        for _ in 0..2 {
            let Some(b) = self.best.as_ref() else {
                return;
            };
            let (cost, nb, domain) = (b.cost(), b.model().nb(), b.model().domain());
            if b.model().na() < RELOCATION_ORDER {
                return;
            }
            let hi = match domain {
                Domain::Continuous => hi,
                Domain::Discrete { ts } => Float::min(hi, T::lit(0.99 * std::f64::consts::PI) / ts),
            };
            let Ok(poles) = b.poles() else {
                return;
            };
            let reps: Vec<Complex<T>> = poles.into_iter().filter(|p| p.im >= T::zero()).collect();
            // the start with the j-th pole replaced by `q` (s-plane; a pair by its upper
            // member): the model and θ
            let start = |j: usize, q: Complex<T>| -> Option<(Rational<T>, Vec<T>)> {
                let (model, theta) = match domain {
                    Domain::Continuous => {
                        let mut basis: Vec<Complex<T>> = reps
                            .iter()
                            .map(|p| {
                                let re = Float::max(Float::abs(p.re), T::default_epsilon());
                                Complex::new(-re, p.im)
                            })
                            .collect();
                        basis[j] = q;
                        let m = Rational::partial_fractions(basis, nb).ok()?;
                        let theta = estimate(&m, data, &levy, &pipeline.linear, None)
                            .ok()?
                            .theta;
                        (m, theta)
                    }
                    Domain::Discrete { ts } => {
                        let mut z = vec![];
                        for (i, p) in reps.iter().enumerate() {
                            let p = if i == j { (q * ts).exp() } else { *p };
                            z.push(p);
                            if p.im > T::zero() {
                                z.push(p.conj());
                            }
                        }
                        let theta = discrete_start(b.model(), &z, data, weights.as_deref())?;
                        (b.model().clone(), theta)
                    }
                };
                let theta = super::chain::stable_start(&model, theta, self.stable).ok()?;
                Some((model, theta))
            };
            let mut ranked: Vec<(T, Rational<T>, Vec<T>)> = vec![];
            for (j, p) in reps.iter().enumerate() {
                for k in 0..RELOCATION_POINTS {
                    let f = (T::from_usize_lossy(k) + T::lit(0.5))
                        / T::from_usize_lossy(RELOCATION_POINTS);
                    let w = lo * Float::powf(hi / lo, f);
                    let moved: Vec<Complex<T>> = if p.im == T::zero() {
                        vec![Complex::new(-w, T::zero())]
                    } else {
                        RELOCATION_DAMPING
                            .iter()
                            .map(|z| {
                                let z = T::lit(*z);
                                Complex::new(-z * w, w * Float::sqrt(T::one() - z * z))
                            })
                            .collect()
                    };
                    for q in moved {
                        let Some((m, theta)) = start(j, q) else {
                            continue;
                        };
                        let short = ml.problem(&m, data).and_then(|problem| {
                            super::chain::ml_solve_in(
                                &screen,
                                &short_lm,
                                &m,
                                &problem,
                                &theta,
                                self.stable,
                            )
                        });
                        if let Ok(sol) = short
                            && Float::is_finite(sol.cost)
                        {
                            ranked.push((sol.cost, m, sol.theta));
                        }
                    }
                }
            }
            ranked.sort_by(|a, b| a.0.partial_cmp(&b.0).unwrap_or(std::cmp::Ordering::Equal));
            for (_, m, theta) in ranked.into_iter().take(RELOCATION_KEEP) {
                let Ok(problem) = ml.problem(&m, data) else {
                    continue;
                };
                let Ok(sol) =
                    super::chain::ml_solve_in(&fast, &lm, &m, &problem, &theta, self.stable)
                else {
                    continue;
                };
                if self.best.as_ref().is_none_or(|b| sol.cost < b.cost()) {
                    let stages = vec![Stage::new(StageKind::MlRelocated, sol.clone())];
                    match Fit::from_ml_problem(m.clone(), data, sol.theta, &problem, stages) {
                        Ok(f) if !hides_thin_pole(&f, &before, data.omega()) => self.offer(f),
                        _ => {}
                    }
                }
            }
            if !self.best.as_ref().is_some_and(|b| b.cost() < cost) {
                return;
            }
        }
    }

    /// ML on the discrete-time `model` from the start of [`discrete_start`] for `poles`;
    /// the fit, with one stage of kind `kind`, is offered when its cost is below the best's.
    fn offer_discrete(
        &mut self,
        ml: &DiscreteMl<'_, T>,
        model: &Rational<T>,
        poles: &[Complex<T>],
        kind: StageKind,
    ) {
        let Some(theta) = discrete_start(model, poles, ml.data, ml.weights.as_deref()) else {
            return;
        };
        let Ok(theta) = super::chain::stable_start(model, theta, self.stable) else {
            return;
        };
        let criterion = MaximumLikelihood {
            weighting: ml.weighting,
        };
        let Ok(problem) = criterion.problem(model, ml.data) else {
            return;
        };
        let fast = crate::solver::GramLevenbergMarquardt::from(ml.lm);
        let Ok(sol) =
            super::chain::ml_solve_in(&fast, &ml.lm, model, &problem, &theta, self.stable)
        else {
            return;
        };
        if self.best.as_ref().is_none_or(|b| sol.cost < b.cost()) {
            let stages = vec![Stage::new(kind, sol.clone())];
            if let Ok(f) = Fit::new(model.clone(), ml.data, sol.theta, ml.weighting, stages) {
                self.offer(f);
            }
        }
    }

    fn finish(self) -> Result<Fit<T, Rational<T>>> {
        match (self.best, self.first_error) {
            (Some(b), _) => Ok(b),
            (None, Some(e)) => Err(e),
            (None, None) => Err(FdidError::Numerical {
                what: "every start of the multistart fit".into(),
            }),
        }
    }

    /// The continuous-time starts of [`fit_multistart`] but the automatic one.
    fn continuous(&mut self, pipeline: &Pipeline, na: usize, nb: usize, data: &FrequencyData<T>) {
        for p in starting_poles(na, data.omega()) {
            self.keep(Rational::partial_fractions(p, nb).and_then(|m| pipeline.chain(&m, data)));
        }
        self.resonances(pipeline, na, nb, None, data);
        // order reduction: the fit of order na + 2 rarely misses a true pole; each way of
        // dropping two of its poles is a start (Levy in that basis, then ML)
        let linear_ml = Pipeline {
            sk: None,
            ..*pipeline
        };
        if let Ok(big) = Rational::continuous(na + 2, nb + 2, data.omega())
            .and_then(|m| pipeline.chain(&m, data))
            && let Ok(poles) = big.poles()
        {
            for start in reduced_poles(&poles) {
                if let Ok(m) = Rational::partial_fractions(start, nb) {
                    self.keep(linear_ml.chain(&m, data));
                }
            }
        }
    }

    /// The order-reduction starts of [`fit_multistart_discrete`] for `model`.
    fn discrete(
        &mut self,
        pipeline: &Pipeline,
        model: &Rational<T>,
        ts: T,
        data: &FrequencyData<T>,
    ) {
        let (na, nb) = (model.na(), model.nb());
        let Some(discrete_ml) = DiscreteMl::new(pipeline, data) else {
            return;
        };
        // (start, stage kind): the reductions of the fit at degrees na + 2, then the
        // pole sets of `starting_poles` mapped to z = exp(s Ts)
        let mut starts: Vec<(Vec<Complex<T>>, StageKind)> = vec![];
        if let Ok(big) =
            Rational::discrete(na + 2, nb + 2, ts).and_then(|m| pipeline.chain(&m, data))
            && let Ok(poles) = big.poles()
        {
            starts.extend(
                reduced_poles_z(&poles)
                    .into_iter()
                    .map(|p| (p, StageKind::MlReduced)),
            );
        }
        for set in starting_poles(na, data.omega()) {
            let mut z = vec![];
            for s in set {
                let q = (s * ts).exp();
                if s.im > T::zero() {
                    z.push(q);
                    z.push(q.conj());
                } else {
                    z.push(Complex::new(q.re, T::zero()));
                }
            }
            starts.push((z, StageKind::MlSpread));
        }
        for (start, kind) in starts {
            self.offer_discrete(&discrete_ml, model, &start, kind);
        }
        self.resonances(pipeline, na, nb, Some(ts), data);
    }

    /// The start at the resonances of the data ([`resonance_poles`]): in s, the chain and
    /// Levy → ML in a partial-fraction basis at those poles; in z (sample time `ts`), ML
    /// from the start of [`discrete_start`] at z = exp(s Ts).
    fn resonances(
        &mut self,
        pipeline: &Pipeline,
        na: usize,
        nb: usize,
        ts: Option<T>,
        data: &FrequencyData<T>,
    ) {
        let Some(poles) = resonance_poles(na, data) else {
            return;
        };
        match ts {
            None => {
                let linear_ml = Pipeline {
                    sk: None,
                    ..*pipeline
                };
                if let Ok(m) = Rational::partial_fractions(poles, nb) {
                    self.keep(pipeline.chain(&m, data));
                    self.keep(linear_ml.chain(&m, data));
                }
            }
            Some(ts) => {
                let (Some(ml), Ok(model)) = (
                    DiscreteMl::new(pipeline, data),
                    Rational::discrete(na, nb, ts),
                ) else {
                    return;
                };
                let mut z = vec![];
                for s in poles {
                    let q = (s * ts).exp();
                    if s.im > T::zero() {
                        z.push(q);
                        z.push(q.conj());
                    } else {
                        z.push(Complex::new(q.re, T::zero()));
                    }
                }
                self.offer_discrete(&ml, &model, &z, StageKind::MlSpread);
            }
        }
    }
}

/// What ML on a discrete-time model from the starts of [`discrete_start`] needs: the
/// data, the pipeline's weighting, its line weights and its ML solver.
struct DiscreteMl<'a, T: Real> {
    data: &'a FrequencyData<T>,
    weighting: NoiseWeighting,
    weights: Option<Vec<T>>,
    lm: LevenbergMarquardt,
}

impl<'a, T: Real> DiscreteMl<'a, T> {
    /// `None` when `pipeline` has no ML stage or the weights of `data` fail.
    fn new(pipeline: &Pipeline, data: &'a FrequencyData<T>) -> Option<Self> {
        let lm = pipeline.ml?;
        let weights = pipeline.weighting.weights(data).ok()?;
        Some(Self {
            data,
            weighting: pipeline.weighting,
            weights,
            lm,
        })
    }
}

thread_local! {
    /// Whether the relocation starts are switched off on this thread
    /// ([`without_relocation`]).
    static NO_RELOCATION: Cell<bool> = const { Cell::new(false) };
}

/// Restores the relocation setting of this thread when dropped (also on a panic).
struct RelocationSetting(bool);

impl Drop for RelocationSetting {
    fn drop(&mut self) {
        NO_RELOCATION.set(self.0);
    }
}

/// Runs `f` with the relocation starts of the multistart search switched off on this
/// thread (the setting before is restored afterwards): the further starts of
/// [`Pipeline::fit`] and the multistart fits then cost about half as much from order
/// [`RELOCATION_ORDER`] on, and the multistart fits reach the optimum of the 500-system
/// study less often (98.8 % instead of 99.0 %). [`crate::workflow::Workflow::run`] runs
/// its fits so: it refits many candidate models within a work budget, and with the
/// relocation the F-16 workflow of the README would exceed it, while the dryer's, the
/// robot arm's and the F-16's verdicts and final models are the same with it.
///
/// ```
/// use fdid::estimate::without_relocation;
/// assert_eq!(without_relocation(|| 2 + 2), 4);
/// ```
pub fn without_relocation<R>(f: impl FnOnce() -> R) -> R {
    with_relocation_off(true, f)
}

/// Whether the relocation starts are switched off on this thread ([`without_relocation`]).
pub(crate) fn relocation_off() -> bool {
    NO_RELOCATION.get()
}

/// Runs `f` with the relocation starts switched off on this thread when `off`, on when not
/// (the setting before is restored afterwards): the setting of [`relocation_off`] carried
/// to another thread.
pub(crate) fn with_relocation_off<R>(off: bool, f: impl FnOnce() -> R) -> R {
    let _restore = RelocationSetting(NO_RELOCATION.replace(off));
    f()
}

/// Lowest denominator order for which the relocation starts of [`fit_multistart`] and
/// [`fit_multistart_discrete`] (and so of [`Pipeline::fit`]'s further starts) run. Below it
/// the other starts already reach nearly every optimum it finds: with the relocation at
/// every order, `fit_multistart` and `fit_multistart_discrete` lowered the cost on 1 of the
/// 335 systems of order ≤ 4 among seeds 1000–1499 and 7000–7299 of the robustness study
/// (by 8·10⁻⁵ relative), while it made the dryer's `diagnose` (candidate models of orders
/// 2–4) take 40 % longer.
pub const RELOCATION_ORDER: usize = 5;

/// Frequencies, log-spread over the band, to which [`Search::relocate_each`] moves each
/// pole of the best fit.
const RELOCATION_POINTS: usize = 10;

/// Damping ratios of the pairs [`Search::relocate_each`] moves a pair to.
const RELOCATION_DAMPING: [f64; 2] = [0.02, 0.3];

/// Steps of the short ML that ranks the starts of [`Search::relocate_each`].
const RELOCATION_SCREEN: usize = 8;

/// Number of the lowest-ranked starts of [`Search::relocate_each`] that full ML goes on
/// from.
const RELOCATION_KEEP: usize = 3;

/// Whether `fit` hides a pole the data cannot determine: it has a pole that none of
/// `before` (s-plane poles) explains and that a single line of `omega` determines — with
/// s = σ + iω_p (s = ln(p)/Ts in discrete time), ω_p inside the band, exactly one line with
/// |ω_k − ω_p| ≤ |σ|, and no pole of `before` within max(|σ|, 10⁻³|s|) of s — and no pole
/// that [`Fit::unresolved_poles`] flags. One line fixes a peak's height but not its width,
/// so such a pole may fit a noise feature, and [`Fit::unresolved_poles`] (no line at all)
/// does not name it: [`Search::relocate_each`] does not keep a fit that gains one unless
/// the fit stays flagged.
fn hides_thin_pole<T: Real>(fit: &Fit<T, Rational<T>>, before: &[Complex<T>], omega: &[T]) -> bool {
    let (Ok(poles), Ok(unresolved)) = (fit.poles(), fit.unresolved_poles()) else {
        return true;
    };
    if !unresolved.is_empty() {
        return false;
    }
    let domain = fit.model().domain();
    poles.iter().filter(|p| p.im >= T::zero()).any(|p| {
        let s = s_plane(domain, *p);
        let near = Float::max(Float::abs(s.re), T::lit(1e-3) * s.norm());
        lines_in_band(s, omega) == Some(1) && !before.iter().any(|q| (*q - s).norm() <= near)
    })
}

/// Variants of the replacement of spurious poles ([`SpuriousPoles::variant`]).
const REPLACEMENT_VARIANTS: usize = 6;

/// The poles of a fit with the spurious ones marked, and the gaps where they may move.
struct SpuriousPoles<T: Real> {
    domain: Domain<T>,
    /// One member of each pair and the real poles, with the spurious ones marked.
    reps: Vec<(Complex<T>, bool)>,
    /// The gaps (in log ω) between the frequencies of the other poles and the band's
    /// ends, widest first.
    gaps: Vec<(T, T)>,
    /// Number of spurious poles.
    n_bad: usize,
}

impl<T: Real> SpuriousPoles<T> {
    /// The poles of `fit` on the band of `data`; `None` when it has no spurious pole, its
    /// poles fail, or the data have no positive band.
    fn of(fit: &Fit<T, Rational<T>>, data: &FrequencyData<T>) -> Option<Self> {
        let Ok(poles) = fit.poles() else {
            return None;
        };
        let unresolved = fit.unresolved_poles().unwrap_or_default();
        let domain = fit.model().domain();
        let reps: Vec<(Complex<T>, bool)> = poles
            .iter()
            .filter(|p| p.im >= T::zero())
            .map(|p| {
                let s = s_plane(domain, *p);
                (*p, !(s.re < T::zero()) || unresolved.contains(p))
            })
            .collect();
        if !reps.iter().any(|(_, bad)| *bad) {
            return None;
        }
        let (lo, hi) = positive_band(data.omega())?;
        let gaps = Self::gaps(domain, &reps, lo, hi);
        let n_bad = reps.iter().filter(|(_, bad)| *bad).count();
        Some(Self {
            domain,
            reps,
            gaps,
            n_bad,
        })
    }

    /// The gaps (in log ω) between the frequencies of the poles of `reps` not marked
    /// spurious (clamped into [lo, hi]) and the band's ends, widest first.
    fn gaps(domain: Domain<T>, reps: &[(Complex<T>, bool)], lo: T, hi: T) -> Vec<(T, T)> {
        let mut kept: Vec<T> = reps
            .iter()
            .filter(|(_, bad)| !bad)
            .map(|(p, _)| Float::ln(Float::min(Float::max(s_plane(domain, *p).norm(), lo), hi)))
            .collect();
        kept.push(Float::ln(lo));
        kept.push(Float::ln(hi));
        kept.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
        let mut gaps: Vec<(T, T)> = kept.windows(2).map(|w| (w[0], w[1])).collect();
        gaps.sort_by(|a, b| {
            (b.1 - b.0)
                .partial_cmp(&(a.1 - a.0))
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        gaps
    }

    /// The frequency of the `j`-th spurious pole under gap variant `k`: log-spread in the
    /// largest gap (k = 3), or in the middle of the j-th largest (k = 4).
    fn moved(&self, k: usize, j: usize) -> T {
        let (a, b) = if k == 3 {
            self.gaps[0]
        } else {
            self.gaps[std::cmp::min(j, self.gaps.len() - 1)]
        };
        let f = if k == 3 {
            (T::from_usize_lossy(j) + T::one()) / (T::from_usize_lossy(self.n_bad) + T::one())
        } else {
            T::lit(0.5)
        };
        Float::exp(a + (b - a) * f)
    }

    /// The s-plane poles of variant `k` < [`REPLACEMENT_VARIANTS`] for the `j`-th
    /// spurious pole `s` (`real` when it is real): [`replacement`] for k ∉ {3, 4}, else
    /// the pole moved into the gaps ([`Self::moved`]) with ζ = 0.5 (a pair) or real.
    fn variant(&self, s: Complex<T>, real: bool, k: usize, j: usize) -> Vec<Complex<T>> {
        if !(3..5).contains(&k) {
            return replacement(s, real, k);
        }
        let half = T::lit(0.5);
        let sqrt_half = Float::sqrt(T::lit(0.75));
        let w = self.moved(k, j);
        if real {
            vec![Complex::new(-w, T::zero())]
        } else {
            vec![Complex::new(-half * w, sqrt_half * w)]
        }
    }

    /// The continuous-time basis poles under variant `k`: the spurious poles replaced,
    /// the others reflected into the left half-plane.
    fn basis(&self, k: usize) -> Vec<Complex<T>> {
        let mut basis = vec![];
        let mut j = 0;
        for (p, bad) in &self.reps {
            if *bad {
                basis.extend(self.variant(*p, p.im == T::zero(), k, j));
                j += 1;
            } else {
                basis.push(Complex::new(-Float::abs(p.re), p.im));
            }
        }
        basis
    }

    /// The discrete-time poles (closed under conjugation) under variant `k` with sample
    /// time `ts`: the spurious poles replaced in s and mapped to z = exp(s Ts), the others
    /// kept, unstable ones reflected (z ↦ z/|z|²).
    fn z_poles(&self, k: usize, ts: T) -> Vec<Complex<T>> {
        let mut set = vec![];
        let mut j = 0;
        for (p, bad) in &self.reps {
            let new: Vec<Complex<T>> = if *bad {
                j += 1;
                self.variant(s_plane(self.domain, *p), p.im == T::zero(), k, j - 1)
                    .into_iter()
                    .map(|s| (s * ts).exp())
                    .collect()
            } else if p.norm() > T::one() {
                vec![*p / p.norm_sqr()]
            } else {
                vec![*p]
            };
            for q in new {
                if Float::abs(q.im) > T::zero() {
                    set.push(Complex::new(q.re, Float::abs(q.im)));
                    set.push(Complex::new(q.re, -Float::abs(q.im)));
                } else {
                    set.push(q);
                }
            }
        }
        set
    }
}

/// The s-plane replacement of a spurious pole s, |s| = ω, under variant `k`: a real pole
/// −ω when `real`; else a pair −ζω ± iω√(1 − ζ²) with ζ = 0.3 (k = 0), 0.7 (k = 1) or
/// 0.05 (k = 5), or two real poles −ω/2 and −2ω (other k).
fn replacement<T: Real>(s: Complex<T>, real: bool, k: usize) -> Vec<Complex<T>> {
    let w = s.norm();
    if real {
        return vec![Complex::new(-w, T::zero())];
    }
    match k {
        0 | 1 | 5 => {
            let zeta = T::lit(match k {
                0 => 0.3,
                1 => 0.7,
                _ => 0.05,
            });
            let im = w * Float::sqrt(T::one() - zeta * zeta);
            vec![Complex::new(-zeta * w, im)]
        }
        _ => vec![
            Complex::new(-w / T::lit(2.0), T::zero()),
            Complex::new(-w * T::lit(2.0), T::zero()),
        ],
    }
}

/// Fits a discrete-time model B(z⁻¹)/A(z⁻¹) of degrees (`na`, `nb`) with sample time
/// `ts` by `pipeline` from several kinds of start, returning the fit of lowest cost V:
/// - the automatic one (Levy → SK → ML);
/// - order reduction: the chain at degrees (na + 2, nb + 2), then, for every way of
///   dropping one pole pair or two real poles of that fit, A = Π(1 − pⱼz⁻¹) over the
///   remaining poles, B by weighted linear least squares with A fixed
///   (min_b Σ_k w_k² |Y_k − B(z_k)/A(z_k) U_k|²), and ML from (A, B);
/// - the three log-spread pole sets of [`fit_multistart`] (pairs with ζ = 0.1 and 0.5, real
///   poles) mapped to z = exp(s Ts), each with B as above and ML;
/// - spurious poles, relocation and a capped ML as in [`fit_multistart`], with
///   s = ln(z)/Ts (the replaced or moved poles enter A, B as above; for spurious poles the
///   others are kept with unstable ones reflected: z ↦ z/|z|²).
///
/// [`Pipeline::fit`] runs the starts but the automatic one itself when its fit shows
/// evidence of a local minimum; here they always run.
///
/// # Errors
/// `na = 0`, `nb > na + 2` or an invalid `ts`; when every start fails, the error of the
/// automatic one.
pub fn fit_multistart_discrete<T: Real>(
    pipeline: &Pipeline,
    na: usize,
    nb: usize,
    ts: T,
    data: &FrequencyData<T>,
) -> Result<Fit<T, Rational<T>>> {
    if na == 0 {
        return Err(FdidError::InvalidArgument {
            name: "na",
            value: "0".into(),
            reason: "order reduction needs at least one pole".into(),
        });
    }
    let model = Rational::discrete(na, nb, ts)?;
    let mut search = Search::new(model.n_params(), pipeline.stable);
    search.keep(pipeline.chain(&model, data));
    search.discrete(pipeline, &model, ts, data);
    search.replace_spurious(pipeline, data);
    search.relocate_each(pipeline, data);
    search.polish(pipeline, data);
    search.finish()
}

/// [`FurtherStarts::further_starts`] for [`Rational`]: when `suspicious`, when `fit` has
/// unstable poles, poles the data cannot resolve ([`Fit::unresolved_poles`]), a zero that
/// nearly cancels a pole or a pole the data barely determine ([`weak_pole`]), or for a
/// discrete-time model of order [`DISCRETE_SEARCH_ORDER`] or more, the starts of
/// [`fit_multistart`] (a partial-fraction model) or of [`fit_multistart_discrete`] (a
/// discrete-time polynomial model) but the automatic one, which gave `fit`; above
/// [`MAX_RESTART_ORDER`] only the start at the resonances of the data
/// ([`resonance_poles`], two chains); `None`
/// otherwise (no evidence, a transient term, the orthonormal polynomial basis) or when
/// every start fails. The caller keeps `fit` unless the returned fit has a lower cost.
///
/// On a record longer than the pipeline's `start_lines`, the starts (and `fit` among them)
/// run on every ⌈N/`start_lines`⌉-th line, whatever the order (the chain's own linear
/// stages may use fewer, [`Pipeline`]), and ML on all lines from the best of them gives the
/// returned fit (an `ml-polish` stage; the earlier stages marked with their lines): on 40
/// random systems of orders 1–10 on 2 500–20 000 lines (`examples/start_lines_study.rs`)
/// 48 s instead of 138 s in all, the same optimum on 37, a lower cost on 1 (by 4.6·10⁻⁴
/// relative) and a higher on 2 (by 3.7·10⁻⁵ and 1.2·10⁻⁴), when the chain's linear stages
/// used the same lines.
fn restart<T: Real>(
    model: &Rational<T>,
    pipeline: &Pipeline,
    data: &FrequencyData<T>,
    fit: &Fit<T, Rational<T>>,
    suspicious: bool,
) -> Option<Fit<T, Rational<T>>> {
    if model.n_transient() > 0 || model.na() == 0 {
        return None;
    }
    let unstable = !model.is_stable(fit.theta()).unwrap_or(true);
    let high_discrete = matches!(model.basis(), PolyBasis::DelayPowers { .. })
        && model.na() >= DISCRETE_SEARCH_ORDER;
    if !suspicious
        && !high_discrete
        && !unstable
        && !fit.unresolved_poles().is_ok_and(|u| !u.is_empty())
        && !near_cancellation(fit)
        && !weak_pole(fit)
    {
        return None;
    }
    let Some(fewer) = pipeline.search_data(model, data) else {
        return search_starts(model, pipeline, data, Some(fit.clone()))
            .filter(|b| b.cost() < fit.cost());
    };
    // a long record: the starts on the lines the chain's linear stages use (their ML
    // too), from the fit among them; then ML on all lines from the best of them
    let fit_on_fewer = Fit::new(
        fit.model().clone(),
        &fewer,
        fit.theta().to_vec(),
        pipeline.weighting,
        fit.stages().to_vec(),
    )
    .ok();
    let best = search_starts(model, pipeline, &fewer, fit_on_fewer)?;
    if best.theta() == fit.theta() {
        return None;
    }
    ml_on_all_lines(pipeline, data, &best, fewer.len()).filter(|b| b.cost() < fit.cost())
}

/// The further starts of [`restart`] on `data` (with `fit` among them when given, but at
/// the high orders, where only the resonance start runs): the best fit, `None` when every
/// start fails.
fn search_starts<T: Real>(
    model: &Rational<T>,
    pipeline: &Pipeline,
    data: &FrequencyData<T>,
    fit: Option<Fit<T, Rational<T>>>,
) -> Option<Fit<T, Rational<T>>> {
    let mut search = Search::new(model.n_params(), pipeline.stable);
    if model.na() > MAX_RESTART_ORDER {
        // high orders: only the start at the resonances of the data (two chains)
        let ts = match model.basis() {
            PolyBasis::PartialFractions { .. } => None,
            PolyBasis::DelayPowers { ts } => Some(*ts),
            PolyBasis::Orthonormal { .. } => return None,
        };
        search.resonances(pipeline, model.na(), model.nb(), ts, data);
        return search.best;
    }
    match model.basis() {
        PolyBasis::PartialFractions { .. } => {
            search.continuous(pipeline, model.na(), model.nb(), data);
        }
        PolyBasis::DelayPowers { ts } => {
            search.discrete(
                pipeline,
                &Rational::discrete(model.na(), model.nb(), *ts).ok()?,
                *ts,
                data,
            );
        }
        PolyBasis::Orthonormal { .. } => return None,
    }
    if let Some(fit) = fit {
        search.keep(Ok(fit));
    }
    search.replace_spurious(pipeline, data);
    search.relocate_each(pipeline, data);
    search.polish(pipeline, data);
    search.best
}

/// ML of `pipeline` on all lines of `data` from `best`, a fit on `lines` of them (its
/// stages marked so, an `ml-polish` stage added); `None` when it fails or the pipeline has
/// no ML.
fn ml_on_all_lines<T: Real>(
    pipeline: &Pipeline,
    data: &FrequencyData<T>,
    best: &Fit<T, Rational<T>>,
    lines: usize,
) -> Option<Fit<T, Rational<T>>> {
    let lm = pipeline.ml?;
    let ml = MaximumLikelihood {
        weighting: pipeline.weighting,
    };
    let problem = ml.problem(best.model(), data).ok()?;
    let fast = crate::solver::GramLevenbergMarquardt::from(lm);
    let sol = super::chain::ml_solve_in(
        &fast,
        &lm,
        best.model(),
        &problem,
        best.theta(),
        pipeline.stable,
    )
    .ok()?;
    let mut stages: Vec<Stage<T>> = best
        .stages()
        .iter()
        .cloned()
        .map(|mut s| {
            s.lines = s.lines.or(Some(lines));
            s
        })
        .collect();
    stages.push(Stage::new(StageKind::MlPolish, sol.clone()));
    Fit::from_ml_problem(best.model().clone(), data, sol.theta, &problem, stages).ok()
}

/// Highest denominator order for which `Pipeline::fit` runs its further starts: their number grows
/// with the order (every pole-pair reduction of the order-(na + 2) search is an ML start),
/// and above this order one search costs minutes. Higher orders get the start at the
/// resonances of the data only; call
/// [`fit_multistart`] or [`fit_multistart_discrete`] for the search.
pub const MAX_RESTART_ORDER: usize = 12;

/// Lowest denominator order of a discrete-time model (z⁻¹ powers) for which
/// [`Pipeline::fit`] runs the further starts whatever the evidence: in the 500-system study
/// (`examples/optimisation_robustness.rs`) the discrete-time fits that ended in a local
/// minimum without any evidence of one were of orders 9 and 10 but one, where the cost
/// over the polynomial coefficients is most rugged (the chain alone reached the optimum on
/// 20 of 24 systems of order 9 and 15 of 30 of order 10). With the rule 246 of the 250
/// discrete-time systems reach it (242 without), for 5 % more time in all.
pub const DISCRETE_SEARCH_ORDER: usize = 9;

/// Relative distance |s_p − s_z|/|s_p| below which a pole and a zero of a fit may cancel
/// (s = p in continuous time, ln(p)/Ts in discrete time).
const NEAR_CANCELLATION: f64 = 0.1;

/// Whether a pole and a zero of `fit` nearly cancel: |s_p − s_z| below both
/// [`NEAR_CANCELLATION`]·|s_p| and the pole's half-power half-width |Re s_p|, i.e. the
/// zero lies inside the pole's resonance band and the pair spends an order on almost
/// nothing, typically where a local minimum parks a pole the data need elsewhere. A zero
/// beside a lightly damped pole but outside its band (an antiresonance next to a
/// resonance, as in collocated mechanical systems) does not count.
fn near_cancellation<T: Real>(fit: &Fit<T, Rational<T>>) -> bool {
    let (Ok(poles), Ok(zeros)) = (fit.poles(), fit.zeros()) else {
        return false;
    };
    let to_s = |p: Complex<T>| s_plane(fit.model().domain(), p);
    let limit = T::lit(NEAR_CANCELLATION);
    poles.iter().any(|p| {
        let s = to_s(*p);
        let radius = Float::min(limit * s.norm(), Float::abs(s.re));
        zeros.iter().any(|z| (s - to_s(*z)).norm() < radius)
    })
}

/// Fraction of a pole's distance from the stability boundary that its standard deviation
/// may reach before [`weak_pole`] takes the pole for one the data barely determine: at 0.5
/// its two-standard-deviation (about 95 %) region reaches the boundary.
const WEAK_POLE: f64 = 0.5;

/// Whether `fit` has a pole the data barely determine: with s = p (continuous time) or
/// s = ln(p)/Ts (discrete time) and its linearised variance
/// σ_s² = Σᵢⱼ Re(∂s/∂θᵢ · conj ∂s/∂θⱼ) Cov_ij (the fit's covariance, ∂p/∂θ from
/// [`Rational::pole_sensitivities`]), a pole with σ_s > [`WEAK_POLE`]·|Re s|. Along such a
/// pole the cost is nearly flat and other minima lie close in cost: the optimum places the
/// weak pole elsewhere, or trades it for a pole–zero pair. In the study
/// (`examples/optimisation_robustness.rs`, seeds 1000–1499 and 7000–7299) the 10 fits
/// that ended in a local minimum without any other evidence all had one, and the search
/// it starts reached the optimum on 7 of them: 496 of 500 and 299 of 300 systems reach
/// it (494 and 294 without the rule); `Pipeline::fit` took 77.4 s over the 500 against
/// 68.4 s before, on a day the chain alone took 1.92 s against 1.65 s. False without a
/// covariance.
fn weak_pole<T: Real>(fit: &Fit<T, Rational<T>>) -> bool {
    let (Some(cov), Some(poles)) = (
        fit.covariance(),
        fit.model().pole_sensitivities(fit.theta()),
    ) else {
        return false;
    };
    let domain = fit.model().domain();
    poles.iter().any(|(p, d)| {
        // σ_p², then σ_s² = |∂s/∂p|²·σ_p² with ∂s/∂p = 1, or 1/(p·Ts)
        let mut var = T::zero();
        for (i, di) in d.iter().enumerate() {
            for (j, dj) in d.iter().enumerate() {
                var += (di.re * dj.re + di.im * dj.im) * cov[(i, j)];
            }
        }
        if let Domain::Discrete { ts } = domain {
            var /= (*p * ts).norm_sqr();
        }
        let s = s_plane(domain, *p);
        var > T::zero() && Float::sqrt(var) > T::lit(WEAK_POLE) * Float::abs(s.re)
    })
}

/// Lowest height ratio h_peak / max(valleys) of a local maximum of |Y/U| that
/// [`resonance_poles`] takes for a resonance (3 dB).
const PEAK_PROMINENCE: f64 = std::f64::consts::SQRT_2;

/// Starting s-plane poles of order `na` at the resonances of the nonparametric FRF
/// h_k = |Y_k/U_k| (lines with U_k ≠ 0 and ω_k > 0): its local maxima, ranked by their
/// prominence h_peak / max(h_valley left, h_valley right) (the valleys being the minima
/// of h between the peak and the neighbouring maxima) and kept when it exceeds 3 dB, give
/// up to ⌊na/2⌋ pairs −ζω_p ± iω_p√(1 − ζ²) (upper halves returned), with ζ from the
/// half-power band, ζ = (ω₊ − ω₋)/(2ω_p) where h first falls below h_peak/√2 on each side
/// (clamped to [10⁻³, 0.3]; 0.01 when the band is narrower than the grid resolves). The
/// other pairs are spread log-uniformly over the band with ζ = 0.1, plus the real pole
/// −ω_max for odd `na`. `None` when the FRF has no such peak.
pub(crate) fn resonance_poles<T: Real>(
    na: usize,
    data: &FrequencyData<T>,
) -> Option<Vec<Complex<T>>> {
    let pts: Vec<(T, T)> = data
        .omega()
        .iter()
        .zip(data.y().iter().zip(data.u()))
        .filter(|(w, (_, u))| **w > T::zero() && u.norm_sqr() > T::zero())
        .map(|(w, (y, u))| (*w, (*y / *u).norm()))
        .filter(|(_, h)| Float::is_finite(*h))
        .collect();
    let n = pts.len();
    if n < 3 || na < 2 {
        return None;
    }
    let h = |k: usize| pts[k].1;
    let maxima: Vec<usize> = (1..n - 1)
        .filter(|k| h(*k) > h(k - 1) && h(*k) >= h(k + 1))
        .collect();
    let mut peaks: Vec<(T, usize)> = vec![];
    for (i, &k) in maxima.iter().enumerate() {
        let lo = if i == 0 { 0 } else { maxima[i - 1] };
        let hi = maxima.get(i + 1).copied().unwrap_or(n - 1);
        let left = (lo..=k).map(h).fold(T::infinity(), Float::min);
        let right = (k..=hi).map(h).fold(T::infinity(), Float::min);
        let valley = Float::max(left, right);
        if valley > T::zero() && h(k) / valley > T::lit(PEAK_PROMINENCE) {
            peaks.push((h(k) / valley, k));
        }
    }
    if peaks.is_empty() {
        return None;
    }
    peaks.sort_by(|a, b| b.0.partial_cmp(&a.0).unwrap_or(std::cmp::Ordering::Equal));
    peaks.truncate(na / 2);
    let half = T::lit(std::f64::consts::FRAC_1_SQRT_2);
    let mut poles: Vec<Complex<T>> = peaks
        .iter()
        .map(|&(_, k)| {
            let (wp, level) = (pts[k].0, h(k) * half);
            let l = (0..k).rev().find(|j| h(*j) < level);
            let r = (k + 1..n).find(|j| h(*j) < level);
            let zeta = match (l, r) {
                (Some(l), Some(r)) if r - l > 2 => Float::min(
                    Float::max((pts[r].0 - pts[l].0) / (wp + wp), T::lit(1e-3)),
                    T::lit(0.3),
                ),
                _ => T::lit(0.01),
            };
            Complex::new(-zeta * wp, wp * Float::sqrt(T::one() - zeta * zeta))
        })
        .collect();
    let (lo, hi) = (pts[0].0, pts[n - 1].0);
    let rest = na / 2 - poles.len();
    poles.extend(log_spread_poles(2 * rest, lo, hi, T::lit(0.1)));
    if na % 2 == 1 {
        poles.push(Complex::new(-hi, T::zero()));
    }
    Some(poles)
}

/// Every way of dropping one conjugate pair or two real poles of a z-plane pole set
/// (closed under conjugation), each returned closed under conjugation.
fn reduced_poles_z<T: Real>(poles: &[Complex<T>]) -> Vec<Vec<Complex<T>>> {
    let pairs: Vec<Complex<T>> = poles.iter().copied().filter(|q| q.im > T::zero()).collect();
    let real: Vec<Complex<T>> = poles
        .iter()
        .copied()
        .filter(|q| q.im == T::zero())
        .collect();
    let close = |p: Vec<Complex<T>>, r: Vec<Complex<T>>| {
        let mut out: Vec<Complex<T>> = p.iter().flat_map(|q| [*q, q.conj()]).collect();
        out.extend(r);
        out
    };
    let mut out = vec![];
    for i in 0..pairs.len() {
        let p = pairs
            .iter()
            .enumerate()
            .filter(|(k, _)| *k != i)
            .map(|(_, q)| *q)
            .collect();
        out.push(close(p, real.clone()));
    }
    for i in 0..real.len() {
        for j in i + 1..real.len() {
            let r = real
                .iter()
                .enumerate()
                .filter(|(k, _)| *k != i && *k != j)
                .map(|(_, q)| *q)
                .collect();
            out.push(close(pairs.clone(), r));
        }
    }
    out
}

/// θ = [a₁ … a_na, b₀ … b_nb] of `model` with A(z⁻¹) = Π(1 − pⱼz⁻¹) and B the weighted
/// linear least-squares numerator for that A; `None` when the solve fails.
fn discrete_start<T: Real>(
    model: &Rational<T>,
    poles: &[Complex<T>],
    data: &FrequencyData<T>,
    weights: Option<&[T]>,
) -> Option<Vec<T>> {
    let (na, nb) = (model.na(), model.nb());
    // Π(1 − p z⁻¹) in ascending powers of z⁻¹
    let mut a = vec![Complex::new(T::one(), T::zero())];
    for p in poles {
        let mut next = vec![Complex::new(T::zero(), T::zero()); a.len() + 1];
        for (k, v) in a.iter().enumerate() {
            next[k] += *v;
            next[k + 1] -= *v * *p;
        }
        a = next;
    }
    if a.len() != na + 1 {
        return None;
    }
    let a: Vec<T> = a.iter().map(|c| c.re).collect();
    let mut theta: Vec<T> = a[1..].to_vec();
    theta.extend(std::iter::repeat_n(T::zero(), nb + 1));
    let n = data.len();
    let mut den = vec![Complex::new(T::zero(), T::zero()); n];
    model.denominator_into(&theta, data.omega(), &mut den);
    let mut m = DMatrix::zeros(2 * n, nb + 1);
    let mut rhs = DVector::zeros(2 * n);
    for k in 0..n {
        let w = weights.map_or(T::one(), |w| w[k]);
        let zinv = model.variable(data.omega()[k]).inv();
        let base = data.u()[k] * w / den[k];
        let mut pw = Complex::new(T::one(), T::zero());
        for j in 0..=nb {
            let c = base * pw;
            m[(2 * k, j)] = c.re;
            m[(2 * k + 1, j)] = c.im;
            pw *= zinv;
        }
        let y = data.y()[k] * w;
        rhs[2 * k] = y.re;
        rhs[2 * k + 1] = y.im;
    }
    let (b, _) = crate::linalg::least_squares(m, rhs, 1e3).ok()?;
    theta[na..].copy_from_slice(b.as_slice());
    Some(theta)
}

/// On evidence of a local minimum, the starts of [`fit_multistart`] (continuous time) or
/// [`fit_multistart_discrete`] (discrete time), for denominator orders up to
/// [`MAX_RESTART_ORDER`], above it the start at the resonances; the fit's own evidence is
/// added to the chain's: unstable poles, poles the data cannot resolve
/// ([`Fit::unresolved_poles`]), a zero within 10 % of a pole and inside its half-power
/// band, a pole whose standard deviation exceeds half its distance from the stability
/// boundary; a discrete-time model of order [`DISCRETE_SEARCH_ORDER`] or more always runs them.
impl<T: Real> FurtherStarts<T> for Rational<T> {
    fn further_starts(
        &self,
        pipeline: &Pipeline,
        data: &FrequencyData<T>,
        fit: &Fit<T, Self>,
        suspicious: bool,
    ) -> Option<Fit<T, Self>> {
        restart(self, pipeline, data, fit, suspicious)
    }
}
