//! [`AutoDiff`]: a [`GreyBox`] model as a [`ModelStructure`], its Jacobian by dual
//! numbers.

use super::{Dual, GreyBox, Parameter, PhysicalParameters, Slot, Transient};
use crate::data::FrequencyData;
use crate::error::{FdidError, Result};
use crate::model::ModelStructure;
use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;
use num_traits::Float;

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
/// and [`crate::estimate::greybox::fit_ml_from`] return typed errors.
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
    pub(super) model: G,
    /// The transient term of a non-periodic record, when enabled.
    #[cfg_attr(feature = "serde", serde(default))]
    pub(super) transient: Option<Transient>,
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
pub(crate) fn fill_nan<T: Real>(g: &mut [Complex<T>], jac: Option<&mut DMatrix<Complex<T>>>) {
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
pub(crate) fn check_sample_time<T: Real>(ts: f64, data: &FrequencyData<T>) -> Result<()> {
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
