//! Simulation of time-varying continuous-time systems for testing estimators: multisine
//! excitations in continuous time, an adaptive ODE integrator for
//! `Σ αₙ(t) y⁽ⁿ⁾ = Σ βₙ(t) u⁽ⁿ⁾` (Lataire & Pintelon, *Frequency Domain Total Least
//! Squares Estimator of Time-Varying Systems*, eq. 1),
//! and seeded coloured noise at a chosen SNR — the set-up of their section V.
//!
//! - [`Multisine`]: `u(t) = Σ A_i cos(2π k_i t / T_period + φ_i)` with exact derivatives.
//! - [`OddMultisineDesign`]: a random-phase odd multisine with detection lines for
//!   nonlinear distortion (analysed by [`DistortionAnalysis`](crate::data::DistortionAnalysis)).
//! - [`TimeVaryingOde`] with [`Coefficient`]s, integrated by [`DormandPrince`]: samples
//!   `y(k T_s)` of the response from a given initial state.
//! - [`ColouredNoise`], [`DtFilter`], [`snr_db`]: disturbances at a target SNR.
//!
//! Integration is in `f64`; sampled records are returned in any [`Real`](crate::Real).

mod multisine;
mod noise;
mod odd_multisine;
mod ode;
mod rng;

pub use multisine::{LineSelection, Multisine};
pub use noise::{ColouredNoise, DtFilter, snr_db};
pub use odd_multisine::OddMultisineDesign;
pub use ode::{Coefficient, DormandPrince, OdeSolution, TimeVaryingOde};
pub use rng::SplitMix64;

/// A continuous-time input whose derivatives are known analytically, so that an ODE
/// with input derivatives on its right-hand side never differentiates numerically.
pub trait Excitation {
    /// Writes `out[n] = dⁿu/dtⁿ (t)` for `n = 0, …, out.len() − 1`.
    fn derivatives_into(&self, t: f64, out: &mut [f64]);
}
