//! The total least squares estimator of the time-varying ODE (Lataire–Pintelon eq. 19).

use super::model::{InstantaneousModel, LtvOde, MonomialCoefficients};
use super::regression::{Lines, Regression, regression};
use crate::data::TimeData;
use crate::error::{FdidError, Result};
use crate::linalg::stack_rows;
use crate::problem::HomogeneousProblem;
use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;
use num_traits::Float;

/// The TLS problem of eq. 19 as a [`HomogeneousProblem`]: minimise ‖M c‖ over ‖c‖ = 1,
/// with M the real-stacked regression matrix [Re K; Im K] (rows 2k, 2k + 1 for line k)
/// whose columns are scaled to unit norm, M = [Re K; Im K] D⁻¹, D = diag(‖column‖).
///
/// [`crate::solver::SvdNullVector`] solves it; θ = D⁻¹c, rescaled so that the Ψ_{N_α}
/// coefficient of the instantaneous denominator at mid-record, a_{N_α}(T/2), is 1
/// (see [`LtvFit::theta`]).
#[derive(Debug, Clone)]
pub struct LtvTlsProblem<T: Real> {
    model: LtvOde<T>,
    regression: Regression<T>,
    stacked: DMatrix<T>,
    column_norms: Vec<T>,
}

impl<T: Real> LtvTlsProblem<T> {
    /// Builds the regressor (see [`regression`]) and its column-scaled real-stacked form.
    ///
    /// # Errors
    /// Those of [`regression`]; [`FdidError::Singular`] when a column of K is zero on
    /// 𝕂 (a zero signal, or a transient term that the lines cannot see), and
    /// [`FdidError::NonFinite`] when the regressor overflows.
    pub fn new(model: &LtvOde<T>, data: &TimeData<T>, lines: &Lines<T>) -> Result<Self> {
        let regression = regression(model, data, lines)?;
        let mut stacked = stack_rows(&regression.matrix, None);
        let mut column_norms = Vec::with_capacity(stacked.ncols());
        for j in 0..stacked.ncols() {
            let norm = stacked.column(j).norm();
            if !Float::is_finite(norm) {
                return Err(FdidError::NonFinite {
                    what: "regression column",
                    index: j,
                    value: format!("{norm}"),
                });
            }
            if !(norm > T::zero()) {
                return Err(FdidError::Singular {
                    what: "LTV regression: a column is zero on the selected lines",
                    condition: f64::INFINITY,
                });
            }
            stacked.column_mut(j).unscale_mut(norm);
            column_norms.push(norm);
        }
        Ok(Self {
            model: model.clone(),
            regression,
            stacked,
            column_norms,
        })
    }

    /// The complex regression matrix K and its lines.
    pub fn regression(&self) -> &Regression<T> {
        &self.regression
    }

    /// The column norms D of the real-stacked K.
    pub fn column_norms(&self) -> &[T] {
        &self.column_norms
    }

    /// θ = D⁻¹c normalised to a_{N_α}(T/2) = 1; `None` when that coefficient is
    /// (numerically) zero.
    fn normalise(&self, c: &[T]) -> Option<Vec<T>> {
        let theta: Vec<T> = c
            .iter()
            .zip(&self.column_norms)
            .map(|(v, d)| *v / *d)
            .collect();
        let half = self.regression.record * T::lit(0.5);
        let (a, _) = self
            .model
            .frozen_coefficients(&theta, half, self.regression.record);
        let lead = *a.last()?;
        // size of the same coefficient if every term added up in phase
        let mut b = vec![T::zero(); self.model.n_p() + 1];
        self.model
            .time_basis()
            .eval_into(half, self.regression.record, &mut b);
        let na = self.model.n_alpha();
        let bound = b.iter().enumerate().fold(T::zero(), |s, (p, bp)| {
            s + Float::abs(theta[self.model.alpha_index(na, p)] * *bp)
        });
        if !(Float::abs(lead) > bound * T::default_epsilon() * T::lit(64.0)) || bound == T::zero() {
            return None;
        }
        Some(theta.iter().map(|v| *v / lead).collect())
    }
}

impl<T: Real> HomogeneousProblem<T> for LtvTlsProblem<T> {
    fn matrix(&self) -> DMatrix<T> {
        self.stacked.clone()
    }

    fn theta_from_null_vector(&self, c: &[T]) -> Option<Vec<T>> {
        self.normalise(c)
    }
}

impl<T: Real> LtvOde<T> {
    /// The TLS problem of eq. 19 on `data` over the lines `lines`, for any solver of
    /// [`HomogeneousProblem`]s.
    ///
    /// # Errors
    /// As [`LtvTlsProblem::new`].
    pub fn problem(&self, data: &TimeData<T>, lines: &Lines<T>) -> Result<LtvTlsProblem<T>> {
        LtvTlsProblem::new(self, data, lines)
    }

