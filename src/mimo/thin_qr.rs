//! The thin QR factor of the tall real-stacked regressors of a common-pole fit, by
//! matrix products where that is accurate (CholeskyQR2) and Householder otherwise.

use crate::error::{FdidError, Result};
use crate::scalar::Real;
use nalgebra::DMatrix;
use num_traits::Float;

/// A = Q R of a tall matrix with its columns equilibrated first: A D⁻¹ = Q R with D the
/// column norms (`scale`), Q (rows × p) with orthonormal columns and R upper triangular.
pub(crate) struct ThinQr<T: Real> {
    pub q: DMatrix<T>,
    pub r: DMatrix<T>,
    pub scale: Vec<T>,
}

impl<T: Real> ThinQr<T> {
    /// Factors `a` (rows ≥ columns). CholeskyQR2 (Fukaya et al. 2014): R₁ = chol(AᵀA),
    /// Q₁ = A R₁⁻¹, R₂ = chol(Q₁ᵀQ₁), Q = Q₁R₂⁻¹, R = R₂R₁ — three matrix products,
    /// several times faster than Householder QR on these shapes, and orthogonal to
    /// working precision when the first pass was nearly so (every entry of R₂ − I below
    /// 10⁻²); otherwise, or when a Cholesky factorisation fails (κ beyond about ε^(−1/2)),
    /// Householder QR.
    ///
    /// # Errors
    /// [`FdidError::TooFewFrequencies`] with fewer rows than columns;
    /// [`FdidError::Singular`] when a column is zero or R has a diagonal below 10³·ε
    /// times its largest (the columns are numerically dependent, e.g. two equal poles).
    pub(crate) fn new(mut a: DMatrix<T>) -> Result<Self> {
        let (rows, p) = a.shape();
        if rows < p {
            return Err(FdidError::TooFewFrequencies {
                lines: rows / 2,
                equations: rows,
                parameters: p,
            });
        }
        let scale = crate::linalg::equilibrate_columns(&mut a);
        let (q, r) = match cholesky_qr2(&a) {
            Some(qr) => qr,
            None => {
                let qr = a.qr();
                (qr.q(), qr.r())
            }
        };
        let diag: Vec<T> = (0..p).map(|i| Float::abs(r[(i, i)])).collect();
        let big = diag.iter().copied().fold(T::zero(), Float::max);
        let small = diag.iter().copied().fold(T::infinity(), Float::min);
        if !(small > big * T::default_epsilon() * T::lit(1e3)) {
            return Err(FdidError::Singular {
                what: "residue least squares (numerically dependent basis columns)",
                condition: (big / small).to_f64_lossless(),
            });
        }
        Ok(Self { q, r, scale })
    }

    /// min ‖A X − B‖ for every column of B: X and the residuals B − A X (as B − QQᵀB,
    /// so that their norms are not differences of norms).
    pub(crate) fn least_squares(&self, b: &DMatrix<T>) -> Result<(DMatrix<T>, DMatrix<T>)> {
        let qtb = at_b(&self.q, b);
        let residual = b - &self.q * &qtb;
        let mut x = self
            .r
            .solve_upper_triangular(&qtb)
            .ok_or_else(|| FdidError::Numerical {
                what: "triangular solve of the residue least squares".into(),
            })?;
        for (j, s) in self.scale.iter().enumerate() {
            x.row_mut(j).unscale_mut(*s);
        }
        Ok((x, residual))
    }
}

/// Q and R of `a` by CholeskyQR2, `None` when it is not accurate (see [`ThinQr::new`]).
fn cholesky_qr2<T: Real>(a: &DMatrix<T>) -> Option<(DMatrix<T>, DMatrix<T>)> {
    let r1 = cholesky_r(a)?;
    let q1 = a * upper_inverse(&r1)?;
    let r2 = cholesky_r(&q1)?;
    let near_identity = T::lit(1e-2);
    let p = r2.nrows();
    for i in 0..p {
        for j in i..p {
            let target = if i == j { T::one() } else { T::zero() };
            if !(Float::abs(r2[(i, j)] - target) < near_identity) {
                return None;
            }
        }
    }
    let q = q1 * upper_inverse(&r2)?;
    Some((q, r2 * r1))
}

