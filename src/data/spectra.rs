//! The spectra of a record with several inputs and outputs: one experiment in which nu
//! inputs act together on ny outputs, as a multi-channel time record's DFT gives them.

use super::time::{TimeData, dft_lines_with, line_frequencies};
use super::{FrequencyData, MimoNoise};
use crate::error::{FdidError, Result};
use crate::scalar::{Complex, Real};
use rustfft::FftPlanner;

/// The DFT spectra U_j(ω_k) of nu inputs and Y_i(ω_k) of ny outputs measured together on
/// one frequency grid (rad/s): the data of Y(ω_k) = G(ω_k) U(ω_k) + T(ω_k) + V(ω_k), with G
/// the ny × nu transfer matrix and T the transient of a finite record (McKelvey eq. 4).
/// Unlike an [`FrfMatrix`](super::FrfMatrix), the inputs need not be separated by
/// experiment: a model fitted to these spectra explains each output by every input at
/// once. Each channel is held as single-channel data with unit input (so the checks and
/// band selection of [`FrequencyData`] apply).
///
/// ```
/// use fdid::data::MimoSpectra;
///
/// // two inputs, one output, 64 samples at Ts = 0.1 s
/// let u1: Vec<f64> = (0..64).map(|t| (0.3 * t as f64).sin()).collect();
/// let u2: Vec<f64> = (0..64).map(|t| (0.7 * t as f64).cos()).collect();
/// let y: Vec<f64> = u1.iter().zip(&u2).map(|(a, b)| 2.0 * a - b).collect();
/// let s = MimoSpectra::from_time(vec![u1, u2], vec![y], 0.1).unwrap();
/// assert_eq!((s.nu(), s.ny(), s.len()), (2, 1, 33));
/// let k = 5;
/// let expected = s.u(0)[k] * 2.0 - s.u(1)[k];
/// assert!((s.y(0)[k] - expected).norm() < 1e-12);
/// ```
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct MimoSpectra<T: Real> {
    inputs: Vec<FrequencyData<T>>,
    outputs: Vec<FrequencyData<T>>,
    noise: Option<MimoNoise<T>>,
}

impl<T: Real> MimoSpectra<T> {
    /// Builds the spectra from the lines `omega` (rad/s, ascending), the input spectra
    /// `u` (nu vectors) and the output spectra `y` (ny vectors), each one value per line,
    /// with an optional sample time.
    ///
    /// # Errors
    /// No input or no output, and every error of [`FrequencyData::from_frf`] for a channel
    /// (lengths, non-finite values, unsorted or negative frequencies).
    pub fn new(
        omega: Vec<T>,
        u: Vec<Vec<Complex<T>>>,
        y: Vec<Vec<Complex<T>>>,
        ts: Option<T>,
    ) -> Result<Self> {
        check_channels(u.len(), y.len())?;
        let channel = |x: Vec<Complex<T>>| FrequencyData::from_frf(omega.clone(), x, ts);
        Ok(Self {
            inputs: u.into_iter().map(channel).collect::<Result<_>>()?,
            outputs: y.into_iter().map(channel).collect::<Result<_>>()?,
            noise: None,
        })
    }

    /// The DFT (McKelvey eq. 1, as [`TimeData::dft`]) of nu input and ny output records
    /// of N samples at sample time `ts`: lines k = 0, …, ⌊N/2⌋ at ω_k = 2πk/(N Ts).
    ///
    /// # Errors
    /// No input or no output, records of different lengths or shorter than 2 samples,
    /// non-finite samples, a sample time that is not positive and finite (as
    /// [`TimeData::new`], naming the channel's position).
    pub fn from_time(inputs: Vec<Vec<T>>, outputs: Vec<Vec<T>>, ts: T) -> Result<Self> {
        let n = check_records(&inputs, &outputs)?;
        let plan = FftPlanner::<T>::new().plan_fft_forward(n.max(1));
        let omega = line_frequencies(n, ts);
        let spectra = |channels: Vec<Vec<T>>, what: &str| -> Result<Vec<FrequencyData<T>>> {
            channels
                .into_iter()
                .enumerate()
                .map(|(c, x)| {
                    // the checks of a time record: length, finite samples, Ts, DFT range
                    let record = TimeData::new(x.clone(), x, ts).map_err(|e| {
                        FdidError::InvalidArgument {
                            name: "channel",
                            value: format!("{what} {}", c + 1),
                            reason: e.to_string(),
                        }
                    })?;
                    let lines = dft_lines_with(plan.as_ref(), record.u());
                    FrequencyData::from_frf(omega.clone(), lines, Some(ts))
                })
                .collect()
        };
        let inputs = spectra(inputs, "input")?;
        let outputs = spectra(outputs, "output")?;
        Ok(Self {
            inputs,
            outputs,
            noise: None,
        })
    }

