//! The detectors of this slice: [`TimeDelay`], [`MissingResonance`], [`Transient`],
//! [`ColoredNoise`].
mod colored;
mod delay;
mod resonance;
mod transient;

pub use colored::ColoredNoise;
pub use delay::TimeDelay;
pub use resonance::MissingResonance;
pub use transient::Transient;
