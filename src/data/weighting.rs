//! Line weights from the measurement noise.

use super::FrequencyData;
use crate::error::{FdidError, Result};
use crate::scalar::Real;

/// How lines are weighted by the measurement noise.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum NoiseWeighting {
    /// Weight line k by 1/σ_k with σ_k² the output noise variance of the data when the data
    /// carry noise variances (a fixed noise model |H_ω|² = σ_k², eq. 23); flat otherwise.
    #[default]
    Auto,
    /// All lines weigh the same (H ≡ 1; λ is estimated, eq. 25).
    Flat,
}

impl NoiseWeighting {
    /// Per-line weights w_k = 1/σ_k, or `None` for flat weighting.
    ///
    /// # Errors
    /// A zero output noise variance on some line (the weight would be infinite).
    pub fn weights<T: Real>(&self, data: &FrequencyData<T>) -> Result<Option<Vec<T>>> {
        match (self, data.noise()) {
            (NoiseWeighting::Flat, _) | (NoiseWeighting::Auto, None) => Ok(None),
            (NoiseWeighting::Auto, Some(noise)) => {
                // checked first, so that the weights are collected at their exact size
                if let Some(k) = noise
                    .var_y
                    .iter()
                    .position(|v| num_traits::Float::is_nan(*v) || *v <= T::zero())
                {
                    return Err(FdidError::InvalidArgument {
                        name: "var_y",
                        value: format!("{} at line {k}", noise.var_y[k]),
                        reason: "a zero noise variance gives an infinite weight; use flat \
                                 weighting or drop the line"
                            .into(),
                    });
                }
                Ok(Some(
                    noise
                        .var_y
                        .iter()
                        .map(|v| T::one() / num_traits::Float::sqrt(*v))
                        .collect(),
                ))
            }
        }
    }
}
