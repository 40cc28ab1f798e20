//! The distortion analysis of periodic records: its type, what it reports and how it is
//! assembled.

use super::bla::{Bla, interpolate_levels};
use super::line_plan::LinePlan;
use super::noise_of;
use super::realisations::{SpreadTest, same_grid};
use super::statistics::{DetectionLine, DetectionTest, detect};
use crate::data::{FrequencyData, NoiseVariances, PeriodicAverage, TimeData};
use crate::error::{FdidError, Result};
use crate::scalar::{Complex, Real};

/// Nonlinear distortion analysis of periodic records excited by an odd multisine, with
/// the best linear approximation (BLA).
///
/// Each record of `N = P M` samples (steady state: drop warm-up periods first) is averaged
/// over its `P ≥ 2` periods ([`PeriodicAverage`]: DFT of McKelvey eq. 1 per period, mean
/// `Ȳ_k, Ū_k`, noise variances of the mean `σ̂²_Y,k = s²_Y,k/P`, `σ̂²_U,k`, `σ̂_YU,k`
/// with `P − 1` degrees of freedom). Within the band `k_min ≤ k ≤ k_max`:
///
/// - **Detection** ([`DetectionTest`]): at the non-excited odd lines and, separately, at
///   the non-excited even lines, is there energy above the noise? Each
///   `|Ȳ_k|²/σ̂²_k ~ F(2, 2(P − 1))` under "noise only".
///   [`DistortionAnalysis::is_nonlinear`] fires when either p-value is below `α/m`
///   (Bonferroni over the `m ≤ 2` tests).
/// - **Levels**: output power at the excited lines `P_Y = mean_k |Ȳ_k|²`; noise power
///   `mean_k σ̂²_k` over all lines of the band; odd and even distortion powers
///   `mean (|Ȳ_k|² − σ̂²_k)` at the detection lines; all also in dB relative to `P_Y`.
/// - **Distortion at the excited lines**: an odd multisine's odd lines only receive
///   odd-degree distortion, whose level varies smoothly with frequency; so the per-line
///   odd detection levels `d_j = |Ȳ_j|² − σ̂²_j` are smoothed (mean over the line and its
///   two neighbouring odd detection lines), interpolated linearly in `k` to each excited
///   line (constant beyond the first and last detection line) and clipped at zero:
///   `σ̂²_S,k`, the output power of the stochastic nonlinear contribution.
/// - **BLA**: `Ĝ_k = Ȳ_k / Ū_k` at the excited lines, with the noise variance (first
///   order in the noise)
///   `σ̂²_Ĝ,n = (σ̂²_Y + |Ĝ|² σ̂²_U − 2 Re(Ĝ* σ̂_YU)) / |Ū|²`
///   and the nonlinear variance `σ̂²_Ĝ,S = σ̂²_S,k / |Ū_k|²`.
///
/// **What one phase realisation can and cannot say.** For a random-phase multisine the
/// output at an excited line is `Y = G_BLA U + Y_S + N`: the stochastic nonlinear
/// contribution `Y_S` is periodic, so it does not average out over periods, and for one
/// phase realisation it is indistinguishable from the BLA itself — `Ĝ` is `G_BLA` plus an
/// error of variance `σ²_Ĝ,S` that the period-to-period spread does not see. The total
/// variance reported with one realisation is therefore `σ̂²_Ĝ,n + σ̂²_Ĝ,S`, the second term
/// estimated from the odd detection lines as above. With several realisations
/// ([`DistortionAnalysis::from_realisations`]: records with different random phases),
/// `Ĝ` is their mean and its total variance comes from their spread, which contains both
/// noise and the stochastic nonlinear term.
///
/// **A linear model cannot remove this distortion.** When [`is_nonlinear`] fires, the
/// residuals of any linear model fitted to these data keep the distortion at the excited
/// lines (variance about `σ̂²_S,k`): the BLA with its total variance is the best a linear
/// model can do, and model validation against the noise-only level will fail by that
/// amount.
///
/// [`is_nonlinear`]: DistortionAnalysis::is_nonlinear
///
/// ```
/// use fdid::TimeData;
/// use fdid::data::DistortionAnalysis;
/// use fdid::simulate::{OddMultisineDesign, SplitMix64};
///
/// // odd multisine on lines 1…60 of a 256-sample period, 1 warm-up + 6 measured periods
/// let (m, p) = (256usize, 6usize);
/// let design = OddMultisineDesign::new([1, 60], 3, 1).unwrap();
/// let u = design.multisine(m as f64, 2).unwrap().sample(1.0, (p + 1) * m);
/// // y = x + 0.2 x³ with x = 0.5 x(t−1) + u(t), plus output noise
/// let mut rng = SplitMix64::new(3);
/// let mut x = 0.0;
/// let y: Vec<f64> = u
///     .iter()
///     .map(|ut| {
///         x = 0.5 * x + ut;
///         x + 0.2 * x * x * x + 1e-3 * rng.gaussian()
///     })
///     .collect();
/// let rec = TimeData::new(u[m..].to_vec(), y[m..].to_vec(), 1.0).unwrap();
/// let nl = DistortionAnalysis::new(&rec, p, design.excited(), [1, 60]).unwrap();
/// assert!(nl.is_nonlinear(0.05).unwrap());
/// assert!(nl.odd().unwrap().p_value() < 1e-6); // x³ fills the odd lines…
/// assert!(nl.even().unwrap().p_value() > 1e-3); // …and not the even ones
/// assert_eq!(nl.bla().len(), design.excited().len());
/// ```
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct DistortionAnalysis<T: Real> {
    periods: usize,
    period_len: usize,
    realisations: usize,
    ts: T,
    band: [usize; 2],
    excited: Vec<usize>,
    omega_excited: Vec<T>,
    bla: Vec<Complex<T>>,
    bla_noise_variance: Vec<T>,
    bla_nonlinear_variance: Option<Vec<T>>,
    bla_total_variance: Vec<T>,
    excited_distortion_power: Option<Vec<T>>,
    odd_lines: Vec<DetectionLine<T>>,
    even_lines: Vec<DetectionLine<T>>,
    odd: Option<DetectionTest>,
    even: Option<DetectionTest>,
    output_power: f64,
    noise_power: f64,
    spread: Option<SpreadTest>,
}

