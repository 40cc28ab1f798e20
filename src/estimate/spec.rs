//! One model specification — domain, orders, factors (delay, transient, noise model) and
//! criterion — and its fit by the strategies of this layer. The command parses its flags
//! into a [`ModelSpec`]; the discrepancy workflow augments one step by step. Nobody else
//! dispatches on the settings.

use super::fit_noise_model;
use super::{Pipeline, estimate, fit_delayed, fit_eiv, fit_eiv_delayed};
use crate::basis::PolyBasis;
use crate::criterion::{TotalLeastSquares, interior_lines};
use crate::data::{FrequencyData, NoiseWeighting, Normalisation};
use crate::error::{FdidError, Result};
use crate::fit::{Fit, Stage, StageKind};
use crate::model::WithNoiseModel;
use crate::model::{Delayed, Domain, ModelStructure, NoiseModel, Rational};
use crate::scalar::Complex;
use crate::solver::SvdNullVector;
use std::borrow::Cow;

/// The criterion of a [`ModelSpec`] and the chain that minimises it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
pub enum Method {
    /// Levy's linear least squares (McKelvey eq. 39) alone.
    Levy,
    /// Levy, then Sanathanan–Koerner iterations (eq. 41).
    Sk,
    /// Output-error maximum likelihood (eq. 23), started by Levy → SK ([`Pipeline`]).
    #[default]
    Ml,
    /// Total least squares of the equation error (SVD null vector).
    Tls,
    /// Errors-in-variables maximum likelihood (eq. 42), started by the ML chain.
    Eiv,
}

impl Method {
    /// The lowercase name (`levy`, `sk`, `ml`, `tls`, `eiv`).
    pub fn name(self) -> &'static str {
        match self {
            Method::Levy => "levy",
            Method::Sk => "sk",
            Method::Ml => "ml",
            Method::Tls => "tls",
            Method::Eiv => "eiv",
        }
    }
}

/// The range a [`ModelSpec`]'s delay τ may take.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
pub enum DelayRange {
    /// The causal, identifiable range 0 ≤ τ < 2π/Δω ([`causal_delay_limit`]); a fit whose
    /// τ̂ leaves it is an error.
    #[default]
    Causal,
    /// Any τ (an advance included).
    Unbounded,
}

impl DelayRange {
    fn is_causal(&self) -> bool {
        *self == DelayRange::Causal
    }
}

/// Whether a [`ModelSpec`]'s fit must be stable.
///
/// With [`Stability::Enforced`] every pole of the rational part B/A ends strictly stable
/// (Re p < 0 in s, |p| < 1 in z), by construction rather than by a check afterwards:
///
/// 1. **Starts and relocation.** After every linear stage (Levy, each SK iteration) the
///    unstable poles are reflected into the stable region, p ↦ −p̄ in s and p ↦ 1/p̄ in z
///    (B scaled by 1/|p| per reflected z pole), which keeps |G| on the frequency axis
///    unchanged ([`crate::model::Rational::reflect_unstable`]); the partial-fraction basis is
///    relocated to the reflected poles.
/// 2. **Stability-constrained ML.** The Levenberg–Marquardt iterations of the ML stage
///    start from the reflected estimate and reject every step θ + δ that leaves the stable
///    set S = {θ : A(θ) has all roots stable}: such a step is treated as a failed one (the
///    damping λ grows, δ shrinks) exactly like a step that raises the cost, so that
///
///    ```text
///    θ_{k+1} = θ_k + δ_k  only if  V(θ_k + δ_k) < V(θ_k)  and  θ_k + δ_k ∈ S,
///    ```
///
///    a descent method on V restricted to the open set S. Since θ₀ ∈ S every iterate is in S;
///    the result is a local minimum of V over S (on its boundary only as a limit).
///
/// A noise model's D (and C) are kept stable by the noise-model fit itself
/// ([`crate::model::NoiseModel::stabilised`]). [`Stability::Free`] fits the unconstrained
/// criterion; check the result with [`RationalFit::is_stable`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
pub enum Stability {
    /// No constraint: the minimiser of the criterion, stable or not.
    #[default]
    Free,
    /// Every pole of the rational part stable by construction (reflection of the linear
    /// stages' poles, stability-constrained ML).
    Enforced,
}

impl Stability {
    /// The lowercase name (`free`, `enforced`).
    pub fn name(self) -> &'static str {
        match self {
            Stability::Free => "free",
            Stability::Enforced => "enforced",
        }
    }

    fn is_free(&self) -> bool {
        *self == Stability::Free
    }
}