    /// The spectra of a periodic record averaged over its P = `periods` periods of
    /// M = N/P samples (as [`PeriodicAverage`](super::PeriodicAverage) does for one
    /// channel): X̄(ω_k) = (1/P) Σ_p X_p(ω_k) for every channel, on the lines k = 0, …,
    /// ⌊M/2⌋ at ω_k = 2πk/(M Ts), with the noise of the means from the spread between
    /// periods when P ≥ 2 ([`MimoNoise`]: the ny × ny output covariance per line and the
    /// input variances). Drop transient periods from the records first.
    ///
    /// ```
    /// use fdid::data::MimoSpectra;
    ///
    /// // one input repeated over 4 periods of 16 samples; the output's second half of
    /// // each period alternates in sign between periods (the part that does not repeat)
    /// let u: Vec<f64> = (0..64).map(|t| ((t % 16) as f64 * 0.4).sin()).collect();
    /// let y: Vec<f64> = (0..64)
    ///     .map(|t| u[t] + if (t / 16) % 2 == 0 { 0.01 } else { -0.01 })
    ///     .collect();
    /// let s = MimoSpectra::from_periods(vec![u], vec![y.clone(), y], 1.0, 4).unwrap();
    /// assert_eq!(s.len(), 9);
    /// let noise = s.noise().unwrap();
    /// assert_eq!(noise.periods(), 4);
    /// // the alternating part shows on the DC line only, in both outputs alike
    /// let c = noise.output_covariance(0);
    /// assert!(c[(0, 0)].re > 0.0 && (c[(0, 1)] - c[(0, 0)]).norm() < 1e-15);
    /// assert!(noise.output_covariance(3)[(0, 0)].re < 1e-25);
    /// ```
    ///
    /// # Errors
    /// As [`MimoSpectra::from_time`]; `periods` zero or not dividing N, a period shorter
    /// than 2 samples ([`FdidError::InvalidArgument`] / [`FdidError::TooShort`]); an
    /// input that does not repeat from period to period (the part that differs between
    /// periods above [`PERIODICITY_TOLERANCE`](super::PERIODICITY_TOLERANCE) of the power
    /// of the part that repeats, [`TimeData::period_mismatch`]), naming the input.
    pub fn from_periods(
        inputs: Vec<Vec<T>>,
        outputs: Vec<Vec<T>>,
        ts: T,
        periods: usize,
    ) -> Result<Self> {
        let n = check_records(&inputs, &outputs)?;
        let m = super::periodic::period_length(n, periods)?;
        if periods >= 2 {
            for (j, u) in inputs.iter().enumerate() {
                let ratio = TimeData::new(u.clone(), u.clone(), ts)?.period_mismatch(periods)?;
                if !(ratio <= super::PERIODICITY_TOLERANCE) {
                    return Err(FdidError::InvalidArgument {
                        name: "periods",
                        value: periods.to_string(),
                        reason: format!(
                            "input {} does not repeat from period to period: the part that \
                             differs between periods has {} the power of the part that \
                             repeats (tolerance {} times); blocks that are different \
                             realisations are not periods",
                            j + 1,
                            if ratio.is_finite() {
                                format!("{ratio:.3} times")
                            } else {
                                "more than".to_string()
                            },
                            super::PERIODICITY_TOLERANCE
                        ),
                    });
                }
            }
        }
        let plan = FftPlanner::<T>::new().plan_fft_forward(m);
        let per_period = |channels: &[Vec<T>]| -> Vec<Vec<Vec<Complex<T>>>> {
            channels
                .iter()
                .map(|x| {
                    x.chunks_exact(m)
                        .map(|period| dft_lines_with(plan.as_ref(), period))
                        .collect()
                })
                .collect()
        };
        let p = T::from_usize_lossy(periods);
        let mean = |spectra: &[Vec<Vec<Complex<T>>>]| -> Vec<Vec<Complex<T>>> {
            spectra
                .iter()
                .map(|c| super::periodic::mean_over_periods(c, m / 2 + 1, p))
                .collect()
        };
        let u_p = per_period(&inputs);
        let y_p = per_period(&outputs);
        let (u_mean, y_mean) = (mean(&u_p), mean(&y_p));
        let noise = if periods >= 2 {
            Some(MimoNoise::between_periods(&u_p, &y_p, &u_mean, &y_mean)?)
        } else {
            None
        };
        let mut spectra = Self::new(line_frequencies(m, ts), u_mean, y_mean, Some(ts))?;
        spectra.noise = noise;
        Ok(spectra)
    }

    /// The noise of the means of a period-averaged record ([`MimoSpectra::from_periods`]
    /// with two periods or more); `None` otherwise.
    pub fn noise(&self) -> Option<&MimoNoise<T>> {
        self.noise.as_ref()
    }