impl<T: Real> DistortionAnalysis<T> {
    /// Analyses one periodic record of `periods` periods excited at the DFT lines
    /// `excited` (of one period; any order, duplicates ignored), within the band of lines
    /// `band = [k_min, k_max]` (see the type documentation). Excited lines outside the
    /// band are only excluded from detection; every other line of the band is a
    /// detection line (odd or even).
    ///
    /// # Errors
    /// - [`FdidError::InvalidArgument`] named `"periods"` when `periods < 2` (no noise
    ///   estimate) or the record length is not a multiple of it;
    /// - [`FdidError::TooShort`] when a period has fewer than 2 samples, when `excited` is
    ///   empty or has no line in the band, or when the band holds no detection line;
    /// - [`FdidError::InvalidArgument`] named `"excited"` for a line above the last DFT
    ///   line `⌊M/2⌋` of a period; named `"band"` when `k_min = 0`, `k_min > k_max` or
    ///   `k_max` is not below the Nyquist line (`2 k_max ≥ M`);
    /// - [`FdidError::ZeroInput`] when the input at an excited line of the band is zero or
    ///   at the rounding level, `|Ū_k| ≤ 10³ ε max_j |Ū_j|` (`ε` the machine epsilon of
    ///   `T`): the line is not excited.
    pub fn new(
        record: &TimeData<T>,
        periods: usize,
        excited: &[usize],
        band: [usize; 2],
    ) -> Result<Self> {
        Self::from_realisations(std::slice::from_ref(record), periods, excited, band)
    }

