//! Real polynomials in ξ = z⁻¹ orthonormal on the measured lines (Arnoldi), the basis of
//! the common-denominator estimator: on a narrow band of oversampled data the powers ξʲ
//! are nearly dependent (the lines lie on a short arc of the unit circle), these are not.

use crate::error::{FdidError, Result};
use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;
use num_traits::Float;

/// Polynomials q_0 … q_d with real coefficients, orthonormal for the inner product
/// ⟨p, q⟩ = (1/L) Σ_k Re p(ξ_k) q(ξ_k)* over the lines ξ_k (and so over the symmetric
/// point set {ξ_k, ξ̄_k}), built by the Arnoldi recurrence
///
/// ```text
/// q_0 = 1,   h_{j+1,j} q_{j+1}(ξ) = ξ q_j(ξ) − Σ_{i≤j} h_ij q_i(ξ),
/// ```
///
/// with the real Hessenberg matrix H of the coefficients h_ij = ⟨ξ q_j, q_i⟩ (twice
/// orthogonalised). The recurrence evaluates the basis, and its derivative, anywhere.
pub(crate) struct ArcBasis<T: Real> {
    /// (d + 1) × d Hessenberg coefficients.
    h: DMatrix<T>,
    /// q_j(ξ_k), L × (d + 1).
    values: DMatrix<Complex<T>>,
}

impl<T: Real> ArcBasis<T> {
    /// The basis up to degree `degree` on the points `xi`.
    ///
    /// # Errors
    /// [`FdidError::TooFewFrequencies`] when the points cannot carry that degree (the new
    /// polynomial vanishes on them to 10³·ε).
    pub(crate) fn new(xi: &[Complex<T>], degree: usize) -> Result<Self> {
        let l = xi.len();
        let n = T::from_usize_lossy(l);
        let dot = |a: &[Complex<T>], b: &[Complex<T>]| {
            a.iter()
                .zip(b)
                .fold(T::zero(), |s, (x, y)| s + (*x * y.conj()).re)
                / n
        };
        let mut q: Vec<Vec<Complex<T>>> = vec![vec![Complex::new(T::one(), T::zero()); l]];
        let mut h = DMatrix::zeros(degree + 1, degree);
        for j in 0..degree {
            let mut v: Vec<Complex<T>> = xi.iter().zip(&q[j]).map(|(x, y)| *x * *y).collect();
            let before = Float::sqrt(dot(&v, &v));
            for _ in 0..2 {
                for (i, qi) in q.iter().enumerate() {
                    let c = dot(&v, qi);
                    h[(i, j)] += c;
                    for (vk, qk) in v.iter_mut().zip(qi) {
                        *vk -= *qk * c;
                    }
                }
            }
            let norm = Float::sqrt(dot(&v, &v));
            if !(norm > before * T::default_epsilon() * T::lit(1e3)) {
                return Err(FdidError::TooFewFrequencies {
                    lines: l,
                    equations: 2 * l,
                    parameters: degree + 1,
                });
            }
            h[(j + 1, j)] = norm;
            q.push(v.into_iter().map(|x| x / norm).collect());
        }
        let values = DMatrix::from_fn(l, degree + 1, |k, j| q[j][k]);
        Ok(Self { h, values })
    }

    /// q_0 … q_n on the lines (L × (n + 1)).
    pub(crate) fn on_lines(&self, n: usize) -> DMatrix<Complex<T>> {
        self.values.columns(0, n + 1).into_owned()
    }

    /// q_0(x) … q_n(x) and their derivatives.
    pub(crate) fn at(&self, x: Complex<T>, n: usize) -> (Vec<Complex<T>>, Vec<Complex<T>>) {
        let zero = Complex::new(T::zero(), T::zero());
        let mut q = vec![Complex::new(T::one(), T::zero())];
        let mut dq = vec![zero];
        for j in 0..n {
            let (mut v, mut dv) = (x * q[j], q[j] + x * dq[j]);
            for i in 0..=j {
                v -= q[i] * self.h[(i, j)];
                dv -= dq[i] * self.h[(i, j)];
            }
            let norm = self.h[(j + 1, j)];
            q.push(v / norm);
            dq.push(dv / norm);
        }
        (q, dq)
    }

