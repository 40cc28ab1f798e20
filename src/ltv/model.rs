//! The time-varying ODE model structure (Lataire–Pintelon eqs. 1–3) and its frozen
//! instantaneous system (eq. 4).

use super::basis::{FrequencyBasis, TimeBasis};
use crate::error::{FdidError, Result};
use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;
use num_traits::Float;

/// A linear ODE whose coefficients are polynomials in time (Lataire–Pintelon eqs. 1–3):
///
/// ```text
/// Σ_{n=0}^{N_α} Σ_{p=0}^{N_p} α̃ₙ,ₚ b_p(t) Ψₙ{y}(t) = Σ_{n=0}^{N_β} Σ_{p=0}^{N_p} β̃ₙ,ₚ b_p(t) Ψₙ{u}(t)
/// ```
///
/// with a time basis b_p ([`TimeBasis`]) and a frequency basis Ψₙ of polynomial derivative
/// operators ([`FrequencyBasis`]). With monomials on both sides this is eq. 1 with
/// αₙ(t) = Σ_p αₙ,ₚ tᵖ (eq. 2).
///
/// The estimator ([`LtvOde::fit`], eq. 19) also fits a transient + alias polynomial
/// I(s_k) = Σ_{m=0}^{N_tr} γ_m Φ_m(ω_k) (eqs. 11, 18), in the Legendre form of eq. 20
/// scaled to the highest frequency of the band, so that its coefficients are real.
///
/// # Parameters
/// θ = [α̃₀,₀ … α̃₀,N_p, α̃₁,₀ … α̃_{N_α,N_p}, β̃₀,₀ … β̃_{N_β,N_p}, γ₀ … γ_{N_tr}]
/// (order n major, time index p minor), the solution of K θ = 0 with
/// K = [K_Y, −K_U, Φ] (eq. 11).
///
/// # Identifiability
/// The orders must not exceed the system's: an ODE multiplied by any polynomial c(t) of
/// order N_p − N_p,true is the same system, so an N_p above the true one leaves a null
/// space of dimension N_p − N_p,true + 1 (the frozen FRF B/A is still right wherever
/// c(t*) ≠ 0, but θ is not unique); likewise for N_α, N_β in s.
///
/// # Settings
/// | setting | default | meaning |
/// |---|---|---|
/// | `n_alpha`, `n_beta`, `n_p` | — | orders N_α, N_β of the ODE and N_p of its coefficients |
/// | time basis | [`TimeBasis::Legendre`] | b_p(t) |
/// | frequency basis | [`FrequencyBasis::Monomial`] | Ψₙ(s); [`FrequencyBasis::Legendre`] with ω_max at the band edge is the paper's robust choice |
/// | transient order | max(N_α, N_β) − 1 (none when both are 0) | N_tr, `None` for no transient polynomial |
///
/// # Example
/// A noise-free LTI case (N_p = 0): G(s) = 2/(s² + 0.4 s + 1) driven by a periodic
/// multisine, so y is exactly the steady-state response.
/// ```
/// use fdid::ltv::{FrequencyBasis, Lines, LtvOde};
/// use fdid::prelude::*;
///
/// let (n, ts) = (256usize, 0.1f64);
/// let g = |w: f64| {
///     let s = Complex::new(0.0, w);
///     Complex::new(2.0, 0.0) / (s * s + s * 0.4 + 1.0)
/// };
/// let (mut u, mut y) = (vec![0.0; n], vec![0.0; n]);
/// for k in 1..=40 {
///     let w = std::f64::consts::TAU * k as f64 / (n as f64 * ts);
///     let phase = 0.7 * (k * k) as f64;
///     for t in 0..n {
///         let e = Complex::from_polar(1.0, w * t as f64 * ts + phase);
///         u[t] += e.re;
///         y[t] += (g(w) * e).re;
///     }
/// }
/// let data = TimeData::new(u, y, ts).unwrap();
/// let band = Lines::band(0.0, 40.0 / (n as f64 * ts));
/// let model = LtvOde::new(2, 0, 0)
///     .with_frequency_basis(FrequencyBasis::legendre(10.0).unwrap());
/// let fit = model.fit(&data, &band).unwrap();
/// let frozen = fit.instantaneous(0.0);
/// let g_hat = frozen.frf(&[1.3]);
/// assert!((g_hat[0] - g(1.3)).norm() < 1e-9);
/// let mut poles = frozen.poles().unwrap();
/// poles.sort_by(|a, b| a.im.partial_cmp(&b.im).unwrap());
/// assert!((poles[1] - Complex::new(-0.2, 0.96f64.sqrt())).norm() < 1e-9);
/// ```
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct LtvOde<T> {
    n_alpha: usize,
    n_beta: usize,
    n_p: usize,
    time_basis: TimeBasis,
    frequency_basis: FrequencyBasis<T>,
    transient: Option<usize>,
}

