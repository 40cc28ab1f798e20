//! Nonlinear distortion detection with odd random-phase multisines, and the best linear
//! approximation (BLA).
//!
//! McKelvey's data model (eq. 19) is linear: `Y_k = G₀(ω_k) U_k + H₀(ω_k) E_k` with the
//! noise term complex normal, zero mean and independent between lines (eqs. 13–14, 17–18).
//! A nonlinear system driven by a periodic input adds a *periodic* term `Y_S,k` that the
//! model cannot explain: it does not average out over periods and it lands on lines the
//! input does not excite. An odd multisine (only odd lines excited) with one odd line in
//! every group left out makes the distortion visible (the design of Pintelon & Schoukens,
//! *System Identification: A Frequency Domain Approach*, ch. 3–4):
//!
//! - even-degree terms of the nonlinearity (`x²`, `x⁴`, …) of an odd signal only produce
//!   *even* lines, odd-degree terms (`x³`, …) only *odd* lines;
//! - so energy above the noise at the non-excited *even* lines reveals even distortion,
//!   at the non-excited *odd* lines odd distortion.
//!
//! Everything here is built on the DFT of each period (McKelvey eq. 1 with `N → M`) and
//! the averaging over `P` periods of [`PeriodicAverage`]: the noise variance per line
//! comes from the spread between periods, the distortion from the energy of the mean.
//!
//! - [`OddMultisineDesign`]: the line plan (excited, odd detection, even detection lines)
//!   and its random-phase [`Multisine`].
//! - [`DistortionAnalysis`]: the detection tests ([`DetectionTest`], per line
//!   [`DetectionLine`]), the distortion and noise levels, and the BLA with its variance.

use crate::data::{FrequencyData, NoiseVariances, PeriodicAverage, TimeData};
use crate::error::{FdidError, Result};
use crate::scalar::{Complex, Real};
use crate::simulate::{Multisine, SplitMix64};
use crate::stats::chi2_sf;
use std::f64::consts::TAU;

/// The line plan of a random odd multisine with detection lines.
///
/// In the band of DFT lines `k_min ≤ k ≤ k_max` (line `k` of one period of `M` samples is
/// at `f_k = k / (M T_s)`):
///
/// - the odd lines are cut into consecutive groups of `g` (`group`); in every full group
///   one line, drawn at random from `seed`, is left out — an *odd detection line*; the
///   others are *excited*; the lines of a last incomplete group are all excited;
/// - every even line is an *even detection line*.
///
/// So a fraction `1/g` of the odd lines detects odd distortion, and all even lines detect
/// even distortion. [`OddMultisineDesign::multisine`] builds the excitation
/// `u(t) = Σ_{k excited} A cos(2π k t / T_period + φ_k)` with independent uniform phases
/// (a *random-phase* multisine, whose distortion behaves as a noise-like term over phase
/// realisations). Sampled over whole periods its DFT (McKelvey eq. 1) is zero at every
/// detection line, so whatever the output shows there is noise or distortion.
///
/// ```
/// use fdid::data::OddMultisineDesign;
///
/// let design = OddMultisineDesign::new([1, 60], 3, 7).unwrap();
/// assert_eq!(design.odd_detection().len(), 10); // 30 odd lines, groups of 3
/// assert_eq!(design.excited().len(), 20);
/// assert_eq!(design.even_detection().len(), 30);
/// let u = design.multisine(256.0f64, 11).unwrap(); // period 256 samples at Ts = 1
/// assert_eq!(u.lines(), design.excited());
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct OddMultisineDesign {
    band: [usize; 2],
    group: usize,
    excited: Vec<usize>,
    odd_detection: Vec<usize>,
    even_detection: Vec<usize>,
}

