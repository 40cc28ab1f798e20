//! The design of a random odd multisine with detection lines: which lines are excited,
//! which are left out to detect odd and even nonlinear distortion, and the excitation.

use crate::data::check_band_order;
use crate::error::{FdidError, Result};
use crate::scalar::Real;
use crate::simulate::{Multisine, SplitMix64};
use std::f64::consts::TAU;

/// The line plan of a random odd multisine with detection lines.
///
/// In the band of DFT lines `k_min ≤ k ≤ k_max` (line `k` of one period of `M` samples is
/// at `f_k = k / (M T_s)`):
///
/// - the odd lines are cut into consecutive groups of `g` (`group`); in every full group
///   one line, drawn at random from `seed`, is left out — an *odd detection line*; the
///   others are *excited*; the lines of a last incomplete group are all excited;
/// - every even line is an *even detection line*.
///
/// So a fraction `1/g` of the odd lines detects odd distortion, and all even lines detect
/// even distortion. [`OddMultisineDesign::multisine`] builds the excitation
/// `u(t) = Σ_{k excited} A cos(2π k t / T_period + φ_k)` with independent uniform phases
/// (a *random-phase* multisine, whose distortion behaves as a noise-like term over phase
/// realisations). Sampled over whole periods its DFT (McKelvey eq. 1) is zero at every
/// detection line, so whatever the output shows there is noise or distortion: the
/// records it excites are analysed by [`DistortionAnalysis`](crate::data::DistortionAnalysis).
///
/// ```
/// use fdid::simulate::OddMultisineDesign;
///
/// let design = OddMultisineDesign::new([1, 60], 3, 7).unwrap();
/// assert_eq!(design.odd_detection().len(), 10); // 30 odd lines, groups of 3
/// assert_eq!(design.excited().len(), 20);
/// assert_eq!(design.even_detection().len(), 30);
/// let u = design.multisine(256.0f64, 11).unwrap(); // period 256 samples at Ts = 1
/// assert_eq!(u.lines(), design.excited());
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct OddMultisineDesign {
    band: [usize; 2],
    group: usize,
    excited: Vec<usize>,
    odd_detection: Vec<usize>,
    even_detection: Vec<usize>,
}

impl OddMultisineDesign {
    /// The line plan on the lines `band[0] ≤ k ≤ band[1]` with one odd detection line in
    /// every group of `group` consecutive odd lines (see the type documentation).
    ///
    /// # Errors
    /// - [`FdidError::InvalidArgument`] named `"band"` when `band[0] = 0` (the DC line is
    ///   not a sinusoid) or `band[0] > band[1]`; named `"group"` when `group < 2`;
    /// - [`FdidError::TooShort`] when the band holds fewer than `group` odd lines (no
    ///   odd detection line could be placed).
    pub fn new(band: [usize; 2], group: usize, seed: u64) -> Result<Self> {
        check_band_order(band)?;
        if group < 2 {
            return Err(FdidError::InvalidArgument {
                name: "group",
                value: group.to_string(),
                reason: "one odd line out of every group is left out: need a group of ≥ 2".into(),
            });
        }
        let odd: Vec<usize> = (band[0]..=band[1]).filter(|k| k % 2 == 1).collect();
        if odd.len() < group {
            return Err(FdidError::TooShort {
                what: "odd lines in the band",
                needed: group,
                got: odd.len(),
            });
        }
        let mut rng = SplitMix64::new(seed);
        let mut excited = Vec::with_capacity(odd.len());
        let mut odd_detection = Vec::with_capacity(odd.len() / group + 1);
        for chunk in odd.chunks(group) {
            if chunk.len() == group {
                // uniform on 0..group (the modulo bias is below 2⁻⁵⁰ for any sane group)
                let out = (rng.next_u64() % group as u64) as usize;
                for (i, &k) in chunk.iter().enumerate() {
                    if i == out {
                        odd_detection.push(k);
                    } else {
                        excited.push(k);
                    }
                }
            } else {
                excited.extend_from_slice(chunk);
            }
        }
        let even_detection = (band[0]..=band[1]).filter(|k| k % 2 == 0).collect();
        Ok(Self {
            band,
            group,
            excited,
            odd_detection,
            even_detection,
        })
    }

    /// The band `[k_min, k_max]` (DFT line numbers of one period).
    pub fn band(&self) -> [usize; 2] {
        self.band
    }

    /// The group size `g`: one odd line in every `g` is a detection line.
    pub fn group(&self) -> usize {
        self.group
    }

    /// The excited lines (odd, increasing).
    pub fn excited(&self) -> &[usize] {
        &self.excited
    }

    /// The odd detection lines: odd lines in the band left unexcited (increasing).
    pub fn odd_detection(&self) -> &[usize] {
        &self.odd_detection
    }

    /// The even detection lines: every even line in the band (increasing).
    pub fn even_detection(&self) -> &[usize] {
        &self.even_detection
    }

    /// The random-phase multisine `u(t) = Σ_{k excited} A cos(2π k t / T_period + φ_k)`
    /// with flat amplitudes `A` scaled to unit RMS (`√(Σ A²/2) = 1`) and phases `φ_k`
    /// independent and uniform on `[0, 2π)`, drawn from `seed` (a new seed gives a new
    /// phase realisation). Sampled with `T_period = M T_s` its DFT over one period is
    /// non-zero only at the excited lines; check the sampling rate with
    /// [`Multisine::check_sampling`].
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] named `"period"` when `period` is not positive and
    /// finite.
    pub fn multisine<T: Real>(&self, period: T, seed: u64) -> Result<Multisine<T>> {
        let mut rng = SplitMix64::new(seed);
        let phases: Vec<T> = self
            .excited
            .iter()
            .map(|_| T::lit(TAU * rng.uniform()))
            .collect();
        let amplitudes = vec![T::one(); self.excited.len()];
        Multisine::from_lines(period, self.excited.clone(), amplitudes, phases)?.with_rms(T::one())
    }
}
