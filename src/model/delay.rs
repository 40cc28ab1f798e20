//! A time delay as a model factor: G(θ, ω) = G_M(θ_M, ω)·e^{−iωτ} (McKelvey section 4,
//! "Continuous time systems"), its starting value from the phase slope, and the end-to-end
//! fit of a delayed rational model.

use super::{ModelStructure, PolesZeros};
use crate::data::FrequencyData;
use crate::error::{FdidError, Result};
use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;
use num_traits::Float;

/// A model `M` followed by a pure time delay τ (s):
///
/// ```text
/// G(θ, ω) = G_M(θ_M, ω) · e^{−iωτ},   θ = [θ_M…, τ]           (McKelvey section 4)
/// ```
///
/// with the analytic Jacobian ∂G/∂θ_M = e^{−iωτ} ∂G_M/∂θ_M and ∂G/∂τ = −iω G. The
/// frequency ω is in rad/s for continuous- and discrete-time inner models alike, so a
/// discrete-time model takes fractional sample delays (τ/Ts not an integer) without change.
///
/// The delay is a finite-dimensional parameter in the frequency domain although it has no
/// finite-dimensional state-space form; the model is nonlinear in τ, so it is fitted by
/// output-error maximum likelihood (McKelvey eq. 23) — see [`Delayed::fit`] and
/// [`crate::estimate::fit_delayed`] — not by the linear criteria.
///
/// **Transient.** An inner model with an input-independent output term T (McKelvey eqs.
/// 4, 9; [`ModelStructure::transient_into`]) keeps it undelayed: Ŷ = G_M e^{−iωτ} U + T.
/// T comes from the initial (and final) state of the inner system, not from the input, so
/// the delay, which acts on the input, does not act on it (∂T/∂τ = 0). The leakage of the
/// delay line itself (the input samples in [−τ, 0) against those in [N·Ts − τ, N·Ts)) is
/// not modelled; it vanishes for periodic excitation.
///
/// **Bounds.** [`Delayed::with_bounds`] restricts τ to [lo, hi] (0 ≤ lo < hi, seconds).
/// τ stays a plain, unconstrained parameter for Levenberg–Marquardt (the trust region sees
/// no kink): the bounds confine the search for the starting value ([`crate::estimate::delay_start`]), and
/// a fitted τ̂ outside them is reported as an error by [`Delayed::fit`] (see
/// [`Delayed::check_delay`]).
///
/// | setting | default | meaning |
/// |---|---|---|
/// | bounds | none | [lo, hi] (s) for τ, 0 ≤ lo < hi |
///
/// ```
/// use fdid::prelude::*;
///
/// // G(s) = 2 e^{−0.3 s} / (s² + 0.4 s + 1), noise free
/// let omega: Vec<f64> = (1..=200).map(|k| 0.02 * k as f64).collect();
/// let frf: Vec<Complex<f64>> = omega
///     .iter()
///     .map(|w| {
///         let s = Complex::new(0.0, *w);
///         Complex::new(2.0, 0.0) / (s * s + s * 0.4 + 1.0) * (-s * 0.3).exp()
///     })
///     .collect();
/// let data = FrequencyData::from_frf(omega, frf, None).unwrap();
/// let model = Delayed::new(Rational::continuous(2, 0, data.omega()).unwrap())
///     .with_bounds(0.0, 2.0)
///     .unwrap();
/// let fit = model.fit(&Pipeline::default(), &data).unwrap();
/// let tau = fit.model().delay(fit.theta()).unwrap();
/// assert!((tau - 0.3).abs() < 1e-9);
/// assert!((fit.gain() - 2.0).abs() < 1e-9);
/// ```
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(try_from = "StoredDelayed<M>"))]
pub struct Delayed<M> {
    pub(crate) inner: M,
    pub(crate) bounds: Option<(f64, f64)>,
}

/// The stored fields of a [`Delayed`], whose bounds [`Delayed::with_bounds`] checks on
/// reading.
#[cfg(feature = "serde")]
#[derive(serde::Deserialize)]
pub struct StoredDelayed<M> {
    inner: M,
    bounds: Option<(f64, f64)>,
}

