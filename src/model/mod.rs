//! Model structures: parameterisations θ ↦ G(θ, ω) with analytic Jacobians.
//!
//! [`ModelStructure`] is the one trait every criterion needs. Models whose equation error
//! A(θ)Y − B(θ)U is affine in θ also implement [`EquationError`], which the linear
//! criteria (Levy, Sanathanan–Koerner, TLS) require; models with poles and zeros implement
//! [`PolesZeros`].

pub(crate) mod delay;
mod kept_basis;
mod kept_grid;
mod modal;
mod noise;
mod output;
mod rational;
mod stacked_rows;

pub use delay::{Delayed, remove_delay};
pub use modal::{Modal, ModalParts};
pub use noise::{NoiseModel, WithNoiseModel};
pub use output::Output;
pub use rational::{Domain, Rational};
pub(crate) use rational::{log_spread_poles, positive_band};

use crate::data::FrequencyData;
use crate::error::Result;
use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;

/// A parameterisation θ ∈ ℝᵖ ↦ G(θ, ω) evaluated at angular frequencies ω (rad/s).
///
/// Implementations provide the response and its **analytic** Jacobian ∂G/∂θ. The trait is
/// object safe, so models can be composed at run time.
pub trait ModelStructure<T: Real> {
    /// Number of free real parameters p.
    fn n_params(&self) -> usize;

    /// Writes G(θ, ω_k) into `out` (same length as `omega`).
    fn response_into(&self, theta: &[T], omega: &[T], out: &mut [Complex<T>]);

    /// Writes G(θ, ω_k) into `g` and ∂G(θ, ω_k)/∂θ_j into `jac[(k, j)]` (`jac` is
    /// `omega.len() × p`).
    fn jacobian_into(
        &self,
        theta: &[T],
        omega: &[T],
        g: &mut [Complex<T>],
        jac: &mut DMatrix<Complex<T>>,
    );

    /// Writes the input-independent output term T(θ, ω_k) of a model with a transient, so
    /// that the modelled output is Ŷ_k = G(θ, ω_k) U_k + T(θ, ω_k) (McKelvey eqs. 4, 9), and,
    /// when `jac` is given, ∂T/∂θ_j into `jac[(k, j)]` (`omega.len() × p`, every column
    /// written). Returns false, writing nothing, for models without such a term (the
    /// default).
    fn transient_into(
        &self,
        theta: &[T],
        omega: &[T],
        t: &mut [Complex<T>],
        jac: Option<&mut DMatrix<Complex<T>>>,
    ) -> bool {
        let _ = (theta, omega, t, jac);
        false
    }

    /// False when [`ModelStructure::transient_into`] certainly returns false (no transient
    /// term), so that evaluators can skip the N × p buffer of ∂T/∂θ. The default, true, is
    /// always correct.
    fn has_transient(&self) -> bool {
        true
    }

    /// The output-error Jacobian rows in one pass, for a model without a transient term:
    /// G(θ, ω_k) into `g` and s_k·∂G(θ, ω_k)/∂θ_j·U_k real-stacked into `jac` (rows 2k and
    /// 2k + 1 of column j the real and imaginary parts, `jac` 2N × p), with s_k = −w_k, or
    /// −1 without `weight`; each value within a few units of rounding of
    /// `(∂G/∂θ_j · U_k)·s_k` from [`ModelStructure::jacobian_into`]'s ∂G/∂θ_j (the pass may
    /// group the products differently). Returns false, with nothing promised
    /// written, when the structure has no such pass (the default): the caller then
    /// evaluates [`ModelStructure::jacobian_into`] and stacks its values.
    fn stacked_jacobian_into(
        &self,
        theta: &[T],
        omega: &[T],
        u: &[Complex<T>],
        weight: Option<&[T]>,
        g: &mut [Complex<T>],
        jac: &mut DMatrix<T>,
    ) -> bool {
        let _ = (theta, omega, u, weight, g, jac);
        false
    }

    /// The diagonal map back from a fit to normalised data: for θ′ fitted to
    /// (c_y·Y_k, c_u·U_k) (`output` = c_y, `input` = c_u), θ_j = d_j·θ′_j describes the data
    /// (Y_k, U_k), with d returned here. Parameters of G's gain (a numerator) have
    /// d_j = c_u/c_y, those of the output term T (a transient) 1/c_y, and those that shape
    /// the response (poles, a delay, a monic noise model) 1. `None` (the default): the
    /// model has no such map and is fitted to the data as given. See
    /// [`crate::data::Normalisation`].
    fn normalisation_map(&self, output: T, input: T) -> Option<Vec<T>> {
        let _ = (output, input);
        None
    }