/// A rational model structure with its factors and criterion.
///
/// | field | default | meaning |
/// |---|---|---|
/// | `domain` | — | s, or z with its sample time |
/// | `na`, `nb` | — | denominator and numerator degrees |
/// | `delay` | false | multiply by e^{−iωτ} with τ estimated ([`Delayed`], section 4) |
/// | `delay_range` | [`DelayRange::Causal`] | where τ may lie |
/// | `transient` | false | add the transient term T(ω) of a non-periodic record (eqs. 4–5, 9–10) |
/// | `noise_order` | `None` | a noise model H = C/D of orders (n, n) (eq. 26) |
/// | `criterion` | [`Method::Ml`] | levy, sk, ml (eq. 23), tls or eiv (eq. 42) |
/// | `stability` | [`Stability::Free`] | [`Stability::Enforced`]: a stable fit by construction |
///
/// [`ModelSpec::fit`] is the one dispatch from settings to estimator.
///
/// ```
/// use fdid::prelude::*;
/// use fdid::estimate::ModelSpec;
/// # fn main() -> fdid::Result<()> {
/// // G(z) = 0.5 z⁻¹/(1 − 0.8 z⁻¹), noise-free
/// let omega: Vec<f64> = (1..=64).map(|k| k as f64 * std::f64::consts::PI / 65.0).collect();
/// let y: Vec<Complex<f64>> = omega
///     .iter()
///     .map(|w| {
///         let zi = Complex::new(0.0, -w).exp();
///         zi * 0.5 / (Complex::new(1.0, 0.0) - zi * 0.8)
///     })
///     .collect();
/// let data = FrequencyData::from_frf(omega, y, Some(1.0))?;
/// let fit = ModelSpec::discrete(1, 1, 1.0).fit(&data)?;
/// assert!((fit.poles()?[0].re - 0.8).abs() < 1e-9);
/// # Ok(())
/// # }
/// ```
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct ModelSpec {
    /// The model's domain.
    pub domain: Domain<f64>,
    /// Denominator degree.
    pub na: usize,
    /// Numerator degree.
    pub nb: usize,
    /// With an estimated time delay.
    pub delay: bool,
    /// Where the delay may lie.
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "DelayRange::is_causal")
    )]
    pub delay_range: DelayRange,
    /// With a transient term (non-periodic records).
    pub transient: bool,
    /// Order of a parametric noise model H = C/D, if any.
    pub noise_order: Option<usize>,
    /// The criterion.
    pub criterion: Method,
    /// Whether the fit must be stable.
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Stability::is_free")
    )]
    pub stability: Stability,
}

impl ModelSpec {
    /// A plain discrete-time ML spec of orders (`na`, `nb`) with sample time `ts`.
    pub fn discrete(na: usize, nb: usize, ts: f64) -> Self {
        Self {
            domain: Domain::Discrete { ts },
            na,
            nb,
            delay: false,
            delay_range: DelayRange::Causal,
            transient: false,
            noise_order: None,
            criterion: Method::Ml,
            stability: Stability::Free,
        }
    }

    /// A plain continuous-time ML spec of orders (`na`, `nb`).
    pub fn continuous(na: usize, nb: usize) -> Self {
        Self {
            domain: Domain::Continuous,
            ..Self::discrete(na, nb, 1.0)
        }
    }

    /// The rational model of the spec on `data`'s grid, with the transient term when asked
    /// for (a continuous-time transient is sampled with the data's sample time).
    ///
    /// # Errors
    /// A continuous-time transient on data without a sample time; the model's own checks.
    pub fn model(&self, data: &FrequencyData<f64>) -> Result<Rational<f64>> {
        let model = match self.domain {
            Domain::Continuous => Rational::continuous(self.na, self.nb, data.omega())?,
            Domain::Discrete { ts } => Rational::discrete(self.na, self.nb, ts)?,
        };
        self.with_transient(model, data)
    }

    /// `model` with the spec's transient term, when it asks for one.
    fn with_transient(
        &self,
        model: Rational<f64>,
        data: &FrequencyData<f64>,
    ) -> Result<Rational<f64>> {
        if !self.transient {
            return Ok(model);
        }
        match self.domain {
            Domain::Discrete { .. } => model.with_transient(),
            Domain::Continuous => {
                let ts = data.ts().ok_or_else(|| FdidError::InvalidArgument {
                    name: "transient",
                    value: "continuous-time spec, data without sample time".into(),
                    reason: "the sampled transient needs the record's sample time".into(),
                })?;
                model.with_sampled_transient(ts)
            }
        }
    }