#[cfg(feature = "serde")]
impl<M> TryFrom<StoredDelayed<M>> for Delayed<M> {
    type Error = crate::error::FdidError;

    fn try_from(s: StoredDelayed<M>) -> crate::error::Result<Self> {
        let model = Delayed::new(s.inner);
        match s.bounds {
            None => Ok(model),
            Some((lo, hi)) => model.with_bounds(lo, hi),
        }
    }
}

impl<M> Delayed<M> {
    /// The model `inner` followed by a delay τ, unbounded.
    pub fn new(inner: M) -> Self {
        Self {
            inner,
            bounds: None,
        }
    }

    /// Restricts τ to [lo, hi] seconds (see the type's docs for what the bounds do).
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] naming the bound when it is not finite or negative,
    /// or naming both when lo ≥ hi.
    pub fn with_bounds(mut self, lo: f64, hi: f64) -> Result<Self> {
        for (name, v) in [("delay lower bound", lo), ("delay upper bound", hi)] {
            if !v.is_finite() {
                return Err(FdidError::InvalidArgument {
                    name,
                    value: format!("{v}"),
                    reason: "a delay bound must be finite".into(),
                });
            }
            if v < 0.0 {
                return Err(FdidError::InvalidArgument {
                    name,
                    value: format!("{v}"),
                    reason: "a delay bound cannot be negative (a causal delay is ≥ 0 s)".into(),
                });
            }
        }
        if !(lo < hi) {
            return Err(FdidError::InvalidArgument {
                name: "delay bounds",
                value: format!("[{lo}, {hi}]"),
                reason: "the lower bound must be below the upper bound".into(),
            });
        }
        self.bounds = Some((lo, hi));
        Ok(self)
    }

    /// The bounds [lo, hi] on τ (s), if any.
    pub fn bounds(&self) -> Option<(f64, f64)> {
        self.bounds
    }

    /// The undelayed model M.
    pub fn inner(&self) -> &M {
        &self.inner
    }

    /// The undelayed model M, by value.
    pub fn into_inner(self) -> M {
        self.inner
    }

    /// Fails when τ is not finite or lies outside the bounds.
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] naming τ.
    pub fn check_delay<T: Real>(&self, tau: T) -> Result<()> {
        let t = tau.to_f64_lossless();
        if !t.is_finite() {
            return Err(FdidError::InvalidArgument {
                name: "delay",
                value: format!("{t} s"),
                reason: "the delay must be finite".into(),
            });
        }
        match self.bounds {
            Some((lo, hi)) if !(t >= lo && t <= hi) => Err(FdidError::InvalidArgument {
                name: "delay",
                value: format!("{t} s"),
                reason: if t < 0.0 && lo >= 0.0 {
                    "the delay is negative: the output leads the input, which no delay \
                     explains"
                        .into()
                } else if t < lo {
                    format!("below the smallest delay allowed, {lo} s")
                } else {
                    format!("above the largest delay allowed, {hi} s")
                },
            }),
            _ => Ok(()),
        }
    }

    /// Clamps τ into the bounds (unchanged without bounds).
    pub(crate) fn clamp<T: Real>(&self, tau: T) -> T {
        match self.bounds {
            Some((lo, hi)) => Float::min(Float::max(tau, T::lit(lo)), T::lit(hi)),
            None => tau,
        }
    }
}

impl<M> Delayed<M> {
    /// τ, the last entry of θ = [θ_M…, τ]; `None` when θ has not `n_params()` entries.
    pub fn delay<T: Real>(&self, theta: &[T]) -> Option<T>
    where
        M: ModelStructure<T>,
    {
        let p = self.inner.n_params();
        if theta.len() == p + 1 {
            Some(theta[p])
        } else {
            None
        }
    }

    /// θ_M, the inner model's parameters (the first `n_params() − 1` entries of θ, or all of
    /// a shorter θ).
    pub fn inner_theta<'a, T: Real>(&self, theta: &'a [T]) -> &'a [T]
    where
        M: ModelStructure<T>,
    {
        &theta[..self.inner.n_params().min(theta.len())]
    }

    /// θ = [θ_M…, τ].
    pub fn theta<T: Real>(inner_theta: &[T], tau: T) -> Vec<T> {
        let mut t = inner_theta.to_vec();
        t.push(tau);
        t
    }
}

