//! Which lines of one period are excited, odd detection or even detection lines.

use crate::error::{FdidError, Result};

/// Which lines of one period are excited, odd detection or even detection lines.
pub(super) struct LinePlan {
    /// Excited lines within the band, increasing.
    pub(super) excited: Vec<usize>,
    /// Odd detection lines: the odd lines of the band not excited, increasing.
    pub(super) odd: Vec<usize>,
    /// Even detection lines: the even lines of the band not excited, increasing.
    pub(super) even: Vec<usize>,
}

impl LinePlan {
    /// The plan of the band `band` of a period of `m` samples excited at `excited`;
    /// `detection_optional`: a band without detection lines is accepted (several
    /// realisations give a test of their own).
    pub(super) fn new(
        m: usize,
        excited: &[usize],
        band: [usize; 2],
        detection_optional: bool,
    ) -> Result<Self> {
        if excited.is_empty() {
            return Err(FdidError::TooShort {
                what: "excited lines",
                needed: 1,
                got: 0,
            });
        }
        if let Some(&k) = excited.iter().find(|&&k| k > m / 2) {
            return Err(FdidError::InvalidArgument {
                name: "excited",
                value: k.to_string(),
                reason: format!(
                    "beyond the last DFT line ⌊M/2⌋ = {} of a period of M = {m} samples",
                    m / 2
                ),
            });
        }
        check_band_order(band)?;
        if 2 * band[1] >= m {
            return Err(FdidError::InvalidArgument {
                name: "band",
                value: format!("[{}, {}]", band[0], band[1]),
                reason: format!(
                    "the highest line must lie below the Nyquist line M/2 = {} (M = {m})",
                    m as f64 / 2.0
                ),
            });
        }
        let mut is_excited = vec![false; band[1] + 1];
        for &k in excited {
            if k <= band[1] {
                is_excited[k] = true;
            }
        }
        let in_band = band[0]..=band[1];
        let exc: Vec<usize> = in_band.clone().filter(|&k| is_excited[k]).collect();
        if exc.is_empty() {
            return Err(FdidError::TooShort {
                what: "excited lines in the band",
                needed: 1,
                got: 0,
            });
        }
        let odd: Vec<usize> = in_band
            .clone()
            .filter(|&k| !is_excited[k] && k % 2 == 1)
            .collect();
        let even: Vec<usize> = in_band.filter(|&k| !is_excited[k] && k % 2 == 0).collect();
        if odd.is_empty() && even.is_empty() && !detection_optional {
            return Err(FdidError::TooShort {
                what: "detection (non-excited) lines in the band",
                needed: 1,
                got: 0,
            });
        }
        Ok(Self {
            excited: exc,
            odd,
            even,
        })
    }
}

/// `band[0] ≥ 1` and `band[0] ≤ band[1]`.
pub(crate) fn check_band_order(band: [usize; 2]) -> Result<()> {
    if band[0] == 0 || band[0] > band[1] {
        return Err(FdidError::InvalidArgument {
            name: "band",
            value: format!("[{}, {}]", band[0], band[1]),
            reason: "need lines 1 ≤ k_min ≤ k_max (the DC line is not a sinusoid)".into(),
        });
    }
    Ok(())
}