    /// Fits the spec to `data`, normalised by powers of two when far from order one
    /// ([`Normalisation::of_far`]; the fit is mapped back, so any finite data of the type's
    /// range give the same poles), choosing
    /// the strategy from its settings:
    ///
    /// | delay | noise model | criterion | strategy |
    /// |---|---|---|---|
    /// | no | no | levy, sk, ml | [`Pipeline::levy`], [`Pipeline::sk`], [`Pipeline::default`] |
    /// | no | no | tls | [`TotalLeastSquares`] by [`SvdNullVector`] |
    /// | no | no | eiv | [`fit_eiv`] |
    /// | yes | no | ml | [`Delayed::fit`] (delay search, then joint ML) |
    /// | yes | no | eiv | [`fit_eiv_delayed`] |
    /// | no | yes | ml | [`fit_noise_model`] (on the [`interior_lines`]) |
    /// | yes | yes | ml | the delayed fit with flat weighting on the excited lines, then [`refine_noise_model`](super::refine_noise_model) |
    ///
    /// # Errors
    /// [`FdidError::ZeroOutput`] when the output is zero on every line;
    /// [`FdidError::TooFewFrequencies`] when 2·lines < na + nb + 1;
    /// [`FdidError::InvalidArgument`] for combinations that do not exist (a noise model with
    /// another criterion than ML; a delay with levy, sk or tls; a noise model on data
    /// without a sample time); the estimators' errors.
    pub fn fit(&self, data: &FrequencyData<f64>) -> Result<RationalFit> {
        self.fit_from(data, None)
    }

    /// [`ModelSpec::fit`] with the delay started at `tau0` (s) instead of searched, for
    /// data whose delay is known to lie near it (a segment of a record whose whole fit
    /// gave τ₀): a delayed ML spec without a noise model is fitted by
    /// `Delayed::fit_from_delay` (the inner model on the data with τ₀ removed, then the
    /// joint ML), at the cost of one fit with the delay known instead of a search; any
    /// other spec as [`ModelSpec::fit`].
    pub(crate) fn fit_near_delay(
        &self,
        data: &FrequencyData<f64>,
        tau0: f64,
    ) -> Result<RationalFit> {
        self.fit_from(data, Some(tau0))
    }

    /// [`ModelSpec::fit`], a delayed ML fit from the delay `delay_from` when given.
    fn fit_from(&self, data: &FrequencyData<f64>, delay_from: Option<f64>) -> Result<RationalFit> {
        crate::progress::report(|| {
            format!(
                "fitting na {} nb {}{}{} on {} lines",
                self.na,
                self.nb,
                match (self.delay, delay_from) {
                    (true, Some(tau)) => format!(" with the delay from {tau:.4e} s"),
                    (true, None) => " with a delay".into(),
                    (false, _) => String::new(),
                },
                self.noise_order.map_or(String::new(), |n| format!(
                    " with a noise model of order {n}"
                )),
                data.len()
            )
        });
        self.check_fit_data(data)?;
        let model = self.model(data)?;
        self.fit_model(&model, Pipeline::default(), data, delay_from)
    }

