//! Grey-box (physical) model structures: write only the frequency response, get the exact
//! Jacobian by forward-mode dual numbers.
//!
//! # Implementing a model structure
//!
//! Every criterion of the crate needs a [`ModelStructure`]: the response G(θ, ω) and its
//! Jacobian ∂G/∂θ. For a physical model the response is a short formula in the physical
//! parameters, while the Jacobian by hand is long and error prone. This module asks for the
//! formula only:
//!
//! 1. **Write the equation.** A first-order lag with gain K, time constant τ_c and dead
//!    time τ_d: G(s) = K e^{−sτ_d}/(τ_c s + 1), s = iω.
//! 2. **Choose θ.** Positive physical parameters are estimated through their logarithms,
//!    θ = [ln K, ln τ_c, ln τ_d]: every θ ∈ ℝᵖ is a valid model, the search never leaves
//!    the physical region, and the relative uncertainty std(K)/K = std(ln K) is what
//!    McKelvey's asymptotic covariance (eqs. 32–34) predicts best for scale parameters.
//! 3. **Implement [`GreyBox`]**: `n_params`, the response generic over the scalar
//!    `S: DualScalar` (so it runs in `f64`, `f32` and in [`Dual`] numbers), and optionally
//!    names and units ([`Parameter`]).
//! 4. **Wrap it in [`AutoDiff`]**, which implements [`ModelStructure`] for `f32` and
//!    `f64`: `response_into` evaluates the formula in `T`, `jacobian_into` evaluates it
//!    once per line in `Complex<Dual<T, N>>`, each dual carrying all p derivatives (up to
//!    32 per pass; more parameters take several passes). The result works with every
//!    output-error criterion — [`crate::MaximumLikelihood`] (eq. 23),
//!    [`crate::criterion::NoiseModelMl`] (eqs. 23–26), [`crate::ErrorsInVariables`]
//!    (eq. 42) — and composes with [`crate::Delayed`] (a delay factor) and [`Fixed`]
//!    (parameters held at known values). The linear criteria (Levy, SK, TLS) need
//!    [`crate::EquationError`], which a general formula does not have.
//! 5. **Start from a physical guess** θ₀ (or from the poles of a rational fit, see
//!    [`physical`]), fit with [`crate::estimate::greybox::fit_ml`] (or [`crate::estimate::greybox::fit_eiv`]).
//! 6. **Read the result in physical units** with [`crate::estimate::greybox::physical_values`]: value exp(θ̂ᵢ) and,
//!    by the delta method, std = value·std(θ̂ᵢ), with confidence intervals exp(θ̂ᵢ ± zσᵢ).
//!
//! ```
//! use fdid::prelude::*;
//! use fdid::greybox::{AutoDiff, DualScalar, GreyBox, Parameter, fit_ml, physical_values};
//!
//! /// G(s) = K e^{−sτ_d} / (τ_c s + 1), θ = [ln K, ln τ_c, ln τ_d].
//! #[derive(Clone)]
//! struct LagDelay;
//!
//! impl GreyBox for LagDelay {
//!     fn n_params(&self) -> usize {
//!         3
//!     }
//!     fn response<S: DualScalar>(&self, theta: &[S], s: Complex<S>) -> Complex<S> {
//!         let (k, tc, td) = (theta[0].exp(), theta[1].exp(), theta[2].exp());
//!         let one = Complex::new(S::one(), S::zero());
//!         (-s * td).exp() * k / (s * tc + one)
//!     }
//!     fn parameters(&self) -> Vec<Parameter> {
//!         vec![Parameter::log("K", "1"), Parameter::log("tau_c", "s"), Parameter::log("tau_d", "s")]
//!     }
//! }
//!
//! // noise-free data from K = 2, τ_c = 0.5 s, τ_d = 0.1 s
//! let omega: Vec<f64> = (1..=100).map(|k| 0.1 * k as f64).collect();
//! let truth = [2f64.ln(), 0.5f64.ln(), 0.1f64.ln()];
//! let model = AutoDiff::new(LagDelay);
//! let frf = model.response(&truth, &omega);
//! let data = FrequencyData::from_frf(omega, frf, None).unwrap();
//! // a physical guess, 30–50 % off
//! let start = model.theta_from_physical(&[3.0, 0.3, 0.15]).unwrap();
//! let fit = fit_ml(&model, &data, &start).unwrap();
//! let values = physical_values(&fit);
//! assert_eq!(values[1].name, "tau_c");
//! assert!((values[0].value - 2.0).abs() < 1e-9);
//! assert!((values[1].value - 0.5).abs() < 1e-9);
//! assert!((values[2].value - 0.1).abs() < 1e-9);
//! ```
//!
//! **Discrete time.** A model whose [`GreyBox::sample_time`] is `Some(Ts)` receives
//! x = z⁻¹ = e^{−iωTs} instead of s = iω (the digital-filter convention of
//! [`crate::Rational::discrete`] and McKelvey eq. 3).
//!
//! **Transient.** The DFT of one non-periodic record (not a whole number of periods in
//! steady state) carries the leakage of the initial and final states, an input-independent
//! term Ŷ = G U + T. A model that exposes its denominator ([`GreyBox::denominator`]:
//! coefficients in x, implemented by every model of [`physical`] and by [`FlexibleModes`])
//! gets it with θ extended by n real coefficients tⱼ (n the degree of the denominator),
//! z_k = e^{iω_kTs}:
//!
//! ```text
//! discrete time, AutoDiff::with_transient (McKelvey eqs. 4–5):
//!     T_k = Σ_{j=1}^{n} tⱼ z_k^{−(j−1)} / A(θ, z_k⁻¹)
//! continuous time sampled at Ts, AutoDiff::with_sampled_transient(Ts) (eqs. 9–10):
//!     T_k = Σ_{j=1}^{n} tⱼ z_k^{−(j−1)} / Πᵢ (1 − e^{pᵢ(θ)Ts} z_k⁻¹),  D(θ, pᵢ) = 0
//! ```
//!
//! With the DFT of [`crate::TimeData::dft`] both are exact: noise-free data from any
//! initial state give θ to rounding. The Jacobian is exact too: ∂T/∂tⱼ is the basis,
//! ∂T/∂θ comes by dual numbers through A, and in continuous time through the poles,
//! ∂pᵢ/∂θ = −(∂D/∂θ)/(∂D/∂s) at s = pᵢ (the poles are the companion-matrix eigenvalues of
//! D in f64). [`Fixed`] and [`crate::Delayed`] keep working (the delay does not act on T);
//! [`crate::estimate::greybox::physical_values`] lists the tⱼ as `transient1` … (linear, no unit). Start the tⱼ at
//! zero: T is linear in them, so the first Levenberg–Marquardt steps fit them at the start
//! θ. **Not supported:**
//! repeated poles in continuous time (∂D/∂s = 0 there: the Jacobian is not finite), models
//! without [`GreyBox::denominator`], the transient of a [`Product`] beyond its first
//! factor's, and data merged from records with different sample times. Periodic data (or
//! a record with a negligible transient) need no transient term.
//!
//! **Cost.** Vector-mode duals make the Jacobian cost about that of one response evaluated
//! with p-fold wider arithmetic; `benches/greybox.rs` compares it with the hand-written
//! Jacobian of [`crate::Rational`]. Write an analytic [`ModelStructure`] where that cost
//! matters.
//!
//! **Why an in-crate dual type.** The derivative part is a fixed-size array on the stack
//! (no allocation per operation), generic over the crate's [`Real`] so `f32` and `f64` both
//! work, and the crate gains no dependency; only the arithmetic `Complex<Dual>` needs is
//! implemented (all of [`num_traits::Float`]).

