//! Touchstone network-parameter files: `.sNp` (version 1 or 2.0) and `.ts` (version 2.0),
//! of 1 to [`crate::io::MAX_PORTS`] ports.

mod matrix;
mod options;
mod rows;
mod text;
mod v1;
mod v2;

#[cfg(test)]
mod tests;

use self::text::{content, keyword};
use self::v1::parse_v1;
use self::v2::parse_v2;
use crate::data::{FrequencyData, FrfMatrix};
use crate::error::{FdidError, Result};
use crate::io::lines::read_text_with_comments;
use crate::scalar::{Complex, Real};
use std::io::Read;
use std::path::Path;

/// Kind of network parameters in a Touchstone file (the second field of the option line).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum NetworkParameter {
    /// Scattering parameters (dimensionless).
    S,
    /// Admittance parameters (S).
    Y,
    /// Impedance parameters (Ω).
    Z,
    /// Hybrid-h parameters (2-port).
    H,
    /// Hybrid-g parameters (2-port).
    G,
}

impl NetworkParameter {
    /// The letter of the option line.
    pub fn letter(self) -> char {
        match self {
            Self::S => 'S',
            Self::Y => 'Y',
            Self::Z => 'Z',
            Self::H => 'H',
            Self::G => 'G',
        }
    }
}

/// How each complex value is written (the third field of the option line).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum NumberFormat {
    /// Real and imaginary part.
    RealImaginary,
    /// Magnitude and angle in degrees: `x = m e^{i φ π/180}`.
    MagnitudeAngle,
    /// Magnitude in dB and angle in degrees: `x = 10^{d/20} e^{i φ π/180}`.
    DecibelAngle,
}

/// The version of a Touchstone file: 1 (no keywords) or 2.0 (`[Version] 2.0`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum TouchstoneVersion {
    /// Version 1: Y, Z, H and G values normalised by R.
    #[default]
    V1,
    /// Version 2.0: keywords in brackets; values not normalised.
    V2,
}

/// The content of a 1-port or 2-port Touchstone file, values as in the network (Y, Z, H
/// and G parameters de-normalised by the reference resistance, see [`parse_touchstone`]).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Touchstone {
    /// Number of ports.
    pub ports: usize,
    /// The kind of parameters.
    pub parameter: NetworkParameter,
    /// How the file wrote them.
    pub format: NumberFormat,
    /// Reference resistance R (Ω) of the option line (50 by default).
    pub reference: f64,
    /// The version of the file format.
    #[cfg_attr(feature = "serde", serde(default))]
    pub version: TouchstoneVersion,
    /// Reference impedance (Ω) of each port: `[Reference]` of a version 2 file, else R
    /// for every port. Empty in values serialised before the field existed.
    #[cfg_attr(feature = "serde", serde(default))]
    pub references: Vec<f64>,
    /// Frequencies in Hz, strictly increasing.
    pub freq_hz: Vec<f64>,
    /// Per frequency the `ports × ports` matrix, row-major: `values[k][(i−1)·ports + (j−1)]`
    /// is `X_ij` (`X = S, Y, Z, H, G`) at `freq_hz[k]`.
    pub values: Vec<Vec<Complex<f64>>>,
}

impl Touchstone {
    /// The response `X_ij(f)` of output port `i` to input port `j` (`(2, 1)` is `S21`) as
    /// frequency-response data `Y_k = X_ij(f_k)`, `U_k = 1` at `ω_k = 2π f_k` rad/s, without a
    /// sample time.
    ///
    /// # Errors
    /// [`FdidError::InvalidArgument`] for a port outside `1..=ports`; as
    /// [`FrequencyData::from_frf`] (e.g. a line at a frequency out of range of `T`).
    pub fn frequency_data<T: Real>(&self, port: (usize, usize)) -> Result<FrequencyData<T>> {
        let (i, j) = port;
        let n = self.ports;
        if !(1..=n).contains(&i) || !(1..=n).contains(&j) {
            return Err(FdidError::InvalidArgument {
                name: "port",
                value: format!("{i}{j}"),
                reason: if n == 1 {
                    "a 1-port file has the port 1".into()
                } else {
                    format!("a {n}-port file has the ports 1 to {n}")
                },
            });
        }
        let k = (i - 1) * n + (j - 1);
        let omega = self
            .freq_hz
            .iter()
            .map(|f| T::lit(std::f64::consts::TAU * f))
            .collect();
        let g = self
            .values
            .iter()
            .map(|m| Complex::new(T::lit(m[k].re), T::lit(m[k].im)))
            .collect();
        FrequencyData::from_frf(omega, g, None)
    }
}

