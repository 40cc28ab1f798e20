//! Findings: a named effect, its test statistic and p-value, and the model augmentation
//! that would explain it.
use super::detectors::{
    ColoredNoiseDetail, InputNoiseDetail, MissingResonanceDetail, NonlinearDistortionDetail,
    OrderIncreaseDetail, TimeDelayDetail, TimeDriftDetail, TimeVariationDetail,
    TimeVariationTestsDetail, TransientDetail,
};
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

/// The named values a detector reports with its finding, one typed record per detector
/// (see each detector for what its values mean). [`Detail::entries`] lists them by name,
/// in the detector's order: the names of the JSON object `{name: value, …}` the detail
/// serialises to, and of the `fdid diagnose` report.
#[derive(Debug, Clone, PartialEq)]
pub enum Detail {
    /// Of [`TimeDelay`](super::detectors::TimeDelay).
    TimeDelay(TimeDelayDetail),
    /// Of [`MissingResonance`](super::detectors::MissingResonance).
    MissingResonance(MissingResonanceDetail),
    /// Of [`Transient`](super::detectors::Transient).
    Transient(TransientDetail),
    /// Of [`ColoredNoise`](super::detectors::ColoredNoise).
    ColoredNoise(ColoredNoiseDetail),
    /// Of [`OrderIncrease`](super::detectors::OrderIncrease).
    OrderIncrease(OrderIncreaseDetail),
    /// Of [`InputNoise`](super::detectors::InputNoise).
    InputNoise(InputNoiseDetail),
    /// Of [`NonlinearDistortion`](super::detectors::NonlinearDistortion).
    NonlinearDistortion(NonlinearDistortionDetail),
    /// Of [`TimeVariation`](super::detectors::TimeVariation) (the skirt test).
    TimeVariation(TimeVariationDetail),
    /// Of [`TimeDrift`](super::detectors::TimeDrift) (the parameter drift test).
    TimeDrift(TimeDriftDetail),
    /// Of [`TimeVariationTests`](super::detectors::TimeVariationTests) (both tests).
    TimeVariationTests(TimeVariationTestsDetail),
    /// Named values of a detector defined outside this crate (a JSON object that is no
    /// detector's detail reads back as this, its names in sorted order).
    Custom(Vec<(String, f64)>),
}

/// Generates, for each typed variant of [`Detail`], its accessor and its arms of
/// [`Detail::entries`] and of the reading of named values.
macro_rules! detail_variants {
    ($($variant:ident($ty:ty) => $accessor:ident),* $(,)?) => {
        impl Detail {
            $(
                #[doc = concat!("The detail of [`", stringify!($variant),
                    "`](super::detectors::", stringify!($variant), "), if it is one.")]
                pub fn $accessor(&self) -> Option<&$ty> {
                    match self {
                        Self::$variant(d) => Some(d),
                        _ => None,
                    }
                }
            )*

            /// The named values, in the detector's order.
            pub fn entries(&self) -> Vec<(&str, f64)> {
                match self {
                    $(Self::$variant(d) => d.entries(),)*
                    Self::Custom(v) => v.iter().map(|(k, v)| (k.as_str(), *v)).collect(),
                }
            }

            /// The typed detail whose names are exactly those of `values`, else
            /// [`Detail::Custom`].
            #[cfg_attr(not(feature = "serde"), allow(dead_code))]
            fn from_entries(values: Vec<(String, f64)>) -> Self {
                $(
                    if let Some(d) = NamedValues::read::<$ty>(&values) {
                        return Self::$variant(d);
                    }
                )*
                Self::Custom(values)
            }
        }
    };
}

detail_variants! {
    TimeDelay(TimeDelayDetail) => time_delay,
    MissingResonance(MissingResonanceDetail) => missing_resonance,
    Transient(TransientDetail) => transient,
    ColoredNoise(ColoredNoiseDetail) => colored_noise,
    OrderIncrease(OrderIncreaseDetail) => order_increase,
    InputNoise(InputNoiseDetail) => input_noise,
    NonlinearDistortion(NonlinearDistortionDetail) => nonlinear_distortion,
    TimeVariation(TimeVariationDetail) => time_variation,
    TimeDrift(TimeDriftDetail) => time_drift,
    TimeVariationTests(TimeVariationTestsDetail) => time_variation_tests,
}

