//! Roots of polynomials given in a [`PolyBasis`]: eigenvalues of a companion matrix
//! (discrete time) or of the comrade matrix of the orthonormal recurrence (continuous time),
//! never through monomial coefficients of the orthonormal expansion.

use crate::basis::PolyBasis;
use crate::error::{FdidError, Result};
use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;
use num_traits::Float;

/// Roots of P = Σ cₙ φₙ in the model's variable: s (rad/s) for continuous time, z for
/// discrete time (where P is a polynomial in z⁻¹; roots at z = 0, from trailing zero
/// coefficients, are left out).
///
/// Highest-degree coefficients smaller than 8·ε·‖c‖ are treated as zero (the degree drops).
///
/// # Errors
/// [`FdidError::NotConverged`] if the eigenvalue iteration fails, [`FdidError::Numerical`]
/// for non-finite coefficients.
pub fn roots<T: Real>(basis: &PolyBasis<T>, coeffs: &[T]) -> Result<Vec<Complex<T>>> {
    if coeffs.iter().any(|c| !Float::is_finite(*c)) {
        return Err(FdidError::Numerical {
            what: "polynomial coefficients are not finite".into(),
        });
    }
    let norm = Float::sqrt(coeffs.iter().fold(T::zero(), |a, c| a + *c * *c));
    let tol = norm * T::default_epsilon() * T::lit(8.0);
    match basis {
        PolyBasis::Orthonormal { scale, gamma } => {
            let mut n = coeffs.len();
            while n > 0 && Float::abs(coeffs[n - 1]) <= tol {
                n -= 1;
            }
            if n <= 1 {
                return Ok(vec![]);
            }
            let d = n - 1; // degree
            let cn = coeffs[d];
            // x φ_k = γ_{k+1} φ_{k+1} − γ_k φ_{k−1},  x = s/ω_s
            let mut m = DMatrix::<T>::zeros(d, d);
            for k in 0..d {
                if k + 1 < d {
                    m[(k, k + 1)] = gamma[k];
                }
                if k >= 1 {
                    m[(k, k - 1)] = -gamma[k - 1];
                }
            }
            for j in 0..d {
                m[(d - 1, j)] -= gamma[d - 1] * coeffs[j] / cn;
            }
            Ok(eigenvalues(m)?.into_iter().map(|x| x * *scale).collect())
        }
        PolyBasis::PartialFractions { .. } => {
            let Some(pf) = PartialFractionNumerator::new(basis, coeffs) else {
                return Ok(vec![]);
            };
            let (q, b, c, c0) = (&pf.q, &pf.b, &pf.c, pf.c0);
            let n = q.nrows();
            if Float::abs(c0) > tol {
                // zeros of c₀ + cᵀ(sI − Q)⁻¹b: eigenvalues of Q − b cᵀ/c₀
                return eigenvalues(q - b * c.transpose() / c0);
            }
            // strictly proper, relative degree r: with Q_σ = Q − σI (σ away from the
            // spectrum) and m = cᵀQ_σ^{r−1}b the first non-zero Markov parameter, the zeros
            // are the eigenvalues of (I − b cᵀQ_σ^{r−1}/m) Q_σ, shifted back by σ, except r
            // spurious ones at 0 (the span of cᵀ, …, cᵀQ_σ^{r−1} is a left-invariant subspace
            // on which the matrix is nilpotent)
            let (r, m, row) = pf.markov();
            if r == 0 {
                return Ok(vec![]); // N ≡ 0 numerically
            }
            let eye = nalgebra::DMatrix::<T>::identity(n, n);
            let proj = &eye - b * &row / m;
            let mut ev = eigenvalues(proj * &pf.shifted)?;
            for _ in 0..r {
                if let Some(i) = ev
                    .iter()
                    .enumerate()
                    .min_by(|x, y| {
                        x.1.norm()
                            .partial_cmp(&y.1.norm())
                            .unwrap_or(std::cmp::Ordering::Equal)
                    })
                    .map(|(i, _)| i)
                {
                    ev.remove(i);
                }
            }
            Ok(ev.into_iter().map(|z| z + pf.sigma).collect())
        }
        PolyBasis::DelayPowers { .. } => {
            // z^n Σ c_k z^{-k} = c_0 z^n + c_1 z^{n-1} + … + c_n
            let mut hi = coeffs.len();
            while hi > 0 && coeffs[hi - 1] == T::zero() {
                hi -= 1; // roots at the origin
            }
            let mut lo = 0;
            while lo < hi && Float::abs(coeffs[lo]) <= tol {
                lo += 1; // degree drops
            }
            if hi <= lo + 1 {
                return Ok(vec![]);
            }
            let c = &coeffs[lo..hi];
            let d = c.len() - 1;
            let mut m = DMatrix::<T>::zeros(d, d);
            for j in 0..d {
                m[(0, j)] = -c[j + 1] / c[0];
            }
            for k in 1..d {
                m[(k, k - 1)] = T::one();
            }
            eigenvalues(m)
        }
    }
}

