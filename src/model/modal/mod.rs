//! Continuous-time models in pole–residue (modal) form, fitted to sampled data either in
//! continuous time (band-limited excitation, McKelvey eqs. 9–10) or through their
//! zero-order-hold (ZOH) sampled equivalent (piecewise-constant excitation, section 2.3 with
//! eqs. 4–5), with the transient of a finite, non-periodic record as an extra output term.

mod start;

use super::{Domain, ModelStructure, PolesZeros};
use crate::basis::PolyBasis;
use crate::data::FrequencyData;
use crate::error::{FdidError, Result};
use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;
use num_traits::Float;

/// A continuous-time model in pole–residue (modal) form,
///
/// ```text
/// G_c(s) = d + Σ_real rᵢ/(s − pᵢ) + Σ_pairs [rⱼ/(s − pⱼ) + r̄ⱼ/(s − p̄ⱼ)],
/// ```
///
/// with `n_real` real poles, `n_pairs` complex-conjugate pairs and an optional direct term
/// d, evaluated in its [`Domain`]:
/// - [`Domain::Continuous`]: G_c at s = iω, the route for band-limited (e.g. multisine)
///   excitation (McKelvey eq. 9);
/// - [`Domain::Discrete`]: the ZOH-sampled discrete-time model, exact at the samples for an
///   input held constant between them (section 2.3): each mode r/(s − p) becomes
///
///   ```text
///   G_d(z) = (r/p)(e^{pTs} − 1) z⁻¹ / (1 − e^{pTs} z⁻¹),   z = e^{iωTs},
///   ```
///
///   (→ r Ts z⁻¹/(1 − z⁻¹) as p → 0), the direct term d unchanged.
///
/// Parameter layout:
///
/// ```text
/// θ = [p₁, r₁, …, p_{n_real}, r_{n_real},            per real pole
///      σ₁, ω₁, Re r₁, Im r₁, …,                      per pair, pⱼ = σⱼ + iωⱼ
///      d,                                            with a direct term
///      τ₁ … τ_{n_real}, Re τ₁, Im τ₁, …]             with a transient
/// ```
///
/// **Transient** ([`Modal::with_transient`]). A finite record that is not one period of a
/// steady state carries the response to the mismatch of the initial state; its DFT (eq. 1)
/// adds to Y_k = G U_k the input-independent term
///
/// ```text
/// T(z) = Σ_real τᵢ/(1 − λᵢz⁻¹) + Σ_pairs [τⱼ/(1 − λⱼz⁻¹) + τ̄ⱼ/(1 − λ̄ⱼz⁻¹)],
/// λ = e^{pTs},  z = e^{iωTs},
/// ```
///
/// which is t(z)/a_cd(z) of eq. 10 for band-limited excitation and t(z)/a(z) of eqs. 4–5
/// for the ZOH-sampled model — both have the discrete-time poles e^{pTs}. It costs n real
/// parameters (a pair's τ is complex). Per mode, τ = r (x(0) − x(N))/√N: the 1/√N of
/// eq. 4 is absorbed in τ. (Written with z: T = Σ τ z/(z − λ), i.e. zC(zI − A)⁻¹(x₀ − x_N)
/// of eq. 5.)
///
/// [`PolesZeros`] reports the poles and zeros of G_c in s in both domains. The Jacobian is
/// analytic in both domains.
///
/// ```
/// use fdid::prelude::*;
/// use fdid::model::Modal;
/// use fdid::estimate::{ModalOptions, fit_modal};
///
/// // noise-free data from G(s) = 1/(s + 0.5) + (1 + 2i)/(s + 0.1 − 2i) + (1 − 2i)/(s + 0.1 + 2i)
/// let (p1, r1) = (Complex::new(-0.5, 0.0), Complex::new(1.0, 0.0));
/// let (p2, r2) = (Complex::new(-0.1, 2.0), Complex::new(1.0, 2.0));
/// let omega: Vec<f64> = (1..=100).map(|k| 0.05 * k as f64).collect();
/// let frf: Vec<Complex<f64>> = omega
///     .iter()
///     .map(|w| {
///         let s = Complex::new(0.0, *w);
///         r1 / (s - p1) + r2 / (s - p2) + r2.conj() / (s - p2.conj())
///     })
///     .collect();
/// let data = FrequencyData::from_frf(omega, frf, None).unwrap();
/// let fit = fit_modal(&Pipeline::default(), &data, 1, 1, ModalOptions::continuous()).unwrap();
/// let parts = fit.model().parts(fit.theta());
/// assert!((parts.pair_poles[0] - p2).norm() < 1e-9);
/// assert!((parts.pair_residues[0] - r2).norm() < 1e-9);
/// assert!((parts.real_poles[0] + 0.5).abs() < 1e-9);
/// assert!(fit.model().is_stable(fit.theta()).unwrap());
/// ```
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Modal<T: Real> {
    n_real: usize,
    n_pairs: usize,
    direct: bool,
    domain: Domain<T>,
    /// Sample time of the transient term, when there is one.
    transient: Option<T>,
}