impl<T: Real> LtvOde<T> {
    /// The ODE of orders N_α (output), N_β (input), with coefficients of order N_p in t,
    /// with the default bases and transient order of the settings table.
    pub fn new(n_alpha: usize, n_beta: usize, n_p: usize) -> Self {
        let m = n_alpha.max(n_beta);
        Self {
            n_alpha,
            n_beta,
            n_p,
            time_basis: TimeBasis::default(),
            frequency_basis: FrequencyBasis::default(),
            transient: m.checked_sub(1),
        }
    }

    /// Sets the time basis b_p(t).
    #[must_use]
    pub fn with_time_basis(mut self, basis: TimeBasis) -> Self {
        self.time_basis = basis;
        self
    }

    /// Sets the frequency basis Ψₙ(s) (validated at fit time).
    #[must_use]
    pub fn with_frequency_basis(mut self, basis: FrequencyBasis<T>) -> Self {
        self.frequency_basis = basis;
        self
    }

    /// Sets the order N_tr of the transient + alias polynomial (eqs. 11, 18); `None` leaves
    /// it out (the paper's case A).
    #[must_use]
    pub fn with_transient(mut self, order: Option<usize>) -> Self {
        self.transient = order;
        self
    }

    /// N_α, the order of the output side.
    pub fn n_alpha(&self) -> usize {
        self.n_alpha
    }

    /// N_β, the order of the input side.
    pub fn n_beta(&self) -> usize {
        self.n_beta
    }

    /// N_p, the order in t of every coefficient αₙ(t), βₙ(t).
    pub fn n_p(&self) -> usize {
        self.n_p
    }

    /// The time basis.
    pub fn time_basis(&self) -> TimeBasis {
        self.time_basis
    }

    /// The frequency basis.
    pub fn frequency_basis(&self) -> FrequencyBasis<T> {
        self.frequency_basis
    }

    /// N_tr, the order of the transient polynomial (`None`: left out).
    pub fn transient_order(&self) -> Option<usize> {
        self.transient
    }

    /// Number of ODE coefficients (N_α + 1 + N_β + 1)(N_p + 1).
    pub fn n_ode_params(&self) -> usize {
        (self.n_alpha + 1 + self.n_beta + 1) * (self.n_p + 1)
    }

    /// Number of transient coefficients N_tr + 1 (0 without the polynomial).
    pub fn n_transient_params(&self) -> usize {
        self.transient.map_or(0, |m| m + 1)
    }

    /// Length of θ: ODE plus transient coefficients (eq. 11).
    pub fn n_params(&self) -> usize {
        self.n_ode_params() + self.n_transient_params()
    }

    /// Index of α̃ₙ,ₚ in θ.
    pub fn alpha_index(&self, n: usize, p: usize) -> usize {
        n * (self.n_p + 1) + p
    }

    /// Index of β̃ₙ,ₚ in θ.
    pub fn beta_index(&self, n: usize, p: usize) -> usize {
        (self.n_alpha + 1 + n) * (self.n_p + 1) + p
    }

    /// Index of the transient coefficient γ_m in θ.
    pub fn transient_index(&self, m: usize) -> usize {
        self.n_ode_params() + m
    }

