//! The best linear approximation over several realisations of a periodic experiment,
//! with the noise variance (between periods) and the total variance (between
//! realisations), for any number of periods `P ≥ 1`.

use super::f64c;
use crate::data::{FrequencyData, NoiseVariances, PeriodicAverage, TimeData};
use crate::error::{FdidError, Result};
use crate::scalar::{Complex, Real};
use crate::stats::{chi2_sf, f_sf};

/// The test "the total variance of the BLA is noise only": the spread over realisations
/// against the spread over periods.
///
/// At each excited line `F_k = σ̂²_Ĝ,k / σ̂²_Ĝ,n,k` (total over noise variance of the mean
/// BLA). Without nonlinear distortion both estimate the same variance; the total has
/// `d₁ = 2(R − 1)` and the noise `d₂ = 2R(P − 1)` real degrees of freedom, so
/// `F_k ~ F(d₁, d₂)` and `p_k = P(F(d₁, d₂) > F_k)`. Fisher's combination over the `K`
/// lines, `X = −2 Σ_k ln p_k`, is `χ²(2K)` under "noise only"; the p-value is
/// `P(χ²(2K) > X)`. The stochastic nonlinear contribution of a random-phase multisine
/// changes from one realisation to the next but not from one period to the next, so it
/// raises the total variance only.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct SpreadTest {
    /// Number of lines `K`.
    pub lines: usize,
    /// Fisher's statistic `X`.
    pub fisher_statistic: f64,
    /// `P(χ²(2K) > X)`.
    pub p_value: f64,
    /// `10 log₁₀(Σ_k σ̂²_Ĝ,k / Σ_k σ̂²_Ĝ,n,k)` (dB): how far the total variance exceeds the
    /// noise variance on average.
    pub total_to_noise_db: f64,
}

impl SpreadTest {
    /// The test of the total variances `total` against the noise variances `noise` of the
    /// mean over `realisations ≥ 2` realisations of `periods ≥ 2` periods; `None` when a
    /// condition fails or no line has a positive noise variance.
    pub(crate) fn new(
        total: &[f64],
        noise: &[f64],
        realisations: usize,
        periods: usize,
    ) -> Option<Self> {
        if realisations < 2 || periods < 2 {
            return None;
        }
        let d1 = 2.0 * (realisations - 1) as f64;
        let d2 = 2.0 * (realisations * (periods - 1)) as f64;
        let (mut fisher, mut lines, mut sum_t, mut sum_n) = (0.0, 0usize, 0.0, 0.0);
        for (t, n) in total.iter().zip(noise) {
            if !(*n > 0.0) {
                continue;
            }
            let p = f_sf(t / n, d1, d2).max(f64::MIN_POSITIVE);
            fisher -= 2.0 * p.ln();
            lines += 1;
            sum_t += t;
            sum_n += n;
        }
        (lines > 0).then(|| Self {
            lines,
            fisher_statistic: fisher,
            p_value: chi2_sf(fisher, 2.0 * lines as f64),
            total_to_noise_db: 10.0 * (sum_t / sum_n).log10(),
        })
    }
}

/// The best linear approximation (BLA) of `R` realisations of a periodic experiment
/// (records of the same length, each `P` periods of `M` samples in steady state), at the
/// lines every realisation excites.
///
/// Realisation `r` is averaged over its periods ([`PeriodicAverage`]: `Ū_r,k`, `Ȳ_r,k`
/// and, for `P ≥ 2`, the noise (co)variances of the mean). At the excited lines (those
/// [`FrequencyData::excitation`] finds in every realisation, `fraction` its level rule):
///
/// - `Ĝ_r,k = Ȳ_r,k / Ū_r,k` and the BLA `Ĝ_k = (1/R) Σ_r Ĝ_r,k`;
/// - for `P ≥ 2` the noise variance of the mean
///   `σ̂²_Ĝ,n,k = (1/R²) Σ_r (σ̂²_Y + |Ĝ_r|² σ̂²_U − 2 Re(Ĝ_r* σ̂_YU)) / |Ū_r|²`
///   (the spread between periods);
/// - for `R ≥ 2` the total variance of the mean
///   `σ̂²_Ĝ,k = (1/(R(R − 1))) Σ_r |Ĝ_r,k − Ĝ_k|²` (the spread between realisations:
///   noise plus the stochastic nonlinear distortion), `R − 1` complex degrees of freedom;
/// - for `R ≥ 2` and `P ≥ 2` the [`SpreadTest`] of the total against the noise. With
///   `P = 1` the two cannot be separated: the total variance holds both.
#[derive(Debug, Clone, PartialEq)]
pub struct RealisationBla<T: Real> {
    realisations: usize,
    periods: usize,
    period_len: usize,
    ts: T,
    lines: Vec<usize>,
    omega: Vec<T>,
    bla: Vec<Complex<T>>,
    noise_variance: Option<Vec<T>>,
    total_variance: Option<Vec<T>>,
    spread: Option<SpreadTest>,
}

