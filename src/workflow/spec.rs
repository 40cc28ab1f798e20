//! The fit of a [`ModelSpec`] reduced to what the detectors and the likelihood-ratio test
//! need.
use crate::data::FrequencyData;
use crate::error::{FdidError, Result};
use crate::estimate::{ModelSpec, RationalFit, Stability};
use crate::fit::Fit;
use crate::model::{Domain, ModelStructure, Output, PolesZeros};
use crate::scalar::Complex;
use nalgebra::DMatrix;
use std::sync::Arc;

/// The result of [`fit_spec`]: the statistics the detectors and the likelihood-ratio test
/// use. Residuals are the normalised r_k = (Y_k − Ŷ_k)/σ_k of the criterion (eq. 23 or 42;
/// with a noise model the innovations).
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct SpecFit {
    /// The spec that was fitted.
    pub spec: ModelSpec,
    /// Number of estimated parameters p (system, delay and noise model).
    pub n_params: usize,
    /// The estimate θ̂ (layout of the fitted model: for a [`crate::model::Rational`] the denominator
    /// and numerator coefficients, then the transient coefficients; then τ for a delay;
    /// then the noise-model coefficients).
    #[cfg_attr(feature = "serde", serde(default))]
    pub theta: Vec<f64>,
    /// The covariance of θ̂ from the fit, (λ/2)(JᵀJ)⁻¹ (first order, McKelvey eqs. 32–34 for
    /// ML), if JᵀJ is invertible. Not serialised.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub covariance: Option<DMatrix<f64>>,
    /// The cost V = Σ|r_k|².
    pub cost: f64,
    /// λ̂ = V/N.
    pub noise_variance: f64,
    /// Whether r is normalised by a given noise level (else λ is estimated).
    pub noise_known: bool,
    /// Degrees of freedom of sample noise variances (periodic records), if any.
    pub variance_dof: Option<usize>,
    /// Cost and whiteness tests.
    pub validation: Validation,
    /// Normalised residuals r_k.
    pub residuals: Vec<Complex<f64>>,
    /// Each line's normaliser c_k = (Y_k − Ŷ_k)/r_k (σ_k for eq. 23 or 42, H_k·g with a
    /// noise model; 1 where r_k = 0).
    pub scale: Vec<Complex<f64>>,
    /// ∂r/∂θ, real-stacked (2N × p, rows Re and Im of line k): −(∂Ŷ_k/∂θ)/c_k (zero
    /// columns for noise-model parameters). Not serialised.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub jacobian: DMatrix<f64>,
    /// Frequencies (rad/s).
    pub omega: Vec<f64>,
    /// The model response Ĝ(ω_k) (including the delay factor).
    pub response: Vec<Complex<f64>>,
    /// The modelled output Ŷ_k = Ĝ U_k + T_k.
    pub output: Vec<Complex<f64>>,
    /// σ_G(ω_k) with σ_G² = E|Ĝ_k − G_k|² (first order, from the covariance), if it exists.
    pub response_std: Option<Vec<f64>>,
    /// Poles of the system part.
    pub poles: Vec<Complex<f64>>,
    /// The estimated delay τ (s) with its standard deviation, for `delay` specs.
    pub delay: Option<(f64, Option<f64>)>,
    /// The fitted rational model of `spec`, `None` for a user's model structure. Not
    /// serialised.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub fit: Option<RationalFit>,
    /// The label of a user's model structure ([`crate::workflow::Workflow::run_model`]),
    /// `None` for a fit of `spec`. For a user model `spec` only carries the delay flag
    /// (`na = nb = 0`, continuous domain) and `poles` is empty.
    #[cfg_attr(feature = "serde", serde(default))]
    pub custom: Option<String>,
}

use crate::validation::Validation;

impl SpecFit {
    /// The scale λ of the normalised residuals: 1 for a known noise level, else
    /// λ̂ = V/(N − p/2) (λ̂ = V/N when there are no degrees of freedom left).
    pub fn residual_scale(&self) -> f64 {
        if self.noise_known {
            return 1.0;
        }
        let dof = self.residuals.len() as f64 - self.n_params as f64 / 2.0;
        if dof > 0.0 {
            self.cost / dof
        } else {
            self.noise_variance
        }
    }

