//! Band-limited periodic multisines, evaluated exactly in continuous time with their
//! analytic derivatives.

use crate::error::{FdidError, Result, check_finite};
use crate::scalar::{Complex, Real};
use crate::simulate::Excitation;
use crate::simulate::rng::SplitMix64;
use std::f64::consts::TAU;

/// Which DFT lines inside the band a [`Multisine`] excites.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum LineSelection {
    /// Every line `k` with `f_k = k / T_period` in the band (a full multisine).
    All,
    /// Only odd `k` (an odd multisine: even lines stay free to detect even nonlinear
    /// distortion).
    Odd,
}

/// A periodic multisine
///
/// ```text
/// u(t) = Σ_i A_i cos(2π f_i t + φ_i),   f_i = k_i / T_period,
/// ```
///
/// on a set of lines `k_i` (strictly increasing; `k = 0` is a constant offset
/// `A cos φ`). The signal is defined in continuous time: [`Multisine::value`] and
/// [`Multisine::derivative`] evaluate it and
///
/// ```text
/// dⁿu/dtⁿ = Σ_i A_i ω_iⁿ cos(ω_i t + φ_i + n π/2),   ω_i = 2π f_i,
/// ```
///
/// exactly (to rounding) at any `t`, which is what an ODE with input derivatives needs
/// (Lataire & Pintelon's eq. 1 right-hand side). Sampled at `t = m T_s` with
/// `T_period = N T_s` and every `f_i < f_s/2`, its DFT (McKelvey eq. 1) is exactly
/// zero outside the excited lines: no leakage.
///
/// The parameters are stored in `T`; every evaluation computes in `f64` (the phase is
/// reduced to `2π frac(k t / T_period) + φ` before the trigonometry) and rounds the
/// result to `T`. Evaluation costs one complex multiplication per line: the rotations
/// `e^{jω_i t}` follow from one another (`e^{jω_{i+1} t} = e^{jω_i t} e^{j(k_{i+1}−k_i)ω₀ t}`),
/// with a direct `sin`/`cos` every 32 lines to keep rounding at the level of a few ulps.
///
/// ```
/// use fdid::simulate::{LineSelection, Multisine};
///
/// // 1 s period, lines 1 … 200 Hz, sampled at 2048 Hz, unit RMS
/// let u = Multisine::new(1.0, [1.0, 200.0], 2048.0, LineSelection::All, 7).unwrap();
/// assert_eq!(u.lines().len(), 200);
/// assert!((u.rms() - 1.0f64).abs() < 1e-12);
/// let x = u.sample(1.0 / 2048.0, 2048);
/// let ms = x.iter().map(|v| v * v).sum::<f64>() / 2048.0;
/// assert!((ms - 1.0).abs() < 1e-10); // sampled power = continuous power on a period
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Multisine<T: Real> {
    period: T,
    lines: Vec<usize>,
    amplitudes: Vec<T>,
    phases: Vec<T>,
    /// `A_i e^{jφ_i}` in `f64`, rebuilt whenever amplitudes or phases change
    phasors64: Vec<Complex<f64>>,
}

/// Lines between direct evaluations of `e^{jω_i t}` in [`Multisine`]'s recurrence.
const ANCHOR: usize = 32;

