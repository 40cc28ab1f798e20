//! Maximum likelihood of the common poles by variable projection: the residues enter
//! linearly and are eliminated entry by entry, so the nonlinear search runs over the n
//! pole parameters only.

use super::poles::{PoleSet, basis_derivative};
use super::vector_fit::Weighted;
use crate::problem::NonlinearProblem;
use crate::scalar::Real;
use nalgebra::{DMatrix, DVector};
use num_traits::Float;

/// The output-error ML cost of the common-pole model with its linear parameters
/// eliminated (Golub and Pereyra's variable projection),
///
/// ```text
/// V(θ) = Σ_e ‖P⊥_e(θ) W_e h_e‖²,   P⊥_e = I − A_e A_e⁺,   A_e = W_e [φ(x; θ) | 1],
/// ```
///
/// McKelvey eq. 23 for every entry at once, weighted by the entries' variances (W_e =
/// diag 1/σ_e,k; unit weights without them). The Jacobian is Kaufman's,
/// J_e = −P⊥_e (∂A_e/∂θ) c_e(θ), whose Gram matrix is the Schur complement of the full
/// problem's in the pole block: the asymptotic covariance of the poles (McKelvey eq. 32)
/// comes from it directly. Without weights one QR of A serves every entry.
pub(crate) struct VarPro<'a, T: Real> {
    pub data: &'a Weighted<T>,
    pub n_real: usize,
    pub order: usize,
}

/// Per entry: its rows' offset in r, its residual and its Jacobian block.
type Sink<'s, T> = dyn FnMut(usize, &DVector<T>, &DMatrix<T>) + 's;

impl<T: Real> VarPro<'_, T> {
    fn rows(&self) -> usize {
        2 * self.data.lines()
    }

    /// Evaluates every entry's residual (and Jacobian block when `sink` is given) at θ;
    /// false when the basis is numerically singular or a value is not finite.
    fn evaluate(&self, theta: &[T], r: &mut [T], mut sink: Option<&mut Sink<'_, T>>) -> bool {
        let poles = PoleSet::from_theta(self.n_real, theta);
        let a = self.data.regressor(&poles);
        let ne = self.data.h.len();
        let rows = self.rows();
        let groups: Vec<Vec<usize>> = match &self.data.w {
            None => vec![(0..ne).collect()],
            Some(_) => (0..ne).map(|e| vec![e]).collect(),
        };
        for group in groups {
            let wts = self.data.w.as_ref().map(|w| w[group[0]].as_slice());
            let mut aw = crate::linalg::stack_rows(&a, wts);
            let p = aw.ncols();
            let mut scale = vec![T::one(); p];
            for (j, s) in scale.iter_mut().enumerate() {
                let n = aw.column(j).norm();
                if !(n > T::zero()) {
                    return false;
                }
                *s = n;
                aw.column_mut(j).unscale_mut(n);
            }
            let qr = aw.qr();
            let rr = qr.r();
            let diag_ok =
                (0..p).all(|i| Float::abs(rr[(i, i)]) > T::default_epsilon() * T::lit(1e3));
            if !diag_ok {
                return false;
            }
            let q = qr.q();
            for e in group {
                let b = DVector::from_fn(rows, |row, _| {
                    let v = self.data.h[e][row / 2] * self.data.weight(e, row / 2);
                    if row % 2 == 0 { v.re } else { v.im }
                });
                let qtb = q.tr_mul(&b);
                let res = &b - &q * &qtb;
                r[e * rows..(e + 1) * rows].copy_from_slice(res.as_slice());
                if let Some(sink) = sink.as_mut() {
                    let Some(mut c) = rr.solve_upper_triangular(&qtb) else {
                        return false;
                    };
                    for (j, s) in scale.iter().enumerate() {
                        c[j] /= *s;
                    }
                    let d = basis_derivative(&self.data.x, &poles, &c.as_slice()[..self.order]);
                    let wts = self.data.w.as_ref().map(|w| w[e].as_slice());
                    let dw = crate::linalg::stack_rows(&d, wts);
                    let jac = -(&dw - &q * q.tr_mul(&dw));
                    sink(e, &res, &jac);
                }
            }
        }
        r.iter().all(|v| Float::is_finite(*v))
    }
}

impl<T: Real> NonlinearProblem<T> for VarPro<'_, T> {
    fn n_params(&self) -> usize {
        self.order
    }

    fn n_residuals(&self) -> usize {
        self.rows() * self.data.h.len()
    }

    fn residuals_into(&self, theta: &[T], r: &mut [T]) -> bool {
        self.evaluate(theta, r, None)
    }

    fn jacobian_into(&self, theta: &[T], r: &mut [T], jac: &mut DMatrix<T>) -> bool {
        let rows = self.rows();
        let mut finite = true;
        let mut sink = |e: usize, _: &DVector<T>, j: &DMatrix<T>| {
            finite &= j.iter().all(|v| Float::is_finite(*v));
            jac.view_mut((e * rows, 0), (rows, j.ncols())).copy_from(j);
        };
        self.evaluate(theta, r, Some(&mut sink)) && finite
    }

    fn normal_equations_into(
        &self,
        theta: &[T],
        r: &mut [T],
        _jac: &mut DMatrix<T>,
        gram: &mut DMatrix<T>,
        grad: &mut DVector<T>,
    ) -> bool {
        let p = self.order;
        *gram = DMatrix::zeros(p, p);
        *grad = DVector::zeros(p);
        let mut finite = true;
        let mut sink = |_: usize, res: &DVector<T>, j: &DMatrix<T>| {
            finite &= j.iter().all(|v| Float::is_finite(*v));
            *gram += j.tr_mul(j);
            *grad += j.tr_mul(res);
        };
        self.evaluate(theta, r, Some(&mut sink)) && finite
    }
}