mod dual;
mod mode;
pub mod physical;
mod transient;

pub use dual::{Dual, DualScalar};
pub use mode::{FlexibleModes, Product};
pub use transient::Transient;

use crate::data::FrequencyData;
use crate::error::{FdidError, Result};
use crate::model::{Delayed, ModelStructure};
use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;
use num_traits::Float;

/// A model given by its frequency response, written once for every scalar type.
///
/// ```text
/// G(θ, ω) = response(θ, x),   x = s = iω (continuous time) or x = z⁻¹ = e^{−iωTs}
/// (discrete time, McKelvey eq. 3)
/// ```
///
/// [`AutoDiff`] turns it into a [`ModelStructure`] with the exact Jacobian. The response
/// must be a smooth function of θ built from the operations of [`DualScalar`] (branches on
/// values are allowed but make the Jacobian one-sided at the switch). See the
/// [module docs](self) for a walk-through.
pub trait GreyBox {
    /// Number of parameters p.
    fn n_params(&self) -> usize;

    /// G(θ, x) for `theta` of length p, with x = iω or e^{−iωTs}.
    fn response<S: DualScalar>(&self, theta: &[S], x: Complex<S>) -> Complex<S>;

    /// `None` (the default) for a continuous-time model (x = iω); `Some(Ts)` for a
    /// discrete-time one (x = e^{−iωTs}).
    fn sample_time(&self) -> Option<f64> {
        None
    }