    /// Reduces any fit to what the detectors and the likelihood-ratio test use: the
    /// normalised residuals r_k of the fit's criterion (McKelvey eq. 23 for ML), each line's
    /// normaliser c_k = (Y_k − Ŷ_k)/r_k, the residual Jacobian ∂r/∂θ = −(∂Ŷ/∂θ)/c_k
    /// real-stacked, the response Ĝ and output Ŷ = ĜU + T ([`Output`]), the cost and
    /// validation of the fit. When `spec.delay`, τ is the last system parameter (before
    /// 2·`noise_order` noise-model parameters), as in [`crate::model::Delayed`]. `poles` is left empty
    /// (see [`SpecFit::with_poles`]); `custom` is `None` (see [`SpecFit::with_custom`]).
    ///
    /// # Errors
    /// A θ whose delay index does not exist ([`FdidError::LengthMismatch`], what
    /// `"theta"`).
    pub fn from_fit<M: ModelStructure<f64>>(
        spec: &ModelSpec,
        fit: &Fit<f64, M>,
        data: &FrequencyData<f64>,
    ) -> Result<Self> {
        reduce(spec, data, fit)
    }

    /// The fit with the poles of its system part (used by [`SpecFit::is_stable`] and the
    /// order-increase and transient detectors).
    #[must_use]
    pub fn with_poles(mut self, poles: Vec<Complex<f64>>) -> Self {
        self.poles = poles;
        self
    }

    /// The fit with the rational model it reduces.
    #[must_use]
    pub fn with_fit(mut self, fit: RationalFit) -> Self {
        self.fit = Some(fit);
        self
    }

    /// The fit marked as one of the user's model structure `label`.
    #[must_use]
    pub fn with_custom(mut self, label: &str) -> Self {
        self.custom = Some(label.to_string());
        self
    }

    /// Whether every pole of the system part is stable: |p| < 1 in discrete time,
    /// Re p < 0 in continuous time.
    pub fn is_stable(&self) -> bool {
        match self.spec.domain {
            Domain::Discrete { .. } => self.poles.iter().all(|p| p.norm() < 1.0),
            Domain::Continuous => self.poles.iter().all(|p| p.re < 0.0),
        }
    }

    /// How many poles of the system part sit on the stability boundary
    /// ([`crate::validation::marginal_poles`]: a damping ratio below [`MARGINAL_DAMPING`],
    /// or a pole closer to s = 0 than [`BELOW_BAND`] times the lowest fitted frequency,
    /// an integrator over the band). The stability-constrained ML stops poles there; such
    /// a pole is not one the data determine.
    pub fn marginal_poles(&self) -> usize {
        crate::validation::marginal_poles(&self.poles, self.spec.domain, &self.omega).len()
    }

    /// Whether the residuals are consistent with the noise at level `alpha`: the cost test
    /// (when the noise level is known) and the whiteness test both pass at α/2 each
    /// (Bonferroni, so that a correct model fails with probability at most α).
    pub fn consistent_with_noise(&self, alpha: f64) -> bool {
        let v = &self.validation;
        let level = alpha / 2.0;
        v.cost_p.is_none_or(|p| p >= level) && v.whiteness_p.is_none_or(|p| p >= level)
    }
}

pub use crate::validation::{BELOW_BAND, MARGINAL_DAMPING};

/// Fits `spec` to `data` ([`ModelSpec::fit`], which chooses the strategy) and reduces the
/// fit to what the detectors need, on the lines it was made on ([`RationalFit::lines`]).
///
/// The workflow never works on an unstable model: when the fit of a spec with
/// [`Stability::Free`] is unstable, the spec is refitted with [`Stability::Enforced`]
/// (stable by construction) and that fit is returned, its spec saying so.
///
/// # Errors
/// As [`ModelSpec::fit`].
pub fn fit_spec(spec: &ModelSpec, data: &FrequencyData<f64>) -> Result<SpecFit> {
    let known = MEMO.with_borrow(|memo| {
        memo.as_ref()?
            .iter()
            .find(|e| e.0 == *spec && e.1 == *data)
            .map(|e| e.2.clone())
    });
    if let Some(fit) = known {
        return fit;
    }
    let fit = fit_spec_by(spec, data, |s| s.fit(data));
    MEMO.with_borrow_mut(|memo| {
        if let Some(memo) = memo {
            memo.push(Arc::new((spec.clone(), data.clone(), fit.clone())));
        }
    });
    fit
}