/// The numerator N(s) = c₀ + cᵀ(sI − Q)⁻¹b of a partial-fraction expansion, with the shift
/// σ used to separate its zeros from the spurious eigenvalues.
struct PartialFractionNumerator<T: Real> {
    q: DMatrix<T>,
    b: nalgebra::DVector<T>,
    c: nalgebra::DVector<T>,
    c0: T,
    shifted: DMatrix<T>,
    sigma: T,
}

impl<T: Real> PartialFractionNumerator<T> {
    fn new(basis: &PolyBasis<T>, coeffs: &[T]) -> Option<Self> {
        let (q, b) = basis.realisation()?;
        let n = q.nrows();
        let c = nalgebra::DVector::from_iterator(
            n,
            (1..=n).map(|k| coeffs.get(k).copied().unwrap_or_else(T::zero)),
        );
        let c0 = coeffs.first().copied().unwrap_or_else(T::zero);
        let radius = q
            .iter()
            .fold(T::one(), |m, v| Float::max(m, Float::abs(*v)));
        let sigma = -radius * T::lit(7.3);
        let shifted = &q - DMatrix::<T>::identity(n, n) * sigma;
        Some(Self {
            q,
            b,
            c,
            c0,
            shifted,
            sigma,
        })
    }

    /// Relative degree r ≥ 1 of the strictly proper part, its first non-negligible Markov
    /// parameter m = cᵀQ_σ^{r−1}b (= cᵀQ^{r−1}b, the leading coefficient of N·Π(s − q)) and
    /// the row cᵀQ_σ^{r−1}; r = 0 when N ≡ 0 numerically.
    fn markov(&self) -> (usize, T, nalgebra::RowDVector<T>) {
        let qn = self.shifted.norm();
        let mut row = self.c.transpose();
        for k in 0..self.q.nrows() {
            let mk = (&row * &self.b)[(0, 0)];
            let scale = self.c.norm() * self.b.norm() * Float::powi(qn, k as i32);
            if Float::abs(mk) > T::lit(1e3) * T::default_epsilon() * scale {
                return (k + 1, mk, row);
            }
            row = &row * &self.shifted;
        }
        (0, T::zero(), row)
    }
}

/// Leading coefficient of the numerator of Σ cₙφₙ written over Π(s − qⱼ) (partial-fraction
/// basis): c₀ when it is not negligible, else the first non-negligible Markov parameter.
/// `None` for the polynomial bases.
pub(crate) fn partial_fraction_leading<T: Real>(basis: &PolyBasis<T>, coeffs: &[T]) -> Option<T> {
    let norm = Float::sqrt(coeffs.iter().fold(T::zero(), |a, c| a + *c * *c));
    let tol = norm * T::default_epsilon() * T::lit(8.0);
    let pf = PartialFractionNumerator::new(basis, coeffs)?;
    if Float::abs(pf.c0) > tol {
        return Some(pf.c0);
    }
    Some(pf.markov().1)
}