    /// Names, units and scales of the parameters (default: `theta0`, `theta1`, … on a
    /// linear scale without unit).
    fn parameters(&self) -> Vec<Parameter> {
        (0..self.n_params())
            .map(|j| Parameter::linear(&format!("theta{j}"), ""))
            .collect()
    }

    /// Model-specific checks of a θ of the right length with finite entries (default: none).
    ///
    /// # Errors
    /// Model-specific, e.g. [`FdidError::InvalidArgument`] naming the parameter.
    fn check_params(&self, theta: &[f64]) -> Result<()> {
        let _ = theta;
        Ok(())
    }

    /// The coefficients of the denominator of G in ascending powers of x, `None` (the
    /// default) when the model does not expose it:
    ///
    /// ```text
    /// D(θ, x) = d₀(θ) + d₁(θ) x + … + d_n(θ) xⁿ,   x = s (continuous time) or z⁻¹
    /// (discrete time),
    /// ```
    ///
    /// such that G·D is a polynomial in x (D holds every pole of G, with d_n ≠ 0 in
    /// continuous time). Its length n + 1 must not depend on θ. The transient term of a
    /// non-periodic record ([`AutoDiff::with_transient`], McKelvey eqs. 4–5;
    /// [`AutoDiff::with_sampled_transient`], eqs. 9–10) is built from it. A discrete-time
    /// model whose numerator has a higher degree than its denominator pads D with zero
    /// coefficients up to the state dimension max(na, nb).
    fn denominator<S: DualScalar>(&self, theta: &[S]) -> Option<Vec<S>> {
        let _ = theta;
        None
    }
}

/// How a parameter θᵢ maps to its physical value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Scale {
    /// value = θ.
    Linear,
    /// value = e^θ (a positive quantity); std(value) = value·std(θ) (delta method).
    Log,
}

/// Name, unit and scale of a parameter.
#[derive(Debug, Clone, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Parameter {
    /// Name (e.g. `"m"`).
    pub name: String,
    /// Unit of the physical value (e.g. `"kg"`).
    pub unit: String,
    /// How θ maps to the value.
    pub scale: Scale,
}

impl Parameter {
    /// A positive quantity estimated as θ = ln(value).
    pub fn log(name: &str, unit: &str) -> Self {
        Self {
            name: name.into(),
            unit: unit.into(),
            scale: Scale::Log,
        }
    }

    /// A quantity estimated as θ = value.
    pub fn linear(name: &str, unit: &str) -> Self {
        Self {
            name: name.into(),
            unit: unit.into(),
            scale: Scale::Linear,
        }
    }

    /// The physical value of θᵢ: e^θ or θ.
    pub fn value<T: Real>(&self, theta: T) -> T {
        match self.scale {
            Scale::Linear => theta,
            Scale::Log => Float::exp(theta),
        }
    }

    /// θᵢ of a physical value: ln(value) or value.
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] naming the parameter when the value is not finite,
    /// or not positive on the log scale.
    pub fn theta<T: Real>(&self, value: f64) -> Result<T> {
        let bad = |reason: &str| FdidError::InvalidArgument {
            name: "physical value",
            value: format!("{} = {value} {}", self.name, self.unit),
            reason: reason.into(),
        };
        if !value.is_finite() {
            return Err(bad("not finite"));
        }
        match self.scale {
            Scale::Linear => Ok(T::lit(value)),
            Scale::Log if value > 0.0 => Ok(T::lit(value.ln())),
            Scale::Log => Err(bad("a physical quantity on the log scale must be positive")),
        }
    }
}

/// Where the value of one parameter of a model comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Slot {
    /// The estimated θ entry with this index.
    Free(usize),
    /// Held at this θ value (see [`Fixed`]).
    Fixed(f64),
}

/// Models that describe their parameters physically: every parameter of the underlying
/// physical model, in order, with where its value comes from. Implemented by [`AutoDiff`],
/// and by [`crate::Delayed`] (the delay τ, in s, on a linear scale) and [`Fixed`] over such
/// models.
pub trait PhysicalParameters {
    /// One entry per physical parameter (free or fixed).
    fn physical_parameters(&self) -> Vec<(Parameter, Slot)>;

    /// Model-specific checks of a full-length, finite θ (default: none).
    ///
    /// # Errors
    /// As [`GreyBox::check_params`].
    fn check_theta(&self, theta: &[f64]) -> Result<()> {
        let _ = theta;
        Ok(())
    }

