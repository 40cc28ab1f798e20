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
            (NoiseWeighting::Auto, Some(noise)) => noise
                .var_y
                .iter()
                .enumerate()
                .map(|(k, v)| {
                    if *v > T::zero() {
                        Ok(T::one() / num_traits::Float::sqrt(*v))
                    } else {
                        Err(FdidError::InvalidArgument {
                            name: "var_y",
                            value: format!("{v} at line {k}"),
                            reason: "a zero noise variance gives an infinite weight; use flat \
                                     weighting or drop the line"
                                .into(),
                        })
                    }
                })
                .collect::<Result<Vec<T>>>()
                .map(Some),
        }
    }
}
