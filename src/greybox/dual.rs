//! Forward-mode dual numbers carrying N directional derivatives, and the scalar trait a
//! grey-box response is written against.
//!
//! A dual number x = a + Σᵢ bᵢ εᵢ with εᵢεⱼ = 0 propagates the derivatives bᵢ = ∂x/∂θᵢ
//! through every operation by the chain rule: f(x) = f(a) + f′(a) Σᵢ bᵢ εᵢ. Seeding
//! θⱼ = θⱼ + εⱼ and evaluating G(θ, x) once in `Complex<Dual<T, N>>` gives G and all N
//! partial derivatives ∂G/∂θⱼ exactly (to rounding), with no step size to choose.

use crate::scalar::Real;
use num_traits::{Float, Num, NumCast, One, ToPrimitive, Zero};
use std::cmp::Ordering;
use std::fmt;
use std::num::FpCategory;
use std::ops::{
    Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Rem, RemAssign, Sub, SubAssign,
};

/// The scalar a grey-box response ([`super::GreyBox::response`]) is evaluated in: the real
/// type `T` itself (plain response) or a dual number [`Dual<T, N>`] (response and
/// Jacobian).
///
/// It is [`num_traits::Float`] with the compound assignments, so `Complex<S>` has the
/// arithmetic (+ − × ÷, `powi`, `inv`, `exp`, `sqrt`, `ln`, …) of `num_complex::Complex`.
/// Constants are written `S::lit(2.0)`. A product of a complex value and a real one is
/// written `z * r` or `z.scale(r)` (not `r * z`).
pub trait DualScalar:
    Float
    + AddAssign
    + SubAssign
    + MulAssign
    + DivAssign
    + RemAssign
    + fmt::Debug
    + fmt::Display
    + Send
    + Sync
    + 'static
{
    /// The constant `x` (exact for `f64`, rounded for `f32`; zero derivatives).
    fn lit(x: f64) -> Self;
}

impl<T: Real> DualScalar for T {
    fn lit(x: f64) -> Self {
        <T as Real>::lit(x)
    }
}

/// A dual number a + Σᵢ bᵢεᵢ (εᵢεⱼ = 0) with N derivative components stored inline:
/// `re` = a, `eps[i]` = bᵢ. Used through [`DualScalar`]; one evaluation in this type gives
/// a value and N partial derivatives.
///
/// Comparisons and classification (`<`, `==`, `is_finite`, …) look at `re` only.
///
/// ```
/// use fdid::greybox::{Dual, DualScalar};
/// use num_traits::Float;
/// // d/dx (x² e^x) at x = 1 is 3e
/// let x = Dual::<f64, 1>::variable(1.0, 0);
/// let y = x * x * x.exp();
/// assert!((y.eps[0] - 3.0 * 1f64.exp()).abs() < 1e-14);
/// ```
#[derive(Clone, Copy, PartialEq)]
pub struct Dual<T, const N: usize> {
    /// The value a.
    pub re: T,
    /// The derivative components bᵢ.
    pub eps: [T; N],
}

impl<T: Real, const N: usize> Dual<T, N> {
    /// The constant `re` (zero derivatives).
    #[inline]
    pub fn constant(re: T) -> Self {
        Self {
            re,
            eps: [T::zero(); N],
        }
    }

    /// The variable `re` + ε_i (derivative one along direction `i`; a constant when
    /// `i ≥ N`).
    #[inline]
    pub fn variable(re: T, i: usize) -> Self {
        let mut d = Self::constant(re);
        if i < N {
            d.eps[i] = T::one();
        }
        d
    }

    /// f(a) + f′(a) Σ bᵢεᵢ given `value` = f(a) and `slope` = f′(a).
    #[inline]
    fn chain(self, value: T, slope: T) -> Self {
        let mut eps = self.eps;
        for e in eps.iter_mut() {
            *e *= slope;
        }
        Self { re: value, eps }
    }

    /// Self·α + other·β in the derivative part, with value `re`.
    #[inline]
    fn combine(self, alpha: T, other: Self, beta: T, re: T) -> Self {
        let mut eps = self.eps;
        for (e, o) in eps.iter_mut().zip(other.eps.iter()) {
            *e = *e * alpha + *o * beta;
        }
        Self { re, eps }
    }
}

impl<T: Real, const N: usize> fmt::Debug for Dual<T, N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?} + {:?}ε", self.re, self.eps)
    }
}