    /// The fit of a plain ML spec (no delay, no noise model) started from the poles
    /// `poles` (na values, closed under conjugation) by [`Pipeline::fit_from_roots`]: the
    /// denominator with those roots, the numerator by linear least squares, then ML
    /// (McKelvey eq. 23), stable-constrained when the spec enforces it. A continuous-time
    /// spec with nb ≤ na is fitted in the partial-fraction form with its basis poles at
    /// `poles` (reflected into the left half-plane), where the start is D = 1 and the Levy
    /// solve in that basis (one Sanathanan–Koerner iteration from those poles, eq. 41)
    /// followed by ML is a second start, the lower cost winning; the others in the spec's
    /// own basis ([`ModelSpec::model`]). A warm start: the discrepancy
    /// workflow refits an augmented model from the poles of the model it augments and
    /// the poles its finding adds, where a fit from scratch may land in another local
    /// minimum.
    ///
    /// ```
    /// use fdid::estimate::ModelSpec;
    /// use fdid::prelude::*;
    /// # fn main() -> fdid::Result<()> {
    /// // G(s) = 1 / (s² + 0.2 s + 1) on 200 lines, started 10 % off
    /// let omega: Vec<f64> = (1..=200).map(|k| 0.01 * k as f64).collect();
    /// let g = |w: f64| {
    ///     let s = Complex::new(0.0, w);
    ///     Complex::new(1.0, 0.0) / (s * s + s * 0.2 + 1.0)
    /// };
    /// let y = omega.iter().map(|w| g(*w)).collect();
    /// let data = FrequencyData::from_frf(omega, y, None)?;
    /// let truth = Complex::new(-0.1, 0.99f64.sqrt());
    /// let start = [truth * 1.1, truth.conj() * 1.1];
    /// let fit = ModelSpec::continuous(2, 0).fit_from_poles(&data, &start)?;
    /// assert!(fit.poles()?.iter().any(|p| (p - truth).norm() < 1e-8));
    /// # Ok(())
    /// # }
    /// ```
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] for a delay, a noise model or another criterion
    /// than ML; as [`Pipeline::fit_from_roots`] and [`ModelSpec::fit`].
    pub fn fit_from_poles(
        &self,
        data: &FrequencyData<f64>,
        poles: &[Complex<f64>],
    ) -> Result<RationalFit> {
        crate::progress::report(|| {
            format!(
                "fitting na {} nb {} from given poles on {} lines",
                self.na,
                self.nb,
                data.len()
            )
        });
        if self.delay || self.noise_order.is_some() || self.criterion != Method::Ml {
            return Err(FdidError::InvalidArgument {
                name: "spec",
                value: format!(
                    "delay {}, noise order {:?}, criterion {}",
                    self.delay,
                    self.noise_order,
                    self.criterion.name()
                ),
                reason: "a start from given poles is for plain ML specs".into(),
            });
        }
        self.check_fit_data(data)?;
        let model = match self.domain {
            Domain::Continuous if self.na >= 1 && self.nb <= self.na => {
                let basis = left_half_plane_members(poles);
                self.with_transient(Rational::partial_fractions(basis, self.nb)?, data)?
            }
            _ => self.model(data)?,
        };
        let pipeline = Pipeline {
            stable: self.stability == Stability::Enforced,
            ..Pipeline::default()
        };
        let normalisation = Normalisation::of_far(data);
        let from_roots = if normalisation.is_identity() {
            pipeline.fit_from_roots(&model, data, poles)
        } else {
            pipeline
                .fit_from_roots(&model, &normalisation.apply(data), poles)
                .and_then(|f| f.denormalised(&normalisation))
        }
        .map(RationalFit::Plain);
        if !matches!(model.basis(), PolyBasis::PartialFractions { .. }) {
            return from_roots;
        }
        // the Levy solve in the basis at the poles: one SK iteration from them
        let one_relocation = Pipeline {
            sk: None,
            ..Pipeline::default()
        };
        let levy = self.fit_model(&model, one_relocation, data, None);
        match (from_roots, levy) {
            (Ok(a), Ok(b)) => Ok(if b.cost() < a.cost() { b } else { a }),
            (Ok(a), Err(_)) => Ok(a),
            (Err(_), Ok(b)) => Ok(b),
            (Err(e), Err(_)) => Err(e),
        }
    }

    /// The checks of [`ModelSpec::fit`] before any model is built: enough lines for the
    /// parameters, an output that is not zero.
    fn check_fit_data(&self, data: &FrequencyData<f64>) -> Result<()> {
        let p = self.na + self.nb + 1;
        if 2 * data.len() < p {
            return Err(FdidError::TooFewFrequencies {
                lines: data.len(),
                equations: 2 * data.len(),
                parameters: p,
            });
        }
        data.check_output()
    }

    /// The fit of `model` by the spec's strategy with `pipeline`'s stages, on data
    /// normalised by powers of two when far from order one (mapped back), stable when the spec enforces it; a
    /// delayed ML fit from the delay `delay_from` when given ([`ModelSpec::fit_near_delay`]).
    fn fit_model(
        &self,
        model: &Rational<f64>,
        pipeline: Pipeline,
        data: &FrequencyData<f64>,
        delay_from: Option<f64>,
    ) -> Result<RationalFit> {
        let stable = self.stability == Stability::Enforced;
        let pipeline = Pipeline { stable, ..pipeline };
        let normalisation = Normalisation::of_far(data);
        let fit = if normalisation.is_identity() {
            self.fit_with(&pipeline, model, data, delay_from)?
        } else {
            self.fit_with(&pipeline, model, &normalisation.apply(data), delay_from)?
                .denormalised(&normalisation)?
        };
        if stable && !fit.is_stable() {
            return Err(FdidError::NotConverged {
                method: "stability-constrained fit",
                reason: "no stable model was found (a pole on the stability boundary)".into(),
            });
        }
        Ok(fit)
    }

    /// [`ModelSpec::fit`] within a budget of `work` multiply-adds of the iterative solvers
    /// (the unit of [`ModelSpec::search_work`]; [`crate::solver::work::within`]): every
    /// Levenberg–Marquardt evaluation and Sanathanan–Koerner solve on L lines and q
    /// parameters charges 2·L·q², and once the budget is spent each solver stops at its
    /// best point so far, so the fit ends soon after, whatever the number of lines, the
    /// orders or the restarts. Returns the fit and whether the budget stopped a solver:
    /// its stages then end with
    /// [`Termination::MaxIterations`](crate::solver::Termination::MaxIterations), and the
    /// model may not be at the criterion's minimum. The delay scan and the linear stages
    /// are not charged ([`ModelSpec::search_work`] bounds the scan before the run).
    ///
    /// ```
    /// use fdid::estimate::ModelSpec;
    /// use fdid::prelude::*;
    /// # fn main() -> fdid::Result<()> {
    /// let omega: Vec<f64> = (1..=200).map(|k| k as f64 * std::f64::consts::PI / 201.0).collect();
    /// let y: Vec<Complex<f64>> = omega
    ///     .iter()
    ///     .map(|w| {
    ///         let zi = Complex::new(0.0, -w).exp();
    ///         zi * 0.5 / (Complex::new(1.0, 0.0) - zi * 0.8)
    ///     })
    ///     .collect();
    /// let data = FrequencyData::from_frf(omega, y, Some(1.0))?;
    /// let spec = ModelSpec::discrete(1, 1, 1.0);
    /// let (fit, stopped) = spec.fit_within(&data, 1e9)?;
    /// assert!(!stopped && (fit.poles()?[0].re - 0.8).abs() < 1e-9);
    /// let (_, stopped) = ModelSpec::discrete(8, 7, 1.0).fit_within(&data, 1e5)?;
    /// assert!(stopped);
    /// # Ok(())
    /// # }
    /// ```
    ///
    /// # Errors
    /// As [`ModelSpec::fit`]; [`FdidError::InvalidArgument`] named `work` when it is not
    /// positive.
    pub fn fit_within(&self, data: &FrequencyData<f64>, work: f64) -> Result<(RationalFit, bool)> {
        if !(work > 0.0) {
            return Err(FdidError::InvalidArgument {
                name: "work",
                value: work.to_string(),
                reason: "the work budget must be positive".into(),
            });
        }
        let (fit, stopped) = crate::solver::work::within(work, || self.fit(data));
        Ok((fit?, stopped))
    }

    /// An estimate of the work of the search stages of [`ModelSpec::fit`] on `data`, in
    /// multiply-adds of its least-squares solves (one evaluation on L lines and q
    /// parameters: 2·L·q²): the delay search and the fits after it (a delay), and the
    /// Levenberg–Marquardt run of the noise model (a noise order n: q = p + 2n), each at
    /// its full evaluation budget. 0 for the other specs, whose cost is a few tens of
    /// solves. A caller can refuse a spec whose bound is beyond what it will wait for: on
    /// two cores of 2026, fdid does about 1.6·10⁸ such units per second.
    ///
    /// ```
    /// use fdid::estimate::ModelSpec;
    /// use fdid::prelude::*;
    /// # fn main() -> fdid::Result<()> {
    /// let omega: Vec<f64> = (1..=500).map(|k| k as f64 * std::f64::consts::PI / 501.0).collect();
    /// let y = vec![Complex::new(1.0, 0.0); 500];
    /// let data = FrequencyData::from_frf(omega, y, Some(1.0))?;
    /// let plain = ModelSpec::discrete(2, 2, 1.0);
    /// assert_eq!(plain.search_work(&data)?, 0.0);
    /// let noise = |n| ModelSpec { noise_order: Some(n), ..plain.clone() };
    /// // (q + 1)·q² with q = p + 2n: (66·65²)/(16·15²) ≈ 77 times the work of order 5
    /// assert!(noise(30).search_work(&data)? > 70.0 * noise(5).search_work(&data)?);
    /// # Ok(())
    /// # }
    /// ```
    ///
    /// # Errors
    /// As [`ModelSpec::model`].
    pub fn search_work(&self, data: &FrequencyData<f64>) -> Result<f64> {
        self.search_work_of(data, super::work::delay_search)
    }

    /// The part of [`ModelSpec::search_work`] that every fit of the spec makes: the same
    /// except that a delay search stops after its first candidate, as it does when that
    /// candidate's ML cost reaches the noise level ([`crate::estimate::delay_start`]). A
    /// caller that runs within a work budget ([`ModelSpec::fit_within`]) can refuse the
    /// specs whose least work is already beyond it, and let the budget stop the rest.
    ///
    /// ```
    /// use fdid::estimate::ModelSpec;
    /// use fdid::prelude::*;
    /// # fn main() -> fdid::Result<()> {
    /// let omega: Vec<f64> = (1..=500).map(|k| k as f64 * std::f64::consts::PI / 501.0).collect();
    /// let y = vec![Complex::new(1.0, 0.0); 500];
    /// let data = FrequencyData::from_frf(omega, y, Some(1.0))?;
    /// let delayed = ModelSpec { delay: true, ..ModelSpec::discrete(2, 2, 1.0) };
    /// // the Levy profile, one refinement and the final fits: a small part of the bound
    /// assert!(delayed.least_search_work(&data)? < delayed.search_work(&data)? / 5.0);
    /// # Ok(())
    /// # }
    /// ```
    ///
    /// # Errors
    /// As [`ModelSpec::model`].
    pub fn least_search_work(&self, data: &FrequencyData<f64>) -> Result<f64> {
        self.search_work_of(data, super::work::delay_search_least)
    }

    /// [`ModelSpec::search_work`] with the delay search's work from `delay_work(p, lines)`.
    fn search_work_of(
        &self,
        data: &FrequencyData<f64>,
        delay_work: fn(usize, usize) -> f64,
    ) -> Result<f64> {
        let p = self.model(data)?.n_params();
        let lines = data.len();
        let delay = if self.delay {
            delay_work(p, lines)
        } else {
            0.0
        };
        let noise = self.noise_order.map_or(0.0, |n| {
            super::work::noise_model(p + usize::from(self.delay), 2 * n, lines)
        });
        Ok(delay + noise)
    }

    /// The dispatch of [`ModelSpec::fit`] with `pipeline` (a delayed ML fit from the delay
    /// `delay_from` when given).
    fn fit_with(
        &self,
        pipeline: &Pipeline,
        model: &Rational<f64>,
        data: &FrequencyData<f64>,
        delay_from: Option<f64>,
    ) -> Result<RationalFit> {
        let pipeline = *pipeline;
        let model = model.clone();
        match (self.delay, self.noise_order, self.criterion) {
            (_, Some(n), c) if c != Method::Ml => Err(FdidError::InvalidArgument {
                name: "noise_order",
                value: n.to_string(),
                reason: format!(
                    "a noise model is estimated by ML, not with the {} criterion",
                    c.name()
                ),
            }),
            (false, None, Method::Ml) => Ok(RationalFit::Plain(pipeline.fit(&model, data)?)),
            (false, None, Method::Levy) => Ok(RationalFit::Plain(
                Pipeline {
                    stable: pipeline.stable,
                    ..Pipeline::levy()
                }
                .fit(&model, data)?,
            )),
            (false, None, Method::Sk) => Ok(RationalFit::Plain(
                Pipeline {
                    stable: pipeline.stable,
                    ..Pipeline::sk()
                }
                .fit(&model, data)?,
            )),
            (false, None, Method::Tls) => {
                Ok(RationalFit::Plain(fit_tls(&model, data, pipeline.stable)?))
            }
            (false, None, Method::Eiv) => Ok(RationalFit::Plain(fit_eiv(&pipeline, &model, data)?)),
            (true, None, Method::Ml) => {
                let delayed = self.delayed(&model, data)?;
                Ok(RationalFit::Delayed(match delay_from {
                    Some(tau0) => delayed.fit_from_delay(&pipeline, data, tau0)?,
                    None => delayed.fit(&pipeline, data)?,
                }))
            }
            (true, None, Method::Eiv) => Ok(RationalFit::Delayed(fit_eiv_delayed(
                &pipeline,
                &self.delayed(&model, data)?,
                data,
            )?)),
            (true, Some(n), Method::Ml) => self.fit_delayed_noise_model(&model, data, n, &pipeline),
            (true, _, c) => Err(FdidError::InvalidArgument {
                name: "delay",
                value: c.name().into(),
                reason: "the delay enters nonlinearly and is fitted by the ml or eiv criterion"
                    .into(),
            }),
            (false, Some(n), _) => Ok(RationalFit::NoiseModel(fit_noise_model(
                &pipeline, &model, data, n, n,
            )?)),
        }
    }

    /// `model` followed by a delay in the spec's range.
    fn delayed(
        &self,
        model: &Rational<f64>,
        data: &FrequencyData<f64>,
    ) -> Result<Delayed<Rational<f64>>> {
        let delayed = Delayed::new(model.clone());
        match self.delay_range {
            DelayRange::Causal => delayed.with_bounds(0.0, causal_delay_limit(data)),
            DelayRange::Unbounded => Ok(delayed),
        }
    }

    /// The delayed model with a noise model H = C/D of orders (n, n), as
    /// [`fit_noise_model`] does for an undelayed one: the delayed fit with flat weighting
    /// on the excited lines as the start (η = 0, H = 1), then the concentrated ML criterion
    /// of McKelvey eq. 26 ([`refine_noise_model`](super::refine_noise_model)).
    fn fit_delayed_noise_model(
        &self,
        model: &Rational<f64>,
        data: &FrequencyData<f64>,
        n: usize,
        pipeline: &Pipeline,
    ) -> Result<RationalFit> {
        let excited: Vec<bool> = data.u().iter().map(|u| u.norm_sqr() > 0.0).collect();
        let flat = Pipeline {
            weighting: NoiseWeighting::Flat,
            ..*pipeline
        };
        let excited = data.select_lines(&excited)?.without_noise();
        let start = match self.delay_range {
            DelayRange::Causal => self.delayed(model, &excited)?.fit(&flat, &excited)?,
            DelayRange::Unbounded => fit_delayed(&flat, model, &excited)?,
        };
        let ts = data.ts().ok_or_else(|| FdidError::InvalidArgument {
            name: "ts",
            value: "none".into(),
            reason: "a noise model H(z) is discrete time: the data need a sample time".into(),
        })?;
        let noise = NoiseModel::new(n, n, ts)?;
        let fit = super::noise_model::refine_noise_model_in(
            &start,
            data,
            noise,
            &pipeline.ml.unwrap_or_default(),
            pipeline.stable,
        )?;
        let delayed = fit.model().system();
        if let Some(tau) = delayed.delay(fit.model().split(fit.theta()).0) {
            delayed.check_delay(tau)?;
        }
        Ok(RationalFit::DelayedNoiseModel(fit))
    }
}

