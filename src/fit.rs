//! The result of an estimation: θ̂ with its cost, noise level, covariance and the
//! uncertainty of the fitted frequency response.

use crate::criterion::{MlProblem, NoiseWeighting};
use crate::data::{FrequencyData, Normalisation};
use crate::error::Result;
use crate::model::{ModelStructure, PolesZeros};
use crate::problem::NonlinearProblem;
use crate::scalar::{Complex, Real};
use crate::solver::Solution;
use crate::validation::Validation;
use nalgebra::DMatrix;
use num_traits::Float;

/// What one stage of an estimation did.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Stage<T: Real> {
    /// The kind of stage (serialised as its name, e.g. `"levy"`).
    #[cfg_attr(feature = "serde", serde(rename = "name"))]
    pub kind: StageKind,
    /// The solver's outcome.
    pub solution: Solution<T>,
    /// The number of lines the stage was solved on when fewer than the data's (the linear
    /// stages of a long record, which only start ML: see [`crate::Pipeline`]'s
    /// `start_lines`); its cost is then the criterion's on those lines. `None`: all lines.
    #[cfg_attr(
        feature = "serde",
        serde(default, skip_serializing_if = "Option::is_none")
    )]
    pub lines: Option<usize>,
}

impl<T: Real> Stage<T> {
    /// A stage solved on all the data's lines.
    pub fn new(kind: StageKind, solution: Solution<T>) -> Self {
        Self {
            kind,
            solution,
            lines: None,
        }
    }
}

/// The kinds of estimation stage, named in reports by [`StageKind::name`].
#[derive(Debug, Clone, PartialEq, Eq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(into = "String", try_from = "String")
)]
pub enum StageKind {
    /// Levy's linear least squares (`levy`, McKelvey eq. 39).
    Levy,
    /// Sanathanan–Koerner iterations or pole relocation (`sk`, eq. 41).
    Sk,
    /// Output-error maximum likelihood (`ml`, eq. 23).
    Ml,
    /// Total least squares (`tls`).
    Tls,
    /// Errors-in-variables maximum likelihood (`eiv`, eq. 42).
    Eiv,
    /// The starting-delay search (`delay`; θ = \[τ₀\]).
    Delay,
    /// ML of the delayed model (`ml-delayed`).
    MlDelayed,
    /// ML polishing the best start of a multistart search (`ml-polish`).
    MlPolish,
    /// ML after replacing spurious poles (`ml-replaced`).
    MlReplaced,
    /// ML from a reduced higher-order fit (`ml-reduced`).
    MlReduced,
    /// ML from log-spread starting poles (`ml-spread`).
    MlSpread,
    /// ML after moving one pole (pair) of the best fit elsewhere (`ml-relocated`).
    MlRelocated,
    /// The least-squares residues of a modal start (`modal ls`).
    ModalLs,
    /// The least-squares numerator over given starting poles (`poles ls`).
    PolesLs,
    /// ML with a noise model (`noise-model ml`, eq. 26).
    NoiseModelMl,
    /// The noise-model ML after H was made stable (`noise-model ml (H stabilised)`).
    NoiseModelStabilised,
    /// A stage of the rational fit that started a modal fit (`rational ml`, …).
    RationalStart(Box<StageKind>),
}

impl StageKind {
    /// The name reports use (`levy`, `sk`, `ml`, `ml-delayed`, `rational ml`, …).
    pub fn name(&self) -> String {
        let plain = match self {
            StageKind::Levy => "levy",
            StageKind::Sk => "sk",
            StageKind::Ml => "ml",
            StageKind::Tls => "tls",
            StageKind::Eiv => "eiv",
            StageKind::Delay => "delay",
            StageKind::MlDelayed => "ml-delayed",
            StageKind::MlPolish => "ml-polish",
            StageKind::MlReplaced => "ml-replaced",
            StageKind::MlReduced => "ml-reduced",
            StageKind::MlSpread => "ml-spread",
            StageKind::MlRelocated => "ml-relocated",
            StageKind::ModalLs => "modal ls",
            StageKind::PolesLs => "poles ls",
            StageKind::NoiseModelMl => "noise-model ml",
            StageKind::NoiseModelStabilised => "noise-model ml (H stabilised)",
            StageKind::RationalStart(inner) => return format!("rational {}", inner.name()),
        };
        plain.to_string()
    }

    /// The kind named `name` ([`StageKind::name`]'s inverse), `None` for an unknown name.
    pub fn from_name(name: &str) -> Option<Self> {
        if let Some(inner) = name.strip_prefix("rational ") {
            return Self::from_name(inner).map(|k| StageKind::RationalStart(Box::new(k)));
        }
        Some(match name {
            "levy" => StageKind::Levy,
            "sk" => StageKind::Sk,
            "ml" => StageKind::Ml,
            "tls" => StageKind::Tls,
            "eiv" => StageKind::Eiv,
            "delay" => StageKind::Delay,
            "ml-delayed" => StageKind::MlDelayed,
            "ml-polish" => StageKind::MlPolish,
            "ml-replaced" => StageKind::MlReplaced,
            "ml-reduced" => StageKind::MlReduced,
            "ml-spread" => StageKind::MlSpread,
            "ml-relocated" => StageKind::MlRelocated,
            "modal ls" => StageKind::ModalLs,
            "poles ls" => StageKind::PolesLs,
            "noise-model ml" => StageKind::NoiseModelMl,
            "noise-model ml (H stabilised)" => StageKind::NoiseModelStabilised,
            _ => return None,
        })
    }
}