impl<T: Real, const N: usize> fmt::Display for Dual<T, N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.re)?;
        for (i, e) in self.eps.iter().enumerate() {
            write!(f, " + {e}ε{i}")?;
        }
        Ok(())
    }
}

impl<T: Real, const N: usize> PartialOrd for Dual<T, N> {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        self.re.partial_cmp(&other.re)
    }
}

impl<T: Real, const N: usize> Add for Dual<T, N> {
    type Output = Self;
    #[inline]
    fn add(self, o: Self) -> Self {
        let mut eps = self.eps;
        for (e, b) in eps.iter_mut().zip(o.eps.iter()) {
            *e += *b;
        }
        Self {
            re: self.re + o.re,
            eps,
        }
    }
}

impl<T: Real, const N: usize> Sub for Dual<T, N> {
    type Output = Self;
    #[inline]
    fn sub(self, o: Self) -> Self {
        let mut eps = self.eps;
        for (e, b) in eps.iter_mut().zip(o.eps.iter()) {
            *e -= *b;
        }
        Self {
            re: self.re - o.re,
            eps,
        }
    }
}

impl<T: Real, const N: usize> Mul for Dual<T, N> {
    type Output = Self;
    /// (a + b·ε)(c + d·ε) = ac + (ad + bc)·ε.
    #[inline]
    fn mul(self, o: Self) -> Self {
        self.combine(o.re, o, self.re, self.re * o.re)
    }
}

impl<T: Real, const N: usize> Div for Dual<T, N> {
    type Output = Self;
    /// (a + b·ε)/(c + d·ε) = a/c + (b − (a/c) d)/c·ε.
    #[inline]
    fn div(self, o: Self) -> Self {
        let inv = T::one() / o.re;
        let q = self.re * inv;
        self.combine(inv, o, -q * inv, q)
    }
}

impl<T: Real, const N: usize> Rem for Dual<T, N> {
    type Output = Self;
    /// a mod c = a − trunc(a/c)·c (derivative b − trunc(a/c)·d).
    fn rem(self, o: Self) -> Self {
        let t = Float::trunc(self.re / o.re);
        self.combine(T::one(), o, -t, self.re % o.re)
    }
}

impl<T: Real, const N: usize> Neg for Dual<T, N> {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        self.chain(-self.re, -T::one())
    }
}

macro_rules! assign_ops {
    ($($tr:ident $m:ident $op:tt),*) => {$(
        impl<T: Real, const N: usize> $tr for Dual<T, N> {
            #[inline]
            fn $m(&mut self, o: Self) {
                *self = *self $op o;
            }
        }
    )*};
}
assign_ops!(AddAssign add_assign +, SubAssign sub_assign -, MulAssign mul_assign *,
            DivAssign div_assign /, RemAssign rem_assign %);

impl<T: Real, const N: usize> Zero for Dual<T, N> {
    fn zero() -> Self {
        Self::constant(T::zero())
    }
    fn is_zero(&self) -> bool {
        self.re == T::zero() && self.eps.iter().all(|e| *e == T::zero())
    }
}

impl<T: Real, const N: usize> One for Dual<T, N> {
    fn one() -> Self {
        Self::constant(T::one())
    }
}

impl<T: Real, const N: usize> Num for Dual<T, N> {
    type FromStrRadixErr = <T as Num>::FromStrRadixErr;
    fn from_str_radix(s: &str, radix: u32) -> Result<Self, Self::FromStrRadixErr> {
        <T as Num>::from_str_radix(s, radix).map(Self::constant)
    }
}

impl<T: Real, const N: usize> ToPrimitive for Dual<T, N> {
    fn to_i64(&self) -> Option<i64> {
        self.re.to_i64()
    }
    fn to_u64(&self) -> Option<u64> {
        self.re.to_u64()
    }
    fn to_f64(&self) -> Option<f64> {
        self.re.to_f64()
    }
}

impl<T: Real, const N: usize> NumCast for Dual<T, N> {
    fn from<P: ToPrimitive>(n: P) -> Option<Self> {
        <T as NumCast>::from(n).map(Self::constant)
    }
}

impl<T: Real, const N: usize> DualScalar for Dual<T, N> {
    fn lit(x: f64) -> Self {
        Self::constant(T::lit(x))
    }
}

/// Unary functions f with f′ given in terms of the argument `$a` and the value `$v`.
macro_rules! unary {
    ($($name:ident |$a:ident, $v:ident| $d:expr;)*) => {$(
        #[inline]
        fn $name(self) -> Self {
            let $a = self.re;
            let $v = Float::$name($a);
            self.chain($v, $d)
        }
    )*};
}

