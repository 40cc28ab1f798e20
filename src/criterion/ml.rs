//! Output-error maximum likelihood with a fixed noise model (McKelvey eq. 23).

use super::{Criterion, NoiseWeighting, check_input};
use crate::Real;
use crate::data::FrequencyData;
use crate::error::Result;
use crate::model::{ModelStructure, Output};
use crate::problem::NonlinearProblem;
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
    /// Work space of [`NonlinearProblem::normal_equations_into`]: full blocks, last block.
    blocks: RefCell<[Block<T>; 2]>,
}

/// The model output and the real-stacked Jacobian rows of one block of lines.
struct Block<T: Real> {
    out: Output<T>,
    jac: DMatrix<T>,
    /// θ of `out` and `jac` when the block holds all the lines and `jac` is unchanged
    /// since (see [`MlProblem::for_each_block`]).
    at: Option<Vec<T>>,
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

    /// Moves G and ∂G/∂θ of the last Jacobian evaluation out of the work space (empty
    /// before any).
    pub(crate) fn take_response_jacobian(
        &self,
    ) -> (Vec<crate::Complex<T>>, DMatrix<crate::Complex<T>>) {
        let mut out = self.scratch.borrow_mut();
        (
            std::mem::take(&mut out.g),
            std::mem::replace(&mut out.dg, DMatrix::zeros(0, 0)),
        )
    }

    /// Evaluates the model output at θ block by block ([`crate::solver::gram`]'s block size, so that
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
        let (omega, u) = (self.data.omega(), self.data.u());
        let lines = crate::solver::gram::block_lines(p);
        for k0 in (0..n).step_by(lines) {
            let len = lines.min(n - k0);
            let Block { out, jac, at } = &mut blocks[usize::from(len < lines)];
            let reuse = last && at.as_deref() == Some(theta);
            *at = None;
            if !reuse {
                let lines = k0..k0 + len;
                if !out.evaluate_lines(self.model, theta, &omega[lines.clone()], &u[lines], true) {
                    return false;
                }
                if jac.shape() != (2 * len, p) {
                    *jac = DMatrix::zeros(2 * len, p);
                }
                for (col, src) in jac
                    .as_mut_slice()
                    .chunks_exact_mut(2 * len)
                    .zip(out.dyhat.as_slice().chunks_exact(len))
                {
                    for (i, (c, d)) in col.chunks_exact_mut(2).zip(src).enumerate() {
                        let d = -*d * self.w(k0 + i);
                        c[0] = d.re;
                        c[1] = d.im;
                    }
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

    /// Writes the residuals r of the lines k0 … k0 + len − 1 from the block's Ŷ.
    pub(crate) fn block_residuals(&self, k0: usize, out: &Output<T>, r: &mut [T]) {
        let len = out.yhat.len();
        for (i, (yhat, y)) in out
            .yhat
            .iter()
            .zip(&self.data.y()[k0..k0 + len])
            .enumerate()
        {
            let e = (*y - *yhat) * self.w(k0 + i);
            r[2 * (k0 + i)] = e.re;
            r[2 * (k0 + i) + 1] = e.im;
        }
    }

    fn w(&self, k: usize) -> T {
        self.weight.as_ref().map_or(T::one(), |w| w[k])
    }
}

fn all_finite<T: Real>(r: &[T]) -> bool {
    r.iter().all(|v| num_traits::Float::is_finite(*v))
}

impl<T: Real, M: ModelStructure<T> + ?Sized> NonlinearProblem<T> for MlProblem<'_, T, M> {
    fn n_params(&self) -> usize {
        self.model.n_params()
    }

    fn n_residuals(&self) -> usize {
        2 * self.data.len()
    }

    fn residuals_into(&self, theta: &[T], r: &mut [T]) -> bool {
        let mut out = self.scratch.borrow_mut();
        let finite = out.evaluate(self.model, theta, self.data, false);
        for (k, (yhat, y)) in out.yhat.iter().zip(self.data.y()).enumerate() {
            let e = (*y - *yhat) * self.w(k);
            r[2 * k] = e.re;
            r[2 * k + 1] = e.im;
        }
        finite && all_finite(r)
    }

    fn jacobian_into(&self, theta: &[T], r: &mut [T], jac: &mut DMatrix<T>) -> bool {
        let mut out = self.scratch.borrow_mut();
        let finite = out.evaluate(self.model, theta, self.data, true);
        for (k, (yhat, y)) in out.yhat.iter().zip(self.data.y()).enumerate() {
            let e = (*y - *yhat) * self.w(k);
            r[2 * k] = e.re;
            r[2 * k + 1] = e.im;
        }
        for j in 0..self.model.n_params() {
            for k in 0..self.data.len() {
                let d = -out.dyhat[(k, j)] * self.w(k);
                jac[(2 * k, j)] = d.re;
                jac[(2 * k + 1, j)] = d.im;
            }
        }
        finite && all_finite(r) && all_finite(jac.as_slice())
    }

    /// JᵀJ and Jᵀr accumulated over blocks of lines (of about 4 096/p lines each), each
    /// block's rows of J formed in a small buffer that stays in cache: no 2N × p matrix is
    /// formed, and `jac` is not used — except for small problems (N·p ≤ 32 768), whose J
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
        if crate::solver::gram::small_problem(n, p) {
            // J itself, in cache
            let m = 2 * n;
            if jac.shape() != (m, p) {
                *jac = DMatrix::zeros(m, p);
            }
            if !self.jacobian_into(theta, r, jac) {
                return false;
            }
            crate::solver::gram::gram_into(jac, gram, false);
            crate::solver::gram::GramWork::tr_mul(jac, r, grad);
            return true;
        }
        gram.fill(T::zero());
        grad.fill(T::zero());
        self.for_each_block(theta, false, |k0, out, jac| {
            let len = out.yhat.len();
            self.block_residuals(k0, out, r);
            crate::solver::gram::gram_into(jac, gram, true);
            let rb = nalgebra::DVectorView::from_slice(&r[2 * k0..2 * (k0 + len)], 2 * len);
            grad.gemv_tr(T::one(), jac, &rb, T::one());
        }) && all_finite(r)
            && all_finite(gram.as_slice())
            && all_finite(grad.as_slice())
    }
}
