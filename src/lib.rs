//! # fdid — frequency-domain system identification (being assembled)

#![warn(missing_docs)]

pub mod basis;
pub mod data;
pub mod error;
#[cfg(feature = "csv")]
pub mod io;
pub mod model;
pub mod roots;
pub mod scalar;

pub use data::{FrequencyData, NoiseVariances, TimeData};
pub use error::{FdidError, Result};
pub use scalar::{Complex, Real};
