//! Maximum likelihood with a parametric noise model H = C/D (McKelvey eqs. 23, 25, 26).

use super::Criterion;
use crate::data::FrequencyData;
use crate::error::{FdidError, Result};
use crate::model::{ModelStructure, NoiseModel, Output, WithNoiseModel};
use crate::problem::NonlinearProblem;
use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;
use num_traits::Float;
use std::cell::RefCell;

/// Maximum likelihood with the noise model estimated together with the system: minimise the
/// concentrated criterion
///
/// ```text
/// W(θ) = log( (1/N) Σ_k |Y_k − Ŷ_k(θ)|² / |H_k(θ)|² ) + (1/N) Σ_k log |H_k(θ)|²   (eq. 26)
/// ```
///
/// (eq. 23 with λ replaced by its minimiser λ̂(θ) of eq. 25), for a [`WithNoiseModel`]:
/// Ŷ_k = G(θ, ω_k) U_k + T(θ, ω_k) from the system model and H_k = H(θ, e^{iω_kTs}) from
/// its monic noise model. W is minimised as the least-squares problem
///
/// ```text
/// r_k(θ) = (Y_k − Ŷ_k)/H_k · g(θ),   g(θ) = exp( (1/N) Σ_j log|H_j| )
/// ```
///
/// (g is the geometric mean of |H|): ‖r‖² = N·λ̂(θ)·g² so log(‖r‖²/N) = W(θ), and
/// Levenberg–Marquardt on the real-stacked r_k minimises W. The Jacobian is analytic,
/// ∂r_k/∂θ_G = −(g/H_k) ∂Ŷ_k/∂θ_G and ∂r_k/∂η = r_k (∂log g/∂η − ∂log H_k/∂η), with
/// ∂log g/∂η = (1/N) Σ_j Re ∂log H_j/∂η.
///
/// Every line of the data is used as a complex Gaussian line (McKelvey leaves out
/// ω = 0 and ω = π/Ts, where the DFT is real; see [`interior_lines`]). Lines with U_k = 0
/// are allowed: they carry information on H only. [`crate::estimate::fit_noise_model`] runs the whole
/// estimation from a system model and a time record's DFT.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct NoiseModelMl;

/// Which residuals a [`NoiseModelProblem`] returns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoiseModelResiduals {
    /// r_k = (Y_k − Ŷ_k)/H_k · g: minimising ‖r‖² minimises eq. 26.
    Concentrated,
    /// r_k = (Y_k − Ŷ_k)/H_k, the estimated innovations (‖r‖²/N = λ̂, eq. 25). Not a
    /// criterion for the noise parameters (it is minimised by |H| → ∞); with H at its
    /// estimate its Jacobian gives the covariance of eqs. 33–34 (see [`crate::estimate::fit_noise_model`]).
    Innovations,
}

/// The noise-model ML criterion bound to a model and data.
pub struct NoiseModelProblem<'a, T: Real, M> {
    model: &'a WithNoiseModel<M>,
    data: &'a FrequencyData<T>,
    noise: NoiseModel<T>,
    form: NoiseModelResiduals,
    scratch: RefCell<Scratch<T>>,
}

struct Scratch<T: Real> {
    out: Output<T>,
    h: Vec<Complex<T>>,
    dlog: DMatrix<Complex<T>>,
}

impl<T: Real, M: ModelStructure<T>> Criterion<T, WithNoiseModel<M>> for NoiseModelMl {
    type Problem<'a>
        = NoiseModelProblem<'a, T, M>
    where
        M: 'a,
        T: 'a;

    fn problem<'a>(
        &'a self,
        model: &'a WithNoiseModel<M>,
        data: &'a FrequencyData<T>,
    ) -> Result<NoiseModelProblem<'a, T, M>> {
        NoiseModelProblem::new(model, data)
    }
}

