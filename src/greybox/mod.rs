//! Grey-box (physical) model structures: write only the frequency response, get the exact
//! Jacobian by forward-mode dual numbers.
//!
//! # Implementing a model structure
//!
//! Every criterion of the crate needs a [`ModelStructure`](crate::model::ModelStructure): the response G(θ, ω) and its
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
//! 4. **Wrap it in [`AutoDiff`]**, which implements [`ModelStructure`](crate::model::ModelStructure) for `f32` and
//!    `f64`: `response_into` evaluates the formula in `T`, `jacobian_into` evaluates it
//!    once per line in `Complex<Dual<T, N>>`, each dual carrying all p derivatives (up to
//!    32 per pass; more parameters take several passes). The result works with every
//!    output-error criterion — [`crate::MaximumLikelihood`] (eq. 23),
//!    [`crate::criterion::NoiseModelMl`] (eqs. 23–26), [`crate::ErrorsInVariables`]
//!    (eq. 42) — and composes with [`crate::Delayed`] (a delay factor) and [`Fixed`]
//!    (parameters held at known values). The linear criteria (Levy, SK, TLS) need
//!    [`crate::EquationError`], which a general formula does not have.
//! 5. **Start from a physical guess** θ₀ (or from the poles of a rational fit, see
//!    [`physical`]), fit with [`crate::estimate::greybox::fit_ml_from`] (or [`crate::estimate::greybox::fit_eiv_from`]).
//! 6. **Read the result in physical units** with [`crate::estimate::greybox::physical_values`]: value exp(θ̂ᵢ) and,
//!    by the delta method, std = value·std(θ̂ᵢ), with confidence intervals exp(θ̂ᵢ ± zσᵢ).
//!
//! ```
//! use fdid::prelude::*;
//! use fdid::greybox::{AutoDiff, DualScalar, GreyBox, Parameter};
//! use fdid::estimate::greybox::{fit_ml_from, physical_values};
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
//! let fit = fit_ml_from(&model, &data, &start).unwrap();
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
//! Jacobian of [`crate::Rational`]. Write an analytic [`ModelStructure`](crate::model::ModelStructure) where that cost
//! matters.
//!
//! **Why an in-crate dual type.** The derivative part is a fixed-size array on the stack
//! (no allocation per operation), generic over the crate's [`Real`](crate::Real) so `f32` and `f64` both
//! work, and the crate gains no dependency; only the arithmetic `Complex<Dual>` needs is
//! implemented (all of [`num_traits::Float`]).

mod autodiff;
mod dual;
mod fixed;
mod mode;
mod parameters;
pub mod physical;
mod transient;

pub use autodiff::AutoDiff;
pub(crate) use autodiff::{check_sample_time, check_theta_common, fill_nan};
pub use dual::{Dual, DualScalar};
pub use fixed::Fixed;
pub use mode::{FlexibleModes, Product};
pub use parameters::{Parameter, PhysicalParameters, Scale, Slot};
pub use transient::Transient;

use crate::error::Result;
use crate::scalar::Complex;

/// A model given by its frequency response, written once for every scalar type.
///
/// ```text
/// G(θ, ω) = response(θ, x),   x = s = iω (continuous time) or x = z⁻¹ = e^{−iωTs}
/// (discrete time, McKelvey eq. 3)
/// ```
///
/// [`AutoDiff`] turns it into a [`ModelStructure`](crate::model::ModelStructure) with the exact Jacobian. The response
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
    /// Model-specific, e.g. [`FdidError::InvalidArgument`](crate::FdidError::InvalidArgument) naming the parameter.
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
