//! The detectors of this slice: [`TimeDelay`], [`MissingResonance`], [`Transient`],
//! [`ColoredNoise`], [`OrderIncrease`] (missing pole or zero), and the measurement-level
//! [`InputNoise`], [`NonlinearDistortion`], [`TimeVariation`], [`TimeDrift`] (both in [`TimeVariationTests`]).
mod colored;
mod delay;
mod distortion;
mod drift;
mod input_noise;
mod order;
mod resonance;
mod score;
mod time_variation;
mod transient;

pub use colored::ColoredNoise;
pub use delay::TimeDelay;
pub use distortion::NonlinearDistortion;
pub use drift::{
    Drift, TimeDrift, TimeVariationTests, TimeVarying, parameter_drift, piecewise_model,
};
pub use input_noise::InputNoise;
pub use order::{Added, OrderIncrease};
pub use resonance::MissingResonance;
pub use time_variation::TimeVariation;
pub use transient::Transient;
