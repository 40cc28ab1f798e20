//! The orthogonal complement of a subspace as a product of Householder reflectors, applied
//! to a row vector in O(m·n) operations instead of the O(n²) of a dense n × (n − m) basis.
//!
//! For an n × m matrix U of full column rank, Householder QR gives U = Q R with
//! Q = H₁H₂⋯H_m, Hⱼ = I − τⱼvⱼvⱼᵀ (Golub & Van Loan, *Matrix Computations*, alg. 5.2.1). The
//! last n − m columns of Q are an orthonormal basis Z of the complement of span U, and a
//! row vector x maps to xZ = (x H₁ H₂ ⋯ H_m)[m..], two passes over n entries per reflector.

use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;
use num_traits::Float;

/// One reflector H = I − τvvᵀ; v is zero before `start`.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub(crate) struct Reflector<T: Real> {
    start: usize,
    v: Vec<T>,
    tau: T,
}

/// Z = (H₁⋯H_m)[:, m..], the orthonormal complement of span U, held as its reflectors.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub(crate) struct Complement<T: Real> {
    n: usize,
    reflectors: Vec<Reflector<T>>,
}

impl<T: Real> Complement<T> {
    /// The reflectors of the Householder QR of `u` (n × m, m ≤ n). `None` when a column is
    /// not finite, or zero to rounding after the previous reflections (U rank deficient).
    pub(crate) fn of(u: &DMatrix<T>) -> Option<Self> {
        let (n, m) = u.shape();
        if m > n {
            return None;
        }
        let mut a = u.clone();
        let mut reflectors = Vec::with_capacity(m);
        for j in 0..m {
            let x: Vec<T> = (j..n).map(|i| a[(i, j)]).collect();
            let norm = Float::sqrt(x.iter().fold(T::zero(), |s, v| s + *v * *v));
            let tiny = T::lit(64.0) * T::default_epsilon() * u.column(j).norm();
            if !(norm > tiny) || !Float::is_finite(norm) {
                return None;
            }
            // v = x − αe₁ with α = −sign(x₀)‖x‖: no cancellation in v₀
            let alpha = if x[0] >= T::zero() { -norm } else { norm };
            let mut v = x;
            v[0] -= alpha;
            let vv = v.iter().fold(T::zero(), |s, e| s + *e * *e);
            let tau = (T::one() + T::one()) / vv;
            for c in j..m {
                let dot = (j..n).fold(T::zero(), |s, i| s + v[i - j] * a[(i, c)]);
                for i in j..n {
                    a[(i, c)] -= tau * dot * v[i - j];
                }
            }
            reflectors.push(Reflector { start: j, v, tau });
        }
        Some(Self { n, reflectors })
    }

    /// Whether `other` has the same dimension and reflectors (start, length) with entries
    /// equal to relative `tol`.
    #[cfg(feature = "serde")]
    pub(crate) fn same_as(&self, other: &Self, tol: T) -> bool {
        let close = |x: T, y: T| Float::abs(x - y) <= tol * (T::one() + Float::abs(y));
        self.n == other.n
            && self.reflectors.len() == other.reflectors.len()
            && self.reflectors.iter().zip(&other.reflectors).all(|(a, b)| {
                a.start == b.start
                    && a.v.len() == b.v.len()
                    && close(a.tau, b.tau)
                    && a.v.iter().zip(&b.v).all(|(x, y)| close(*x, *y))
            })
    }

    /// Dimension n of the space.
    pub(crate) fn dim(&self) -> usize {
        self.n
    }

    /// Number m of reflectors (the dimension of the subspace whose complement this is).
    pub(crate) fn rank(&self) -> usize {
        self.reflectors.len()
    }

    /// The complement basis Z = (H₁⋯H_m)[:, m..] as an n × (n − m) matrix.
    pub(crate) fn basis(&self) -> DMatrix<T> {
        let (n, m) = (self.n, self.rank());
        let mut z = DMatrix::zeros(n, n - m);
        for j in 0..n - m {
            z[(m + j, j)] = T::one();
        }
        // Q e = H₁(H₂(⋯ H_m e)): the reflectors from the last
        for r in self.reflectors.iter().rev() {
            for mut col in z.column_iter_mut() {
                let dot =
                    r.v.iter()
                        .enumerate()
                        .fold(T::zero(), |s, (i, v)| s + *v * col[r.start + i]);
                for (i, v) in r.v.iter().enumerate() {
                    col[r.start + i] -= r.tau * dot * *v;
                }
            }
        }
        z
    }

    /// x ← x H₁ ⋯ H_m for a complex row vector of length n; then x[m..] = (x_in) Z.
    #[inline]
    pub(crate) fn reflect_row(&self, x: &mut [Complex<T>]) {
        for r in &self.reflectors {
            let tail = &mut x[r.start..r.start + r.v.len()];
            let (mut re, mut im) = (T::zero(), T::zero());
            for (e, v) in tail.iter().zip(&r.v) {
                re += e.re * *v;
                im += e.im * *v;
            }
            let (re, im) = (re * r.tau, im * r.tau);
            for (e, v) in tail.iter_mut().zip(&r.v) {
                e.re -= re * *v;
                e.im -= im * *v;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::lcg;

    fn random(n: usize, m: usize, seed: u64) -> DMatrix<f64> {
        let mut s = seed;
        DMatrix::from_fn(n, m, |_, _| lcg(&mut s))
    }

    #[test]
    fn basis_is_orthonormal_and_orthogonal_to_the_subspace() {
        for (n, m) in [(1, 0), (2, 1), (5, 1), (10, 3), (20, 7), (6, 6)] {
            let u = random(n, m, 17 + n as u64);
            let c = Complement::of(&u).unwrap();
            let z = c.basis();
            assert_eq!(z.shape(), (n, n - m));
            let eye = z.transpose() * &z;
            assert!((eye - DMatrix::identity(n - m, n - m)).norm() < 1e-14 * n as f64);
            assert!((u.transpose() * &z).norm() <= 1e-14 * n as f64 * u.norm());
        }
    }

    #[test]
    fn reflected_row_equals_the_product_with_the_basis() {
        let (n, m) = (9, 2);
        let c = Complement::of(&random(n, m, 5)).unwrap();
        let z = c.basis();
        let mut s = 11;
        let x: Vec<Complex<f64>> = (0..n)
            .map(|_| Complex::new(lcg(&mut s), lcg(&mut s)))
            .collect();
        let mut y = x.clone();
        c.reflect_row(&mut y);
        for j in 0..n - m {
            let want = (0..n).fold(Complex::new(0.0, 0.0), |acc, k| acc + x[k] * z[(k, j)]);
            assert!((y[m + j] - want).norm() < 1e-14);
        }
    }

    #[test]
    fn rank_deficient_or_non_finite_subspaces_are_refused() {
        let mut u = random(5, 2, 3);
        let first = u.column(0).clone_owned();
        u.set_column(1, &(first * 2.0));
        assert!(Complement::of(&u).is_none());
        let mut u = random(4, 1, 3);
        u[(2, 0)] = f64::NAN;
        assert!(Complement::of(&u).is_none());
        assert!(Complement::of(&random(2, 3, 1)).is_none());
    }
}