/// The parameters of a [`Modal`] model by meaning (see the layout there). Pairs are given
/// by their member with Im p ≥ 0 (from [`Modal::parts`]; any member is accepted by
/// [`Modal::theta_from_parts`]).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct ModalParts<T: Real> {
    /// Real poles pᵢ (rad/s).
    pub real_poles: Vec<T>,
    /// Their residues rᵢ.
    pub real_residues: Vec<T>,
    /// One pole pⱼ = σⱼ + iωⱼ of each pair.
    pub pair_poles: Vec<Complex<T>>,
    /// The residue rⱼ of that pole (its conjugate belongs to p̄ⱼ).
    pub pair_residues: Vec<Complex<T>>,
    /// Direct term d (zero without one).
    pub direct: T,
    /// Transient coefficients τᵢ of the real modes (empty without a transient).
    pub transient_real: Vec<T>,
    /// Transient coefficients τⱼ of the pairs, belonging to `pair_poles[j]` (empty without
    /// a transient).
    pub transient_pairs: Vec<Complex<T>>,
}

/// Checks that a sample time is positive and finite (and π/Ts finite).
fn check_sample_time<T: Real>(name: &'static str, ts: T) -> Result<()> {
    if Float::is_finite(ts) && ts > T::zero() && Float::is_finite(T::pi() / ts) {
        Ok(())
    } else {
        Err(FdidError::InvalidArgument {
            name,
            value: format!("{ts}"),
            reason: "the sample time must be positive and finite".into(),
        })
    }
}

/// e^x − 1 for complex x without cancellation near x = 0:
/// Re = expm1(a) cos b − 2 sin²(b/2), Im = e^a sin b.
fn expm1_complex<T: Real>(x: Complex<T>) -> Complex<T> {
    let (a, b) = (x.re, x.im);
    let h = Float::sin(b / T::lit(2.0));
    Complex::new(
        Float::exp_m1(a) * Float::cos(b) - T::lit(2.0) * h * h,
        Float::exp(a) * Float::sin(b),
    )
}

/// f(x) = (eˣ − 1)/x, f′(x) and eˣ − 1, by the series Σ xᵏ/(k+1)! for |x| < 1 (no
/// cancellation as x → 0, f(0) = 1, f′(0) = 1/2), else from expm1.
fn zoh_kernel<T: Real>(x: Complex<T>) -> (Complex<T>, Complex<T>, Complex<T>) {
    let em1 = expm1_complex(x);
    if x.norm() < T::one() {
        let mut term = Complex::new(T::one(), T::zero());
        let mut f = term;
        let mut fp = Complex::new(T::zero(), T::zero());
        for k in 1..=30usize {
            let (kf, k1) = (T::from_usize_lossy(k), T::from_usize_lossy(k + 1));
            fp += term * (kf / k1);
            term = term * x / k1;
            f += term;
        }
        (f, fp, em1)
    } else {
        let f = em1 / x;
        let fp = (em1 + T::one() - f) / x;
        (f, fp, em1)
    }
}

