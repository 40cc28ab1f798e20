//! Roots of polynomials given in a [`PolyBasis`]: eigenvalues of a companion matrix
//! (discrete time) or of the comrade matrix of the orthonormal recurrence (continuous time),
//! never through monomial coefficients of the orthonormal expansion.

use crate::basis::PolyBasis;
use crate::error::{FdidError, Result};
use crate::{Complex, Real};
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

fn eigenvalues<T: Real>(m: DMatrix<T>) -> Result<Vec<Complex<T>>> {
    let d = m.nrows();
    let schur = nalgebra::Schur::try_new(m, T::default_epsilon(), 200 * d.max(10)).ok_or(
        FdidError::NotConverged {
            method: "Schur eigenvalue iteration",
            reason: format!("no convergence for a companion matrix of size {d}"),
        },
    )?;
    let ev = schur.complex_eigenvalues();
    if ev
        .iter()
        .any(|e| !(Float::is_finite(e.re) && Float::is_finite(e.im)))
    {
        return Err(FdidError::Numerical {
            what: "eigenvalues of the companion matrix".into(),
        });
    }
    Ok(ev.iter().map(|e| Complex::new(e.re, e.im)).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let mut p = vec![Complex::new(1.0, 0.0)];
        for r in &want {
            let mut q = vec![Complex::new(0.0, 0.0); p.len() + 1];
            for (i, c) in p.iter().enumerate() {
                q[i + 1] += *c;
                q[i] -= *c * *r;
            }
            p = q;
        }
        let a = DMatrix::from_fn(5, 5, |i, j| cols[j][i]);
        let rhs = nalgebra::DVector::from_fn(5, |i, _| p[i].re);
        let c = a.lu().solve(&rhs).unwrap();
        let r = sorted(roots(&b, c.as_slice()).unwrap());
        for (x, y) in r.iter().zip(sorted(want.to_vec())) {
            assert!((x - y).norm() < 1e-9, "{x} vs {y}");
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