/// The fits of [`fit_spec`] made on this thread inside [`memoised`]: spec, data and
/// outcome (shared, so that a copy for forked work is cheap).
pub(crate) type Memo = Vec<Arc<(ModelSpec, FrequencyData<f64>, Result<SpecFit>)>>;

/// A copy of this thread's memo (`None` outside [`memoised`]), for work forked to other
/// threads ([`with_memo`]).
pub(crate) fn memo_copy() -> Option<Memo> {
    MEMO.with_borrow(Clone::clone)
}

/// Runs `f` with `memo` as this thread's memo (the memo before is restored afterwards);
/// returns the value and the memo as `f` left it.
pub(crate) fn with_memo<R>(memo: Option<Memo>, f: impl FnOnce() -> R) -> (R, Option<Memo>) {
    /// Puts the memo before back when dropped (also on a panic).
    struct Restore(Option<Memo>);
    impl Drop for Restore {
        fn drop(&mut self) {
            MEMO.set(self.0.take());
        }
    }
    let restore = Restore(MEMO.replace(memo));
    let value = f();
    let left = MEMO.replace(None);
    drop(restore);
    (value, left)
}

/// Adds to this thread's memo (if it keeps one) the entries of `entries` it does not
/// hold, in their order.
pub(crate) fn memo_merge(entries: Memo) {
    MEMO.with_borrow_mut(|memo| {
        let Some(memo) = memo else {
            return;
        };
        for e in entries {
            if !memo.iter().any(|m| m.0 == e.0 && m.1 == e.1) {
                memo.push(e);
            }
        }
    });
}

thread_local! {
    /// [`Memo`], kept while a call of [`memoised`] runs on this thread.
    static MEMO: std::cell::RefCell<Option<Memo>> = const { std::cell::RefCell::new(None) };
}

/// Runs `f` with [`fit_spec`] remembering its outcomes on this thread: a spec fitted again
/// on equal data returns the first outcome instead of being refitted (the fit is a
/// deterministic function of the two). The workflow refits the same spec several times —
/// the backward elimination and the revision refit models the forward loop already fitted.
/// Nested calls share the outermost memo, which is dropped when it returns.
pub(crate) fn memoised<R>(f: impl FnOnce() -> R) -> R {
    /// Drops the memo when the call that made it returns (or unwinds).
    struct Forget;
    impl Drop for Forget {
        fn drop(&mut self) {
            MEMO.set(None);
        }
    }
    let outermost =
        MEMO.with_borrow_mut(|memo| memo.is_none() && memo.insert(Vec::new()).is_empty());
    // built only by the outermost call: dropping one forgets the memo
    let _forget = if outermost { Some(Forget) } else { None };
    f()
}

/// [`fit_spec`] started from the poles `poles` (na values, closed under conjugation;
/// [`ModelSpec::fit_from_poles`]: plain ML specs), with the same stability rule.
///
/// # Errors
/// As [`ModelSpec::fit_from_poles`].
pub(crate) fn fit_spec_from_poles(
    spec: &ModelSpec,
    data: &FrequencyData<f64>,
    poles: &[Complex<f64>],
) -> Result<SpecFit> {
    fit_spec_by(spec, data, |s| s.fit_from_poles(data, poles))
}

/// [`fit_spec`] with the delay of a delayed spec started at `tau0` (s) instead of
/// searched ([`ModelSpec::fit_near_delay`]): for the segments of a record whose whole fit
/// gave τ₀.
pub(crate) fn fit_spec_near_delay(
    spec: &ModelSpec,
    data: &FrequencyData<f64>,
    tau0: f64,
) -> Result<SpecFit> {
    fit_spec_by(spec, data, |s| s.fit_near_delay(data, tau0))
}