    /// θ from the physical values of the free parameters, in the order of θ (e.g.
    /// `[m, c, k]` in kg, N·s/m, N/m): θᵢ = ln(value) on the log scale.
    ///
    /// # Errors
    /// [`FdidError::LengthMismatch`] (what `"physical values"`) when the count differs from
    /// the number of free parameters; [`FdidError::InvalidArgument`] naming the parameter
    /// for a non-finite value or a non-positive one on the log scale.
    fn theta_from_physical<T: Real>(&self, values: &[f64]) -> Result<Vec<T>>
    where
        Self: Sized,
    {
        let mut free: Vec<(usize, Parameter)> = self
            .physical_parameters()
            .into_iter()
            .filter_map(|(p, s)| match s {
                Slot::Free(i) => Some((i, p)),
                Slot::Fixed(_) => None,
            })
            .collect();
        free.sort_by_key(|(i, _)| *i);
        if values.len() != free.len() {
            return Err(FdidError::LengthMismatch {
                what: "physical values",
                expected: free.len(),
                got: values.len(),
            });
        }
        free.iter()
            .zip(values)
            .map(|((_, p), v)| p.theta(*v))
            .collect()
    }
}

/// A [`GreyBox`] model as a [`ModelStructure`] with the Jacobian by forward-mode dual
/// numbers:
///
/// ```text
/// G_k = response(θ, x_k),   ∂G_k/∂θⱼ = ε-part j of response(θ + Σⱼ εⱼ eⱼ, x_k)
/// ```
///
/// with x_k = iω_k, or e^{−iω_kTs} for a discrete-time model. The Jacobian is exact to
/// rounding (no step size). Up to 32 parameters take one pass per line with a dual of
/// exactly as many (or a few more) components; more take ⌈p/32⌉ passes.
///
/// With a transient term ([`AutoDiff::with_transient`], McKelvey eqs. 4–5;
/// [`AutoDiff::with_sampled_transient`], eqs. 9–10) θ = [θ_model, t₁ … t_n] and
/// `transient_into` gives T and ∂T/∂θ (G does not depend on the tⱼ).
///
/// A θ of the wrong length makes `response_into`/`jacobian_into` write NaN (which every
/// criterion reports as a numerical failure) instead of panicking; [`AutoDiff::evaluate`]
/// and [`crate::estimate::greybox::fit_ml`] return typed errors.
///
/// ```
/// use fdid::prelude::*;
/// use fdid::greybox::{AutoDiff, physical::MassSpringDamper};
/// let model = AutoDiff::new(MassSpringDamper::new());
/// let theta: Vec<f64> = model.theta_from_physical(&[1.0, 0.4, 4.0]).unwrap();
/// let g = model.evaluate(&theta, &[2.0]).unwrap();
/// // 1/(m s² + c s + k) at s = 2i: 1/(−4 + 0.8i + 4)
/// assert!((g[0] - Complex::new(0.0, -1.25)).norm() < 1e-12);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct AutoDiff<G> {
    model: G,
    /// The transient term of a non-periodic record, when enabled.
    #[cfg_attr(feature = "serde", serde(default))]
    transient: Option<Transient>,
}

impl<G: GreyBox> AutoDiff<G> {
    /// Wraps `model` (without a transient term).
    pub fn new(model: G) -> Self {
        Self {
            model,
            transient: None,
        }
    }

    /// p = the model's parameters plus the transient coefficients.
    fn total_params(&self) -> usize {
        self.model.n_params() + self.n_transient()
    }

    /// The wrapped model.
    pub fn model(&self) -> &G {
        &self.model
    }

    /// The wrapped model, by value.
    pub fn into_inner(self) -> G {
        self.model
    }

    /// Checks θ: its length, finite entries, then [`GreyBox::check_params`].
    ///
    /// # Errors
    /// [`FdidError::LengthMismatch`] (what `"theta"`), [`FdidError::NonFinite`] (what
    /// `"theta"`), or the model's own error.
    pub fn check_theta<T: Real>(&self, theta: &[T]) -> Result<()> {
        check_theta_common(self.total_params(), theta)?;
        let t: Vec<f64> = theta.iter().map(|v| v.to_f64_lossless()).collect();
        self.model.check_params(&t[..self.model.n_params()])
    }

    /// G(θ, ω_k), checking θ first.
    ///
    /// # Errors
    /// As [`AutoDiff::check_theta`]; [`FdidError::NonFinite`] (what `"omega"`).
    pub fn evaluate<T: Real>(&self, theta: &[T], omega: &[T]) -> Result<Vec<Complex<T>>> {
        self.check_theta(theta)?;
        crate::error::check_finite("omega", omega)?;
        Ok(ModelStructure::response(self, theta, omega))
    }

