//! Levy's linear least-squares estimator (McKelvey eq. 39).

use super::{Criterion, EquationErrorSystem, NoiseWeighting};
use crate::data::FrequencyData;
use crate::error::Result;
use crate::model::EquationError;
use crate::problem::LinearProblem;
use crate::scalar::Real;
use nalgebra::{DMatrix, DVector};

/// Levy's estimator: minimise the equation error
///
/// ```text
/// V(θ) = Σ_k W_k |A_θ(ω_k) Y_k − B_θ(ω_k) U_k|²        (McKelvey eq. 39)
/// ```
///
/// with W_k = 1/σ_k² when the data carry output noise variances (else 1). Quadratic in θ,
/// so one linear least-squares solve; biased with noise (an implicit noise model 1/A), but
/// a good start for SK and ML. Requires an [`EquationError`] model.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Levy {
    /// Noise weighting of the lines.
    pub weighting: NoiseWeighting,
}

/// Levy's criterion bound to a model and data.
#[derive(Debug, Clone)]
pub struct LevyProblem<T: Real> {
    system: EquationErrorSystem<T>,
}

impl<T: Real, M: EquationError<T> + ?Sized> Criterion<T, M> for Levy {
    type Problem<'a>
        = LevyProblem<T>
    where
        M: 'a,
        T: 'a;

    fn problem<'a>(&'a self, model: &'a M, data: &'a FrequencyData<T>) -> Result<LevyProblem<T>> {
        Ok(LevyProblem {
            system: EquationErrorSystem::new(model, data, self.weighting)?,
        })
    }
}

impl<T: Real> LinearProblem<T> for LevyProblem<T> {
    fn system(&self) -> (DMatrix<T>, DVector<T>) {
        self.system.normalised(None)
    }
}