impl std::fmt::Display for StageKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.name())
    }
}

impl From<StageKind> for String {
    fn from(kind: StageKind) -> Self {
        kind.name()
    }
}

impl TryFrom<String> for StageKind {
    type Error = String;

    fn try_from(name: String) -> std::result::Result<Self, String> {
        StageKind::from_name(&name).ok_or_else(|| format!("unknown stage {name:?}"))
    }
}

/// A fitted model with its statistics, all evaluated with the normalised residuals r_k of
/// a criterion at θ̂: for [`Fit::new`] the output-error (ML) residuals
/// r_k = (Y_k − Ŷ_k)/σ_k, Ŷ = G_θ̂ U + T_θ̂ (σ_k = 1 when the data carry no noise
/// variances); for [`Fit::from_problem`] those of the given problem (e.g. errors in
/// variables, or (Y − Ŷ)/Ĥ with an estimated noise model).
///
/// - `cost` V = Σ_k |r_k|² (McKelvey eq. 23 without the constant log term);
/// - `noise_variance` λ̂ = V/N (eq. 25);
/// - `covariance` of θ̂: with J the Jacobian of the real-stacked residuals,
///   Cov θ̂ = (λ/2)(JᵀJ)⁻¹ — the asymptotic covariance of eqs. 32–34 for circular complex
///   noise of variance λ, whose real and imaginary parts each have variance λ/2. λ = 1 when
///   the data carry their noise variances, else the degrees-of-freedom corrected
///   λ̂ = V/(N − p/2);
/// - `response_std` σ_G(ω_k)² = Σ_ij Cov_ij Re(∂G_k/∂θ_i · conj ∂G_k/∂θ_j), with the
///   standard deviations of |Ĝ| and ∠Ĝ and confidence [`Fit::bounds`];
/// - `robust_covariance`: the sandwich R⁻¹QR⁻¹ of eqs. 32–34, valid when the criterion's
///   noise model is wrong;
/// - `validation`: the cost against its expected value and the whiteness of r across
///   frequency ([`crate::validation::Validation`]).
///
/// The covariance is the ML one: for Levy or SK estimates it describes what ML would
/// achieve, not their own (larger, biased) error.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Fit<T: Real, M> {
    model: M,
    theta: Vec<T>,
    omega: Vec<T>,
    response: Vec<Complex<T>>,
    cost: T,
    noise_variance: T,
    noise_known: bool,
    covariance: Option<DMatrix<T>>,
    /// F with Cov θ̂ = F Fᵀ.
    #[cfg_attr(feature = "serde", serde(default))]
    covariance_factor: Option<DMatrix<T>>,
    robust_covariance: Option<DMatrix<T>>,
    /// The standard deviations of the response, computed when first asked for.
    #[cfg_attr(feature = "serde", serde(skip))]
    response_std: std::sync::OnceLock<Option<ResponseStd<T>>>,
    residuals: Vec<Complex<T>>,
    validation: Validation,
    stages: Vec<Stage<T>>,
}

impl<T: Real, M: ModelStructure<T>> Fit<T, M> {
    /// Evaluates the statistics of `theta` for `model` on `data` with the output-error
    /// (ML, fixed noise model) residuals of [`MlProblem`].
    ///
    /// # Errors
    /// As [`MlProblem::new`]; non-finite model response at θ.
    pub fn new(
        model: M,
        data: &FrequencyData<T>,
        theta: Vec<T>,
        weighting: NoiseWeighting,
        stages: Vec<Stage<T>>,
    ) -> Result<Self> {
        let problem = MlProblem::new(&model, data, weighting)?;
        let parts = Self::ml_blocks(&problem, &theta);
        drop(problem);
        match parts {
            Some(parts) => Ok(Self::assemble(model, data, theta, parts, stages)),
            None => {
                let problem = MlProblem::new(&model, data, weighting)?;
                let (r, jac, level, response) = Self::ml_statistics_input(&problem, &theta)?;
                drop(problem);
                Self::from_residuals(model, data, theta, r, jac, level, stages, response)
            }
        }
    }

    /// [`Fit::new`] with the [`MlProblem`] the estimate was solved with (its work space,
    /// already allocated, is reused); `problem` must be bound to a model equal to `model`
    /// and to `data`.
    pub(crate) fn from_ml_problem<Mp: ModelStructure<T> + ?Sized>(
        model: M,
        data: &FrequencyData<T>,
        theta: Vec<T>,
        problem: &MlProblem<'_, T, Mp>,
        stages: Vec<Stage<T>>,
    ) -> Result<Self> {
        if let Some(parts) = Self::ml_blocks(problem, &theta) {
            return Ok(Self::assemble(model, data, theta, parts, stages));
        }
        let (r, jac, level, response) = Self::ml_statistics_input(problem, &theta)?;
        Self::from_residuals(model, data, theta, r, jac, level, stages, response)
    }

