//! Errors-in-variables maximum likelihood: noise on the measured input as well as on the
//! output (McKelvey eq. 42, with the correction for correlated input and output noise).

use super::{Criterion, check_input};
use crate::data::FrequencyData;
use crate::error::{FdidError, Result};
use crate::model::{ModelStructure, Output};
use crate::problem::NonlinearProblem;
use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;
use num_traits::Float;
use std::cell::RefCell;

/// Errors-in-variables maximum likelihood (McKelvey eq. 42): both spectra are measured
/// with noise, Y_k = Y₀,k + N_Y,k and U_k = U₀,k + N_U,k, with known (or, from P ≥ 2
/// periods, estimated) per-line noise (co)variances var_y,k = E|N_Y|², var_u,k = E|N_U|²
/// and cov_yu,k = E[N_Y conj N_U] (as in [`crate::NoiseVariances`]). The ML estimate
/// minimises
///
/// ```text
/// V(θ) = Σ_k |Y_k − Ŷ_k(θ)|² / σ_k²(θ),                       (McKelvey eq. 42)
/// Ŷ_k(θ) = G_k(θ) U_k + T_k(θ),
/// σ_k²(θ) = var_y,k + |G_k|² var_u,k − 2 Re(conj(G_k) cov_yu,k),
/// ```
///
/// the variance of the output error Y − GU − T = N_Y − G N_U at the true θ. With G = B/A
/// and cov_yu = 0, multiplying numerator and denominator by |A|² gives eq. 42 as printed;
/// the covariance term is the "correction subtracted from the denominator" that the paper
/// mentions for correlated noise. With var_u = cov_yu = 0 the criterion is the output-error
/// ML of eq. 23 with the fixed noise model σ_k² = var_y,k ([`crate::MaximumLikelihood`]).
///
/// The residuals handed to [`crate::solver::LevenbergMarquardt`] are
/// r_k = (Y_k − Ŷ_k)/σ_k(θ), real-stacked (`r[2k]` = Re, `r[2k+1]` = Im), with the analytic
/// Jacobian
///
/// ```text
/// ∂r_k/∂θ_j = −(∂Ŷ_k/∂θ_j)/σ_k − r_k (∂σ_k²/∂θ_j) / (2σ_k²),
/// ∂σ_k²/∂θ_j = 2 Re(conj(G_k) ∂G_k/∂θ_j) var_u,k − 2 Re(conj(∂G_k/∂θ_j) cov_yu,k).
/// ```
///
/// Variances estimated from P periods ([`crate::TimeData::average_periods`]) keep the
/// estimate consistent (the paper cites four repeated experiments as enough); they make the
/// cost at the minimum about N·ν/(ν − 2), ν = 2(P − 1), instead of N, and the actual
/// covariance of θ̂ somewhat larger than the one predicted with known variances.
///
/// | setting | default | meaning |
/// |---|---|---|
/// | `use_covariance` | `true` | include the cov_yu term of σ_k²; `false` treats input and output noise as uncorrelated |
///
/// # Errors
/// [`Criterion::problem`] fails when the data carry no noise variances (a record of one
/// period, P = 1), when every var_u is zero (use [`crate::MaximumLikelihood`]), when a line's
/// (co)variances are not those of a noise (|cov_yu|² > var_y·var_u), on zero input lines
/// and on too few lines.
///
/// ```
/// use fdid::prelude::*;
///
/// // G(z) = 0.5 z⁻¹ / (1 − 0.8 z⁻¹) on 40 lines, with small known input and output noise
/// // variances (here noise-free spectra, so the estimate is exact)
/// let ts = 1.0;
/// let omega: Vec<f64> = (1..=40).map(|k| 3.0 * k as f64 / 41.0).collect();
/// let u: Vec<Complex<f64>> = omega.iter().map(|w| Complex::from_polar(1.0, 2.0 * w)).collect();
/// let y: Vec<Complex<f64>> = omega
///     .iter()
///     .zip(&u)
///     .map(|(w, u)| {
///         let zi = Complex::from_polar(1.0, -w * ts);
///         zi * 0.5 / (1.0 - zi * 0.8) * u
///     })
///     .collect();
/// let noise = NoiseVariances {
///     var_y: vec![1e-4; 40],
///     var_u: vec![1e-4; 40],
///     cov_yu: vec![Complex::new(0.0, 0.0); 40],
/// };
/// let data = FrequencyData::new(omega, y, u, Some(ts)).unwrap().with_noise(noise).unwrap();
/// let model = Rational::discrete(1, 1, ts).unwrap();
/// let fit = fit_eiv(&Pipeline::default(), &model, &data).unwrap();
/// let truth = [-0.8, 0.0, 0.5];
/// assert!(fit.theta().iter().zip(truth).all(|(a, b)| (a - b).abs() < 1e-9));
/// assert_eq!(fit.stages().last().unwrap().kind, StageKind::Eiv);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ErrorsInVariables {
    /// Include the input–output noise covariance in σ_k² (default `true`).
    pub use_covariance: bool,
}