impl OddMultisineDesign {
    /// The line plan on the lines `band[0] ≤ k ≤ band[1]` with one odd detection line in
    /// every group of `group` consecutive odd lines (see the type documentation).
    ///
    /// # Errors
    /// - [`FdidError::InvalidArgument`] named `"band"` when `band[0] = 0` (the DC line is
    ///   not a sinusoid) or `band[0] > band[1]`; named `"group"` when `group < 2`;
    /// - [`FdidError::TooShort`] when the band holds fewer than `group` odd lines (no
    ///   odd detection line could be placed).
    pub fn new(band: [usize; 2], group: usize, seed: u64) -> Result<Self> {
        check_band_order(band)?;
        if group < 2 {
            return Err(FdidError::InvalidArgument {
                name: "group",
                value: group.to_string(),
                reason: "one odd line out of every group is left out: need a group of ≥ 2".into(),
            });
        }
        let odd: Vec<usize> = (band[0]..=band[1]).filter(|k| k % 2 == 1).collect();
        if odd.len() < group {
            return Err(FdidError::TooShort {
                what: "odd lines in the band",
                needed: group,
                got: odd.len(),
            });
        }
        let mut rng = SplitMix64::new(seed);
        let mut excited = Vec::with_capacity(odd.len());
        let mut odd_detection = Vec::with_capacity(odd.len() / group + 1);
        for chunk in odd.chunks(group) {
            if chunk.len() == group {
                // uniform on 0..group (the modulo bias is below 2⁻⁵⁰ for any sane group)
                let out = (rng.next_u64() % group as u64) as usize;
                for (i, &k) in chunk.iter().enumerate() {
                    if i == out {
                        odd_detection.push(k);
                    } else {
                        excited.push(k);
                    }
                }
            } else {
                excited.extend_from_slice(chunk);
            }
        }
        let even_detection = (band[0]..=band[1]).filter(|k| k % 2 == 0).collect();
        Ok(Self {
            band,
            group,
            excited,
            odd_detection,
            even_detection,
        })
    }

    /// The band `[k_min, k_max]` (DFT line numbers of one period).
    pub fn band(&self) -> [usize; 2] {
        self.band
    }

    /// The group size `g`: one odd line in every `g` is a detection line.
    pub fn group(&self) -> usize {
        self.group
    }

    /// The excited lines (odd, increasing).
    pub fn excited(&self) -> &[usize] {
        &self.excited
    }

    /// The odd detection lines: odd lines in the band left unexcited (increasing).
    pub fn odd_detection(&self) -> &[usize] {
        &self.odd_detection
    }

    /// The even detection lines: every even line in the band (increasing).
    pub fn even_detection(&self) -> &[usize] {
        &self.even_detection
    }

    /// The random-phase multisine `u(t) = Σ_{k excited} A cos(2π k t / T_period + φ_k)`
    /// with flat amplitudes `A` scaled to unit RMS (`√(Σ A²/2) = 1`) and phases `φ_k`
    /// independent and uniform on `[0, 2π)`, drawn from `seed` (a new seed gives a new
    /// phase realisation). Sampled with `T_period = M T_s` its DFT over one period is
    /// non-zero only at the excited lines; check the sampling rate with
    /// [`Multisine::check_sampling`].
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] named `"period"` when `period` is not positive and
    /// finite.
    pub fn multisine<T: Real>(&self, period: T, seed: u64) -> Result<Multisine<T>> {
        let mut rng = SplitMix64::new(seed);
        let phases: Vec<T> = self
            .excited
            .iter()
            .map(|_| T::lit(TAU * rng.uniform()))
            .collect();
        let amplitudes = vec![T::one(); self.excited.len()];
        Multisine::from_lines(period, self.excited.clone(), amplitudes, phases)?.with_rms(T::one())
    }
}

/// One detection line: the energy of the period-averaged output against its noise
/// variance.
///
/// With `Ȳ_k` the output spectrum averaged over `P` periods and `σ̂²_k` the sample
/// variance of that mean (divisor `P(P − 1)`, see [`PeriodicAverage`]),
/// `ratio = |Ȳ_k|² / σ̂²_k`. Under "noise only" (the linear model of McKelvey eq. 19 with
/// complex normal noise, eq. 14, and no input at the line) the ratio follows an
/// `F(2, 2(P − 1))` distribution and `p_value = P(F > ratio) = (1 + ratio/(P − 1))^{−(P−1)}`.
/// With several phase realisations the line's power and variance are averaged over them.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct DetectionLine<T: Real> {
    /// DFT line number `k` of one period.
    pub line: usize,
    /// Its frequency `ω_k = 2πk / (M T_s)` (rad/s).
    pub omega: T,
    /// `|Ȳ_k|²`: the output power of the mean.
    pub power: T,
    /// `σ̂²_k`: the noise variance of the mean.
    pub noise_variance: T,
    /// `|Ȳ_k|² / σ̂²_k` (`+∞` when `σ̂²_k = 0 < |Ȳ_k|²`, `0` when both vanish).
    pub ratio: f64,
    /// `P(F(2, 2(P − 1)) > ratio)`; with `R` realisations Fisher's combination of their
    /// `R` tail probabilities at this line, `P(χ²(2R) > 2(P − 1) Σ_r ln(1 + x_r/(P − 1)))`.
    pub p_value: f64,
}