    /// The statistics of an ML problem at θ without any N × p matrix, over blocks of lines
    /// ([`MlProblem::for_each_block`]): r and G first (reusing the problem's last
    /// evaluation when it was at θ, as after a solver's last step), then in one pass of
    /// Jacobian blocks both JᵀJ and the sandwich's JᵀD²J (D from the residuals); the
    /// covariance from the equilibrated Gram matrix when it is accepted (see
    /// [`covariance_factors`]). `None` for small problems (N·p ≤ 8 192, whose N × p
    /// matrices stay in cache), when anything is not finite or when the Gram matrix is
    /// refused: then the caller takes the path of [`Fit::from_residuals`] (the full J, its
    /// QR/SVD when needed, typed errors).
    fn ml_blocks<Mp: ModelStructure<T> + ?Sized>(
        problem: &MlProblem<'_, T, Mp>,
        theta: &[T],
    ) -> Option<Parts<T>> {
        use crate::linalg::gram::{gram_into, max_condition, scaled_cholesky};
        let (n, p) = (problem.data().len(), problem.n_params());
        let level = if problem.weights().is_some() {
            NoiseLevel::Known
        } else {
            NoiseLevel::Estimated
        };
        if p == 0 || 2 * n < p || crate::linalg::gram::small_problem(n, p) {
            return None;
        }
        let mut r = vec![Complex::new(T::zero(), T::zero()); n];
        if !problem.residuals_at(theta, crate::scalar::interleaved_mut(&mut r)) {
            return None;
        }
        let head = Head::new(n, p, r, level).ok()?;
        let d: Vec<T> = local_half_power(&head.residuals)
            .into_iter()
            .map(Float::sqrt)
            .collect();
        // JᵀJ and Q = (DJ)ᵀ(DJ) from the same blocks (J scaled in place after the first)
        let mut g = DMatrix::zeros(p, p);
        let mut q = DMatrix::zeros(p, p);
        let finite = problem.for_each_block(theta, true, |k0, _, jac| {
            gram_into(jac, &mut g, true);
            let len = jac.nrows() / 2;
            for col in jac.as_mut_slice().chunks_exact_mut(2 * len) {
                for (c, dk) in col.chunks_exact_mut(2).zip(&d[k0..k0 + len]) {
                    c[0] *= *dk;
                    c[1] *= *dk;
                }
            }
            gram_into(jac, &mut q, true);
        });
        if !finite {
            return None;
        }
        let sc = scaled_cholesky(&g, max_condition::<T>())?;
        let linv = sc
            .chol
            .l()
            .solve_lower_triangular(&DMatrix::identity(p, p))?;
        let f0 = DMatrix::from_fn(p, p, |i, k| linv[(k, i)] / sc.d[i]);
        if !f0.iter().all(|v| Float::is_finite(*v)) {
            return None;
        }
        let factor = head.lambda.map(|l| &f0 * Float::sqrt(l / T::lit(2.0)));
        let c0 = &f0 * f0.transpose();
        let robust = &c0 * &q * &c0;
        // G from the problem's evaluation at θ (the Jacobian blocks do not touch it)
        let response = problem.take_response(theta)?;
        Some(Parts {
            head,
            factor,
            robust_covariance: Some(robust),
            response,
        })
    }

    /// The fit from its statistics.
    fn assemble(
        model: M,
        data: &FrequencyData<T>,
        theta: Vec<T>,
        parts: Parts<T>,
        stages: Vec<Stage<T>>,
    ) -> Self {
        let Parts {
            head,
            factor,
            robust_covariance,
            response,
        } = parts;
        let validation = Validation::new(
            &head.residuals,
            model.n_params(),
            head.noise_known,
            data.variance_dof(),
        );
        Self {
            model,
            theta,
            omega: data.omega().to_vec(),
            response,
            cost: head.cost,
            noise_variance: head.noise_variance,
            noise_known: head.noise_known,
            covariance: factor.as_ref().map(|f| f * f.transpose()),
            covariance_factor: factor,
            robust_covariance,
            response_std: std::sync::OnceLock::new(),
            residuals: head.residuals,
            validation,
            stages,
        }
    }

    /// r, J, the noise level and G of an ML problem at θ.
    #[allow(clippy::type_complexity)] // a private tuple of the four inputs
    fn ml_statistics_input<Mp: ModelStructure<T> + ?Sized>(
        problem: &MlProblem<'_, T, Mp>,
        theta: &[T],
    ) -> Result<(Vec<T>, DMatrix<T>, NoiseLevel, Option<Vec<Complex<T>>>)> {
        let level = if problem.weights().is_some() {
            NoiseLevel::Known
        } else {
            NoiseLevel::Estimated
        };
        let (r, jac) = residuals_and_jacobian(problem, theta)?;
        let response = problem
            .take_response(theta)
            .filter(|g| g.len() == problem.data().len());
        Ok((r, jac, level, response))
    }

    /// Evaluates the statistics of `theta` with the normalised residuals of any
    /// criterion's [`NonlinearProblem`] (e.g. errors-in-variables or ML with a noise model):
    /// r(θ̂) and J = ∂r/∂θ at θ̂, real-stacked line by line (2N rows).
    ///
    /// # Errors
    /// Non-finite residuals, Jacobian or model response at θ; a problem whose residual
    /// count is not 2N.
    pub fn from_problem<P: NonlinearProblem<T> + ?Sized>(
        model: M,
        data: &FrequencyData<T>,
        theta: Vec<T>,
        problem: &P,
        level: NoiseLevel,
        stages: Vec<Stage<T>>,
    ) -> Result<Self> {
        if problem.n_residuals() != 2 * data.len() || problem.n_params() != model.n_params() {
            return Err(crate::error::FdidError::InvalidArgument {
                name: "problem",
                value: format!(
                    "{} residuals, {} parameters",
                    problem.n_residuals(),
                    problem.n_params()
                ),
                reason: format!(
                    "expected 2N = {} residuals and the model's {} parameters",
                    2 * data.len(),
                    model.n_params()
                ),
            });
        }
        let (r, jac) = residuals_and_jacobian(problem, &theta)?;
        Self::from_residuals(model, data, theta, r, jac, level, stages, None)
    }