/// A detector's typed detail as named values: [`Detail::entries`] and the way back.
pub(crate) trait DetailFields: Sized {
    /// The named values, in the detector's order (optional values only when present).
    fn entries(&self) -> Vec<(&'static str, f64)>;

    /// The detail from `values`, taking the names it reads; `None` when a name it needs
    /// is missing or its value is malformed.
    fn take_from(values: &mut NamedValues) -> Option<Self>;
}

/// The values of `named` that are present, in order: the entries of a detail with
/// optional values.
pub(crate) fn present<const N: usize>(
    named: [(&'static str, Option<f64>); N],
) -> Vec<(&'static str, f64)> {
    named
        .into_iter()
        .filter_map(|(name, v)| v.map(|v| (name, v)))
        .collect()
}

/// Named values being read back into a typed detail ([`DetailFields::take_from`]).
pub(crate) struct NamedValues(Vec<(String, f64)>);

impl NamedValues {
    /// The typed detail `D` whose names are exactly those of `values`.
    fn read<D: DetailFields>(values: &[(String, f64)]) -> Option<D> {
        let mut rest = Self(values.to_vec());
        let detail = D::take_from(&mut rest)?;
        rest.0.is_empty().then_some(detail)
    }

    /// The value named `name`, removed from the rest.
    pub(crate) fn take(&mut self, name: &str) -> Option<f64> {
        let i = self.0.iter().position(|(n, _)| n == name)?;
        Some(self.0.remove(i).1)
    }

    /// The count named `name` (a non-negative whole number), removed from the rest.
    pub(crate) fn take_count(&mut self, name: &str) -> Option<usize> {
        let v = self.take(name)?;
        (v >= 0.0 && v.fract() == 0.0).then_some(v as usize)
    }
}

#[cfg(feature = "serde")]
impl serde::Serialize for Detail {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let entries = self.entries();
        let mut m = s.serialize_map(Some(entries.len()))?;
        for (k, v) in &entries {
            m.serialize_entry(k, v)?;
        }
        m.end()
    }
}

#[cfg(feature = "serde")]
impl<'de> serde::Deserialize<'de> for Detail {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let m = std::collections::BTreeMap::<String, f64>::deserialize(d)?;
        Ok(Self::from_entries(m.into_iter().collect()))
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
    /// The detector's named values (e.g. the peak frequency).
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

    /// Whether `finding` (of this measurement-level detector) rests on a test that assumes
    /// the model is adequate, its residuals noise (e.g. the drift of the parameters fitted
    /// on time segments): such a finding is not acted on while structural detectors fire,
    /// since a missing pole or delay makes the segment fits disagree too. Default `false`.
    fn model_based(&self, finding: &Finding) -> bool {
        let _ = finding;
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

#[cfg(test)]
mod tests {
    use super::*;

    fn skirt(db: Option<f64>) -> TimeVariationDetail {
        TimeVariationDetail {
            skirt_ratio: 1.5,
            skirt_to_noise_db: db,
            skirt_to_output_db: db.map(|v| v - 20.0),
            adjacent_lines: 100,
            reference_lines: 300,
        }
    }

    fn drift() -> TimeDriftDetail {
        TimeDriftDetail {
            drift_statistic: 12.5,
            drift_dof: 5,
            segments: 2,
            largest_shift: 2.5,
        }
    }

    /// One detail of each kind (optional values present and absent) with its names in
    /// order.
    fn cases() -> Vec<(Detail, Vec<&'static str>)> {
        let mut cases = structural_cases();
        cases.extend(measurement_cases());
        cases.push((
            Detail::Custom(vec![("a".into(), 1.0), ("b".into(), 2.0)]),
            vec!["a", "b"],
        ));
        cases
    }

    /// The details of the structural detectors.
    fn structural_cases() -> Vec<(Detail, Vec<&'static str>)> {
        vec![
            (
                Detail::TimeDelay(TimeDelayDetail {
                    slope: 0.25,
                    slope_std: 0.01,
                    t: 25.0,
                }),
                vec!["slope", "slope_std", "t"],
            ),
            (
                Detail::MissingResonance(MissingResonanceDetail {
                    peak_hz: 1.2,
                    width_hz: 0.1,
                    damping: 0.1 / 2.4,
                    lines: 5,
                }),
                vec!["peak_hz", "width_hz", "damping", "lines"],
            ),
            (
                Detail::Transient(TransientDetail {
                    explained: 30.0,
                    dof: 6,
                }),
                vec!["explained", "dof"],
            ),
            (
                Detail::ColoredNoise(ColoredNoiseDetail {
                    blocks: 12,
                    ratio: 3.0,
                }),
                vec!["blocks", "ratio"],
            ),
            (
                Detail::OrderIncrease(OrderIncreaseDetail {
                    coefficient: -0.1,
                    std: 0.02,
                    t: -5.0,
                }),
                vec!["coefficient", "std", "t"],
            ),
        ]
    }

    /// The details of the measurement-level detectors.
    fn measurement_cases() -> Vec<(Detail, Vec<&'static str>)> {
        vec![
            (
                Detail::InputNoise(InputNoiseDetail {
                    excess: 0.3,
                    predicted_excess: 0.28,
                    score_p: 1e-9,
                    consistent_p: 0.4,
                    input_to_output: 0.29,
                    input_snr_db: 30.0,
                }),
                vec![
                    "excess",
                    "predicted_excess",
                    "score_p",
                    "consistent_p",
                    "input_to_output",
                    "input_snr_db",
                ],
            ),
            (
                Detail::NonlinearDistortion(NonlinearDistortionDetail {
                    odd_p: Some(1e-12),
                    odd_db: Some(-40.0),
                    even_p: Some(0.3),
                    even_db: None,
                    noise_db: -60.0,
                    distortion_to_noise_db: Some(10.0),
                    realisations: 1,
                }),
                vec![
                    "odd_p",
                    "odd_db",
                    "even_p",
                    "noise_db",
                    "distortion_to_noise_db",
                    "realisations",
                ],
            ),
            (
                Detail::NonlinearDistortion(NonlinearDistortionDetail {
                    odd_p: None,
                    odd_db: None,
                    even_p: Some(0.3),
                    even_db: Some(-50.0),
                    noise_db: -60.0,
                    distortion_to_noise_db: None,
                    realisations: 3,
                }),
                vec!["even_p", "even_db", "noise_db", "realisations"],
            ),
            (
                Detail::TimeVariation(skirt(Some(3.0))),
                vec![
                    "skirt_ratio",
                    "skirt_to_noise_db",
                    "skirt_to_output_db",
                    "adjacent_lines",
                    "reference_lines",
                ],
            ),
            (
                Detail::TimeVariation(skirt(None)),
                vec!["skirt_ratio", "adjacent_lines", "reference_lines"],
            ),
            (
                Detail::TimeDrift(drift()),
                vec!["drift_statistic", "drift_dof", "segments", "largest_shift"],
            ),
            (
                Detail::TimeVariationTests(TimeVariationTestsDetail {
                    skirt: Some(skirt(None)),
                    skirt_p: Some(0.01),
                    drift: Some(drift()),
                    drift_p: Some(0.02),
                }),
                vec![
                    "skirt_ratio",
                    "adjacent_lines",
                    "reference_lines",
                    "skirt_p",
                    "drift_statistic",
                    "drift_dof",
                    "segments",
                    "largest_shift",
                    "drift_p",
                ],
            ),
            (
                Detail::TimeVariationTests(TimeVariationTestsDetail {
                    skirt: None,
                    skirt_p: None,
                    drift: Some(drift()),
                    drift_p: Some(0.02),
                }),
                vec![
                    "drift_statistic",
                    "drift_dof",
                    "segments",
                    "largest_shift",
                    "drift_p",
                ],
            ),
        ]
    }

    #[test]
    fn entries_name_the_values_in_the_detectors_order() {
        for (detail, names) in cases() {
            let got: Vec<&str> = detail.entries().into_iter().map(|(n, _)| n).collect();
            assert_eq!(got, names, "{detail:?}");
        }
    }

    #[test]
    fn named_values_read_back_into_the_same_detail() {
        for (detail, _) in cases() {
            let mut values: Vec<(String, f64)> = detail
                .entries()
                .into_iter()
                .map(|(n, v)| (n.to_string(), v))
                .collect();
            // a typed detail from its names in any order (a custom one keeps the order)
            if !matches!(detail, Detail::Custom(_)) {
                values.reverse();
            }
            assert_eq!(Detail::from_entries(values), detail);
        }
    }

    #[test]
    fn other_names_read_back_as_custom() {
        let values = vec![
            ("slope".to_string(), 1.0),
            ("slope_std".to_string(), 0.1),
            ("t".to_string(), 10.0),
            ("extra".to_string(), 0.0),
        ];
        assert_eq!(Detail::from_entries(values.clone()), Detail::Custom(values));
        // a count that is not a whole number
        let values = vec![("explained".to_string(), 1.0), ("dof".to_string(), 2.5)];
        assert_eq!(Detail::from_entries(values.clone()), Detail::Custom(values));
        // the combined tests without either p-value
        let values = vec![("skirt_ratio".to_string(), 1.0)];
        assert_eq!(Detail::from_entries(values.clone()), Detail::Custom(values));
    }
}