impl Touchstone {
    /// Every entry X_ij as a frequency response matrix (output port i, input port j),
    /// stored column by column as [`FrfMatrix`] does, without a sample time.
    ///
    /// # Errors
    /// As [`FrfMatrix::from_entries`].
    pub fn frf_matrix<T: Real>(&self) -> Result<FrfMatrix<T>> {
        let n = self.ports;
        let omega: Vec<T> = self
            .freq_hz
            .iter()
            .map(|f| T::lit(std::f64::consts::TAU * f))
            .collect();
        let entries = (0..n * n)
            .map(|e| {
                let (i, j) = (e % n, e / n);
                self.values
                    .iter()
                    .map(|m| {
                        let v = m[i * n + j];
                        Complex::new(T::lit(v.re), T::lit(v.im))
                    })
                    .collect()
            })
            .collect();
        FrfMatrix::from_entries(omega, n, n, entries, None)
    }
}

/// Reads a Touchstone file: `.sNp` (version 1 or 2.0; the number of ports
/// comes from the extension) or `.ts` (version 2.0, whose `[Number of Ports]` gives it);
/// extensions are case-insensitive. See [`parse_touchstone`] for the format. Errors name
/// the file.
///
/// # Errors
/// [`FdidError::Io`] when the file cannot be opened or read; [`FdidError::Parse`] for an
/// extension other than `.sNp`/`.ts`; otherwise as [`parse_touchstone`].
pub fn read_touchstone(path: &Path) -> Result<Touchstone> {
    let name = path.display().to_string();
    let ports = touchstone_ports(path);
    if ports.is_none() && !is_touchstone(path) {
        return Err(parse_error(
            &name,
            0,
            "a Touchstone file needs the extension .sNp (N ports: .s1p, .s2p, .s4p, …) or \
             .ts (version 2.0)"
                .into(),
        ));
    }
    let file = std::fs::File::open(path).map_err(|e| FdidError::Io(format!("{name}: {e}")))?;
    match ports {
        Some(ports) => parse_touchstone(file, ports, &name),
        None => parse_touchstone_v2(file, &name),
    }
}

/// The number of ports a `.sNp` extension names (case-insensitive, N from 1 to
/// [`crate::io::MAX_PORTS`]), `None` for any other file name (also `.ts`, whose number of
/// ports is in the file).
pub fn touchstone_ports(path: &Path) -> Option<usize> {
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    let digits = ext.strip_prefix('s')?.strip_suffix('p')?;
    if digits.is_empty() || digits.len() > 2 || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    let n: usize = digits.parse().ok()?;
    (1..=crate::io::MAX_PORTS).contains(&n).then_some(n)
}

/// Whether the extension is that of a Touchstone file [`read_touchstone`] reads: `.sNp`
/// or `.ts` (case-insensitive).
pub fn is_touchstone(path: &Path) -> bool {
    touchstone_ports(path).is_some()
        || path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("ts"))
}

