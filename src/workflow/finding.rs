//! Findings: a named effect, its test statistic and p-value, and the model augmentation
//! that would explain it.
use super::spec::SpecFit;
use crate::data::DistortionAnalysis;
use crate::data::{FrequencyData, TimeData};
use crate::error::FdidError;
use crate::estimate::ModelSpec;
use std::sync::Arc;

/// The effects the workflow names (issue names via [`Effect::as_str`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum Effect {
    /// A linear phase trend in ω: a missing time delay.
    TimeDelay,
    /// A localised peak of the normalised residual: a missing lightly damped pole pair.
    MissingResonance,
    /// A broadband slope mismatch: a missing pole.
    MissingPole,
    /// A broadband slope mismatch: a missing zero.
    MissingZero,
    /// A smooth residual of a non-periodic record: the missing transient term.
    Transient,
    /// Skirts around excited lines or drifting parameters: a time-varying system.
    TimeVariation,
    /// Energy at non-excited lines of a multisine: nonlinear distortion.
    NonlinearDistortion,
    /// Residual variance varying with frequency: coloured noise.
    ColoredNoise,
    /// Significant input noise: errors-in-variables.
    InputNoise,
}

impl Effect {
    /// The effect's name: `time_delay`, `missing_resonance`, `missing_pole`,
    /// `missing_zero`, `transient`, `time_variation`, `nonlinear_distortion`,
    /// `colored_noise`, `input_noise`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::TimeDelay => "time_delay",
            Self::MissingResonance => "missing_resonance",
            Self::MissingPole => "missing_pole",
            Self::MissingZero => "missing_zero",
            Self::Transient => "transient",
            Self::TimeVariation => "time_variation",
            Self::NonlinearDistortion => "nonlinear_distortion",
            Self::ColoredNoise => "colored_noise",
            Self::InputNoise => "input_noise",
        }
    }
}

impl std::fmt::Display for Effect {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Named values describing a finding (e.g. `peak_omega`, `slope`); serialised as a JSON
/// object `{name: value, …}`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Detail(pub Vec<(String, f64)>);

impl Detail {
    /// Adds a named value.
    #[must_use]
    pub fn with(mut self, name: &str, value: f64) -> Self {
        self.0.push((name.to_string(), value));
        self
    }

    /// The value named `name`, if present.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.0.iter().find(|(n, _)| n == name).map(|(_, v)| *v)
    }
}

#[cfg(feature = "serde")]
impl serde::Serialize for Detail {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = s.serialize_map(Some(self.0.len()))?;
        for (k, v) in &self.0 {
            m.serialize_entry(k, v)?;
        }
        m.end()
    }
}

#[cfg(feature = "serde")]
impl<'de> serde::Deserialize<'de> for Detail {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let m = std::collections::BTreeMap::<String, f64>::deserialize(d)?;
        Ok(Self(m.into_iter().collect()))
    }
}

/// One detector's evidence.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Finding {
    /// The effect named.
    pub effect: Effect,
    /// The test statistic (its meaning is documented by each detector).
    pub statistic: f64,
    /// The p-value under "the model is right and the residual is noise" (corrected for
    /// multiple comparisons where the detector scans).
    pub p_value: f64,
    /// Named values (e.g. the peak frequency).
    pub detail: Detail,
    /// The augmented model that would explain the effect.
    pub proposal: ModelSpec,
}

/// A periodic time record behind the averaged spectra that are fitted: `periods` periods
/// of M = N/`periods` samples, steady state (warm-up dropped). The measurement-level
/// detectors ([`NonlinearDistortion`](super::detectors::NonlinearDistortion),
/// [`TimeVariation`](super::detectors::TimeVariation)) read the lines the averaged,
/// excited-line data do not hold: the non-excited lines of the period grid and the lines
/// between them in the DFT of the whole record.
#[derive(Debug, Clone, PartialEq)]
pub struct PeriodicRecord {
    record: TimeData<f64>,
    periods: usize,
}

impl PeriodicRecord {
    /// The record of `periods` periods.
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] named `"periods"` when `periods < 2` or the record
    /// length is not a multiple of it; [`FdidError::TooShort`] when a period has fewer
    /// than 4 samples.
    pub fn new(record: TimeData<f64>, periods: usize) -> crate::error::Result<Self> {
        if periods < 2 || !record.len().is_multiple_of(periods) {
            return Err(FdidError::InvalidArgument {
                name: "periods",
                value: periods.to_string(),
                reason: format!(
                    "need at least 2 periods dividing the record length {}",
                    record.len()
                ),
            });
        }
        let m = record.len() / periods;
        if m < 4 {
            return Err(FdidError::TooShort {
                what: "samples per period",
                needed: 4,
                got: m,
            });
        }
        Ok(Self { record, periods })
    }

    /// The time record.
    pub fn record(&self) -> &TimeData<f64> {
        &self.record
    }

    /// The number of periods P.
    pub fn periods(&self) -> usize {
        self.periods
    }

    /// Samples per period M = N/P.
    pub fn period_len(&self) -> usize {
        self.record.len() / self.periods
    }

    /// The period-grid line numbers k (ω = 2πk/(M Ts)) of the frequencies `omega`, or
    /// `None` when one of them is not on the grid (relative mismatch above 10⁻⁶ of a line)
    /// or lies beyond the Nyquist line.
    pub fn period_lines(&self, omega: &[f64]) -> Option<Vec<usize>> {
        let m = self.period_len();
        let step = std::f64::consts::TAU / (m as f64 * self.record.ts());
        omega
            .iter()
            .map(|w| {
                let k = w / step;
                let r = k.round();
                ((k - r).abs() < 1e-6 && r >= 0.0 && r <= (m / 2) as f64).then_some(r as usize)
            })
            .collect()
    }
}

