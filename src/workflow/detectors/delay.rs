use crate::stats::erfc;
use crate::workflow::finding::{Context, Detail, Detector, Effect, Finding, residual_power};
use crate::workflow::spec::SpecFit;
use crate::{Complex, FrequencyData};
use nalgebra::{DMatrix, DVector};

/// A linear phase trend of Y/(ĜU) in ω: a missing delay e^{−iωτ}.
///
/// A small extra delay δ changes the output by Ĝ U (e^{−iωδ} − 1) ≈ −iω δ Ĝ U, so the
/// normalised residual is r_k ≈ δ a_k with a_k = −iω_k Ĝ_k U_k/σ_k: the weighted LS of the
/// phase arg(Y_k/(Ĝ_k U_k)) against ω_k with phase variance σ_k²/(2|Ĝ_k U_k|²) (McKelvey
/// eq. 23 linearised in τ), c_k the line's normaliser. The part of a that the model's own
/// parameters can produce is removed (a⊥ = (I − P_J) a, P_J the projector on the columns of
/// the residual Jacobian J, from its SVD): the score (Lagrange-multiplier) test of an
/// added delay. Estimate δ̂ = a⊥ᵀr/‖a⊥‖², var δ̂ = μλ/(2‖a⊥‖²) (real-stacked; μ = E|r_k|²
/// under the null, λ = 1 for a known noise level, else λ̂ = V/(N − p/2)); statistic
/// t = δ̂/std δ̂, two-sided p = erfc(|t|/√2) (Student's t with 2N − p degrees of
/// freedom when λ is estimated).
///
/// Proposal: the same spec with `delay = true`; detail: `slope` (δ̂, s), `slope_std`, `t`.
#[derive(Debug, Clone, Copy, Default)]
pub struct TimeDelay;

impl Detector for TimeDelay {
    fn effect(&self) -> Effect {
        Effect::TimeDelay
    }

    fn detect(&self, data: &FrequencyData<f64>, fit: &SpecFit, _ctx: &Context) -> Option<Finding> {
        if fit.spec.delay {
            return None;
        }
        let (power, mean, _) = residual_power(fit);
        let lambda = if fit.noise_known {
            1.0
        } else {
            fit.residuals
                .iter()
                .zip(&power)
                .find(|(r, _)| r.norm_sqr() > 0.0)
                .map(|(r, p)| r.norm_sqr() / p)?
        };
        // a_k = −iω_k Ĝ_k U_k / c_k, real-stacked, projected off the model's Jacobian
        let n = fit.residuals.len();
        let mut a = DVector::<f64>::zeros(2 * n);
        let mut r = DVector::<f64>::zeros(2 * n);
        for k in 0..n {
            let gu = fit.response[k] * data.u()[k];
            let v = Complex::new(0.0, -fit.omega[k]) * gu / fit.scale[k];
            a[2 * k] = v.re;
            a[2 * k + 1] = v.im;
            r[2 * k] = fit.residuals[k].re;
            r[2 * k + 1] = fit.residuals[k].im;
        }
        let a = project_off(&fit.jacobian, a);
        let num = a.dot(&r);
        let den = a.norm_squared();
        if !(den > 0.0) {
            return None;
        }
        let slope = num / den;
        let std = (mean * lambda / (2.0 * den)).sqrt();
        let t = slope / std;
        let p_value = two_sided_p(t, fit);
        let proposal = crate::workflow::ModelSpec {
            delay: true,
            ..fit.spec.clone()
        };
        Some(Finding {
            effect: Effect::TimeDelay,
            statistic: t,
            p_value,
            detail: Detail::default()
                .with("slope", slope)
                .with("slope_std", std)
                .with("t", t),
            proposal,
        })
    }
}

/// (I − P_J) a with P_J the orthogonal projector on the column space of `j` (SVD of the
/// column-scaled J, singular values below 1e-10 of the largest dropped).
pub(crate) fn project_off(j: &DMatrix<f64>, a: DVector<f64>) -> DVector<f64> {
    if j.ncols() == 0 || j.nrows() != a.len() {
        return a;
    }
    let mut js = j.clone();
    for mut c in js.column_iter_mut() {
        let norm = c.norm();
        if norm > 0.0 {
            c /= norm;
        }
    }
    let svd = js.svd(true, false);
    let Some(u) = svd.u else {
        return a;
    };
    let smax = svd.singular_values.max();
    let mut out = a.clone();
    for (i, s) in svd.singular_values.iter().enumerate() {
        if *s > 1e-10 * smax {
            let col = u.column(i);
            let c = col.dot(&a);
            out -= col * c;
        }
    }
    out
}

/// Two-sided p-value of a score statistic t: erfc(|t|/√2) from the normal when the noise
/// level is known; with λ̂ estimated, Student's t with ν = 2N − p degrees of freedom,
/// P(|T| > |t|) = P(F(1, ν) > t²).
pub(crate) fn two_sided_p(t: f64, fit: &SpecFit) -> f64 {
    let nu = 2 * fit.residuals.len();
    if fit.noise_known || nu <= fit.n_params {
        erfc(t.abs() / std::f64::consts::SQRT_2)
    } else {
        crate::workflow::lrt::f_sf(t * t, 1.0, (nu - fit.n_params) as f64)
    }
}
