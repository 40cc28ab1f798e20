//! Frequency-domain data: spectra `Y_k`, `U_k` at frequencies `ω_k`, with optional noise
//! (co)variances.

use crate::error::{FdidError, Result, check_finite, check_finite_complex};
use crate::scalar::{Complex, Real};

/// Per-line noise (co)variances of the measured spectra.
///
/// `var_y[k] = E|N_Y(ω_k)|²`, `var_u[k] = E|N_U(ω_k)|²` and `cov_yu[k] = E[N_Y N_U*]`.
/// For frequency response data (`U_k = 1`), `var_y` is the variance of the FRF noise and
/// `var_u` is zero.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct NoiseVariances<T: Real> {
    /// Output noise variance per line.
    pub var_y: Vec<T>,
    /// Input noise variance per line.
    pub var_u: Vec<T>,
    /// Output–input noise covariance per line.
    pub cov_yu: Vec<Complex<T>>,
}

impl<T: Real> NoiseVariances<T> {
    /// Output noise only (`var_u = 0`, `cov_yu = 0`): the case of FRF data with a `var`
    /// column.
    pub fn output_only(var_y: Vec<T>) -> Self {
        let n = var_y.len();
        Self {
            var_y,
            var_u: vec![T::zero(); n],
            cov_yu: vec![Complex::new(T::zero(), T::zero()); n],
        }
    }

    /// Number of lines.
    pub fn len(&self) -> usize {
        self.var_y.len()
    }

    /// True when there are no lines.
    pub fn is_empty(&self) -> bool {
        self.var_y.is_empty()
    }

    fn validate(&self, n: usize) -> Result<()> {
        for (what, got) in [
            ("var_y", self.var_y.len()),
            ("var_u", self.var_u.len()),
            ("cov_yu", self.cov_yu.len()),
        ] {
            if got != n {
                return Err(FdidError::LengthMismatch {
                    what,
                    expected: n,
                    got,
                });
            }
        }
        check_finite("var_y", &self.var_y)?;
        check_finite("var_u", &self.var_u)?;
        check_finite_complex("cov_yu", &self.cov_yu)?;
        for (what, v) in [("var_y", &self.var_y), ("var_u", &self.var_u)] {
            if let Some(index) = v.iter().position(|x| *x < T::zero()) {
                return Err(FdidError::InvalidArgument {
                    name: what,
                    value: format!("{} at entry {index}", v[index]),
                    reason: "a variance cannot be negative".into(),
                });
            }
        }
        Ok(())
    }

    /// Keeps the lines where `keep` is true.
    pub(crate) fn filter(&self, keep: &[bool]) -> Self {
        Self {
            var_y: pick(&self.var_y, keep),
            var_u: pick(&self.var_u, keep),
            cov_yu: pick(&self.cov_yu, keep),
        }
    }
}

/// Frequency-domain data of one or more merged experiments.
///
/// Frequencies are angular (rad/s) inside the crate; files use Hz. Invariants, checked by
/// [`FrequencyData::new`]: equal lengths, finite values, frequencies non-negative and
/// non-decreasing (equal frequencies occur only after merging experiments), at least one
/// line, `ts > 0` when given.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct FrequencyData<T: Real> {
    /// Shared by the data derived from these with the same lines (normalised or with
    /// another sample time) and by the grid a model keeps (see [`Self::shared_omega`]).
    omega: std::sync::Arc<[T]>,
    y: Vec<Complex<T>>,
    u: Vec<Complex<T>>,
    noise: Option<NoiseVariances<T>>,
    ts: Option<T>,
    /// Degrees of freedom of sample noise variances (P − 1 for P periods).
    #[cfg_attr(feature = "serde", serde(default))]
    variance_dof: Option<usize>,
    /// Merged from sampled experiments with different sample times.
    #[cfg_attr(feature = "serde", serde(default))]
    mixed_ts: bool,
}

impl<T: Real> FrequencyData<T> {
    /// Builds validated spectra data: output `y`, input `u` at angular frequencies `omega`
    /// (rad/s), with an optional sample time `ts` (s) for discrete-time models.
    ///
    /// # Errors
    /// Mismatched lengths, no lines, non-finite values, negative or decreasing frequencies,
    /// `ts ≤ 0` or non-finite.
    pub fn new(
        omega: Vec<T>,
        y: Vec<Complex<T>>,
        u: Vec<Complex<T>>,
        ts: Option<T>,
    ) -> Result<Self> {
        Self::new_shared(omega.into(), y, u, ts)
    }

    /// [`Self::new`] with the frequencies already in the shared buffer the data keep.
    pub(crate) fn new_shared(
        omega: std::sync::Arc<[T]>,
        y: Vec<Complex<T>>,
        u: Vec<Complex<T>>,
        ts: Option<T>,
    ) -> Result<Self> {
        Self::checked(omega, y, u, ts, true)
    }

