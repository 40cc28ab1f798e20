//! Sampled time records and their discrete Fourier transform (McKelvey eq. 1).

use crate::data::FrequencyData;
use crate::error::{FdidError, Result, check_finite};
use crate::scalar::{Complex, Real};
use num_traits::Float;
use rustfft::{Fft, FftPlanner};

/// A sampled single-input single-output record: input `u(t Ts)` and output `y(t Ts)`,
/// `t = 0, …, N−1`, at sample time `Ts`.
///
/// Invariants, checked by [`TimeData::new`]: `u` and `y` have the same length `N ≥ 2`,
/// all samples are finite, `Ts > 0` is finite, and the record is small enough for its DFT
/// to stay finite in `T`.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct TimeData<T: Real> {
    u: Vec<T>,
    y: Vec<T>,
    ts: T,
}

impl<T: Real> TimeData<T> {
    /// Builds a validated time record from input samples `u`, output samples `y` and the
    /// sample time `ts` (s).
    ///
    /// # Errors
    /// - [`FdidError::LengthMismatch`] when `y.len() != u.len()`;
    /// - [`FdidError::TooShort`] when `N < 2`;
    /// - [`FdidError::NonFinite`] naming `"u"` or `"y"` and the first bad sample;
    /// - [`FdidError::InvalidArgument`] named `"ts"` when `ts` is not positive and finite
    ///   (or so small that `π / Ts` overflows), or named `"u"`/`"y"` when `Σ|x(t)|`
    ///   overflows `T` (the DFT could not be represented).
    pub fn new(u: Vec<T>, y: Vec<T>, ts: T) -> Result<Self> {
        if y.len() != u.len() {
            return Err(FdidError::LengthMismatch {
                what: "y",
                expected: u.len(),
                got: y.len(),
            });
        }
        if u.len() < 2 {
            return Err(FdidError::TooShort {
                what: "time samples",
                needed: 2,
                got: u.len(),
            });
        }
        check_finite("u", &u)?;
        check_finite("y", &y)?;
        check_ts(ts)?;
        for (name, x) in [("u", &u), ("y", &y)] {
            check_dft_range(name, x)?;
        }
        Ok(Self { u, y, ts })
    }

    /// Input samples `u(t Ts)`.
    pub fn u(&self) -> &[T] {
        &self.u
    }

    /// Output samples `y(t Ts)`.
    pub fn y(&self) -> &[T] {
        &self.y
    }

    /// Sample time `Ts` (s).
    pub fn ts(&self) -> T {
        self.ts
    }

    /// Number of samples `N`.
    pub fn len(&self) -> usize {
        self.u.len()
    }

    /// Always false for validated data (kept for API symmetry with `len`).
    pub fn is_empty(&self) -> bool {
        self.u.is_empty()
    }

    /// The DFT of the record, McKelvey eq. (1):
    ///
    /// `X(ω_k) = (1/√N) Σ_{t=0}^{N−1} x(t Ts) e^{−i 2π k t / N}`, for `x = u, y`,
    ///
    /// on the lines `k = 0, …, ⌊N/2⌋` at `ω_k = 2πk / (N Ts)` rad/s, with
    /// `ts = Some(Ts)` and no noise (co)variances. Both signals go through one complex FFT
    /// of z = u/s_u + i·y/s_y (s the RMS values, so that neither signal's rounding swamps
    /// the other's), split by symmetry: U_k = s_u(Z_k + conj Z_{N−k})/2,
    /// Y_k = s_y(Z_k − conj Z_{N−k})/(2i).
    pub fn dft(&self) -> FrequencyData<T> {
        let n = self.len();
        let plan = FftPlanner::<T>::new().plan_fft_forward(n);
        let (u, y) = dft_pair_with(plan.as_ref(), &self.u, &self.y);
        let omega = line_frequencies(n, self.ts);
        FrequencyData::from_parts_unchecked(omega, y, u, None, Some(self.ts))
    }
}

/// Checks `Ts > 0`, finite, and `π / Ts` finite (so every DFT line frequency is finite).
pub(crate) fn check_ts<T: Real>(ts: T) -> Result<()> {
    let ok = num_traits::Float::is_finite(ts)
        && ts > T::zero()
        && num_traits::Float::is_finite(T::pi() / ts);
    if ok {
        Ok(())
    } else {
        Err(FdidError::InvalidArgument {
            name: "ts",
            value: format!("{ts}"),
            reason: "the sample time must be positive and finite (and π/Ts finite)".into(),
        })
    }
}

/// Checks that `4 Σ|x(t)|` is finite, which bounds every intermediate value of the
/// scaled FFT and so keeps the DFT finite.
fn check_dft_range<T: Real>(name: &'static str, x: &[T]) -> Result<()> {
    let sum = x
        .iter()
        .fold(T::zero(), |acc, v| acc + num_traits::Float::abs(*v));
    if num_traits::Float::is_finite(sum * T::lit(4.0)) {
        Ok(())
    } else {
        Err(FdidError::InvalidArgument {
            name,
            value: format!("sum of |{name}| = {sum}"),
            reason: "samples too large: the DFT would overflow".into(),
        })
    }
}

/// Line frequencies `ω_k = 2πk / (N Ts)`, `k = 0, …, ⌊N/2⌋`, computed in `f64` and then
/// rounded to `T`.
pub(crate) fn line_frequencies<T: Real>(n: usize, ts: T) -> Vec<T> {
    let ts = ts.to_f64_lossless();
    (0..=n / 2)
        .map(|k| T::lit(std::f64::consts::TAU * (k as f64 / n as f64) / ts))
        .collect()
}