    /// The frequency variable at ω: iω, or e^{−iωTs}.
    fn variable<T: Real>(&self, omega: T) -> Complex<T> {
        match self.model.sample_time() {
            None => Complex::new(T::zero(), omega),
            Some(ts) => {
                let (s, c) = Float::sin_cos(omega * T::lit(ts));
                Complex::new(c, -s)
            }
        }
    }

    /// G and the Jacobian columns `first .. first + min(N, p − first)` with N-component
    /// duals. Kept out of line: each instance gets its own inlining budget, so the
    /// response and the dual arithmetic inline into the loop over the lines.
    #[inline(never)]
    fn jacobian_pass<T: Real, const N: usize>(
        &self,
        first: usize,
        theta: &[T],
        omega: &[T],
        g: &mut [Complex<T>],
        jac: &mut DMatrix<Complex<T>>,
    ) {
        let p = theta.len();
        let seeded: Vec<Dual<T, N>> = theta
            .iter()
            .enumerate()
            .map(|(j, t)| match j.checked_sub(first) {
                Some(i) => Dual::variable(*t, i),
                None => Dual::constant(*t),
            })
            .collect();
        let cols = N.min(p - first);
        for (k, w) in omega.iter().enumerate() {
            let x = self.variable(*w);
            let x = Complex::new(Dual::constant(x.re), Dual::constant(x.im));
            let r = self.model.response(&seeded, x);
            g[k] = Complex::new(r.re.re, r.im.re);
            for i in 0..cols {
                jac[(k, first + i)] = Complex::new(r.re.eps[i], r.im.eps[i]);
            }
        }
    }
}

/// Length and finiteness of θ.
pub(crate) fn check_theta_common<T: Real>(p: usize, theta: &[T]) -> Result<()> {
    if theta.len() != p {
        return Err(FdidError::LengthMismatch {
            what: "theta",
            expected: p,
            got: theta.len(),
        });
    }
    crate::error::check_finite("theta", theta)
}

/// Fills a response (and Jacobian) with NaN: the answer to a θ of the wrong length.
fn fill_nan<T: Real>(g: &mut [Complex<T>], jac: Option<&mut DMatrix<Complex<T>>>) {
    let nan = Complex::new(T::nan(), T::nan());
    g.fill(nan);
    if let Some(j) = jac {
        j.fill(nan);
    }
}

/// Dispatches a Jacobian evaluation (`jacobian_pass` or `transient_pass`) to a dual of (at
/// least) p components.
macro_rules! dispatch {
    ($self:ident . $pass:ident ($theta:expr, $omega:ident, $g:ident, $jac:ident)) => {
        match $theta.len() {
            1 => $self.$pass::<T, 1>(0, $theta, $omega, $g, $jac),
            2 => $self.$pass::<T, 2>(0, $theta, $omega, $g, $jac),
            3 => $self.$pass::<T, 3>(0, $theta, $omega, $g, $jac),
            4 => $self.$pass::<T, 4>(0, $theta, $omega, $g, $jac),
            5 => $self.$pass::<T, 5>(0, $theta, $omega, $g, $jac),
            6 => $self.$pass::<T, 6>(0, $theta, $omega, $g, $jac),
            7 => $self.$pass::<T, 7>(0, $theta, $omega, $g, $jac),
            8 => $self.$pass::<T, 8>(0, $theta, $omega, $g, $jac),
            9..=10 => $self.$pass::<T, 10>(0, $theta, $omega, $g, $jac),
            11..=12 => $self.$pass::<T, 12>(0, $theta, $omega, $g, $jac),
            13..=16 => $self.$pass::<T, 16>(0, $theta, $omega, $g, $jac),
            17..=20 => $self.$pass::<T, 20>(0, $theta, $omega, $g, $jac),
            21..=24 => $self.$pass::<T, 24>(0, $theta, $omega, $g, $jac),
            25..=32 => $self.$pass::<T, 32>(0, $theta, $omega, $g, $jac),
            p => {
                let mut first = 0;
                while first < p {
                    $self.$pass::<T, 32>(first, $theta, $omega, $g, $jac);
                    first += 32;
                }
            }
        }
    };
}

