//! The modelled output Ŷ(θ) = G(θ)U + T(θ) on the lines of a data set, with its Jacobian:
//! what every output-error criterion (ML, ML with a noise model, errors-in-variables)
//! compares with the measured Y.

use super::ModelStructure;
use crate::data::FrequencyData;
use crate::scalar::{Complex, Real};
use nalgebra::DMatrix;

/// Buffers for G(θ, ω_k), Ŷ_k(θ) = G U_k + T_k and their Jacobians, reused across
/// evaluations.
///
/// ```
/// use fdid::prelude::*;
/// use fdid::model::Output;
/// let omega = vec![1.0, 2.0, 3.0];
/// let frf = omega.iter().map(|w| Complex::new(1.0, 0.0) / Complex::new(1.0, *w)).collect();
/// let data = FrequencyData::from_frf(omega, frf, None).unwrap();
/// let model = Rational::continuous(1, 0, data.omega()).unwrap();
/// let mut out = Output::new(data.len(), model.n_params());
/// out.evaluate(&model, &[0.0, 1.0], &data, true);
/// assert_eq!(out.yhat.len(), 3);
/// assert_eq!(out.dyhat.shape(), (3, 2));
/// // the last two lines only, e.g. one block of a long record
/// let mut block = Output::new(data.len(), model.n_params());
/// assert!(block.evaluate_range(&model, &[0.0, 1.0], data.omega(), data.u(), 1..3));
/// assert_eq!(block.yhat[1..], out.yhat[1..]);
/// assert!(!block.evaluate_range(&model, &[0.0, 1.0], data.omega(), data.u(), 2..4));
/// ```
#[derive(Debug, Clone)]
pub struct Output<T: Real> {
    /// G(θ, ω_k).
    pub g: Vec<Complex<T>>,
    /// Ŷ_k = G(θ, ω_k) U_k + T(θ, ω_k).
    pub yhat: Vec<Complex<T>>,
    /// ∂G_k/∂θ_j (filled when the Jacobian is requested).
    pub dg: DMatrix<Complex<T>>,
    /// ∂Ŷ_k/∂θ_j (filled when the Jacobian is requested).
    pub dyhat: DMatrix<Complex<T>>,
    t: Vec<Complex<T>>,
    dt: DMatrix<Complex<T>>,
}

impl<T: Real> Output<T> {
    /// Buffers for `lines` lines and `params` parameters. The Jacobian buffers, and the
    /// transient term's of a model that has one, are allocated on the first evaluation
    /// that needs them.
    pub fn new(lines: usize, params: usize) -> Self {
        let _ = params;
        let zero = Complex::new(T::zero(), T::zero());
        Self {
            g: crate::recycle::filled(lines, zero),
            yhat: crate::recycle::filled(lines, zero),
            dg: DMatrix::zeros(0, 0),
            dyhat: DMatrix::zeros(0, 0),
            t: Vec::new(),
            dt: DMatrix::zeros(0, 0),
        }
    }

    /// Gives the buffers to the thread's shelf for later fits ([`crate::recycle`]), leaving
    /// the output empty.
    pub(crate) fn recycle(&mut self) {
        for v in [&mut self.g, &mut self.yhat, &mut self.t] {
            crate::recycle::keep(std::mem::take(v));
        }
        for m in [&mut self.dg, &mut self.dyhat, &mut self.dt] {
            crate::recycle::keep_matrix(m);
        }
    }

    /// Evaluates G and Ŷ (and their Jacobians when `jacobian`) at θ on the lines of `data`.
    /// Returns false when a value is not finite.
    pub fn evaluate<M: ModelStructure<T> + ?Sized>(
        &mut self,
        model: &M,
        theta: &[T],
        data: &FrequencyData<T>,
        jacobian: bool,
    ) -> bool {
        self.evaluate_lines(model, theta, data.omega(), data.u(), jacobian)
    }

    /// G and Ŷ at θ, and the stacked weighted Jacobian rows of the output-error residuals
    /// in `jac` (2N × p), in one pass of the model
    /// ([`ModelStructure::stacked_jacobian_into`]); ∂G/∂θ and ∂Ŷ/∂θ are not kept. `None`
    /// when the model has no such pass (a transient term, or none implemented), else
    /// whether G and Ŷ are finite.
    pub(crate) fn stacked_jacobian<M: ModelStructure<T> + ?Sized>(
        &mut self,
        model: &M,
        theta: &[T],
        omega: &[T],
        u: &[Complex<T>],
        weight: Option<&[T]>,
        jac: &mut DMatrix<T>,
    ) -> Option<bool> {
        let n = omega.len().min(u.len());
        if model.has_transient() {
            return None;
        }
        let zero = Complex::new(T::zero(), T::zero());
        for v in [&mut self.g, &mut self.yhat] {
            if v.len() != n {
                crate::recycle::refill_vec(v, n, zero);
            }
        }
        let (omega, u) = (&omega[..n], &u[..n]);
        if !model.stacked_jacobian_into(theta, omega, u, weight, &mut self.g, jac) {
            return None;
        }
        for ((yhat, g), u) in self.yhat.iter_mut().zip(&self.g).zip(u) {
            *yhat = *g * *u;
        }
        use crate::scalar::all_finite_complex;
        Some(all_finite_complex(&self.yhat) && all_finite_complex(&self.g))
    }