/// Total least squares of the equation error ([`TotalLeastSquares`], SVD null vector),
/// with the statistics of [`Fit::new`]; with `stable` the unstable poles of the solution
/// reflected ([`Rational::stabilised`]).
fn fit_tls(
    model: &Rational<f64>,
    data: &FrequencyData<f64>,
    stable: bool,
) -> Result<Fit<f64, Rational<f64>>> {
    let tls = TotalLeastSquares::default();
    let solution = estimate(model, data, &tls, &SvdNullVector, None)?;
    let theta = if stable {
        model.stabilised(&solution.theta)?
    } else {
        solution.theta.clone()
    };
    let stages = vec![Stage::new(StageKind::Tls, solution)];
    Fit::new(model.clone(), data, theta, tls.weighting, stages)
}

/// The upper end 2π/Δω of the causal, identifiable delay range (Δω the smallest line
/// spacing: beyond it the phase e^{−iωτ} repeats on a uniform grid; 1000 periods of the
/// highest frequency without spacing).
pub fn causal_delay_limit(data: &FrequencyData<f64>) -> f64 {
    let omega = data.omega();
    let spacing = omega
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d > 0.0)
        .fold(f64::INFINITY, f64::min);
    let w_max = omega.iter().copied().fold(0.0, f64::max);
    if spacing.is_finite() {
        2.0 * std::f64::consts::PI / spacing
    } else {
        2000.0 * std::f64::consts::PI / w_max
    }
}