    /// `response`: G at θ on the data lines when the caller has it.
    #[allow(clippy::too_many_arguments)]
    fn from_residuals(
        model: M,
        data: &FrequencyData<T>,
        theta: Vec<T>,
        r: Vec<T>,
        jac: DMatrix<T>,
        level: NoiseLevel,
        stages: Vec<Stage<T>>,
        response: Option<Vec<Complex<T>>>,
    ) -> Result<Self> {
        let (n, p) = (data.len(), model.n_params());
        let residuals = r.chunks(2).map(|c| Complex::new(c[0], c[1])).collect();
        let head = Head::new(n, p, residuals, level)?;
        // (JᵀJ)⁻¹ = F₀F₀ᵀ from the QR/SVD of J; Cov = (λ/2)(JᵀJ)⁻¹ = F Fᵀ, F = √(λ/2) F₀
        let (base, robust_covariance) = covariance_factors(jac, &head.residuals);
        let factor = head
            .lambda
            .and_then(|l| base.map(|f| f * Float::sqrt(l / T::lit(2.0))));
        let response = response.unwrap_or_else(|| {
            let mut response = vec![Complex::new(T::zero(), T::zero()); n];
            model.response_into(&theta, data.omega(), &mut response);
            response
        });
        let parts = Parts {
            head,
            factor,
            robust_covariance,
            response,
        };
        Ok(Self::assemble(model, data, theta, parts, stages))
    }