    /// [`Self::new`], checking the values of `u` only when `check_u` (not for the unit
    /// input of an FRF).
    fn checked(
        omega: std::sync::Arc<[T]>,
        y: Vec<Complex<T>>,
        u: Vec<Complex<T>>,
        ts: Option<T>,
        check_u: bool,
    ) -> Result<Self> {
        let n = omega.len();
        if n == 0 {
            return Err(FdidError::TooShort {
                what: "frequency lines",
                needed: 1,
                got: 0,
            });
        }
        for (what, got) in [("y", y.len()), ("u", u.len())] {
            if got != n {
                return Err(FdidError::LengthMismatch {
                    what,
                    expected: n,
                    got,
                });
            }
        }
        // the frequencies' tests (finite, not negative, not decreasing) or-ed over every
        // line in two passes on vector lanes; the bad line is searched (in the order of
        // the errors) only when there is one
        let suspect = omega.iter().fold(false, |bad, w| {
            bad | (*w * T::zero() != T::zero()) | (*w < T::zero())
        }) | omega
            .iter()
            .zip(&omega[1..])
            .fold(false, |bad, (a, b)| bad | (*b < *a));
        if suspect {
            check_finite("omega", &omega)?;
        }
        check_finite_complex("y", &y)?;
        if check_u {
            check_finite_complex("u", &u)?;
        }
        if suspect && let Some(index) = omega.iter().position(|w| *w < T::zero()) {
            return Err(FdidError::NegativeFrequency {
                index,
                value: omega[index].to_f64_lossless(),
            });
        }
        if suspect && let Some(i) = omega.windows(2).position(|w| w[1] < w[0]) {
            return Err(FdidError::Unsorted {
                index: i + 1,
                value: omega[i + 1].to_f64_lossless(),
                previous: omega[i].to_f64_lossless(),
            });
        }
        if let Some(t) = ts
            && (!num_traits::Float::is_finite(t) || t <= T::zero())
        {
            return Err(FdidError::InvalidArgument {
                name: "ts",
                value: format!("{t}"),
                reason: "the sample time must be positive and finite".into(),
            });
        }
        Ok(Self {
            omega,
            y,
            u,
            noise: None,
            ts,
            variance_dof: None,
            mixed_ts: false,
        })
    }

    /// Frequency response data `G_k` (so `U_k = 1`, `Y_k = G_k`).
    ///
    /// # Errors
    /// As [`FrequencyData::new`].
    pub fn from_frf(omega: Vec<T>, frf: Vec<Complex<T>>, ts: Option<T>) -> Result<Self> {
        Self::from_frf_shared(omega.into(), frf, ts)
    }

    /// [`Self::from_frf`] with the frequencies already in the shared buffer the data keep
    /// (no copy: a reader builds them there).
    pub(crate) fn from_frf_shared(
        omega: std::sync::Arc<[T]>,
        frf: Vec<Complex<T>>,
        ts: Option<T>,
    ) -> Result<Self> {
        let u = vec![Complex::new(T::one(), T::zero()); frf.len()];
        Self::checked(omega, frf, u, ts, false)
    }

    /// Attaches per-line noise (co)variances.
    ///
    /// # Errors
    /// Lengths differ from the number of lines, non-finite or negative variances.
    pub fn with_noise(mut self, noise: NoiseVariances<T>) -> Result<Self> {
        noise.validate(self.len())?;
        self.noise = Some(noise);
        Ok(self)
    }

    /// Removes the noise (co)variances.
    pub fn without_noise(mut self) -> Self {
        self.noise = None;
        self.variance_dof = None;
        self
    }

    /// Declares the noise (co)variances to be sample estimates with `dof` degrees of freedom
    /// per line (P − 1 when estimated from P periods, as [`crate::TimeData::average_periods`]
    /// sets). Validation statistics then expect the cost inflated by ν/(ν − 2), ν = 2·dof,
    /// the mean of the F(2, ν) distribution of |Y − ĜU|²/σ̂².
    ///
    /// # Errors
    /// `dof = 0`, or data without noise variances.
    pub fn with_variance_dof(mut self, dof: usize) -> Result<Self> {
        if dof == 0 || self.noise.is_none() {
            return Err(FdidError::InvalidArgument {
                name: "variance_dof",
                value: format!("{dof}"),
                reason: "needs noise variances and at least one degree of freedom".into(),
            });
        }
        self.variance_dof = Some(dof);
        Ok(self)
    }

    /// True for data merged from sampled experiments with different sample times: only a
    /// continuous-time model without a sampled transient describes them.
    pub fn mixed_sample_times(&self) -> bool {
        self.mixed_ts
    }

