//! Output-error maximum likelihood with a fixed noise model (McKelvey eq. 23).

use super::{Criterion, NoiseWeighting, check_input};
use crate::data::FrequencyData;
use crate::error::Result;
use crate::model::{ModelStructure, Output};
use crate::problem::NonlinearProblem;
use crate::scalar::Real;
use crate::scalar::all_finite;
use nalgebra::{DMatrix, DVector};
use std::cell::RefCell;

/// Maximum likelihood with a fixed noise model: minimise
///
/// ```text
/// V(θ) = Σ_k |Y_k − G_θ(ω_k) U_k|² / σ_k²          (McKelvey eq. 23 with H fixed)
/// ```
///
/// with σ_k² the output noise variance of the data (|H_ω|²λ in the paper) or σ_k = 1 when
/// the data carry none; then λ is estimated by eq. (25), λ̂ = V(θ̂)/N. Asymptotically this
/// is weighted nonlinear least squares whose limit is eq. (31). Works with any
/// [`ModelStructure`]; solved by [`crate::solver::LevenbergMarquardt`] on the residuals
/// r_k = (Y_k − G_θ U_k)/σ_k stacked as real and imaginary parts.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MaximumLikelihood {
    /// Noise weighting of the lines.
    pub weighting: NoiseWeighting,
}

/// The ML criterion bound to a model and data.
pub struct MlProblem<'a, T: Real, M: ?Sized> {
    model: &'a M,
    data: &'a FrequencyData<T>,
    weight: Option<Vec<T>>,
    scratch: RefCell<Output<T>>,
    /// θ of the evaluation in `scratch`.
    scratch_at: RefCell<Option<Vec<T>>>,
    /// Work space of [`NonlinearProblem::normal_equations_into`]: full blocks, last block.
    blocks: RefCell<[Block<T>; 2]>,
}

impl<T: Real, M: ?Sized> Drop for MlProblem<'_, T, M> {
    /// Gives the buffers of the full evaluation, of the record's length, back for the next
    /// fit's ([`crate::recycle`]).
    fn drop(&mut self) {
        self.scratch.get_mut().recycle();
    }
}

/// The model output and the real-stacked Jacobian rows of one block of lines.
struct Block<T: Real> {
    out: Output<T>,
    jac: DMatrix<T>,
    /// θ of `out` and `jac` when the block holds all the lines and `jac` is unchanged
    /// since (see [`MlProblem::for_each_block`]).
    at: Option<Vec<T>>,
}

impl<T: Real> Drop for Block<T> {
    /// Gives the block's buffers back for the next fit's ([`crate::recycle`]).
    fn drop(&mut self) {
        crate::recycle::keep_matrix(&mut self.jac);
        self.out.recycle();
    }
}

impl<T: Real> Block<T> {
    fn new() -> Self {
        Self {
            out: Output::new(0, 0),
            jac: DMatrix::zeros(0, 0),
            at: None,
        }
    }
}

impl<T: Real, M: ModelStructure<T> + ?Sized> Criterion<T, M> for MaximumLikelihood {
    type Problem<'a>
        = MlProblem<'a, T, M>
    where
        M: 'a,
        T: 'a;

    fn problem<'a>(
        &'a self,
        model: &'a M,
        data: &'a FrequencyData<T>,
    ) -> Result<MlProblem<'a, T, M>> {
        MlProblem::new(model, data, self.weighting)
    }
}

impl<'a, T: Real, M: ModelStructure<T> + ?Sized> MlProblem<'a, T, M> {
    /// Binds `model` and `data`.
    ///
    /// # Errors
    /// As [`ModelStructure::check_data`]; zero input lines; zero noise variances.
    pub fn new(
        model: &'a M,
        data: &'a FrequencyData<T>,
        weighting: NoiseWeighting,
    ) -> Result<Self> {
        model.check_data(data)?;
        check_input(data)?;
        let weight = weighting.weights(data)?;
        Ok(Self {
            model,
            data,
            weight,
            scratch: RefCell::new(Output::new(data.len(), model.n_params())),
            scratch_at: RefCell::new(None),
            blocks: RefCell::new([Block::new(), Block::new()]),
        })
    }

    /// Per-line weights 1/σ_k (`None`: flat).
    pub fn weights(&self) -> Option<&[T]> {
        self.weight.as_deref()
    }

    /// The data.
    pub fn data(&self) -> &FrequencyData<T> {
        self.data
    }

    /// The model.
    pub fn model(&self) -> &M {
        self.model
    }

    /// The cost V(θ) = ‖r(θ)‖².
    pub fn cost(&self, theta: &[T]) -> T {
        let mut r = vec![T::zero(); 2 * self.data.len()];
        self.residuals_into(theta, &mut r);
        r.iter().fold(T::zero(), |s, v| s + *v * *v)
    }

