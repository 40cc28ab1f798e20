//! Seeded coloured Gaussian noise and its scaling to a signal-to-noise ratio.

use crate::error::{FdidError, Result, check_finite};
use crate::scalar::Real;
use crate::simulate::rng::SplitMix64;
use nalgebra::DMatrix;

/// A discrete-time filter
///
/// ```text
/// H(z) = (b₀ + b₁ z⁻¹ + … + b_m z⁻ᵐ) / (a₀ + a₁ z⁻¹ + … + a_n z⁻ⁿ),
/// ```
///
/// applied as the difference equation `Σ aᵢ v(t−i) = Σ bᵢ e(t−i)` from rest.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct DtFilter {
    b: Vec<f64>,
    a: Vec<f64>,
}

impl DtFilter {
    /// The filter `b(z⁻¹) / a(z⁻¹)`.
    ///
    /// # Errors
    /// - [`FdidError::TooShort`] when `b` or `a` is empty;
    /// - [`FdidError::NonFinite`] naming `"b"` or `"a"`;
    /// - [`FdidError::InvalidArgument`] named `"a"` when `a₀ = 0`, or when a pole
    ///   (root of `zⁿ a(z⁻¹)`) lies on or outside the unit circle — the noise would not
    ///   be stationary.
    pub fn new(b: Vec<f64>, a: Vec<f64>) -> Result<Self> {
        for (what, c) in [("b", &b), ("a", &a)] {
            if c.is_empty() {
                return Err(FdidError::TooShort {
                    what,
                    needed: 1,
                    got: 0,
                });
            }
            check_finite(what, c)?;
        }
        if a[0] == 0.0 {
            return Err(FdidError::InvalidArgument {
                name: "a",
                value: format!("{a:?}"),
                reason: "a₀ must be non-zero".into(),
            });
        }
        let n = a.len() - 1;
        if n > 0 {
            // companion matrix of z^n + (a₁/a₀) z^{n−1} + … + a_n/a₀
            let mut c = DMatrix::<f64>::zeros(n, n);
            for j in 0..n {
                c[(0, j)] = -a[j + 1] / a[0];
            }
            for i in 1..n {
                c[(i, i - 1)] = 1.0;
            }
            let radius = c
                .complex_eigenvalues()
                .iter()
                .map(|p| p.norm())
                .fold(0.0, f64::max);
            if !(radius < 1.0) {
                return Err(FdidError::InvalidArgument {
                    name: "a",
                    value: format!("{a:?}"),
                    reason: format!("a pole has modulus {radius} ≥ 1: the filter is unstable"),
                });
            }
        }
        Ok(Self { b, a })
    }

    /// `H(z) = 1` (white noise).
    pub fn identity() -> Self {
        Self {
            b: vec![1.0],
            a: vec![1.0],
        }
    }

    /// Numerator coefficients `bᵢ` (of `z⁻ⁱ`).
    pub fn b(&self) -> &[f64] {
        &self.b
    }

    /// Denominator coefficients `aᵢ` (of `z⁻ⁱ`).
    pub fn a(&self) -> &[f64] {
        &self.a
    }

    /// `H(e^{jθ})` at the normalised angular frequency `θ = ω T_s` (rad/sample).
    pub fn response(&self, theta: f64) -> crate::scalar::Complex<f64> {
        let ev = |c: &[f64]| {
            c.iter()
                .enumerate()
                .map(|(i, ci)| crate::scalar::Complex::from_polar(*ci, -(i as f64) * theta))
                .sum::<crate::scalar::Complex<f64>>()
        };
        ev(&self.b) / ev(&self.a)
    }

    /// The filtered sequence `v = H(q) e` from zero initial conditions (transposed
    /// direct form II).
    pub fn filter(&self, e: &[f64]) -> Vec<f64> {
        let order = self.a.len().max(self.b.len());
        let a0 = self.a[0];
        let coef = |c: &[f64], i: usize| c.get(i).copied().unwrap_or(0.0) / a0;
        let mut state = vec![0.0; order];
        e.iter()
            .map(|&x| {
                let v = coef(&self.b, 0) * x + state[0];
                for i in 1..order {
                    let next = if i + 1 < order { state[i] } else { 0.0 };
                    state[i - 1] = next + coef(&self.b, i) * x - coef(&self.a, i) * v;
                }
                v
            })
            .collect()
    }
}

/// Seeded Gaussian noise coloured by a [`DtFilter`]: `v = H(q) e`, `e` white N(0, 1)
/// from a SplitMix64 stream, after `warmup` discarded samples so that the filter's
/// start-up transient is gone and `v` is (close to) stationary.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct ColouredNoise {
    filter: DtFilter,
    seed: u64,
    warmup: usize,
}