    /// Inputs nu.
    pub fn nu(&self) -> usize {
        self.inputs.len()
    }

    /// Outputs ny.
    pub fn ny(&self) -> usize {
        self.outputs.len()
    }

    /// Number of frequency lines.
    pub fn len(&self) -> usize {
        self.inputs[0].len()
    }

    /// Always false for validated spectra.
    pub fn is_empty(&self) -> bool {
        self.inputs[0].is_empty()
    }

    /// Angular frequencies (rad/s).
    pub fn omega(&self) -> &[T] {
        self.inputs[0].omega()
    }

    /// Sample time, when the data are sampled.
    pub fn ts(&self) -> Option<T> {
        self.inputs[0].ts()
    }

    /// Input j's spectrum (zero-based).
    ///
    /// # Panics
    /// When j ≥ nu.
    pub fn u(&self, j: usize) -> &[Complex<T>] {
        self.inputs[j].y()
    }

    /// Output i's spectrum (zero-based).
    ///
    /// # Panics
    /// When i ≥ ny.
    pub fn y(&self, i: usize) -> &[Complex<T>] {
        self.outputs[i].y()
    }

    /// Keeps the lines with `f_min ≤ f ≤ f_max` (Hz) in every channel.
    ///
    /// # Errors
    /// As [`FrequencyData::band_hz`].
    pub fn band_hz(&self, f_min: T, f_max: T) -> Result<Self> {
        // the first channel's band (and its errors) gives the lines every channel keeps
        let kept = self.inputs[0].band_hz(f_min, f_max)?;
        let keep: Vec<bool> = self
            .omega()
            .iter()
            .map(|w| {
                kept.omega()
                    .binary_search_by(|v| v.partial_cmp(w).unwrap_or(std::cmp::Ordering::Less))
                    .is_ok()
            })
            .collect();
        self.select_lines(&keep)
    }

    /// Keeps the lines where `keep` is true.
    ///
    /// # Errors
    /// As [`FrequencyData::select_lines`] (wrong length, nothing kept).
    pub fn select_lines(&self, keep: &[bool]) -> Result<Self> {
        let select = |c: &FrequencyData<T>| c.select_lines(keep);
        Ok(Self {
            inputs: self.inputs.iter().map(select).collect::<Result<_>>()?,
            outputs: self.outputs.iter().map(select).collect::<Result<_>>()?,
            noise: self.noise.as_ref().map(|n| n.select(keep)),
        })
    }
}

/// Checks the channels of a record: at least one input and one output, all of the first
/// input's length; returns that length.
fn check_records<T: Real>(inputs: &[Vec<T>], outputs: &[Vec<T>]) -> Result<usize> {
    check_channels(inputs.len(), outputs.len())?;
    let n = inputs[0].len();
    for (what, x) in inputs
        .iter()
        .map(|x| ("input", x))
        .chain(outputs.iter().map(|x| ("output", x)))
    {
        if x.len() != n {
            return Err(FdidError::LengthMismatch {
                what: if what == "input" {
                    "samples of an input (as the first input)"
                } else {
                    "samples of an output (as the first input)"
                },
                expected: n,
                got: x.len(),
            });
        }
    }
    Ok(n)
}

fn check_channels(nu: usize, ny: usize) -> Result<()> {
    if nu == 0 || ny == 0 {
        return Err(FdidError::InvalidArgument {
            name: "channels",
            value: format!("{nu} inputs and {ny} outputs"),
            reason: "spectra need at least one input and one output".into(),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_records_are_errors_naming_the_channel() {
        let ok = vec![0.0, 1.0, 0.5, -1.0];
        let err = MimoSpectra::from_time(vec![ok.clone()], vec![vec![0.0, 1.0]], 1.0);
        assert!(err.unwrap_err().to_string().contains("output"));
        let mut bad = ok.clone();
        bad[2] = f64::NAN;
        let err = MimoSpectra::from_time(vec![ok.clone(), bad], vec![ok.clone()], 1.0);
        assert!(err.unwrap_err().to_string().contains("input 2"));
        assert!(MimoSpectra::<f64>::from_time(vec![], vec![ok.clone()], 1.0).is_err());
        assert!(MimoSpectra::from_time(vec![ok.clone()], vec![ok.clone()], 0.0).is_err());
        let s = MimoSpectra::from_time(vec![ok.clone()], vec![ok], 1.0).unwrap();
        assert_eq!(s.len(), 3);
        let no_dc = s.select_lines(&[false, true, true]).unwrap();
        assert_eq!(no_dc.len(), 2);
        assert!(s.band_hz(0.6, 0.9).is_err());
    }
}
