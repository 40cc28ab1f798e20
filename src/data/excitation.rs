//! Which lines of a measured spectrum the input excites, and whether a record repeats
//! period after period.

use crate::data::{FrequencyData, TimeData};
use crate::error::{FdidError, Result};
use crate::scalar::{Complex, Real};

/// Default fraction of [`FrequencyData::excited_lines`]: a line is excited when
/// `|U_k| > 10⁻⁶ max_{j: ω_j > 0} |U_j|` (−120 dB). Lines left out of a multisine keep
/// `|U_k|` at the rounding level (about `10⁻¹⁶` of the largest line in `f64`, never exactly
/// zero) and fall far below; the lines of a noise input almost never do (for a
/// Rayleigh-distributed `|U_k|` the chance is about `10⁻¹¹` per line).
pub const EXCITATION_FRACTION: f64 = 1e-6;

/// A line above DC is excited only when `|U_k| > 10⁻¹⁰ |U_DC|` (and above the floor of
/// [`EXCITATION_FRACTION`]): the DFT of a constant input holds about `10⁻¹⁶ |U_DC|` of
/// rounding on the other lines and excites none, while any input that varies by more than
/// `10⁻¹⁰` of its mean (times √N) is not affected.
pub const DC_ROUNDING: f64 = 1e-10;

/// Default tolerance of [`TimeData::period_mismatch`]: the part of the input that differs
/// between periods may carry at most `0.1` (−10 dB) of the power of the part that repeats.
pub const PERIODICITY_TOLERANCE: f64 = 0.1;

impl<T: Real> FrequencyData<T> {
    /// The excitation floor `max(fraction · max_{k: ω_k > 0} |U_k|,` [`DC_ROUNDING`]` · |U_DC|)`
    /// (`U_DC` the line at ω = 0, if any): a constant input, whose DFT holds only rounding
    /// (about 10⁻¹⁶ |U_DC|) above DC, excites no line.
    pub fn excitation_floor(&self, fraction: f64) -> f64 {
        let level = |(_, u): (&T, &Complex<T>)| u.norm().to_f64_lossless();
        let lines = || self.omega().iter().zip(self.u());
        let max = lines()
            .filter(|(w, _)| **w > T::zero())
            .map(level)
            .fold(0.0, f64::max);
        let dc = lines()
            .filter(|(w, _)| **w == T::zero())
            .map(level)
            .fold(0.0, f64::max);
        (fraction * max).max(DC_ROUNDING * dc)
    }

    /// True when the input has a DC line and no line above it reaches [`DC_ROUNDING`] of
    /// it: the input is constant to rounding.
    pub fn input_is_constant(&self) -> bool {
        let mut dc = 0.0;
        let mut max = 0.0;
        for (w, u) in self.omega().iter().zip(self.u()) {
            let l = u.norm().to_f64_lossless();
            if *w == T::zero() {
                dc = l;
            } else {
                max = f64::max(max, l);
            }
        }
        dc > 0.0 && max <= DC_ROUNDING * dc
    }

    /// Per line, whether the input excites it: `ω_k > 0` and
    /// `|U_k| > fraction · max_{j: ω_j > 0} |U_j|` ([`EXCITATION_FRACTION`] is the default
    /// fraction). The DC line is never excited (it carries offsets, not dynamics).
    pub fn excited_lines(&self, fraction: f64) -> Vec<bool> {
        let floor = self.excitation_floor(fraction);
        self.omega()
            .iter()
            .zip(self.u())
            .map(|(w, u)| *w > T::zero() && u.norm().to_f64_lossless() > floor)
            .collect()
    }
}

