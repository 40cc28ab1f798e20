//! The floating-point type every estimator is generic over.

use nalgebra::RealField;
use num_traits::{Float, FromPrimitive};
use std::fmt::{Debug, Display};

/// A real scalar usable throughout the crate: `f32` or `f64`.
///
/// The bound gathers what the numerics need (nalgebra's `RealField`, `num_traits::Float`,
/// FFT support) so that user code only ever writes `T: Real`.
///
/// Both `RealField` and `Float` define `sqrt`, `abs`, … ; inside the crate math calls are
/// written `Float::sqrt(x)` to stay unambiguous.
pub trait Real:
    RealField + Float + FromPrimitive + Copy + Debug + Display + Default + rustfft::FftNum
{
    /// Converts an `f64` constant to `Self` (exact for `f64`, rounded for `f32`).
    fn lit(x: f64) -> Self;
    /// Converts to `f64` (exact).
    fn to_f64_lossless(self) -> f64;
    /// Converts a count to `Self`.
    fn from_usize_lossy(n: usize) -> Self {
        Self::lit(n as f64)
    }
}

impl Real for f32 {
    fn lit(x: f64) -> Self {
        x as f32
    }
    fn to_f64_lossless(self) -> f64 {
        self as f64
    }
}

impl Real for f64 {
    fn lit(x: f64) -> Self {
        x
    }
    fn to_f64_lossless(self) -> f64 {
        self
    }
}

/// Complex numbers over [`Real`].
pub type Complex<T> = num_complex::Complex<T>;

/// 1/z with one division (num-complex's `inv` makes two): the model evaluations divide
/// by a complex number at every line.
#[inline]
pub(crate) fn recip<T: Real>(z: Complex<T>) -> Complex<T> {
    let d = T::one() / z.norm_sqr();
    Complex::new(z.re * d, -z.im * d)
}

/// Σ (v − v) over the real and imaginary parts: zero when every value is finite, NaN
/// otherwise (a finiteness test that vectorises and cannot overflow).
#[inline]
pub(crate) fn all_finite_complex<T: Real>(v: &[Complex<T>]) -> bool {
    let s = v
        .iter()
        .fold(T::zero(), |s, z| s + ((z.re - z.re) + (z.im - z.im)));
    s == T::zero()
}
