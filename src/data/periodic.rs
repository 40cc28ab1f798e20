//! Periodic records: averaging the DFT over `P` periods and estimating the noise
//! (co)variances from the spread between periods.

use crate::data::time::{TimeData, dft_pair_with, line_frequencies};
use crate::data::{FrequencyData, NoiseVariances};
use crate::error::{FdidError, Result, check_finite, check_finite_complex};
use crate::scalar::{Complex, Real};
use rustfft::FftPlanner;

/// The DFT of a periodic record averaged over its `P` periods, with the sample noise
/// (co)variances between periods.
///
/// The record of `N = P·M` samples is cut into `P` periods of `M` samples. Period `p`
/// (`p = 0, …, P−1`) has the DFT (McKelvey eq. 1 with `N → M`)
///
/// `X_p(ω_k) = (1/√M) Σ_{t=0}^{M−1} x((pM + t) Ts) e^{−i 2π k t / M}`,
/// `k = 0, …, ⌊M/2⌋`, `ω_k = 2πk / (M Ts)`,
///
/// and the averaged spectra are `X̄(ω_k) = (1/P) Σ_p X_p(ω_k)` for `x = u, y`. When
/// `P ≥ 2` the per-period sample (co)variances are
///
/// - `s²_Y[k] = (1/(P−1)) Σ_p |Y_p[k] − Ȳ[k]|²`,
/// - `s²_U[k] = (1/(P−1)) Σ_p |U_p[k] − Ū[k]|²`,
/// - `s_YU[k] = (1/(P−1)) Σ_p (Y_p[k] − Ȳ[k]) (U_p[k] − Ū[k])*`,
///
/// and the noise (co)variances of the *mean* attached to the averaged data are these
/// divided by `P`: `var_y[k] = s²_Y[k] / P`, `var_u[k] = s²_U[k] / P`,
/// `cov_yu[k] = s_YU[k] / P`. With `P = 1` there is no noise estimate.
///
/// [`TimeData::average_periods`] is the one-call shortcut that returns only the averaged
/// [`FrequencyData`].
#[derive(Debug, Clone, PartialEq)]
pub struct PeriodicAverage<T: Real> {
    data: FrequencyData<T>,
    periods: usize,
    period_len: usize,
    sample: Option<NoiseVariances<T>>,
}

impl<T: Real> PeriodicAverage<T> {
    /// Averages the DFT of `record` over `periods` periods (see the type documentation
    /// for the formulas).
    ///
    /// # Errors
    /// - [`FdidError::InvalidArgument`] named `"periods"` when `periods = 0` or when the
    ///   record length `N` is not a multiple of `periods` (the message names both);
    /// - [`FdidError::TooShort`] when a period has fewer than 2 samples;
    /// - [`FdidError::NonFinite`] if a variance overflows `T`.
    pub fn new(record: &TimeData<T>, periods: usize) -> Result<Self> {
        let m = period_length(record.len(), periods)?;
        let (u_p, y_p) = period_spectra(record, m);
        let lines = m / 2 + 1;
        let p_t = T::from_usize_lossy(periods);
        let u_mean = mean_over_periods(&u_p, lines, p_t);
        let y_mean = mean_over_periods(&y_p, lines, p_t);
        let sample = if periods >= 2 {
            Some(sample_variances(&u_p, &y_p, &u_mean, &y_mean)?)
        } else {
            None
        };
        let omega = line_frequencies(m, record.ts());
        let mut data = FrequencyData::new(omega, y_mean, u_mean, Some(record.ts()))?;
        if let Some(s) = &sample {
            data = data
                .with_noise(NoiseVariances {
                    var_y: s.var_y.iter().map(|v| *v / p_t).collect(),
                    var_u: s.var_u.iter().map(|v| *v / p_t).collect(),
                    cov_yu: s.cov_yu.iter().map(|v| *v / p_t).collect(),
                })?
                .with_variance_dof(periods - 1)?;
        }
        Ok(Self {
            data,
            periods,
            period_len: m,
            sample,
        })
    }

    /// Number of periods `P`.
    pub fn periods(&self) -> usize {
        self.periods
    }

    /// Samples per period `M = N / P`.
    pub fn period_len(&self) -> usize {
        self.period_len
    }

    /// The averaged spectra `Ū`, `Ȳ` on `ω_k = 2πk/(M Ts)`, with the noise (co)variances
    /// of the mean (`s²/P`) when `P ≥ 2`.
    pub fn data(&self) -> &FrequencyData<T> {
        &self.data
    }

    /// The per-period sample (co)variances `s²_Y`, `s²_U`, `s_YU` (divisor `P − 1`, *not*
    /// divided by `P`); `None` when `P = 1`.
    pub fn sample_variances(&self) -> Option<&NoiseVariances<T>> {
        self.sample.as_ref()
    }

