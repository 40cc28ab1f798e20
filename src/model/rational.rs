//! Rational transfer-function models G = B/A in s (continuous time) or z⁻¹ (discrete time).

use super::{EquationError, ModelStructure, PolesZeros};
use crate::basis::PolyBasis;
use crate::data::FrequencyData;
use crate::error::{FdidError, Result};
use crate::roots::roots;
use crate::{Complex, Real};
use nalgebra::DMatrix;
use num_traits::Float;

/// Time domain of a model.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Domain<T: Real> {
    /// Continuous time: G evaluated at s = iω.
    Continuous,
    /// Discrete time with sample time `ts` (s): G evaluated at z = e^{iωTs}.
    Discrete {
        /// Sample time (s).
        ts: T,
    },
}

/// A rational model G(θ) = B(θ)/A(θ).
///
/// **Continuous time** (McKelvey eq. 7): A(s) of degree `na` and B(s) of degree `nb`, both
/// expanded in the basis φₙ(s) orthonormal on the data grid ([`PolyBasis::Orthonormal`]):
///
/// ```text
/// A(s) = φ_na(s) + Σ_{n<na} aₙ φₙ(s),   B(s) = Σ_{n≤nb} bₙ φₙ(s),
/// θ = [a₀ … a_{na−1}, b₀ … b_nb].
/// ```
///
/// `nb = na` gives a direct feedthrough, `nb < na` a strictly proper model; `nb > na`
/// (improper, e.g. an impedance R + sL) is allowed.
///
/// **Discrete time** (McKelvey eq. 3), the digital-filter convention:
///
/// ```text
/// A(z⁻¹) = 1 + a₁z⁻¹ + … + a_na z⁻ⁿᵃ,   B(z⁻¹) = b₀ + b₁z⁻¹ + … + b_nb z⁻ⁿᵇ,
/// θ = [a₁ … a_na, b₀ … b_nb].
/// ```
///
/// The Jacobian is analytic: ∂G/∂bₙ = φₙ/A, ∂G/∂aₙ = −G φₙ/A.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Rational<T: Real> {
    na: usize,
    nb: usize,
    basis: PolyBasis<T>,
}

impl<T: Real> Rational<T> {
    /// A continuous-time model with denominator degree `na`, numerator degree `nb`, in the
    /// basis orthonormal on the frequency grid `omega` (rad/s) — normally the data's.
    ///
    /// # Errors
    /// No positive frequency, or too few distinct frequencies for the degrees.
    pub fn continuous(na: usize, nb: usize, omega: &[T]) -> Result<Self> {
        crate::error::check_finite("omega", omega)?;
        let basis = PolyBasis::orthonormal(omega, na.max(nb))?;
        Ok(Self { na, nb, basis })
    }

    /// A discrete-time model with sample time `ts` (s), A of degree `na` and B of degree
    /// `nb` in z⁻¹.
    ///
    /// # Errors
    /// `ts ≤ 0` or not finite.
    pub fn discrete(na: usize, nb: usize, ts: T) -> Result<Self> {
        Ok(Self {
            na,
            nb,
            basis: PolyBasis::delay_powers(ts)?,
        })
    }

    /// Denominator degree.
    pub fn na(&self) -> usize {
        self.na
    }

    /// Numerator degree.
    pub fn nb(&self) -> usize {
        self.nb
    }

    /// The polynomial basis.
    pub fn basis(&self) -> &PolyBasis<T> {
        &self.basis
    }

    /// Continuous or discrete time.
    pub fn domain(&self) -> Domain<T> {
        match self.basis {
            PolyBasis::Orthonormal { .. } => Domain::Continuous,
            PolyBasis::DelayPowers { ts } => Domain::Discrete { ts },
        }
    }

    /// The complex frequency variable at ω (s = iω or z = e^{iωTs}).
    pub fn variable(&self, omega: T) -> Complex<T> {
        self.basis.variable(omega)
    }

    /// Splits θ into the full denominator coefficients (normalising one included) and the
    /// numerator coefficients, in the basis.
    ///
    /// # Panics
    /// Never for `theta.len() == n_params()`; shorter θ is padded with zeros.
    pub fn coefficients(&self, theta: &[T]) -> (Vec<T>, Vec<T>) {
        let na = self.na;
        let get = |i: usize| theta.get(i).copied().unwrap_or_else(T::zero);
        let mut a = Vec::with_capacity(na + 1);
        match self.basis {
            PolyBasis::Orthonormal { .. } => {
                a.extend((0..na).map(get));
                a.push(T::one());
            }
            PolyBasis::DelayPowers { .. } => {
                a.push(T::one());
                a.extend((0..na).map(get));
            }
        }
        let b = (na..na + self.nb + 1).map(get).collect();
        (a, b)
    }