/// The fit of a [`ModelSpec`]: the rational model with the factors the spec asked for.
#[derive(Debug, Clone)]
pub enum RationalFit {
    /// G = B/A (with its transient term, if any).
    Plain(Fit<f64, Rational<f64>>),
    /// G e^{−iωτ}.
    Delayed(Fit<f64, Delayed<Rational<f64>>>),
    /// G with a noise model H = C/D.
    NoiseModel(Fit<f64, WithNoiseModel<Rational<f64>>>),
    /// G e^{−iωτ} with a noise model H = C/D.
    DelayedNoiseModel(Fit<f64, WithNoiseModel<Delayed<Rational<f64>>>>),
}

/// Applies `$body` to the typed fit of every variant.
macro_rules! each_fit {
    ($self:expr, $fit:ident => $body:expr) => {
        match $self {
            RationalFit::Plain($fit) => $body,
            RationalFit::Delayed($fit) => $body,
            RationalFit::NoiseModel($fit) => $body,
            RationalFit::DelayedNoiseModel($fit) => $body,
        }
    };
}

impl RationalFit {
    /// The fit to data normalised by `n` mapped back to the data as given
    /// ([`Fit::denormalised`]).
    ///
    /// # Errors
    /// As [`Fit::denormalised`].
    pub fn denormalised(self, n: &Normalisation<f64>) -> Result<Self> {
        Ok(match self {
            RationalFit::Plain(f) => RationalFit::Plain(f.denormalised(n)?),
            RationalFit::Delayed(f) => RationalFit::Delayed(f.denormalised(n)?),
            RationalFit::NoiseModel(f) => RationalFit::NoiseModel(f.denormalised(n)?),
            RationalFit::DelayedNoiseModel(f) => RationalFit::DelayedNoiseModel(f.denormalised(n)?),
        })
    }

