//! Time variation named from a periodic record's skirts around the excited lines
//! ([`TimeVariation`]), and both tests of time variation, the skirts and the parameter
//! drift, as one detector ([`TimeVariationTests`]).
use super::{TimeDrift, TimeDriftDetail};
use crate::data::FrequencyData;
use crate::workflow::finding::{
    Context, Detail, DetailFields, Detector, Effect, Finding, NamedValues, Remedy, present,
};
use crate::workflow::lrt::f_sf;
use crate::workflow::spec::SpecFit;

/// Skirts around the excited lines of a periodic record: a time-varying system.
///
/// Take the DFT of the whole record of N = P M samples (McKelvey eq. 1): the periodic
/// excitation and the steady-state response of a time-invariant system (linear or not)
/// live on the lines l = kP of the period grid; the lines in between hold noise only, of
/// a spectrum that is smooth in frequency. A time-varying system multiplies the response
/// by functions of t: with coefficients polynomial in t the output holds terms
/// tᵖ x(t), x periodic, whose spectrum is the spectrum of tᵖ, a hyperbola in the offset
/// |l − kP|, pasted around every excited line kP (Lataire and Pintelon, *Frequency domain
/// total least squares estimator of time-varying systems*, eq. 17 and appendix VII-B:
/// the "skirts"). So time variation concentrates power on the lines next to the excited
/// ones, unlike nonlinear distortion (periodic: only on the lines kP) and unlike noise or
/// a transient (smooth over the in-between lines).
///
/// With K the excited period lines (the fitted data's frequencies), the *adjacent* lines
/// A = {kP ± 1 : k ∈ K} and the *reference* lines R = {kP ± j : 2 ≤ j ≤ P − 2, k ∈ K} ∖ A
/// (P ≥ 4; lines 0 and N/2 and the multiples of P excluded) interleave, so under
/// "time-invariant system, noise with a smooth spectrum" the mean output powers
/// P_A = mean_{l∈A} |Y_l|², P_R = mean_{l∈R} |Y_l|² estimate the same variance from
/// independent complex normal lines and F = P_A/P_R ~ F(2|A|, 2|R|); the one-sided
/// p-value is P(F(2|A|, 2|R|) > F).
///
/// Applies when the [`Context`] holds the periodic record ([`Context::with_record`]) of
/// P ≥ 4 periods and every fitted line is on its period grid; `None` otherwise.
///
/// An LTI [`ModelSpec`](crate::workflow::ModelSpec) cannot absorb a time-varying system
/// ([`Remedy::NotAbsorbed`]): the workflow names the effect, stops refining the LTI model
/// and reports it as unmodelled; a time-varying model is [`crate::ltv`] (fitted on the
/// time record, outside the workflow), or the piecewise time-invariant model the
/// workflow switches to with [`TimeVariationTests::switching`]. Proposal: the current spec
/// unchanged. Detail: [`TimeVariationDetail`].
#[derive(Debug, Clone, Copy, Default)]
pub struct TimeVariation;

impl Detector for TimeVariation {
    fn effect(&self) -> Effect {
        Effect::TimeVariation
    }

    fn measurement(&self) -> bool {
        true
    }

