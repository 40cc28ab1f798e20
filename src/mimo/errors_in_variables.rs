//! Common-pole fits of FRF matrices whose inputs were measured with noise: the
//! errors-in-variables covariance, which holds the model's response, by reweighting.

use super::{CommonPoleFit, CommonPoleOptions, PoleSet, fit_matrix};
use crate::data::FrfMatrix;
use crate::error::Result;
use crate::scalar::Real;
use nalgebra::DMatrix;
use num_traits::Float;

/// Refits after the first at most this many times.
const PASSES: usize = 4;

/// A change of the cost between passes below this fraction ends the reweighting.
const SETTLED: f64 = 1e-3;

/// The common-pole fit of `data` (from `start` when given). Without input noise attached
/// ([`FrfMatrix::with_input_noise`]) or without `full_covariance`, one fit as weighted.
/// Otherwise the errors-in-variables weighting
///
/// ```text
/// V(θ) = Σ_j Σ_k r_jkᴴ C_jk(θ)⁻¹ r_jk,
/// C_jk(θ) = C_jk − c_jk G_j(θ)ᴴ − G_j(θ) c_jkᴴ + G_j(θ) G_j(θ)ᴴ s_jk
/// ```
///
/// (McKelvey's errors-in-variables criterion with one input per column, the weight
/// holding the model's response G_j of column j), by reweighting: the first fit weights
/// by C at the measured FRF, each further one by C at the previous fit's response,
/// warm-started from its poles, until the cost changes by less than 10⁻³ of itself or
/// after 4 refits. The derivative of the weight is not in the Jacobian (a fixed point of
/// the reweighting, not the exact minimiser of V(θ)); the poles' covariance is that of
/// the last weighted fit.
pub(super) fn reweighted<T: Real>(
    data: &FrfMatrix<T>,
    order: usize,
    start: Option<&PoleSet<T>>,
    options: &CommonPoleOptions<T>,
) -> Result<CommonPoleFit<T>> {
    if !(options.full_covariance && data.has_input_noise()) {
        return fit_matrix(data, order, start, options);
    }
    let (ny, nu) = (data.ny(), data.nu());
    let measured = |k: usize| DMatrix::from_fn(ny, nu, |i, j| data.entry(i, j).y()[k]);
    let mut fit = fit_matrix(&data.at_response(measured)?, order, start, options)?;
    for _ in 0..PASSES {
        let g = fit.model.response(data.omega());
        let weighted = data.at_response(|k| g[k].clone())?;
        let next = fit_matrix(&weighted, order, Some(&fit.model.poles), options)?;
        let change =
            Float::abs(next.cost - fit.cost) / Float::max(fit.cost, T::min_positive_value());
        fit = next;
        if change < T::lit(SETTLED) {
            break;
        }
    }
    Ok(fit)
}