/// The DFT lines `k = 0, …, ⌊N/2⌋` of a real sequence `x` of length `N`, with McKelvey's
/// scaling:
///
/// `X_k = (1/√N) Σ_{t=0}^{N−1} x_t e^{−i 2π k t / N}`.
///
/// Returns an empty vector for empty input. The samples are scaled by `1/√N` before the
/// FFT, so the result is finite whenever `Σ|x_t|` is comfortably below `T::MAX`.
pub fn dft_lines<T: Real>(x: &[T]) -> Vec<Complex<T>> {
    if x.is_empty() {
        return Vec::new();
    }
    let plan = FftPlanner::<T>::new().plan_fft_forward(x.len());
    dft_lines_with(plan.as_ref(), x)
}

/// The DFT lines of two real sequences of the same length through one complex FFT (see
/// [`TimeData::dft`]); falls back to two transforms when a signal is zero or not finite.
pub(crate) fn dft_pair_with<T: Real>(
    plan: &dyn Fft<T>,
    u: &[T],
    y: &[T],
) -> (Vec<Complex<T>>, Vec<Complex<T>>) {
    let n = u.len();
    let rms = |x: &[T]| {
        let m = x
            .iter()
            .fold(T::zero(), |a, v| Float::max(a, Float::abs(*v)));
        if !(m > T::zero() && Float::is_finite(m)) {
            return None;
        }
        let s = x.iter().fold(T::zero(), |a, v| a + (*v / m) * (*v / m));
        Some(m * Float::sqrt(s / T::from_usize_lossy(n)))
    };
    let (Some(su), Some(sy)) = (rms(u), rms(y)) else {
        return (dft_lines_with(plan, u), dft_lines_with(plan, y));
    };
    if plan.len() != n || y.len() != n {
        return (dft_lines_with(plan, u), dft_lines_with(plan, y));
    }
    let scale = T::one() / Float::sqrt(T::from_usize_lossy(n));
    let (cu, cy) = (scale / su, scale / sy);
    let mut z: Vec<Complex<T>> = u
        .iter()
        .zip(y)
        .map(|(a, b)| Complex::new(*a * cu, *b * cy))
        .collect();
    plan.process(&mut z);
    let half = T::lit(0.5);
    let m = n / 2 + 1;
    let (mut uo, mut yo) = (Vec::with_capacity(m), Vec::with_capacity(m));
    for k in 0..m {
        let a = z[k];
        let b = z[(n - k) % n].conj();
        // U = (a + b)/2, Y = (a − b)/(2i) = −i(a − b)/2
        let s = (a + b) * half;
        let d = (a - b) * half;
        uo.push(s * su);
        yo.push(Complex::new(d.im, -d.re) * sy);
    }
    (uo, yo)
}

/// [`dft_lines`] with a given forward plan (re-planned if its length is not `x.len()`).
pub(crate) fn dft_lines_with<T: Real>(plan: &dyn Fft<T>, x: &[T]) -> Vec<Complex<T>> {
    let n = x.len();
    if n == 0 {
        return Vec::new();
    }
    if plan.len() != n {
        return dft_lines(x);
    }
    let scale = T::one() / num_traits::Float::sqrt(T::from_usize_lossy(n));
    let mut buf: Vec<Complex<T>> = x
        .iter()
        .map(|v| Complex::new(*v * scale, T::zero()))
        .collect();
    plan.process(&mut buf);
    buf.truncate(n / 2 + 1);
    buf
}

#[cfg(test)]
mod pair_tests {
    use super::*;

    /// One packed FFT of two signals equals two separate transforms, also when their scales
    /// differ by 10⁶, for even and odd lengths, in f64 and f32.
    #[test]
    fn packed_pair_equals_two_transforms() {
        fn check<T: Real>(n: usize, tol: f64) {
            let u: Vec<T> = (0..n)
                .map(|t| T::lit((0.37 * t as f64).sin() + 0.1 * (t % 7) as f64))
                .collect();
            let y: Vec<T> = (0..n)
                .map(|t| T::lit(1e-6 * ((1.3 * t as f64).cos() - 0.2)))
                .collect();
            let plan = FftPlanner::<T>::new().plan_fft_forward(n);
            let (pu, py) = dft_pair_with(plan.as_ref(), &u, &y);
            for (packed, x) in [(pu, &u), (py, &y)] {
                let direct = dft_lines(x);
                assert_eq!(packed.len(), direct.len());
                let norm = direct
                    .iter()
                    .map(|v| v.norm_sqr())
                    .fold(T::zero(), |a, b| a + b);
                let err = packed
                    .iter()
                    .zip(&direct)
                    .map(|(a, b)| (*a - *b).norm_sqr())
                    .fold(T::zero(), |a, b| a + b);
                let rel = Float::sqrt(err / norm).to_f64_lossless();
                assert!(rel < tol, "n = {n}: relative error {rel:e}");
            }
        }
        for n in [2usize, 3, 7, 64, 1000, 1023] {
            check::<f64>(n, 1e-13);
            check::<f32>(n, 1e-5);
        }
        // a zero signal falls back to separate transforms
        let plan = FftPlanner::<f64>::new().plan_fft_forward(4);
        let (u, y) = dft_pair_with(plan.as_ref(), &[1.0, 2.0, 3.0, 4.0], &[0.0; 4]);
        assert!(y.iter().all(|v| v.norm() == 0.0));
        assert!((u[0].re - 5.0).abs() < 1e-14);
    }
}