/// The [`SpecFit`] of `fit(spec)`, refitted with the stability enforced when it is
/// unstable and `spec` leaves stability free.
fn fit_spec_by(
    spec: &ModelSpec,
    data: &FrequencyData<f64>,
    fit: impl Fn(&ModelSpec) -> Result<RationalFit>,
) -> Result<SpecFit> {
    let first = fit(spec)?;
    if spec.stability == Stability::Free && !first.is_stable() {
        let stable = ModelSpec {
            stability: Stability::Enforced,
            ..spec.clone()
        };
        if let Ok(refit) = fit(&stable)
            && let Ok(reduced) = reduce_fit(&stable, data, refit)
        {
            return Ok(reduced);
        }
    }
    reduce_fit(spec, data, first)
}

/// The [`SpecFit`] of the fit `fit` of `spec`.
fn reduce_fit(spec: &ModelSpec, data: &FrequencyData<f64>, fit: RationalFit) -> Result<SpecFit> {
    let lines = fit.lines(data)?;
    let summary = match &fit {
        RationalFit::Plain(f) => summarise(spec, &lines, f),
        RationalFit::Delayed(f) => summarise(spec, &lines, f),
        RationalFit::NoiseModel(f) => summarise(spec, &lines, f),
        RationalFit::DelayedNoiseModel(f) => summarise(spec, &lines, f),
    }?;
    Ok(summary.with_fit(fit))
}

/// Reduces a fit with poles to a [`SpecFit`].
fn summarise<M: ModelStructure<f64> + PolesZeros<f64>>(
    spec: &ModelSpec,
    data: &FrequencyData<f64>,
    fit: &Fit<f64, M>,
) -> Result<SpecFit> {
    Ok(reduce(spec, data, fit)?.with_poles(fit.poles()?))
}

