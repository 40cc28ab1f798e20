//! The detectors of this slice: [`TimeDelay`], [`MissingResonance`], [`Transient`],
//! [`ColoredNoise`], [`OrderIncrease`] (missing pole or zero), and the measurement-level
//! [`InputNoise`], [`NonlinearDistortion`], [`TimeVariation`], [`TimeDrift`] (both in [`TimeVariationTests`]).
//!
//! Each detector's [`Finding`](super::Finding) carries its typed detail
//! ([`Detail`](super::Detail)): [`TimeDelayDetail`], [`MissingResonanceDetail`], ….
//! Beside the detectors: the piecewise time-invariant model the workflow switches to when
//! it names time variation ([`piecewise_model`], [`TimeVarying`]).
mod colored;
mod delay;
mod distortion;
mod drift;
mod input_noise;
mod order;
mod piecewise;
mod resonance;
mod score;
mod time_variation;
mod transient;

pub use colored::{ColoredNoise, ColoredNoiseDetail, reference_colour};
pub use delay::{TimeDelay, TimeDelayDetail};
pub use distortion::{NonlinearDistortion, NonlinearDistortionDetail};
pub use drift::{Drift, TimeDrift, TimeDriftDetail, parameter_drift};
pub use input_noise::{InputNoise, InputNoiseDetail};
pub use order::{Added, OrderIncrease, OrderIncreaseDetail};
pub use piecewise::{TimeVarying, piecewise_model};
pub use resonance::{MissingResonance, MissingResonanceDetail};
pub use time_variation::{
    TimeVariation, TimeVariationDetail, TimeVariationTests, TimeVariationTestsDetail,
};
pub use transient::{Transient, TransientDetail};