    /// Analyses `R ≥ 1` records of the same experiment repeated with different random
    /// phase realisations (same length, sample time, excited lines and `periods`). The
    /// detection tests pool the terms of all realisations; the BLA is the mean
    /// `Ĝ_k = (1/R) Σ_r Ȳ_r,k / Ū_r,k` with, for `R ≥ 2`, the total variance of the mean
    /// from the spread, `σ̂²_Ĝ = (1/(R(R − 1))) Σ_r |Ĝ_r,k − Ĝ_k|²` (`R − 1` degrees of
    /// freedom), the noise variance `σ̂²_Ĝ,n = (1/R²) Σ_r σ̂²_Ĝ,n,r` and the nonlinear
    /// variance `max(σ̂²_Ĝ − σ̂²_Ĝ,n, 0)`. With `R = 1` this is [`DistortionAnalysis::new`].
    ///
    /// # Errors
    /// As [`DistortionAnalysis::new`], and
    /// - [`FdidError::TooShort`] when `records` is empty;
    /// - [`FdidError::LengthMismatch`] when the records differ in length;
    /// - [`FdidError::InvalidArgument`] named `"ts"` when they differ in sample time.
    ///
    /// With `R ≥ 2` a band without detection lines is accepted (a full multisine): the
    /// [`DistortionAnalysis::spread_test`] of the total against the noise variance then
    /// still detects the stochastic nonlinear distortion.
    pub fn from_realisations(
        records: &[TimeData<T>],
        periods: usize,
        excited: &[usize],
        band: [usize; 2],
    ) -> Result<Self> {
        let first = same_grid(records)?;
        if periods < 2 {
            return Err(FdidError::InvalidArgument {
                name: "periods",
                value: periods.to_string(),
                reason: "the noise variance comes from the spread between periods: need ≥ 2".into(),
            });
        }
        let averages = records
            .iter()
            .map(|r| PeriodicAverage::new(r, periods))
            .collect::<Result<Vec<_>>>()?;
        let m = averages[0].period_len();
        let plan = LinePlan::new(m, excited, band, records.len() >= 2)?;
        assemble(&averages, &plan, periods, band, first.ts())
    }

    /// Number of periods `P` per record.
    pub fn periods(&self) -> usize {
        self.periods
    }

    /// Samples per period `M`.
    pub fn period_len(&self) -> usize {
        self.period_len
    }

    /// Number of phase realisations `R`.
    pub fn realisations(&self) -> usize {
        self.realisations
    }

    /// The analysed band `[k_min, k_max]` (DFT lines of one period).
    pub fn band(&self) -> [usize; 2] {
        self.band
    }

    /// The excited lines inside the band (increasing), where the BLA is given.
    pub fn excited(&self) -> &[usize] {
        &self.excited
    }

    /// Their frequencies `ω_k = 2πk / (M T_s)` (rad/s).
    pub fn omega(&self) -> &[T] {
        &self.omega_excited
    }

    /// The best linear approximation `Ĝ_k = Ȳ_k / Ū_k` at the excited lines (mean over
    /// realisations).
    pub fn bla(&self) -> &[Complex<T>] {
        &self.bla
    }

    /// Noise variance of `Ĝ_k`: `(σ̂²_Y + |Ĝ|² σ̂²_U − 2 Re(Ĝ* σ̂_YU)) / |Ū|²` from the
    /// periods (divided by `R²` and summed over realisations for the mean).
    pub fn bla_noise_variance(&self) -> &[T] {
        &self.bla_noise_variance
    }

    /// Variance of `Ĝ_k` due to the stochastic nonlinear contribution: from the spread
    /// over realisations minus the noise variance when `R ≥ 2`, else interpolated from
    /// the odd detection lines, `σ̂²_S,k / |Ū_k|²`; `None` with one realisation and no
    /// odd detection line.
    pub fn bla_nonlinear_variance(&self) -> Option<&[T]> {
        self.bla_nonlinear_variance.as_deref()
    }

    /// Total variance of `Ĝ_k` around the BLA: the spread over realisations when
    /// `R ≥ 2`; with one realisation the noise variance plus the interpolated nonlinear
    /// variance (the noise variance alone when there is no odd detection line).
    pub fn bla_total_variance(&self) -> &[T] {
        &self.bla_total_variance
    }