/// The test "the detection lines of one kind (odd or even) hold only noise".
///
/// Over the `n` terms (detection lines × phase realisations) with ratios
/// `x_j = |Ȳ_j|² / σ̂²_j ~ F(2, d₂)`, `d₂ = 2(P − 1)` under the null hypothesis, two
/// statistics are reported:
///
/// - the sum `S = Σ_j x_j`, with `E S = n d₂/(d₂ − 2)` (`P ≥ 3`) and
///   `var S = n d₂³/((d₂ − 2)²(d₂ − 4))` (`P ≥ 4`), compared (`P ≥ 4`) with a scaled
///   `c χ²(f)` of the same mean and variance (as the cost test of
///   [`Validation`](crate::validation::Validation)): `p_sum = P(χ²(f) > S/c)`;
/// - Fisher's combination of the exact per-line tail probabilities
///   `p_j = (1 + x_j/(P − 1))^{−(P−1)}`: `X = −2 Σ ln p_j = 2(P − 1) Σ ln(1 + x_j/(P − 1))`,
///   exactly `χ²(2n)` under the null hypothesis (the `p_j` are independent uniforms:
///   lines are independent, eq. 18 asymptotically, and the mean and sample variance of a
///   normal sample are independent), `p_fisher = P(χ²(2n) > X)`.
///
/// The decision p-value [`DetectionTest::p_value`] is `p_fisher`: it is exact for every
/// `P ≥ 2`, whereas the `F(2, d₂)` terms are heavy tailed (the fourth moment is infinite
/// for `P ≤ 5`) and the two-moment χ² fit of the sum is then only approximate. It is also
/// the more powerful of the two on spread-out distortion: with `P = 4` and 20 odd
/// detection lines at a distortion-to-noise ratio of 0 dB per line, the Bonferroni
/// decision fires in 45 % of the runs with Fisher's statistic against 29 % with the sum
/// (tests/suite/data_distortion.rs, 300 seeds).
///
/// The distortion power `D = mean_j (|Ȳ_j|² − σ̂²_j)` estimates the mean power of the
/// periodic distortion `|Y_S,k|²` at these lines without bias (`E|Ȳ|² = |Y_S|² + σ²`,
/// `E σ̂² = σ²`); it is reported in dB relative to the output power at the excited lines
/// (`None` when `D ≤ 0`, i.e. nothing above the noise).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct DetectionTest {
    /// Number of terms `n` (lines × realisations).
    pub terms: usize,
    /// The sum `S = Σ x_j`.
    pub statistic: f64,
    /// `E S = n d₂/(d₂ − 2)` under noise only (`None` for `P = 2`: the mean is infinite).
    pub expected: Option<f64>,
    /// The scaled-χ² tail probability of `S` (`None` for `P ≤ 3`).
    pub p_sum: Option<f64>,
    /// Fisher's statistic `X = 2(P − 1) Σ ln(1 + x_j/(P − 1))`.
    pub fisher_statistic: f64,
    /// `P(χ²(2n) > X)`: exact under noise only.
    pub p_fisher: f64,
    /// Mean distortion power `D = mean (|Ȳ_j|² − σ̂²_j)` (may be negative by chance).
    pub distortion_power: f64,
    /// `10 log₁₀(D / output power)` (dB), `None` when `D ≤ 0`.
    pub distortion_db: Option<f64>,
}