impl<T: Real> Multisine<T> {
    /// A random-phase multisine with flat amplitudes, normalised to unit RMS
    /// (`√(Σ A_i²/2) = 1`), on the lines `k` with `band_hz[0] ≤ k / period ≤ band_hz[1]`
    /// (odd `k` only for [`LineSelection::Odd`]). The phases `φ_i` are independent and
    /// uniform on `[0, 2π)`, drawn from `seed` (the DC line, if selected, gets `φ = 0`).
    ///
    /// # Errors
    /// - [`FdidError::InvalidArgument`] named `"period"` or `"fs"` when not positive and
    ///   finite; named `"band_hz"` when an edge is negative or not finite, when
    ///   `band_hz[0] > band_hz[1]`, or when the highest selected line is not below the
    ///   Nyquist frequency `fs / 2`;
    /// - [`FdidError::EmptyBand`] (edges in rad/s, `2π band_hz`) when no line is selected.
    pub fn new(
        period: T,
        band_hz: [T; 2],
        fs: T,
        selection: LineSelection,
        seed: u64,
    ) -> Result<Self> {
        let tp = check_positive("period", period)?;
        check_positive("fs", fs)?;
        let (lo, hi) = (band_hz[0].to_f64_lossless(), band_hz[1].to_f64_lossless());
        if !(lo.is_finite() && hi.is_finite() && lo >= 0.0 && lo <= hi) {
            return Err(FdidError::InvalidArgument {
                name: "band_hz",
                value: format!("[{lo}, {hi}]"),
                reason: "need finite edges with 0 ≤ fmin ≤ fmax".into(),
            });
        }
        // lines k with lo ≤ k / tp ≤ hi (a small tolerance keeps edges that sit exactly
        // on a line despite rounding in k / tp)
        let k_lo = (lo * tp * (1.0 - 1e-12)).ceil().max(0.0);
        let k_hi = (hi * tp * (1.0 + 1e-12)).floor();
        if k_hi > 1e9 {
            return Err(FdidError::InvalidArgument {
                name: "band_hz",
                value: format!("[{lo}, {hi}]"),
                reason: format!("selects about {k_hi:.3e} lines; at most 1e9 are allowed"),
            });
        }
        let lines: Vec<usize> = if k_hi < k_lo {
            Vec::new()
        } else {
            (k_lo as usize..=k_hi as usize)
                .filter(|k| selection == LineSelection::All || k % 2 == 1)
                .collect()
        };
        if lines.is_empty() {
            return Err(FdidError::EmptyBand {
                min: TAU * lo,
                max: TAU * hi,
            });
        }
        let mut rng = SplitMix64::new(seed);
        let phases: Vec<T> = lines
            .iter()
            .map(|&k| {
                let phi = TAU * rng.uniform();
                if k == 0 { T::zero() } else { T::lit(phi) }
            })
            .collect();
        let amplitudes = vec![T::one(); lines.len()];
        let ms = Self::from_lines(period, lines, amplitudes, phases)?.with_rms(T::one())?;
        ms.check_sampling(fs)?;
        Ok(ms)
    }

    /// A multisine with given lines `k_i` (strictly increasing), amplitudes `A_i` and
    /// phases `φ_i` (rad) on the period `T_period` (s).
    ///
    /// # Errors
    /// - [`FdidError::InvalidArgument`] named `"period"` when not positive and finite;
    /// - [`FdidError::TooShort`] when `lines` is empty;
    /// - [`FdidError::LengthMismatch`] when `amplitudes` or `phases` differ in length
    ///   from `lines`;
    /// - [`FdidError::Unsorted`] / [`FdidError::DuplicateFrequency`] (values in Hz) when
    ///   the lines are not strictly increasing;
    /// - [`FdidError::NonFinite`] naming `"amplitudes"` or `"phases"`.
    pub fn from_lines(
        period: T,
        lines: Vec<usize>,
        amplitudes: Vec<T>,
        phases: Vec<T>,
    ) -> Result<Self> {
        let tp = check_positive("period", period)?;
        if lines.is_empty() {
            return Err(FdidError::TooShort {
                what: "multisine lines",
                needed: 1,
                got: 0,
            });
        }
        for (what, v) in [("amplitudes", &amplitudes), ("phases", &phases)] {
            if v.len() != lines.len() {
                return Err(FdidError::LengthMismatch {
                    what,
                    expected: lines.len(),
                    got: v.len(),
                });
            }
        }
        for i in 1..lines.len() {
            let (value, previous) = (lines[i] as f64 / tp, lines[i - 1] as f64 / tp);
            if lines[i] == lines[i - 1] {
                return Err(FdidError::DuplicateFrequency { index: i, value });
            }
            if lines[i] < lines[i - 1] {
                return Err(FdidError::Unsorted {
                    index: i,
                    value,
                    previous,
                });
            }
        }
        check_finite("amplitudes", &amplitudes)?;
        check_finite("phases", &phases)?;
        let mut ms = Self {
            period,
            lines,
            amplitudes,
            phases,
            phasors64: Vec::new(),
        };
        ms.update_phasors();
        Ok(ms)
    }