    /// The averaged data, with the noise (co)variances of the mean when `P ≥ 2`.
    pub fn into_frequency_data(self) -> FrequencyData<T> {
        self.data
    }
}

/// The samples per period `M = N / P` of a record of `n` samples in `periods` periods.
pub(crate) fn period_length(n: usize, periods: usize) -> Result<usize> {
    if periods == 0 {
        return Err(FdidError::InvalidArgument {
            name: "periods",
            value: "0".into(),
            reason: "at least one period is needed".into(),
        });
    }
    if !n.is_multiple_of(periods) {
        return Err(FdidError::InvalidArgument {
            name: "periods",
            value: periods.to_string(),
            reason: format!(
                "the record length N = {n} is not a multiple of the number of periods {periods}"
            ),
        });
    }
    let m = n / periods;
    if m < 2 {
        return Err(FdidError::TooShort {
            what: "samples per period",
            needed: 2,
            got: m,
        });
    }
    Ok(m)
}

/// Per period a spectrum on the lines `k = 0, …, ⌊M/2⌋`.
type Spectra<T> = Vec<Vec<Complex<T>>>;

/// The DFTs `U_p`, `Y_p` of each period of `m` samples of `record`: one packed FFT of `u`
/// and `y` per period, as [`TimeData::dft`].
fn period_spectra<T: Real>(record: &TimeData<T>, m: usize) -> (Spectra<T>, Spectra<T>) {
    let plan = FftPlanner::<T>::new().plan_fft_forward(m);
    record
        .u()
        .chunks_exact(m)
        .zip(record.y().chunks_exact(m))
        .map(|(u, y)| dft_pair_with(plan.as_ref(), u, y))
        .unzip()
}

/// `X̄[k] = (1/P) Σ_p X_p[k]` on the lines `k < lines`, with `p_t = P`.
pub(crate) fn mean_over_periods<T: Real>(
    x: &[Vec<Complex<T>>],
    lines: usize,
    p_t: T,
) -> Vec<Complex<T>> {
    (0..lines)
        .map(|k| {
            x.iter()
                .fold(Complex::new(T::zero(), T::zero()), |acc, xp| acc + xp[k])
                / p_t
        })
        .collect()
}

/// The per-period sample (co)variances `s²_Y`, `s²_U`, `s_YU` (divisor `P − 1`) of the
/// spectra `u_p`, `y_p` of `P ≥ 2` periods around their means.
///
/// # Errors
/// [`FdidError::NonFinite`] if a variance overflows `T`.
fn sample_variances<T: Real>(
    u_p: &[Vec<Complex<T>>],
    y_p: &[Vec<Complex<T>>],
    u_mean: &[Complex<T>],
    y_mean: &[Complex<T>],
) -> Result<NoiseVariances<T>> {
    let lines = u_mean.len();
    let dof = T::from_usize_lossy(u_p.len() - 1);
    let mut var_y = vec![T::zero(); lines];
    let mut var_u = vec![T::zero(); lines];
    let mut cov_yu = vec![Complex::new(T::zero(), T::zero()); lines];
    for (up, yp) in u_p.iter().zip(y_p) {
        for k in 0..lines {
            let du = up[k] - u_mean[k];
            let dy = yp[k] - y_mean[k];
            var_y[k] += dy.norm_sqr();
            var_u[k] += du.norm_sqr();
            cov_yu[k] += dy * du.conj();
        }
    }
    for k in 0..lines {
        var_y[k] /= dof;
        var_u[k] /= dof;
        cov_yu[k] /= dof;
    }
    check_finite("var_y", &var_y)?;
    check_finite("var_u", &var_u)?;
    check_finite_complex("cov_yu", &cov_yu)?;
    Ok(NoiseVariances {
        var_y,
        var_u,
        cov_yu,
    })
}

impl<T: Real> TimeData<T> {
    /// Averages the DFT over `periods` periods of a periodic record and, for
    /// `periods ≥ 2`, attaches the noise (co)variances of the mean:
    /// `var_y[k] = (1/(P(P−1))) Σ_p |Y_p[k] − Ȳ[k]|²`, `var_u` likewise and
    /// `cov_yu[k] = (1/(P(P−1))) Σ_p (Y_p[k] − Ȳ[k])(U_p[k] − Ū[k])*`, with the per-period
    /// DFT scaled by `1/√M` on the lines `ω_k = 2πk/(M Ts)`, `k = 0, …, ⌊M/2⌋`,
    /// `M = N/P`. See [`PeriodicAverage`] for the details and the sample variances.
    ///
    /// # Errors
    /// As [`PeriodicAverage::new`].
    pub fn average_periods(&self, periods: usize) -> Result<FrequencyData<T>> {
        PeriodicAverage::new(self, periods).map(PeriodicAverage::into_frequency_data)
    }
}