/// Parses a Touchstone file of `ports` ports (from the extension) from `reader`:
/// version 1, or version 2.0 when its first line (after comments) is `[Version] 2.0`.
/// `name` is used in error messages.
///
/// # Version 1
///
/// - `!` starts a comment that runs to the end of the line; blank lines are ignored.
/// - The option line `# <unit> <parameter> <format> R <ref>` comes before the data; its
///   fields are case-insensitive, in any order, each optional: unit `Hz`, `kHz`, `MHz` or
///   `GHz` (default GHz), parameter `S`, `Y`, `Z`, `H` or `G` (default S), format `RI`
///   (real, imaginary), `MA` (magnitude, angle in degrees) or `DB` (20·log₁₀ magnitude,
///   angle in degrees) (default MA), `R` followed by the reference resistance in Ω (default
///   50). Later option lines are ignored, as the specification says; an option line
///   after data rows that were read with the defaults is an error.
/// - Data: per frequency the frequency, then the pairs of the `ports × ports` matrix. A
///   1-port row is `f X11`; a 2-port row is `f X11 X21 X12 X22` (this column order is
///   that of version 1); a row of 3 or more ports writes the matrix row by row,
///   `f X11 X12 … X1n X21 … Xnn`. Fields are separated by spaces, tabs or commas; a row may be
///   continued on the next lines.
/// - Frequencies must be non-negative and strictly increasing. In a 2-port file a row
///   whose frequency is not above the previous one starts the noise-parameter section,
///   which is not read.
/// - Version 1 writes Y and Z parameters (and H, G) normalised by R: the values returned
///   are the physical ones, `Z = R·z`, `Y = y/R`, `H11 = R·h11`, `H22 = h22/R`,
///   `G11 = g11/R`, `G22 = R·g22` (the other entries are dimensionless).
///
/// # Version 2.0
///
/// Comments, the option line, the number format and the case-insensitivity are those of
/// version 1; keywords in brackets structure the file, each on its own line:
///
/// - `[Version] 2.0` first, then the option line (exactly one), then
///   `[Number of Ports] n` (the number the extension names, if any);
/// - before `[Network Data]`, in any order, each at most once:
///   `[Two-Port Data Order] 12_21|21_12` (required for 2 ports, not allowed for others:
///   `12_21` writes `f X11 X12 X21 X22`, `21_12` the version 1 order `f X11 X21 X12 X22`;
///   other numbers of ports write the matrix row by row),
///   `[Number of Frequencies] N` (required; the data must hold exactly N frequencies),
///   `[Reference] r1 … rn` (the reference impedance of each port in Ω, positive; the
///   values may continue on the next lines; default R of the option line),
///   `[Matrix Format] Full|Lower|Upper` (default Full; Lower and Upper write one
///   triangle with the diagonal, row by row, of a symmetric matrix: `f X11 X21 X22` or
///   `f X11 X12 X22`), `[Number of Noise Frequencies] M` (2 ports),
///   `[Begin Information]` … `[End Information]` (skipped);
/// - `[Network Data]` and its rows (a row may span lines; frequencies non-negative and
///   strictly increasing); then `[Noise Data]` and its rows when
///   `[Number of Noise Frequencies]` was given (skipped: the noise parameters are not
///   read); then `[End]`, after which only comments may follow.
/// - Version 2 values are not normalised: Y, Z, H and G are returned as written, and
///   `[Reference]` (in [`Touchstone::references`]) is the reference of S parameters only.
///
/// `[Mixed-Mode Order]`, other versions and more than [`crate::io::MAX_PORTS`] ports are
/// not supported.
///
/// # Errors
/// [`FdidError::Parse`] with the 1-based line number (0 for the file as a whole) for: an
/// unknown or repeated option field, an option line after the data, a missing or bad
/// reference resistance, a field that is not a number or is not finite, a negative or
/// non-increasing frequency, a row cut short, no data rows, invalid UTF-8, a port count
/// outside 1 to [`crate::io::MAX_PORTS`]; H or G parameters of other than 2 ports; in version 1 any keyword; in version 2 an unknown, repeated,
/// misplaced or unsupported keyword, a bad keyword argument, a missing required keyword
/// (`[Number of Ports]`, `[Two-Port Data Order]`, `[Number of Frequencies]`,
/// `[Network Data]`, `[Noise Data]`, `[End]`), a number of ports other than the
/// extension's, a number of frequencies other than declared, content after `[End]`;
/// [`FdidError::Io`] when reading fails.
pub fn parse_touchstone<R: Read>(reader: R, ports: usize, name: &str) -> Result<Touchstone> {
    if !(1..=crate::io::MAX_PORTS).contains(&ports) {
        return Err(parse_error(
            name,
            0,
            format!(
                "{ports}-port files are not supported (1 to {} ports)",
                crate::io::MAX_PORTS
            ),
        ));
    }
    let text = read_text_with_comments(reader, name, b'!')?;
    parse_text(&text, Some(ports), name)
}

/// Parses a version 2.0 Touchstone file (a `.ts` file), whose `[Number of Ports]` gives
/// the number of ports; `name` is used in error messages. The format is that of
/// [`parse_touchstone`].
///
/// # Errors
/// As [`parse_touchstone`]; a file that does not start with `[Version] 2.0` is an error.
pub fn parse_touchstone_v2<R: Read>(reader: R, name: &str) -> Result<Touchstone> {
    let text = read_text_with_comments(reader, name, b'!')?;
    parse_text(&text, None, name)
}

/// A [`FdidError::Parse`] of the file `name` at `line`.
fn parse_error(name: &str, line: usize, message: String) -> FdidError {
    FdidError::Parse {
        path: name.to_string(),
        line,
        message,
    }
}

/// Version 1 or 2 by the first line that is not blank or a comment.
fn parse_text(text: &str, ports: Option<usize>, name: &str) -> Result<Touchstone> {
    let first = text
        .lines()
        .enumerate()
        .find(|(_, l)| !content(l).is_empty());
    if let Some((i, l)) = first
        && let Some((kw, _, arg)) = keyword(content(l))
        && kw == "version"
    {
        return parse_v2(text, ports, name, i + 1, arg);
    }
    match ports {
        Some(ports) => parse_v1(text, ports, name),
        None => Err(parse_error(
            name,
            first.map_or(0, |(i, _)| i + 1),
            "a .ts file must be a Touchstone 2.0 file starting with `[Version] 2.0` (a \
             version 1 file needs the extension .sNp, e.g. .s2p)"
                .into(),
        )),
    }
}
