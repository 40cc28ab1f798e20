//! Maximum likelihood with a parametric noise model H = C/D (McKelvey eqs. 23, 25, 26).

use super::{Criterion, NoiseWeighting};
use crate::data::FrequencyData;
use crate::error::{FdidError, Result};
use crate::fit::{Fit, NoiseLevel, Stage};
use crate::model::{EquationError, ModelStructure, NoiseModel, Output, WithNoiseModel};
use crate::pipeline::{Pipeline, estimate};
use crate::problem::NonlinearProblem;
use crate::solver::LevenbergMarquardt;
use crate::{Complex, Real};
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
/// are allowed: they carry information on H only. [`fit_noise_model`] runs the whole
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
    /// estimate its Jacobian gives the covariance of eqs. 33–34 (see [`fit_noise_model`]).
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

/// Fits `model` with a monic noise model H = C/D of orders `nc`, `nd` to the DFT `data` of
/// a time record by maximum likelihood (McKelvey eq. 26, [`NoiseModelMl`]):
///
/// 1. keeps the [`interior_lines`] (DC and Nyquist dropped);
/// 2. starts G from `pipeline` with flat weighting (H ≡ 1, eq. 25) on the lines with
///    U_k ≠ 0 (its model is used, with the basis the pipeline may have relocated), and H
///    from η = 0 (H = 1);
/// 3. minimises W with Levenberg–Marquardt (`pipeline.ml`, or the default);
/// 4. makes H stable and inversely stable ([`NoiseModel::stabilised`]: W is unchanged) and,
///    if a root was reflected, polishes once more from there;
/// 5. evaluates the statistics with [`Fit::from_problem`] on the innovation residuals
///    r_k = (Y_k − Ŷ_k)/H_k at θ̂ ([`NoiseModelResiduals::Innovations`],
///    [`NoiseLevel::Estimated`]).
///
/// In the result, `noise_variance` is λ̂ = (1/N) Σ|Y_k − Ŷ_k|²/|Ĥ_k|² (eq. 25, the
/// innovation variance per line) and `covariance` is (λ/2)(JᵀJ)⁻¹ of the innovation
/// residuals with λ = V/(N − p/2). Its system block is, to first order, λ̂R⁻¹ with R of
/// eq. 33 weighted by 1/|Ĥ|² (eq. 34 with the noise model estimated: the efficient
/// covariance); the coupling of the system and noise columns, Σ Re(∂Ŷ/H · conj(ε ∂log H)),
/// has mean zero and vanishes relative to the blocks as N grows. The noise block, with
/// columns −ε_k ∂log H_k/∂η (ε the innovations), approximates (1/2)(Σ_k Re ∂log H_k ∂log
/// H_k^*)⁻¹ = (N·mean Re ∂log H ∂log H^*)⁻¹, which on the full DFT grid of a record of N
/// samples is the asymptotic ML (and prediction-error) covariance of the noise
/// parameters. `response_std` is the uncertainty of Ĝ.
///
/// | setting | from | meaning |
/// |---|---|---|
/// | `pipeline.linear`, `pipeline.sk` | `pipeline` | the start for G (weighting forced flat) |
/// | `pipeline.ml` | `pipeline` | the LM of the start and of the noise-model fit (`None`: skip in the start; default LM for the fit) |
///
/// # Errors
/// Data without a sample time, or with no line between DC and Nyquist;
/// [`FdidError::TooFewFrequencies`] when nc + nd + 1 exceeds the number of lines; the
/// errors of the start fit (e.g. too few excited lines for `model`) and of
/// Levenberg–Marquardt.
///
/// ```
/// use fdid::prelude::*;
/// use fdid::criterion::fit_noise_model;
/// // noise-free DFT lines of G(z) = 0.5 / (1 − 0.8 z⁻¹), Ts = 1
/// let n = 64;
/// let omega: Vec<f64> = (0..=n / 2).map(|k| std::f64::consts::TAU * k as f64 / n as f64).collect();
/// let u: Vec<Complex<f64>> = (0..omega.len())
///     .map(|k| Complex::from_polar(1.0, 0.7 * (k * k) as f64))
///     .collect();
/// let y = omega
///     .iter()
///     .zip(&u)
///     .map(|(w, u)| u * 0.5 / (1.0 - 0.8 * Complex::new(0.0, -*w).exp()))
///     .collect();
/// let data = FrequencyData::new(omega, y, u, Some(1.0)).unwrap();
/// let model = Rational::discrete(1, 0, 1.0).unwrap();
/// let fit = fit_noise_model(&Pipeline::default(), &model, &data, 1, 1).unwrap();
/// assert!((fit.theta()[0] + 0.8).abs() < 1e-9 && (fit.theta()[1] - 0.5).abs() < 1e-9);
/// assert_eq!(fit.theta().len(), 4); // [a₁, b₀, c₁, d₁]
/// ```
pub fn fit_noise_model<T: Real, M: EquationError<T> + Clone>(
    pipeline: &Pipeline,
    model: &M,
    data: &FrequencyData<T>,
    nc: usize,
    nd: usize,
) -> Result<Fit<T, WithNoiseModel<M>>> {
    let ts = data.ts().ok_or_else(|| FdidError::InvalidArgument {
        name: "ts",
        value: "none".into(),
        reason: "a noise model H(z) is discrete time: the data need a sample time".into(),
    })?;
    let noise = NoiseModel::new(nc, nd, ts)?;
    let data = interior_lines(data)?;
    if data.len() < nc + nd + 1 {
        return Err(FdidError::TooFewFrequencies {
            lines: data.len(),
            equations: data.len(),
            parameters: nc + nd + 1,
        });
    }
    let excited: Vec<bool> = data.u().iter().map(|u| u.norm_sqr() > T::zero()).collect();
    let start_fit = {
        let flat = Pipeline {
            weighting: NoiseWeighting::Flat,
            ..*pipeline
        };
        let start_data = data.select_lines(&excited)?.without_noise();
        flat.fit(model, &start_data)?
    };
    refine_noise_model(&start_fit, &data, noise, &pipeline.ml.unwrap_or_default())
}

