//! Eigenvalues of a real square matrix without its Schur vectors: balancing (Parlett and
//! Reinsch), Householder reduction to upper Hessenberg form (nalgebra's), and the Francis
//! double-shift QR iteration on the active window only (Golub and Van Loan, algorithm
//! 7.5.2, without accumulating the transformations): about half the time of a Schur
//! decomposition that also forms Q, for the same eigenvalues.

use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;
use num_traits::Float;

/// Balancing sweeps at most (each scales rows and columns by powers of 2; two or three
/// sweeps settle in practice).
const BALANCE_SWEEPS: usize = 100;

/// Double-shift iterations at most per eigenvalue (exceptional shifts after 10 and 20
/// without deflation, as EISPACK's `hqr`).
const ITERATIONS_PER_EIGENVALUE: usize = 60;

/// The eigenvalues of `a` (complex pairs as conjugates, the one with positive imaginary
/// part first), `None` when a value is not finite or the iteration does not converge.
pub(crate) fn eigenvalues<T: Real>(mut a: DMatrix<T>) -> Option<Vec<Complex<T>>> {
    let n = a.nrows();
    if n != a.ncols() || a.iter().any(|v| !Float::is_finite(*v)) {
        return None;
    }
    if n == 0 {
        return Some(Vec::new());
    }
    balance(&mut a);
    // Householder reduction to upper Hessenberg form (a similarity: same eigenvalues)
    hessenberg_qr(nalgebra::linalg::Hessenberg::new(a).unpack_h())
}

/// Scales row i by 1/f and column i by f (f a power of 2, exact) until every row and
/// column of the off-diagonal part have comparable norms; the eigenvalues are unchanged
/// and their computed values less sensitive to rounding.
fn balance<T: Real>(a: &mut DMatrix<T>) {
    let n = a.nrows();
    let radix = T::lit(2.0);
    let radix2 = radix * radix;
    for _ in 0..BALANCE_SWEEPS {
        let mut done = true;
        for i in 0..n {
            let (mut c, mut r) = (T::zero(), T::zero());
            for j in (0..n).filter(|j| *j != i) {
                c += Float::abs(a[(j, i)]);
                r += Float::abs(a[(i, j)]);
            }
            if c == T::zero() || r == T::zero() {
                continue;
            }
            let sum = c + r;
            let mut f = T::one();
            let mut g = r / radix;
            while c < g {
                f *= radix;
                c *= radix2;
            }
            g = r * radix;
            while c > g {
                f /= radix;
                c /= radix2;
            }
            if (c + r) / f < T::lit(0.95) * sum {
                done = false;
                let inv = T::one() / f;
                for j in 0..n {
                    a[(i, j)] *= inv;
                    a[(j, i)] *= f;
                }
            }
        }
        if done {
            break;
        }
    }
}

/// |a| with the sign of b.
fn with_sign<T: Real>(a: T, b: T) -> T {
    if b >= T::zero() {
        Float::abs(a)
    } else {
        -Float::abs(a)
    }
}

