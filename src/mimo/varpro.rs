//! Maximum likelihood of the common poles by variable projection: the residues enter
//! linearly and are eliminated entry by entry, so the nonlinear search runs over the n
//! pole parameters only.

use super::poles::PoleSet;
use super::thin_qr::{ThinQr, at_b};
use super::vector_fit::Weighted;
use crate::problem::NonlinearProblem;
use crate::scalar::Real;
use nalgebra::{DMatrix, DVector, DVectorView};
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
/// comes from it directly.
///
/// The derivative of the basis applied to c_e factors as (∂A/∂θ) c_e = Ψ C_e, with Ψ the
/// derivatives of the basis functions (one or two per pole, L × n) and C_e small and
/// block diagonal (the coefficients of entry e). Without weights every entry shares A, so
/// one QR of A and one projection Ψ⊥ = P⊥Ψ serve all of them: J_e = −Ψ⊥C_e,
/// JᵀJ = Σ_e C_eᵀ(Ψ⊥ᵀΨ⊥)C_e and Jᵀr = −Σ_e C_eᵀΨᵀr_e, so an evaluation costs one QR and
/// O(L(m + n)) per entry instead of O(L m n).
///
/// For the outputs of a multi-input record the regressor is [φU_1 | U_1 | … | φx_T]
/// ([`Weighted::regressor`]), and the same factorisation holds with Ψ the derivative
/// columns of every group, [ΨU_1 | … | Ψx_T], and C_e the stacked coefficient matrices
/// of the groups.
pub(crate) struct VarPro<'a, T: Real> {
    pub data: &'a Weighted<T>,
    pub n_real: usize,
    pub order: usize,
}

/// What [`VarPro::evaluate`] hands on per entry: its index, projection, Ψᵀr_e (the
/// derivative basis against its residual) and coefficient matrix C_e.
type EntrySink<'s, T> = dyn FnMut(usize, &Projection<T>, DVectorView<'_, T>, &DMatrix<T>) + 's;

/// The projection of one group of entries sharing their weights: the thin Q of the
/// equilibrated regressor, its R, the column scales, and the derivative basis with its
/// projection (empty when only the residuals are wanted).
struct Projection<T: Real> {
    q: DMatrix<T>,
    r: DMatrix<T>,
    scale: Vec<T>,
    psi_perp: DMatrix<T>,
    psi: DMatrix<T>,
}

impl<T: Real> VarPro<'_, T> {
    fn rows(&self) -> usize {
        2 * self.data.lines()
    }

    /// The projection for the weights `w` (none: unit weights), with the derivative basis
    /// when `derivatives`; `None` when the regressor is numerically singular.
    fn projection(
        &self,
        poles: &PoleSet<T>,
        w: Option<&[T]>,
        derivatives: bool,
    ) -> Option<Projection<T>> {
        let a = crate::linalg::stack_rows(&self.data.regressor(poles), w);
        if (0..a.ncols()).any(|j| !(a.column(j).norm() > T::zero())) {
            return None;
        }
        let ThinQr { q, r, scale } = ThinQr::new(a).ok()?;
        let (psi, psi_perp) = if derivatives {
            let psi = crate::linalg::stack_rows(&self.data.derivative_regressor(poles), w);
            let psi_perp = &psi - &q * at_b(&q, &psi);
            (psi, psi_perp)
        } else {
            (DMatrix::zeros(0, 0), DMatrix::zeros(0, 0))
        };
        Some(Projection {
            q,
            r,
            scale,
            psi_perp,
            psi,
        })
    }

    /// Entry e's weighted data, real-stacked.
    fn target(&self, e: usize) -> DVector<T> {
        DVector::from_fn(self.rows(), |row, _| {
            let v = self.data.h[e][row / 2] * self.data.weight(e, row / 2);
            if row % 2 == 0 { v.re } else { v.im }
        })
    }

    /// Evaluates every entry's residual at θ into `r` and hands each entry's projection,
    /// Ψᵀr_e and coefficient matrix C_e to `sink`; false when the basis is numerically
    /// singular or a value is not finite. Without weights the entries share the
    /// projection and are handled together: QᵀB, B − QQᵀB and ΨᵀR as matrix products over
    /// every entry's column of B.
    fn evaluate(&self, theta: &[T], r: &mut [T], mut sink: Option<&mut EntrySink<'_, T>>) -> bool {
        let poles = PoleSet::from_theta(self.n_real, theta);
        let ne = self.data.h.len();
        let rows = self.rows();
        if self.data.w.is_none() {
            let Some(proj) = self.projection(&poles, None, sink.is_some()) else {
                return false;
            };
            let b = self.data.stacked();
            let qtb = at_b(&proj.q, &b);
            let res = b - &proj.q * &qtb;
            r.copy_from_slice(res.as_slice());
            if let Some(sink) = sink.as_mut() {
                let Some(c) = proj.r.solve_upper_triangular(&qtb) else {
                    return false;
                };
                let psi_t_res = at_b(&proj.psi, &res);
                for e in 0..ne {
                    let ce = self.coefficients(&poles, &proj, c.column(e).into_owned());
                    sink(e, &proj, psi_t_res.column(e), &ce);
                }
            }
            return r.iter().all(|v| Float::is_finite(*v));
        }
        for e in 0..ne {
            let w = self.data.w.as_ref().map(|w| w[e].as_slice());
            let Some(proj) = self.projection(&poles, w, sink.is_some()) else {
                return false;
            };
            let b = self.target(e);
            let qtb = proj.q.tr_mul(&b);
            let res = &b - &proj.q * &qtb;
            r[e * rows..(e + 1) * rows].copy_from_slice(res.as_slice());
            if let Some(sink) = sink.as_mut() {
                let Some(c) = proj.r.solve_upper_triangular(&qtb) else {
                    return false;
                };
                let ce = self.coefficients(&poles, &proj, c);
                sink(e, &proj, proj.psi.tr_mul(&res).column(0), &ce);
            }
        }
        r.iter().all(|v| Float::is_finite(*v))
    }

    /// The coefficient matrix C_e of an entry from its least-squares solution `c` in the
    /// equilibrated columns of the projection.
    fn coefficients(
        &self,
        poles: &PoleSet<T>,
        proj: &Projection<T>,
        mut c: DVector<T>,
    ) -> DMatrix<T> {
        for (j, s) in proj.scale.iter().enumerate() {
            c[j] /= *s;
        }
        self.data.coefficient_stack(poles, c.as_slice())
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
        let mut sink = |e: usize, p: &Projection<T>, _: DVectorView<'_, T>, ce: &DMatrix<T>| {
            let j = -(&p.psi_perp * ce);
            jac.view_mut((e * rows, 0), (rows, j.ncols())).copy_from(&j);
        };
        self.evaluate(theta, r, Some(&mut sink)) && jac.iter().all(|v| Float::is_finite(*v))
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
        // Ψ⊥ᵀΨ⊥ once per projection: once in all without weights
        let mut psi_gram: Option<DMatrix<T>> = None;
        let shared = self.data.w.is_none();
        let mut sink =
            |_: usize, proj: &Projection<T>, psi_t_res: DVectorView<'_, T>, ce: &DMatrix<T>| {
                if !shared || psi_gram.is_none() {
                    psi_gram = Some(at_b(&proj.psi_perp, &proj.psi_perp));
                }
                let Some(g) = psi_gram.as_ref() else { return };
                add_congruence(gram, g, ce);
                // Jᵀr = −C_eᵀΨ⊥ᵀr_e = −C_eᵀΨᵀr_e (r_e is orthogonal to the range of Q)
                *grad -= ce.tr_mul(&psi_t_res);
            };
        self.evaluate(theta, r, Some(&mut sink))
            && gram.iter().all(|v| Float::is_finite(*v))
            && grad.iter().all(|v| Float::is_finite(*v))
    }
}