/// What the detectors know about the measurement.
///
/// Built by [`Context::periodic`], [`Context::non_periodic`] or
/// [`Context::frequency_data`]; the measurement-level detectors need more than the fitted
/// lines: [`Context::with_record`] attaches the periodic time record,
/// [`Context::with_time_record`] a non-periodic one,
/// [`Context::with_distortion`] a nonlinear distortion analysis (e.g. over several phase
/// realisations). Without them those detectors do not apply.
#[derive(Debug, Clone, PartialEq)]
pub struct Context {
    /// Whether the data are the averaged spectra of a periodic record (no transient,
    /// no leakage); `false` for the DFT of one non-periodic record or for frequency data.
    pub periodic: bool,
    /// Whether the data are the DFT of a time record (a transient can exist).
    pub time_record: bool,
    /// The false-alarm level α of each test.
    pub alpha: f64,
    /// The periodic time record behind the data, if known.
    pub record: Option<Arc<PeriodicRecord>>,
    /// The non-periodic time record whose DFT ([`TimeData::dft`]) holds the fitted lines,
    /// if known ([`Context::with_time_record`]).
    pub time: Option<Arc<TimeData<f64>>>,
    /// A nonlinear distortion analysis of the measurement (odd random-phase multisine),
    /// if known; else [`NonlinearDistortion`](super::detectors::NonlinearDistortion)
    /// builds one from `record`.
    pub distortion: Option<Arc<DistortionAnalysis<f64>>>,
}

impl Context {
    /// The context of the averaged spectra of a periodic record at level `alpha`.
    pub fn periodic(alpha: f64) -> Self {
        Self {
            periodic: true,
            time_record: true,
            alpha,
            record: None,
            time: None,
            distortion: None,
        }
    }

    /// The context of frequency data without a time record (no transient, no noise
    /// model) at level `alpha`.
    pub fn frequency_data(alpha: f64) -> Self {
        Self {
            periodic: false,
            time_record: false,
            ..Self::periodic(alpha)
        }
    }

    /// The context of the DFT of one non-periodic record at level `alpha`.
    pub fn non_periodic(alpha: f64) -> Self {
        Self {
            periodic: false,
            time_record: true,
            ..Self::periodic(alpha)
        }
    }

    /// Attaches the periodic time record of `periods` periods whose averaged spectra
    /// ([`TimeData::average_periods`]) are the fitted data.
    ///
    /// ```
    /// use fdid::prelude::*;
    /// use fdid::simulate::{Multisine, SplitMix64};
    /// use fdid::workflow::{Context, Effect, ModelSpec, Workflow};
    /// # fn main() -> fdid::Result<()> {
    /// // y(t) = 0.5 u(t) + a(t) y(t−1), a drifting from 0.5 to 0.6: a time-varying system
    /// let (m, p) = (256, 6);
    /// let lines: Vec<usize> = (1..=60).collect();
    /// let ms = Multisine::from_lines(m as f64, lines.clone(), vec![1.0; 60], (0..60).map(|k| k as f64).collect())?;
    /// let u = ms.sample(1.0, (p + 1) * m);
    /// let mut rng = SplitMix64::new(1);
    /// let mut y = vec![0.0; u.len()];
    /// for t in 1..u.len() {
    ///     let a = 0.5 + 0.1 * t as f64 / u.len() as f64;
    ///     y[t] = 0.5 * u[t] + a * y[t - 1];
    /// }
    /// let y: Vec<f64> = y.iter().map(|v| v + 0.01 * rng.gaussian()).collect();
    /// let record = TimeData::new(u[m..].to_vec(), y[m..].to_vec(), 1.0)?;
    /// let all = record.average_periods(p)?;
    /// let keep: Vec<bool> = (0..all.len()).map(|k| lines.contains(&k)).collect();
    /// let data = all.select_lines(&keep)?;
    /// let ctx = Context::periodic(0.05).with_record(record, p)?;
    /// let report = Workflow::naming_time_variation().run(&data, ModelSpec::discrete(1, 0, 1.0), ctx)?;
    /// assert_eq!(report.effects.first(), Some(&Effect::TimeVariation));
    /// assert_eq!(report.unmodelled, vec![Effect::TimeVariation]);
    /// # Ok(())
    /// # }
    /// ```
    ///
    /// # Errors
    /// As [`PeriodicRecord::new`].
    pub fn with_record(
        mut self,
        record: TimeData<f64>,
        periods: usize,
    ) -> crate::error::Result<Self> {
        self.record = Some(Arc::new(PeriodicRecord::new(record, periods)?));
        Ok(self)
    }