impl Default for ErrorsInVariables {
    fn default() -> Self {
        Self {
            use_covariance: true,
        }
    }
}

/// The errors-in-variables criterion (eq. 42) bound to a model and data: a
/// [`NonlinearProblem`] with residuals r_k = (Y_k − Ŷ_k(θ))/σ_k(θ).
pub struct EivProblem<'a, T: Real, M: ?Sized> {
    model: &'a M,
    data: &'a FrequencyData<T>,
    var_y: &'a [T],
    var_u: &'a [T],
    cov_yu: Option<&'a [Complex<T>]>,
    scratch: RefCell<Output<T>>,
}

impl<T: Real, M: ModelStructure<T> + ?Sized> Criterion<T, M> for ErrorsInVariables {
    type Problem<'a>
        = EivProblem<'a, T, M>
    where
        M: 'a,
        T: 'a;

    fn problem<'a>(
        &'a self,
        model: &'a M,
        data: &'a FrequencyData<T>,
    ) -> Result<EivProblem<'a, T, M>> {
        let problem = EivProblem::new(model, data, self.use_covariance)?;
        if problem.var_u.iter().all(|v| *v == T::zero()) {
            return Err(FdidError::InvalidArgument {
                name: "var_u",
                value: "0 on every line".into(),
                reason: "errors-in-variables needs the input noise variances; with a \
                         noise-free input use MaximumLikelihood (eq. 23)"
                    .into(),
            });
        }
        Ok(problem)
    }
}

impl<'a, T: Real, M: ModelStructure<T> + ?Sized> EivProblem<'a, T, M> {
    /// Binds `model` and `data` with the data's noise (co)variances; `use_covariance =
    /// false` leaves out cov_yu. Unlike [`Criterion::problem`], zero input variances are
    /// accepted (the problem is then output-error ML, eq. 23).
    ///
    /// # Errors
    /// - [`FdidError::InvalidArgument`] named `"noise"` when the data carry no noise
    ///   variances (e.g. a periodic record averaged over P = 1 period);
    /// - [`FdidError::InvalidArgument`] named `"cov_yu"` when |cov_yu,k|² > var_y,k·var_u,k
    ///   on some line (not a covariance), or `"var_y"` when var_y,k = var_u,k = 0 (σ_k would
    ///   be zero for every θ);
    /// - as [`ModelStructure::check_data`]; [`FdidError::ZeroInput`].
    pub fn new(model: &'a M, data: &'a FrequencyData<T>, use_covariance: bool) -> Result<Self> {
        model.check_data(data)?;
        check_input(data)?;
        let noise = data.noise().ok_or_else(|| FdidError::InvalidArgument {
            name: "noise",
            value: "none".into(),
            reason: "errors-in-variables needs the input and output noise (co)variances: \
                     average a periodic record over P ≥ 2 periods (TimeData::average_periods) \
                     or attach NoiseVariances"
                .into(),
        })?;
        for k in 0..data.len() {
            let (vy, vu, c) = (noise.var_y[k], noise.var_u[k], noise.cov_yu[k]);
            if vy == T::zero() && vu == T::zero() {
                return Err(FdidError::InvalidArgument {
                    name: "var_y",
                    value: format!("0 at line {k} (var_u also 0)"),
                    reason: "a line without noise has an infinite weight; drop the line".into(),
                });
            }
            // the sample covariance matrix of P periods is positive semidefinite; allow
            // round-off of a few ulps
            if use_covariance
                && c.norm_sqr() > vy * vu * (T::one() + T::default_epsilon() * T::lit(64.0))
            {
                return Err(FdidError::InvalidArgument {
                    name: "cov_yu",
                    value: format!("{c} at line {k} (var_y = {vy}, var_u = {vu})"),
                    reason: "|cov_yu|² exceeds var_y·var_u: not the covariance of a noise".into(),
                });
            }
        }
        Ok(Self {
            model,
            data,
            var_y: &noise.var_y,
            var_u: &noise.var_u,
            cov_yu: use_covariance.then_some(noise.cov_yu.as_slice()),
            scratch: RefCell::new(Output::new(data.len(), model.n_params())),
        })
    }

