//! The detectors of this slice: [`TimeDelay`], [`MissingResonance`], [`Transient`].
mod delay;
mod resonance;
mod transient;

pub use delay::TimeDelay;
pub use resonance::MissingResonance;
pub use transient::Transient;