impl<T: Real> RealisationBla<T> {
    /// The BLA of `records` (one per realisation) of `periods` periods each, at the lines
    /// excited in every realisation (see the type documentation; `fraction` is the level
    /// rule of [`FrequencyData::excitation`]).
    ///
    /// # Errors
    /// - [`FdidError::TooShort`] when `records` is empty or no line is excited in every
    ///   realisation;
    /// - [`FdidError::LengthMismatch`] / [`FdidError::InvalidArgument`] named `"ts"` when
    ///   the records differ in length or sample time;
    /// - as [`PeriodicAverage::new`] (`periods` must divide the length).
    pub fn new(records: &[TimeData<T>], periods: usize, fraction: f64) -> Result<Self> {
        let first = same_grid(records)?;
        let averages = records
            .iter()
            .map(|r| PeriodicAverage::new(r, periods))
            .collect::<Result<Vec<_>>>()?;
        let mut excited = averages[0].data().excitation(fraction).lines().to_vec();
        for a in &averages[1..] {
            for (e, x) in excited
                .iter_mut()
                .zip(a.data().excitation(fraction).lines())
            {
                *e &= *x;
            }
        }
        let lines: Vec<usize> = (0..excited.len()).filter(|&k| excited[k]).collect();
        if lines.is_empty() {
            return Err(FdidError::TooShort {
                what: "lines excited in every realisation",
                needed: 1,
                got: 0,
            });
        }
        Ok(Self::assemble(&averages, lines, periods, first.ts()))
    }

    /// The BLA, its variances and the test from the period averages at `lines`.
    fn assemble(averages: &[PeriodicAverage<T>], lines: Vec<usize>, periods: usize, ts: T) -> Self {
        let r = averages.len();
        let r_f = r as f64;
        let per: Vec<Vec<(Complex<f64>, Option<f64>)>> = averages
            .iter()
            .map(|a| lines.iter().map(|&k| realisation_line(a, k)).collect())
            .collect();
        let mean: Vec<Complex<f64>> = (0..lines.len())
            .map(|i| per.iter().map(|g| g[i].0).sum::<Complex<f64>>() / r_f)
            .collect();
        let noise: Option<Vec<f64>> = (periods >= 2).then(|| {
            (0..lines.len())
                .map(|i| per.iter().map(|g| g[i].1.unwrap_or(0.0)).sum::<f64>() / (r_f * r_f))
                .collect()
        });
        let total: Option<Vec<f64>> = (r >= 2).then(|| {
            (0..lines.len())
                .map(|i| {
                    per.iter()
                        .map(|g| (g[i].0 - mean[i]).norm_sqr())
                        .sum::<f64>()
                        / (r_f * (r_f - 1.0))
                })
                .collect()
        });
        let spread = match (&total, &noise) {
            (Some(t), Some(n)) => SpreadTest::new(t, n, r, periods),
            _ => None,
        };
        let to_t = |v: &[f64]| -> Vec<T> { v.iter().map(|x| T::lit(*x)).collect() };
        let omega_all = averages[0].data().omega();
        Self {
            realisations: r,
            periods,
            period_len: averages[0].period_len(),
            ts,
            omega: lines.iter().map(|&k| omega_all[k]).collect(),
            lines,
            bla: mean
                .iter()
                .map(|g| Complex::new(T::lit(g.re), T::lit(g.im)))
                .collect(),
            noise_variance: noise.as_deref().map(to_t),
            total_variance: total.as_deref().map(to_t),
            spread,
        }
    }

    /// Number of realisations `R`.
    pub fn realisations(&self) -> usize {
        self.realisations
    }

