//! Nonlinear distortion detection with odd random-phase multisines, and the best linear
//! approximation (BLA).
//!
//! McKelvey's data model (eq. 19) is linear: `Y_k = G₀(ω_k) U_k + H₀(ω_k) E_k` with the
//! noise term complex normal, zero mean and independent between lines (eqs. 13–14, 17–18).
//! A nonlinear system driven by a periodic input adds a *periodic* term `Y_S,k` that the
//! model cannot explain: it does not average out over periods and it lands on lines the
//! input does not excite. An odd multisine (only odd lines excited) with one odd line in
//! every group left out makes the distortion visible (the design of Pintelon & Schoukens,
//! *System Identification: A Frequency Domain Approach*, ch. 3–4):
//!
//! - even-degree terms of the nonlinearity (`x²`, `x⁴`, …) of an odd signal only produce
//!   *even* lines, odd-degree terms (`x³`, …) only *odd* lines;
//! - so energy above the noise at the non-excited *even* lines reveals even distortion,
//!   at the non-excited *odd* lines odd distortion.
//!
//! Everything here is built on the DFT of each period (McKelvey eq. 1 with `N → M`) and
//! the averaging over `P` periods of [`PeriodicAverage`]: the noise variance per line
//! comes from the spread between periods, the distortion from the energy of the mean.
//!
//! - The line plan: which lines of the band are excited, odd detection or even detection
//!   lines (`fdid::simulate::OddMultisineDesign` designs a random-phase odd multisine
//!   with such a plan).
//! - [`DistortionAnalysis`]: the detection tests ([`DetectionTest`], per line
//!   [`DetectionLine`]), the distortion and noise levels, and the BLA with its variance.

mod analysis;
mod bla;
mod line_plan;
mod realisations;
mod statistics;

pub use analysis::DistortionAnalysis;
pub(crate) use line_plan::check_band_order;
pub use realisations::{RealisationBla, SpreadTest};
pub use statistics::{DetectionLine, DetectionTest};

use crate::data::{NoiseVariances, PeriodicAverage};
use crate::scalar::{Complex, Real};

fn f64c<T: Real>(c: Complex<T>) -> Complex<f64> {
    Complex::new(c.re.to_f64_lossless(), c.im.to_f64_lossless())
}

fn noise_of<T: Real>(avg: &PeriodicAverage<T>) -> &NoiseVariances<T> {
    avg.data()
        .noise()
        .expect("P ≥ 2 periods always give noise variances")
}