macro_rules! constants {
    ($($name:ident),*) => {$(
        fn $name() -> Self {
            Self::constant(<T as Float>::$name())
        }
    )*};
}

macro_rules! predicates {
    ($($name:ident),*) => {$(
        fn $name(self) -> bool {
            Float::$name(self.re)
        }
    )*};
}

impl<T: Real, const N: usize> Float for Dual<T, N> {
    constants!(
        nan,
        infinity,
        neg_infinity,
        neg_zero,
        min_value,
        min_positive_value,
        epsilon,
        max_value
    );
    predicates!(
        is_nan,
        is_infinite,
        is_finite,
        is_normal,
        is_sign_positive,
        is_sign_negative
    );

    fn classify(self) -> FpCategory {
        Float::classify(self.re)
    }

    unary! {
        floor |_a, _v| T::zero();
        ceil |_a, _v| T::zero();
        round |_a, _v| T::zero();
        trunc |_a, _v| T::zero();
        fract |_a, _v| T::one();
        abs |a, _v| if a < T::zero() { -T::one() } else { T::one() };
        signum |_a, _v| T::zero();
        recip |_a, v| -v * v;
        sqrt |_a, v| T::lit(0.5) / v;
        exp |_a, v| v;
        exp2 |_a, v| v * T::ln_2();
        ln |a, _v| T::one() / a;
        log2 |a, _v| T::one() / (a * T::ln_2());
        log10 |a, _v| T::one() / (a * T::ln_10());
        cbrt |_a, v| T::one() / (T::lit(3.0) * v * v);
        sin |a, _v| Float::cos(a);
        cos |a, _v| -Float::sin(a);
        tan |_a, v| T::one() + v * v;
        asin |a, _v| T::one() / Float::sqrt(T::one() - a * a);
        acos |a, _v| -T::one() / Float::sqrt(T::one() - a * a);
        atan |a, _v| T::one() / (T::one() + a * a);
        exp_m1 |a, _v| Float::exp(a);
        ln_1p |a, _v| T::one() / (T::one() + a);
        sinh |a, _v| Float::cosh(a);
        cosh |a, _v| Float::sinh(a);
        tanh |_a, v| T::one() - v * v;
        asinh |a, _v| T::one() / Float::sqrt(a * a + T::one());
        acosh |a, _v| T::one() / Float::sqrt(a * a - T::one());
        atanh |a, _v| T::one() / (T::one() - a * a);
    }

    fn mul_add(self, a: Self, b: Self) -> Self {
        self * a + b
    }

    /// x^n, derivative n x^{n−1} (zero for n = 0).
    fn powi(self, n: i32) -> Self {
        let v = Float::powi(self.re, n);
        let d = if n == 0 {
            T::zero()
        } else {
            <T as Real>::lit(<f64 as From<i32>>::from(n)) * Float::powi(self.re, n - 1)
        };
        self.chain(v, d)
    }

    /// x^y: derivative y x^{y−1} dx + x^y ln(x) dy (the second term left out when y is a
    /// constant, so that 0^y stays differentiable in x).
    fn powf(self, y: Self) -> Self {
        let v = Float::powf(self.re, y.re);
        let dx = y.re * Float::powf(self.re, y.re - T::one());
        if y.eps.iter().all(|e| *e == T::zero()) {
            self.chain(v, dx)
        } else {
            self.combine(dx, y, v * Float::ln(self.re), v)
        }
    }

    fn log(self, base: Self) -> Self {
        Float::ln(self) / Float::ln(base)
    }

    fn max(self, other: Self) -> Self {
        if other.re > self.re || self.re.is_nan() {
            other
        } else {
            self
        }
    }

    fn min(self, other: Self) -> Self {
        if other.re < self.re || self.re.is_nan() {
            other
        } else {
            self
        }
    }

    fn abs_sub(self, other: Self) -> Self {
        if self.re > other.re {
            self - other
        } else {
            Self::zero()
        }
    }

    /// √(x² + y²), derivative (x dx + y dy)/h.
    fn hypot(self, other: Self) -> Self {
        let h = Float::hypot(self.re, other.re);
        if h == T::zero() {
            return Self::constant(h);
        }
        self.combine(self.re / h, other, other.re / h, h)
    }

    /// atan2(y = self, x = other), derivative (x dy − y dx)/(x² + y²).
    fn atan2(self, other: Self) -> Self {
        let r2 = self.re * self.re + other.re * other.re;
        let v = Float::atan2(self.re, other.re);
        if r2 == T::zero() {
            return Self::constant(v);
        }
        self.combine(other.re / r2, other, -self.re / r2, v)
    }