    /// Degrees of freedom of [`DistortionAnalysis::bla_total_variance`] when it is a
    /// sample variance over realisations (`R − 1`, `R ≥ 2`); `None` otherwise.
    pub fn bla_variance_dof(&self) -> Option<usize> {
        (self.realisations >= 2).then(|| self.realisations - 1)
    }

    /// The BLA as frequency response data (`Y = Ĝ`, `U = 1`) at the excited lines with
    /// the total variance as output noise variance, ready for a parametric fit of the
    /// best linear approximation.
    ///
    /// # Errors
    /// [`FdidError::NonFinite`] if a value is not finite.
    pub fn bla_data(&self) -> Result<FrequencyData<T>> {
        let data =
            FrequencyData::from_frf(self.omega_excited.clone(), self.bla.clone(), Some(self.ts))?;
        let data = data.with_noise(NoiseVariances::output_only(self.bla_total_variance.clone()))?;
        match self.bla_variance_dof() {
            Some(dof) => data.with_variance_dof(dof),
            None => Ok(data),
        }
    }

    /// The estimated output power of the stochastic nonlinear contribution `σ̂²_S,k` at
    /// each excited line, interpolated from the odd detection lines (see the type
    /// documentation); `None` without odd detection lines.
    pub fn excited_distortion_power(&self) -> Option<&[T]> {
        self.excited_distortion_power.as_deref()
    }

    /// The odd detection lines in the band with their levels.
    pub fn odd_lines(&self) -> &[DetectionLine<T>] {
        &self.odd_lines
    }

    /// The even detection lines in the band with their levels.
    pub fn even_lines(&self) -> &[DetectionLine<T>] {
        &self.even_lines
    }

    /// The test at the odd detection lines (odd-degree distortion); `None` when the band
    /// has no odd detection line.
    pub fn odd(&self) -> Option<&DetectionTest> {
        self.odd.as_ref()
    }

    /// The test at the even detection lines (even-degree distortion); `None` when the
    /// band has no even detection line.
    pub fn even(&self) -> Option<&DetectionTest> {
        self.even.as_ref()
    }

    /// With `R ≥ 2` realisations, the test of the total variance of the BLA (between
    /// realisations) against its noise variance (between periods): the stochastic
    /// nonlinear distortion at the excited lines themselves ([`SpreadTest`]); `None` for
    /// one realisation. [`DistortionAnalysis::is_nonlinear`] does not include it.
    pub fn spread_test(&self) -> Option<&SpreadTest> {
        self.spread.as_ref()
    }

    /// Output power at the excited lines, `P_Y = mean_k |Ȳ_k|²` (the reference of the dB
    /// levels).
    pub fn output_power(&self) -> f64 {
        self.output_power
    }

    /// Noise power of the mean, `mean_k σ̂²_Y,k` over every line of the band.
    pub fn noise_power(&self) -> f64 {
        self.noise_power
    }

    /// `10 log₁₀(noise power / P_Y)` (dB).
    pub fn noise_db(&self) -> f64 {
        10.0 * (self.noise_power / self.output_power).log10()
    }