/// Checks data against a sample time `ts` (s): no mixed sample times, the data's Ts (if
/// any) equal to it, every ω at or below the Nyquist frequency π/Ts.
fn check_sample_time<T: Real>(ts: f64, data: &FrequencyData<T>) -> Result<()> {
    if !(ts.is_finite() && ts > 0.0) {
        return Err(FdidError::InvalidArgument {
            name: "ts",
            value: format!("{ts}"),
            reason: "the model's sample time must be positive and finite".into(),
        });
    }
    if data.mixed_sample_times() {
        return Err(FdidError::InvalidArgument {
            name: "ts",
            value: "several".into(),
            reason: "the data merge experiments with different sample times: only a \
                     continuous-time model without a transient term fits them"
                .into(),
        });
    }
    data.check_sampled_grid(T::lit(ts), "model")
}

impl<T: Real, G: GreyBox> ModelStructure<T> for AutoDiff<G> {
    /// The model's parameters plus the n transient coefficients, if any.
    fn n_params(&self) -> usize {
        self.total_params()
    }

    /// G(θ, ω_k) = response(θ, x_k) evaluated in `T` (NaN for a θ of the wrong length).
    fn response_into(&self, theta: &[T], omega: &[T], out: &mut [Complex<T>]) {
        if theta.len() != self.total_params() {
            return fill_nan(out, None);
        }
        let theta = &theta[..self.model.n_params()];
        for (w, o) in omega.iter().zip(out.iter_mut()) {
            *o = self.model.response(theta, self.variable(*w));
        }
    }

    /// G and ∂G/∂θ by one evaluation per line in dual numbers (NaN for a θ of the wrong
    /// length).
    fn jacobian_into(
        &self,
        theta: &[T],
        omega: &[T],
        g: &mut [Complex<T>],
        jac: &mut DMatrix<Complex<T>>,
    ) {
        if theta.len() != self.total_params() || jac.shape() != (omega.len(), theta.len()) {
            return fill_nan(g, Some(jac));
        }
        let pm = self.model.n_params();
        let model_theta = &theta[..pm];
        if pm == 0 {
            self.response_into(theta, omega, g);
        } else {
            dispatch!(self.jacobian_pass(model_theta, omega, g, jac));
        }
        // G does not depend on the transient coefficients
        for j in pm..theta.len() {
            jac.column_mut(j).fill(Complex::new(T::zero(), T::zero()));
        }
    }

    /// The transient term of [`AutoDiff::with_transient`] (McKelvey eqs. 4–5) or
    /// [`AutoDiff::with_sampled_transient`] (eqs. 9–10), with ∂T/∂θ by dual numbers (through
    /// the denominator, and in continuous time through the poles); false without one. NaN
    /// for a θ of the wrong length or a denominator that cannot be evaluated.
    fn transient_into(
        &self,
        theta: &[T],
        omega: &[T],
        t: &mut [Complex<T>],
        jac: Option<&mut DMatrix<Complex<T>>>,
    ) -> bool {
        if self.transient.is_none() {
            return false;
        }
        let p = self.total_params();
        match jac {
            Some(jac) => {
                if theta.len() != p || jac.shape() != (omega.len(), p) {
                    fill_nan(t, Some(jac));
                } else {
                    dispatch!(self.transient_pass(theta, omega, t, jac));
                }
            }
            None => {
                if theta.len() != p {
                    fill_nan(t, None);
                } else {
                    let mut none = DMatrix::zeros(0, 0);
                    self.transient_pass::<T, 0>(theta.len(), theta, omega, t, &mut none);
                }
            }
        }
        true
    }

    /// At least p/2 lines; for a discrete-time model, or with the sampled transient term,
    /// the data's sample time (if any) must equal the model's (the transient's) and every ω
    /// must lie at or below the Nyquist frequency π/Ts.
    fn check_data(&self, data: &FrequencyData<T>) -> Result<()> {
        crate::model::check_line_count(self.total_params(), data.len())?;
        if let Some(ts) = self.model.sample_time() {
            check_sample_time(ts, data)?;
        }
        self.check_sampled_data(data)
    }
}

impl<G: GreyBox> PhysicalParameters for AutoDiff<G> {
    /// The model's [`GreyBox::parameters`], all free, in the order of θ, then the transient
    /// coefficients `transient1` … `transient{n}` (linear scale, no unit), if any.
    fn physical_parameters(&self) -> Vec<(Parameter, Slot)> {
        let mut params = self.model.parameters();
        params.resize_with(self.model.n_params(), || Parameter::linear("", ""));
        params.extend(
            (1..=self.n_transient()).map(|j| Parameter::linear(&format!("transient{j}"), "")),
        );
        params
            .into_iter()
            .enumerate()
            .map(|(j, p)| (p, Slot::Free(j)))
            .collect()
    }

    fn check_theta(&self, theta: &[f64]) -> Result<()> {
        self.model
            .check_params(&theta[..self.model.n_params().min(theta.len())])
    }
}