    /// The fit to data normalised by `n` ([`Normalisation::apply`]) mapped back to the data
    /// as given: θ_j = d_j·θ′_j with d from [`ModelStructure::normalisation_map`],
    /// Cov θ̂ = D Cov θ̂′ D, G = (c_u/c_y)·G′; without the data's noise variances the
    /// residuals scale by 1/c_y and the cost and λ̂ by 1/c_y² (with them, the normalised
    /// residuals are the same). The stages' θ are mapped by the leading entries of d (the
    /// start of a delayed or noise-model fit is its undelayed system) and their costs by
    /// 1/c_y² (exact for the output-error and equation-error stages).
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`](crate::FdidError::InvalidArgument) when the model has no
    /// normalisation map; [`FdidError::Numerical`](crate::FdidError::Numerical) when a mapped
    /// parameter is not finite (a gain beyond the type's range).
    pub fn denormalised(mut self, n: &Normalisation<T>) -> Result<Self> {
        if n.is_identity() {
            return Ok(self);
        }
        let d = self
            .model
            .normalisation_map(n.output(), n.input())
            .ok_or_else(|| crate::error::FdidError::InvalidArgument {
                name: "model",
                value: "a model structure without a normalisation map".into(),
                reason: "its parameters cannot be mapped back from normalised data".into(),
            })?;
        let residual = n.residual_scale(self.noise_known);
        let cost = n.cost_scale(self.noise_known);
        denormalise_theta(&mut self.theta, &d);
        if let Some(bad) = self.theta.iter().position(|t| !Float::is_finite(*t)) {
            return Err(crate::error::FdidError::Numerical {
                what: format!(
                    "parameter {bad} of the fit is beyond the range of the number type once \
                     mapped back to the data's units"
                ),
            });
        }
        let dm = DMatrix::from_diagonal(&nalgebra::DVector::from_column_slice(&d));
        let sandwich = |c: &DMatrix<T>| &dm * c * &dm;
        self.covariance = self.covariance.as_ref().map(sandwich);
        self.robust_covariance = self.robust_covariance.as_ref().map(sandwich);
        self.covariance_factor = self.covariance_factor.as_ref().map(|f| &dm * f);
        self.response_std = std::sync::OnceLock::new();
        let gain = n.input() / n.output();
        for g in &mut self.response {
            *g = g.scale(gain);
        }
        for r in &mut self.residuals {
            *r = r.scale(residual);
        }
        self.cost *= cost;
        self.noise_variance *= cost;
        denormalise_stages(&mut self.stages, &d, cost);
        Ok(self)
    }

    /// The model structure.
    pub fn model(&self) -> &M {
        &self.model
    }

    /// The estimate θ̂.
    pub fn theta(&self) -> &[T] {
        &self.theta
    }

    /// The frequencies (rad/s) of the data fitted.
    pub fn omega(&self) -> &[T] {
        &self.omega
    }

    /// The fitted response G(θ̂, ω_k) at the data frequencies.
    pub fn response(&self) -> &[Complex<T>] {
        &self.response
    }

    /// The fitted response at other frequencies (rad/s).
    pub fn response_at(&self, omega: &[T]) -> Vec<Complex<T>> {
        self.model.response(&self.theta, omega)
    }

    /// V(θ̂) = Σ |r_k|².
    pub fn cost(&self) -> T {
        self.cost
    }

    /// λ̂ = V(θ̂)/N (McKelvey eq. 25): the residual variance per line (≈ 1 when the data
    /// carry correct noise variances).
    pub fn noise_variance(&self) -> T {
        self.noise_variance
    }

    /// True when the statistics use the data's noise variances (λ = 1).
    pub fn noise_known(&self) -> bool {
        self.noise_known
    }

    /// Covariance of θ̂, `None` when JᵀJ is singular or there are no degrees of freedom.
    pub fn covariance(&self) -> Option<&DMatrix<T>> {
        self.covariance.as_ref()
    }

    /// Standard deviations of θ̂ (from the rows of the covariance factor when there is one,
    /// each scaled by a power of two, so that they stay finite where the variances would
    /// not: a gain near the type's limits).
    pub fn theta_std(&self) -> Option<Vec<T>> {
        if let Some(f) = &self.covariance_factor {
            return Some(
                f.row_iter()
                    .map(|row| {
                        let c = crate::data::power_of_two_factor(row.iter().copied());
                        Float::sqrt(row.iter().fold(T::zero(), |s, v| s + (*v * c) * (*v * c))) / c
                    })
                    .collect(),
            );
        }
        self.covariance.as_ref().map(|c| {
            (0..c.nrows())
                .map(|i| Float::sqrt(Float::max(c[(i, i)], T::zero())))
                .collect()
        })
    }

    /// Standard deviation of Ĝ at each data frequency: σ_G(ω_k)² = E|Ĝ_k − G_k|² =
    /// Σ_ij Cov_ij Re(∂G_k/∂θ_i · conj ∂G_k/∂θ_j).
    ///
    /// Computed on the first call of this method, [`Fit::magnitude_std`],
    /// [`Fit::phase_std`] or [`Fit::bounds`] (one evaluation of ∂G/∂θ on the data lines).
    pub fn response_std(&self) -> Option<&[T]> {
        self.std_of_response().map(|s| s.complex.as_slice())
    }

    /// The [`ResponseStd`] of the fit, computed on first use: ∂G/∂θ at θ̂ on blocks of
    /// the data lines, through the covariance factor.
    fn std_of_response(&self) -> Option<&ResponseStd<T>> {
        self.response_std
            .get_or_init(|| {
                let f = self.covariance_factor.as_ref()?;
                let (n, p) = (self.omega.len(), f.ncols());
                let mut blocks = ResponseStdBlocks::new(n, p);
                let mut g = vec![Complex::new(T::zero(), T::zero()); RESPONSE_BLOCK.min(n)];
                let mut dg = DMatrix::zeros(0, p);
                for k0 in (0..n).step_by(RESPONSE_BLOCK) {
                    let len = RESPONSE_BLOCK.min(n - k0);
                    if dg.nrows() != len {
                        dg = DMatrix::zeros(len, p);
                        g.resize(len, Complex::new(T::zero(), T::zero()));
                    }
                    let lines = k0..k0 + len;
                    self.model.jacobian_into(
                        &self.theta,
                        &self.omega[lines.clone()],
                        &mut g,
                        &mut dg,
                    );
                    blocks.push_block(&dg, 0, &self.response[lines], f);
                }
                Some(blocks.out)
            })
            .as_ref()
    }

    /// Standard deviation of |Ĝ| at each data frequency (first order: the component of
    /// δG along G).
    pub fn magnitude_std(&self) -> Option<&[T]> {
        self.std_of_response().map(|s| s.magnitude.as_slice())
    }

    /// Standard deviation of the phase ∠Ĝ (rad) at each data frequency (first order:
    /// Im(δG/G)).
    pub fn phase_std(&self) -> Option<&[T]> {
        self.std_of_response().map(|s| s.phase.as_slice())
    }

    /// Pointwise confidence bounds at `level` (e.g. 0.95) on |G| and on its phase at each
    /// data frequency, from the first-order standard deviations and the normal quantile
    /// z = Φ⁻¹((1 + level)/2). `None` without a covariance or for `level` outside (0, 1).
    pub fn bounds(&self, level: f64) -> Option<Vec<Bounds<T>>> {
        let s = self.std_of_response()?;
        if !(level > 0.0 && level < 1.0) {
            return None;
        }
        let z = T::lit(crate::stats::normal_quantile(0.5 + level / 2.0));
        Some(
            self.response
                .iter()
                .enumerate()
                .map(|(k, g)| {
                    let (m, ph) = (g.norm(), g.arg());
                    Bounds {
                        magnitude: (
                            Float::max(m - z * s.magnitude[k], T::zero()),
                            m + z * s.magnitude[k],
                        ),
                        phase: (ph - z * s.phase[k], ph + z * s.phase[k]),
                    }
                })
                .collect(),
        )
    }

    /// The sandwich covariance R⁻¹QR⁻¹ of McKelvey eqs. 32–34 with R = JᵀJ and
    /// Q = Σ_k J_kᵀJ_k ŝ_k/2, ŝ_k the residual power |r_k|² averaged over the nine nearest
    /// lines: valid when the noise model of the criterion is wrong (e.g. flat weighting of
    /// coloured noise), where [`Fit::covariance`] is not. Equals it asymptotically when the
    /// noise model is right. `None` when J is rank deficient.
    pub fn robust_covariance(&self) -> Option<&DMatrix<T>> {
        self.robust_covariance.as_ref()
    }

    /// The normalised residuals r_k = (Y_k − Ŷ_k)/σ_k of the criterion at θ̂, one per line.
    pub fn residuals(&self) -> &[Complex<T>] {
        &self.residuals
    }

    /// Validation statistics: cost against its expected value, whiteness of the residuals.
    pub fn validation(&self) -> &Validation {
        &self.validation
    }

    /// What each stage did, in order.
    pub fn stages(&self) -> &[Stage<T>] {
        &self.stages
    }
}

impl<T: Real, M: ModelStructure<T> + PolesZeros<T>> Fit<T, M> {
    /// Poles of the fitted model.
    ///
    /// # Errors
    /// As [`PolesZeros::poles`].
    pub fn poles(&self) -> Result<Vec<Complex<T>>> {
        self.model.poles(&self.theta)
    }

    /// Zeros of the fitted model.
    ///
    /// # Errors
    /// As [`PolesZeros::zeros`].
    pub fn zeros(&self) -> Result<Vec<Complex<T>>> {
        self.model.zeros(&self.theta)
    }

    /// Gain of the factored form.
    pub fn gain(&self) -> T {
        self.model.gain(&self.theta)
    }
}

/// The cost and noise level of a fit from its residuals.
struct Head<T: Real> {
    cost: T,
    noise_variance: T,
    noise_known: bool,
    /// λ of the covariance (`None`: no degrees of freedom).
    lambda: Option<T>,
    residuals: Vec<Complex<T>>,
}

impl<T: Real> Head<T> {
    /// V = ‖r‖², λ̂ = V/N, and λ = 1 (noise known) or V/(N − p/2) for `n` lines and `p`
    /// parameters.
    ///
    /// # Errors
    /// A cost that is not finite.
    fn new(n: usize, p: usize, residuals: Vec<Complex<T>>, level: NoiseLevel) -> Result<Self> {
        let cost = residuals
            .iter()
            .fold(T::zero(), |s, v| s + v.re * v.re + v.im * v.im);
        if !Float::is_finite(cost) {
            return Err(crate::error::FdidError::Numerical {
                what: format!(
                    "the fit's cost is not finite ({}): the data are too large for this precision; scale them",
                    cost.to_f64_lossless()
                ),
            });
        }
        let nf = T::from_usize_lossy(n);
        let noise_known = level == NoiseLevel::Known;
        let dof = nf - T::from_usize_lossy(p) / T::lit(2.0);
        let lambda = if noise_known {
            Some(T::one())
        } else if dof > T::zero() {
            Some(cost / dof)
        } else {
            None
        };
        Ok(Self {
            cost,
            noise_variance: cost / nf,
            noise_known,
            lambda,
            residuals,
        })
    }
}

/// Everything of a [`Fit`] but the model, θ and the stages.
struct Parts<T: Real> {
    head: Head<T>,
    /// F with Cov θ̂ = F Fᵀ.
    factor: Option<DMatrix<T>>,
    robust_covariance: Option<DMatrix<T>>,
    response: Vec<Complex<T>>,
}

/// Pointwise confidence bounds of one line (see [`Fit::bounds`]).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Bounds<T: Real> {
    /// Lower and upper bound on |G|.
    pub magnitude: (T, T),
    /// Lower and upper bound on the phase (rad).
    pub phase: (T, T),
}

/// First-order standard deviations of Ĝ, |Ĝ| and ∠Ĝ on the data lines.
#[derive(Debug, Clone)]
struct ResponseStd<T: Real> {
    complex: Vec<T>,
    magnitude: Vec<T>,
    phase: Vec<T>,
}

/// Lines per block of the response's standard deviations.
const RESPONSE_BLOCK: usize = 256;

/// [`ResponseStd`] built block of lines by block of lines, with the buffers of the two
/// real products.
struct ResponseStdBlocks<T: Real> {
    out: ResponseStd<T>,
    bre: DMatrix<T>,
    bim: DMatrix<T>,
    are: DMatrix<T>,
    aim: DMatrix<T>,
}

impl<T: Real> ResponseStdBlocks<T> {
    fn new(lines: usize, p: usize) -> Self {
        let z = || DMatrix::zeros(0, p);
        Self {
            out: ResponseStd {
                complex: Vec::with_capacity(lines),
                magnitude: Vec::with_capacity(lines),
                phase: Vec::with_capacity(lines),
            },
            bre: z(),
            bim: z(),
            are: z(),
            aim: z(),
        }
    }

    /// Appends the lines of `g` (G on them, at most [`RESPONSE_BLOCK`]), whose ∂G/∂θ are
    /// the rows k0 … k0 + g.len() − 1 of `dg`: with a_k = (∂G_k/∂θ)F for a covariance
    /// factor F (Cov = F Fᵀ), σ_G² = ‖a_k‖², σ_|G| = ‖Re(conj(G_k) a_k)‖/|G_k|,
    /// σ_∠G = ‖Im(a_k/G_k)‖, through two real products (the real gemm is much faster than
    /// the complex one) in small reused buffers.
    fn push_block(
        &mut self,
        dg: &DMatrix<Complex<T>>,
        k0: usize,
        g: &[Complex<T>],
        f: &DMatrix<T>,
    ) {
        let (len, p) = (g.len(), f.ncols());
        for m in [&mut self.bre, &mut self.bim, &mut self.are, &mut self.aim] {
            if m.shape() != (len, p) {
                *m = DMatrix::zeros(len, p);
            }
        }
        for j in 0..p {
            for i in 0..len {
                let v = dg[(k0 + i, j)];
                self.bre[(i, j)] = v.re;
                self.bim[(i, j)] = v.im;
            }
        }
        self.are.gemm(T::one(), &self.bre, f, T::zero());
        self.aim.gemm(T::one(), &self.bim, f, T::zero());
        let out = &mut self.out;
        for (i, gk) in g.iter().enumerate() {
            let (mut c, mut m, mut ph) = (T::zero(), T::zero(), T::zero());
            let mag2 = gk.norm_sqr();
            for j in 0..p {
                let (x, y) = (self.are[(i, j)], self.aim[(i, j)]);
                c += x * x + y * y;
                let dm = gk.re * x + gk.im * y;
                let dp = gk.re * y - gk.im * x;
                m += dm * dm;
                ph += dp * dp;
            }
            out.complex.push(Float::sqrt(c));
            if mag2 > T::zero() {
                out.magnitude.push(Float::sqrt(m / mag2));
                out.phase.push(Float::sqrt(ph) / mag2);
            } else {
                out.magnitude.push(Float::sqrt(c));
                out.phase.push(T::infinity());
            }
        }
    }
}

/// R⁻¹QR⁻¹ = F₀(MᵀM)F₀ᵀ with M = D J F₀, D² = ŝ_k/2 on both rows of line k, ŝ_k the mean
/// of |r_j|² over the nine lines nearest k.
fn sandwich<T: Real>(jac: &DMatrix<T>, f0: &DMatrix<T>, r: &[Complex<T>]) -> DMatrix<T> {
    let d2 = local_half_power(r);
    let mut m = jac * f0;
    for (k, s) in d2.iter().enumerate() {
        let d = Float::sqrt(*s);
        for row in [2 * k, 2 * k + 1] {
            m.row_mut(row).scale_mut(d);
        }
    }
    let inner = m.transpose() * m;
    f0 * inner * f0.transpose()
}

/// Whether the residuals are normalised by the true noise level.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum NoiseLevel {
    /// The residuals are divided by their noise standard deviations (λ = 1).
    Known,
    /// The noise level is unknown: λ̂ = V/(N − p/2).
    Estimated,
}

/// r(θ) and ∂r/∂θ of a problem, failing when not finite.
fn residuals_and_jacobian<T: Real, P: NonlinearProblem<T> + ?Sized>(
    problem: &P,
    theta: &[T],
) -> Result<(Vec<T>, DMatrix<T>)> {
    let mut r = vec![T::zero(); problem.n_residuals()];
    let mut jac = DMatrix::zeros(problem.n_residuals(), problem.n_params());
    if !problem.jacobian_into(theta, &mut r, &mut jac) {
        return Err(crate::error::FdidError::Numerical {
            what: "model response or Jacobian at the estimate".into(),
        });
    }
    Ok((r, jac))
}

/// The mean of |r_j|² over the nine lines nearest each line k, halved: the D_k² of the
/// sandwich covariance (see [`sandwich`]).
fn local_half_power<T: Real>(r: &[Complex<T>]) -> Vec<T> {
    const HALF: usize = 4;
    let n = r.len();
    // |r_k|², overwritten in place by the means: the HALF powers before k, already
    // overwritten, are kept in a ring (summed in index order all the same)
    let mut out: Vec<T> = r.iter().map(|v| v.norm_sqr()).collect();
    let mut before = [T::zero(); HALF];
    for k in 0..n {
        let (lo, hi) = (k.saturating_sub(HALF), (k + HALF + 1).min(n));
        let sum = (lo..k)
            .map(|j| before[j % HALF])
            .chain(out[k..hi].iter().copied())
            .fold(T::zero(), |a, b| a + b);
        before[k % HALF] = out[k];
        out[k] = sum / T::from_usize_lossy(hi - lo) / T::lit(2.0);
    }
    out
}

/// F₀ with (JᵀJ)⁻¹ = F₀F₀ᵀ and the sandwich R⁻¹QR⁻¹ (R = JᵀJ, Q = JᵀD²J, see [`sandwich`]).
///
/// First from the equilibrated Gram matrix Gₛ = S⁻¹JᵀJS⁻¹ = LLᵀ (S = diag ‖J_j‖) when it
/// factors with κ₁(Gₛ) ≤ 10⁸ in f64 (10³ in f32): F₀ = S⁻¹L⁻ᵀ, accurate to about κ₁·ε
/// relative — far more digits than a covariance carries — for one matrix product instead
/// of a QR, and Q from a second product of the same transposed copy of J. Otherwise from
/// a QR of J ([`gram_inverse_factor_qr`]), `None` when J is numerically rank deficient.
/// Only F₀F₀ᵀ is defined: the two factors differ by an orthogonal matrix, which no
/// statistic computed from F₀ sees.
fn covariance_factors<T: Real>(
    mut jac: DMatrix<T>,
    r: &[Complex<T>],
) -> (Option<DMatrix<T>>, Option<DMatrix<T>>) {
    use crate::linalg::gram::{GramWork, max_condition, scaled_cholesky};
    let (m, p) = jac.shape();
    if p == 0 || m < p || m != 2 * r.len() {
        return (None, None);
    }
    let mut work = GramWork::new(p);
    work.gram(&jac);
    if let Some(sc) = scaled_cholesky(&work.g, max_condition::<T>()) {
        let linv = sc.chol.l().solve_lower_triangular(&DMatrix::identity(p, p));
        if let Some(linv) = linv {
            let f0 = DMatrix::from_fn(p, p, |i, k| linv[(k, i)] / sc.d[i]);
            if f0.iter().all(|v| Float::is_finite(*v)) {
                // Q = (DJ)ᵀ(DJ), J scaled in place (it is not needed afterwards)
                for (k, s) in local_half_power(r).iter().enumerate() {
                    let d = Float::sqrt(*s);
                    for row in [2 * k, 2 * k + 1] {
                        jac.row_mut(row).scale_mut(d);
                    }
                }
                work.gram(&jac);
                let q = &work.g;
                let c0 = &f0 * f0.transpose();
                let robust = &c0 * q * &c0;
                return (Some(f0), Some(robust));
            }
        }
    }
    let base = gram_inverse_factor_qr(jac.clone());
    let robust = base.as_ref().map(|f0| sandwich(&jac, f0, r));
    (base, robust)
}

/// F with (JᵀJ)⁻¹ = F Fᵀ, from a QR of the column-equilibrated J = Q R D and an SVD
/// R = UΣVᵀ: F = D⁻¹VΣ⁻¹. `None` when J is (numerically) rank deficient.
fn gram_inverse_factor_qr<T: Real>(mut jac: DMatrix<T>) -> Option<DMatrix<T>> {
    let p = jac.ncols();
    if p == 0 || jac.nrows() < p {
        return None;
    }
    let mut scale = vec![T::one(); p];
    for (j, s) in scale.iter_mut().enumerate() {
        let n = jac.column(j).norm();
        if n > T::zero() {
            *s = n;
            jac.column_mut(j).unscale_mut(n);
        }
    }
    let r = jac.qr().unpack_r();
    if r.iter().any(|v| !Float::is_finite(*v)) {
        return None;
    }
    let svd = crate::linalg::try_svd(r, false, true, 100 * p.max(10))?;
    let smax = svd.singular_values.max();
    let smin = svd.singular_values.min();
    if !(smin > smax * T::default_epsilon() * T::lit(10.0)) {
        return None;
    }
    let vt = svd.v_t?;
    Some(DMatrix::from_fn(p, p, |i, k| {
        vt[(k, i)] / (svd.singular_values[k] * scale[i])
    }))
}

impl<T: Real> Fit<T, crate::model::Rational<T>> {
    /// Poles whose half-power band holds no data line, so that the data do not determine
    /// their damping ([`crate::validation::unresolved_poles`]): with s = p (continuous
    /// time) or s = ln(p)/Ts (discrete time), s = σ + iω_p, a pole is unresolved when ω_p
    /// lies inside the band of the data and no line ω_k satisfies |ω_k − |ω_p|| ≤ |σ|.
    /// Such a pole is typically spurious — a resonance fitted between two lines (e.g. in
    /// place of poles closer together than the noise resolves) — even when the cost looks
    /// right; one conjugate of each pair is listed.
    ///
    /// # Errors
    /// As [`crate::model::PolesZeros::poles`].
    pub fn unresolved_poles(&self) -> Result<Vec<Complex<T>>> {
        Ok(crate::validation::unresolved_poles(
            &self.poles()?,
            self.model().domain(),
            self.omega(),
        ))
    }
}

/// θ estimated on normalised data mapped back to the data's units: θ_j·d_j, `d` the model's
/// [`ModelStructure::normalisation_map`](crate::model::ModelStructure::normalisation_map).
pub(crate) fn denormalise_theta<T: Real>(theta: &mut [T], d: &[T]) {
    for (t, f) in theta.iter_mut().zip(d) {
        *t *= *f;
    }
}

/// Stages estimated on normalised data mapped back: θ by `d` ([`denormalise_theta`]; not
/// a delay stage's, whose θ is τ) and the costs by `cost` (the squared residual scale,
/// [`Normalisation::cost_scale`]).
pub(crate) fn denormalise_stages<T: Real>(stages: &mut [Stage<T>], d: &[T], cost: T) {
    for stage in stages {
        if stage.kind != StageKind::Delay {
            denormalise_theta(&mut stage.solution.theta, d);
        }
        stage.solution.cost *= cost;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::lcg;

    /// The Cholesky path of the covariance and of the sandwich equals the QR/SVD path.
    #[test]
    fn local_half_power_is_the_windowed_mean() {
        for n in [0usize, 1, 3, 8, 9, 10, 31] {
            let r: Vec<Complex<f64>> = (0..n)
                .map(|k| Complex::new((k as f64 * 0.7).sin(), 1.0 / (k as f64 + 1.5)))
                .collect();
            let d = local_half_power(&r);
            assert_eq!(d.len(), n);
            for (k, dk) in d.iter().enumerate() {
                let (lo, hi) = (k.saturating_sub(4), (k + 5).min(n));
                let sum = r[lo..hi].iter().fold(0.0, |a, v| a + v.norm_sqr());
                assert_eq!(*dk, sum / (hi - lo) as f64 / 2.0, "n {n} line {k}");
            }
        }
    }

    #[test]
    fn covariance_from_the_gram_matrix_equals_the_qr_one() {
        let (n, p) = (300, 7);
        let mut s = 21;
        let jac = DMatrix::from_fn(2 * n, p, |_, j| lcg(&mut s) * 10f64.powi(j as i32 - 2));
        let r: Vec<Complex<f64>> = (0..n)
            .map(|_| Complex::new(lcg(&mut s), lcg(&mut s)))
            .collect();
        let (f, robust) = covariance_factors(jac.clone(), &r);
        let (f, robust) = (f.expect("gram path"), robust.expect("robust"));
        let fq = gram_inverse_factor_qr(jac.clone()).expect("qr path");
        let (c, cq) = (&f * f.transpose(), &fq * fq.transpose());
        assert!((&c - &cq).norm() <= 1e-10 * cq.norm(), "{c} vs {cq}");
        let rq = sandwich(&jac, &fq, &r);
        assert!((&robust - &rq).norm() <= 1e-10 * rq.norm());
        // f32 with its tighter guard still agrees to its precision
        let j32 = jac.map(|v| v as f32);
        let r32: Vec<Complex<f32>> = r
            .iter()
            .map(|v| Complex::new(v.re as f32, v.im as f32))
            .collect();
        let (f32c, _) = covariance_factors(j32, &r32);
        let f32c = f32c.expect("well conditioned in f32 too");
        let c32 = (&f32c * f32c.transpose()).map(f64::from);
        assert!((&c32 - &cq).norm() <= 1e-3 * cq.norm());
        // a rank-deficient J has no covariance on either path
        let mut def = jac.clone();
        let col = def.column(0).into_owned();
        def.set_column(1, &col);
        assert!(covariance_factors(def, &r).0.is_none());
    }
}