/// Eigenvalues of a real matrix (balanced Hessenberg QR, [`crate::linalg::eigenvalues`]);
/// typed errors when a value is not finite or the iteration does not converge.
pub(crate) fn eigenvalues<T: Real>(m: DMatrix<T>) -> Result<Vec<Complex<T>>> {
    let d = m.nrows();
    if m.iter().any(|v| !Float::is_finite(*v)) {
        return Err(FdidError::Numerical {
            what: "eigenvalues of the companion matrix".into(),
        });
    }
    let ev = crate::linalg::eigenvalues::eigenvalues(m).ok_or(FdidError::NotConverged {
        method: "Hessenberg QR eigenvalue iteration",
        reason: format!("no convergence for a companion matrix of size {d}"),
    })?;
    if ev
        .iter()
        .any(|e| !(Float::is_finite(e.re) && Float::is_finite(e.im)))
    {
        return Err(FdidError::Numerical {
            what: "eigenvalues of the companion matrix".into(),
        });
    }
    Ok(ev)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Ascending monomial coefficients of Π(s − rᵢ).
    fn monic_from_roots(roots: &[Complex<f64>]) -> Vec<Complex<f64>> {
        let mut p = vec![Complex::new(1.0, 0.0)];
        for r in roots {
            let mut q = vec![Complex::new(0.0, 0.0); p.len() + 1];
            for (i, c) in p.iter().enumerate() {
                q[i + 1] += *c;
                q[i] -= *c * *r;
            }
            p = q;
        }
        p
    }

    fn sorted(mut v: Vec<Complex<f64>>) -> Vec<Complex<f64>> {
        v.sort_by(|a, b| (a.re, a.im).partial_cmp(&(b.re, b.im)).unwrap());
        v
    }

    #[test]
    fn comrade_roots_match() {
        let omega: Vec<f64> = (1..200).map(|k| 0.05 * k as f64).collect();
        let b = PolyBasis::orthonormal(&omega, 4).unwrap();
        // P(s) = (s+1)(s+2)(s^2+0.2s+4): find basis coefficients by LS through to_monomial
        let want = [
            Complex::new(-1.0, 0.0),
            Complex::new(-2.0, 0.0),
            Complex::new(-0.1, (4.0f64 - 0.01).sqrt()),
            Complex::new(-0.1, -(4.0f64 - 0.01).sqrt()),
        ];
        // monomial coefficient columns of φ_k
        let mut cols = vec![];
        for k in 0..5 {
            let mut e = vec![0.0; 5];
            e[k] = 1.0;
            cols.push(b.to_monomial(&e));
        }
        // target monomial (ascending): expand the product
        let p = monic_from_roots(&want);
        let a = DMatrix::from_fn(5, 5, |i, j| cols[j][i]);
        let rhs = nalgebra::DVector::from_fn(5, |i, _| p[i].re);
        let c = a.lu().solve(&rhs).unwrap();
        let r = sorted(roots(&b, c.as_slice()).unwrap());
        for (x, y) in r.iter().zip(sorted(want.to_vec())) {
            assert!((x - y).norm() < 1e-9, "{x} vs {y}");
        }
    }

    #[test]
    fn partial_fraction_roots_any_relative_degree() {
        let b = PolyBasis::partial_fractions(vec![
            Complex::new(-0.3, 2.0),
            Complex::new(-1.5, 0.0),
            Complex::new(-0.1, 7.0),
        ])
        .unwrap();
        let n = 5;
        // coefficients of the polynomial with the given roots, via monomials: solve for c
        // from the numerator polynomial through to_monomial's columns
        let cols: Vec<Vec<f64>> = (0..=n)
            .map(|k| {
                let mut e = vec![0.0; n + 1];
                e[k] = 1.0;
                b.to_monomial(&e)
            })
            .collect();
        for want in [
            vec![
                Complex::new(-2.0, 0.0),
                Complex::new(-1.0, 3.0),
                Complex::new(-1.0, -3.0),
            ],
            vec![
                Complex::new(-2.0, 0.0),
                Complex::new(-1.0, 3.0),
                Complex::new(-1.0, -3.0),
                Complex::new(0.5, 0.0),
            ],
        ] {
            let p = monic_from_roots(&want);
            // strictly proper numerator: c₀ = 0, solve the 5 remaining from degrees 0..4
            let a = DMatrix::from_fn(n, n, |i, j| cols[j + 1][i]);
            let rhs = nalgebra::DVector::from_fn(n, |i, _| p.get(i).map_or(0.0, |c| c.re));
            let c = a.lu().solve(&rhs).unwrap();
            let mut full = vec![0.0];
            full.extend(c.iter());
            let r = sorted(roots(&b, &full).unwrap());
            assert_eq!(r.len(), want.len());
            for (x, y) in r.iter().zip(sorted(want.clone())) {
                assert!((x - y).norm() < 1e-8, "{x} vs {y}");
            }
        }
    }

    #[test]
    fn companion_roots_in_z() {
        let b = PolyBasis::delay_powers(1.0f64).unwrap();
        // (1 - 0.5 z^-1)(1 + 0.25 z^-1) z^-1 -> roots 0.5, -0.25 (origin left out)
        let r = sorted(roots(&b, &[1.0, -0.25, -0.125, 0.0]).unwrap());
        assert!((r[0] - Complex::new(-0.25, 0.0)).norm() < 1e-12);
        assert!((r[1] - Complex::new(0.5, 0.0)).norm() < 1e-12);
        assert_eq!(r.len(), 2);
        assert!(roots(&b, &[f64::NAN, 1.0]).is_err());
    }
}