/// Per-pole quantities that do not depend on the frequency.
#[derive(Debug, Clone, Copy)]
struct PoleTerms<T: Real> {
    /// The pole p (rad/s).
    p: Complex<T>,
    /// ZOH: E = (e^{pTs} − 1)/p and dE/dp.
    e: Complex<T>,
    de: Complex<T>,
    /// ZOH: λ = e^{pTs}.
    lam: Complex<T>,
    /// Transient: λ_t = e^{pTs} with the transient's Ts.
    lam_t: Complex<T>,
}

impl<T: Real> PoleTerms<T> {
    fn conj(&self) -> Self {
        Self {
            p: self.p.conj(),
            e: self.e.conj(),
            de: self.de.conj(),
            lam: self.lam.conj(),
            lam_t: self.lam_t.conj(),
        }
    }
}

/// One mode read from θ.
#[derive(Debug, Clone, Copy)]
struct Mode<T: Real> {
    pair: bool,
    /// Index in θ of the pole (p, or σ then ω); the residue follows.
    at: usize,
    terms: PoleTerms<T>,
    residue: Complex<T>,
    /// Index in θ of τ (or Re τ, Im τ).
    tau_at: Option<usize>,
    tau: Complex<T>,
}

/// The frequency variables at one line: s = iω, w = z⁻¹ = e^{−iωTs} of the ZOH model and of
/// the transient.
#[derive(Debug, Clone, Copy)]
struct Vars<T: Real> {
    s: Complex<T>,
    w: Complex<T>,
    w_t: Complex<T>,
}

impl<T: Real> Modal<T> {
    /// A modal model with `n_real` real poles, `n_pairs` complex pairs and a direct term when
    /// `direct`, evaluated in `domain`.
    ///
    /// # Errors
    /// No pole (`n_real + n_pairs = 0`), an order `n_real + 2·n_pairs` above
    /// `usize::MAX / 8`; for [`Domain::Discrete`], `ts` not positive and finite.
    pub fn new(n_real: usize, n_pairs: usize, direct: bool, domain: Domain<T>) -> Result<Self> {
        let order = n_pairs.checked_mul(2).and_then(|p| p.checked_add(n_real));
        if order.is_none_or(|o| o > super::MAX_DEGREE) {
            return Err(FdidError::InvalidArgument {
                name: "n_real + 2 n_pairs",
                value: format!("{n_real} + 2·{n_pairs}"),
                reason: format!("the model order must be at most {}", super::MAX_DEGREE),
            });
        }
        if order == Some(0) {
            return Err(FdidError::InvalidArgument {
                name: "n_real + n_pairs",
                value: "0".into(),
                reason: "a modal model needs at least one pole".into(),
            });
        }
        if let Domain::Discrete { ts } = domain {
            check_sample_time("ts", ts)?;
        }
        Ok(Self {
            n_real,
            n_pairs,
            direct,
            domain,
            transient: None,
        })
    }

    /// A model evaluated at s = iω ([`Domain::Continuous`]).
    ///
    /// # Errors
    /// As [`Modal::new`].
    pub fn continuous(n_real: usize, n_pairs: usize, direct: bool) -> Result<Self> {
        Self::new(n_real, n_pairs, direct, Domain::Continuous)
    }

    /// A ZOH-sampled model with sample time `ts` ([`Domain::Discrete`]).
    ///
    /// # Errors
    /// As [`Modal::new`].
    pub fn zoh(n_real: usize, n_pairs: usize, direct: bool, ts: T) -> Result<Self> {
        Self::new(n_real, n_pairs, direct, Domain::Discrete { ts })
    }