    fn update_phasors(&mut self) {
        self.phasors64 = self
            .amplitudes
            .iter()
            .zip(&self.phases)
            .map(|(a, p)| Complex::from_polar(a.to_f64_lossless(), p.to_f64_lossless()))
            .collect();
    }

    /// The same multisine with its amplitudes scaled so that its RMS
    /// ([`Multisine::rms`]) equals `rms`.
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] named `"rms"` when `rms` is negative or not finite,
    /// or when the current RMS is zero (all amplitudes zero) and `rms > 0`.
    pub fn with_rms(mut self, rms: T) -> Result<Self> {
        let target = rms.to_f64_lossless();
        if !(target.is_finite() && target >= 0.0) {
            return Err(FdidError::InvalidArgument {
                name: "rms",
                value: format!("{target}"),
                reason: "must be finite and non-negative".into(),
            });
        }
        let now = self.rms_f64();
        if !(now > 0.0) && target > 0.0 {
            return Err(FdidError::InvalidArgument {
                name: "rms",
                value: format!("{target}"),
                reason: "the multisine is identically zero and cannot be scaled".into(),
            });
        }
        let scale = if target == 0.0 { 0.0 } else { target / now };
        for a in &mut self.amplitudes {
            *a = T::lit(a.to_f64_lossless() * scale);
        }
        self.update_phasors();
        Ok(self)
    }

    /// Checks that every line lies below the Nyquist frequency: `f_max < f_s / 2`.
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] named `"fs"` when `fs` is not positive and finite,
    /// named `"band_hz"` when the highest line `f_max ≥ fs / 2`.
    pub fn check_sampling(&self, fs: T) -> Result<()> {
        let fs = check_positive("fs", fs)?;
        let f_max = *self.lines.last().expect("validated non-empty") as f64 / self.period_f64();
        if !(f_max < 0.5 * fs) {
            return Err(FdidError::InvalidArgument {
                name: "band_hz",
                value: format!("{f_max} Hz"),
                reason: format!(
                    "the highest line must lie below the Nyquist frequency fs/2 = {} Hz",
                    0.5 * fs
                ),
            });
        }
        Ok(())
    }

    /// The period `T_period` (s); lines are at `k / T_period` Hz.
    pub fn period(&self) -> T {
        self.period
    }

    /// The excited line numbers `k_i`.
    pub fn lines(&self) -> &[usize] {
        &self.lines
    }

    /// The amplitudes `A_i`.
    pub fn amplitudes(&self) -> &[T] {
        &self.amplitudes
    }

    /// The phases `φ_i` (rad).
    pub fn phases(&self) -> &[T] {
        &self.phases
    }

    /// The excited frequencies `f_i = k_i / T_period` (Hz).
    pub fn frequencies_hz(&self) -> Vec<T> {
        let tp = self.period_f64();
        self.lines.iter().map(|&k| T::lit(k as f64 / tp)).collect()
    }

    /// The phasors `A_i e^{jφ_i}`, so that `u(t) = Σ_i Re(A_i e^{jφ_i} e^{jω_i t})`.
    pub fn phasors(&self) -> Vec<Complex<T>> {
        self.amplitudes
            .iter()
            .zip(&self.phases)
            .map(|(a, p)| Complex::from_polar(*a, *p))
            .collect()
    }

    /// The RMS over one period, `√(Σ_{k_i>0} A_i²/2 + (A_0 cos φ_0)²)` (the last term
    /// only when the DC line `k = 0` is excited).
    pub fn rms(&self) -> T {
        T::lit(self.rms_f64())
    }

    /// `u(t)`.
    pub fn value(&self, t: T) -> T {
        self.derivative(t, 0)
    }

    /// `dⁿu/dtⁿ (t) = Σ_i A_i ω_iⁿ cos(ω_i t + φ_i + n π/2)`.
    pub fn derivative(&self, t: T, order: usize) -> T {
        let mut out = vec![0.0; order + 1];
        self.derivatives_into(t.to_f64_lossless(), &mut out);
        T::lit(out[order])
    }

    /// The samples `u(m T_s)`, `m = 0, …, n − 1`.
    pub fn sample(&self, ts: T, n: usize) -> Vec<T> {
        let ts = ts.to_f64_lossless();
        let mut out = [0.0];
        (0..n)
            .map(|m| {
                self.derivatives_into(m as f64 * ts, &mut out);
                T::lit(out[0])
            })
            .collect()
    }

    fn period_f64(&self) -> f64 {
        self.period.to_f64_lossless()
    }

    fn rms_f64(&self) -> f64 {
        let ms: f64 = self
            .lines
            .iter()
            .zip(self.amplitudes.iter().zip(&self.phases))
            .map(|(&k, (a, p))| {
                let a = a.to_f64_lossless();
                if k == 0 {
                    let dc = a * p.to_f64_lossless().cos();
                    dc * dc
                } else {
                    0.5 * a * a
                }
            })
            .sum();
        ms.sqrt()
    }
}

