//! Readers for the data files of the `fdid` command (feature `csv`).
//!
//! A CSV file holds one [`Measurement`]: frequency-domain data (an FRF or input/output
//! spectra) or a uniformly sampled time record. See [`parse_csv`] for the format. A raw
//! table of several channels (a benchmark file, a DaISy `.dat` file) gives a time record
//! of one input and one output column: [`read_channels`]; several input and output
//! columns of one record give their spectra: [`read_multichannel`]. A
//! Touchstone `.sNp` (version 1 or 2.0) or `.ts` (version 2.0) file holds the
//! network parameters of an n-port; see [`parse_touchstone`],
//! [`Touchstone::frequency_data`] for one entry as an FRF and [`Touchstone::frf_matrix`]
//! for all of them.

mod csv;
mod lines;
mod touchstone;

pub use self::lines::{MAX_LINE_BYTES, printable};

/// The most ports of a Touchstone file that are read (`.s1p` … `.s64p`).
pub const MAX_PORTS: usize = 64;

pub use self::csv::{
    ChannelSelection, Column, MultiChannelSelection, is_frf_matrix_csv, parse_channels, parse_csv,
    parse_multichannel, read_channels, read_csv, read_multichannel, uniform_sample_time,
};
pub use self::touchstone::{
    NetworkParameter, NumberFormat, Touchstone, TouchstoneVersion, is_touchstone, parse_touchstone,
    parse_touchstone_v2, read_touchstone, touchstone_ports,
};

use crate::data::{FrequencyData, FrfMatrix, TimeData};
use crate::scalar::Real;

/// The content of a data file.
#[derive(Debug, Clone, PartialEq)]
pub enum Measurement<T: Real> {
    /// Frequency-domain data: an FRF `G_k` (stored with `U_k = 1`) or spectra `Y_k`, `U_k`,
    /// at `ω_k = 2π f_k` rad/s, without a sample time.
    Frequency(FrequencyData<T>),
    /// A uniformly sampled time record `u(t)`, `y(t)` with sample time `Ts`.
    Time(TimeData<T>),
    /// A frequency response matrix (ny × nu FRF per line) without a sample time.
    Matrix(FrfMatrix<T>),
}

impl<T: Real> Measurement<T> {
    /// The frequency-domain form: frequency data unchanged, a time record through its DFT
    /// `X(ω_k) = (1/√N) Σ_t x(t Ts) e^{−i 2π k t / N}` on `ω_k = 2πk/(N Ts)`,
    /// `k = 0, …, ⌊N/2⌋` (see [`TimeData::dft`]), a 1 × 1 matrix its entry.
    ///
    /// # Errors
    /// A frequency response matrix of more than one entry: pick one with
    /// [`FrfMatrix::entry`], or fit them all with [`crate::mimo::fit_common_poles`].
    pub fn into_frequency_data(self) -> crate::error::Result<FrequencyData<T>> {
        match self {
            Self::Frequency(d) => Ok(d),
            Self::Time(t) => Ok(t.dft()),
            Self::Matrix(m) if m.ny() * m.nu() == 1 => Ok(m.entry(0, 0).clone()),
            Self::Matrix(m) => Err(crate::error::FdidError::InvalidArgument {
                name: "measurement",
                value: format!("a {} x {} frequency response matrix", m.ny(), m.nu()),
                reason: "one entry is needed: pick it (FrfMatrix::entry) or fit every \
                         entry with common poles (fdid::mimo)"
                    .into(),
            }),
        }
    }

    /// True for a time record.
    pub fn is_time(&self) -> bool {
        matches!(self, Self::Time(_))
    }
}