    /// Number of periods `P` averaged per realisation.
    pub fn periods(&self) -> usize {
        self.periods
    }

    /// Samples per period `M`.
    pub fn period_len(&self) -> usize {
        self.period_len
    }

    /// The excited DFT lines `k` of one period (increasing).
    pub fn lines(&self) -> &[usize] {
        &self.lines
    }

    /// Their frequencies `ω_k = 2πk/(M Ts)` (rad/s).
    pub fn omega(&self) -> &[T] {
        &self.omega
    }

    /// The BLA `Ĝ_k`.
    pub fn bla(&self) -> &[Complex<T>] {
        &self.bla
    }

    /// The noise variance of `Ĝ_k` from the periods; `None` for `P = 1`.
    pub fn noise_variance(&self) -> Option<&[T]> {
        self.noise_variance.as_deref()
    }

    /// The total variance of `Ĝ_k` from the realisations; `None` for `R = 1`.
    pub fn total_variance(&self) -> Option<&[T]> {
        self.total_variance.as_deref()
    }

    /// The test of the total against the noise variance; `None` unless `R ≥ 2` and
    /// `P ≥ 2`.
    pub fn spread_test(&self) -> Option<&SpreadTest> {
        self.spread.as_ref()
    }

    /// The BLA as frequency response data (`Y = Ĝ`, `U = 1`, sample time `Ts`) with the
    /// total variance as output noise variance (`R − 1` degrees of freedom) when `R ≥ 2`,
    /// else the noise variance (`R(P − 1)` degrees of freedom) when `P ≥ 2`, else none.
    ///
    /// # Errors
    /// [`FdidError::NonFinite`] if a value is not finite.
    pub fn total_data(&self) -> Result<FrequencyData<T>> {
        match (&self.total_variance, &self.noise_variance) {
            (Some(t), _) => self.data_with(t, self.realisations - 1),
            (None, Some(n)) => self.data_with(n, self.realisations * (self.periods - 1)),
            (None, None) => {
                FrequencyData::from_frf(self.omega.clone(), self.bla.clone(), Some(self.ts))
            }
        }
    }

    /// The BLA as frequency response data weighted by the noise variance (between
    /// periods, `R(P − 1)` degrees of freedom); `None` for `P = 1`.
    ///
    /// # Errors
    /// [`FdidError::NonFinite`] if a value is not finite.
    pub fn noise_data(&self) -> Option<Result<FrequencyData<T>>> {
        let n = self.noise_variance.as_ref()?;
        Some(self.data_with(n, self.realisations * (self.periods - 1)))
    }

    fn data_with(&self, var: &[T], dof: usize) -> Result<FrequencyData<T>> {
        FrequencyData::from_frf(self.omega.clone(), self.bla.clone(), Some(self.ts))?
            .with_noise(NoiseVariances::output_only(var.to_vec()))?
            .with_variance_dof(dof)
    }
}

/// `Ĝ_r,k = Ȳ_r,k/Ū_r,k` of one realisation and, with noise variances, its noise variance
/// `(σ̂²_Y + |Ĝ|² σ̂²_U − 2 Re(Ĝ* σ̂_YU)) / |Ū|²`.
/// The first of `records` after checking that every record has its length and sample
/// time (realisations of one experiment).
///
/// # Errors
/// [`FdidError::TooShort`] without records; [`FdidError::LengthMismatch`] /
/// [`FdidError::InvalidArgument`] named `"ts"` when the records differ in length or
/// sample time.
pub(super) fn same_grid<T: Real>(records: &[TimeData<T>]) -> Result<&TimeData<T>> {
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
    Ok(first)
}

fn realisation_line<T: Real>(avg: &PeriodicAverage<T>, k: usize) -> (Complex<f64>, Option<f64>) {
    let d = avg.data();
    let (y, u) = (f64c(d.y()[k]), f64c(d.u()[k]));
    let g = y / u;
    let var = d.noise().map(|nv| {
        ((nv.var_y[k].to_f64_lossless() + g.norm_sqr() * nv.var_u[k].to_f64_lossless()
            - 2.0 * (g.conj() * f64c(nv.cov_yu[k])).re)
            / u.norm_sqr())
        .max(0.0)
    });
    (g, var)
}