impl DetectionTest {
    /// The decision p-value: [`DetectionTest::p_fisher`] (see the type documentation).
    pub fn p_value(&self) -> f64 {
        self.p_fisher
    }
}

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
/// use fdid::data::{DistortionAnalysis, OddMultisineDesign};
/// use fdid::simulate::SplitMix64;
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
    pub fn from_realisations(
        records: &[TimeData<T>],
        periods: usize,
        excited: &[usize],
        band: [usize; 2],
    ) -> Result<Self> {
        let first = records.first().ok_or(FdidError::TooShort {
            what: "realisations",
            needed: 1,
            got: 0,
        })?;
        for r in &records[1..] {
            if r.len() != first.len() {
                return Err(FdidError::LengthMismatch {
                    what: "realisation record",
                    expected: first.len(),
                    got: r.len(),
                });
            }
            if r.ts() != first.ts() {
                return Err(FdidError::InvalidArgument {
                    name: "ts",
                    value: format!("{}", r.ts()),
                    reason: format!(
                        "every realisation must share the sample time {}",
                        first.ts()
                    ),
                });
            }
        }
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
        let plan = LinePlan::new(m, excited, band)?;
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

/// Which lines of one period are excited, odd detection or even detection lines.
struct LinePlan {
    /// Excited lines within the band, increasing.
    excited: Vec<usize>,
    odd: Vec<usize>,
    even: Vec<usize>,
}

impl LinePlan {
    fn new(m: usize, excited: &[usize], band: [usize; 2]) -> Result<Self> {
        if excited.is_empty() {
            return Err(FdidError::TooShort {
                what: "excited lines",
                needed: 1,
                got: 0,
            });
        }
        if let Some(&k) = excited.iter().find(|&&k| k > m / 2) {
            return Err(FdidError::InvalidArgument {
                name: "excited",
                value: k.to_string(),
                reason: format!(
                    "beyond the last DFT line ⌊M/2⌋ = {} of a period of M = {m} samples",
                    m / 2
                ),
            });
        }
        check_band_order(band)?;
        if 2 * band[1] >= m {
            return Err(FdidError::InvalidArgument {
                name: "band",
                value: format!("[{}, {}]", band[0], band[1]),
                reason: format!(
                    "the highest line must lie below the Nyquist line M/2 = {} (M = {m})",
                    m as f64 / 2.0
                ),
            });
        }
        let mut is_excited = vec![false; band[1] + 1];
        for &k in excited {
            if k <= band[1] {
                is_excited[k] = true;
            }
        }
        let in_band = band[0]..=band[1];
        let exc: Vec<usize> = in_band.clone().filter(|&k| is_excited[k]).collect();
        if exc.is_empty() {
            return Err(FdidError::TooShort {
                what: "excited lines in the band",
                needed: 1,
                got: 0,
            });
        }
        let odd: Vec<usize> = in_band
            .clone()
            .filter(|&k| !is_excited[k] && k % 2 == 1)
            .collect();
        let even: Vec<usize> = in_band.filter(|&k| !is_excited[k] && k % 2 == 0).collect();
        if odd.is_empty() && even.is_empty() {
            return Err(FdidError::TooShort {
                what: "detection (non-excited) lines in the band",
                needed: 1,
                got: 0,
            });
        }
        Ok(Self {
            excited: exc,
            odd,
            even,
        })
    }
}

/// `band[0] ≥ 1` and `band[0] ≤ band[1]`.
fn check_band_order(band: [usize; 2]) -> Result<()> {
    if band[0] == 0 || band[0] > band[1] {
        return Err(FdidError::InvalidArgument {
            name: "band",
            value: format!("[{}, {}]", band[0], band[1]),
            reason: "need lines 1 ≤ k_min ≤ k_max (the DC line is not a sinusoid)".into(),
        });
    }
    Ok(())
}

fn f64c<T: Real>(c: Complex<T>) -> Complex<f64> {
    Complex::new(c.re.to_f64_lossless(), c.im.to_f64_lossless())
}

fn noise_of<T: Real>(avg: &PeriodicAverage<T>) -> &NoiseVariances<T> {
    avg.data()
        .noise()
        .expect("P ≥ 2 periods always give noise variances")
}

/// `|Ȳ|²/σ̂²` with the conventions of [`DetectionLine::ratio`].
fn ratio(power: f64, var: f64) -> f64 {
    if var > 0.0 {
        power / var
    } else if power > 0.0 {
        f64::INFINITY
    } else {
        0.0
    }
}

/// The detection lines of one kind, and their test.
fn detect<T: Real>(
    averages: &[PeriodicAverage<T>],
    lines: &[usize],
    nu: f64,
    output_power: f64,
) -> (Vec<DetectionLine<T>>, Option<DetectionTest>, Vec<f64>) {
    if lines.is_empty() {
        return (Vec::new(), None, Vec::new());
    }
    let r_t = averages.len() as f64;
    let omega = averages[0].data().omega();
    let (mut sum, mut fisher, mut excess_total) = (0.0, 0.0, 0.0);
    let mut excess = Vec::with_capacity(lines.len());
    let mut out = Vec::with_capacity(lines.len());
    for &k in lines {
        let (mut power_k, mut var_k, mut fisher_k) = (0.0, 0.0, 0.0);
        for avg in averages {
            let power = avg.data().y()[k].norm_sqr().to_f64_lossless();
            let var = noise_of(avg).var_y[k].to_f64_lossless();
            let x = ratio(power, var);
            sum += x;
            // −ln p = (P − 1) ln(1 + x/(P − 1))
            fisher_k += 2.0 * nu * (x / nu).ln_1p();
            power_k += power / r_t;
            var_k += var / r_t;
        }
        fisher += fisher_k;
        excess.push(power_k - var_k);
        excess_total += power_k - var_k;
        out.push(DetectionLine {
            line: k,
            omega: omega[k],
            power: T::lit(power_k),
            noise_variance: T::lit(var_k),
            ratio: ratio(power_k, var_k),
            p_value: chi2_sf(fisher_k, 2.0 * r_t),
        });
    }
    let n = (lines.len() * averages.len()) as f64;
    let d2 = 2.0 * nu;
    let expected = (d2 > 2.0).then(|| n * d2 / (d2 - 2.0));
    let p_sum = (d2 > 4.0).then(|| {
        let mean = n * d2 / (d2 - 2.0);
        let var = n * d2 * d2 * d2 / ((d2 - 2.0) * (d2 - 2.0) * (d2 - 4.0));
        let c = var / (2.0 * mean);
        let f = 2.0 * mean * mean / var;
        chi2_sf(sum / c, f)
    });
    let distortion_power = excess_total / lines.len() as f64;
    let test = DetectionTest {
        terms: lines.len() * averages.len(),
        statistic: sum,
        expected,
        p_sum,
        fisher_statistic: fisher,
        p_fisher: chi2_sf(fisher, 2.0 * n),
        distortion_power,
        distortion_db: (distortion_power > 0.0)
            .then(|| 10.0 * (distortion_power / output_power).log10()),
    };
    (out, Some(test), excess)
}

/// Smoothed (3-point mean), linearly interpolated and clipped levels at `targets`.
fn interpolate_levels(lines: &[usize], levels: &[f64], targets: &[usize]) -> Vec<f64> {
    let n = lines.len();
    let smooth: Vec<f64> = (0..n)
        .map(|j| {
            let lo = j.saturating_sub(1);
            let hi = (j + 1).min(n - 1);
            levels[lo..=hi].iter().sum::<f64>() / (hi - lo + 1) as f64
        })
        .collect();
    targets
        .iter()
        .map(|&k| {
            let v = match lines.iter().position(|&l| l >= k) {
                Some(0) => smooth[0],
                None => smooth[n - 1],
                Some(j) => {
                    let (k0, k1) = (lines[j - 1] as f64, lines[j] as f64);
                    let t = (k as f64 - k0) / (k1 - k0);
                    smooth[j - 1] + t * (smooth[j] - smooth[j - 1])
                }
            };
            v.max(0.0)
        })
        .collect()
}

fn assemble<T: Real>(
    averages: &[PeriodicAverage<T>],
    plan: &LinePlan,
    periods: usize,
    band: [usize; 2],
    ts: T,
) -> Result<DistortionAnalysis<T>> {
    let r = averages.len();
    let r_f = r as f64;
    let nu = (periods - 1) as f64;
    let omega_all = averages[0].data().omega();

    // BLA per realisation, with its noise variance
    let mut g_r: Vec<Vec<Complex<f64>>> = Vec::with_capacity(r);
    let mut gvar_r: Vec<Vec<f64>> = Vec::with_capacity(r);
    let mut u_power = vec![0.0; plan.excited.len()];
    let mut output_power = 0.0;
    for avg in averages {
        let d = avg.data();
        let nv = noise_of(avg);
        let mut g = Vec::with_capacity(plan.excited.len());
        let mut gv = Vec::with_capacity(plan.excited.len());
        // an input at the rounding level of the largest excited line is no excitation
        let u_max = plan
            .excited
            .iter()
            .map(|&k| d.u()[k].norm())
            .fold(T::zero(), |a, b| if b > a { b } else { a });
        let u_floor = T::lit(1e3) * <T as num_traits::Float>::epsilon() * u_max;
        for (i, &k) in plan.excited.iter().enumerate() {
            let (y, u) = (f64c(d.y()[k]), f64c(d.u()[k]));
            let u2 = u.norm_sqr();
            if !(d.u()[k].norm() > u_floor) || !(u2 > 0.0) {
                return Err(FdidError::ZeroInput {
                    index: k,
                    omega: omega_all[k].to_f64_lossless(),
                });
            }
            let gk = y / u;
            let var = (nv.var_y[k].to_f64_lossless()
                + gk.norm_sqr() * nv.var_u[k].to_f64_lossless()
                - 2.0 * (gk.conj() * f64c(nv.cov_yu[k])).re)
                / u2;
            g.push(gk);
            gv.push(var.max(0.0));
            u_power[i] += u2 / r_f;
            output_power += y.norm_sqr();
        }
        g_r.push(g);
        gvar_r.push(gv);
    }
    let n_exc = plan.excited.len();
    output_power /= (n_exc * r) as f64;
    let bla: Vec<Complex<f64>> = (0..n_exc)
        .map(|i| g_r.iter().map(|g| g[i]).sum::<Complex<f64>>() / r_f)
        .collect();
    let noise_var: Vec<f64> = (0..n_exc)
        .map(|i| gvar_r.iter().map(|v| v[i]).sum::<f64>() / (r_f * r_f))
        .collect();

    // noise power over the band
    let band_lines = band[1] - band[0] + 1;
    let noise_power = averages
        .iter()
        .map(|a| {
            noise_of(a).var_y[band[0]..=band[1]]
                .iter()
                .map(|v| v.to_f64_lossless())
                .sum::<f64>()
        })
        .sum::<f64>()
        / (band_lines * r) as f64;

    let (odd_lines, odd, odd_excess) = detect(averages, &plan.odd, nu, output_power);
    let (even_lines, even, _) = detect(averages, &plan.even, nu, output_power);

    let excited_distortion =
        (!plan.odd.is_empty()).then(|| interpolate_levels(&plan.odd, &odd_excess, &plan.excited));
    let (nl_var, total_var): (Option<Vec<f64>>, Vec<f64>) = if r >= 2 {
        let total: Vec<f64> = (0..n_exc)
            .map(|i| {
                g_r.iter().map(|g| (g[i] - bla[i]).norm_sqr()).sum::<f64>() / (r_f * (r_f - 1.0))
            })
            .collect();
        let nl = total
            .iter()
            .zip(&noise_var)
            .map(|(t, n)| (t - n).max(0.0))
            .collect();
        (Some(nl), total)
    } else {
        match &excited_distortion {
            Some(d) => {
                let nl: Vec<f64> = d.iter().zip(&u_power).map(|(d, u2)| d / u2).collect();
                let total = nl.iter().zip(&noise_var).map(|(a, b)| a + b).collect();
                (Some(nl), total)
            }
            None => (None, noise_var.clone()),
        }
    };
    let to_t = |v: &[f64]| -> Vec<T> { v.iter().map(|x| T::lit(*x)).collect() };
    Ok(DistortionAnalysis {
        periods,
        period_len: averages[0].period_len(),
        realisations: r,
        ts,
        band,
        excited: plan.excited.clone(),
        omega_excited: plan.excited.iter().map(|&k| omega_all[k]).collect(),
        bla: bla
            .iter()
            .map(|g| Complex::new(T::lit(g.re), T::lit(g.im)))
            .collect(),
        bla_noise_variance: to_t(&noise_var),
        bla_nonlinear_variance: nl_var.as_deref().map(to_t),
        bla_total_variance: to_t(&total_var),
        excited_distortion_power: excited_distortion.as_deref().map(to_t),
        odd_lines,
        even_lines,
        odd,
        even,
        output_power,
        noise_power,
    })
}