    /// True when a detection test rejects "noise only": `min p < α/m` over the `m`
    /// available tests (odd, even; Bonferroni). Then the data hold nonlinear distortion
    /// that no linear model can remove (see the type documentation).
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] named `"alpha"` unless `0 < α < 1`.
    pub fn is_nonlinear(&self, alpha: f64) -> Result<bool> {
        if !(alpha > 0.0 && alpha < 1.0) {
            return Err(FdidError::InvalidArgument {
                name: "alpha",
                value: format!("{alpha}"),
                reason: "the false-alarm level must lie in (0, 1)".into(),
            });
        }
        let tests: Vec<&DetectionTest> = self.odd.iter().chain(self.even.iter()).collect();
        let m = tests.len() as f64;
        Ok(tests.iter().any(|t| t.p_value() < alpha / m))
    }

    /// A short text verdict at false-alarm level `alpha`: which distortion was detected,
    /// its level, and what it means for a linear model.
    ///
    /// # Errors
    /// As [`DistortionAnalysis::is_nonlinear`].
    pub fn summary(&self, alpha: f64) -> Result<String> {
        let nonlinear = self.is_nonlinear(alpha)?;
        let m = self.odd.iter().count() + self.even.iter().count();
        let describe = |name: &str, t: Option<&DetectionTest>| match t {
            None => format!("{name}: no detection line"),
            Some(t) => format!(
                "{name}: p = {:.3e} ({}), level {}",
                t.p_value(),
                if t.p_value() < alpha / m as f64 {
                    "above the noise"
                } else {
                    "noise only"
                },
                match t.distortion_db {
                    Some(db) => format!("{db:.1} dB"),
                    None => "not above the noise".into(),
                }
            ),
        };
        let mut s = format!(
            "nonlinear distortion (α = {alpha}, {} period(s) × {} realisation(s)): {}\n  {}\n  {}\n  noise level {:.1} dB (relative to the output at the excited lines)\n",
            self.periods,
            self.realisations,
            if nonlinear {
                "detected"
            } else {
                "not detected"
            },
            describe("odd lines", self.odd.as_ref()),
            describe("even lines", self.even.as_ref()),
            self.noise_db(),
        );
        if nonlinear {
            s.push_str(
                "  a linear model cannot remove this distortion: the best linear approximation \
                 is reported with its total (noise + nonlinear) variance\n",
            );
        }
        Ok(s)
    }
}

/// The analysis of the period averages `averages` (one per realisation) on the line plan
/// `plan`.
fn assemble<T: Real>(
    averages: &[PeriodicAverage<T>],
    plan: &LinePlan,
    periods: usize,
    band: [usize; 2],
    ts: T,
) -> Result<DistortionAnalysis<T>> {
    let nu = (periods - 1) as f64;
    let omega_all = averages[0].data().omega();
    let bla = Bla::new(averages, &plan.excited, omega_all)?;
    let noise_power = band_noise_power(averages, band);
    let odd = detect(averages, &plan.odd, nu, bla.output_power);
    let even = detect(averages, &plan.even, nu, bla.output_power);
    let excited_distortion =
        (!plan.odd.is_empty()).then(|| interpolate_levels(&plan.odd, &odd.excess, &plan.excited));
    let (nl_var, total_var) = bla.variances(excited_distortion.as_deref());
    let to_t = |v: &[f64]| -> Vec<T> { v.iter().map(|x| T::lit(*x)).collect() };
    Ok(DistortionAnalysis {
        periods,
        period_len: averages[0].period_len(),
        realisations: averages.len(),
        ts,
        band,
        excited: plan.excited.clone(),
        omega_excited: plan.excited.iter().map(|&k| omega_all[k]).collect(),
        bla: bla
            .mean
            .iter()
            .map(|g| Complex::new(T::lit(g.re), T::lit(g.im)))
            .collect(),
        bla_noise_variance: to_t(&bla.noise_variance),
        bla_nonlinear_variance: nl_var.as_deref().map(to_t),
        bla_total_variance: to_t(&total_var),
        excited_distortion_power: excited_distortion.as_deref().map(to_t),
        odd_lines: odd.lines,
        even_lines: even.lines,
        odd: odd.test,
        even: even.test,
        output_power: bla.output_power,
        noise_power,
        spread: if averages.len() >= 2 {
            SpreadTest::new(&total_var, &bla.noise_variance, averages.len(), periods)
        } else {
            None
        },
    })
}

/// The noise power of the mean, `mean_k σ̂²_Y,k` over every line of the band and every
/// realisation.
fn band_noise_power<T: Real>(averages: &[PeriodicAverage<T>], band: [usize; 2]) -> f64 {
    let band_lines = band[1] - band[0] + 1;
    averages
        .iter()
        .map(|a| {
            noise_of(a).var_y[band[0]..=band[1]]
                .iter()
                .map(|v| v.to_f64_lossless())
                .sum::<f64>()
        })
        .sum::<f64>()
        / (band_lines * averages.len()) as f64
}
