//! Fits with an estimated noise model H = C/D (McKelvey eqs. 23–26): the output-error chain
//! gives G's start, then the joint ML of G and H.

use super::{FurtherStarts, Pipeline};
use crate::criterion::{
    Criterion, NoiseModelMl, NoiseModelProblem, NoiseModelResiduals, NoiseWeighting, interior_lines,
};
use crate::data::FrequencyData;
use crate::error::{FdidError, Result};
use crate::fit::{Fit, NoiseLevel, Stage, StageKind};
use crate::model::{ModelStructure, NoiseModel, WithNoiseModel};
use crate::problem::NonlinearProblem;
use crate::scalar::{Complex, Real};
use crate::solver::{GramLevenbergMarquardt, LevenbergMarquardt};

/// The relative cost reduction at which the noise-model ML counts as converged, unless the
/// solver sets its own: 10⁻⁶ of V. The criterion is about N/2 times the innovation
/// variance λ on N lines, so this is a change of about 10⁻⁶·N/2 in V/λ — 0.002 on 4 096
/// lines, far below the unit changes a likelihood-ratio test resolves. With the
/// solver's default of 10⁻¹⁰ a noise model of more parameters than the noise needs
/// crawls along the valley of its nearly cancelling roots of C and D for thousands of
/// iterations (order 20 on 4 096 samples: 49.7 s; with 10⁻⁶, 1.1 s). The estimate then
/// stops short of the exact stationary point by a statistically negligible amount; set
/// `cost_tolerance` on the solver for a tighter one.
pub const NOISE_MODEL_COST_TOLERANCE: f64 = 1e-6;

/// Fits `model` with a monic noise model H = C/D of orders `nc`, `nd` to the DFT `data` of
/// a time record by maximum likelihood (McKelvey eq. 26, [`NoiseModelMl`]):
///
/// 1. keeps the [`interior_lines`] (DC and Nyquist dropped);
/// 2. starts G from `pipeline` with flat weighting (H ≡ 1, eq. 25) on the lines with
///    U_k ≠ 0 (its model is used, with the basis the pipeline may have relocated), and H
///    from the linear estimate of Hannan and Rissanen on the start's residuals
///    (`noise_start`: a long autoregression, then D ε = C ê by least squares; roots
///    reflected into the unit disc) when it lowers the criterion, else from η = 0 (H = 1);
/// 3. minimises W with Levenberg–Marquardt (`pipeline.ml`, or the default), converged at a
///    relative cost reduction of [`NOISE_MODEL_COST_TOLERANCE`] unless the solver sets
///    its own `cost_tolerance`;
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
/// use fdid::estimate::fit_noise_model;
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
pub fn fit_noise_model<T: Real, M: FurtherStarts<T>>(
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
    refine_noise_model_in(
        &start_fit,
        &data,
        noise,
        &pipeline.ml.unwrap_or_default(),
        pipeline.stable,
    )
}

/// The start of H from the residuals of the system's start (`theta` with η = 0, where the
/// criterion's residuals are Y − Ŷ): [`super::noise_start::hannan_rissanen`] on the lines
/// of `data`; the whole start [θ_G, η₀] when it lowers the criterion ‖r‖² below η = 0's.
fn linear_noise_start<T: Real, M: ModelStructure<T> + Clone>(
    full: &WithNoiseModel<M>,
    data: &FrequencyData<T>,
    problem: &impl NonlinearProblem<T>,
    theta: &[T],
) -> Option<Vec<T>> {
    let p = theta.len() - full.noise::<T>().n_params();
    let mut r = vec![T::zero(); problem.n_residuals()];
    if !problem.residuals_into(theta, &mut r) {
        return None;
    }
    let eps: Vec<Complex<T>> = r
        .chunks_exact(2)
        .map(|c| Complex::new(c[0], c[1]))
        .collect();
    let eta = super::noise_start::hannan_rissanen(&full.noise(), &eps, data.omega())?;
    let mut with = theta[..p].to_vec();
    with.extend(eta);
    let norm = |r: &[T]| r.iter().fold(T::zero(), |s, v| s + *v * *v);
    let before = norm(&r);
    (problem.residuals_into(&with, &mut r) && norm(&r) < before).then_some(with)
}

/// The noise-model stage of [`fit_noise_model`] for any model structure: from a fitted
/// system model `start` (e.g. a [`crate::model::Delayed`] fit), ML on the concentrated
/// criterion (26) over [θ_G, η] from [θ̂_G, η₀] with Levenberg–Marquardt, η₀ the linear
/// (Hannan–Rissanen) estimate of H from the start's residuals when it lowers the
/// criterion, else 0; H is then made
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
    refine_noise_model_in(start, data, noise, lm, false)
}

/// [`refine_noise_model`], with `stable` restricted to a stable system part (the start's
/// unstable poles reflected, then the constrained Levenberg–Marquardt of
/// [`crate::solver::Feasible`]).
pub(crate) fn refine_noise_model_in<T: Real, M: ModelStructure<T> + Clone>(
    start: &Fit<T, M>,
    data: &FrequencyData<T>,
    noise: NoiseModel<T>,
    lm: &LevenbergMarquardt,
    stable: bool,
) -> Result<Fit<T, WithNoiseModel<M>>> {
    let mut stages = start.stages().to_vec();
    let full = WithNoiseModel::new(start.model().clone(), noise);
    let p = start.model().n_params();
    let mut theta = super::chain::stable_start(start.model(), start.theta().to_vec(), stable)?;
    theta.extend(std::iter::repeat_n(T::zero(), noise.n_params()));
    let problem = NoiseModelMl.problem(&full, data)?;
    // H from the start's residuals (Hannan–Rissanen) when it lowers the criterion
    if let Some(start) = linear_noise_start(&full, data, &problem, &theta) {
        theta = start;
    }
    // converged at a relative cost reduction of NOISE_MODEL_COST_TOLERANCE unless the
    // solver sets its own
    let relaxed = LevenbergMarquardt {
        cost_tolerance: lm.cost_tolerance.or(Some(NOISE_MODEL_COST_TOLERANCE)),
        ..*lm
    };
    // normal-equation steps first (at most 100), MINPACK's LM from where they stop
    let fast = GramLevenbergMarquardt::from(relaxed);
    let solve = |theta: &[T]| {
        super::chain::gram_then_lm_in(&fast, &relaxed, &full, &problem, theta, stable)
    };
    let sol = solve(&theta)?;
    theta = sol.theta.clone();
    stages.push(Stage::new(StageKind::NoiseModelMl, sol));
    let stabilise = |theta: &mut Vec<T>| -> Result<bool> {
        let eta = noise.stabilised(&theta[p..])?;
        let changed = eta != theta[p..];
        theta.truncate(p);
        theta.extend(eta);
        Ok(changed)
    };
    if stabilise(&mut theta)? {
        let sol = solve(&theta)?;
        theta = sol.theta.clone();
        stages.push(Stage::new(StageKind::NoiseModelStabilised, sol));
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