    /// Attaches the non-periodic time record whose DFT ([`TimeData::dft`], McKelvey eq. 1)
    /// holds the fitted lines, for the tests that split it in time
    /// ([`TimeDrift`](super::detectors::TimeDrift)).
    #[must_use]
    pub fn with_time_record(mut self, record: TimeData<f64>) -> Self {
        self.time = Some(Arc::new(record));
        self
    }

    /// Attaches a nonlinear distortion analysis of the measurement.
    #[must_use]
    pub fn with_distortion(mut self, analysis: DistortionAnalysis<f64>) -> Self {
        self.distortion = Some(Arc::new(analysis));
        self
    }
}

/// How the workflow acts on a significant finding ([`Detector::remedy`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Remedy {
    /// Refit [`Finding::proposal`] (a larger model) on the same data; the step is kept
    /// when the nested likelihood-ratio test accepts it.
    Refit,
    /// Refit [`Finding::proposal`] under another criterion (e.g. errors-in-variables,
    /// McKelvey eq. 42): the weighting changes, so the nested likelihood-ratio test does
    /// not apply. The step is kept when the detector's test is significant and the full
    /// negative log-likelihood Σ(ln|c_k|² + |r_k|²) (c_k the line's normaliser, so the
    /// log-determinant of the noise variances is included) decreases.
    Criterion,
    /// Keep the model, change the noise reference: refit the current spec on these data
    /// (same lines, new noise variances). The step is kept on the detector's own test; the
    /// workflow continues on the new data.
    NoiseReference(FrequencyData<f64>),
    /// The effect lies outside the model class (e.g. a time-varying system for an LTI
    /// spec): the workflow names it and stops refining the model. It records the effect
    /// as unmodelled, unless the detector names a piecewise time-invariant model
    /// ([`Detector::piecewise_segments`]) that the F test accepts and whose segment fits
    /// are consistent with the noise ([`Workflow::run`](super::Workflow::run)).
    NotAbsorbed,
}

/// A test for one effect on the residuals of a fit.
pub trait Detector {
    /// The effect this detector names.
    fn effect(&self) -> Effect;

    /// The finding on `fit` of `data`, or `None` when the test does not apply (e.g. the
    /// effect is already in the model) or cannot be computed. The finding is returned
    /// whatever its p-value: the caller compares it with the level.
    fn detect(&self, data: &FrequencyData<f64>, fit: &SpecFit, ctx: &Context) -> Option<Finding>;

    /// Whether the detector tests the measurement (noise reference, criterion, time
    /// invariance) rather than the model structure. Such detectors run at every step, even
    /// when the fit is consistent with the noise (the stated noise may hide the effect),
    /// and their significant findings are acted on before the structural ones: the
    /// likelihood-ratio tests of structural steps assume the residual is noise at the
    /// stated level. Default `false`.
    fn measurement(&self) -> bool {
        false
    }

    /// The number S of time segments of the piecewise time-invariant model
    /// ([`piecewise_model`](super::detectors::piecewise_model)) the workflow switches to
    /// when this detector's finding is acted on by [`Remedy::NotAbsorbed`] (the effect is
    /// outside the LTI model class); `None` (the default): no switch, the effect stays
    /// unmodelled.
    fn piecewise_segments(&self) -> Option<usize> {
        None
    }

    /// How to act on `finding` (from this detector on `fit` of `data`); `None` when it
    /// cannot be acted on. Default [`Remedy::Refit`].
    fn remedy(
        &self,
        _data: &FrequencyData<f64>,
        _fit: &SpecFit,
        _ctx: &Context,
        _finding: &Finding,
    ) -> Option<Remedy> {
        Some(Remedy::Refit)
    }
}

/// The scale λ of the normalised residuals ([`SpecFit::residual_scale`]).
pub(crate) fn noise_scale(fit: &SpecFit) -> f64 {
    fit.residual_scale()
}

/// Per-line moments (mean, variance) of |r_k|² under the null: 1 and 1 for exact noise
/// variances (|r|² ~ ½χ²(2)); F(2, 2ν) moments for sample variances with ν degrees of
/// freedom; residuals scaled by λ̂ when the noise level is estimated.
pub(crate) fn residual_power(fit: &SpecFit) -> (Vec<f64>, f64, f64) {
    let lambda = noise_scale(fit);
    let power = fit
        .residuals
        .iter()
        .map(|r| r.norm_sqr() / lambda)
        .collect();
    match fit.variance_dof.filter(|_| fit.noise_known) {
        Some(dof) if dof > 2 => {
            let d2 = 2.0 * dof as f64;
            let mean = d2 / (d2 - 2.0);
            let var = d2.powi(3) / ((d2 - 2.0).powi(2) * (d2 - 4.0));
            (power, mean, var)
        }
        _ => (power, 1.0, 1.0),
    }
}
