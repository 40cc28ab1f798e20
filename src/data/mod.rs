//! Measured data: time records, their DFT (McKelvey eq. 1), periodic averaging, and
//! frequency-domain data with band selection and merging of experiments.

mod distortion;
mod excitation;
mod excited;
mod frequency;
mod grid;
mod input_noise;
mod lpm;
mod matrix;
mod merge;
mod mimo_noise;
mod normalise;
mod periodic;
mod spectra;
mod time;
mod weighting;

pub(crate) use distortion::check_band_order;
pub use distortion::{
    DetectionLine, DetectionTest, DistortionAnalysis, RealisationBla, SpreadTest,
};
pub use excitation::{DC_ROUNDING, EXCITATION_FRACTION, PERIODICITY_TOLERANCE};
pub use excited::{
    EXCITATION_DIP_DB, EXCITATION_GAP_DB, EXCITATION_GAP_MIN_LINES, EXCITATION_GRID_ALPHA,
    Excitation, ExcitationRule, GridPattern, UNEXCITED_NEIGHBOURS,
};
pub use frequency::{FrequencyData, NoiseVariances};
pub use grid::{SAMPLE_TIME_TOLERANCE, nyquist_slack};
pub use input_noise::InputNoise;
pub use lpm::{Lpm, LpmEstimate, lpm};
pub use matrix::FrfMatrix;
pub use merge::merge;
pub use mimo_noise::MimoNoise;
pub(crate) use normalise::power_of_two_factor;
pub use normalise::{NEAR_ONE_EXPONENT, Normalisation};
pub use periodic::PeriodicAverage;
pub use spectra::MimoSpectra;
pub(crate) use time::check_ts;
pub use time::{TimeData, dft_lines};
pub use weighting::NoiseWeighting;