/// The eigenvalues of an upper Hessenberg matrix by the Francis double-shift QR
/// iteration, deflating from the bottom as subdiagonal entries become negligible
/// (below ε times their diagonal neighbours).
fn hessenberg_qr<T: Real>(mut a: DMatrix<T>) -> Option<Vec<Complex<T>>> {
    let n = a.nrows();
    let mut out = vec![Complex::new(T::zero(), T::zero()); n];
    let norm = (0..n).fold(T::zero(), |s, i| {
        (i.saturating_sub(1)..n).fold(s, |s, j| s + Float::abs(a[(i, j)]))
    });
    let eps = T::default_epsilon();
    let half = T::lit(0.5);
    // the exceptional shifts accumulate into t
    let mut t = T::zero();
    let mut nn = n - 1;
    loop {
        let mut its = 0;
        loop {
            // the lowest l with a negligible a[l][l−1] (the active window is l..=nn)
            let mut l = nn;
            while l >= 1 {
                let mut s = Float::abs(a[(l - 1, l - 1)]) + Float::abs(a[(l, l)]);
                if s == T::zero() {
                    s = norm;
                }
                if Float::abs(a[(l, l - 1)]) <= eps * s {
                    a[(l, l - 1)] = T::zero();
                    break;
                }
                l -= 1;
            }
            let mut x = a[(nn, nn)];
            if l == nn {
                // one real eigenvalue
                out[nn] = Complex::new(x + t, T::zero());
                if nn == 0 {
                    return Some(out);
                }
                nn -= 1;
                break;
            }
            let mut y = a[(nn - 1, nn - 1)];
            let mut w = a[(nn, nn - 1)] * a[(nn - 1, nn)];
            if l + 1 == nn {
                // a 2 × 2 block: two real eigenvalues or a complex pair
                let p = half * (y - x);
                let q = p * p + w;
                let z = Float::sqrt(Float::abs(q));
                x += t;
                if q >= T::zero() {
                    let z = p + with_sign(z, p);
                    let high = x + z;
                    let low = if z != T::zero() { x - w / z } else { high };
                    out[nn - 1] = Complex::new(high, T::zero());
                    out[nn] = Complex::new(low, T::zero());
                } else {
                    out[nn - 1] = Complex::new(x + p, z);
                    out[nn] = Complex::new(x + p, -z);
                }
                if nn < 2 {
                    return Some(out);
                }
                nn -= 2;
                break;
            }
            if its == ITERATIONS_PER_EIGENVALUE {
                return None;
            }
            if its > 0 && its % 10 == 0 {
                // exceptional shift
                t += x;
                for i in 0..=nn {
                    a[(i, i)] -= x;
                }
                let s = Float::abs(a[(nn, nn - 1)]) + Float::abs(a[(nn - 1, nn - 2)]);
                x = T::lit(0.75) * s;
                y = x;
                w = T::lit(-0.4375) * s * s;
            }
            its += 1;
            // the first column of the double-shift polynomial, and the highest m ≥ l
            // where it may start (two consecutive small subdiagonal entries)
            let mut m = nn - 2;
            let (mut p, mut q, mut r);
            loop {
                let z = a[(m, m)];
                let rr = x - z;
                let ss = y - z;
                p = (rr * ss - w) / a[(m + 1, m)] + a[(m, m + 1)];
                q = a[(m + 1, m + 1)] - z - rr - ss;
                r = a[(m + 2, m + 1)];
                let s = Float::abs(p) + Float::abs(q) + Float::abs(r);
                p /= s;
                q /= s;
                r /= s;
                if m == l {
                    break;
                }
                let u = Float::abs(a[(m, m - 1)]) * (Float::abs(q) + Float::abs(r));
                let v = Float::abs(p)
                    * (Float::abs(a[(m - 1, m - 1)])
                        + Float::abs(z)
                        + Float::abs(a[(m + 1, m + 1)]));
                if u <= eps * v {
                    break;
                }
                m -= 1;
            }
            for i in m + 2..=nn {
                a[(i, i - 2)] = T::zero();
                if i != m + 2 {
                    a[(i, i - 3)] = T::zero();
                }
            }
            // the double QR step on rows and columns m..=nn of the window
            for k in m..nn {
                if k != m {
                    p = a[(k, k - 1)];
                    q = a[(k + 1, k - 1)];
                    r = if k + 1 != nn {
                        a[(k + 2, k - 1)]
                    } else {
                        T::zero()
                    };
                    x = Float::abs(p) + Float::abs(q) + Float::abs(r);
                    if x != T::zero() {
                        p /= x;
                        q /= x;
                        r /= x;
                    }
                }
                let s = with_sign(Float::sqrt(p * p + q * q + r * r), p);
                if s == T::zero() {
                    continue;
                }
                if k == m {
                    if l != m {
                        a[(k, k - 1)] = -a[(k, k - 1)];
                    }
                } else {
                    a[(k, k - 1)] = -s * x;
                }
                p += s;
                x = p / s;
                y = q / s;
                let z = r / s;
                q /= p;
                r /= p;
                for j in k..=nn {
                    let mut pp = a[(k, j)] + q * a[(k + 1, j)];
                    if k + 1 != nn {
                        pp += r * a[(k + 2, j)];
                        a[(k + 2, j)] -= pp * z;
                    }
                    a[(k + 1, j)] -= pp * y;
                    a[(k, j)] -= pp * x;
                }
                let last = nn.min(k + 3);
                for i in l..=last {
                    let mut pp = x * a[(i, k)] + y * a[(i, k + 1)];
                    if k + 1 != nn {
                        pp += z * a[(i, k + 2)];
                        a[(i, k + 2)] -= pp * r;
                    }
                    a[(i, k + 1)] -= pp * q;
                    a[(i, k)] -= pp;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sorted (re, im) pairs for comparing spectra.
    fn sorted(mut v: Vec<Complex<f64>>) -> Vec<Complex<f64>> {
        v.sort_by(|a, b| {
            a.re.partial_cmp(&b.re)
                .unwrap()
                .then(a.im.partial_cmp(&b.im).unwrap())
        });
        v
    }

    fn reference(m: &DMatrix<f64>) -> Vec<Complex<f64>> {
        let schur = nalgebra::Schur::new(m.clone());
        schur
            .complex_eigenvalues()
            .iter()
            .map(|e| Complex::new(e.re, e.im))
            .collect()
    }

    #[test]
    fn matches_the_schur_decomposition_on_varied_matrices() {
        for n in [1, 2, 3, 5, 12, 50] {
            for seed in 0..4u64 {
                let m = DMatrix::from_fn(n, n, |i, j| {
                    let k = (i * 131 + j * 71 + seed as usize * 17) as f64;
                    (k * 0.618).sin() * 10f64.powi(((i + 2 * j) % 5) as i32 - 2)
                });
                let got = sorted(eigenvalues(m.clone()).unwrap());
                let want = sorted(reference(&m));
                let scale = m.norm();
                for (g, w) in got.iter().zip(&want) {
                    assert!(
                        (g - w).norm() <= 1e-9 * scale,
                        "n {n} seed {seed}: {g} vs {w}"
                    );
                }
            }
        }
    }

    #[test]
    fn recovers_known_spectra() {
        // block diagonal pairs σ ± iω and reals, mixed by a similarity
        let pairs = [(-0.1, 1.0), (-0.02, 3.0), (-1.0, 0.5)];
        let reals = [-2.0, -0.3];
        let n = 2 * pairs.len() + reals.len();
        let mut d = DMatrix::<f64>::zeros(n, n);
        for (k, (s, w)) in pairs.iter().enumerate() {
            d[(2 * k, 2 * k)] = *s;
            d[(2 * k, 2 * k + 1)] = *w;
            d[(2 * k + 1, 2 * k)] = -*w;
            d[(2 * k + 1, 2 * k + 1)] = *s;
        }
        for (k, r) in reals.iter().enumerate() {
            d[(2 * pairs.len() + k, 2 * pairs.len() + k)] = *r;
        }
        let t = DMatrix::from_fn(n, n, |i, j| {
            if i == j {
                2.0
            } else {
                ((i + 3 * j) as f64).cos() * 0.4
            }
        });
        let m = &t * d * t.clone().try_inverse().unwrap();
        let got = sorted(eigenvalues(m).unwrap());
        let mut want: Vec<Complex<f64>> = pairs
            .iter()
            .flat_map(|(s, w)| [Complex::new(*s, *w), Complex::new(*s, -*w)])
            .chain(reals.iter().map(|r| Complex::new(*r, 0.0)))
            .collect();
        want = sorted(want);
        for (g, w) in got.iter().zip(&want) {
            assert!((g - w).norm() < 1e-12, "{g} vs {w}");
        }
    }

    #[test]
    fn refuses_non_finite_and_handles_trivial_sizes() {
        let mut m = DMatrix::<f64>::identity(3, 3);
        m[(1, 2)] = f64::NAN;
        assert!(eigenvalues(m).is_none());
        assert!(eigenvalues(DMatrix::<f64>::zeros(0, 0)).unwrap().is_empty());
        let zero = eigenvalues(DMatrix::<f64>::zeros(4, 4)).unwrap();
        assert!(zero.iter().all(|e| e.norm() == 0.0));
        let f32s =
            eigenvalues(DMatrix::<f32>::from_row_slice(2, 2, &[0.0, 1.0, -4.0, 0.0])).unwrap();
        assert!(
            f32s.iter()
                .all(|e| (e.im.abs() - 2.0).abs() < 1e-6 && e.re.abs() < 1e-6)
        );
    }
}