    /// The same model with the transient term T(z) = Σ τ/(1 − e^{pTs}z⁻¹) of a record
    /// sampled with `ts` (see [`Modal`]; McKelvey eqs. 4–5, 9–10), adding n = n_real +
    /// 2 n_pairs parameters at the end of θ.
    ///
    /// # Errors
    /// `ts` not positive and finite, or, for a ZOH model, different from its sample time.
    pub fn with_transient(mut self, ts: T) -> Result<Self> {
        check_sample_time("ts", ts)?;
        if let Domain::Discrete { ts: own } = self.domain
            && !(Float::abs(ts - own) <= own * T::lit(crate::data::SAMPLE_TIME_TOLERANCE))
        {
            return Err(FdidError::InvalidArgument {
                name: "ts",
                value: format!("{ts}"),
                reason: format!("the transient of a ZOH model is sampled with its own Ts = {own}"),
            });
        }
        self.transient = Some(ts);
        Ok(self)
    }

    /// Number of real poles.
    pub fn n_real(&self) -> usize {
        self.n_real
    }

    /// Number of complex-conjugate pole pairs.
    pub fn n_pairs(&self) -> usize {
        self.n_pairs
    }

    /// Model order n = n_real + 2 n_pairs.
    pub fn order(&self) -> usize {
        self.n_real + 2 * self.n_pairs
    }

    /// True with a direct term d.
    pub fn has_direct(&self) -> bool {
        self.direct
    }

    /// The domain.
    pub fn domain(&self) -> Domain<T> {
        self.domain
    }

    /// The transient's sample time, `None` without a transient term.
    pub fn transient_ts(&self) -> Option<T> {
        self.transient
    }

    /// Index of d in θ, if the model has one.
    pub fn direct_index(&self) -> Option<usize> {
        self.direct.then_some(2 * self.n_real + 4 * self.n_pairs)
    }

    /// Index in θ of the first transient coefficient, if the model has a transient.
    pub fn transient_offset(&self) -> Option<usize> {
        self.transient
            .map(|_| 2 * self.n_real + 4 * self.n_pairs + usize::from(self.direct))
    }

    /// Indices in θ of the pole parameters (p of each real mode, σ and ω of each pair); θ
    /// is linear in all the others (residues, d, τ).
    pub fn pole_indices(&self) -> Vec<usize> {
        let mut idx: Vec<usize> = (0..self.n_real).map(|i| 2 * i).collect();
        for j in 0..self.n_pairs {
            let at = 2 * self.n_real + 4 * j;
            idx.extend([at, at + 1]);
        }
        idx
    }

    /// θ split by meaning, each pair given by its member with Im p ≥ 0 (residue and τ
    /// conjugated with it when θ holds the other member).
    ///
    /// # Panics
    /// When `theta.len() != n_params()`.
    pub fn parts(&self, theta: &[T]) -> ModalParts<T> {
        assert_eq!(theta.len(), self.n_params(), "θ has the wrong length");
        let mut parts = ModalParts {
            real_poles: vec![],
            real_residues: vec![],
            pair_poles: vec![],
            pair_residues: vec![],
            direct: self.direct_index().map_or_else(T::zero, |i| theta[i]),
            transient_real: vec![],
            transient_pairs: vec![],
        };
        let off = self.transient_offset();
        for i in 0..self.n_real {
            parts.real_poles.push(theta[2 * i]);
            parts.real_residues.push(theta[2 * i + 1]);
            if let Some(o) = off {
                parts.transient_real.push(theta[o + i]);
            }
        }
        for j in 0..self.n_pairs {
            let at = 2 * self.n_real + 4 * j;
            let mut p = Complex::new(theta[at], theta[at + 1]);
            let mut r = Complex::new(theta[at + 2], theta[at + 3]);
            let mut tau = off.map(|o| {
                let k = o + self.n_real + 2 * j;
                Complex::new(theta[k], theta[k + 1])
            });
            if p.im < T::zero() {
                p = p.conj();
                r = r.conj();
                tau = tau.map(|t| t.conj());
            }
            parts.pair_poles.push(p);
            parts.pair_residues.push(r);
            if let Some(t) = tau {
                parts.transient_pairs.push(t);
            }
        }
        parts
    }

