//! Time and frequency bases of the time-varying ODE (Lataire–Pintelon eqs. 3 and 20).
//!
//! The model Σₙ Σ_p α̃ₙ,ₚ b_p(t) Ψₙ{y} = Σₙ Σ_p β̃ₙ,ₚ b_p(t) Ψₙ{u} (eq. 3) uses a basis
//! {b₀, …, b_{N_p}} of polynomials in t and a basis {Ψ₀, …, Ψ_N} of polynomial derivative
//! operators. Both bases here are related to the monomials tᵖ and sⁿ of eqs. 1–2 by a
//! triangular change of coefficients, given by [`TimeBasis::monomial_coefficients`] and
//! [`FrequencyBasis::monomial_coefficients`].

use crate::error::{FdidError, Result};
use crate::scalar::{Complex, Real};
use num_traits::Float;

/// The time basis b_p(t) on the record [0, T] (Lataire–Pintelon eq. 3, section IV-A).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum TimeBasis {
    /// b_p(t) = tᵖ, t in seconds (eq. 2).
    Monomial,
    /// b_p(t) = P_p(2t/T − 1), the Legendre polynomial shifted to the record [0, T]
    /// (section IV-A): bounded by 1 over the record, so no column of the regressor
    /// dominates.
    #[default]
    Legendre,
}

impl TimeBasis {
    /// Writes b₀(t) … b_d(t) into `out` (length d + 1) for the record length `record` = T
    /// (s).
    pub fn eval_into<T: Real>(&self, t: T, record: T, out: &mut [T]) {
        match self {
            Self::Monomial => {
                let mut v = T::one();
                for o in out.iter_mut() {
                    *o = v;
                    v *= t;
                }
            }
            Self::Legendre => legendre_into(T::lit(2.0) * t / record - T::one(), out),
        }
    }

    /// The coefficients of b_p in powers of t (seconds): row p holds c_{p,0} … c_{p,p}
    /// with b_p(t) = Σ_q c_{p,q} t^q, for p = 0 … `order`, on a record of length
    /// `record` = T (s). For the Legendre basis this expands P_p(2t/T − 1) binomially.
    pub fn monomial_coefficients(&self, order: usize, record: f64) -> Vec<Vec<f64>> {
        match self {
            Self::Monomial => (0..=order)
                .map(|p| (0..=p).map(|q| if q == p { 1.0 } else { 0.0 }).collect())
                .collect(),
            Self::Legendre => {
                let c = legendre_coefficients(order);
                let a = 2.0 / record;
                c.iter()
                    .enumerate()
                    .map(|(p, cp)| {
                        // Σ_m c_m (a t − 1)^m = Σ_m c_m Σ_q C(m,q) a^q t^q (−1)^{m−q}
                        let mut out = vec![0.0; p + 1];
                        for (m, cm) in cp.iter().enumerate() {
                            let mut binom = 1.0;
                            for (q, o) in out.iter_mut().enumerate().take(m + 1) {
                                let sign = if (m - q) % 2 == 0 { 1.0 } else { -1.0 };
                                *o += cm * binom * a.powi(q as i32) * sign;
                                binom = binom * (m - q) as f64 / (q + 1) as f64;
                            }
                        }
                        out
                    })
                    .collect()
            }
        }
    }
}

/// The frequency basis Ψₙ(s) of polynomial derivative operators (Lataire–Pintelon eqs. 3
/// and 20). Every Ψₙ is a real-coefficient polynomial of degree n in s, so Ψₙ(−jω) is the
/// conjugate of Ψₙ(jω) and real parameters give a real ODE.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum FrequencyBasis<T> {
    /// Ψₙ(s) = sⁿ, s in rad/s (eq. 1).
    #[default]
    Monomial,
    /// Eq. 20: Ψₙ(jω) = j Pₙ(ω/ω_max) for odd n and Pₙ(ω/ω_max) for even n, with ω_max
    /// (rad/s) the upper edge of the band of interest. In s this is the real polynomial
    /// Ψₙ(s) = Σ_m c_{n,m} (−1)^⌊m/2⌋ (s/ω_max)^m, with Pₙ(x) = Σ_m c_{n,m} x^m.
    Legendre {
        /// Frequency scale ω_max (rad/s), positive and finite.
        omega_max: T,
    },
}

impl<T: Real> FrequencyBasis<T> {
    /// The Legendre basis of eq. 20 scaled to `omega_max` (rad/s).
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] named `omega_max` unless it is positive and finite.
    pub fn legendre(omega_max: T) -> Result<Self> {
        let b = Self::Legendre { omega_max };
        b.validate()?;
        Ok(b)
    }

    /// Checks the scale of the Legendre basis.
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] named `omega_max` unless it is positive and finite.
    pub fn validate(&self) -> Result<()> {
        if let Self::Legendre { omega_max } = self
            && !(Float::is_finite(*omega_max) && *omega_max > T::zero())
        {
            return Err(FdidError::InvalidArgument {
                name: "omega_max",
                value: format!("{omega_max}"),
                reason: "the Legendre frequency scale must be positive and finite".into(),
            });
        }
        Ok(())
    }

    /// Writes Ψ₀(jω) … Ψ_d(jω) into `out` (length d + 1) at the signed angular frequency
    /// ω (rad/s).
    pub fn eval_into(&self, omega: T, out: &mut [Complex<T>]) {
        match self {
            Self::Monomial => {
                let s = Complex::new(T::zero(), omega);
                let mut v = Complex::new(T::one(), T::zero());
                for o in out.iter_mut() {
                    *o = v;
                    v *= s;
                }
            }
            Self::Legendre { omega_max } => {
                legendre_complex_into(omega / *omega_max, out);
            }
        }
    }

    /// The coefficients of Ψₙ in powers of z = s/`scale`: row n holds d_{n,0} … d_{n,n}
    /// with Ψₙ(s) = Σ_m d_{n,m} (s/scale)^m, for n = 0 … `order`. With `scale` = 1 these
    /// are the monomial coefficients in s of eq. 1; a scale near the band edge keeps them
    /// of comparable size (used for roots).
    pub fn monomial_coefficients(&self, order: usize, scale: T) -> Vec<Vec<T>> {
        match self {
            Self::Monomial => (0..=order)
                .map(|n| {
                    (0..=n)
                        .map(|m| {
                            if m == n {
                                Float::powi(scale, n as i32)
                            } else {
                                T::zero()
                            }
                        })
                        .collect()
                })
                .collect(),
            Self::Legendre { omega_max } => {
                let ratio = scale / *omega_max;
                legendre_coefficients(order)
                    .iter()
                    .map(|cn| {
                        cn.iter()
                            .enumerate()
                            .map(|(m, c)| {
                                let sign = if (m / 2) % 2 == 0 { 1.0 } else { -1.0 };
                                T::lit(c * sign) * Float::powi(ratio, m as i32)
                            })
                            .collect()
                    })
                    .collect()
            }
        }
    }
}

