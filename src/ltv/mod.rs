//! Continuous-time, time-varying systems: the frequency-domain total least squares
//! estimator of J. Lataire and R. Pintelon, *Frequency domain total least squares
//! estimator of time-varying systems* (equation numbers below are that paper's).
//!
//! The system is a linear ODE with polynomial coefficients (eqs. 1–3),
//!
//! ```text
//! Σₙ αₙ(t) dⁿy/dtⁿ = Σₙ βₙ(t) dⁿu/dtⁿ,    αₙ(t) = Σ_p αₙ,ₚ tᵖ,  βₙ(t) = Σ_p βₙ,ₚ tᵖ,
//! ```
//!
//! evaluated in the frequency domain on a chosen set of DFT lines 𝕂 (eq. 5). The pieces:
//! - [`LtvOde`]: the model structure — orders N_α, N_β, N_p, a time basis ([`TimeBasis`])
//!   and a frequency basis ([`FrequencyBasis`], eq. 20), the transient + alias polynomial
//!   order N_tr (eqs. 11, 18), and the conversion to the monomial form of eqs. 1–2;
//! - [`regression()`]: the regression matrix K = [K_Y, −K_U, Φ] of eq. 11, built with FFTs
//!   (eq. 15) on the lines [`Lines`];
//! - [`LtvTlsProblem`]: eq. 19 as a [`crate::problem::HomogeneousProblem`], solvable by
//!   [`crate::solver::SvdNullVector`]; [`LtvOde::fit`] solves it and keeps every singular
//!   value in an [`LtvFit`];
//! - [`InstantaneousModel`]: the frozen system at t* (eq. 4) — its FRF, poles and zeros —
//!   and [`LtvFit::pole_sweep`] over time.

mod basis;
mod estimate;
mod model;
mod regression;

pub use basis::{FrequencyBasis, TimeBasis, legendre_into};
pub use estimate::{LtvFit, LtvTlsProblem};
pub use model::{InstantaneousModel, LtvOde, MonomialCoefficients};
pub use regression::{Lines, Regression, max_time_order, regression};
