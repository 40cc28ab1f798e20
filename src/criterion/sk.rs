//! Sanathanan–Koerner iterations (McKelvey eq. 41).

use super::{Criterion, EquationErrorSystem, NoiseWeighting};
use crate::data::FrequencyData;
use crate::error::Result;
use crate::model::EquationError;
use crate::problem::ReweightedProblem;
use crate::{Complex, Real};
use nalgebra::{DMatrix, DVector};

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
        })
    }
}

impl<T: Real, M: EquationError<T> + ?Sized> ReweightedProblem<T> for SkProblem<'_, T, M> {
    fn system(&self, previous: Option<&[T]>) -> (DMatrix<T>, DVector<T>) {
        match previous {
            None => self.system.normalised(None),
            Some(theta) => {
                let mut a = vec![Complex::new(T::zero(), T::zero()); self.data.len()];
                self.model
                    .denominator_into(theta, self.data.omega(), &mut a);
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
                self.system.normalised(Some(&w))
            }
        }
    }

    fn change(&self, old: &[T], new: &[T]) -> T {
        let omega = self.data.omega();
        super::relative_change(
            &self.model.response(old, omega),
            &self.model.response(new, omega),
        )
    }

    fn cost(&self, theta: &[T]) -> T {
        super::output_error_cost(self.model, theta, self.data, self.noise_weight.as_deref()).0
    }
}