/// The noise-model stage of [`fit_noise_model`] for any model structure: from a fitted
/// system model `start` (e.g. a [`crate::model::Delayed`] fit), ML on the concentrated
/// criterion (26) over [θ_G, η] from [θ̂_G, 0] with Levenberg–Marquardt; H is then made
/// stable and inversely stable ([`NoiseModel::stabilised`], which leaves the criterion
/// unchanged) and polished once more when a root was reflected; the statistics come from
/// the innovations (Y − Ŷ)/H with λ estimated. `data` should hold the interior lines
/// ([`interior_lines`]).
///
/// # Errors
/// As [`NoiseModelProblem::new`] and the solver.
pub fn refine_noise_model<T: Real, M: ModelStructure<T> + Clone>(
    start: &Fit<T, M>,
    data: &FrequencyData<T>,
    noise: NoiseModel<T>,
    lm: &LevenbergMarquardt,
) -> Result<Fit<T, WithNoiseModel<M>>> {
    let mut stages = start.stages().to_vec();
    let full = WithNoiseModel::new(start.model().clone(), noise);
    let p = start.model().n_params();
    let mut theta = start.theta().to_vec();
    theta.extend(std::iter::repeat_n(T::zero(), noise.n_params()));
    let sol = estimate(&full, data, &NoiseModelMl, lm, Some(&theta))?;
    theta = sol.theta.clone();
    stages.push(Stage {
        name: "noise-model ml".into(),
        solution: sol,
    });
    let stabilise = |theta: &mut Vec<T>| -> Result<bool> {
        let eta = noise.stabilised(&theta[p..])?;
        let changed = eta != theta[p..];
        theta.truncate(p);
        theta.extend(eta);
        Ok(changed)
    };
    if stabilise(&mut theta)? {
        let sol = estimate(&full, data, &NoiseModelMl, lm, Some(&theta))?;
        theta = sol.theta.clone();
        stages.push(Stage {
            name: "noise-model ml (H stabilised)".into(),
            solution: sol,
        });
        stabilise(&mut theta)?;
    }
    let problem =
        NoiseModelProblem::new(&full, data)?.with_residuals(NoiseModelResiduals::Innovations);
    Fit::from_problem(
        full.clone(),
        data,
        theta,
        &problem,
        NoiseLevel::Estimated,
        stages,
    )
}