/// gram += CᵀGC for a coefficient stack C whose columns hold at most a few nonzeros (one
/// or two per input group: [`Weighted::coefficient_stack`] is block diagonal in 1 × 1
/// and 2 × 2 blocks): O(rows · n) per column pair instead of the dense O(rows² n + rows n²).
fn add_congruence<T: Real>(gram: &mut DMatrix<T>, g: &DMatrix<T>, c: &DMatrix<T>) {
    let nonzeros: Vec<Vec<(usize, T)>> = c
        .column_iter()
        .map(|col| {
            col.iter()
                .enumerate()
                .filter(|(_, v)| **v != T::zero())
                .map(|(r, v)| (r, *v))
                .collect()
        })
        .collect();
    // GC column by column, then Cᵀ(GC)
    let mut gc = DMatrix::<T>::zeros(g.nrows(), c.ncols());
    for (j, nz) in nonzeros.iter().enumerate() {
        let mut out = gc.column_mut(j);
        for (r, v) in nz {
            out.axpy(*v, &g.column(*r), T::one());
        }
    }
    for (i, nz) in nonzeros.iter().enumerate() {
        for j in 0..c.ncols() {
            gram[(i, j)] += nz.iter().fold(T::zero(), |s, (r, v)| s + *v * gc[(*r, j)]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mimo::poles::coefficient_matrix;
    use num_complex::Complex;

    #[test]
    fn sparse_congruence_matches_the_dense_product() {
        let poles = PoleSet {
            real: vec![-0.3],
            pairs: vec![Complex::new(-0.1, 1.0), Complex::new(-0.05, 2.0)],
        };
        let n = poles.order();
        let c: Vec<f64> = (0..n).map(|k| 0.5 + k as f64).collect();
        // two input groups: the stack of two block-diagonal coefficient matrices
        let mut stack = DMatrix::zeros(2 * n, n);
        stack
            .view_mut((0, 0), (n, n))
            .copy_from(&coefficient_matrix(&poles, &c));
        let c2: Vec<f64> = c.iter().map(|v| -2.0 * v).collect();
        stack
            .view_mut((n, 0), (n, n))
            .copy_from(&coefficient_matrix(&poles, &c2));
        let a = DMatrix::from_fn(2 * n, 2 * n, |i, j| ((3 * i + 7 * j) % 5) as f64 - 1.5);
        let g = a.transpose() * &a;
        let start = DMatrix::from_fn(n, n, |i, j| (i + j) as f64);
        let mut sparse = start.clone();
        add_congruence(&mut sparse, &g, &stack);
        let dense = &start + stack.transpose() * &g * &stack;
        assert!((sparse - &dense).amax() < 1e-12 * dense.amax());
    }
}