    fn detect(&self, _data: &FrequencyData<f64>, fit: &SpecFit, ctx: &Context) -> Option<Finding> {
        let rec = ctx.record.as_ref()?;
        let p = rec.periods();
        if p < 4 {
            return None;
        }
        let excited = rec.period_lines(&fit.omega)?;
        let full = rec.record().dft();
        let n_lines = full.len(); // ⌊N/2⌋ + 1
        let n = rec.record().len();
        let usable = |l: usize| {
            l > 0 && l < n_lines && !(n.is_multiple_of(2) && l == n / 2) && !l.is_multiple_of(p)
        };
        let mut adjacent = vec![false; n_lines];
        let mut reference = vec![false; n_lines];
        let mut output = 0.0;
        for &k in &excited {
            let c = k * p;
            if c < n_lines {
                output += full.y()[c].norm_sqr();
            }
            // offsets j = 1 (adjacent) and 2 … P − 2 (reference) on both sides
            for j in 1..p - 1 {
                let sides = [Some(c + j), c.checked_sub(j)];
                for l in sides.into_iter().flatten() {
                    if usable(l) {
                        if j == 1 {
                            adjacent[l] = true;
                        } else {
                            reference[l] = true;
                        }
                    }
                }
            }
        }
        let pick = |set: &[bool], not: &[bool]| -> (usize, f64) {
            let mut count = 0;
            let mut sum = 0.0;
            for (l, (s, x)) in set.iter().zip(not).enumerate() {
                if *s && !*x {
                    count += 1;
                    sum += full.y()[l].norm_sqr();
                }
            }
            (count, sum)
        };
        let none = vec![false; n_lines];
        let (na, sa) = pick(&adjacent, &none);
        let (nr, sr) = pick(&reference, &adjacent);
        if na == 0 || nr == 0 || !(sr > 0.0) {
            return None;
        }
        let (pa, pr) = (sa / na as f64, sr / nr as f64);
        let ratio = pa / pr;
        let p_value = f_sf(ratio, 2.0 * na as f64, 2.0 * nr as f64);
        let output = output / excited.len() as f64;
        let excess = pa > pr;
        let detail = TimeVariationDetail {
            skirt_ratio: ratio,
            skirt_to_noise_db: excess.then(|| 10.0 * ((pa - pr) / pr).log10()),
            skirt_to_output_db: (excess && output > 0.0)
                .then(|| 10.0 * ((pa - pr) / output).log10()),
            adjacent_lines: na,
            reference_lines: nr,
        };
        Some(Finding {
            effect: Effect::TimeVariation,
            statistic: ratio,
            p_value,
            detail: Detail::TimeVariation(detail),
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

/// Both tests of time variation as one measurement-level detector: the skirts around the
/// excited lines ([`TimeVariation`], periodic records) and the parameter drift between
/// time segments ([`TimeDrift`], periodic or non-periodic records).
///
/// With the p-values p₁ … p_m of the tests that apply (m ≤ 2), the finding's p-value is
/// min(1, m · min_i p_i) (Bonferroni), so that on a time-invariant system it falls below
/// any level α with probability at most α; the workflow then tests it at α/(2m′) among its
/// m′ measurement-level detectors, as any other. Statistic: that of the smaller p-value's
/// test. Detail: [`TimeVariationTestsDetail`]. `None` when neither applies. Remedy:
/// [`Remedy::NotAbsorbed`]: an LTI model cannot absorb the effect; with `piecewise` the
/// workflow then switches to the piecewise time-invariant model
/// ([`piecewise_model`](super::piecewise_model), [`TimeVariationTests::switching`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct TimeVariationTests {
    /// The drift test (its number of segments).
    pub drift: TimeDrift,
    /// Whether the workflow switches to the piecewise time-invariant model on the drift
    /// test's S segments when it names the effect ([`Detector::piecewise_segments`],
    /// [`piecewise_model`](super::piecewise_model)); `false` by default (the effect is
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

    /// Model-based when the drift test (which assumes the structure is adequate) carries
    /// the finding: the skirt test does not apply or is the less significant of the two.
    fn model_based(&self, finding: &Finding) -> bool {
        let Some(detail) = finding.detail.time_variation_tests() else {
            return false;
        };
        match (detail.skirt_p, detail.drift_p) {
            (Some(skirt), Some(drift)) => drift < skirt,
            (None, Some(_)) => true,
            _ => false,
        }
    }

    fn detect(&self, data: &FrequencyData<f64>, fit: &SpecFit, ctx: &Context) -> Option<Finding> {
        let skirt = TimeVariation.detect(data, fit, ctx);
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

/// The detail of a [`TimeVariation`] finding (the skirt test).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimeVariationDetail {
    /// The statistic F = P_A/P_R, named `skirt_ratio`.
    pub skirt_ratio: f64,
    /// 10 log₁₀((P_A − P_R)/P_R), present when P_A > P_R, named `skirt_to_noise_db`.
    pub skirt_to_noise_db: Option<f64>,
    /// The same excess relative to the mean output power at the excited lines (dB),
    /// present when P_A > P_R and that power is positive, named `skirt_to_output_db`.
    pub skirt_to_output_db: Option<f64>,
    /// The number |A| of adjacent lines, named `adjacent_lines`.
    pub adjacent_lines: usize,
    /// The number |R| of reference lines, named `reference_lines`.
    pub reference_lines: usize,
}

impl DetailFields for TimeVariationDetail {
    fn entries(&self) -> Vec<(&'static str, f64)> {
        present([
            ("skirt_ratio", Some(self.skirt_ratio)),
            ("skirt_to_noise_db", self.skirt_to_noise_db),
            ("skirt_to_output_db", self.skirt_to_output_db),
            ("adjacent_lines", Some(self.adjacent_lines as f64)),
            ("reference_lines", Some(self.reference_lines as f64)),
        ])
    }

    fn take_from(values: &mut NamedValues) -> Option<Self> {
        Some(Self {
            skirt_ratio: values.take("skirt_ratio")?,
            skirt_to_noise_db: values.take("skirt_to_noise_db"),
            skirt_to_output_db: values.take("skirt_to_output_db"),
            adjacent_lines: values.take_count("adjacent_lines")?,
            reference_lines: values.take_count("reference_lines")?,
        })
    }
}
