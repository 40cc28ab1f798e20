//! # fdid — frequency-domain system identification
//!
//! Estimate linear dynamic models (poles, zeros, gain, with uncertainty) from measured
//! input/output spectra or frequency response data.
//!
//! The crate is built from three traits that compose:
//! - [`ModelStructure`]: a parameterisation θ ↦ G(θ, ω_k) with an analytic Jacobian
//!   (e.g. [`Rational`] in s or z); models linear in their parameters in equation-error
//!   form also implement [`EquationError`].
//! - [`Criterion`]: what is minimised — output-error maximum likelihood
//!   ([`MaximumLikelihood`], McKelvey eq. 23), Levy linear least squares ([`Levy`],
//!   eq. 39), Sanathanan–Koerner re-weighting ([`SanathananKoerner`], eq. 41), total
//!   least squares ([`TotalLeastSquares`]), ML with an estimated noise model H = C/D
//!   ([`criterion::NoiseModelMl`], eqs. 23–26) and errors-in-variables ML
//!   ([`criterion::ErrorsInVariables`], eq. 42).
//!
//! Model factors compose with every criterion: a transient term for non-periodic records
//! ([`Rational::with_transient`], eqs. 4–5; [`Rational::with_sampled_transient`], eqs.
//! 9–10), a time delay ([`model::Delayed`]), continuous-time models matched to sampled data
//! through the zero-order hold ([`model::Modal`], section 2.3). Every [`Fit`] carries the
//! parameter covariance (λR⁻¹ and the sandwich R⁻¹QR⁻¹, eqs. 32–34), confidence bounds on
//! |G| and phase, and validation statistics (cost against its χ² expectation, whiteness of
//! the residuals across frequency).
//! - [`Solver`]: how — Levenberg–Marquardt, QR/SVD linear least squares, SVD null vector,
//!   the SK fixed-point loop.
//!
//! A criterion that needs a linear-in-parameters model only accepts models implementing
//! [`EquationError`], and each solver only accepts the problem kind it can solve, so a
//! nonsensical combination does not compile.
//!
//! Continuous-time models are kept well conditioned at high orders over many decades:
//! [`Rational::continuous`] uses vector fitting's partial-fraction (barycentric) form for
//! every proper model, and [`Pipeline`] moves its basis poles to the estimated poles
//! (Sanathanan–Koerner as pole relocation) before the ML refinement. [`Pipeline`] runs
//! Levy → SK → ML; [`estimate::estimate()`] composes any criterion with any solver that
//! accepts its problem.
//! [`estimate::batch::fit_many`] fits many independent data sets with one pipeline, on rayon's
//! thread pool with the `rayon` feature. [`estimate::ModelSpec`] names a whole structure
//! (domain, orders, delay, transient, noise model, criterion) and
//! [`estimate::ModelSpec::fit`] picks the strategy for it; the discrepancy workflow
//! ([`workflow`]) augments one step by step.
//!
//! **Layers.** Each module belongs to one layer and imports only from its own and lower
//! ones: foundation (`scalar`, `error`, `stats`, `progress`, `recycle`) → linear algebra
//! (`linalg`, `basis`, `roots`) → data (`data`, `simulate`, `io`) → models (`model`,
//! `greybox`) → criteria (`problem`, `criterion`) → solvers (`solver`) → fits (`fit`,
//! `fitted`, `validation`) → estimation strategies (`estimate`, `ltv`, `mimo`) → the
//! workflow (`workflow`). Models and criteria describe; only `estimate` runs them. The
//! table is kept, and checked on every file, by the test `tests/suite/architecture.rs`.
//!
//! Equation numbers refer to T. McKelvey, *Frequency domain identification methods*
//! (Circuits Systems Signal Processing, 2002).
//!
//! ```
//! use fdid::prelude::*;
//!
//! // noise-free data from G(s) = 2 / (s^2 + 0.4 s + 1)
//! let omega: Vec<f64> = (1..=200).map(|k| 0.02 * k as f64).collect();
//! let frf: Vec<Complex<f64>> = omega
//!     .iter()
//!     .map(|w| {
//!         let s = Complex::new(0.0, *w);
//!         Complex::new(2.0, 0.0) / (s * s + s * 0.4 + 1.0)
//!     })
//!     .collect();
//! let data = FrequencyData::from_frf(omega, frf, None).unwrap();
//! let model = Rational::continuous(2, 0, data.omega()).unwrap();
//! let fit = Pipeline::default().fit(&model, &data).unwrap();
//! let mut poles = fit.poles().unwrap();
//! poles.sort_by(|a, b| a.im.partial_cmp(&b.im).unwrap());
//! assert!((poles[1] - Complex::new(-0.2, 0.96f64.sqrt())).norm() < 1e-9);
//! ```

#![warn(missing_docs)]
// `!(x > tol)` is deliberate throughout: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod basis;
pub mod criterion;
pub mod data;
pub mod error;
pub mod estimate;
pub mod fit;
pub mod fitted;
pub mod greybox;
#[cfg(doctest)]
mod guide;
#[cfg(feature = "csv")]
pub mod io;
pub mod linalg;
pub mod ltv;
pub mod mimo;
pub mod model;
pub mod problem;
pub mod progress;
pub mod recycle;
pub mod roots;
pub mod scalar;
pub mod simulate;
pub mod solver;
pub mod stats;
#[cfg(test)]
mod test_rng;
pub mod validation;
pub mod workflow;

pub use criterion::ErrorsInVariables;
pub use criterion::{Criterion, Levy, MaximumLikelihood, SanathananKoerner, TotalLeastSquares};
pub use data::{FrequencyData, NoiseVariances, TimeData};
pub use error::{FdidError, Result};
pub use estimate::{FurtherStarts, Pipeline, fit_eiv};
pub use fit::{Fit, NoiseLevel};
pub use fitted::FittedModel;
pub use model::{Delayed, EquationError, ModelStructure, PolesZeros, Rational};
pub use scalar::{Complex, Real};
pub use solver::{Solution, Solver};

/// The names most programs need.
pub mod prelude {
    pub use crate::criterion::NoiseWeighting;
    pub use crate::criterion::{
        Criterion, Levy, MaximumLikelihood, SanathananKoerner, TotalLeastSquares,
    };
    pub use crate::criterion::{ErrorsInVariables, NoiseModelMl};
    pub use crate::data::{FrequencyData, NoiseVariances, TimeData};
    pub use crate::data::{Lpm, LpmEstimate, lpm};
    pub use crate::error::{FdidError, Result};
    pub use crate::estimate::{FurtherStarts, Pipeline, estimate};
    pub use crate::estimate::{ModalOptions, fit_modal};
    pub use crate::estimate::{fit_delayed, fit_eiv, fit_noise_model};
    pub use crate::estimate::{fit_multistart, fit_multistart_discrete};
    pub use crate::fit::{Fit, NoiseLevel, StageKind};
    pub use crate::greybox::{AutoDiff, Fixed, GreyBox, PhysicalParameters};
    pub use crate::ltv::{LtvFit, LtvOde};
    pub use crate::model::Delayed;
    pub use crate::model::Modal;
    pub use crate::model::{Domain, EquationError, ModelStructure, PolesZeros, Rational};
    pub use crate::model::{NoiseModel, WithNoiseModel};
    pub use crate::scalar::{Complex, Real};
    pub use crate::solver::{
        FixedPoint, LevenbergMarquardt, LinearLeastSquares, Solution, Solver, SvdNullVector,
    };
}