impl<M: PhysicalParameters> PhysicalParameters for Delayed<M> {
    /// The inner model's parameters, then the delay `tau` (s, linear scale).
    fn physical_parameters(&self) -> Vec<(Parameter, Slot)> {
        let mut params = self.inner().physical_parameters();
        let free = params
            .iter()
            .filter(|(_, s)| matches!(s, Slot::Free(_)))
            .count();
        params.push((Parameter::linear("tau", "s"), Slot::Free(free)));
        params
    }

    fn check_theta(&self, theta: &[f64]) -> Result<()> {
        let Some((tau, inner)) = theta.split_last() else {
            return Ok(());
        };
        self.check_delay(*tau)?;
        self.inner().check_theta(inner)
    }
}

/// A model with some parameters held at known values: θ holds only the free ones.
///
/// ```text
/// G_Fixed(θ_free, ω) = G_M(θ_full, ω),   θ_full,i = θ_free,j(i) (free) or c_i (fixed),
/// ∂G_Fixed/∂θ_free,j = ∂G_M/∂θ_full,i(j)
/// ```
///
/// Use it where the physics leaves a direction unidentifiable (a DC motor's five
/// parameters give three transfer-function combinations: fix the measured winding
/// resistance and inductance) or where a value is known from another experiment. The criteria see only
/// the free parameters; [`crate::estimate::greybox::physical_values`] reports the fixed ones with zero std.
///
/// ```
/// use fdid::prelude::*;
/// use fdid::greybox::{AutoDiff, Fixed, physical::DcMotor};
/// let motor = AutoDiff::new(DcMotor::new());
/// // hold R = 2 Ω and L = 5 mH; θ = [ln K, ln J, ln b]
/// let model = Fixed::physical(motor, &[("R", 2.0), ("L", 5e-3)]).unwrap();
/// assert_eq!(ModelStructure::<f64>::n_params(&model), 3);
/// ```
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Fixed<M> {
    inner: M,
    /// Per inner parameter: the fixed θ value, or `None` when free.
    fixed: Vec<Option<f64>>,
}

