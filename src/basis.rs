//! Polynomial bases for the numerator and denominator of rational models.
//!
//! Raw monomials sⁿ are hopelessly ill-conditioned over several decades of frequency, so
//! continuous-time polynomials are expanded in a basis that is **orthonormal on the data's
//! frequency grid** (Forsythe polynomials, built by the Stieltjes procedure), and
//! discrete-time polynomials in powers of z⁻¹, which are already orthogonal on the unit
//! circle.
//!
//! ## The orthonormal basis in s
//! Let x = ω/ω_s with ω_s the largest frequency. The points ±x_k with equal weights define
//! a symmetric discrete measure, whose orthonormal polynomials pₙ satisfy a three-term
//! recurrence without diagonal term, x pₙ = γₙ₊₁ pₙ₊₁ + γₙ pₙ₋₁, and have the parity of n.
//! The functions φₙ(s) = iⁿ pₙ(−i s/ω_s) are then *real* polynomials in s of degree n with
//!
//! ```text
//! φ₀ = 1,   φ₁ = (s/ω_s)/γ₁,   φₙ₊₁(s) = ((s/ω_s) φₙ(s) + γₙ φₙ₋₁(s)) / γₙ₊₁,
//! ```
//!
//! and |φₙ(iω_k)| = |pₙ(x_k)|, orthonormal over the data. A real coefficient vector c gives
//! the real polynomial P(s) = Σ cₙ φₙ(s), so physical (real-coefficient) models are kept.

use crate::error::{FdidError, Result};
use crate::{Complex, Real};

/// A basis {φ₀, …, φ_d} of real polynomials, evaluated at the model's complex frequency
/// variable (s = iω or z⁻¹ = e^{−iωTs}).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum PolyBasis<T: Real> {
    /// Orthonormal polynomials in s for a continuous-time model (see the module docs).
    Orthonormal {
        /// Frequency scale ω_s (rad/s).
        scale: T,
        /// Recurrence coefficients γ₁ … γ_d (all positive).
        gamma: Vec<T>,
    },
    /// Powers of z⁻¹ for a discrete-time model with sample time `ts`.
    DelayPowers {
        /// Sample time (s).
        ts: T,
    },
}

impl<T: Real> PolyBasis<T> {
    /// Builds the orthonormal basis up to `degree` on the frequency grid `omega` (rad/s).
    ///
    /// # Errors
    /// No positive frequency, or too few distinct frequencies for the degree
    /// (2·#distinct positive lines + 1 if ω = 0 is present must exceed `degree`).
    pub fn orthonormal(omega: &[T], degree: usize) -> Result<Self> {
        let scale = omega.iter().fold(T::zero(), |m, w| Float::max(m, *w));
        if !(scale > T::zero()) || !Float::is_finite(scale) {
            return Err(FdidError::InvalidArgument {
                name: "omega",
                value: format!("max {scale}"),
                reason: "a continuous-time basis needs at least one positive, finite frequency"
                    .into(),
            });
        }
        // symmetric discrete measure: points ±x_k, equal weights summing to one
        let x: Vec<T> = omega.iter().map(|w| *w / scale).collect();
        let n = T::from_usize_lossy(x.len());
        // p_{n-1}, p_n at the points x_k (>= 0); by parity the −x_k half mirrors it.
        let mut prev = vec![T::zero(); x.len()];
        let mut cur = vec![T::one(); x.len()];
        let mut gamma = Vec::with_capacity(degree);
        let tiny = T::default_epsilon() * T::lit(64.0);
        for k in 0..degree {
            let g_prev = if k == 0 { T::zero() } else { gamma[k - 1] };
            // q = x p_k − γ_k p_{k−1}
            let mut norm2 = T::zero();
            let next: Vec<T> = x
                .iter()
                .zip(cur.iter().zip(&prev))
                .map(|(xi, (c, p))| {
                    let q = *xi * *c - g_prev * *p;
                    norm2 += q * q;
                    q
                })
                .collect();
            let g = Float::sqrt(norm2 / n);
            if !(g > tiny) {
                return Err(FdidError::TooFewFrequencies {
                    lines: omega.len(),
                    equations: 2 * omega.len(),
                    parameters: degree + 1,
                });
            }
            gamma.push(g);
            prev = cur;
            cur = next.into_iter().map(|q| q / g).collect();
        }
        Ok(Self::Orthonormal { scale, gamma })
    }

    /// The discrete-time basis z⁻ⁿ for sample time `ts`.
    ///
    /// # Errors
    /// `ts ≤ 0` or not finite.
    pub fn delay_powers(ts: T) -> Result<Self> {
        if !(ts > T::zero()) || !Float::is_finite(ts) {
            return Err(FdidError::InvalidArgument {
                name: "ts",
                value: format!("{ts}"),
                reason: "the sample time must be positive and finite".into(),
            });
        }
        Ok(Self::DelayPowers { ts })
    }

    /// Highest degree the basis can evaluate (`usize::MAX` for powers of z⁻¹).
    pub fn max_degree(&self) -> usize {
        match self {
            Self::Orthonormal { gamma, .. } => gamma.len(),
            Self::DelayPowers { .. } => usize::MAX,
        }
    }

    /// The complex frequency variable at angular frequency ω: s = iω (continuous time) or
    /// z = e^{iωTs} (discrete time).
    pub fn variable(&self, omega: T) -> Complex<T> {
        match self {
            Self::Orthonormal { .. } => Complex::new(T::zero(), omega),
            Self::DelayPowers { ts } => Complex::new(T::zero(), omega * *ts).exp(),
        }
    }