    fn sin_cos(self) -> (Self, Self) {
        let (s, c) = Float::sin_cos(self.re);
        (self.chain(s, c), self.chain(c, -s))
    }

    fn to_degrees(self) -> Self {
        let f = T::lit(180.0) / T::pi();
        self.chain(self.re * f, f)
    }

    fn to_radians(self) -> Self {
        let f = T::pi() / T::lit(180.0);
        self.chain(self.re * f, f)
    }

    fn integer_decode(self) -> (u64, i16, i8) {
        Float::integer_decode(self.re)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    type D = Dual<f64, 2>;
    type Case = (&'static str, fn(D) -> D, fn(f64) -> f64);

    fn fd(f: impl Fn(f64) -> f64, x: f64) -> f64 {
        let h = 1e-6 * x.abs().max(1.0);
        (f(x + h) - f(x - h)) / (2.0 * h)
    }

    #[test]
    fn unary_derivatives_match_differences() {
        let x = 0.37;
        let d = D::variable(x, 0);
        let cases: Vec<Case> = vec![
            ("sqrt", |v| v.sqrt(), |v| v.sqrt()),
            ("exp", |v| v.exp(), |v| v.exp()),
            ("ln", |v| v.ln(), |v| v.ln()),
            ("sin", |v| v.sin(), |v| v.sin()),
            ("cos", |v| v.cos(), |v| v.cos()),
            ("tan", |v| v.tan(), |v| v.tan()),
            ("asin", |v| v.asin(), |v| v.asin()),
            ("acos", |v| v.acos(), |v| v.acos()),
            ("atan", |v| v.atan(), |v| v.atan()),
            ("sinh", |v| v.sinh(), |v| v.sinh()),
            ("cosh", |v| v.cosh(), |v| v.cosh()),
            ("tanh", |v| v.tanh(), |v| v.tanh()),
            ("asinh", |v| v.asinh(), |v| v.asinh()),
            ("atanh", |v| v.atanh(), |v| v.atanh()),
            ("cbrt", |v| v.cbrt(), |v| v.cbrt()),
            ("exp2", |v| v.exp2(), |v| v.exp2()),
            ("log2", |v| v.log2(), |v| v.log2()),
            ("log10", |v| v.log10(), |v| v.log10()),
            ("exp_m1", |v| v.exp_m1(), |v| v.exp_m1()),
            ("ln_1p", |v| v.ln_1p(), |v| v.ln_1p()),
            ("recip", |v| v.recip(), |v| v.recip()),
            ("powi", |v| v.powi(3), |v| v.powi(3)),
            ("powf", |v| v.powf(D::constant(2.5)), |v| v.powf(2.5)),
            ("abs", |v| (-v).abs(), |v| (-v).abs()),
            ("neg", |v| -v, |v| -v),
        ];
        for (name, f, g) in cases {
            let y = f(d);
            assert!((y.re - g(x)).abs() < 1e-15, "{name} value");
            let want = fd(g, x);
            assert!(
                (y.eps[0] - want).abs() < 1e-8 * want.abs().max(1.0),
                "{name}: {} vs {want}",
                y.eps[0]
            );
            assert_eq!(y.eps[1], 0.0, "{name}");
        }
        let acosh = D::variable(1.7, 0).acosh();
        assert!((acosh.eps[0] - fd(f64::acosh, 1.7)).abs() < 1e-8);
    }

    #[test]
    fn binary_derivatives() {
        let (a, b) = (0.8, -1.3);
        let x = D::variable(a, 0);
        let y = D::variable(b, 1);
        let check = |v: D, f: fn(f64, f64) -> f64| {
            let (da, db) = (fd(|t| f(t, b), a), fd(|t| f(a, t), b));
            assert!((v.re - f(a, b)).abs() < 1e-15);
            assert!(
                (v.eps[0] - da).abs() < 1e-8 && (v.eps[1] - db).abs() < 1e-8,
                "{v:?} vs {da} {db}"
            );
        };
        check(x + y, |p, q| p + q);
        check(x - y, |p, q| p - q);
        check(x * y, |p, q| p * q);
        check(x / y, |p, q| p / q);
        check(x.atan2(y), f64::atan2);
        check(x.hypot(y), f64::hypot);
        check(x.powf(y), f64::powf);
        check(x.mul_add(y, x), |p, q| p * q + p);
    }
}
