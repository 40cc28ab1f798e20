//! Maximum likelihood of the common poles by variable projection: the residues enter
//! linearly and are eliminated entry by entry, so the nonlinear search runs over the n
//! pole parameters only.

use super::poles::PoleSet;
use super::thin_qr::{ThinQr, at_b};
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

/// What [`VarPro::evaluate`] hands on per entry: its index, projection, residual and
/// coefficient matrix C_e.
type EntrySink<'s, T> = dyn FnMut(usize, &Projection<T>, &DVector<T>, &DMatrix<T>) + 's;

/// The projection of one group of entries sharing their weights: the thin Q of the
/// equilibrated regressor, its R, the column scales, and the projected derivative basis.
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

    /// The projection for the weights `w` (none: unit weights); `None` when the
    /// regressor is numerically singular.
    fn projection(&self, poles: &PoleSet<T>, w: Option<&[T]>) -> Option<Projection<T>> {
        let a = crate::linalg::stack_rows(&self.data.regressor(poles), w);
        if (0..a.ncols()).any(|j| !(a.column(j).norm() > T::zero())) {
            return None;
        }
        let ThinQr { q, r, scale } = ThinQr::new(a).ok()?;
        let psi = crate::linalg::stack_rows(&self.data.derivative_regressor(poles), w);
        let psi_perp = &psi - &q * at_b(&q, &psi);
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
    /// residual and coefficient matrix C_e to `sink`; false when the basis is numerically
    /// singular or a value is not finite.
    fn evaluate(&self, theta: &[T], r: &mut [T], mut sink: Option<&mut EntrySink<'_, T>>) -> bool {
        let poles = PoleSet::from_theta(self.n_real, theta);
        let ne = self.data.h.len();
        let rows = self.rows();
        let shared = match &self.data.w {
            None => match self.projection(&poles, None) {
                Some(p) => Some(p),
                None => return false,
            },
            Some(_) => None,
        };
        for e in 0..ne {
            let own;
            let proj = match &shared {
                Some(p) => p,
                None => {
                    let w = self.data.w.as_ref().map(|w| w[e].as_slice());
                    match self.projection(&poles, w) {
                        Some(p) => {
                            own = p;
                            &own
                        }
                        None => return false,
                    }
                }
            };
            let b = self.target(e);
            let qtb = proj.q.tr_mul(&b);
            let res = &b - &proj.q * &qtb;
            r[e * rows..(e + 1) * rows].copy_from_slice(res.as_slice());
            if let Some(sink) = sink.as_mut() {
                let Some(mut c) = proj.r.solve_upper_triangular(&qtb) else {
                    return false;
                };
                for (j, s) in proj.scale.iter().enumerate() {
                    c[j] /= *s;
                }
                let ce = self.data.coefficient_stack(&poles, c.as_slice());
                sink(e, proj, &res, &ce);
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
        let mut sink = |e: usize, p: &Projection<T>, _: &DVector<T>, ce: &DMatrix<T>| {
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
        let mut sink = |_: usize, proj: &Projection<T>, res: &DVector<T>, ce: &DMatrix<T>| {
            if !shared || psi_gram.is_none() {
                psi_gram = Some(at_b(&proj.psi_perp, &proj.psi_perp));
            }
            let Some(g) = psi_gram.as_ref() else { return };
            *gram += ce.tr_mul(&(g * ce));
            // Jᵀr = −C_eᵀΨ⊥ᵀr_e = −C_eᵀΨᵀr_e (r_e is orthogonal to the range of Q)
            *grad -= ce.tr_mul(&proj.psi.tr_mul(res));
        };
        self.evaluate(theta, r, Some(&mut sink))
            && gram.iter().all(|v| Float::is_finite(*v))
            && grad.iter().all(|v| Float::is_finite(*v))
    }
}
