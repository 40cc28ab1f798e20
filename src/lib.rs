//! # fdid — frequency-domain system identification (being assembled)

#![warn(missing_docs)]

pub mod data;
pub mod error;
#[cfg(feature = "csv")]
pub mod io;
pub mod scalar;

pub use data::{FrequencyData, NoiseVariances};
pub use error::{FdidError, Result};
pub use scalar::{Complex, Real};
