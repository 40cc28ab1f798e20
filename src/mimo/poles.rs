//! The poles shared by every entry of a multi-input multi-output model, and the real
//! partial-fraction basis they span.

use crate::error::Result;
use crate::model::Domain;
use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;
use num_traits::Float;

/// Poles of a real model: real poles and complex-conjugate pairs, each pair held by its
/// member with Im p > 0. In s (rad/s) or z (the z-plane) by the model's domain.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct PoleSet<T: Real> {
    /// Real poles.
    pub real: Vec<T>,
    /// One member (Im p > 0) of each complex-conjugate pair.
    pub pairs: Vec<Complex<T>>,
}

impl<T: Real> PoleSet<T> {
    /// The order n: real poles plus twice the pairs.
    pub fn order(&self) -> usize {
        self.real.len() + 2 * self.pairs.len()
    }

    /// Every pole as a complex number (the real ones, then each pair's two members).
    pub fn all(&self) -> Vec<Complex<T>> {
        let mut v: Vec<Complex<T>> = self
            .real
            .iter()
            .map(|r| Complex::new(*r, T::zero()))
            .collect();
        for p in &self.pairs {
            v.push(*p);
            v.push(p.conj());
        }
        v
    }

    /// The poles one slot each (real ones, then the Im > 0 member of each pair): the
    /// order of the residue matrices of [`super::CommonPoleModel`].
    pub fn slots(&self) -> Vec<Complex<T>> {
        self.real
            .iter()
            .map(|r| Complex::new(*r, T::zero()))
            .chain(self.pairs.iter().copied())
            .collect()
    }

    /// The poles as real parameters: [real poles…, Re p, Im p of each pair…].
    pub(crate) fn theta(&self) -> Vec<T> {
        let mut v = self.real.clone();
        for p in &self.pairs {
            v.push(p.re);
            v.push(p.im);
        }
        v
    }

    /// The inverse of [`PoleSet::theta`] for `n_real` real poles.
    pub(crate) fn from_theta(n_real: usize, theta: &[T]) -> Self {
        let real = theta[..n_real].to_vec();
        let pairs = theta[n_real..]
            .chunks_exact(2)
            .map(|c| Complex::new(c[0], c[1]))
            .collect();
        Self { real, pairs }
    }

    /// Sorts eigenvalues of a real matrix into real poles and pairs: an eigenvalue with
    /// |Im λ| ≤ 10⁻¹⁰·max(|λ|, 1)·‖·‖ (f64) is real; the others come in conjugate pairs, of
    /// which the member with Im λ > 0 is kept.
    pub(crate) fn from_eigenvalues(ev: &[Complex<T>]) -> Self {
        let tol = Float::sqrt(T::default_epsilon()) * T::lit(1e-2);
        let mut real = Vec::new();
        let mut pairs = Vec::new();
        for e in ev {
            let size = Float::max(e.norm(), T::one());
            if Float::abs(e.im) <= tol * size {
                real.push(e.re);
            } else if e.im > T::zero() {
                pairs.push(*e);
            }
        }
        real.sort_by(|a, b| b.partial_cmp(a).unwrap_or(std::cmp::Ordering::Equal));
        pairs.sort_by(|a, b| a.im.partial_cmp(&b.im).unwrap_or(std::cmp::Ordering::Equal));
        Self { real, pairs }
    }

    /// True when every pole is stable in `domain`: Re p < 0 in s, |p| < 1 in z.
    pub fn is_stable(&self, domain: Domain<T>) -> bool {
        self.all().iter().all(|p| stable(*p, domain))
    }

    /// Every unstable pole reflected into the stable region: Re p → −Re p in s (McKelvey's
    /// pole flipping, as in vector fitting), p → 1/p̄ in z. The magnitude response of a
    /// reflected factor is unchanged up to a constant, so relocation continues from a
    /// model of the same shape.
    pub(crate) fn reflected(&self, domain: Domain<T>) -> Self {
        let flip = |p: Complex<T>| match domain {
            Domain::Continuous if p.re > T::zero() => Complex::new(-p.re, p.im),
            Domain::Discrete { .. } if p.norm() > T::one() => crate::scalar::recip(p.conj()),
            _ => p,
        };
        Self {
            real: self
                .real
                .iter()
                .map(|r| flip(Complex::new(*r, T::zero())).re)
                .collect(),
            pairs: self.pairs.iter().map(|p| flip(*p)).collect(),
        }
    }

    /// The poles scaled by `factor` (s-plane poles between rad/s and scaled units).
    pub(crate) fn scaled(&self, factor: T) -> Self {
        Self {
            real: self.real.iter().map(|r| *r * factor).collect(),
            pairs: self.pairs.iter().map(|p| *p * factor).collect(),
        }
    }

    /// Checks that every pole is finite.
    pub(crate) fn check_finite(&self) -> Result<()> {
        crate::error::check_finite_complex("poles", &self.all())
    }
}

/// True for a stable pole of `domain`.
pub(crate) fn stable<T: Real>(p: Complex<T>, domain: Domain<T>) -> bool {
    match domain {
        Domain::Continuous => p.re < T::zero(),
        Domain::Discrete { .. } => p.norm() < T::one(),
    }
}

