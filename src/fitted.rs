//! A fitted model reduced to what is needed to use it later: the model structure, θ̂, its
//! covariance and the noise level, without the data (feature `serde` makes it
//! serialisable, so that a fit can be saved and reloaded).

use crate::error::{FdidError, Result};
use crate::fit::Fit;
use crate::model::ModelStructure;
use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;

/// The `format` key of a saved model file (`fdid fit --save`, `Fit.to_json()` of the
/// Python package): a JSON object holding a [`FittedModel`] under `fitted`.
pub const SAVED_FORMAT: &str = "fdid-model";
/// Its `version` key.
pub const SAVED_VERSION: u64 = 1;

/// The summary of a [`Fit`]: model structure `M`, estimate θ̂ and its covariance, noise
/// level and cost. Evaluating [`FittedModel::response`] gives exactly (bit for bit) what
/// the fit's model gives at θ̂, also after a round trip through a serde format that keeps
/// `f64` exactly (e.g. JSON with `serde_json`'s `float_roundtrip`).
///
/// The standard deviation of the response at any ω is that of [`Fit::response_std`]:
/// σ_G(ω)² = Σ_ij Cov_ij Re(∂G/∂θ_i · conj ∂G/∂θ_j).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct FittedModel<T: Real, M> {
    /// The model structure (orders, basis, sample time, delay, noise model structure).
    pub model: M,
    /// The estimate θ̂.
    pub theta: Vec<T>,
    /// Covariance of θ̂ (see [`Fit`]), when it could be computed.
    pub covariance: Option<DMatrix<T>>,
    /// Noise variance λ (known from the data, or λ̂ = V/N).
    pub noise_variance: T,
    /// Whether λ came from the data's noise variances.
    pub noise_known: bool,
    /// Cost V at θ̂.
    pub cost: T,
    /// Number of frequency lines fitted.
    pub lines: usize,
}

impl<T: Real, M: ModelStructure<T> + Clone> FittedModel<T, M> {
    /// The summary of `fit`.
    pub fn of_fit(fit: &Fit<T, M>) -> Self {
        Self {
            model: fit.model().clone(),
            theta: fit.theta().to_vec(),
            covariance: fit.covariance().cloned(),
            noise_variance: fit.noise_variance(),
            noise_known: fit.noise_known(),
            cost: fit.cost(),
            lines: fit.omega().len(),
        }
    }
}

