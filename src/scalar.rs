//! The floating-point type every estimator is generic over.

use nalgebra::RealField;
use num_traits::{Float, FromPrimitive};
use std::borrow::Cow;
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
    /// The complex values as `f64`: borrowed when `Self` is `f64`, else converted (exactly).
    fn complex_as_f64(v: &[Complex<Self>]) -> Cow<'_, [Complex<f64>]> {
        Cow::Owned(
            v.iter()
                .map(|z| Complex::new(z.re.to_f64_lossless(), z.im.to_f64_lossless()))
                .collect(),
        )
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
    fn complex_as_f64(v: &[Complex<Self>]) -> Cow<'_, [Complex<f64>]> {
        Cow::Borrowed(v)
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

/// The real and imaginary parts of `v` as one real slice, interleaved (Re v₀, Im v₀, Re v₁,
/// …): the real-stacked layout of the crate's residual vectors, written in place.
#[inline]
pub(crate) fn interleaved_mut<T: Real>(v: &mut [Complex<T>]) -> &mut [T] {
    // SAFETY: `num_complex::Complex<T>` is `#[repr(C)]` with the two fields `re`, `im` of
    // type T, so n complex values are 2n values of T in that order, with T's alignment;
    // the returned slice borrows `v` mutably for its lifetime
    unsafe { std::slice::from_raw_parts_mut(v.as_mut_ptr().cast::<T>(), 2 * v.len()) }
}

/// True when every value is finite: Σ 0·v is zero then and NaN otherwise (0·∞ and 0·NaN
/// are NaN) — a test without branches that cannot overflow, summed in eight independent
/// lanes so that it vectorises (a single running sum is a chain of dependent additions).
#[inline]
pub(crate) fn all_finite<T: Real>(v: &[T]) -> bool {
    const LANES: usize = 8;
    let zero = T::zero();
    let chunks = v.chunks_exact(LANES);
    let rest = chunks.remainder().iter().fold(zero, |s, x| s + *x * zero);
    let mut acc = [zero; LANES];
    for c in chunks {
        for (a, x) in acc.iter_mut().zip(c) {
            *a += *x * zero;
        }
    }
    acc.iter().fold(rest, |s, a| s + *a) == zero
}

/// [`all_finite`] over the real and imaginary parts.
#[inline]
pub(crate) fn all_finite_complex<T: Real>(v: &[Complex<T>]) -> bool {
    const LANES: usize = 4;
    let zero = T::zero();
    let chunks = v.chunks_exact(LANES);
    let rest = chunks
        .remainder()
        .iter()
        .fold(zero, |s, z| s + z.re * zero + z.im * zero);
    let mut acc = [zero; 2 * LANES];
    for c in chunks {
        for (a, z) in acc.chunks_exact_mut(2).zip(c) {
            a[0] += z.re * zero;
            a[1] += z.im * zero;
        }
    }
    acc.iter().fold(rest, |s, a| s + *a) == zero
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finiteness_and_reciprocal() {
        let big = f64::MAX;
        assert!(all_finite(&[1.0, -big, big, 0.0]));
        assert!(all_finite::<f64>(&[]));
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            assert!(!all_finite(&[1.0, bad, 2.0]));
            assert!(!all_finite_complex(&[Complex::new(0.0, bad)]));
            assert!(!all_finite_complex(&[Complex::new(bad, 1.0)]));
        }
        assert!(all_finite_complex(&[
            Complex::new(big, big),
            Complex::new(-big, big)
        ]));
        // every position: the vector lanes and the remainder
        for n in 1..40 {
            for k in 0..n {
                for bad in [f64::NAN, f64::INFINITY] {
                    let mut v = vec![f64::MAX; n];
                    v[k] = bad;
                    assert!(!all_finite(&v), "n {n} at {k}");
                    let mut z = vec![Complex::new(-big, big); n];
                    z[k].im = bad;
                    assert!(!all_finite_complex(&z), "n {n} at {k}");
                    z[k] = Complex::new(bad, 0.0);
                    assert!(!all_finite_complex(&z), "n {n} at {k}");
                }
            }
            assert!(
                all_finite(&vec![-big; n]) && all_finite_complex(&vec![Complex::new(big, big); n])
            );
        }
        let z = Complex::new(3.0f64, -4.0);
        assert!((recip(z) - Complex::new(1.0, 0.0) / z).norm() <= 1e-16);
        let z = Complex::new(0.5f32, 2.0);
        assert!((recip(z) * z - Complex::new(1.0, 0.0)).norm() <= 1e-6);
    }

    #[test]
    fn interleaved_view_and_f64_view() {
        let mut v = vec![Complex::new(1.0f32, 2.0), Complex::new(3.0, 4.0)];
        let r = interleaved_mut(&mut v);
        assert_eq!(r, &[1.0, 2.0, 3.0, 4.0]);
        r[3] = -4.0;
        assert_eq!(v[1], Complex::new(3.0, -4.0));
        assert!(interleaved_mut::<f64>(&mut []).is_empty());
        // f64 borrows, f32 converts exactly
        let z = [Complex::new(0.1f64, -0.2)];
        assert!(matches!(f64::complex_as_f64(&z), Cow::Borrowed(b) if b == z));
        let w = f32::complex_as_f64(&v);
        assert!(matches!(w, Cow::Owned(_)));
        assert_eq!(&*w, &[Complex::new(1.0, 2.0), Complex::new(3.0, -4.0)]);
    }
}