    /// Checks the settings that do not depend on the data.
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] for a Legendre frequency basis whose ω_max is not
    /// positive and finite.
    pub fn validate(&self) -> Result<()> {
        self.frequency_basis.validate()
    }

    /// The coefficients of the instantaneous system at t* (eq. 4) in the Ψ basis:
    /// aₙ(t*) = Σ_p α̃ₙ,ₚ b_p(t*) and bₙ(t*) = Σ_p β̃ₙ,ₚ b_p(t*), on a record of length
    /// `record` = T (s). `theta` must have [`LtvOde::n_params`] entries (or at least the
    /// ODE coefficients).
    pub fn frozen_coefficients(&self, theta: &[T], t: T, record: T) -> (Vec<T>, Vec<T>) {
        let mut b = vec![T::zero(); self.n_p + 1];
        self.time_basis.eval_into(t, record, &mut b);
        let side = |count: usize, index: &dyn Fn(usize, usize) -> usize| -> Vec<T> {
            (0..count)
                .map(|n| {
                    b.iter()
                        .enumerate()
                        .fold(T::zero(), |acc, (p, bp)| acc + theta[index(n, p)] * *bp)
                })
                .collect()
        };
        (
            side(self.n_alpha + 1, &|n, p| self.alpha_index(n, p)),
            side(self.n_beta + 1, &|n, p| self.beta_index(n, p)),
        )
    }

    /// The monomial form of eqs. 1–2: αₙ,ₚ and βₙ,ₚ such that
    /// αₙ(t) = Σ_p αₙ,ₚ tᵖ multiplies dⁿy/dtⁿ (t in s, s in rad/s), from θ in this model's
    /// bases, on a record of length `record` = T (s). Exact in exact arithmetic; monomial
    /// coefficients of long records or high orders are badly scaled, so use them for
    /// display.
    pub fn to_monomial(&self, theta: &[T], record: T) -> MonomialCoefficients<T> {
        let ct = self
            .time_basis
            .monomial_coefficients(self.n_p, record.to_f64_lossless());
        let nmax = self.n_alpha.max(self.n_beta);
        let cf = self.frequency_basis.monomial_coefficients(nmax, T::one());
        let convert = |count: usize, index: &dyn Fn(usize, usize) -> usize| {
            let mut out = vec![vec![T::zero(); self.n_p + 1]; count];
            for n in 0..count {
                for p in 0..=self.n_p {
                    let c = theta[index(n, p)];
                    for (m, cm) in cf[n].iter().enumerate() {
                        for (q, cq) in ct[p].iter().enumerate() {
                            out[m][q] += c * *cm * T::lit(*cq);
                        }
                    }
                }
            }
            out
        };
        MonomialCoefficients {
            alpha: convert(self.n_alpha + 1, &|n, p| self.alpha_index(n, p)),
            beta: convert(self.n_beta + 1, &|n, p| self.beta_index(n, p)),
        }
    }
}

/// The ODE coefficients in the monomial form of eqs. 1–2: `alpha[n][p]` = αₙ,ₚ multiplies
/// tᵖ dⁿy/dtⁿ, `beta[n][p]` = βₙ,ₚ multiplies tᵖ dⁿu/dtⁿ (t in s).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct MonomialCoefficients<T> {
    /// αₙ,ₚ, indexed `[n][p]`.
    pub alpha: Vec<Vec<T>>,
    /// βₙ,ₚ, indexed `[n][p]`.
    pub beta: Vec<Vec<T>>,
}

/// The instantaneous (frozen) LTI system at a time t* (Lataire–Pintelon eq. 4):
/// A(s) = Σₙ aₙ Ψₙ(s), B(s) = Σₙ bₙ Ψₙ(s) with aₙ = αₙ(t*), bₙ = βₙ(t*) in the Ψ basis,
/// and G_{t*}(s) = B(s)/A(s).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct InstantaneousModel<T> {
    /// The time t* (s).
    pub t: T,
    /// a₀ … a_{N_α}: denominator coefficients in the Ψ basis.
    pub alpha: Vec<T>,
    /// b₀ … b_{N_β}: numerator coefficients in the Ψ basis.
    pub beta: Vec<T>,
    /// The frequency basis Ψ.
    pub basis: FrequencyBasis<T>,
    /// Frequency scale ω_s (rad/s) used to condition the root finding: roots are computed
    /// in z = s/ω_s.
    pub scale: T,
}