    /// Checks that the model can be fitted to `data` (domain, sample time, enough lines).
    /// The criteria call it before they evaluate the model on the data, so a model may also
    /// keep values of the data's grid there for its evaluations (a discrete-time
    /// [`crate::Rational`] keeps z⁻¹ = e^{−iωTs}, read by evaluations on runs of the same
    /// lines, with the same values bit for bit).
    ///
    /// # Errors
    /// Model-specific; [`crate::FdidError::TooFewFrequencies`] at least when
    /// `2·lines < p`.
    fn check_data(&self, data: &FrequencyData<T>) -> Result<()> {
        check_line_count(self.n_params(), data.len())
    }

    /// G(θ, ω_k) as a new vector.
    fn response(&self, theta: &[T], omega: &[T]) -> Vec<Complex<T>> {
        let mut out = vec![Complex::new(T::zero(), T::zero()); omega.len()];
        self.response_into(theta, omega, &mut out);
        out
    }

    /// Whether θ lies in the stable set S of the structure — every pole strictly stable
    /// (Re p < 0 in s, |p| < 1 in z) — for the stability-constrained fits
    /// ([`crate::solver::Feasible`]); `None` (the default) for a structure without that
    /// notion, which the constrained fits then leave unconstrained. A θ whose poles cannot
    /// be computed is not in S.
    fn stable_at(&self, theta: &[T]) -> Option<bool> {
        let _ = theta;
        None
    }

    /// θ with every unstable pole reflected into the stable region, keeping |G| on the
    /// frequency axis (p ↦ −p̄ in s, p ↦ 1/p̄ in z with the gain scaled by 1/|p|), the start
    /// of a stability-constrained fit; `None` (the default) for a structure without poles.
    ///
    /// # Errors
    /// When the poles cannot be computed or the reflected model cannot be formed.
    fn stabilised(&self, theta: &[T]) -> Option<Result<Vec<T>>> {
        let _ = theta;
        None
    }
}

/// Largest polynomial degree a model accepts, `usize::MAX / 8`: far beyond any order that
/// data could identify, and low enough that parameter counts (na + nb + 1, plus a
/// transient of up to max(na, nb) coefficients) cannot overflow. Orders the data cannot
/// support are rejected later, by [`ModelStructure::check_data`].
pub(crate) const MAX_DEGREE: usize = usize::MAX / 8;

/// Checks the degrees `na`, `nb` of a model against [`MAX_DEGREE`].
///
/// # Errors
/// [`crate::FdidError::InvalidArgument`] naming the degree.
pub(crate) fn check_degrees(na: usize, nb: usize) -> Result<()> {
    for (name, d) in [("na", na), ("nb", nb)] {
        if d > MAX_DEGREE {
            return Err(crate::error::FdidError::InvalidArgument {
                name,
                value: d.to_string(),
                reason: format!("a model degree must be at most {MAX_DEGREE}"),
            });
        }
    }
    Ok(())
}

/// Checks the degrees of a continuous-time model built on a grid of `lines` frequencies:
/// [`check_degrees`], then a degree above 2·lines (more unknowns in one polynomial than
/// the 2·lines real equations of the grid: no fit on that grid can succeed) is
/// [`crate::FdidError::TooFewFrequencies`] with `parameters = na + nb + 1`.
pub(crate) fn check_degrees_on_grid(na: usize, nb: usize, lines: usize) -> Result<()> {
    check_degrees(na, nb)?;
    if na.max(nb) > 2 * lines {
        return Err(crate::error::FdidError::TooFewFrequencies {
            lines,
            equations: 2 * lines,
            parameters: na + nb + 1,
        });
    }
    Ok(())
}

/// Fails with [`crate::FdidError::TooFewFrequencies`] when `lines` complex lines give fewer
/// real equations than `parameters`.
pub(crate) fn check_line_count(parameters: usize, lines: usize) -> Result<()> {
    if 2 * lines < parameters {
        return Err(crate::error::FdidError::TooFewFrequencies {
            lines,
            equations: 2 * lines,
            parameters,
        });
    }
    Ok(())
}

