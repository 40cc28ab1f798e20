//! The detectors of this slice: [`TimeDelay`], [`MissingResonance`], [`Transient`],
//! [`ColoredNoise`], [`OrderIncrease`] (missing pole or zero).
mod colored;
mod delay;
mod order;
mod resonance;
mod score;
mod transient;

pub use colored::ColoredNoise;
pub use delay::TimeDelay;
pub use order::{Added, OrderIncrease};
pub use resonance::MissingResonance;
pub use transient::Transient;