/// Writes the Legendre polynomials P₀(x) … P_d(x) into `out` (length d + 1), by the
/// three-term recurrence (n + 1) P_{n+1} = (2n + 1) x Pₙ − n P_{n−1}.
pub fn legendre_into<T: Real>(x: T, out: &mut [T]) {
    for k in 0..out.len() {
        out[k] = match k {
            0 => T::one(),
            1 => x,
            _ => {
                let n = T::from_usize_lossy(k - 1);
                ((n + n + T::one()) * x * out[k - 1] - n * out[k - 2]) / (n + T::one())
            }
        };
    }
}

/// Writes j^(n mod 2) Pₙ(x) for n = 0 … d into `out` (eq. 20 at x = ω/ω_max).
pub(crate) fn legendre_complex_into<T: Real>(x: T, out: &mut [Complex<T>]) {
    let (mut pm2, mut pm1) = (T::zero(), T::zero());
    for (k, o) in out.iter_mut().enumerate() {
        let p = match k {
            0 => T::one(),
            1 => x,
            _ => {
                let n = T::from_usize_lossy(k - 1);
                ((n + n + T::one()) * x * pm1 - n * pm2) / (n + T::one())
            }
        };
        *o = if k % 2 == 0 {
            Complex::new(p, T::zero())
        } else {
            Complex::new(T::zero(), p)
        };
        pm2 = pm1;
        pm1 = p;
    }
}

/// Ascending power coefficients of P₀ … P_d: row n holds c_{n,0} … c_{n,n} with
/// Pₙ(x) = Σ_m c_{n,m} x^m.
pub(crate) fn legendre_coefficients(d: usize) -> Vec<Vec<f64>> {
    let mut rows: Vec<Vec<f64>> = Vec::with_capacity(d + 1);
    for k in 0..=d {
        let row = match k {
            0 => vec![1.0],
            1 => vec![0.0, 1.0],
            _ => {
                let n = (k - 1) as f64;
                let mut r = vec![0.0; k + 1];
                for (m, c) in rows[k - 1].iter().enumerate() {
                    r[m + 1] += (2.0 * n + 1.0) * c / (n + 1.0);
                }
                for (m, c) in rows[k - 2].iter().enumerate() {
                    r[m] -= n * c / (n + 1.0);
                }
                r
            }
        };
        rows.push(row);
    }
    rows
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn legendre_coefficients_match_recurrence() {
        let c = legendre_coefficients(8);
        let mut p = [0.0; 9];
        for x in [-1.0, -0.3, 0.0, 0.45, 1.0] {
            legendre_into(x, &mut p);
            for n in 0..=8 {
                let v: f64 = c[n]
                    .iter()
                    .enumerate()
                    .map(|(m, c)| c * x.powi(m as i32))
                    .sum();
                assert!((v - p[n]).abs() < 1e-13, "P_{n}({x})");
            }
        }
    }

    #[test]
    fn frequency_basis_in_s() {
        let b = FrequencyBasis::Legendre { omega_max: 7.0 };
        let d = b.monomial_coefficients(7, 3.0);
        let mut psi = [Complex::new(0.0, 0.0); 8];
        for w in [-9.0, -2.0, 0.5, 6.9] {
            b.eval_into(w, &mut psi);
            let s = Complex::new(0.0, w / 3.0);
            for n in 0..=7 {
                let v = d[n]
                    .iter()
                    .enumerate()
                    .fold(Complex::new(0.0, 0.0), |a, (m, c)| {
                        a + s.powi(m as i32) * *c
                    });
                assert!(
                    (v - psi[n]).norm() < 1e-12 * (1.0 + psi[n].norm()),
                    "n = {n}"
                );
                // conjugate symmetry
                let mut neg = [Complex::new(0.0, 0.0); 8];
                b.eval_into(-w, &mut neg);
                assert!((neg[n] - psi[n].conj()).norm() < 1e-14);
            }
        }
    }

    #[test]
    fn time_basis_in_t() {
        let c = TimeBasis::Legendre.monomial_coefficients(6, 2.5);
        let mut b = [0.0; 7];
        for t in [0.0, 0.3, 1.25, 2.5] {
            TimeBasis::Legendre.eval_into(t, 2.5, &mut b);
            for p in 0..=6 {
                let v: f64 = c[p]
                    .iter()
                    .enumerate()
                    .map(|(q, c)| c * t.powi(q as i32))
                    .sum();
                assert!((v - b[p]).abs() < 1e-12, "b_{p}({t})");
            }
        }
    }
}