    /// The roots of P(ξ) = Σ_{j≤n} c_j q_j(ξ) (c_n ≠ 0): the eigenvalues of the
    /// confederate matrix H_n − (h_{n,n−1}/c_n) c e_nᵀ, H_n the leading n × n block and
    /// c = (c_0 … c_{n−1}) — the recurrence's companion.
    pub(crate) fn roots(&self, c: &[T]) -> Result<Vec<Complex<T>>> {
        let n = c.len() - 1;
        let lead = c[n];
        let size = c
            .iter()
            .fold(T::zero(), |m, v| Float::max(m, Float::abs(*v)));
        if !(Float::abs(lead) > size * T::default_epsilon()) {
            return Err(FdidError::Numerical {
                what: "roots of the common denominator: its leading coefficient vanishes (a \
                       pole at z = 0 of higher multiplicity than the data resolve)"
                    .into(),
            });
        }
        let scale = self.h[(n, n - 1)] / lead;
        let m = DMatrix::from_fn(n, n, |i, j| {
            let v = self.h[(i, j)];
            if j == n - 1 { v - scale * c[i] } else { v }
        });
        crate::roots::eigenvalues(m)
    }

    /// The real coefficients of the polynomial of degree ≤ n whose values on the lines
    /// are `f`: c_j = ⟨f, q_j⟩.
    pub(crate) fn project(&self, f: &[Complex<T>], n: usize) -> Vec<T> {
        let l = T::from_usize_lossy(f.len());
        (0..=n)
            .map(|j| {
                f.iter().enumerate().fold(T::zero(), |s, (k, v)| {
                    s + (*v * self.values[(k, j)].conj()).re
                }) / l
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On a short arc (lines 2–15 Hz at 400 Hz sampling) the basis of degree 20 is
    /// orthonormal to 10⁻¹², evaluates like the stored values, and finds the roots of a
    /// polynomial built from chosen roots.
    #[test]
    fn orthonormal_on_a_short_arc_with_its_roots() {
        let xi: Vec<Complex<f64>> = (0..267)
            .map(|k| {
                Complex::new(
                    0.0,
                    -(2.0 + 13.0 * k as f64 / 266.0) * std::f64::consts::TAU * 0.0025,
                )
                .exp()
            })
            .collect();
        let basis = ArcBasis::new(&xi, 20).unwrap();
        let q = basis.on_lines(20);
        for a in 0..=20 {
            for b in 0..=20 {
                let d = q
                    .column(a)
                    .iter()
                    .zip(q.column(b).iter())
                    .map(|(x, y)| (x * y.conj()).re)
                    .sum::<f64>()
                    / 267.0;
                let want = if a == b { 1.0 } else { 0.0 };
                assert!((d - want).abs() < 1e-12, "⟨q{a}, q{b}⟩ = {d}");
            }
        }
        let (at, _) = basis.at(xi[100], 20);
        assert!((at[20] - q[(100, 20)]).norm() < 1e-9 * q[(100, 20)].norm().max(1.0));
        let roots = [
            Complex::new(0.99, 0.05),
            Complex::new(0.99, -0.05),
            Complex::new(1.02, 0.0),
        ];
        let f: Vec<Complex<f64>> = xi
            .iter()
            .map(|x| {
                roots
                    .iter()
                    .fold(Complex::new(1.0, 0.0), |v, r| v * (x - r))
            })
            .collect();
        let c = basis.project(&f, 3);
        let mut found = basis.roots(&c).unwrap();
        found.sort_by(|a, b| a.im.partial_cmp(&b.im).unwrap());
        let mut want = roots.to_vec();
        want.sort_by(|a, b| a.im.partial_cmp(&b.im).unwrap());
        for (f, w) in found.iter().zip(&want) {
            assert!((f - w).norm() < 1e-9, "{f} vs {w}");
        }
    }
}