impl<M> Fixed<M> {
    /// `inner` with θ entries `fixed = [(index, θ value), …]` held (θ values: on the log
    /// scale for log parameters).
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] (name `"fixed"`) for an index ≥ p or given twice;
    /// [`FdidError::NonFinite`] for a non-finite value.
    pub fn new<T: Real>(inner: M, fixed: &[(usize, T)]) -> Result<Self>
    where
        M: ModelStructure<T>,
    {
        let p = inner.n_params();
        let mut slots = vec![None; p];
        for (i, (j, v)) in fixed.iter().enumerate() {
            if *j >= p || slots[*j].is_some() {
                return Err(FdidError::InvalidArgument {
                    name: "fixed",
                    value: format!("index {j}"),
                    reason: if *j >= p {
                        format!("the model has {p} parameters")
                    } else {
                        "the parameter is fixed twice".into()
                    },
                });
            }
            if !Float::is_finite(*v) {
                return Err(FdidError::NonFinite {
                    what: "fixed",
                    index: i,
                    value: format!("{v}"),
                });
            }
            slots[*j] = Some(v.to_f64_lossless());
        }
        Ok(Self {
            inner,
            fixed: slots,
        })
    }

    /// `inner` with the named parameters held at physical values (e.g. `[("R", 2.0)]` in
    /// the parameter's unit), converted to θ by their [`Scale`].
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] for an unknown or repeated name, a name of a
    /// parameter that is not free in `inner`, or a value the scale rejects (non-finite,
    /// non-positive on the log scale).
    pub fn physical(inner: M, values: &[(&str, f64)]) -> Result<Self>
    where
        M: PhysicalParameters,
    {
        let params = inner.physical_parameters();
        let p = params
            .iter()
            .filter(|(_, s)| matches!(s, Slot::Free(_)))
            .count();
        let mut slots = vec![None; p];
        for (name, v) in values {
            let Some((param, Slot::Free(j))) = params.iter().find(|(q, _)| q.name == *name) else {
                return Err(FdidError::InvalidArgument {
                    name: "fixed",
                    value: (*name).to_string(),
                    reason: format!(
                        "not a free parameter of the model (free: {})",
                        params
                            .iter()
                            .filter(|(_, s)| matches!(s, Slot::Free(_)))
                            .map(|(q, _)| q.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                });
            };
            if slots[*j].is_some() {
                return Err(FdidError::InvalidArgument {
                    name: "fixed",
                    value: (*name).to_string(),
                    reason: "the parameter is fixed twice".into(),
                });
            }
            slots[*j] = Some(param.theta::<f64>(*v)?);
        }
        Ok(Self {
            inner,
            fixed: slots,
        })
    }

    /// The model with all parameters.
    pub fn inner(&self) -> &M {
        &self.inner
    }

    /// The full θ of the inner model from the free θ (`None` when `free` has the wrong
    /// length).
    pub fn full_theta<T: Real>(&self, free: &[T]) -> Option<Vec<T>> {
        let mut it = free.iter();
        let full: Vec<T> = self
            .fixed
            .iter()
            .map(|f| match f {
                Some(v) => Some(T::lit(*v)),
                None => it.next().copied(),
            })
            .collect::<Option<_>>()?;
        it.next().is_none().then_some(full)
    }

    /// The free entries of a full θ.
    pub fn free_theta<T: Real>(&self, full: &[T]) -> Vec<T> {
        full.iter()
            .zip(&self.fixed)
            .filter(|(_, f)| f.is_none())
            .map(|(v, _)| *v)
            .collect()
    }

    fn free_count(&self) -> usize {
        self.fixed.iter().filter(|f| f.is_none()).count()
    }
}

impl<T: Real, M: ModelStructure<T>> ModelStructure<T> for Fixed<M> {
    fn n_params(&self) -> usize {
        self.free_count()
    }

    fn response_into(&self, theta: &[T], omega: &[T], out: &mut [Complex<T>]) {
        match self.full_theta(theta) {
            Some(full) => self.inner.response_into(&full, omega, out),
            None => fill_nan(out, None),
        }
    }

    /// The inner Jacobian's free columns.
    fn jacobian_into(
        &self,
        theta: &[T],
        omega: &[T],
        g: &mut [Complex<T>],
        jac: &mut DMatrix<Complex<T>>,
    ) {
        let Some(full) = self.full_theta(theta) else {
            return fill_nan(g, Some(jac));
        };
        let mut all = DMatrix::zeros(omega.len(), full.len());
        self.inner.jacobian_into(&full, omega, g, &mut all);
        self.copy_free_columns(&all, jac);
    }

    fn transient_into(
        &self,
        theta: &[T],
        omega: &[T],
        t: &mut [Complex<T>],
        jac: Option<&mut DMatrix<Complex<T>>>,
    ) -> bool {
        let Some(full) = self.full_theta(theta) else {
            return false;
        };
        match jac {
            None => self.inner.transient_into(&full, omega, t, None),
            Some(jac) => {
                let mut all = DMatrix::zeros(omega.len(), full.len());
                let has = self.inner.transient_into(&full, omega, t, Some(&mut all));
                if has {
                    self.copy_free_columns(&all, jac);
                }
                has
            }
        }
    }

    fn check_data(&self, data: &FrequencyData<T>) -> Result<()> {
        self.inner.check_data(data)?;
        crate::model::check_line_count(self.free_count(), data.len())
    }
}

impl<M> Fixed<M> {
    fn copy_free_columns<T: Real>(&self, all: &DMatrix<Complex<T>>, jac: &mut DMatrix<Complex<T>>) {
        let free = self
            .fixed
            .iter()
            .enumerate()
            .filter(|(_, f)| f.is_none())
            .map(|(i, _)| i);
        for (j, i) in free.enumerate() {
            jac.column_mut(j).copy_from(&all.column(i));
        }
    }
}

impl<M: PhysicalParameters> PhysicalParameters for Fixed<M> {
    /// The inner model's parameters with the fixed ones marked [`Slot::Fixed`] and the free
    /// ones renumbered.
    fn physical_parameters(&self) -> Vec<(Parameter, Slot)> {
        // free index of each inner θ entry
        let mut map = vec![None; self.fixed.len()];
        let mut next = 0;
        for (i, f) in self.fixed.iter().enumerate() {
            if f.is_none() {
                map[i] = Some(next);
                next += 1;
            }
        }
        self.inner
            .physical_parameters()
            .into_iter()
            .map(|(p, s)| match s {
                Slot::Free(i) => match (self.fixed.get(i).copied().flatten(), map.get(i)) {
                    (Some(v), _) => (p, Slot::Fixed(v)),
                    (None, Some(Some(j))) => (p, Slot::Free(*j)),
                    _ => (p, Slot::Free(i)),
                },
                fixed => (p, fixed),
            })
            .collect()
    }

    fn check_theta(&self, theta: &[f64]) -> Result<()> {
        match self.full_theta(theta) {
            Some(full) => self.inner.check_theta(&full),
            None => Ok(()),
        }
    }
}