    /// The rational part B/A (without delay and noise model).
    pub fn rational(&self) -> &Rational<f64> {
        match self {
            RationalFit::Plain(f) => f.model(),
            RationalFit::Delayed(f) => f.model().inner(),
            RationalFit::NoiseModel(f) => f.model().system(),
            RationalFit::DelayedNoiseModel(f) => f.model().system().inner(),
        }
    }

    /// θ of the rational part B/A (without delay and noise-model parameters).
    pub fn rational_theta(&self) -> &[f64] {
        match self {
            RationalFit::Plain(f) => f.theta(),
            RationalFit::Delayed(f) => f.model().inner_theta(f.theta()),
            RationalFit::NoiseModel(f) => f.model().split(f.theta()).0,
            RationalFit::DelayedNoiseModel(f) => {
                let (system, _) = f.model().split(f.theta());
                f.model().system().inner_theta(system)
            }
        }
    }

    /// Whether the fitted model is stable: every pole of the rational part B/A strictly
    /// inside the unit circle (z) or in the open left half plane (s), and, with a noise
    /// model H = C/D, every root of D strictly inside the unit circle. A model whose poles
    /// cannot be computed (non-finite θ) is not stable.
    pub fn is_stable(&self) -> bool {
        let system = self
            .rational()
            .is_stable(self.rational_theta())
            .unwrap_or(false);
        let noise = match self {
            RationalFit::NoiseModel(f) => Some((f.model().noise(), f.model().split(f.theta()).1)),
            RationalFit::DelayedNoiseModel(f) => {
                Some((f.model().noise(), f.model().split(f.theta()).1))
            }
            _ => None,
        };
        let noise_stable = noise.is_none_or(|(h, eta)| {
            h.poles(eta)
                .map(|p| p.iter().all(|z| z.norm() < 1.0))
                .unwrap_or(false)
        });
        system && noise_stable
    }