/// The upper Cholesky factor R (RᵀR = aᵀa), `None` when the factorisation fails or gives
/// a value that is not finite.
fn cholesky_r<T: Real>(a: &DMatrix<T>) -> Option<DMatrix<T>> {
    let r = at_b(a, a).cholesky()?.l().transpose();
    r.iter().all(|v| Float::is_finite(*v)).then_some(r)
}

/// The inverse of an upper triangular matrix by back substitution on the identity.
fn upper_inverse<T: Real>(r: &DMatrix<T>) -> Option<DMatrix<T>> {
    let inverse = r.solve_upper_triangular(&DMatrix::identity(r.nrows(), r.ncols()))?;
    inverse
        .iter()
        .all(|v| Float::is_finite(*v))
        .then_some(inverse)
}

/// aᵀb through a transposed copy and a matrix product: nalgebra's `tr_mul` forms one dot
/// product per entry, while the product of two matrices runs the blocked kernels of
/// matrixmultiply, several times faster on the tall matrices of a fit.
pub(crate) fn at_b<T: Real>(a: &DMatrix<T>, b: &DMatrix<T>) -> DMatrix<T> {
    a.transpose() * b
}

/// The R factor of a tall matrix `a` by CholeskyQR2 (see [`ThinQr::new`]) or, when that
/// is not accurate, Householder QR; `a` is not equilibrated.
pub(crate) fn r_factor<T: Real>(a: DMatrix<T>) -> DMatrix<T> {
    match cholesky_qr2(&a) {
        Some((_, r)) => r,
        None => a.qr().r(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tall matrix with columns of condition number about `kappa`: Vandermonde-like
    /// columns cos(j t) on a grid, the last scaled by 1/kappa.
    fn tall(rows: usize, cols: usize, kappa: f64) -> DMatrix<f64> {
        DMatrix::from_fn(rows, cols, |i, j| {
            let t = i as f64 / rows as f64;
            let v = (j as f64 * 3.0 * t).cos() + 0.1 * (t * (j + 1) as f64).sin();
            if j + 1 == cols { v / kappa } else { v }
        })
    }

    #[test]
    fn reproduces_the_matrix_with_orthonormal_q() {
        for kappa in [1.0, 1e4, 1e9] {
            let a = tall(400, 12, kappa);
            let f = ThinQr::new(a.clone()).unwrap();
            let qtq = f.q.transpose() * &f.q;
            let orth = (qtq - DMatrix::identity(12, 12)).amax();
            assert!(orth < 1e-13, "κ {kappa}: ‖QᵀQ − I‖ = {orth:e}");
            let mut back = &f.q * &f.r;
            for (j, s) in f.scale.iter().enumerate() {
                back.column_mut(j).scale_mut(*s);
            }
            let err = (back - &a).amax() / a.amax();
            assert!(err < 1e-13, "κ {kappa}: ‖QR − A‖ = {err:e}");
        }
    }

    #[test]
    fn least_squares_matches_the_normal_solution_and_residual() {
        let a = tall(300, 6, 10.0);
        let x_true = DMatrix::from_fn(6, 2, |i, j| (i + 2 * j) as f64 - 3.0);
        let noise = DMatrix::from_fn(300, 2, |i, j| ((7 * i + 3 * j) % 11) as f64 * 1e-3);
        let b = &a * &x_true + &noise;
        let (x, residual) = ThinQr::new(a.clone()).unwrap().least_squares(&b).unwrap();
        for c in 0..2 {
            let r = b.column(c) - &a * x.column(c);
            // the residual is orthogonal to the columns of A (normal equations hold)
            assert!((a.transpose() * &r).amax() < 1e-10);
            assert!((&r - residual.column(c)).amax() < 1e-12 * r.amax().max(1e-3));
        }
    }

    #[test]
    fn dependent_or_zero_columns_are_singular() {
        let mut a = tall(100, 4, 1.0);
        let first = a.column(0).into_owned();
        a.set_column(3, &first);
        assert!(matches!(
            ThinQr::new(a.clone()),
            Err(FdidError::Singular { .. })
        ));
        a.column_mut(3).fill(0.0);
        assert!(matches!(ThinQr::new(a), Err(FdidError::Singular { .. })));
        assert!(matches!(
            ThinQr::new(DMatrix::<f64>::zeros(3, 5)),
            Err(FdidError::TooFewFrequencies { .. })
        ));
    }
}