    /// θ from its parts (the inverse of [`Modal::parts`]); `direct` is ignored without a
    /// direct term.
    ///
    /// # Errors
    /// [`FdidError::LengthMismatch`] when a part does not match the model's orders (the
    /// transient parts must be empty without a transient term).
    pub fn theta_from_parts(&self, parts: &ModalParts<T>) -> Result<Vec<T>> {
        let nt = |n: usize| if self.transient.is_some() { n } else { 0 };
        for (what, expected, got) in [
            ("real_poles", self.n_real, parts.real_poles.len()),
            ("real_residues", self.n_real, parts.real_residues.len()),
            ("pair_poles", self.n_pairs, parts.pair_poles.len()),
            ("pair_residues", self.n_pairs, parts.pair_residues.len()),
            (
                "transient_real",
                nt(self.n_real),
                parts.transient_real.len(),
            ),
            (
                "transient_pairs",
                nt(self.n_pairs),
                parts.transient_pairs.len(),
            ),
        ] {
            if expected != got {
                return Err(FdidError::LengthMismatch {
                    what,
                    expected,
                    got,
                });
            }
        }
        let mut theta = Vec::with_capacity(self.n_params());
        for (p, r) in parts.real_poles.iter().zip(&parts.real_residues) {
            theta.extend([*p, *r]);
        }
        for (p, r) in parts.pair_poles.iter().zip(&parts.pair_residues) {
            theta.extend([p.re, p.im, r.re, r.im]);
        }
        if self.direct {
            theta.push(parts.direct);
        }
        if self.transient.is_some() {
            theta.extend_from_slice(&parts.transient_real);
            for t in &parts.transient_pairs {
                theta.extend([t.re, t.im]);
            }
        }
        Ok(theta)
    }

    /// True when every pole is strictly stable, Re p < 0 (in both domains: the ZOH poles
    /// e^{pTs} are then inside the unit circle).
    ///
    /// # Errors
    /// As [`PolesZeros::poles`].
    pub fn is_stable(&self, theta: &[T]) -> Result<bool> {
        Ok(self.poles(theta)?.iter().all(|p| p.re < T::zero()))
    }

    /// The pole-dependent quantities of pole p.
    fn pole_terms(&self, p: Complex<T>) -> PoleTerms<T> {
        let one = Complex::new(T::one(), T::zero());
        let (e, de, lam) = match self.domain {
            Domain::Discrete { ts } => {
                let (f, fp, em1) = zoh_kernel(p * ts);
                (f * ts, fp * (ts * ts), em1 + one)
            }
            Domain::Continuous => (one, Complex::new(T::zero(), T::zero()), one),
        };
        let lam_t = match (self.domain, self.transient) {
            (Domain::Discrete { .. }, _) => lam,
            (Domain::Continuous, Some(ts)) => expm1_complex(p * ts) + one,
            (Domain::Continuous, None) => one,
        };
        PoleTerms {
            p,
            e,
            de,
            lam,
            lam_t,
        }
    }

    /// The modes of θ with their pole-dependent quantities.
    fn modes(&self, theta: &[T]) -> Vec<Mode<T>> {
        let zero = Complex::new(T::zero(), T::zero());
        let off = self.transient_offset();
        let mut modes = Vec::with_capacity(self.n_real + self.n_pairs);
        for i in 0..self.n_real {
            let tau_at = off.map(|o| o + i);
            modes.push(Mode {
                pair: false,
                at: 2 * i,
                terms: self.pole_terms(Complex::new(theta[2 * i], T::zero())),
                residue: Complex::new(theta[2 * i + 1], T::zero()),
                tau_at,
                tau: tau_at.map_or(zero, |k| Complex::new(theta[k], T::zero())),
            });
        }
        for j in 0..self.n_pairs {
            let at = 2 * self.n_real + 4 * j;
            let tau_at = off.map(|o| o + self.n_real + 2 * j);
            modes.push(Mode {
                pair: true,
                at,
                terms: self.pole_terms(Complex::new(theta[at], theta[at + 1])),
                residue: Complex::new(theta[at + 2], theta[at + 3]),
                tau_at,
                tau: tau_at.map_or(zero, |k| Complex::new(theta[k], theta[k + 1])),
            });
        }
        modes
    }