impl<T: Real> Excitation for Multisine<T> {
    /// `out[n] = dⁿu/dtⁿ (t)` for `n = 0, …, out.len() − 1`: with `θ = ω t + φ`, the
    /// derivatives of each line cycle through `A ωⁿ (cos θ, −sin θ, −cos θ, sin θ)`.
    fn derivatives_into(&self, t: f64, out: &mut [f64]) {
        let tp = self.period_f64();
        let w0 = TAU / tp;
        let cycles = t / tp;
        // e^{j 2π frac(k t / T)}, phase reduced before the trigonometry
        let rotation = |k: usize| {
            let x = k as f64 * cycles;
            Complex::from_polar(1.0, TAU * (x - x.floor()))
        };
        // acc[n] = Σ_i ω_iⁿ A_i e^{jθ_i}; dⁿu/dtⁿ = Re(jⁿ acc[n])
        let mut small = [Complex::new(0.0, 0.0); 8];
        let mut big = Vec::new();
        let acc: &mut [Complex<f64>] = if out.len() <= small.len() {
            &mut small[..out.len()]
        } else {
            big.resize(out.len(), Complex::new(0.0, 0.0));
            &mut big
        };
        let mut z = Complex::new(1.0, 0.0);
        let (mut step_gap, mut step) = (0, Complex::new(1.0, 0.0));
        let mut prev = 0;
        for (lines, phasors) in self.lines.chunks(ANCHOR).zip(self.phasors64.chunks(ANCHOR)) {
            for (i, (&k, p)) in lines.iter().zip(phasors).enumerate() {
                if i == 0 {
                    z = rotation(k);
                } else {
                    let gap = k - prev;
                    if gap != step_gap {
                        step_gap = gap;
                        step = rotation(gap);
                    }
                    z *= step;
                }
                prev = k;
                let w = k as f64 * w0;
                let mut v = p * z;
                for a in acc.iter_mut() {
                    *a += v;
                    v *= w;
                }
            }
        }
        for (n, o) in out.iter_mut().enumerate() {
            let a = acc[n];
            *o = match n % 4 {
                0 => a.re,
                1 => -a.im,
                2 => -a.re,
                _ => a.im,
            };
        }
    }
}

/// Checks `x > 0` and finite, returning it as `f64`.
fn check_positive<T: Real>(name: &'static str, x: T) -> Result<f64> {
    let v = x.to_f64_lossless();
    if !(v.is_finite() && v > 0.0) {
        return Err(FdidError::InvalidArgument {
            name,
            value: format!("{v}"),
            reason: "must be positive and finite".into(),
        });
    }
    Ok(v)
}