    /// Marks the data as merged from different sample times (see
    /// [`FrequencyData::mixed_sample_times`]); drops the sample time.
    pub(crate) fn mark_mixed_sample_times(mut self) -> Self {
        self.ts = None;
        self.mixed_ts = true;
        self
    }

    /// Degrees of freedom of the noise variances when they are sample estimates (`None`:
    /// the variances are taken as exact).
    pub fn variance_dof(&self) -> Option<usize> {
        self.variance_dof
    }

    /// Number of frequency lines.
    pub fn len(&self) -> usize {
        self.omega.len()
    }

    /// Always false for validated data (kept for API symmetry with `len`).
    pub fn is_empty(&self) -> bool {
        self.omega.is_empty()
    }

    /// Angular frequencies ω_k (rad/s).
    pub fn omega(&self) -> &[T] {
        &self.omega
    }

    /// The frequencies' buffer itself: evaluations on [`Self::omega`] (or on a run of
    /// its lines) read the very memory a model kept from it, which no other buffer
    /// shares, so a model knows its lines without comparing their values.
    pub(crate) fn shared_omega(&self) -> &std::sync::Arc<[T]> {
        &self.omega
    }

    /// Frequencies in Hz.
    pub fn freq_hz(&self) -> Vec<T> {
        let two_pi = T::two_pi();
        self.omega.iter().map(|w| *w / two_pi).collect()
    }

    /// Output spectrum Y_k.
    pub fn y(&self) -> &[Complex<T>] {
        &self.y
    }

    /// Input spectrum U_k (ones for FRF data).
    pub fn u(&self) -> &[Complex<T>] {
        &self.u
    }

    /// Noise (co)variances, if known.
    pub fn noise(&self) -> Option<&NoiseVariances<T>> {
        self.noise.as_ref()
    }

    /// Sample time (s), if the data come from a sampled record.
    pub fn ts(&self) -> Option<T> {
        self.ts
    }

    /// Sets or clears the sample time.
    ///
    /// # Errors
    /// `ts ≤ 0` or non-finite.
    pub fn with_ts(self, ts: Option<T>) -> Result<Self> {
        if let (Some(t), true) = (ts, self.mixed_ts) {
            return Err(FdidError::InvalidArgument {
                name: "ts",
                value: format!("{t}"),
                reason: "the data merge experiments with different sample times".into(),
            });
        }
        let noise = self.noise.clone();
        let dof = self.variance_dof;
        let mut d = Self::new(self.omega.to_vec(), self.y, self.u, ts)?;
        if let Some(n) = noise {
            d = d.with_noise(n)?;
        }
        d.variance_dof = dof;
        d.mixed_ts = self.mixed_ts;
        // the same lines: their buffer stays shared (see `omega`)
        d.omega = self.omega;
        Ok(d)
    }

    /// Empirical transfer function estimate Y_k / U_k.
    ///
    /// # Errors
    /// [`FdidError::ZeroInput`] at the first line where `U_k = 0`.
    pub fn etfe(&self) -> Result<Vec<Complex<T>>> {
        self.y
            .iter()
            .zip(&self.u)
            .enumerate()
            .map(|(k, (y, u))| {
                if u.norm_sqr() == T::zero() {
                    Err(FdidError::ZeroInput {
                        index: k,
                        omega: self.omega[k].to_f64_lossless(),
                    })
                } else {
                    Ok(*y / *u)
                }
            })
            .collect()
    }

    /// Keeps the lines with `omega_min ≤ ω_k ≤ omega_max` (rad/s): the ideal band-pass of
    /// McKelvey section 4.
    ///
    /// # Errors
    /// [`FdidError::EmptyBand`] when no line falls in the band, or bad edges.
    pub fn band(&self, omega_min: T, omega_max: T) -> Result<Self> {
        if !(num_traits::Float::is_finite(omega_min) && num_traits::Float::is_finite(omega_max))
            || omega_min > omega_max
        {
            return Err(FdidError::InvalidArgument {
                name: "band",
                value: format!("[{omega_min}, {omega_max}]"),
                reason: "edges must be finite with min ≤ max".into(),
            });
        }
        let keep: Vec<bool> = self
            .omega
            .iter()
            .map(|w| *w >= omega_min && *w <= omega_max)
            .collect();
        if !keep.iter().any(|k| *k) {
            return Err(FdidError::EmptyBand {
                min: omega_min.to_f64_lossless(),
                max: omega_max.to_f64_lossless(),
            });
        }
        Ok(self.filter(&keep))
    }

    /// Keeps the lines with `f_min ≤ f_k ≤ f_max` (Hz).
    ///
    /// # Errors
    /// As [`FrequencyData::band`].
    pub fn band_hz(&self, f_min: T, f_max: T) -> Result<Self> {
        self.band(f_min * T::two_pi(), f_max * T::two_pi())
    }