    fn vars(&self, omega: T) -> Vars<T> {
        let zinv = |ts: T| Complex::new(T::zero(), -omega * ts).exp();
        let one = Complex::new(T::one(), T::zero());
        Vars {
            s: Complex::new(T::zero(), omega),
            w: match self.domain {
                Domain::Discrete { ts } => zinv(ts),
                Domain::Continuous => one,
            },
            w_t: self.transient.map_or(one, zinv),
        }
    }

    /// The mode's basis function b(p) in G = Σ r b(p) and db/dp:
    /// 1/(s − p) and its square at s = iω, or E w/(1 − λw) with w = z⁻¹ (ZOH) and
    /// d/dp = w q (E′ + E Ts λ w q), q = 1/(1 − λw).
    #[inline]
    fn g_basis(&self, t: &PoleTerms<T>, v: &Vars<T>) -> (Complex<T>, Complex<T>) {
        match self.domain {
            Domain::Continuous => {
                let b = (v.s - t.p).inv();
                (b, b * b)
            }
            Domain::Discrete { ts } => {
                let one = Complex::new(T::one(), T::zero());
                let q = (one - t.lam * v.w).inv();
                let wq = v.w * q;
                (t.e * wq, wq * (t.de + t.e * t.lam * wq * ts))
            }
        }
    }

    /// The transient basis c(p) = 1/(1 − λ_t w_t) and dc/dp = Ts λ_t w_t c².
    #[inline]
    fn t_basis(&self, t: &PoleTerms<T>, v: &Vars<T>, ts: T) -> (Complex<T>, Complex<T>) {
        let one = Complex::new(T::one(), T::zero());
        let c = (one - t.lam_t * v.w_t).inv();
        (c, c * c * t.lam_t * v.w_t * ts)
    }

    /// Writes Σ_modes coef·b(p) (a pair adding its conjugate mode) and, when `jac` is given,
    /// the derivatives w.r.t. the pole parameters and the (real) coefficients into row k.
    fn sum_modes(
        modes: &[Mode<T>],
        basis: impl Fn(&PoleTerms<T>) -> (Complex<T>, Complex<T>),
        coef: impl Fn(&Mode<T>) -> (Complex<T>, Option<usize>),
        k: usize,
        mut jac: Option<&mut DMatrix<Complex<T>>>,
    ) -> Complex<T> {
        let i = Complex::new(T::zero(), T::one());
        let mut sum = Complex::new(T::zero(), T::zero());
        for m in modes {
            let (c, c_at) = coef(m);
            let (b, bp) = basis(&m.terms);
            if !m.pair {
                sum += b * c;
                if let Some(j) = jac.as_deref_mut() {
                    j[(k, m.at)] += bp * c;
                    if let Some(a) = c_at {
                        j[(k, a)] = b;
                    }
                }
            } else {
                let (b2, bp2) = basis(&m.terms.conj());
                let cc = c.conj();
                sum += b * c + b2 * cc;
                if let Some(j) = jac.as_deref_mut() {
                    let (d1, d2) = (bp * c, bp2 * cc);
                    j[(k, m.at)] += d1 + d2;
                    j[(k, m.at + 1)] += (d1 - d2) * i;
                    if let Some(a) = c_at {
                        j[(k, a)] = b + b2;
                        j[(k, a + 1)] = (b - b2) * i;
                    }
                }
            }
        }
        sum
    }

    /// Index of a mode's residue in θ.
    fn residue_at(m: &Mode<T>) -> usize {
        if m.pair { m.at + 2 } else { m.at + 1 }
    }
}

impl<T: Real> ModelStructure<T> for Modal<T> {
    fn has_transient(&self) -> bool {
        self.transient.is_some()
    }

    fn n_params(&self) -> usize {
        let transient = if self.transient.is_some() {
            self.order()
        } else {
            0
        };
        2 * self.n_real + 4 * self.n_pairs + usize::from(self.direct) + transient
    }

