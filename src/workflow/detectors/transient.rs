use crate::data::FrequencyData;
use crate::model::Domain;
use crate::scalar::Complex;
use crate::stats::chi2_sf;
use crate::workflow::finding::{
    Context, Detail, DetailFields, Detector, Effect, Finding, NamedValues, residual_power,
};
use crate::workflow::lrt::f_sf;
use crate::workflow::spec::SpecFit;
use nalgebra::{DMatrix, DVector};

/// A smooth residual of a non-periodic record: the missing transient term T = I/A.
///
/// The leakage of a non-periodic record adds T(z) = I(z⁻¹)/A(z⁻¹) to Y = GU (McKelvey
/// eq. 1 with the record's initial and final states); on the fitted model the normalised
/// residual then holds r_k ≈ Σ_j c_j z_k^{−j}/(Â(z_k⁻¹) σ_k), j = 0 … m,
/// m = max(na, nb), c_j complex, Â from the fitted poles (z = e^{iωts}). The regressors
/// are projected off the model's residual Jacobian (a score test: what the fitted
/// parameters can absorb is not counted); the real-stacked LS projection P r onto these
/// q = 2(m + 1) regressors (QR) gives the statistic
/// 2‖Pr‖²/μ ~ χ²(q) with known noise, or
/// F = (‖Pr‖²/q)/((‖r‖² − ‖Pr‖²)/(2N − p − q)) ~ F(q, 2N − p − q) with the noise level
/// estimated. Applies only to non-periodic time records without a transient term.
///
/// Proposal: `transient = true`; detail: [`TransientDetail`].
#[derive(Debug, Clone, Copy, Default)]
pub struct Transient;

impl Detector for Transient {
    fn effect(&self) -> Effect {
        Effect::Transient
    }

    fn detect(&self, data: &FrequencyData<f64>, fit: &SpecFit, ctx: &Context) -> Option<Finding> {
        if ctx.periodic || !ctx.time_record || fit.spec.transient {
            return None;
        }
        let (ts, discrete) = match fit.spec.domain {
            Domain::Discrete { ts } => (ts, true),
            Domain::Continuous => (data.ts()?, false),
        };
        let poles: Vec<Complex<f64>> = fit
            .poles
            .iter()
            .map(|p| if discrete { *p } else { (*p * ts).exp() })
            .collect();
        let n = fit.residuals.len();
        let m = fit.spec.na.max(fit.spec.nb);
        let q = 2 * (m + 1);
        if 2 * n <= fit.n_params + q {
            return None;
        }
        let mut x = DMatrix::<f64>::zeros(2 * n, q);
        let mut r = DVector::<f64>::zeros(2 * n);
        for k in 0..n {
            let zinv = Complex::new(0.0, -fit.omega[k] * ts).exp();
            let a = poles.iter().fold(Complex::new(1.0, 0.0), |s, p| {
                s * (Complex::new(1.0, 0.0) - p * zinv)
            });
            let base = Complex::new(1.0, 0.0) / (a * fit.scale[k]);
            let mut zj = Complex::new(1.0, 0.0);
            for j in 0..=m {
                let b = zj * base;
                x[(2 * k, 2 * j)] = b.re;
                x[(2 * k + 1, 2 * j)] = b.im;
                x[(2 * k, 2 * j + 1)] = -b.im;
                x[(2 * k + 1, 2 * j + 1)] = b.re;
                zj *= zinv;
            }
            r[2 * k] = fit.residuals[k].re;
            r[2 * k + 1] = fit.residuals[k].im;
        }
        // remove what the model's own parameters produce (score test), scale the columns
        for j in 0..q {
            let c = super::score::project_off(&fit.jacobian, x.column(j).into_owned());
            x.set_column(j, &c);
        }
        for mut c in x.column_iter_mut() {
            let norm = c.norm();
            if norm > 0.0 {
                c /= norm;
            }
        }
        let qmat = x.qr().q();
        let explained = (qmat.transpose() * &r).norm_squared();
        let total = r.norm_squared();
        let (statistic, p_value) = if fit.noise_known {
            let (_, mean, _) = residual_power(fit);
            let s = 2.0 * explained / mean;
            (s, chi2_sf(s, q as f64))
        } else {
            let d2 = (2 * n - fit.n_params - q) as f64;
            let rest = (total - explained).max(f64::MIN_POSITIVE);
            let f = (explained / q as f64) / (rest / d2);
            (f, f_sf(f, q as f64, d2))
        };
        let proposal = crate::workflow::ModelSpec {
            transient: true,
            ..fit.spec.clone()
        };
        Some(Finding {
            effect: Effect::Transient,
            statistic,
            p_value,
            detail: Detail::Transient(TransientDetail { explained, dof: q }),
            proposal,
        })
    }
}

/// The detail of a [`Transient`] finding.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TransientDetail {
    /// The residual power the transient regressors explain, ‖Pr‖², named `explained`.
    pub explained: f64,
    /// The number q of real regressors, named `dof`.
    pub dof: usize,
}

impl DetailFields for TransientDetail {
    fn entries(&self) -> Vec<(&'static str, f64)> {
        vec![("explained", self.explained), ("dof", self.dof as f64)]
    }

    fn take_from(values: &mut NamedValues) -> Option<Self> {
        Some(Self {
            explained: values.take("explained")?,
            dof: values.take_count("dof")?,
        })
    }
}