impl ColouredNoise {
    /// Noise `H(q) e` from `seed`, with 4096 warm-up samples.
    pub fn new(filter: DtFilter, seed: u64) -> Self {
        Self {
            filter,
            seed,
            warmup: 4096,
        }
    }

    /// White N(0, 1) noise from `seed`.
    pub fn white(seed: u64) -> Self {
        Self::new(DtFilter::identity(), seed)
    }

    /// The number of discarded start-up samples.
    #[must_use]
    pub fn with_warmup(mut self, warmup: usize) -> Self {
        self.warmup = warmup;
        self
    }

    /// `n` noise samples (unscaled: `e` has unit variance).
    pub fn generate(&self, n: usize) -> Vec<f64> {
        let mut rng = SplitMix64::new(self.seed);
        let e: Vec<f64> = (0..n + self.warmup).map(|_| rng.gaussian()).collect();
        let mut v = self.filter.filter(&e);
        v.drain(..self.warmup);
        v
    }

    /// Noise of the length of `signal`, scaled so that the signal-to-noise ratio
    ///
    /// ```text
    /// SNR = 10 log₁₀( Σ s(t)² / Σ v(t)² )  dB
    /// ```
    ///
    /// (mean-square powers, see [`snr_db`]) equals `snr_db`.
    ///
    /// # Errors
    /// - [`FdidError::InvalidArgument`] named `"snr_db"` when not finite, named
    ///   `"signal"` when its power is zero;
    /// - [`FdidError::TooShort`] when `signal` is empty;
    /// - [`FdidError::NonFinite`] naming `"signal"`.
    pub fn at_snr<T: Real>(&self, signal: &[T], snr_db: f64) -> Result<Vec<T>> {
        if !snr_db.is_finite() {
            return Err(FdidError::InvalidArgument {
                name: "snr_db",
                value: format!("{snr_db}"),
                reason: "must be finite".into(),
            });
        }
        let ps = power("signal", signal)?;
        let v = self.generate(signal.len());
        let pv = v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64;
        if !(pv > 0.0 && pv.is_finite()) {
            return Err(FdidError::Numerical {
                what: format!("coloured noise power {pv}"),
            });
        }
        let scale = (ps / pv / 10f64.powf(snr_db / 10.0)).sqrt();
        Ok(v.into_iter().map(|x| T::lit(scale * x)).collect())
    }

    /// `signal + v` with `v` from [`ColouredNoise::at_snr`]; returns `(noisy, v)`.
    ///
    /// # Errors
    /// As [`ColouredNoise::at_snr`].
    pub fn add_at_snr<T: Real>(&self, signal: &[T], snr_db: f64) -> Result<(Vec<T>, Vec<T>)> {
        let v = self.at_snr(signal, snr_db)?;
        let noisy = signal.iter().zip(&v).map(|(s, n)| *s + *n).collect();
        Ok((noisy, v))
    }
}

/// The signal-to-noise ratio `10 log₁₀(Σ s² / Σ v²)` in dB.
///
/// # Errors
/// - [`FdidError::LengthMismatch`] when the lengths differ;
/// - [`FdidError::TooShort`] when empty;
/// - [`FdidError::NonFinite`] naming `"signal"` or `"noise"`;
/// - [`FdidError::InvalidArgument`] named `"signal"` or `"noise"` when its power is zero.
pub fn snr_db<T: Real>(signal: &[T], noise: &[T]) -> Result<f64> {
    if noise.len() != signal.len() {
        return Err(FdidError::LengthMismatch {
            what: "noise",
            expected: signal.len(),
            got: noise.len(),
        });
    }
    let ps = power("signal", signal)?;
    let pv = power("noise", noise)?;
    Ok(10.0 * (ps / pv).log10())
}

/// Mean square of `x`, checked non-empty, finite and positive.
fn power<T: Real>(what: &'static str, x: &[T]) -> Result<f64> {
    if x.is_empty() {
        return Err(FdidError::TooShort {
            what,
            needed: 1,
            got: 0,
        });
    }
    check_finite(what, x)?;
    let p = x
        .iter()
        .map(|v| {
            let v = v.to_f64_lossless();
            v * v
        })
        .sum::<f64>()
        / x.len() as f64;
    if !(p > 0.0 && p.is_finite()) {
        return Err(FdidError::InvalidArgument {
            name: what,
            value: format!("power {p}"),
            reason: "the mean-square power must be positive and finite".into(),
        });
    }
    Ok(p)
}