    /// θ from full denominator and numerator coefficients (the denominator is rescaled so
    /// that its normalising coefficient is one).
    ///
    /// # Errors
    /// Wrong lengths, or a zero normalising coefficient.
    pub fn theta_from_polys(&self, a: &[T], b: &[T]) -> Result<Vec<T>> {
        if a.len() != self.na + 1 || b.len() != self.nb + 1 {
            return Err(FdidError::LengthMismatch {
                what: "polynomial coefficients (a, b)",
                expected: self.na + self.nb + 2,
                got: a.len() + b.len(),
            });
        }
        let mut c = a.to_vec();
        c.extend_from_slice(b);
        self.theta_from_coefficients(&c)
            .ok_or_else(|| FdidError::InvalidArgument {
                name: "a",
                value: format!("{:?}", a),
                reason: "the normalising coefficient of the denominator is zero".into(),
            })
    }

    /// Monomial coefficients (ascending powers of s, or of z⁻¹) of A and B. Exact in exact
    /// arithmetic but ill-conditioned for high orders over wide bands: for display.
    pub fn monomial_coefficients(&self, theta: &[T]) -> (Vec<T>, Vec<T>) {
        let (a, b) = self.coefficients(theta);
        (self.basis.to_monomial(&a), self.basis.to_monomial(&b))
    }

    /// True when every pole is strictly stable (Re p < 0, or |p| < 1).
    ///
    /// # Errors
    /// As [`PolesZeros::poles`].
    pub fn is_stable(&self, theta: &[T]) -> Result<bool> {
        let poles = self.poles(theta)?;
        Ok(match self.basis {
            PolyBasis::Orthonormal { .. } => poles.iter().all(|p| p.re < T::zero()),
            PolyBasis::DelayPowers { .. } => poles.iter().all(|p| p.norm() < T::one()),
        })
    }

    /// Reflects unstable poles into the stable region, keeping |G(iω)| (or |G(e^{iωTs})|)
    /// unchanged: p ↦ −p̄ in s, p ↦ 1/p̄ in z (with B scaled by 1/|p| to keep the
    /// magnitude). The denominator is rebuilt from its roots by multiplying factors in the
    /// basis, never through monomials of the orthonormal expansion.
    ///
    /// # Errors
    /// As [`PolesZeros::poles`]; a pole at z = 0 cannot be reflected and is kept.
    pub fn reflect_unstable(&self, theta: &[T]) -> Result<Vec<T>> {
        let poles = self.poles(theta)?;
        let (_, mut b) = self.coefficients(theta);
        let mut gain_fix = T::one();
        let reflected: Vec<Complex<T>> = poles
            .iter()
            .map(|p| match self.basis {
                PolyBasis::Orthonormal { .. } if p.re > T::zero() => Complex::new(-p.re, p.im),
                PolyBasis::DelayPowers { .. } if p.norm() > T::one() => {
                    gain_fix /= p.norm();
                    p.conj().inv()
                }
                _ => *p,
            })
            .collect();
        let a = self.poly_from_roots(&reflected);
        for v in b.iter_mut() {
            *v *= gain_fix;
        }
        self.theta_from_polys(&a, &b)
    }

