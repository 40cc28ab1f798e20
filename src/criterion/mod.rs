//! Criteria: what an estimator minimises. A criterion binds a model and data into a
//! problem of one of the kinds in [`crate::problem`].
//!
//! | criterion | McKelvey | needs | problem kind | solver |
//! |---|---|---|---|---|
//! | [`MaximumLikelihood`] | eq. 23, fixed noise model | [`ModelStructure`](crate::ModelStructure) | nonlinear LS | [`LevenbergMarquardt`](crate::solver::LevenbergMarquardt) |
//! | [`Levy`] | eq. 39 | [`EquationError`](crate::EquationError) | linear LS | [`LinearLeastSquares`](crate::solver::LinearLeastSquares) |
//! | [`SanathananKoerner`] | eq. 41 | [`EquationError`](crate::EquationError) | re-weighted LS | [`FixedPoint`](crate::solver::FixedPoint) |
//! | [`TotalLeastSquares`] | — | [`EquationError`](crate::EquationError) | homogeneous | [`SvdNullVector`](crate::solver::SvdNullVector) |
//! | [`NoiseModelMl`] | eqs. 23, 25, 26, noise model H = C/D estimated | [`WithNoiseModel`](crate::model::WithNoiseModel) of any [`ModelStructure`](crate::ModelStructure) | nonlinear LS | [`LevenbergMarquardt`](crate::solver::LevenbergMarquardt) |
//! | [`ErrorsInVariables`] | eq. 42 with the input–output covariance | [`ModelStructure`](crate::ModelStructure) + input/output noise (co)variances | nonlinear LS | [`LevenbergMarquardt`](crate::solver::LevenbergMarquardt) |
//!
//! Every output-error criterion compares Y with Ŷ = G U + T (see
//! [`crate::model::Output`]), so a transient term of the model ([`crate::Rational::with_transient`],
//! [`crate::model::Modal::with_transient`]) and a delay factor ([`crate::model::Delayed`])
//! compose with each of them.

mod equation_error;
mod levy;
mod ml;
mod noise_model;
mod sk;
mod tls;

mod eiv;
pub use crate::data::NoiseWeighting;
pub use eiv::{EivProblem, ErrorsInVariables};
pub use equation_error::EquationErrorSystem;
pub use levy::{Levy, LevyProblem};
pub use ml::{MaximumLikelihood, MlProblem};
pub use noise_model::interior_lines;
pub use noise_model::{NoiseModelMl, NoiseModelProblem, NoiseModelResiduals};
pub use sk::{SanathananKoerner, SkProblem};
pub use tls::{TlsProblem, TotalLeastSquares};

use crate::data::FrequencyData;
use crate::error::{FdidError, Result};
use crate::scalar::Real;

/// A criterion for model `M` on data with scalar `T`.
pub trait Criterion<T: Real, M: ?Sized> {
    /// The problem this criterion hands to a solver.
    type Problem<'a>
    where
        Self: 'a,
        M: 'a,
        T: 'a;

    /// Binds the model and data into a problem, validating both.
    ///
    /// # Errors
    /// Data the model cannot be fitted to (too few lines, wrong sample time, zero input on
    /// a line, invalid noise variances).
    fn problem<'a>(&'a self, model: &'a M, data: &'a FrequencyData<T>)
    -> Result<Self::Problem<'a>>;
}

/// Checks that no input spectrum line is zero (it would carry no information on G).
pub(crate) fn check_input<T: Real>(data: &FrequencyData<T>) -> Result<()> {
    match data.u().iter().position(|u| u.norm_sqr() == T::zero()) {
        None => Ok(()),
        Some(index) => Err(FdidError::ZeroInput {
            index,
            omega: data.omega()[index].to_f64_lossless(),
        }),
    }
}

/// The output-error cost Σ_k w_k²|Y_k − Ŷ_k|² of `model` at θ on `data`, with
/// Ŷ = G U + T (the transient when the model has one) and w_k = 1 when `weights` is `None`.
/// Returns the model response G on the lines too.
pub(crate) fn output_error_cost<T: Real, M: crate::model::ModelStructure<T> + ?Sized>(
    model: &M,
    theta: &[T],
    data: &FrequencyData<T>,
    weights: Option<&[T]>,
) -> (T, Vec<crate::scalar::Complex<T>>) {
    let mut out = crate::model::Output::new(data.len(), model.n_params());
    let cost = output_error_cost_in(&mut out, model, theta, data, weights);
    (cost, out.g)
}

/// [`output_error_cost`] in the buffers of `out` (G in `out.g`), which an iteration reuses.
pub(crate) fn output_error_cost_in<T: Real, M: crate::model::ModelStructure<T> + ?Sized>(
    out: &mut crate::model::Output<T>,
    model: &M,
    theta: &[T],
    data: &FrequencyData<T>,
    weights: Option<&[T]>,
) -> T {
    out.evaluate(model, theta, data, false);
    out.yhat
        .iter()
        .zip(data.y())
        .enumerate()
        .fold(T::zero(), |s, (k, (yhat, y))| {
            let wk = weights.map_or(T::one(), |w| w[k]);
            s + ((*y - *yhat) * wk).norm_sqr()
        })
}

/// Relative change ‖new − old‖/‖new‖ between two model responses.
pub(crate) fn relative_change<T: Real>(
    old: &[crate::scalar::Complex<T>],
    new: &[crate::scalar::Complex<T>],
) -> T {
    let (num, den) = old
        .iter()
        .zip(new)
        .fold((T::zero(), T::zero()), |(n, d), (a, b)| {
            (n + (*a - *b).norm_sqr(), d + b.norm_sqr())
        });
    num_traits::Float::sqrt(num / den)
}