    /// Checks that the data carry a response to fit: some `Y_k ≠ 0`.
    ///
    /// # Errors
    /// [`FdidError::ZeroOutput`] when the output is zero on every line.
    pub fn check_output(&self) -> Result<()> {
        if self
            .y
            .iter()
            .all(|y| y.re == T::zero() && y.im == T::zero())
        {
            return Err(FdidError::ZeroOutput { lines: self.len() });
        }
        Ok(())
    }

    /// Keeps the lines where `keep[k]` is true, with their noise variances and sample time.
    ///
    /// # Errors
    /// `keep` has the wrong length, or keeps no line.
    pub fn select_lines(&self, keep: &[bool]) -> Result<Self> {
        if keep.len() != self.len() {
            return Err(FdidError::LengthMismatch {
                what: "line selection",
                expected: self.len(),
                got: keep.len(),
            });
        }
        if !keep.iter().any(|k| *k) {
            return Err(FdidError::TooShort {
                what: "selected frequency lines",
                needed: 1,
                got: 0,
            });
        }
        Ok(self.filter(keep))
    }

    /// Every ⌈N/`most`⌉-th line, counted down from the last so that the highest line stays,
    /// with the mask of the kept lines; `None` when the data have at most `most` lines.
    pub(crate) fn every_nth_line(&self, most: usize) -> Option<(Self, Vec<bool>)> {
        let n = self.len();
        let stride = n.div_ceil(most.max(1));
        if stride <= 1 {
            return None;
        }
        let keep: Vec<bool> = (0..n).map(|k| (n - 1 - k).is_multiple_of(stride)).collect();
        Some((self.filter(&keep), keep))
    }

    /// Keeps the lines where `keep[k]` is true (lengths must match; not checked here).
    pub(crate) fn filter(&self, keep: &[bool]) -> Self {
        Self {
            omega: pick(&self.omega, keep).into(),
            y: pick(&self.y, keep),
            u: pick(&self.u, keep),
            noise: self.noise.as_ref().map(|n| n.filter(keep)),
            ts: self.ts,
            variance_dof: self.variance_dof,
            mixed_ts: self.mixed_ts,
        }
    }

    /// Y scaled by `output`, U by `input` and the noise (co)variances with them (see
    /// [`super::Normalisation`]).
    pub(crate) fn scaled(&self, output: T, input: T) -> Self {
        let scale = |v: &[Complex<T>], c: T| v.iter().map(|x| x.scale(c)).collect();
        Self {
            omega: std::sync::Arc::clone(&self.omega),
            y: scale(&self.y, output),
            u: scale(&self.u, input),
            noise: self.noise.as_ref().map(|n| NoiseVariances {
                var_y: n.var_y.iter().map(|v| *v * output * output).collect(),
                var_u: n.var_u.iter().map(|v| *v * input * input).collect(),
                cov_yu: n
                    .cov_yu
                    .iter()
                    .map(|v| v.scale(output).scale(input))
                    .collect(),
            }),
            ts: self.ts,
            variance_dof: self.variance_dof,
            mixed_ts: self.mixed_ts,
        }
    }

    /// Assembles data from parts already known to be valid (used by merging and by the
    /// DFT of validated time records).
    pub(crate) fn from_parts_unchecked(
        omega: Vec<T>,
        y: Vec<Complex<T>>,
        u: Vec<Complex<T>>,
        noise: Option<NoiseVariances<T>>,
        ts: Option<T>,
    ) -> Self {
        Self {
            omega: omega.into(),
            y,
            u,
            noise,
            ts,
            variance_dof: None,
            mixed_ts: false,
        }
    }
}

/// The entries of `v` where `keep` is true.
fn pick<X: Copy>(v: &[X], keep: &[bool]) -> Vec<X> {
    v.iter()
        .zip(keep)
        .filter(|(_, k)| **k)
        .map(|(x, _)| *x)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_with_the_same_lines_share_their_frequencies() {
        let omega = vec![1.0, 2.0, 3.0];
        let y = vec![Complex::new(1.0, 0.5); 3];
        let data = FrequencyData::new(omega, y.clone(), y, Some(0.1)).unwrap();
        let same =
            |d: &FrequencyData<f64>| std::sync::Arc::ptr_eq(d.shared_omega(), data.shared_omega());
        assert!(same(&data.scaled(0.5, 2.0)));
        let other_ts = data.clone().with_ts(Some(0.2)).unwrap();
        assert!(same(&other_ts) && other_ts.ts() == Some(0.2));
        assert!(!same(&data.filter(&[true, false, true])));
    }
}
