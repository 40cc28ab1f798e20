//! The one check of frequency data against a model sampled with a sample time Ts.

use super::FrequencyData;
use crate::error::{FdidError, Result};
use crate::scalar::Real;
use num_traits::Float;

/// Relative tolerance of a sample-time comparison: the data's Ts and a model's Ts agree
/// when |Ts_data − Ts| ≤ 10⁻⁶·Ts (sample times written to files with six or more
/// significant digits compare equal).
pub const SAMPLE_TIME_TOLERANCE: f64 = 1e-6;

/// Relative slack on the Nyquist frequency π/Ts for the rounding of line frequencies:
/// max(10⁻⁹, 64ε) (the Nyquist line of a DFT converted to f32 stays on the grid).
pub fn nyquist_slack<T: Real>() -> T {
    Float::max(T::lit(1e-9), T::default_epsilon() * T::lit(64.0))
}

impl<T: Real> FrequencyData<T> {
    /// Checks the data against a model part sampled with `ts` (named `what` in the
    /// messages, e.g. `"model"`, `"transient"`): the data's own sample time, when they carry
    /// one, equal to `ts` within [`SAMPLE_TIME_TOLERANCE`], and no line above the Nyquist
    /// frequency π/Ts (with the slack of [`nyquist_slack`]).
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] naming the data's sample time (`ts`) or the first
    /// line above the Nyquist frequency (`omega`).
    pub fn check_sampled_grid(&self, ts: T, what: &str) -> Result<()> {
        if let Some(dts) = self.ts()
            && !(Float::abs(dts - ts) <= ts * T::lit(SAMPLE_TIME_TOLERANCE))
        {
            return Err(FdidError::InvalidArgument {
                name: "ts",
                value: format!("{dts}"),
                reason: format!("the data's sample time differs from the {what}'s ({ts})"),
            });
        }
        let nyquist = T::pi() / ts;
        if let Some(w) = self
            .omega()
            .iter()
            .find(|w| **w > nyquist * (T::one() + nyquist_slack::<T>()))
        {
            return Err(FdidError::InvalidArgument {
                name: "omega",
                value: format!("{w} rad/s"),
                reason: format!(
                    "above the Nyquist frequency {nyquist} rad/s of the {what}'s Ts = {ts} s"
                ),
            });
        }
        Ok(())
    }
}