/// Reduces any fit to a [`SpecFit`] without poles.
fn reduce<M: ModelStructure<f64>>(
    spec: &ModelSpec,
    data: &FrequencyData<f64>,
    fit: &Fit<f64, M>,
) -> Result<SpecFit> {
    let model = fit.model();
    let theta = fit.theta();
    let mut out = Output::new(data.len(), model.n_params());
    out.evaluate(model, theta, data, true);
    let residuals = fit.residuals().to_vec();
    if residuals.len() != data.len() {
        return Err(FdidError::LengthMismatch {
            what: "fit residuals",
            expected: data.len(),
            got: residuals.len(),
        });
    }
    let scale: Vec<Complex<f64>> = residuals
        .iter()
        .zip(data.y().iter().zip(&out.yhat))
        .map(|(r, (y, yh))| {
            let e = y - yh;
            if r.norm() > 0.0 && e.norm() > 0.0 {
                e / r
            } else {
                Complex::new(1.0, 0.0)
            }
        })
        .collect();
    let (n, p) = out.dyhat.shape();
    let mut jacobian = DMatrix::zeros(2 * n, p);
    for k in 0..n {
        for j in 0..p {
            let d = -out.dyhat[(k, j)] / scale[k];
            jacobian[(2 * k, j)] = d.re;
            jacobian[(2 * k + 1, j)] = d.im;
        }
    }
    let delay = if spec.delay {
        // the delay is the last parameter of the delayed system (before a noise model)
        let tau_index = theta
            .len()
            .checked_sub(1 + 2 * spec.noise_order.unwrap_or(0))
            .ok_or(FdidError::LengthMismatch {
                what: "theta",
                expected: 1 + 2 * spec.noise_order.unwrap_or(0),
                got: theta.len(),
            })?;
        let std_tau = fit.theta_std().map(|s| s[tau_index]);
        Some((theta[tau_index], std_tau))
    } else {
        None
    };
    Ok(SpecFit {
        spec: spec.clone(),
        n_params: theta.len(),
        theta: theta.to_vec(),
        covariance: fit.covariance().cloned(),
        cost: fit.cost(),
        noise_variance: fit.noise_variance(),
        noise_known: fit.noise_known(),
        variance_dof: data.variance_dof(),
        validation: fit.validation().clone(),
        residuals,
        scale,
        jacobian,
        omega: fit.omega().to_vec(),
        response: out.g.clone(),
        output: out.yhat.clone(),
        response_std: fit.response_std().map(<[f64]>::to_vec),
        poles: Vec::new(),
        delay,
        fit: None,
        custom: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A first-order fit on 1..10 rad/s whose poles are then replaced.
    fn fit_with_poles(poles: &[Complex<f64>]) -> SpecFit {
        let omega: Vec<f64> = (1..=20).map(|k| 0.5 * k as f64).collect();
        let frf = omega
            .iter()
            .map(|w| Complex::new(1.0, 0.0) / Complex::new(2.0, *w))
            .collect();
        let data = FrequencyData::from_frf(omega, frf, None).unwrap();
        let mut fit = fit_spec(&ModelSpec::continuous(1, 0), &data).unwrap();
        fit.poles = poles.to_vec();
        fit
    }

    #[test]
    fn marginal_poles_are_undamped_resonances_and_poles_next_to_zero() {
        let lowest = 0.5;
        let c = Complex::new;
        // determined: a real pole below the band but well away from s = 0, a damped pair
        assert_eq!(fit_with_poles(&[c(-0.1, 0.0)]).marginal_poles(), 0);
        assert_eq!(
            fit_with_poles(&[c(-0.1, 3.0), c(-0.1, -3.0)]).marginal_poles(),
            0
        );
        // a pair with ζ below 10⁻⁶ and a real pole 10⁻⁸ rad/s from the axis (an
        // integrator over 0.5..10 rad/s)
        assert_eq!(
            fit_with_poles(&[c(-1e-7, 3.0), c(-1e-7, -3.0)]).marginal_poles(),
            2
        );
        assert_eq!(fit_with_poles(&[c(-1e-8, 0.0)]).marginal_poles(), 1);
        // the bound is BELOW_BAND ω_lo
        let at = BELOW_BAND * lowest;
        assert_eq!(fit_with_poles(&[c(-0.5 * at, 0.0)]).marginal_poles(), 1);
        assert_eq!(fit_with_poles(&[c(-2.0 * at, 0.0)]).marginal_poles(), 0);
    }

    #[test]
    fn memoised_fits_are_kept_by_spec_and_data_inside_the_scope_only() {
        let omega: Vec<f64> = (1..=20).map(|k| 0.5 * k as f64).collect();
        let data = |gain: f64| {
            let frf = omega
                .iter()
                .map(|w| Complex::new(gain, 0.0) / Complex::new(2.0, *w))
                .collect();
            FrequencyData::from_frf(omega.clone(), frf, None).unwrap()
        };
        let (one, two) = (data(1.0), data(2.0));
        let spec = ModelSpec::continuous(1, 0);
        let kept = || MEMO.with_borrow(|m| m.as_ref().map(Vec::len));
        assert_eq!(kept(), None);
        let first = memoised(|| {
            let first = fit_spec(&spec, &one).unwrap();
            let again = fit_spec(&spec, &one).unwrap();
            assert_eq!((first.cost, &first.theta), (again.cost, &again.theta));
            assert_eq!(kept(), Some(1));
            // other data, another spec: fitted, not looked up
            let other = fit_spec(&spec, &two).unwrap();
            assert!((other.theta[1] / first.theta[1] - 2.0).abs() < 1e-9);
            fit_spec(&ModelSpec::continuous(1, 1), &one).unwrap();
            // a nested scope shares the memo and leaves it in place
            memoised(|| assert_eq!(fit_spec(&spec, &one).unwrap().theta, first.theta));
            assert_eq!(kept(), Some(3));
            first
        });
        assert_eq!(kept(), None);
        assert_eq!(fit_spec(&spec, &one).unwrap().theta, first.theta);
        assert_eq!(kept(), None);
    }
}