    /// G_c(iω) or the ZOH-sampled G_d(e^{iωTs}) (see [`Domain`]).
    fn response_into(&self, theta: &[T], omega: &[T], out: &mut [Complex<T>]) {
        let modes = self.modes(theta);
        let d = self.direct_index().map_or_else(T::zero, |i| theta[i]);
        for (k, (w, o)) in omega.iter().zip(out.iter_mut()).enumerate() {
            let v = self.vars(*w);
            let g = Self::sum_modes(
                &modes,
                |t| self.g_basis(t, &v),
                |m| (m.residue, None),
                k,
                None,
            );
            *o = g + d;
        }
    }

    /// ∂G/∂p = r b′(p), ∂G/∂r = b(p) for a real mode; for a pair with p = σ + iω,
    /// ∂G/∂σ = r b′(p) + r̄ b′(p̄), ∂G/∂ω = i(r b′(p) − r̄ b′(p̄)), ∂G/∂Re r = b(p) + b(p̄),
    /// ∂G/∂Im r = i(b(p) − b(p̄)); ∂G/∂d = 1; zero for the τ.
    fn jacobian_into(
        &self,
        theta: &[T],
        omega: &[T],
        g: &mut [Complex<T>],
        jac: &mut DMatrix<Complex<T>>,
    ) {
        let modes = self.modes(theta);
        let d_at = self.direct_index();
        let d = d_at.map_or_else(T::zero, |i| theta[i]);
        jac.fill(Complex::new(T::zero(), T::zero()));
        for (k, w) in omega.iter().enumerate() {
            let v = self.vars(*w);
            let gk = Self::sum_modes(
                &modes,
                |t| self.g_basis(t, &v),
                |m| (m.residue, Some(Self::residue_at(m))),
                k,
                Some(jac),
            );
            g[k] = gk + d;
            if let Some(i) = d_at {
                jac[(k, i)] = Complex::new(T::one(), T::zero());
            }
        }
    }

    /// T(z) = Σ τ c(p), c = 1/(1 − e^{pTs}z⁻¹) (pairs adding the conjugate mode), with
    /// ∂T/∂p = τ Ts λ z⁻¹ c², ∂T/∂τ = c (as for G's residues), zero for residues and d.
    fn transient_into(
        &self,
        theta: &[T],
        omega: &[T],
        t: &mut [Complex<T>],
        mut jac: Option<&mut DMatrix<Complex<T>>>,
    ) -> bool {
        let Some(ts) = self.transient else {
            return false;
        };
        let modes = self.modes(theta);
        if let Some(j) = jac.as_deref_mut() {
            j.fill(Complex::new(T::zero(), T::zero()));
        }
        for (k, w) in omega.iter().enumerate() {
            let v = self.vars(*w);
            t[k] = Self::sum_modes(
                &modes,
                |p| self.t_basis(p, &v, ts),
                |m| (m.tau, m.tau_at),
                k,
                jac.as_deref_mut(),
            );
        }
        true
    }

    /// # Errors
    /// Too few lines; for a ZOH model or a transient, a data sample time different from the
    /// model's, or lines above its Nyquist frequency.
    fn check_data(&self, data: &FrequencyData<T>) -> Result<()> {
        super::check_line_count(self.n_params(), data.len())?;
        let sampled = matches!(self.domain, Domain::Discrete { .. }) || self.transient.is_some();
        if sampled && data.mixed_sample_times() {
            return Err(FdidError::InvalidArgument {
                name: "ts",
                value: "several".into(),
                reason: "the data merge experiments with different sample times: only a \
                         continuous-time model without a sampled transient fits them"
                    .into(),
            });
        }
        if let Domain::Discrete { ts } = self.domain {
            data.check_sampled_grid(ts, "ZOH model")?;
        }
        if let Some(ts) = self.transient {
            data.check_sampled_grid(ts, "transient")?;
        }
        Ok(())
    }
}

