//! The score (Lagrange-multiplier) test of one added parameter, shared by the detectors
//! whose effect enters the residual linearly at first order.

use crate::scalar::Complex;
use crate::stats::erfc;
use crate::workflow::finding::{noise_scale, residual_power};
use crate::workflow::spec::SpecFit;
use nalgebra::{DMatrix, DVector};

/// The score test of a parameter β whose normalised output derivative is `direction`
/// (one complex value per line, d_k = ∂Ŷ_k/∂β / c_k): with d⊥ = (I − P_J)d real-stacked
/// (P_J the projector on the model's residual Jacobian), β̂ = d⊥ᵀr/‖d⊥‖²,
/// var β̂ = μλ/(2‖d⊥‖²) (μ = E|r_k|² under the null, λ the residual scale), t = β̂/std β̂.
pub(crate) struct ScoreTest {
    /// β̂.
    pub estimate: f64,
    /// Standard deviation of β̂.
    pub std: f64,
    /// t = β̂/std.
    pub t: f64,
    /// Two-sided p-value of t.
    pub p_value: f64,
}

impl ScoreTest {
    /// The test on `fit`, or `None` when the direction vanishes once projected.
    pub(crate) fn new(fit: &SpecFit, direction: &[Complex<f64>]) -> Option<Self> {
        let n = fit.residuals.len();
        let mut d = DVector::<f64>::zeros(2 * n);
        let mut r = DVector::<f64>::zeros(2 * n);
        for k in 0..n {
            d[2 * k] = direction[k].re;
            d[2 * k + 1] = direction[k].im;
            r[2 * k] = fit.residuals[k].re;
            r[2 * k + 1] = fit.residuals[k].im;
        }
        let d = project_off(&fit.jacobian, d);
        let den = d.norm_squared();
        if !(den > 0.0) || !den.is_finite() {
            return None;
        }
        let (_, mean, _) = residual_power(fit);
        let estimate = d.dot(&r) / den;
        let std = (mean * noise_scale(fit) / (2.0 * den)).sqrt();
        let t = estimate / std;
        Some(Self {
            estimate,
            std,
            t,
            p_value: two_sided_p(t, fit),
        })
    }
}

/// Two-sided p-value of t: from the normal distribution for a known noise level, else
/// from Student's t with 2N − p degrees of freedom (as F(1, 2N − p) of t²).
pub(crate) fn two_sided_p(t: f64, fit: &SpecFit) -> f64 {
    let nu = 2 * fit.residuals.len();
    if fit.noise_known || nu <= fit.n_params {
        erfc(t.abs() / std::f64::consts::SQRT_2)
    } else {
        crate::workflow::lrt::f_sf(t * t, 1.0, (nu - fit.n_params) as f64)
    }
}

/// An orthonormal basis of the column space of `j` (SVD of the column-scaled J, singular
/// values below 1e-10 of the largest dropped); `None` for an empty J or a failed SVD.
pub(crate) fn column_space(j: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    if j.ncols() == 0 {
        return None;
    }
    let mut js = j.clone();
    for mut c in js.column_iter_mut() {
        let norm = c.norm();
        if norm > 0.0 {
            c /= norm;
        }
    }
    // bounded iterations: a J with non-finite entries fails instead of looping
    let iterations = 100 * js.ncols().max(10);
    let svd = crate::linalg::try_svd(js, true, false, iterations)?;
    let u = svd.u?;
    let smax = svd.singular_values.max();
    let keep: Vec<usize> = (0..svd.singular_values.len())
        .filter(|i| svd.singular_values[*i] > 1e-10 * smax)
        .collect();
    Some(u.select_columns(&keep))
}

/// (I − P_J) a with P_J the orthogonal projector on the column space of `j`
/// ([`column_space`]).
pub(crate) fn project_off(j: &DMatrix<f64>, a: DVector<f64>) -> DVector<f64> {
    if j.nrows() != a.len() {
        return a;
    }
    let Some(q) = column_space(j) else {
        return a;
    };
    let mut out = a.clone();
    for col in q.column_iter() {
        let c = col.dot(&a);
        out -= col * c;
    }
    out
}