    /// The residuals r(θ) into `r`, reusing the last full evaluation when it was at θ (e.g.
    /// the last step of a solver). False when a value is not finite.
    pub(crate) fn residuals_at(&self, theta: &[T], r: &mut [T]) -> bool {
        if self.scratch_at.borrow().as_deref() == Some(theta) {
            let out = self.scratch.borrow();
            self.residuals_of(0, &out.yhat, r);
            return crate::scalar::all_finite_complex(&out.yhat) && all_finite(r);
        }
        self.residuals_into(theta, r)
    }

    /// G on the data lines from the last full evaluation ([`NonlinearProblem::residuals_into`]
    /// or [`NonlinearProblem::jacobian_into`]) when it was at θ, moved out of the work
    /// space (which then holds no evaluation); `None` otherwise.
    pub(crate) fn take_response(&self, theta: &[T]) -> Option<Vec<crate::scalar::Complex<T>>> {
        let mut at = self.scratch_at.borrow_mut();
        if at.as_deref() != Some(theta) {
            return None;
        }
        *at = None;
        Some(std::mem::take(&mut self.scratch.borrow_mut().g))
    }

    /// Evaluates the model output at θ block by block ([`crate::linalg::gram`]'s block size, so that
    /// a block stays in cache) and calls `f(k0, output, jac)` for each block starting at
    /// line k0, with G, Ŷ and their Jacobians on the block's lines in `output` and the
    /// block's rows of J = ∂r/∂θ (real-stacked line by line, 2·len × p) in `jac`. Returns
    /// false, stopping, at the first block with a value that is not finite.
    ///
    /// `f` may overwrite `jac` only with `last`: then, when one block holds all the lines
    /// and the previous call evaluated them at the same θ (and did not have `last`), that
    /// evaluation is reused.
    pub(crate) fn for_each_block(
        &self,
        theta: &[T],
        last: bool,
        mut f: impl FnMut(usize, &Output<T>, &mut DMatrix<T>),
    ) -> bool {
        let (n, p) = (self.data.len(), self.model.n_params());
        let mut blocks = self.blocks.borrow_mut();
        let lines = crate::linalg::gram::block_lines(p);
        for k0 in (0..n).step_by(lines) {
            let len = lines.min(n - k0);
            let Block { out, jac, at } = &mut blocks[usize::from(len < lines)];
            let reuse = last && at.as_deref() == Some(theta);
            *at = None;
            if !reuse {
                let lines = k0..k0 + len;
                if jac.shape() != (2 * len, p) {
                    crate::recycle::refill(jac, 2 * len, p, T::zero());
                }
                let weight = self.weight.as_deref().map(|w| &w[k0..k0 + len]);
                if !self.stacked_rows(out, theta, lines, weight, jac) {
                    return false;
                }
                if !all_finite(jac.as_slice()) {
                    return false;
                }
                if len == n && !last {
                    *at = Some(theta.to_vec());
                }
            }
            f(k0, out, jac);
        }
        true
    }

    /// G and Ŷ of `lines` into `out` and their rows of J (real-stacked, weighted) into
    /// `jac`: in one pass of the model when it has one
    /// ([`ModelStructure::stacked_jacobian_into`]), else from its Jacobian ∂Ŷ/∂θ. False
    /// when a value of G, Ŷ or ∂Ŷ/∂θ is not finite.
    fn stacked_rows(
        &self,
        out: &mut Output<T>,
        theta: &[T],
        lines: std::ops::Range<usize>,
        weight: Option<&[T]>,
        jac: &mut DMatrix<T>,
    ) -> bool {
        let (omega, u) = (&self.data.omega()[lines.clone()], &self.data.u()[lines]);
        if let Some(finite) = out.stacked_jacobian(self.model, theta, omega, u, weight, jac) {
            return finite;
        }
        if !out.evaluate_lines(self.model, theta, omega, u, true) {
            return false;
        }
        let len = omega.len();
        if len == 0 {
            return true;
        }
        for (col, src) in jac
            .as_mut_slice()
            .chunks_exact_mut(2 * len)
            .zip(out.dyhat.as_slice().chunks_exact(len))
        {
            stack_weighted(src, weight, -T::one(), col);
        }
        true
    }

    /// Records θ as the point of the evaluation in `scratch`.
    fn mark_scratch(&self, theta: &[T]) {
        let mut at = self.scratch_at.borrow_mut();
        match at.as_mut() {
            Some(v) if v.len() == theta.len() => v.copy_from_slice(theta),
            _ => *at = Some(theta.to_vec()),
        }
    }

    /// Writes the residuals r of the lines k0 … k0 + len − 1 from the block's Ŷ.
    pub(crate) fn block_residuals(&self, k0: usize, out: &Output<T>, r: &mut [T]) {
        let len = out.yhat.len();
        self.residuals_of(k0, &out.yhat, &mut r[2 * k0..2 * (k0 + len)]);
    }