impl<T: Real> TimeData<T> {
    /// How far the input is from repeating over `periods` periods of `M = N/P` samples:
    /// with `u_p(t)` period `p` of the input after removing its mean over the record,
    /// `ū(t) = (1/P) Σ_p u_p(t)` the mean period and
    ///
    /// `σ̂² = (1/((P − 1) M)) Σ_p Σ_t (u_p(t) − ū(t))²` the power of the part that differs
    /// between periods, `S = (1/M) Σ_t ū(t)² − σ̂²/P` the power of the part that repeats
    /// (the mean period's power less the non-repeating power left in it),
    ///
    /// the ratio `σ̂² / S` (`+∞` when `S ≤ 0`). A periodic input measured with noise gives
    /// the noise-to-signal power ratio; blocks that are different realisations of a random
    /// signal give `S ≈ 0` and so a huge ratio. Compare with [`PERIODICITY_TOLERANCE`].
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] named `"periods"` when `periods < 2` or does not
    /// divide the record length.
    pub fn period_mismatch(&self, periods: usize) -> Result<f64> {
        let n = self.len();
        if periods < 2 || !n.is_multiple_of(periods) {
            return Err(FdidError::InvalidArgument {
                name: "periods",
                value: periods.to_string(),
                reason: format!(
                    "need at least 2 periods dividing the record length N = {n} to check \
                     that the input repeats"
                ),
            });
        }
        let m = n / periods;
        let u: Vec<f64> = self.u().iter().map(|v| v.to_f64_lossless()).collect();
        let mean = u.iter().sum::<f64>() / n as f64;
        let p = periods as f64;
        let mut spread = 0.0;
        let mut power = 0.0;
        for t in 0..m {
            let avg = (0..periods).map(|q| u[q * m + t] - mean).sum::<f64>() / p;
            power += avg * avg;
            spread += (0..periods)
                .map(|q| (u[q * m + t] - mean - avg).powi(2))
                .sum::<f64>();
        }
        let sigma2 = spread / ((p - 1.0) * m as f64);
        let s = power / m as f64 - sigma2 / p;
        Ok(if s > 0.0 { sigma2 / s } else { f64::INFINITY })
    }

    /// The record without its first `samples` samples (e.g. the transient periods).
    ///
    /// # Errors
    /// [`FdidError::TooShort`] when fewer than 2 samples would remain.
    pub fn skip_samples(&self, samples: usize) -> Result<Self> {
        let n = self.len();
        if samples + 2 > n {
            return Err(FdidError::TooShort {
                what: "samples after the skipped ones",
                needed: 2,
                got: n.saturating_sub(samples),
            });
        }
        Self::new(
            self.u()[samples..].to_vec(),
            self.y()[samples..].to_vec(),
            self.ts(),
        )
    }

    /// The record cut into `blocks` consecutive records of `N/blocks` samples each (e.g.
    /// the realisations of a multisine measured one after the other).
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] named `"blocks"` when `blocks = 0` or does not divide
    /// `N`; [`FdidError::TooShort`] when a block would have fewer than 2 samples.
    pub fn split_blocks(&self, blocks: usize) -> Result<Vec<Self>> {
        let n = self.len();
        if blocks == 0 || !n.is_multiple_of(blocks) {
            return Err(FdidError::InvalidArgument {
                name: "blocks",
                value: blocks.to_string(),
                reason: format!("must divide the record length N = {n}"),
            });
        }
        let m = n / blocks;
        if m < 2 {
            return Err(FdidError::TooShort {
                what: "samples per block",
                needed: 2,
                got: m,
            });
        }
        (0..blocks)
            .map(|b| {
                Self::new(
                    self.u()[b * m..(b + 1) * m].to_vec(),
                    self.y()[b * m..(b + 1) * m].to_vec(),
                    self.ts(),
                )
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mismatch_of_periodic_and_random_blocks() {
        let m = 64;
        let per: Vec<f64> = (0..m).map(|t| (0.3 * t as f64).sin() + 2.0).collect();
        let u: Vec<f64> = (0..4 * m).map(|i| per[i % m]).collect();
        let rec = TimeData::new(u.clone(), u, 1.0).unwrap();
        assert!(rec.period_mismatch(4).unwrap() < 1e-20);
        let mut state = 5u64;
        let u: Vec<f64> = (0..4 * m)
            .map(|_| crate::test_rng::lcg(&mut state))
            .collect();
        let rec = TimeData::new(u.clone(), u, 1.0).unwrap();
        assert!(rec.period_mismatch(4).unwrap() > 1.0);
        assert!(rec.period_mismatch(3).is_err());
        assert_eq!(rec.split_blocks(4).unwrap()[1].u()[0], rec.u()[m]);
        assert_eq!(rec.skip_samples(m).unwrap().len(), 3 * m);
    }
}