    /// Writes φ₀(v) … φ_d(v) into `out` (length d + 1) for the variable `v` returned by
    /// [`PolyBasis::variable`] (or any complex s / z).
    pub fn eval_into(&self, v: Complex<T>, out: &mut [Complex<T>]) {
        let Some(first) = out.first_mut() else {
            return;
        };
        *first = Complex::new(T::one(), T::zero());
        match self {
            Self::Orthonormal { scale, gamma } => {
                let x = v / *scale;
                for k in 1..out.len() {
                    let back = if k >= 2 {
                        out[k - 2] * gamma[k - 2]
                    } else {
                        Complex::new(T::zero(), T::zero())
                    };
                    out[k] = (x * out[k - 1] + back) / gamma[k - 1];
                }
            }
            Self::DelayPowers { .. } => {
                let zinv = v.inv();
                for k in 1..out.len() {
                    out[k] = out[k - 1] * zinv;
                }
            }
        }
    }

    /// Evaluates the polynomial Σ cₙ φₙ(v).
    pub fn eval_poly(&self, coeffs: &[T], v: Complex<T>) -> Complex<T> {
        let mut phi = vec![Complex::new(T::zero(), T::zero()); coeffs.len()];
        self.eval_into(v, &mut phi);
        phi.iter()
            .zip(coeffs)
            .fold(Complex::new(T::zero(), T::zero()), |acc, (p, c)| {
                acc + *p * *c
            })
    }

    /// Converts basis coefficients to monomial coefficients: in s (ascending powers) for the
    /// orthonormal basis, in z⁻¹ (unchanged) for the discrete-time one.
    ///
    /// The conversion is exact in exact arithmetic, but monomial coefficients of a high-order
    /// model spanning several decades are ill-conditioned: use them for display, not for
    /// computation.
    pub fn to_monomial(&self, coeffs: &[T]) -> Vec<T> {
        match self {
            Self::DelayPowers { .. } => coeffs.to_vec(),
            Self::Orthonormal { scale, gamma } => {
                let d = coeffs.len();
                let mut out = vec![T::zero(); d];
                if d == 0 {
                    return out;
                }
                // monomial coefficients of φ_{k-1}, φ_k
                let mut prev: Vec<T> = vec![];
                let mut cur: Vec<T> = vec![T::one()];
                out[0] = coeffs[0];
                for k in 1..d {
                    let mut next = vec![T::zero(); k + 1];
                    for (j, c) in cur.iter().enumerate() {
                        next[j + 1] += *c / *scale;
                    }
                    if k >= 2 {
                        for (j, p) in prev.iter().enumerate() {
                            next[j] += gamma[k - 2] * *p;
                        }
                    }
                    for v in next.iter_mut() {
                        *v /= gamma[k - 1];
                    }
                    for (j, v) in next.iter().enumerate() {
                        out[j] += coeffs[k] * *v;
                    }
                    prev = cur;
                    cur = next;
                }
                out
            }
        }
    }
}

use num_traits::Float;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orthonormal_on_grid() {
        let omega: Vec<f64> = (0..400)
            .map(|k| 10f64.powf(-2.0 + 5.0 * k as f64 / 399.0))
            .collect();
        let b = PolyBasis::orthonormal(&omega, 20).unwrap();
        let mut gram = vec![vec![0.0; 21]; 21];
        let mut phi = vec![Complex::new(0.0, 0.0); 21];
        for w in &omega {
            b.eval_into(b.variable(*w), &mut phi);
            for (row, pi) in gram.iter_mut().zip(&phi) {
                for (g, pj) in row.iter_mut().zip(&phi) {
                    *g += (pi * pj.conj()).re / omega.len() as f64;
                }
            }
        }
        for (i, row) in gram.iter().enumerate() {
            for (j, g) in row.iter().enumerate() {
                // the symmetric measure makes Re⟨φi, φj⟩ = δij on the positive half
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((g - want).abs() < 1e-9, "gram[{i}][{j}] = {g}");
            }
        }
    }

    #[test]
    fn basis_is_real_polynomial_in_s() {
        let omega: Vec<f64> = (1..50).map(|k| k as f64).collect();
        let b = PolyBasis::orthonormal(&omega, 6).unwrap();
        let c = [0.3, -1.0, 2.0, 0.5, -0.25, 1.5, 0.7];
        let mono = b.to_monomial(&c);
        for s in [
            Complex::new(0.3, 2.0),
            Complex::new(-1.0, 0.5),
            Complex::new(0.0, 33.0),
        ] {
            let direct = b.eval_poly(&c, s);
            let via = mono
                .iter()
                .rev()
                .fold(Complex::new(0.0, 0.0), |acc, m| acc * s + *m);
            assert!((direct - via).norm() < 1e-9 * via.norm().max(1.0));
        }
        // real argument gives a real value
        let v = b.eval_poly(&c, Complex::new(0.7, 0.0));
        assert!(v.im.abs() < 1e-12);
    }

    #[test]
    fn too_few_points() {
        assert!(matches!(
            PolyBasis::orthonormal(&[1.0, 2.0], 5),
            Err(FdidError::TooFewFrequencies { .. })
        ));
        assert!(PolyBasis::orthonormal(&[1.0, 2.0], 3).is_ok());
        assert!(PolyBasis::<f64>::orthonormal(&[0.0], 1).is_err());
        assert!(PolyBasis::delay_powers(0.0f64).is_err());
    }
}