/// Models linear in their coefficients in equation-error form.
///
/// With the homogeneous coefficient vector c (θ plus the one coefficient fixed by the
/// normalisation), the equation error at line k is
/// `e_k(c) = A(c, ω_k) Y_k − B(c, ω_k) U_k = Σ_j R_kj c_j`.
/// Levy (McKelvey eq. 39) and Sanathanan–Koerner (eq. 41) solve for θ with the normalising
/// coefficient fixed to one; TLS solves for c with ‖c‖ = 1.
pub trait EquationError<T: Real>: ModelStructure<T> {
    /// Length of c: `n_params() + 1`.
    fn n_coefficients(&self) -> usize {
        self.n_params() + 1
    }

    /// Index in c of the coefficient the normalisation fixes to one.
    fn normalising_index(&self) -> usize;

    /// Writes the regressor R (`data.len() × n_coefficients()`) into `out`.
    fn regressor_into(&self, data: &FrequencyData<T>, out: &mut DMatrix<Complex<T>>);

    /// Writes the rows k0 … k0 + `out.nrows()` − 1 of the regressor R (lines of `data`)
    /// into `out` (`out.nrows() × n_coefficients()`), so that a solve accumulated over
    /// blocks of lines never forms the N × q matrix. The default forms all of R with
    /// [`EquationError::regressor_into`] and copies the rows; structures override it.
    ///
    /// # Panics
    /// When the lines run past the end of `data` or `out` has the wrong number of columns.
    fn regressor_lines_into(
        &self,
        data: &FrequencyData<T>,
        k0: usize,
        out: &mut DMatrix<Complex<T>>,
    ) {
        let mut full = DMatrix::zeros(data.len(), self.n_coefficients());
        self.regressor_into(data, &mut full);
        out.copy_from(&full.rows(k0, out.nrows()));
    }

    /// Writes the denominator A(θ, ω_k) (the Sanathanan–Koerner weight is 1/|A|²).
    fn denominator_into(&self, theta: &[T], omega: &[T], out: &mut [Complex<T>]);

    /// Writes G(θ, ω_k) into `g` and A(θ, ω_k) into `a`: the Sanathanan–Koerner cost of an
    /// estimate and the weights of the next iteration. The default makes two evaluations
    /// ([`ModelStructure::response_into`], [`EquationError::denominator_into`]);
    /// structures override it with one.
    fn response_and_denominator_into(
        &self,
        theta: &[T],
        omega: &[T],
        g: &mut [Complex<T>],
        a: &mut [Complex<T>],
    ) {
        self.response_into(theta, omega, g);
        self.denominator_into(theta, omega, a);
    }

    /// A model of the same structure with its basis adapted to θ — e.g. partial fractions
    /// whose basis poles are moved to the poles of θ (vector fitting's relocation) — or
    /// `None` when the basis is fixed. A Levy solve in the relocated basis is then one
    /// Sanathanan–Koerner iteration.
    ///
    /// # Errors
    /// When θ does not define a valid new basis.
    fn relocated(&self, theta: &[T]) -> Option<Result<Self>>
    where
        Self: Sized,
    {
        let _ = theta;
        None
    }

    /// θ from a homogeneous coefficient vector: c divided by its normalising entry, which is
    /// then dropped. `None` when that entry is (numerically) zero.
    fn theta_from_coefficients(&self, c: &[T]) -> Option<Vec<T>> {
        let i = self.normalising_index();
        let n = *c.get(i)?;
        let max = c.iter().fold(T::zero(), |m, v| {
            num_traits::Float::max(m, num_traits::Float::abs(*v))
        });
        if !(num_traits::Float::abs(n) > max * T::default_epsilon() * T::lit(16.0)) {
            return None;
        }
        Some(
            c.iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(_, v)| *v / n)
                .collect(),
        )
    }
}

/// Models with poles, zeros and a gain.
pub trait PolesZeros<T: Real> {
    /// Poles: in s (rad/s) for continuous time, in z for discrete time.
    ///
    /// # Errors
    /// Eigenvalue failure or non-finite parameters.
    fn poles(&self, theta: &[T]) -> Result<Vec<Complex<T>>>;

    /// Zeros, in the same plane as the poles (for z: the roots of z^nb B, zeros at the
    /// origin left out).
    ///
    /// # Errors
    /// As [`PolesZeros::poles`].
    fn zeros(&self, theta: &[T]) -> Result<Vec<Complex<T>>>;

    /// Gain k of the factored form G = k Π(v − zᵢ)/Π(v − pⱼ) (v = s or z, up to a power
    /// of z for discrete time).
    fn gain(&self, theta: &[T]) -> T;
}