impl<'a, T: Real, M: ModelStructure<T>> NoiseModelProblem<'a, T, M> {
    /// Binds `model` and `data` with the concentrated residuals.
    ///
    /// # Errors
    /// As [`WithNoiseModel::check_data`](ModelStructure::check_data) (data without a sample
    /// time, a sample time other than the noise model's, fewer than nc + nd + 1 lines);
    /// [`FdidError::TooFewFrequencies`] when the lines with U_k ≠ 0 give fewer real
    /// equations than the system has parameters.
    pub fn new(model: &'a WithNoiseModel<M>, data: &'a FrequencyData<T>) -> Result<Self> {
        model.check_data(data)?;
        let excited = data.u().iter().filter(|u| u.norm_sqr() > T::zero()).count();
        let p = model.system().n_params();
        if 2 * excited < p {
            return Err(FdidError::TooFewFrequencies {
                lines: excited,
                equations: 2 * excited,
                parameters: p,
            });
        }
        let noise = model.noise::<T>();
        let n = data.len();
        Ok(Self {
            model,
            data,
            noise,
            form: NoiseModelResiduals::Concentrated,
            scratch: RefCell::new(Scratch {
                out: Output::new(n, p),
                h: vec![Complex::new(T::zero(), T::zero()); n],
                dlog: DMatrix::zeros(n, noise.n_params()),
            }),
        })
    }

    /// The same problem with the residuals `form`.
    pub fn with_residuals(mut self, form: NoiseModelResiduals) -> Self {
        self.form = form;
        self
    }

    /// The residuals this problem returns.
    pub fn residuals_form(&self) -> NoiseModelResiduals {
        self.form
    }

    /// The model.
    pub fn model(&self) -> &WithNoiseModel<M> {
        self.model
    }

    /// The data.
    pub fn data(&self) -> &FrequencyData<T> {
        self.data
    }

    /// |Y_k − Ŷ_k|²/|H_k|² and log|H_k|² per line, or `None` when not finite.
    fn terms(&self, theta: &[T]) -> Option<Vec<(T, T)>> {
        let (tg, eta) = self.model.split(theta);
        let mut s = self.scratch.borrow_mut();
        let Scratch { out, h, .. } = &mut *s;
        if !out.evaluate(self.model.system(), tg, self.data, false) {
            return None;
        }
        self.noise.response_into(eta, self.data.omega(), h);
        let t: Vec<(T, T)> = out
            .yhat
            .iter()
            .zip(self.data.y())
            .zip(h.iter())
            .map(|((yh, y), h)| {
                let h2 = h.norm_sqr();
                ((*y - *yh).norm_sqr() / h2, Float::ln(h2))
            })
            .collect();
        t.iter()
            .all(|(a, b)| Float::is_finite(*a) && Float::is_finite(*b))
            .then_some(t)
    }

    /// λ̂(θ) = (1/N) Σ_k |Y_k − Ŷ_k|²/|H_k|² (McKelvey eq. 25); NaN when not finite.
    pub fn lambda_hat(&self, theta: &[T]) -> T {
        self.terms(theta).map_or(T::nan(), |t| {
            t.iter().fold(T::zero(), |s, v| s + v.0) / T::from_usize_lossy(t.len())
        })
    }

    /// The concentrated criterion W(θ) = log λ̂(θ) + (1/N) Σ_k log|H_k|² (McKelvey eq. 26);
    /// NaN when not finite.
    pub fn concentrated_cost(&self, theta: &[T]) -> T {
        self.terms(theta).map_or(T::nan(), |t| {
            let n = T::from_usize_lossy(t.len());
            let (e, l) = t
                .iter()
                .fold((T::zero(), T::zero()), |(e, l), v| (e + v.0, l + v.1));
            Float::ln(e / n) + l / n
        })
    }

    /// The full criterion V(θ, λ) = (1/N) Σ_k [log(|H_k|²λ) + |Y_k − Ŷ_k|²/(|H_k|²λ)]
    /// (McKelvey eq. 23); V(θ, λ̂(θ)) = W(θ) + 1. NaN when not finite or λ ≤ 0.
    pub fn full_cost(&self, theta: &[T], lambda: T) -> T {
        if !(lambda > T::zero()) {
            return T::nan();
        }
        self.terms(theta).map_or(T::nan(), |t| {
            let n = T::from_usize_lossy(t.len());
            t.iter()
                .fold(T::zero(), |s, v| s + Float::ln(lambda) + v.1 + v.0 / lambda)
                / n
        })
    }

