//! Findings: a named effect, its test statistic and p-value, and the model augmentation
//! that would explain it.
use super::spec::{ModelSpec, SpecFit};
use crate::FrequencyData;

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

/// What the detectors know about the measurement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Context {
    /// Whether the data are the averaged spectra of a periodic record (no transient,
    /// no leakage); `false` for the DFT of one non-periodic record or for frequency data.
    pub periodic: bool,
    /// Whether the data are the DFT of a time record (a transient can exist).
    pub time_record: bool,
    /// The false-alarm level α of each test.
    pub alpha: f64,
}

impl Context {
    /// The context of the averaged spectra of a periodic record at level `alpha`.
    pub fn periodic(alpha: f64) -> Self {
        Self {
            periodic: true,
            time_record: true,
            alpha,
        }
    }

    /// The context of frequency data without a time record (no transient, no noise
    /// model) at level `alpha`.
    pub fn frequency_data(alpha: f64) -> Self {
        Self {
            periodic: false,
            time_record: false,
            alpha,
        }
    }

    /// The context of the DFT of one non-periodic record at level `alpha`.
    pub fn non_periodic(alpha: f64) -> Self {
        Self {
            periodic: false,
            time_record: true,
            alpha,
        }
    }
}

/// A test for one effect on the residuals of a fit.
pub trait Detector {
    /// The effect this detector names.
    fn effect(&self) -> Effect;

    /// The finding on `fit` of `data`, or `None` when the test does not apply (e.g. the
    /// effect is already in the model) or cannot be computed. The finding is returned
    /// whatever its p-value: the caller compares it with the level.
    fn detect(&self, data: &FrequencyData<f64>, fit: &SpecFit, ctx: &Context) -> Option<Finding>;
}

/// The scale λ of the normalised residuals: 1 for a known noise level, else
/// λ̂ = V/(N − p/2) (λ̂ = V/N when there are no degrees of freedom left).
pub(crate) fn noise_scale(fit: &SpecFit) -> f64 {
    if fit.noise_known {
        return 1.0;
    }
    let dof = fit.residuals.len() as f64 - fit.n_params as f64 / 2.0;
    if dof > 0.0 {
        fit.cost / dof
    } else {
        fit.noise_variance
    }
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