    /// Whether the model has a delay factor.
    pub fn has_delay(&self) -> bool {
        matches!(
            self,
            RationalFit::Delayed(_) | RationalFit::DelayedNoiseModel(_)
        )
    }

    /// The noise model H = C/D, if any.
    pub fn noise_model(&self) -> Option<NoiseModel<f64>> {
        match self {
            RationalFit::NoiseModel(f) => Some(f.model().noise()),
            RationalFit::DelayedNoiseModel(f) => Some(f.model().noise()),
            _ => None,
        }
    }

    /// The estimate θ̂ in the fitted model's layout.
    pub fn theta(&self) -> &[f64] {
        each_fit!(self, f => f.theta())
    }

    /// The cost V at θ̂.
    pub fn cost(&self) -> f64 {
        each_fit!(self, f => f.cost())
    }

    /// The validation statistics of the fit (cost and whiteness tests).
    pub fn validation(&self) -> &crate::validation::Validation {
        each_fit!(self, f => f.validation())
    }

    /// The model structure's name in a saved model's `kind` key: `rational`, `delayed`,
    /// `noise_model` or `delayed_noise_model`.
    pub fn kind(&self) -> &'static str {
        match self {
            RationalFit::Plain(_) => "rational",
            RationalFit::Delayed(_) => "delayed",
            RationalFit::NoiseModel(_) => "noise_model",
            RationalFit::DelayedNoiseModel(_) => "delayed_noise_model",
        }
    }

    /// Poles of the system part.
    ///
    /// # Errors
    /// As [`crate::model::PolesZeros::poles`].
    pub fn poles(&self) -> Result<Vec<Complex<f64>>> {
        each_fit!(self, f => f.poles())
    }

    /// The number of estimated parameters p.
    pub fn n_params(&self) -> usize {
        each_fit!(self, f => f.model().n_params())
    }

    /// The lines the fit was made on: the [`interior_lines`] of `data` for a noise model
    /// without delay ([`fit_noise_model`] drops DC and Nyquist), else `data` itself.
    ///
    /// # Errors
    /// As [`interior_lines`].
    pub fn lines<'d>(&self, data: &'d FrequencyData<f64>) -> Result<Cow<'d, FrequencyData<f64>>> {
        match self {
            RationalFit::NoiseModel(_) => Ok(Cow::Owned(interior_lines(data)?)),
            _ => Ok(Cow::Borrowed(data)),
        }
    }
}

/// One member of each complex pair (im > 0) and the real values of `poles`, reflected
/// into the left half-plane (a pole on the imaginary axis moved left by ε|p|): basis
/// poles of the partial-fraction form. Members with im < 0 are dropped, so a set closed
/// under conjugation gives a basis of its own order.
fn left_half_plane_members(poles: &[Complex<f64>]) -> Vec<Complex<f64>> {
    poles
        .iter()
        .filter(|q| q.im >= 0.0)
        .map(|q| {
            let re = if q.re > 0.0 {
                -q.re
            } else if q.re == 0.0 {
                -f64::EPSILON * q.norm().max(f64::MIN_POSITIVE)
            } else {
                q.re
            };
            Complex::new(re, q.im)
        })
        .collect()
}
