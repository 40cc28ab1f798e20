//! Measured data: time records, their DFT (McKelvey eq. 1), periodic averaging, and
//! frequency-domain data with band selection and merging of experiments.

mod distortion;
mod frequency;
mod lpm;
mod merge;
mod periodic;
mod time;

pub(crate) use distortion::check_band_order;
pub use distortion::{DetectionLine, DetectionTest, DistortionAnalysis};
pub use frequency::{FrequencyData, NoiseVariances};
pub use lpm::{Lpm, LpmEstimate, lpm};
pub use merge::merge;
pub use periodic::PeriodicAverage;
pub(crate) use time::check_ts;
pub use time::{TimeData, dft_lines};