    /// Coefficients (in the basis, normalised) of the monic polynomial with the given roots
    /// (conjugate pairs are multiplied together so the arithmetic stays real).
    fn poly_from_roots(&self, r: &[Complex<T>]) -> Vec<T> {
        let n = self.na;
        // real quadratic and linear factors
        let mut factors: Vec<(T, T, bool)> = vec![]; // (c1, c0, quadratic): x² + c1 x + c0 or x + c0
        let mut used = vec![false; r.len()];
        let tol = T::lit(1e3) * T::default_epsilon();
        for i in 0..r.len() {
            if used[i] {
                continue;
            }
            used[i] = true;
            let scale = Float::max(r[i].norm(), T::one());
            if Float::abs(r[i].im) <= tol * scale {
                factors.push((T::zero(), -r[i].re, false));
            } else {
                // find its conjugate
                let mate = (0..r.len()).filter(|j| !used[*j]).min_by(|x, y| {
                    let dx = (r[*x] - r[i].conj()).norm();
                    let dy = (r[*y] - r[i].conj()).norm();
                    dx.partial_cmp(&dy).unwrap_or(std::cmp::Ordering::Equal)
                });
                if let Some(j) = mate {
                    used[j] = true;
                }
                factors.push((-(r[i].re + r[i].re), r[i].norm_sqr(), true));
            }
        }
        match &self.basis {
            PolyBasis::DelayPowers { .. } => {
                // A(z⁻¹) = Π (1 − p z⁻¹): in z⁻¹ the factor x + c0 becomes 1 + c0 z⁻¹
                let mut c = vec![T::one()];
                for (c1, c0, quad) in factors {
                    let add: Vec<T> = if quad {
                        vec![T::one(), c1, c0]
                    } else {
                        vec![T::one(), c0]
                    };
                    let mut next = vec![T::zero(); c.len() + add.len() - 1];
                    for (i, x) in c.iter().enumerate() {
                        for (j, y) in add.iter().enumerate() {
                            next[i + j] += *x * *y;
                        }
                    }
                    c = next;
                }
                c.resize(n + 1, T::zero());
                c
            }
            PolyBasis::Orthonormal { scale, gamma } => {
                // work in x = s/ω_s; multiply by x using x φ_k = γ_{k+1} φ_{k+1} − γ_k φ_{k−1}
                let times_x = |c: &[T]| {
                    let mut out = vec![T::zero(); c.len() + 1];
                    for (k, ck) in c.iter().enumerate() {
                        out[k + 1] += gamma[k] * *ck;
                        if k >= 1 {
                            out[k - 1] -= gamma[k - 1] * *ck;
                        }
                    }
                    out
                };
                let mut c = vec![T::one()];
                for (c1, c0, quad) in factors {
                    let xs = times_x(&c);
                    let mut next = if quad { times_x(&xs) } else { xs.clone() };
                    let s1 = c1 / *scale;
                    let s0 = if quad {
                        c0 / (*scale * *scale)
                    } else {
                        c0 / *scale
                    };
                    if quad {
                        for (k, v) in xs.iter().enumerate() {
                            next[k] += s1 * *v;
                        }
                    }
                    for (k, v) in c.iter().enumerate() {
                        next[k] += s0 * *v;
                    }
                    c = next;
                }
                c.resize(n + 1, T::zero());
                let lead = c[n];
                c.iter().map(|v| *v / lead).collect()
            }
        }
    }

    /// Evaluates A and B at one variable value, with the basis values in `phi`.
    #[inline]
    fn eval_ab(
        &self,
        theta: &[T],
        v: Complex<T>,
        phi: &mut [Complex<T>],
    ) -> (Complex<T>, Complex<T>) {
        self.basis.eval_into(v, phi);
        let zero = Complex::new(T::zero(), T::zero());
        let na = self.na;
        let mut a = zero;
        let mut b = zero;
        match self.basis {
            PolyBasis::Orthonormal { .. } => {
                for k in 0..na {
                    a += phi[k] * theta[k];
                }
                a += phi[na];
            }
            PolyBasis::DelayPowers { .. } => {
                a = phi[0];
                for k in 1..=na {
                    a += phi[k] * theta[k - 1];
                }
            }
        }
        for k in 0..=self.nb {
            b += phi[k] * theta[na + k];
        }
        (a, b)
    }

    fn zero_phi(&self) -> Vec<Complex<T>> {
        vec![Complex::new(T::zero(), T::zero()); self.na.max(self.nb) + 1]
    }

    /// Offset of the free denominator parameters in the basis index (0 in s, 1 in z).
    fn a_offset(&self) -> usize {
        match self.basis {
            PolyBasis::Orthonormal { .. } => 0,
            PolyBasis::DelayPowers { .. } => 1,
        }
    }
}

impl<T: Real> ModelStructure<T> for Rational<T> {
    fn n_params(&self) -> usize {
        self.na + self.nb + 1
    }

    fn response_into(&self, theta: &[T], omega: &[T], out: &mut [Complex<T>]) {
        let mut phi = self.zero_phi();
        for (w, o) in omega.iter().zip(out.iter_mut()) {
            let (a, b) = self.eval_ab(theta, self.basis.variable(*w), &mut phi);
            *o = b / a;
        }
    }

    fn jacobian_into(
        &self,
        theta: &[T],
        omega: &[T],
        g: &mut [Complex<T>],
        jac: &mut DMatrix<Complex<T>>,
    ) {
        let mut phi = self.zero_phi();
        let na = self.na;
        let off = self.a_offset();
        for (k, w) in omega.iter().enumerate() {
            let (a, b) = self.eval_ab(theta, self.basis.variable(*w), &mut phi);
            let inv_a = a.inv();
            let gk = b * inv_a;
            g[k] = gk;
            let minus_g_over_a = -gk * inv_a;
            for j in 0..na {
                jac[(k, j)] = phi[j + off] * minus_g_over_a;
            }
            for j in 0..=self.nb {
                jac[(k, na + j)] = phi[j] * inv_a;
            }
        }
    }