impl<T: Real> InstantaneousModel<T> {
    /// The frozen FRF G_{t*}(jω) = B(jω)/A(jω) at the angular frequencies `omega` (rad/s).
    pub fn frf(&self, omega: &[T]) -> Vec<Complex<T>> {
        let d = self.alpha.len().max(self.beta.len());
        let mut psi = vec![Complex::new(T::zero(), T::zero()); d];
        omega
            .iter()
            .map(|w| {
                self.basis.eval_into(*w, &mut psi);
                let dot = |c: &[T]| {
                    c.iter()
                        .zip(&psi)
                        .fold(Complex::new(T::zero(), T::zero()), |a, (c, p)| a + *p * *c)
                };
                dot(&self.beta) / dot(&self.alpha)
            })
            .collect()
    }

    /// Ascending monomial coefficients in s (rad/s) of A(s) = Σₙ αₙ(t*) sⁿ (eq. 4).
    pub fn alpha_monomial(&self) -> Vec<T> {
        to_powers(&self.basis, &self.alpha, T::one())
    }

    /// Ascending monomial coefficients in s (rad/s) of B(s) = Σₙ βₙ(t*) sⁿ (eq. 4).
    pub fn beta_monomial(&self) -> Vec<T> {
        to_powers(&self.basis, &self.beta, T::one())
    }

    /// Instantaneous poles: the roots of A(s) (rad/s), from the companion matrix of A in
    /// z = s/ω_s. Leading coefficients below 8ε‖a‖ are dropped (the degree falls).
    ///
    /// # Errors
    /// [`FdidError::Numerical`] for non-finite coefficients, [`FdidError::NotConverged`]
    /// if the eigenvalue iteration fails.
    pub fn poles(&self) -> Result<Vec<Complex<T>>> {
        roots_scaled(&to_powers(&self.basis, &self.alpha, self.scale), self.scale)
    }

    /// Instantaneous zeros: the roots of B(s) (rad/s), as [`InstantaneousModel::poles`].
    ///
    /// # Errors
    /// As [`InstantaneousModel::poles`].
    pub fn zeros(&self) -> Result<Vec<Complex<T>>> {
        roots_scaled(&to_powers(&self.basis, &self.beta, self.scale), self.scale)
    }
}

/// Coefficients of Σₙ cₙ Ψₙ(s) in powers of z = s/scale.
fn to_powers<T: Real>(basis: &FrequencyBasis<T>, c: &[T], scale: T) -> Vec<T> {
    if c.is_empty() {
        return vec![];
    }
    let d = basis.monomial_coefficients(c.len() - 1, scale);
    let mut out = vec![T::zero(); c.len()];
    for (cn, row) in c.iter().zip(&d) {
        for (o, v) in out.iter_mut().zip(row) {
            *o += *cn * *v;
        }
    }
    out
}

/// Roots of Σ e_m z^m, times `scale`.
fn roots_scaled<T: Real>(e: &[T], scale: T) -> Result<Vec<Complex<T>>> {
    if e.iter().any(|v| !Float::is_finite(*v)) {
        return Err(FdidError::Numerical {
            what: "instantaneous polynomial coefficients are not finite".into(),
        });
    }
    let norm = Float::sqrt(e.iter().fold(T::zero(), |a, v| a + *v * *v));
    let tol = norm * T::default_epsilon() * T::lit(8.0);
    let mut n = e.len();
    while n > 0 && Float::abs(e[n - 1]) <= tol {
        n -= 1;
    }
    if n <= 1 {
        return Ok(vec![]);
    }
    let d = n - 1;
    let lead = e[d];
    let mut m = DMatrix::<T>::zeros(d, d);
    for k in 1..d {
        m[(k, k - 1)] = T::one();
    }
    for k in 0..d {
        m[(k, d - 1)] = -e[k] / lead;
    }
    let ev = crate::roots::eigenvalues(m)?;
    Ok(ev
        .iter()
        .map(|v| Complex::new(v.re * scale, v.im * scale))
        .collect())
}