    /// Writes the residuals of the chosen form and, when `jac` is given, their Jacobian.
    fn fill(&self, theta: &[T], r: &mut [T], jac: Option<&mut DMatrix<T>>) -> bool {
        let (tg, eta) = self.model.split(theta);
        let (n, p) = (self.data.len(), self.model.system().n_params());
        let mut s = self.scratch.borrow_mut();
        let Scratch { out, h, dlog } = &mut *s;
        let want = jac.is_some();
        let mut finite = out.evaluate(self.model.system(), tg, self.data, want);
        if want {
            self.noise
                .log_jacobian_into(eta, self.data.omega(), h, dlog);
        } else {
            self.noise.response_into(eta, self.data.omega(), h);
        }
        let nf = T::from_usize_lossy(n);
        let g = match self.form {
            NoiseModelResiduals::Concentrated => {
                Float::exp(h.iter().fold(T::zero(), |s, v| s + Float::ln(v.norm())) / nf)
            }
            NoiseModelResiduals::Innovations => T::one(),
        };
        finite &= Float::is_finite(g);
        // the complex residual of line k
        let res: Vec<Complex<T>> = (0..n)
            .map(|k| (self.data.y()[k] - out.yhat[k]) / h[k] * g)
            .collect();
        for (k, v) in res.iter().enumerate() {
            r[2 * k] = v.re;
            r[2 * k + 1] = v.im;
        }
        if let Some(jac) = jac {
            for j in 0..p {
                for k in 0..n {
                    let d = -out.dyhat[(k, j)] / h[k] * g;
                    jac[(2 * k, j)] = d.re;
                    jac[(2 * k + 1, j)] = d.im;
                }
            }
            for i in 0..self.noise.n_params() {
                let dlog_g = match self.form {
                    NoiseModelResiduals::Concentrated => {
                        (0..n).fold(T::zero(), |s, k| s + dlog[(k, i)].re) / nf
                    }
                    NoiseModelResiduals::Innovations => T::zero(),
                };
                for k in 0..n {
                    let d = res[k] * (Complex::new(dlog_g, T::zero()) - dlog[(k, i)]);
                    jac[(2 * k, p + i)] = d.re;
                    jac[(2 * k + 1, p + i)] = d.im;
                }
            }
            finite &= jac.iter().all(|v| Float::is_finite(*v));
        }
        finite && r.iter().all(|v| Float::is_finite(*v))
    }
}

impl<T: Real, M: ModelStructure<T>> NonlinearProblem<T> for NoiseModelProblem<'_, T, M> {
    fn n_params(&self) -> usize {
        self.model.n_params()
    }

    fn n_residuals(&self) -> usize {
        2 * self.data.len()
    }

    fn residuals_into(&self, theta: &[T], r: &mut [T]) -> bool {
        self.fill(theta, r, None)
    }

    fn jacobian_into(&self, theta: &[T], r: &mut [T], jac: &mut DMatrix<T>) -> bool {
        self.fill(theta, r, Some(jac))
    }
}

/// The lines of `data` strictly between ω = 0 and the Nyquist frequency π/Ts: the DFT of
/// a real record is real at those two, so they do not follow the circular complex Gaussian
/// model (22) behind eq. 23, and McKelvey leaves them out.
///
/// # Errors
/// Data without a sample time; no line left.
pub fn interior_lines<T: Real>(data: &FrequencyData<T>) -> Result<FrequencyData<T>> {
    let ts = data.ts().ok_or_else(|| FdidError::InvalidArgument {
        name: "ts",
        value: "none".into(),
        reason: "the Nyquist line needs the data's sample time".into(),
    })?;
    let nyquist = T::pi() / ts;
    let edge = nyquist * (T::one() - T::lit(1e-9));
    let keep: Vec<bool> = data
        .omega()
        .iter()
        .map(|w| *w > T::zero() && *w < edge)
        .collect();
    data.select_lines(&keep)
}