/// e^{−iωτ}.
#[inline]
pub(crate) fn delay_factor<T: Real>(omega: T, tau: T) -> Complex<T> {
    let (s, c) = crate::basis::sin_cos(omega * tau);
    Complex::new(c, -s)
}

/// Runs `f` on the first `p` columns of `jac` as an `nrows × p` matrix, sharing the storage
/// (the matrix is column major, so they are its first `nrows·p` entries); the other columns
/// come back zeroed.
fn with_leading_columns<T: Real, R>(
    jac: &mut DMatrix<Complex<T>>,
    p: usize,
    f: impl FnOnce(&mut DMatrix<Complex<T>>) -> R,
) -> R {
    let (n, cols) = jac.shape();
    let zero = Complex::new(T::zero(), T::zero());
    let full = std::mem::replace(jac, DMatrix::zeros(0, 0));
    let mut v: Vec<Complex<T>> = full.data.into();
    v.truncate(n * p);
    let mut lead = DMatrix::from_vec(n, p, v);
    let out = f(&mut lead);
    let mut v: Vec<Complex<T>> = lead.data.into();
    v.resize(n * cols, zero);
    *jac = DMatrix::from_vec(n, cols, v);
    out
}

impl<T: Real, M: ModelStructure<T>> ModelStructure<T> for Delayed<M> {
    /// The inner model's stability ([`ModelStructure::stable_at`]; a delay has no pole).
    fn stable_at(&self, theta: &[T]) -> Option<bool> {
        self.inner.stable_at(self.inner_theta(theta))
    }

    /// The inner model's θ stabilised, τ kept.
    fn stabilised(&self, theta: &[T]) -> Option<Result<Vec<T>>> {
        let inner = self.inner.stabilised(self.inner_theta(theta))?;
        let tau = theta.last().copied();
        Some(inner.map(|mut t| {
            t.extend(tau);
            t
        }))
    }

    fn n_params(&self) -> usize {
        self.inner.n_params() + 1
    }

    fn has_transient(&self) -> bool {
        self.inner.has_transient()
    }

    /// The inner model's map, and 1 for τ.
    fn normalisation_map(&self, output: T, input: T) -> Option<Vec<T>> {
        let mut d = self.inner.normalisation_map(output, input)?;
        d.push(T::one());
        Some(d)
    }

    /// G = G_M(θ_M) e^{−iωτ}.
    fn response_into(&self, theta: &[T], omega: &[T], out: &mut [Complex<T>]) {
        let p = self.inner.n_params();
        self.inner.response_into(&theta[..p], omega, out);
        let tau = theta[p];
        for (w, o) in omega.iter().zip(out.iter_mut()) {
            *o *= delay_factor(*w, tau);
        }
    }

    /// ∂G/∂θ_M = e^{−iωτ} ∂G_M/∂θ_M, ∂G/∂τ = −iω G.
    fn jacobian_into(
        &self,
        theta: &[T],
        omega: &[T],
        g: &mut [Complex<T>],
        jac: &mut DMatrix<Complex<T>>,
    ) {
        let p = self.inner.n_params();
        with_leading_columns(jac, p, |lead| {
            self.inner.jacobian_into(&theta[..p], omega, g, lead)
        });
        let tau = theta[p];
        for (k, w) in omega.iter().enumerate() {
            let d = delay_factor(*w, tau);
            for j in 0..p {
                jac[(k, j)] *= d;
            }
            g[k] *= d;
            jac[(k, p)] = Complex::new(T::zero(), -*w) * g[k];
        }
    }

