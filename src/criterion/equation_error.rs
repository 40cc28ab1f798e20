//! The weighted equation-error system shared by Levy, Sanathanan–Koerner and TLS.

use super::{NoiseWeighting, check_input};
use crate::data::FrequencyData;
use crate::error::Result;
use crate::model::EquationError;
use crate::scalar::{Complex, Real};
use nalgebra::{DMatrix, DVector};

/// The regressor R of an [`EquationError`] model on data (e_k = Σ_j R_kj c_j), with the
/// per-line noise weights.
#[derive(Debug, Clone)]
pub struct EquationErrorSystem<T: Real> {
    regressor: DMatrix<Complex<T>>,
    noise_weight: Option<Vec<T>>,
    normalising: usize,
}

impl<T: Real> EquationErrorSystem<T> {
    /// Builds R for `model` on `data`.
    ///
    /// # Errors
    /// As [`crate::ModelStructure::check_data`]; zero input lines; zero noise variances.
    pub fn new<M: EquationError<T> + ?Sized>(
        model: &M,
        data: &FrequencyData<T>,
        weighting: NoiseWeighting,
    ) -> Result<Self> {
        model.check_data(data)?;
        check_input(data)?;
        let noise_weight = weighting.weights(data)?;
        let mut regressor = DMatrix::zeros(data.len(), model.n_coefficients());
        model.regressor_into(data, &mut regressor);
        Ok(Self {
            regressor,
            noise_weight,
            normalising: model.normalising_index(),
        })
    }

    /// The complex regressor R.
    pub fn regressor(&self) -> &DMatrix<Complex<T>> {
        &self.regressor
    }

    /// Index of the coefficient fixed to one by the normalisation.
    pub(crate) fn normalising(&self) -> usize {
        self.normalising
    }

    /// Per-line weights √W_k = extra_k · w_k, with w_k the noise weight.
    pub(crate) fn line_weights(&self, extra: Option<&[T]>) -> Option<Vec<T>> {
        match (extra, &self.noise_weight) {
            (None, None) => None,
            (Some(e), None) => Some(e.to_vec()),
            (None, Some(w)) => Some(w.clone()),
            (Some(e), Some(w)) => Some(e.iter().zip(w).map(|(a, b)| *a * *b).collect()),
        }
    }

    /// The real-stacked weighted homogeneous matrix (all coefficients).
    pub fn homogeneous(&self, extra: Option<&[T]>) -> DMatrix<T> {
        crate::linalg::stack_rows(&self.regressor, self.line_weights(extra).as_deref())
    }

    /// The real-stacked weighted system A θ ≈ b with the normalising coefficient fixed to
    /// one: A holds the other columns, b = −(normalising column). Built in one pass.
    pub fn normalised(&self, extra: Option<&[T]>) -> (DMatrix<T>, DVector<T>) {
        let w = self.line_weights(extra);
        let (n, p) = self.regressor.shape();
        let mut a = DMatrix::<T>::zeros(2 * n, p - 1);
        let mut b = DVector::<T>::zeros(2 * n);
        crate::linalg::normalised_into(
            &self.regressor,
            w.as_deref(),
            self.normalising,
            &mut a,
            &mut b,
        );
        (a, b)
    }
}