/// The real partial-fraction basis of `poles` at the points `x` (L × n, complex):
/// 1/(x − p) for a real pole; for a pair p, p̄ the two real combinations
///
/// ```text
/// φ₁ = 1/(x − p) + 1/(x − p̄),   φ₂ = i/(x − p) − i/(x − p̄),
/// ```
///
/// so that c₁φ₁ + c₂φ₂ = (c₁ + ic₂)/(x − p) + (c₁ − ic₂)/(x − p̄) with real c (vector
/// fitting's real formulation).
pub(crate) fn basis<T: Real>(x: &[Complex<T>], poles: &PoleSet<T>) -> DMatrix<Complex<T>> {
    let n = poles.order();
    let i = Complex::new(T::zero(), T::one());
    DMatrix::from_fn(x.len(), n, |k, col| {
        let xk = x[k];
        let nr = poles.real.len();
        if col < nr {
            crate::scalar::recip(xk - Complex::new(poles.real[col], T::zero()))
        } else {
            let p = poles.pairs[(col - nr) / 2];
            let a = crate::scalar::recip(xk - p);
            let b = crate::scalar::recip(xk - p.conj());
            if (col - nr).is_multiple_of(2) {
                a + b
            } else {
                i * (a - b)
            }
        }
    })
}

/// The derivatives of the basis functions against the pole parameters θ of
/// [`PoleSet::theta`] (L × n, complex): with q = 1/(x − p)² and q̄' = 1/(x − p̄)², the
/// column of a real pole is ∂φ/∂p = q; a pair a ± ib has the two columns
/// P = q + q̄' and M = i(q − q̄'), from which
/// ∂φ₁/∂a = P, ∂φ₁/∂b = M, ∂φ₂/∂a = M, ∂φ₂/∂b = −P.
/// The derivative of Σ c_col φ_col against θ is Ψ C(c) ([`coefficient_matrix`]).
pub(crate) fn derivative_basis<T: Real>(
    x: &[Complex<T>],
    poles: &PoleSet<T>,
) -> DMatrix<Complex<T>> {
    let n = poles.order();
    let nr = poles.real.len();
    let i = Complex::new(T::zero(), T::one());
    let mut d = DMatrix::zeros(x.len(), n);
    for (k, xk) in x.iter().enumerate() {
        for (t, p) in poles.real.iter().enumerate() {
            let q = crate::scalar::recip(*xk - Complex::new(*p, T::zero()));
            d[(k, t)] = q * q;
        }
        for (m, p) in poles.pairs.iter().enumerate() {
            let a = crate::scalar::recip(*xk - *p);
            let b = crate::scalar::recip(*xk - p.conj());
            let (qa, qb) = (a * a, b * b);
            d[(k, nr + 2 * m)] = qa + qb;
            d[(k, nr + 2 * m + 1)] = i * (qa - qb);
        }
    }
    d
}

/// The n × n block-diagonal matrix C(c) with Ψ C(c) = ∂(Σ c_col φ_col)/∂θ for the basis
/// coefficients `c` (length n): c_t for a real pole; [[c₁, −c₂], [c₂, c₁]] for a pair
/// (rows P, M of [`derivative_basis`]; columns a, b).
pub(crate) fn coefficient_matrix<T: Real>(poles: &PoleSet<T>, c: &[T]) -> DMatrix<T> {
    let n = poles.order();
    let nr = poles.real.len();
    let mut m = DMatrix::zeros(n, n);
    for t in 0..nr {
        m[(t, t)] = c[t];
    }
    for k in 0..poles.pairs.len() {
        let t = nr + 2 * k;
        let (c1, c2) = (c[t], c[t + 1]);
        m[(t, t)] = c1;
        m[(t, t + 1)] = -c2;
        m[(t + 1, t)] = c2;
        m[(t + 1, t + 1)] = c1;
    }
    m
}

/// The evaluation points of a model in `domain` at `omega` (rad/s): iω/`scale` in s,
/// e^{iωTs} in z.
pub(crate) fn points<T: Real>(omega: &[T], domain: Domain<T>, scale: T) -> Vec<Complex<T>> {
    omega
        .iter()
        .map(|w| match domain {
            Domain::Continuous => Complex::new(T::zero(), *w / scale),
            Domain::Discrete { ts } => Complex::new(T::zero(), *w * ts).exp(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derivative_matches_differences() {
        let poles = PoleSet {
            real: vec![-0.3],
            pairs: vec![Complex::new(-0.1, 0.8)],
        };
        let x: Vec<Complex<f64>> = (1..6).map(|k| Complex::new(0.0, 0.3 * k as f64)).collect();
        let c = [0.7, -1.2, 0.4];
        let d = derivative_basis(&x, &poles)
            * coefficient_matrix(&poles, &c).map(|v| Complex::new(v, 0.0));
        let theta = poles.theta();
        for t in 0..3 {
            let h = 1e-7;
            let mut tp = theta.clone();
            tp[t] += h;
            let mut tm = theta.clone();
            tm[t] -= h;
            let bp = basis(&x, &PoleSet::from_theta(1, &tp));
            let bm = basis(&x, &PoleSet::from_theta(1, &tm));
            for k in 0..x.len() {
                let mut num = Complex::new(0.0, 0.0);
                for col in 0..3 {
                    num += (bp[(k, col)] - bm[(k, col)]) * c[col] / (2.0 * h);
                }
                assert!((num - d[(k, t)]).norm() < 1e-6, "θ{t} line {k}");
            }
        }
    }

    #[test]
    fn eigenvalues_sort_into_real_poles_and_pairs() {
        let ev = [
            Complex::new(-1.0, 1e-14),
            Complex::new(-0.2, 3.0),
            Complex::new(-0.2, -3.0),
        ];
        let s = PoleSet::from_eigenvalues(&ev);
        assert_eq!((s.real.len(), s.pairs.len()), (1, 1));
        assert!(s.is_stable(Domain::Continuous));
        let flipped = PoleSet {
            real: vec![2.0],
            pairs: vec![Complex::new(0.5, 1.0)],
        }
        .reflected(Domain::Continuous);
        assert!(flipped.is_stable(Domain::Continuous));
    }
}