    /// The Lataire–Pintelon frequency-domain TLS estimate (eq. 19): θ̂ is the right singular
    /// vector of the smallest singular value of the column-scaled, real-stacked regressor
    /// K of eq. 11 (columns by FFT, eq. 15; transient + alias polynomial, eq. 18), mapped
    /// back through the column scaling and normalised to a_{N_α}(T/2) = 1.
    ///
    /// The column scaling makes the estimate independent of the units of t, s and the
    /// signals; it is exact for noise-free data, and with noise it is one particular
    /// weighting of the TLS problem (the paper's eq. 19 leaves the column scale to the
    /// choice of basis). Weighted (generalised) TLS with known noise covariances is not
    /// offered.
    ///
    /// # Errors
    /// - those of [`LtvTlsProblem::new`] (settings, lines, N_p against the record, too few
    ///   lines);
    /// - [`FdidError::NotConverged`] if the SVD fails;
    /// - [`FdidError::Singular`] when the estimate has a_{N_α}(T/2) = 0 (the model order
    ///   N_α is not supported by the data at mid-record).
    pub fn fit(&self, data: &TimeData<T>, lines: &Lines<T>) -> Result<LtvFit<T>> {
        let problem = self.problem(data, lines)?;
        let m = &problem.stacked;
        let p = m.ncols();
        // QR first: the SVD then works on a p × p factor
        let r = if m.nrows() > p {
            m.clone().qr().unpack_r()
        } else {
            m.clone()
        };
        let svd = crate::linalg::try_svd(r, false, true, 200 * p.max(10)).ok_or(
            FdidError::NotConverged {
                method: "SVD",
                reason: "no convergence for the LTV regression matrix".into(),
            },
        )?;
        let v_t = svd.v_t.as_ref().ok_or(FdidError::Numerical {
            what: "SVD without right singular vectors".into(),
        })?;
        let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
        order.sort_by(|a, b| {
            svd.singular_values[*b]
                .partial_cmp(&svd.singular_values[*a])
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        let singular_values: Vec<T> = order.iter().map(|i| svd.singular_values[*i]).collect();
        let imin = *order.last().ok_or(FdidError::Numerical {
            what: "empty SVD".into(),
        })?;
        let mut null_vector: Vec<T> = v_t.row(imin).iter().copied().collect();
        let theta = problem.normalise(&null_vector).ok_or(FdidError::Singular {
            what: "LTV TLS: the estimate has a zero leading output coefficient at mid-record",
            condition: f64::INFINITY,
        })?;
        // sign convention of the reported unit vector: same sign as θ
        if let Some(j) = (0..p).find(|j| theta[*j] != T::zero())
            && (null_vector[j] > T::zero()) != (theta[j] > T::zero())
        {
            null_vector.iter_mut().for_each(|v| *v = -*v);
        }
        Ok(LtvFit {
            model: self.clone(),
            theta,
            null_vector,
            singular_values,
            lines: problem.regression.lines,
            omega: problem.regression.omega,
            record: problem.regression.record,
            transient_scale: problem.regression.transient_scale,
        })
    }
}

/// A fitted time-varying ODE ([`LtvOde::fit`]).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct LtvFit<T> {
    /// The model structure that was fitted.
    pub model: LtvOde<T>,
    /// θ̂ in the model's bases (layout in [`LtvOde`]), normalised so that the Ψ_{N_α}
    /// coefficient of the instantaneous denominator at mid-record is one:
    /// a_{N_α}(T/2) = Σ_p α̃_{N_α,p} b_p(T/2) = 1. For monomial Ψ this is the monic
    /// instantaneous denominator α_{N_α}(T/2) = 1.
    pub theta: Vec<T>,
    /// The unit-norm right singular vector c of eq. 19 (in the column-scaled coordinates),
    /// θ̂ ∝ D⁻¹c.
    pub null_vector: Vec<T>,
    /// Singular values of the column-scaled real-stacked regressor, largest first; the last
    /// is the TLS cost ‖M c‖.
    pub singular_values: Vec<T>,
    /// The lines 𝕂 used.
    pub lines: Vec<usize>,
    /// Their angular frequencies (rad/s).
    pub omega: Vec<T>,
    /// Record length T = N T_s (s).
    pub record: T,
    /// Frequency scale of the transient polynomial (rad/s).
    pub transient_scale: T,
}

impl<T: Real> LtvFit<T> {
    /// The frozen system at t* (eq. 4); t* in seconds from the first sample.
    pub fn instantaneous(&self, t: T) -> InstantaneousModel<T> {
        let (alpha, beta) = self.model.frozen_coefficients(&self.theta, t, self.record);
        let basis = self.model.frequency_basis();
        let scale = match basis {
            super::FrequencyBasis::Legendre { omega_max } => omega_max,
            super::FrequencyBasis::Monomial => self.transient_scale,
        };
        InstantaneousModel {
            t,
            alpha,
            beta,
            basis,
            scale,
        }
    }

    /// The instantaneous poles at each time of `times` (s): a sweep of eq. 4's poles.
    ///
    /// # Errors
    /// As [`InstantaneousModel::poles`].
    pub fn pole_sweep(&self, times: &[T]) -> Result<Vec<Vec<Complex<T>>>> {
        times
            .iter()
            .map(|t| self.instantaneous(*t).poles())
            .collect()
    }

    /// The coefficients γ₀ … γ_{N_tr} of the transient + alias polynomial (eq. 18), in
    /// the Legendre form Φ_m(ω) = j^(m mod 2) P_m(ω/ω_tr), ω_tr = `transient_scale`.
    pub fn transient(&self) -> &[T] {
        &self.theta[self.model.n_ode_params()..]
    }

    /// αₙ,ₚ and βₙ,ₚ of eqs. 1–2 (see [`LtvOde::to_monomial`]).
    pub fn monomial(&self) -> MonomialCoefficients<T> {
        self.model.to_monomial(&self.theta, self.record)
    }
}
