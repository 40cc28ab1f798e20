//! The passivity check of a scattering model: ‖S(iω)‖₂ ≤ 1 at every frequency.

use super::model::CommonPoleModel;
use crate::scalar::Real;
use num_traits::Float;

/// How far above 1 the largest singular value may be before a grid point counts as a
/// violation: rounding and the fit error of a lossless port (|S₁₁(0)| = 1 for a series
/// capacitor) reach 10⁻⁷, far below any physical gain.
pub const PASSIVITY_TOLERANCE: f64 = 1e-6;

/// The largest singular value of a scattering model's S over a dense grid.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Passivity<T: Real> {
    /// max over the grid of σ_max(S).
    pub max_singular_value: T,
    /// Where it is reached (Hz).
    pub at_hz: T,
    /// Grid points where σ_max(S) > 1 + [`PASSIVITY_TOLERANCE`].
    pub violations: usize,
    /// Grid points checked.
    pub points: usize,
}

impl<T: Real> Passivity<T> {
    /// True when no grid point violates σ_max(S) ≤ 1 + [`PASSIVITY_TOLERANCE`].
    pub fn passive(&self) -> bool {
        self.violations == 0
    }
}

/// Checks σ_max(S(iω)) ≤ 1 for a scattering model on `points` evenly spaced frequencies
/// from 0 to 1.5 times `f_max_hz` together with the natural frequency of every pole and
/// points on its flanks (where a violation peaks), the test of a passive n-port (a reciprocal lossless network has
/// σ_max = 1). A sampled check: a violation narrower than the grid can escape it.
pub fn passivity<T: Real>(model: &CommonPoleModel<T>, f_max_hz: T, points: usize) -> Passivity<T> {
    let omega = frequency_grid(model, f_max_hz, points);
    let responses = model.response(&omega);
    let largest = crate::linalg::parallel::map_indices(responses.len(), |k| {
        nalgebra::SVD::try_new_unordered(
            responses[k].clone(),
            false,
            false,
            T::default_epsilon(),
            1000,
        )
        .map(|svd| {
            svd.singular_values
                .iter()
                .copied()
                .fold(T::zero(), Float::max)
        })
        .unwrap_or(T::infinity())
    });
    let mut worst = (T::zero(), T::zero());
    let mut violations = 0;
    for (w, s) in omega.iter().zip(largest) {
        if s > T::one() + T::lit(PASSIVITY_TOLERANCE) {
            violations += 1;
        }
        if !(s <= worst.0) {
            worst = (s, *w / T::two_pi());
        }
    }
    Passivity {
        max_singular_value: worst.0,
        at_hz: worst.1,
        violations,
        points: omega.len(),
    }
}

/// The check's frequencies (rad/s, ascending): `points` evenly spaced from 0 to 1.5 times
/// `f_max_hz`, the natural frequency of every pole and, within that range, 8 points on
/// its flanks (±¼, ½, 1, 2 half-bandwidths).
pub(crate) fn frequency_grid<T: Real>(
    model: &CommonPoleModel<T>,
    f_max_hz: T,
    points: usize,
) -> Vec<T> {
    let top = f_max_hz * T::lit(1.5) * T::two_pi();
    let mut omega: Vec<T> = (0..points.max(2))
        .map(|k| top * T::from_usize_lossy(k) / T::from_usize_lossy(points.max(2) - 1))
        .collect();
    // each resonance's peak and its flanks, at a quarter to twice its half-bandwidth
    // |Re p| (in z, |ln|p||/ts) on either side: an evenly spaced grid over a wide band
    // steps over the peak of a lightly damped low-frequency mode
    for p in model.poles.slots() {
        let (w, half_width) = match model.domain {
            crate::model::Domain::Continuous => (Float::abs(p.im), Float::abs(p.re)),
            crate::model::Domain::Discrete { ts } => (
                Float::abs(p.arg()) / ts,
                Float::abs(Float::ln(p.norm())) / ts,
            ),
        };
        omega.push(w);
        for offset in [0.25, 0.5, 1.0, 2.0] {
            for side in [-1.0, 1.0] {
                let at = w + T::lit(side * offset) * half_width;
                if at >= T::zero() && at <= top {
                    omega.push(at);
                }
            }
        }
    }
    omega.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
    omega
}