impl<T: Real> PolesZeros<T> for Modal<T> {
    /// The poles of G_c in s (rad/s), in both domains: real ones, then each pair as p, p̄.
    fn poles(&self, theta: &[T]) -> Result<Vec<Complex<T>>> {
        let parts = self.parts(theta);
        crate::error::check_finite("real poles", &parts.real_poles)?;
        crate::error::check_finite_complex("pair poles", &parts.pair_poles)?;
        let mut poles: Vec<Complex<T>> = parts
            .real_poles
            .iter()
            .map(|p| Complex::new(*p, T::zero()))
            .collect();
        for p in &parts.pair_poles {
            poles.extend([*p, p.conj()]);
        }
        Ok(poles)
    }

    /// The zeros of G_c in s, in both domains (not the sampling zeros of the ZOH model):
    /// the roots of the numerator of d + Σ r/(s − p) over Π(s − p), computed by
    /// [`crate::roots::roots`] in the partial-fraction basis with the model's poles as basis
    /// poles (a shift s − s₀ keeps them off the imaginary axis; coinciding poles are merged
    /// first, adding their residues).
    fn zeros(&self, theta: &[T]) -> Result<Vec<Complex<T>>> {
        let (basis, coeffs, shift) = self.numerator_in_basis(theta)?;
        Ok(crate::roots::roots(&basis, &coeffs)?
            .into_iter()
            .map(|z| z + shift)
            .collect())
    }

    /// k of G_c = k Π(s − zᵢ)/Π(s − pⱼ): d with a direct term, else the first non-zero
    /// Markov parameter (Σ residues, …).
    fn gain(&self, theta: &[T]) -> T {
        self.numerator_in_basis(theta)
            .ok()
            .and_then(|(basis, c, _)| crate::roots::partial_fraction_leading(&basis, &c))
            .unwrap_or_else(T::zero)
    }
}

impl<T: Real> Modal<T> {
    /// G_c as c₀ + Σ cₙφₙ(s − s₀) in a partial-fraction basis over the (merged, shifted)
    /// poles; returns the basis, c and the shift s₀.
    fn numerator_in_basis(&self, theta: &[T]) -> Result<(PolyBasis<T>, Vec<T>, T)> {
        let parts = self.parts(theta);
        crate::error::check_finite("theta", theta)?;
        // (upper pole, residue): real poles have im = 0 and a real residue
        let mut entries: Vec<(Complex<T>, Complex<T>)> = parts
            .real_poles
            .iter()
            .zip(&parts.real_residues)
            .map(|(p, r)| (Complex::new(*p, T::zero()), Complex::new(*r, T::zero())))
            .collect();
        for (p, r) in parts.pair_poles.iter().zip(&parts.pair_residues) {
            if p.im == T::zero() {
                // a degenerate pair: 2 Re r/(s − σ)
                entries.push((*p, Complex::new(r.re + r.re, T::zero())));
            } else {
                entries.push((*p, *r));
            }
        }
        let mut merged: Vec<(Complex<T>, Complex<T>)> = vec![];
        for (p, r) in entries {
            let tol = T::lit(4.0) * T::default_epsilon() * Float::max(p.norm(), T::one());
            match merged.iter_mut().find(|(q, _)| (*q - p).norm() <= tol) {
                Some(e) => e.1 += r,
                None => merged.push((p, r)),
            }
        }
        let radius = merged
            .iter()
            .fold(T::zero(), |m, (p, _)| Float::max(m, p.norm()));
        let shift = if merged.iter().any(|(p, _)| p.re == T::zero()) {
            -(radius + T::one()) * T::lit(1.37)
        } else {
            T::zero()
        };
        let poles: Vec<Complex<T>> = merged
            .iter()
            .map(|(p, _)| Complex::new(p.re - shift, p.im))
            .collect();
        let mut coeffs = vec![parts.direct];
        for (p, r) in &merged {
            if p.im == T::zero() {
                coeffs.push(r.re);
            } else {
                coeffs.extend([r.re, r.im]);
            }
        }
        Ok((PolyBasis::partial_fractions(poles)?, coeffs, shift))
    }
}