    fn check_data(&self, data: &FrequencyData<T>) -> Result<()> {
        let p = self.n_params();
        if 2 * data.len() < p {
            return Err(FdidError::TooFewFrequencies {
                lines: data.len(),
                equations: 2 * data.len(),
                parameters: p,
            });
        }
        if let (PolyBasis::DelayPowers { ts }, Some(dts)) = (&self.basis, data.ts()) {
            let rel = Float::abs(*ts - dts) / *ts;
            if rel > T::lit(1e-6) {
                return Err(FdidError::InvalidArgument {
                    name: "ts",
                    value: format!("{dts}"),
                    reason: format!(
                        "the data's sample time differs from the model's ({ts}); merge \
                         experiments with different sample times into a continuous-time model"
                    ),
                });
            }
        }
        if let PolyBasis::DelayPowers { ts } = &self.basis {
            let nyquist = T::pi() / *ts;
            if let Some(w) = data
                .omega()
                .iter()
                .find(|w| **w > nyquist * (T::one() + T::lit(1e-9)))
            {
                return Err(FdidError::InvalidArgument {
                    name: "omega",
                    value: format!("{w} rad/s"),
                    reason: format!("above the Nyquist frequency {nyquist} rad/s of Ts = {ts} s"),
                });
            }
        }
        Ok(())
    }
}

impl<T: Real> EquationError<T> for Rational<T> {
    fn normalising_index(&self) -> usize {
        match self.basis {
            PolyBasis::Orthonormal { .. } => self.na,
            PolyBasis::DelayPowers { .. } => 0,
        }
    }

    /// c = [A coefficients (na + 1, basis order), B coefficients (nb + 1)],
    /// R_k = [φ₀ Y_k … φ_na Y_k, −φ₀ U_k … −φ_nb U_k].
    fn regressor_into(&self, data: &FrequencyData<T>, out: &mut DMatrix<Complex<T>>) {
        let mut phi = self.zero_phi();
        let na = self.na;
        for (k, ((w, y), u)) in data.omega().iter().zip(data.y()).zip(data.u()).enumerate() {
            self.basis.eval_into(self.basis.variable(*w), &mut phi);
            for j in 0..=na {
                out[(k, j)] = phi[j] * *y;
            }
            for j in 0..=self.nb {
                out[(k, na + 1 + j)] = -(phi[j] * *u);
            }
        }
    }

    fn denominator_into(&self, theta: &[T], omega: &[T], out: &mut [Complex<T>]) {
        let mut phi = self.zero_phi();
        for (w, o) in omega.iter().zip(out.iter_mut()) {
            *o = self.eval_ab(theta, self.basis.variable(*w), &mut phi).0;
        }
    }
}

impl<T: Real> PolesZeros<T> for Rational<T> {
    fn poles(&self, theta: &[T]) -> Result<Vec<Complex<T>>> {
        let (a, _) = self.coefficients(theta);
        roots(&self.basis, &a)
    }

    fn zeros(&self, theta: &[T]) -> Result<Vec<Complex<T>>> {
        let (_, b) = self.coefficients(theta);
        roots(&self.basis, &b)
    }

    fn gain(&self, theta: &[T]) -> T {
        let (a, b) = self.coefficients(theta);
        match &self.basis {
            PolyBasis::DelayPowers { .. } => b
                .iter()
                .copied()
                .find(|v| *v != T::zero())
                .unwrap_or_else(T::zero),
            PolyBasis::Orthonormal { scale, gamma } => {
                // leading coefficient of φ_n is 1/(ω_s^n Π_{j≤n} γ_j); use the degrees that
                // survive trimming in the root finder
                let deg = |c: &[T]| {
                    let norm = Float::sqrt(c.iter().fold(T::zero(), |s, v| s + *v * *v));
                    let tol = norm * T::default_epsilon() * T::lit(8.0);
                    let mut n = c.len();
                    while n > 0 && Float::abs(c[n - 1]) <= tol {
                        n -= 1;
                    }
                    n.saturating_sub(1)
                };
                let (da, db) = (deg(&a), deg(&b));
                let mut k = b[db] / a[da];
                // ratio of leading coefficients: Π_{j≤db} 1/(ω_s γ_j) / Π_{j≤da} 1/(ω_s γ_j)
                if da > db {
                    for g in &gamma[db..da] {
                        k *= *scale * *g;
                    }
                } else {
                    for g in &gamma[da..db] {
                        k /= *scale * *g;
                    }
                }
                k
            }
        }
    }
}