    /// The data.
    pub fn data(&self) -> &FrequencyData<T> {
        self.data
    }

    /// The model.
    pub fn model(&self) -> &M {
        self.model
    }

    /// The cost V(θ) = Σ_k |Y_k − Ŷ_k|²/σ_k²(θ) = ‖r(θ)‖² (eq. 42); NaN where σ_k² ≤ 0 or
    /// the model is not finite.
    pub fn cost(&self, theta: &[T]) -> T {
        let mut r = vec![T::zero(); 2 * self.data.len()];
        if !self.residuals_into(theta, &mut r) {
            return T::nan();
        }
        r.iter().fold(T::zero(), |s, v| *v * *v + s)
    }

    /// The output-error variances σ_k²(θ) = var_y,k + |G_k|² var_u,k − 2 Re(conj(G_k)
    /// cov_yu,k) of every line.
    pub fn error_variances(&self, theta: &[T]) -> Vec<T> {
        let g = self.model.response(theta, self.data.omega());
        g.iter()
            .enumerate()
            .map(|(k, g)| self.sigma2(k, *g))
            .collect()
    }

    /// σ_k² for response `g` at line k.
    #[inline]
    fn sigma2(&self, k: usize, g: Complex<T>) -> T {
        let mut s = self.var_y[k] + g.norm_sqr() * self.var_u[k];
        if let Some(c) = self.cov_yu {
            s -= T::lit(2.0) * (g.conj() * c[k]).re;
        }
        s
    }

    /// Writes the residuals from the evaluated output; false when some σ_k² is not
    /// positive and finite.
    fn write_residuals(&self, out: &Output<T>, r: &mut [T], sigma: &mut [T]) -> bool {
        let mut ok = true;
        for (k, (yhat, y)) in out.yhat.iter().zip(self.data.y()).enumerate() {
            let s2 = self.sigma2(k, out.g[k]);
            if !(s2 > T::zero() && Float::is_finite(s2)) {
                ok = false;
                sigma[k] = T::nan();
                r[2 * k] = T::nan();
                r[2 * k + 1] = T::nan();
                continue;
            }
            let s = Float::sqrt(s2);
            sigma[k] = s;
            let e = (*y - *yhat) / s;
            r[2 * k] = e.re;
            r[2 * k + 1] = e.im;
        }
        ok && r.iter().all(|v| Float::is_finite(*v))
    }
}

impl<T: Real, M: ModelStructure<T> + ?Sized> NonlinearProblem<T> for EivProblem<'_, T, M> {
    fn n_params(&self) -> usize {
        self.model.n_params()
    }

    fn n_residuals(&self) -> usize {
        2 * self.data.len()
    }

    fn residuals_into(&self, theta: &[T], r: &mut [T]) -> bool {
        let mut out = self.scratch.borrow_mut();
        let finite = out.evaluate(self.model, theta, self.data, false);
        let mut sigma = vec![T::zero(); self.data.len()];
        // the model's output must be finite before σ is formed from G
        finite && self.write_residuals(&out, r, &mut sigma)
    }

    fn jacobian_into(&self, theta: &[T], r: &mut [T], jac: &mut DMatrix<T>) -> bool {
        let mut out = self.scratch.borrow_mut();
        if !out.evaluate(self.model, theta, self.data, true) {
            return false;
        }
        let mut sigma = vec![T::zero(); self.data.len()];
        if !self.write_residuals(&out, r, &mut sigma) {
            return false;
        }
        let two = T::lit(2.0);
        for j in 0..self.model.n_params() {
            for k in 0..self.data.len() {
                let dg = out.dg[(k, j)];
                // ∂σ²/∂θ_j = 2 Re(conj G ∂G) var_u − 2 Re(conj(∂G) cov_yu)
                let mut ds2 = two * (out.g[k].conj() * dg).re * self.var_u[k];
                if let Some(c) = self.cov_yu {
                    ds2 -= two * (dg.conj() * c[k]).re;
                }
                let s = sigma[k];
                // ∂r/∂θ_j = −∂Ŷ/σ − r ∂σ²/(2σ²)
                let f = ds2 / (two * s * s);
                let d = -out.dyhat[(k, j)] / s;
                jac[(2 * k, j)] = d.re - r[2 * k] * f;
                jac[(2 * k + 1, j)] = d.im - r[2 * k + 1] * f;
            }
        }
        jac.iter().all(|v| Float::is_finite(*v))
    }
}
