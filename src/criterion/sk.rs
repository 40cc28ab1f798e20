//! Sanathanan–Koerner iterations (McKelvey eq. 41).

use super::{Criterion, EquationErrorSystem, NoiseWeighting};
use crate::data::FrequencyData;
use crate::error::Result;
use crate::model::EquationError;
use crate::problem::ReweightedProblem;
use crate::scalar::{Complex, Real};
use nalgebra::{DMatrix, DVector};
use std::cell::RefCell;

/// Sanathanan–Koerner: at iteration m minimise
///
/// ```text
/// V_m(θ) = Σ_k W_k |A_θ(ω_k) Y_k − B_θ(ω_k) U_k|² / |Â^(m−1)(ω_k)|²   (McKelvey eq. 41)
/// ```
///
/// starting from W_k^(1) = W_k (Levy), with W_k = 1/σ_k² when the data carry noise
/// variances. At a fixed point the criterion equals the output-error cost
/// Σ W_k |Y_k − G U_k|², which is reported as the cost. Convergence to the ML minimiser is
/// not guaranteed (McKelvey ref. 20); the pipeline refines with ML. Requires an
/// [`EquationError`] model; solved by [`crate::solver::FixedPoint`].
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SanathananKoerner {
    /// Noise weighting of the lines.
    pub weighting: NoiseWeighting,
}

/// The SK criterion bound to a model and data.
pub struct SkProblem<'a, T: Real, M: ?Sized> {
    model: &'a M,
    data: &'a FrequencyData<T>,
    system: EquationErrorSystem<T>,
    noise_weight: Option<Vec<T>>,
    /// The responses G(θ) of the last two estimates whose cost was evaluated: the
    /// convergence test compares each estimate with the previous one.
    responses: RefCell<Vec<Evaluated<T>>>,
    /// The denominator A(θ) of the last estimate whose cost was evaluated: the weights of
    /// the next iteration.
    denominator: RefCell<Option<Evaluated<T>>>,
}

/// An estimate θ with its response G(θ) on the data lines.
type Evaluated<T> = (Vec<T>, Vec<Complex<T>>);

impl<T: Real, M: EquationError<T> + ?Sized> SkProblem<'_, T, M> {
    /// G(θ) on the data lines, from the cache when θ is one of its two estimates.
    fn response(&self, theta: &[T]) -> Vec<Complex<T>> {
        let cached = self.responses.borrow();
        match cached.iter().find(|(t, _)| t.as_slice() == theta) {
            Some((_, g)) => g.clone(),
            None => self.model.response(theta, self.data.omega()),
        }
    }

    /// The SK weights 1/|Â^(m−1)(ω_k)| normalised by their RMS (`None`: the first, Levy,
    /// iteration).
    fn sk_weights(&self, previous: Option<&[T]>) -> Option<Vec<T>> {
        match previous {
            None => None,
            Some(theta) => {
                let cached = self
                    .denominator
                    .borrow()
                    .as_ref()
                    .filter(|(t, _)| t.as_slice() == theta)
                    .map(|(_, a)| a.clone());
                let a = cached.unwrap_or_else(|| {
                    let mut a = vec![Complex::new(T::zero(), T::zero()); self.data.len()];
                    self.model
                        .denominator_into(theta, self.data.omega(), &mut a);
                    a
                });
                // 1/|A| normalised by its RMS so the weights stay O(1)
                let mut w: Vec<T> = a.iter().map(|v| T::one() / v.norm()).collect();
                let rms = num_traits::Float::sqrt(
                    w.iter().fold(T::zero(), |s, v| s + *v * *v) / T::from_usize_lossy(w.len()),
                );
                if rms > T::zero() && num_traits::Float::is_finite(rms) {
                    for v in w.iter_mut() {
                        *v /= rms;
                    }
                }
                Some(w)
            }
        }
    }
}

impl<T: Real, M: EquationError<T> + ?Sized> Criterion<T, M> for SanathananKoerner {
    type Problem<'a>
        = SkProblem<'a, T, M>
    where
        M: 'a,
        T: 'a;

    fn problem<'a>(
        &'a self,
        model: &'a M,
        data: &'a FrequencyData<T>,
    ) -> Result<SkProblem<'a, T, M>> {
        Ok(SkProblem {
            model,
            data,
            system: EquationErrorSystem::new(model, data, self.weighting)?,
            noise_weight: self.weighting.weights(data)?,
            responses: RefCell::new(Vec::with_capacity(2)),
            denominator: RefCell::new(None),
        })
    }
}

impl<T: Real, M: EquationError<T> + ?Sized> ReweightedProblem<T> for SkProblem<'_, T, M> {
    fn system(&self, previous: Option<&[T]>) -> (DMatrix<T>, DVector<T>) {
        self.system.normalised(self.sk_weights(previous).as_deref())
    }

    /// Small systems as the default; large ones accumulated over blocks of lines from the
    /// regressor, without the real-stacked system.
    fn solve_normal_equations(&self, previous: Option<&[T]>) -> Option<(Vec<T>, T)> {
        let reg = self.system.regressor();
        let max_cond = crate::linalg::gram::max_condition::<T>();
        let extra = self.sk_weights(previous);
        let (theta, cost) = if crate::linalg::gram::small_problem(reg.nrows(), reg.ncols()) {
            let (a, b) = self.system.normalised(extra.as_deref());
            crate::linalg::gram::least_squares_gram(&a, &b, max_cond)?
        } else {
            let w = self.system.line_weights(extra.as_deref());
            crate::linalg::gram::regressor_least_squares_gram(
                reg,
                w.as_deref(),
                self.system.normalising(),
                max_cond,
            )?
        };
        Some((theta.as_slice().to_vec(), cost))
    }

    fn rows(&self) -> usize {
        2 * self.system.regressor().nrows()
    }

    fn change(&self, old: &[T], new: &[T]) -> T {
        super::relative_change(&self.response(old), &self.response(new))
    }

    /// The output-error cost Σ W_k |Y_k − G U_k|²; without a transient term G and A come
    /// from one evaluation, and A is kept for the next iteration's weights.
    fn cost(&self, theta: &[T]) -> T {
        let (cost, g) = if self.model.has_transient() {
            super::output_error_cost(self.model, theta, self.data, self.noise_weight.as_deref())
        } else {
            let zero = Complex::new(T::zero(), T::zero());
            let (mut g, mut a) = (vec![zero; self.data.len()], vec![zero; self.data.len()]);
            self.model
                .response_and_denominator_into(theta, self.data.omega(), &mut g, &mut a);
            let (y, u) = (self.data.y(), self.data.u());
            let w = self.noise_weight.as_deref();
            let cost = (0..g.len()).fold(T::zero(), |s, k| {
                let wk = w.map_or(T::one(), |w| w[k]);
                s + ((y[k] - g[k] * u[k]) * wk).norm_sqr()
            });
            *self.denominator.borrow_mut() = Some((theta.to_vec(), a));
            (cost, g)
        };
        let mut cached = self.responses.borrow_mut();
        if cached.len() == 2 {
            cached.remove(0);
        }
        cached.push((theta.to_vec(), g));
        cost
    }
}