impl<T: Real, M: ModelStructure<T>> FittedModel<T, M> {
    /// Checks a summary read from a file: θ has the model's p entries, all finite; the
    /// covariance is p × p, finite, symmetric and positive semidefinite (its smallest
    /// eigenvalue ≥ −10⁻⁸ times its largest magnitude, to rounding); the noise variance and
    /// the cost are finite and non-negative. (The model structure itself is checked when it
    /// is deserialised.)
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] naming the field and the bad value.
    pub fn check(&self) -> Result<()> {
        let bad = |name: &'static str, value: String, reason: &str| FdidError::InvalidArgument {
            name,
            value,
            reason: reason.into(),
        };
        let p = self.model.n_params();
        if self.theta.len() != p {
            return Err(bad(
                "theta",
                format!("{} entries", self.theta.len()),
                &format!("the model has {p} parameters"),
            ));
        }
        crate::error::check_finite("theta", &self.theta)?;
        for (name, x) in [("noise_variance", self.noise_variance), ("cost", self.cost)] {
            if !(x >= T::zero() && num_traits::Float::is_finite(x)) {
                return Err(bad(name, format!("{x}"), "must be finite and non-negative"));
            }
        }
        let Some(c) = &self.covariance else {
            return Ok(());
        };
        if c.shape() != (p, p) {
            return Err(bad(
                "covariance",
                format!("{}x{}", c.nrows(), c.ncols()),
                &format!("theta has {p} entries"),
            ));
        }
        crate::error::check_finite("covariance", c.as_slice())?;
        let scale = c.iter().fold(T::zero(), |m, x| {
            num_traits::Float::max(m, num_traits::Float::abs(*x))
        });
        let tol = T::lit(1e-8) * scale;
        for i in 0..p {
            for j in 0..i {
                if num_traits::Float::abs(c[(i, j)] - c[(j, i)]) > tol {
                    return Err(bad(
                        "covariance",
                        format!(
                            "entries ({i}, {j}) = {} and ({j}, {i}) = {}",
                            c[(i, j)],
                            c[(j, i)]
                        ),
                        "a covariance is symmetric",
                    ));
                }
            }
        }
        let least = c
            .clone()
            .symmetric_eigenvalues()
            .iter()
            .fold(T::infinity(), |m, x| num_traits::Float::min(m, *x));
        if least < -tol {
            return Err(bad(
                "covariance",
                format!("eigenvalue {least}"),
                "a covariance is positive semidefinite",
            ));
        }
        Ok(())
    }

    /// G(θ̂, ω_k) at the angular frequencies `omega` (rad/s).
    pub fn response(&self, omega: &[T]) -> Vec<Complex<T>> {
        self.model.response(&self.theta, omega)
    }

    /// σ_G(ω_k), the standard deviation of the response at `omega` (rad/s) from the
    /// covariance of θ̂; `None` without a covariance.
    pub fn response_std(&self, omega: &[T]) -> Option<Vec<T>> {
        let cov = self.covariance.as_ref()?;
        let (_, jac) = self.jacobian(omega);
        Some(
            (0..omega.len())
                .map(|k| {
                    let mut v = T::zero();
                    for i in 0..cov.nrows() {
                        for j in 0..cov.ncols() {
                            v += cov[(i, j)] * (jac[(k, i)] * jac[(k, j)].conj()).re;
                        }
                    }
                    num_traits::Float::sqrt(num_traits::Float::max(v, T::zero()))
                })
                .collect(),
        )
    }

    /// Pointwise confidence bounds at `level` (e.g. 0.95) on |G| and on its phase at
    /// `omega` (rad/s), as [`Fit::bounds`] gives them on the data lines: first-order
    /// standard deviations σ_|G|² = aᵀCa with a = Re(conj(G) ∂G/∂θ)/|G| and σ_∠G² = bᵀCb
    /// with b = Im(conj(G) ∂G/∂θ)/|G|², and the normal quantile z = Φ⁻¹((1 + level)/2);
    /// |G| − zσ is floored at 0. `None` without a covariance or for `level` outside
    /// (0, 1).
    pub fn bounds(&self, omega: &[T], level: f64) -> Option<Vec<crate::fit::Bounds<T>>> {
        let cov = self.covariance.as_ref()?;
        if !(level > 0.0 && level < 1.0) {
            return None;
        }
        let z = T::lit(crate::stats::normal_quantile(0.5 + level / 2.0));
        let (g, jac) = self.jacobian(omega);
        let quadratic = |v: &[T]| {
            let mut s = T::zero();
            for i in 0..v.len() {
                for j in 0..v.len() {
                    s += cov[(i, j)] * v[i] * v[j];
                }
            }
            num_traits::Float::sqrt(num_traits::Float::max(s, T::zero()))
        };
        Some(
            g.iter()
                .enumerate()
                .map(|(k, gk)| {
                    let m = gk.norm();
                    let along: Vec<Complex<T>> =
                        jac.row(k).iter().map(|d| gk.conj() * *d).collect();
                    let a: Vec<T> = along.iter().map(|v| v.re / m).collect();
                    let b: Vec<T> = along.iter().map(|v| v.im / (m * m)).collect();
                    let (sm, sp) = (quadratic(&a), quadratic(&b));
                    crate::fit::Bounds {
                        magnitude: (num_traits::Float::max(m - z * sm, T::zero()), m + z * sm),
                        phase: (gk.arg() - z * sp, gk.arg() + z * sp),
                    }
                })
                .collect(),
        )
    }

    /// G and ∂G/∂θ (lines × p) at θ̂ on `omega`.
    fn jacobian(&self, omega: &[T]) -> (Vec<Complex<T>>, DMatrix<Complex<T>>) {
        let zero = Complex::new(T::zero(), T::zero());
        let mut g = vec![zero; omega.len()];
        let mut jac = DMatrix::from_element(omega.len(), self.theta.len(), zero);
        self.model
            .jacobian_into(&self.theta, omega, &mut g, &mut jac);
        (g, jac)
    }
}