    /// r_k = w_k (Y_k − Ŷ_k) for the lines k0 … k0 + ŷ.len() − 1, real-stacked into `r`.
    fn residuals_of(&self, k0: usize, yhat: &[crate::scalar::Complex<T>], r: &mut [T]) {
        let len = yhat.len();
        let y = &self.data.y()[k0..k0 + len];
        let weight = self.weight.as_deref().map(|w| &w[k0..k0 + len]);
        let rc = r.chunks_exact_mut(2);
        match weight {
            Some(w) => {
                for (((c, y), yhat), w) in rc.zip(y).zip(yhat).zip(w) {
                    c[0] = (y.re - yhat.re) * *w;
                    c[1] = (y.im - yhat.im) * *w;
                }
            }
            None => {
                for ((c, y), yhat) in rc.zip(y).zip(yhat) {
                    c[0] = y.re - yhat.re;
                    c[1] = y.im - yhat.im;
                }
            }
        }
    }
}

/// Lines per block of [`NonlinearProblem::residuals_into`] of [`MlProblem`]: the per-line
/// vectors of a block (about a dozen of 16 bytes per line) take some 0.8 MB, within the
/// second-level cache.
const RESIDUAL_BLOCK: usize = 4_096;

/// dst\[2i\], dst\[2i + 1\] = Re, Im of sign·w_i·src_i (w absent: unit weights).
fn stack_weighted<T: Real>(
    src: &[crate::scalar::Complex<T>],
    weight: Option<&[T]>,
    sign: T,
    dst: &mut [T],
) {
    let dc = dst.chunks_exact_mut(2);
    match weight {
        Some(w) => {
            for ((c, d), w) in dc.zip(src).zip(w) {
                let s = sign * *w;
                c[0] = d.re * s;
                c[1] = d.im * s;
            }
        }
        None => {
            for (c, d) in dc.zip(src) {
                c[0] = d.re * sign;
                c[1] = d.im * sign;
            }
        }
    }
}

impl<T: Real, M: ModelStructure<T> + ?Sized> NonlinearProblem<T> for MlProblem<'_, T, M> {
    fn n_params(&self) -> usize {
        self.model.n_params()
    }

    fn n_residuals(&self) -> usize {
        2 * self.data.len()
    }

    /// The model evaluated and the residuals formed block by block (of
    /// 4 096 lines), so that a long record's per-line values are used while in
    /// cache; G and Ŷ of all the lines are kept for the statistics at the solution.
    fn residuals_into(&self, theta: &[T], r: &mut [T]) -> bool {
        let mut out = self.scratch.borrow_mut();
        let (omega, u) = (self.data.omega(), self.data.u());
        let n = self.data.len();
        let mut finite = true;
        for k0 in (0..n).step_by(RESIDUAL_BLOCK) {
            let lines = k0..n.min(k0 + RESIDUAL_BLOCK);
            finite &= out.evaluate_range(self.model, theta, omega, u, lines.clone());
            let rb = &mut r[2 * lines.start..2 * lines.end];
            self.residuals_of(k0, &out.yhat[lines], rb);
            finite &= all_finite(rb);
        }
        self.mark_scratch(theta);
        finite
    }

    fn jacobian_into(&self, theta: &[T], r: &mut [T], jac: &mut DMatrix<T>) -> bool {
        let mut out = self.scratch.borrow_mut();
        let n = self.data.len();
        let finite = self.stacked_rows(&mut out, theta, 0..n, self.weight.as_deref(), jac);
        self.mark_scratch(theta);
        self.residuals_of(0, &out.yhat, r);
        finite && all_finite(r) && all_finite(jac.as_slice())
    }

    /// JᵀJ and Jᵀr accumulated over blocks of lines (of about 4 096/p lines each), each
    /// block's rows of J formed in a small buffer that stays in cache: no 2N × p matrix is
    /// formed, and `jac` is not used — except for small problems (N·p ≤ 8 192), whose J
    /// is formed in `jac` as by the default.
    fn normal_equations_into(
        &self,
        theta: &[T],
        r: &mut [T],
        jac: &mut DMatrix<T>,
        gram: &mut DMatrix<T>,
        grad: &mut DVector<T>,
    ) -> bool {
        let (n, p) = (self.data.len(), self.model.n_params());
        if gram.shape() != (p, p) {
            *gram = DMatrix::zeros(p, p);
        }
        if grad.len() != p {
            *grad = DVector::zeros(p);
        }
        if crate::linalg::gram::small_problem(n, p) {
            // J itself, in cache
            let m = 2 * n;
            if jac.shape() != (m, p) {
                *jac = DMatrix::zeros(m, p);
            }
            if !self.jacobian_into(theta, r, jac) {
                return false;
            }
            crate::linalg::gram::gram_into(jac, gram, false);
            crate::linalg::gram::GramWork::tr_mul(jac, r, grad);
            return true;
        }
        gram.fill(T::zero());
        grad.fill(T::zero());
        self.for_each_block(theta, false, |k0, out, jac| {
            let len = out.yhat.len();
            self.block_residuals(k0, out, r);
            crate::linalg::gram::gram_into(jac, gram, true);
            let rb = nalgebra::DVectorView::from_slice(&r[2 * k0..2 * (k0 + len)], 2 * len);
            grad.gemv_tr(T::one(), jac, &rb, T::one());
        }) && all_finite(r)
            && all_finite(gram.as_slice())
            && all_finite(grad.as_slice())
    }
}