    /// The stacked rows of [`Delayed::jacobian_into`]'s values times U_k, scaled by s_k,
    /// in one pass after the inner model's ∂G_M/∂θ_M (each value rounded as
    /// `((∂G_M/∂θ_j · e^{−iωτ}) · U_k)·s_k`); false for an inner model with a transient.
    fn stacked_jacobian_into(
        &self,
        theta: &[T],
        omega: &[T],
        u: &[Complex<T>],
        weight: Option<&[T]>,
        g: &mut [Complex<T>],
        jac: &mut DMatrix<T>,
    ) -> bool {
        let (n, p) = (omega.len(), self.inner.n_params());
        let rows = super::stacked_rows::StackedRows::new(omega, u, weight, g, jac, p + 1);
        let Some(rows) = rows.filter(|_| !self.inner.has_transient() && theta.len() == p + 1)
        else {
            return false;
        };
        let zero = Complex::new(T::zero(), T::zero());
        let mut lead = DMatrix::from_element(n, p, zero);
        self.inner.jacobian_into(&theta[..p], omega, g, &mut lead);
        let tau = theta[p];
        let d: Vec<Complex<T>> = omega.iter().map(|w| delay_factor(*w, tau)).collect();
        for (g, d) in g.iter_mut().zip(&d) {
            *g *= *d;
        }
        let mut cols = jac.as_mut_slice().chunks_exact_mut(2 * n);
        for (col, src) in cols.by_ref().take(p).zip(lead.as_slice().chunks_exact(n)) {
            for (k, (out, v)) in col.chunks_exact_mut(2).zip(src).enumerate() {
                rows.write(out, *v * d[k], k);
            }
        }
        if let Some(col) = cols.next() {
            for (k, (out, w)) in col.chunks_exact_mut(2).zip(omega).enumerate() {
                rows.write(out, Complex::new(T::zero(), -*w) * g[k], k);
            }
        }
        true
    }

    /// The inner model's transient T(θ_M), not delayed (∂T/∂τ = 0; see the type's docs).
    fn transient_into(
        &self,
        theta: &[T],
        omega: &[T],
        t: &mut [Complex<T>],
        jac: Option<&mut DMatrix<Complex<T>>>,
    ) -> bool {
        let p = self.inner.n_params();
        match jac {
            None => self.inner.transient_into(&theta[..p], omega, t, None),
            Some(jac) => {
                // the τ column comes back zeroed
                with_leading_columns(jac, p, |lead| {
                    self.inner.transient_into(&theta[..p], omega, t, Some(lead))
                })
            }
        }
    }

    /// The inner model's checks, and at least as many real equations as p_M + 1.
    fn check_data(&self, data: &FrequencyData<T>) -> Result<()> {
        self.inner.check_data(data)?;
        super::check_line_count(self.n_params(), data.len())
    }
}

impl<T: Real, M: ModelStructure<T> + PolesZeros<T>> PolesZeros<T> for Delayed<M> {
    /// The inner model's poles (a delay has none).
    fn poles(&self, theta: &[T]) -> Result<Vec<Complex<T>>> {
        self.inner.poles(self.inner_theta(theta))
    }

    /// The inner model's zeros (a delay has none).
    fn zeros(&self, theta: &[T]) -> Result<Vec<Complex<T>>> {
        self.inner.zeros(self.inner_theta(theta))
    }

    /// The inner model's gain (|e^{−iωτ}| = 1).
    fn gain(&self, theta: &[T]) -> T {
        self.inner.gain(self.inner_theta(theta))
    }
}

/// The data with a delay τ (s) taken out of the output: Y_k e^{iω_kτ}, so that a model
/// G_M fitted to them gives G_M e^{−iωτ} for the original data. U and the variances are
/// unchanged; the output–input covariance turns with Y (cov_yu e^{iωτ}).
///
/// # Errors
/// [`FdidError::NonFinite`] when τ is not finite.
pub fn remove_delay<T: Real>(data: &FrequencyData<T>, tau: T) -> Result<FrequencyData<T>> {
    crate::error::check_finite("delay", &[tau])?;
    let turn: Vec<Complex<T>> = data
        .omega()
        .iter()
        .map(|w| delay_factor(*w, tau).conj())
        .collect();
    let y = data.y().iter().zip(&turn).map(|(y, d)| *y * *d).collect();
    let noise = data.noise().map(|n| {
        let mut n = n.clone();
        for (c, d) in n.cov_yu.iter_mut().zip(&turn) {
            *c *= *d;
        }
        n
    });
    Ok(FrequencyData::from_parts_unchecked(
        data.omega().to_vec(),
        y,
        data.u().to_vec(),
        noise,
        data.ts(),
    ))
}