    /// G and Ŷ (no Jacobian) at θ on the lines `range` of `omega` and `u` (the buffers
    /// hold all of them, resized when their lengths differ; the other lines are left as
    /// they are), so that a caller can go through a long record block by block while the
    /// block's values are in cache. Returns false when a value of Ŷ is not finite, and
    /// without evaluating anything when `range` does not lie within the lines.
    pub fn evaluate_range<M: ModelStructure<T> + ?Sized>(
        &mut self,
        model: &M,
        theta: &[T],
        omega: &[T],
        u: &[Complex<T>],
        range: std::ops::Range<usize>,
    ) -> bool {
        let n = omega.len().min(u.len());
        if range.start > range.end || range.end > n {
            return false;
        }
        let zero = Complex::new(T::zero(), T::zero());
        let with_t = model.has_transient();
        for v in [&mut self.g, &mut self.yhat] {
            if v.len() != n {
                v.resize(n, zero);
            }
        }
        if with_t && self.t.len() != n {
            self.t.resize(n, zero);
        }
        let (omega, u) = (&omega[range.clone()], &u[range.clone()]);
        let (g, yhat) = (&mut self.g[range.clone()], &mut self.yhat[range.clone()]);
        model.response_into(theta, omega, g);
        let has_t = with_t && model.transient_into(theta, omega, &mut self.t[range.clone()], None);
        for ((yhat, g), u) in yhat.iter_mut().zip(g.iter()).zip(u) {
            *yhat = *g * *u;
        }
        if has_t {
            for (yhat, t) in yhat.iter_mut().zip(&self.t[range]) {
                *yhat += *t;
            }
        }
        crate::scalar::all_finite_complex(yhat)
    }

    /// [`Output::evaluate`] on the lines with frequencies `omega` and input spectrum `u`
    /// (of equal lengths; e.g. a block of a data set's lines). The buffers are resized to
    /// `omega.len()` lines when their sizes differ. Returns false when a value is not
    /// finite.
    pub fn evaluate_lines<M: ModelStructure<T> + ?Sized>(
        &mut self,
        model: &M,
        theta: &[T],
        omega: &[T],
        u: &[Complex<T>],
        jacobian: bool,
    ) -> bool {
        let (n, p) = (omega.len().min(u.len()), model.n_params());
        if !jacobian {
            return self.evaluate_range(model, theta, omega, u, 0..n);
        }
        let omega = &omega[..n];
        let u = &u[..n];
        let zero = Complex::new(T::zero(), T::zero());
        for v in [&mut self.g, &mut self.yhat] {
            if v.len() != n {
                v.resize(n, zero);
            }
        }
        // T only for a model with a transient term
        let with_t = model.has_transient();
        if with_t && self.t.len() != n {
            self.t.resize(n, zero);
        }
        for m in [&mut self.dg, &mut self.dyhat] {
            if m.shape() != (n, p) {
                crate::recycle::refill(m, n, p, zero);
            }
        }
        model.jacobian_into(theta, omega, &mut self.g, &mut self.dg);
        let has_t = with_t && {
            if self.dt.shape() != (n, p) {
                self.dt = DMatrix::zeros(n, p);
            }
            model.transient_into(theta, omega, &mut self.t, Some(&mut self.dt))
        };
        for ((yhat, g), u) in self.yhat.iter_mut().zip(&self.g).zip(u) {
            *yhat = *g * *u;
        }
        if has_t {
            for (yhat, t) in self.yhat.iter_mut().zip(&self.t) {
                *yhat += *t;
            }
        }
        if n > 0 {
            let cols = self
                .dyhat
                .as_mut_slice()
                .chunks_exact_mut(n)
                .zip(self.dg.as_slice().chunks_exact(n));
            for (j, (d, g)) in cols.enumerate() {
                for ((d, g), u) in d.iter_mut().zip(g).zip(u) {
                    *d = *g * *u;
                }
                if has_t {
                    for (d, t) in d.iter_mut().zip(&self.dt.as_slice()[j * n..(j + 1) * n]) {
                        *d += *t;
                    }
                }
            }
        }
        use crate::scalar::all_finite_complex;
        all_finite_complex(&self.yhat)
            && all_finite_complex(self.dyhat.as_slice())
            && all_finite_complex(&self.g)
    }
}
