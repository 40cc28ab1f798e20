//! Normalisation of the spectra by powers of two, so that fits see data of order one
//! whatever the units (a response of 10⁻¹⁷⁰ or 10¹⁷⁰ would otherwise underflow or overflow
//! in the squared residuals).

use super::FrequencyData;
use crate::scalar::Real;
use num_traits::Float;

/// The factors (c_y, c_u) of a normalisation Y′ = c_y·Y, U′ = c_u·U, variances scaled by
/// c_y², c_u² and c_y·c_u.
///
/// Each factor is the power of two that brings the largest |Y_k| (|U_k|) into \[0.5, 1)
/// (1 when the spectrum is zero), with the exponent capped at 0.9 of the type's largest so
/// that the factor is finite. Multiplying by a power of two is exact in binary floating
/// point (short of underflow), so a fit to the normalised data is the fit to the data:
/// only the parameters of the gain and of the output term change, by the
/// [`ModelStructure::normalisation_map`](crate::model::ModelStructure::normalisation_map).
///
/// ```
/// use fdid::data::{FrequencyData, Normalisation};
/// use fdid::Complex;
/// let data = FrequencyData::from_frf(
///     vec![1.0, 2.0],
///     vec![Complex::new(3e-170, 0.0), Complex::new(0.0, -1e-170)],
///     None,
/// )?;
/// let n = Normalisation::of(&data);
/// assert_eq!(n.input(), 0.5); // |U| = 1 becomes 0.5
/// let scaled = n.apply(&data);
/// assert!((0.5..1.0).contains(&scaled.y()[0].norm()));
/// # Ok::<(), fdid::FdidError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Normalisation<T: Real> {
    output: T,
    input: T,
}

impl<T: Real> Normalisation<T> {
    /// The factors for `data`.
    pub fn of(data: &FrequencyData<T>) -> Self {
        Self {
            output: power_of_two_factor(data.y().iter().map(|v| v.norm())),
            input: power_of_two_factor(data.u().iter().map(|v| v.norm())),
        }
    }

    /// The factors of [`Normalisation::of`] when the data lie far from order one (a largest
    /// |Y_k| or |U_k| beyond 2^±[`NEAR_ONE_EXPONENT`]), else the identity: data nearer
    /// one are fitted as they are (their squares and sums stay far inside the range of
    /// `f32` and `f64`; the solvers equilibrate their columns and stop on relative changes,
    /// so the scale leaves the fit but for rounding), which spares a copy of the data.
    ///
    /// ```
    /// use fdid::data::{FrequencyData, Normalisation};
    /// use fdid::Complex;
    /// let frf = |g: f64| FrequencyData::from_frf(vec![1.0], vec![Complex::new(g, 0.0)], None);
    /// assert!(Normalisation::of_far(&frf(3e4)?).is_identity());
    /// assert_eq!(Normalisation::of_far(&frf(3e-170)?), Normalisation::of(&frf(3e-170)?));
    /// # Ok::<(), fdid::FdidError>(())
    /// ```
    pub fn of_far(data: &FrequencyData<T>) -> Self {
        let n = Self::of(data);
        if n.exponent() <= NEAR_ONE_EXPONENT {
            Self {
                output: T::one(),
                input: T::one(),
            }
        } else {
            n
        }
    }

    /// The factors for a time record's output samples `y` and input samples `u` (the DFT is
    /// linear, so they normalise its spectra as well).
    pub fn of_samples(y: &[T], u: &[T]) -> Self {
        Self {
            output: power_of_two_factor(y.iter().copied()),
            input: power_of_two_factor(u.iter().copied()),
        }
    }

    /// The larger of the binary exponents of the two factors' magnitudes: how far from
    /// order one the data lie (0 for data already in \[0.5, 1)).
    pub fn exponent(&self) -> i32 {
        let e = |c: T| c.to_f64_lossless().log2().abs().round() as i32;
        e(self.output).max(e(self.input))
    }

    /// c_y, the factor of the output spectrum.
    pub fn output(&self) -> T {
        self.output
    }

    /// The factor that maps residuals of the normalised data back to the data's units:
    /// 1/c_y, or 1 when the noise is known (the residuals are then weighted by the noise
    /// level, which the normalisation scales alike).
    pub(crate) fn residual_scale(&self, noise_known: bool) -> T {
        if noise_known {
            T::one()
        } else {
            T::one() / self.output
        }
    }

    /// The factor of costs (squared residuals): [`Self::residual_scale`] squared.
    pub(crate) fn cost_scale(&self, noise_known: bool) -> T {
        let r = self.residual_scale(noise_known);
        r * r
    }

    /// c_u, the factor of the input spectrum.
    pub fn input(&self) -> T {
        self.input
    }

    /// True when both factors are 1 (the data are already of order one).
    pub fn is_identity(&self) -> bool {
        self.output == T::one() && self.input == T::one()
    }

    /// The data with Y and U scaled and their noise (co)variances with them.
    pub fn apply(&self, data: &FrequencyData<T>) -> FrequencyData<T> {
        data.scaled(self.output, self.input)
    }
}

/// Largest binary exponent of the data (|log₂| of a factor of [`Normalisation::of`]) that
/// [`Normalisation::of_far`] leaves as it is: 2^16 ≈ 6.6·10⁴, so that even fourth powers of
/// the data stay within 2^±64, far inside `f32`.
pub const NEAR_ONE_EXPONENT: i32 = 16;

/// 2^−e with e the binary exponent of the largest of the magnitudes `x` (so that it
/// becomes \[0.5, 1)), the exponent capped at ±0.9 of the type's largest; 1 when all are
/// zero or one is not finite.
pub(crate) fn power_of_two_factor<T: Real>(x: impl IntoIterator<Item = T>) -> T {
    let largest = x
        .into_iter()
        .map(Float::abs)
        .fold(T::zero(), |m, v| if v > m || v.is_nan() { v } else { m });
    if largest == T::zero() || !Float::is_finite(largest) {
        return T::one();
    }
    let cap = (<T as Float>::max_value().to_f64_lossless().log2() * 0.9).floor();
    let exponent = (largest.to_f64_lossless().log2().floor() + 1.0).clamp(-cap, cap);
    Float::powi(T::lit(2.0), -(exponent as i32))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn factors_are_powers_of_two_bringing_the_largest_to_one() {
        for (largest, exponent) in [(1.0, -1), (0.75, 0), (3e-170, 563), (5e-324, 1073)] {
            let c: f64 = power_of_two_factor([largest, 0.0]);
            let cap = (f64::MAX.log2() * 0.9).floor() as i32;
            assert_eq!(c, 2f64.powi(exponent.min(cap)), "largest {largest}");
            if exponent < cap {
                assert!((0.5..1.0).contains(&(largest * c)), "largest {largest}");
            }
        }
        assert_eq!(power_of_two_factor([0.0f64, -0.0]), 1.0);
        assert_eq!(power_of_two_factor([1.0, f64::NAN]), 1.0);
        let c: f32 = power_of_two_factor([-1e-30f32]);
        assert!((0.5..1.0).contains(&(1e-30 * c)));
    }
}
