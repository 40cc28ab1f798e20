//! Total least squares on the equation error.

use super::{Criterion, EquationErrorSystem, NoiseWeighting};
use crate::data::FrequencyData;
use crate::error::Result;
use crate::model::EquationError;
use crate::problem::HomogeneousProblem;
use crate::scalar::Real;
use nalgebra::DMatrix;

/// Total least squares: minimise ‖W R c‖ over real coefficient vectors with ‖c‖ = 1,
/// i.e. c is the right singular vector of the smallest singular value of the real-stacked,
/// weighted regressor [Re(WR); Im(WR)]; θ = c / c_norm. Requires an [`EquationError`]
/// model. Unlike Levy it treats every coefficient alike (no preferred normalisation).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct TotalLeastSquares {
    /// Noise weighting of the lines.
    pub weighting: NoiseWeighting,
}

/// The TLS criterion bound to a model and data.
pub struct TlsProblem<'a, T: Real, M: ?Sized> {
    model: &'a M,
    system: EquationErrorSystem<T>,
}

impl<T: Real, M: EquationError<T> + ?Sized> Criterion<T, M> for TotalLeastSquares {
    type Problem<'a>
        = TlsProblem<'a, T, M>
    where
        M: 'a,
        T: 'a;

    fn problem<'a>(
        &'a self,
        model: &'a M,
        data: &'a FrequencyData<T>,
    ) -> Result<TlsProblem<'a, T, M>> {
        Ok(TlsProblem {
            model,
            system: EquationErrorSystem::new(model, data, self.weighting)?,
        })
    }
}

impl<T: Real, M: EquationError<T> + ?Sized> HomogeneousProblem<T> for TlsProblem<'_, T, M> {
    fn matrix(&self) -> DMatrix<T> {
        self.system.homogeneous(None)
    }

    fn theta_from_null_vector(&self, c: &[T]) -> Option<Vec<T>> {
        self.model.theta_from_coefficients(c)
    }
}
