//! Touchstone network-parameter files: `.s1p` and `.s2p` (version 1 or 2.0) and `.ts`
//! (version 2.0), of 1 or 2 ports.

use crate::data::FrequencyData;
use crate::error::{FdidError, Result};
use crate::scalar::{Complex, Real};
use std::io::Read;
use std::path::Path;

/// Kind of network parameters in a Touchstone file (the second field of the option line).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Parameter {
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

impl Parameter {
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

/// How the `[Network Data]` of a version 2 file writes each matrix (`[Matrix Format]`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum MatrixFormat {
    /// Every entry.
    Full,
    /// The lower triangle with the diagonal, row by row, of a symmetric matrix.
    Lower,
    /// The upper triangle with the diagonal, row by row, of a symmetric matrix.
    Upper,
}

/// The content of a 1-port or 2-port Touchstone file, values as in the network (Y, Z, H
/// and G parameters de-normalised by the reference resistance, see [`parse_touchstone`]).
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Touchstone {
    /// Number of ports, 1 or 2.
    pub ports: usize,
    /// The kind of parameters.
    pub parameter: Parameter,
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
                reason: format!(
                    "a {n}-port file has the ports 1{}",
                    if n == 1 { "" } else { " and 2" }
                ),
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

/// Reads a Touchstone file: `.s1p` and `.s2p` (version 1 or 2.0; the number of ports
/// comes from the extension) or `.ts` (version 2.0, whose `[Number of Ports]` gives it);
/// extensions are case-insensitive. See [`parse_touchstone`] for the format. Errors name
/// the file.
///
/// # Errors
/// [`FdidError::Io`] when the file cannot be opened or read; [`FdidError::Parse`] for an
/// extension other than `.s1p`/`.s2p`/`.ts`; otherwise as [`parse_touchstone`].
pub fn read_touchstone(path: &Path) -> Result<Touchstone> {
    let name = path.display().to_string();
    let ports = touchstone_ports(path);
    if ports.is_none() && !is_touchstone(path) {
        return Err(parse_error(
            &name,
            0,
            "a Touchstone file needs the extension .s1p (1 port), .s2p (2 ports) or .ts \
             (version 2.0)"
                .into(),
        ));
    }
    let file = std::fs::File::open(path).map_err(|e| FdidError::Io(format!("{name}: {e}")))?;
    match ports {
        Some(ports) => parse_touchstone(file, ports, &name),
        None => parse_touchstone_v2(file, &name),
    }
}

/// The number of ports a `.s1p`/`.s2p` extension names (case-insensitive), `None` for any
/// other file name (also `.ts`, whose number of ports is in the file).
pub fn touchstone_ports(path: &Path) -> Option<usize> {
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    match ext.as_str() {
        "s1p" => Some(1),
        "s2p" => Some(2),
        _ => None,
    }
}

/// Whether the extension is that of a Touchstone file [`read_touchstone`] reads: `.s1p`,
/// `.s2p` or `.ts` (case-insensitive).
pub fn is_touchstone(path: &Path) -> bool {
    touchstone_ports(path).is_some()
        || path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("ts"))
}

/// Parses a Touchstone file of `ports` ports (1 or 2, from the extension) from `reader`:
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
///   that of version 1). Fields are separated by spaces, tabs or commas; a row may be
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
///   `[Number of Ports] n` (1 or 2, and the number the extension names);
/// - before `[Network Data]`, in any order, each at most once:
///   `[Two-Port Data Order] 12_21|21_12` (required for 2 ports, not allowed for 1:
///   `12_21` writes `f X11 X12 X21 X22`, `21_12` the version 1 order `f X11 X21 X12 X22`),
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
/// `[Mixed-Mode Order]`, other versions and more than 2 ports are not supported.
///
/// # Errors
/// [`FdidError::Parse`] with the 1-based line number (0 for the file as a whole) for: an
/// unknown or repeated option field, an option line after the data, a missing or bad
/// reference resistance, a field that is not a number or is not finite, a negative or
/// non-increasing frequency, a row cut short, no data rows, invalid UTF-8, a port count
/// other than 1 or 2; in version 1 any keyword; in version 2 an unknown, repeated,
/// misplaced or unsupported keyword, a bad keyword argument, a missing required keyword
/// (`[Number of Ports]`, `[Two-Port Data Order]`, `[Number of Frequencies]`,
/// `[Network Data]`, `[Noise Data]`, `[End]`), a number of ports other than the
/// extension's, a number of frequencies other than declared, content after `[End]`;
/// [`FdidError::Io`] when reading fails.
pub fn parse_touchstone<R: Read>(reader: R, ports: usize, name: &str) -> Result<Touchstone> {
    if !(1..=2).contains(&ports) {
        return Err(parse_error(
            name,
            0,
            format!("{ports}-port files are not supported (only .s1p and .s2p)"),
        ));
    }
    let text = read_text(reader, name)?;
    parse_text(&text, Some(ports), name)
}

/// Parses a version 2.0 Touchstone file (a `.ts` file), whose `[Number of Ports]` gives
/// the number of ports; `name` is used in error messages. The format is that of
/// [`parse_touchstone`].
///
/// # Errors
/// As [`parse_touchstone`]; a file that does not start with `[Version] 2.0` is an error.
pub fn parse_touchstone_v2<R: Read>(reader: R, name: &str) -> Result<Touchstone> {
    let text = read_text(reader, name)?;
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

/// The text of `reader` (UTF-8, without a byte-order mark).
fn read_text<R: Read>(mut reader: R, name: &str) -> Result<String> {
    let mut bytes = Vec::new();
    reader
        .read_to_end(&mut bytes)
        .map_err(|e| FdidError::Io(format!("{name}: {e}")))?;
    let text = String::from_utf8(bytes).map_err(|e| {
        let line = 1 + e.as_bytes()[..e.utf8_error().valid_up_to()]
            .iter()
            .filter(|b| **b == b'\n')
            .count();
        parse_error(name, line, "invalid UTF-8".into())
    })?;
    Ok(match text.strip_prefix('\u{feff}') {
        Some(rest) => rest.to_string(),
        None => text,
    })
}

/// The content of a line without its comment, trimmed.
fn content(raw: &str) -> &str {
    raw.split('!').next().unwrap_or("").trim()
}

/// A keyword line `[Name] argument`: the name, lower case with single spaces for the
/// spaces and dashes between words, as written, and the argument.
fn keyword(content: &str) -> Option<(String, &str, &str)> {
    let rest = content.strip_prefix('[')?;
    let (inner, argument) = rest.split_once(']').unwrap_or((rest, ""));
    let normal = inner
        .split(|c: char| c.is_whitespace() || c == '-')
        .filter(|w| !w.is_empty())
        .collect::<Vec<_>>()
        .join(" ")
        .to_ascii_lowercase();
    Some((normal, inner, argument.trim()))
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
             version 1 file needs the extension .s1p or .s2p)"
                .into(),
        )),
    }
}

/// Version 1 (see [`parse_touchstone`]).
fn parse_v1(text: &str, ports: usize, name: &str) -> Result<Touchstone> {
    let perr = |line: usize, message: String| parse_error(name, line, message);
    let mut options: Option<Options> = None;
    let width = 1 + 2 * ports * ports;
    let mut row: Vec<f64> = Vec::with_capacity(width);
    let mut row_line = 0;
    let mut freq_hz = Vec::new();
    let mut values = Vec::new();
    let mut noise_section = false;
    let mut options_given = false;
    let mut data_line: Option<usize> = None;
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let content = content(raw);
        if content.is_empty() || noise_section {
            continue;
        }
        if let Some((_, written, _)) = keyword(content) {
            return Err(perr(
                line,
                format!(
                    "`[{written}]` is a Touchstone 2 keyword, but the file does not start \
                     with `[Version] 2.0`: a version 2 file needs that line first, a \
                     version 1 file has no keywords"
                ),
            ));
        }
        if let Some(rest) = content.strip_prefix('#') {
            if let Some(first) = data_line {
                if options_given {
                    // later option lines are ignored
                    continue;
                }
                return Err(perr(
                    line,
                    format!(
                        "the option line comes after the data of line {first}: it must \
                         precede them (the data above would have been read with the \
                         defaults GHz, S, MA)"
                    ),
                ));
            }
            if options.is_none() {
                options = Some(Options::parse(rest).map_err(|m| perr(line, m))?);
                options_given = true;
            }
            continue;
        }
        data_line.get_or_insert(line);
        let opts = *options.get_or_insert_with(Options::default);
        for field in fields(content) {
            let v = number(field).map_err(|m| perr(line, m))?;
            if row.is_empty() {
                row_line = line;
                let f = v * opts.unit;
                if ports == 2 && freq_hz.last().is_some_and(|last| f <= *last) {
                    // the noise parameters of a 2-port follow the network data
                    noise_section = true;
                    break;
                }
                check_frequency(f, freq_hz.last().copied(), field).map_err(|m| perr(line, m))?;
            }
            row.push(v);
            if row.len() == width {
                freq_hz.push(row[0] * opts.unit);
                values.push(opts.matrix(&row[1..], ports));
                row.clear();
            }
        }
    }
    if !row.is_empty() {
        return Err(perr(row_line, short_row(&row, width, ports)));
    }
    if freq_hz.is_empty() {
        return Err(perr(0, "no data rows".into()));
    }
    let opts = options.unwrap_or_default();
    Ok(Touchstone {
        ports,
        parameter: opts.parameter,
        format: opts.format,
        reference: opts.reference,
        version: TouchstoneVersion::V1,
        references: vec![opts.reference; ports],
        freq_hz,
        values,
    })
}

/// The fields of a data line: separated by spaces, tabs or commas.
fn fields(content: &str) -> impl Iterator<Item = &str> {
    content
        .split(|c: char| c.is_whitespace() || c == ',')
        .filter(|f| !f.is_empty())
}

/// A finite number.
fn number(field: &str) -> std::result::Result<f64, String> {
    let v: f64 = field
        .parse()
        .map_err(|_| format!("`{}` is not a number", shorten(field)))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("value `{field}` is not finite"))
    }
}

/// The message for a row of `width` numbers cut short after `row`.
fn short_row(row: &[f64], width: usize, ports: usize) -> String {
    format!(
        "the row of frequency {} ends after {} of its {width} numbers (f and {} pairs for \
         {ports} port{})",
        row[0],
        row.len(),
        (width - 1) / 2,
        if ports == 1 { "" } else { "s" }
    )
}

/// Where a version 2 file is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Section {
    /// After `[Version]`: the option line comes next.
    Version,
    /// After the option line: `[Number of Ports]` comes next.
    Options,
    /// The keywords before `[Network Data]`.
    Header,
    /// Inside `[Begin Information]` … `[End Information]`.
    Information,
    /// `[Reference]` values, more to come.
    Reference,
    /// The rows of `[Network Data]`.
    Network,
    /// The rows of `[Noise Data]` (skipped).
    Noise,
    /// After `[End]`.
    End,
}

/// The keywords of a version 2 file, with the line each was given on.
#[derive(Debug, Default)]
struct Header {
    ports: Option<(usize, usize)>,
    order_12_21: Option<(bool, usize)>,
    frequencies: Option<(usize, usize)>,
    noise_frequencies: Option<(usize, usize)>,
    reference: Option<usize>,
    matrix: Option<(MatrixFormat, usize)>,
    information: Option<usize>,
    network: Option<usize>,
    noise: Option<usize>,
}

/// A count argument: a positive whole number.
fn count(keyword: &str, argument: &str) -> std::result::Result<usize, String> {
    match argument.parse::<usize>() {
        Ok(n) if n > 0 => Ok(n),
        _ => Err(format!(
            "`[{keyword}]` needs a positive whole number, got `{}`",
            shorten(argument)
        )),
    }
}

/// Version 2.0 (see [`parse_touchstone`]); `[Version]` is on line `version_line` with the
/// argument `version`.
fn parse_v2(
    text: &str,
    expected_ports: Option<usize>,
    name: &str,
    version_line: usize,
    version: &str,
) -> Result<Touchstone> {
    let perr = |line: usize, message: String| parse_error(name, line, message);
    if version.parse::<f64>() != Ok(2.0) {
        return Err(perr(
            version_line,
            format!(
                "`[Version] {}`: only Touchstone version 2.0 (or version 1, without \
                 `[Version]`) is read",
                shorten(version)
            ),
        ));
    }
    let mut section = Section::Version;
    let mut h = Header::default();
    let mut opts = Options::default();
    let mut references: Vec<f64> = Vec::new();
    let mut reference_line = 0;
    let mut width = 0;
    let mut row: Vec<f64> = Vec::new();
    let mut row_line = 0;
    let mut freq_hz: Vec<f64> = Vec::new();
    let mut values: Vec<Vec<Complex<f64>>> = Vec::new();
    let mut last_line = version_line;
    for (i, raw) in text.lines().enumerate().skip(version_line) {
        let line = i + 1;
        let content = content(raw);
        if content.is_empty() {
            continue;
        }
        last_line = line;
        if section == Section::End {
            return Err(perr(
                line,
                format!(
                    "`{}` after `[End]`: only comments may follow it",
                    shorten(content)
                ),
            ));
        }
        if section == Section::Information
            && keyword(content).is_none_or(|(kw, _, _)| kw != "end information")
        {
            // the information block is skipped
            continue;
        }
        let ports = h.ports.map(|p| p.0);
        if let Some(rest) = content.strip_prefix('#') {
            if section != Section::Version {
                return Err(perr(
                    line,
                    "a second option line: a Touchstone 2.0 file has one, right after \
                     `[Version]`"
                        .into(),
                ));
            }
            opts = Options::parse(rest).map_err(|m| perr(line, m))?;
            section = Section::Options;
            continue;
        }
        let Some((kw, written, arg)) = keyword(content) else {
            // a data line
            match section {
                Section::Reference => {
                    let n = ports.unwrap_or(1);
                    for field in fields(content) {
                        references.push(
                            reference_value(field, n, references.len())
                                .map_err(|m| perr(line, m))?,
                        );
                    }
                    if references.len() >= n {
                        section = Section::Header;
                    }
                    continue;
                }
                Section::Network => {
                    let ports = ports.unwrap_or(1);
                    for field in fields(content) {
                        let v = number(field).map_err(|m| perr(line, m))?;
                        if row.is_empty() {
                            row_line = line;
                            let declared = h.frequencies.map_or(0, |f| f.0);
                            if freq_hz.len() == declared {
                                return Err(perr(
                                    line,
                                    format!(
                                        "more than the {declared} frequencies of \
                                         `[Number of Frequencies]` (line {}): a row starts \
                                         with `{}` after the last one",
                                        h.frequencies.map_or(0, |f| f.1),
                                        shorten(field)
                                    ),
                                ));
                            }
                            check_frequency(v * opts.unit, freq_hz.last().copied(), field)
                                .map_err(|m| perr(line, m))?;
                        }
                        row.push(v);
                        if row.len() == width {
                            freq_hz.push(row[0] * opts.unit);
                            values.push(opts.matrix_v2(
                                &row[1..],
                                ports,
                                h.matrix.map_or(MatrixFormat::Full, |m| m.0),
                                h.order_12_21.is_some_and(|o| o.0),
                            ));
                            row.clear();
                        }
                    }
                    continue;
                }
                Section::Noise => continue,
                Section::Version => {
                    return Err(perr(
                        line,
                        format!(
                            "`{}`: the option line (`# ...`) must follow `[Version] 2.0`",
                            shorten(content)
                        ),
                    ));
                }
                _ => {
                    return Err(perr(
                        line,
                        format!(
                            "`{}` before `[Network Data]`: data rows come after that \
                             keyword",
                            shorten(content)
                        ),
                    ));
                }
            }
        };
        let kw = kw.as_str();
        // the end of a section that keywords close
        match section {
            Section::Reference => {
                return Err(perr(
                    line,
                    format!(
                        "`[{written}]`: `[Reference]` (line {reference_line}) gives {} of the \
                         {} reference impedances",
                        references.len(),
                        ports.unwrap_or(1)
                    ),
                ));
            }
            Section::Network => {
                if !row.is_empty() {
                    return Err(perr(row_line, short_row(&row, width, ports.unwrap_or(1))));
                }
                check_frequency_count(&h, freq_hz.len(), line).map_err(|m| perr(line, m))?;
            }
            Section::Version => {
                return Err(perr(
                    line,
                    format!("`[{written}]`: the option line (`# ...`) must follow `[Version] 2.0`"),
                ));
            }
            _ => {}
        }
        if section == Section::Options && kw != "number of ports" {
            return Err(perr(
                line,
                format!("`[{written}]`: `[Number of Ports]` must follow the option line"),
            ));
        }
        let once = |seen: Option<usize>| match seen {
            Some(first) => Err(perr(
                line,
                format!("`[{written}]` repeats the keyword of line {first}"),
            )),
            None => Ok(()),
        };
        let header_only = |section: Section| {
            if section == Section::Header {
                Ok(())
            } else {
                Err(perr(
                    line,
                    format!("`[{written}]` must come before `[Network Data]`"),
                ))
            }
        };
        if matches!(
            kw,
            "network data" | "noise data" | "end" | "begin information" | "end information"
        ) && !arg.is_empty()
        {
            return Err(perr(
                line,
                format!(
                    "`[{written}]` takes no argument, got `{}` (data rows go on the lines \
                     after it)",
                    shorten(arg)
                ),
            ));
        }
        match kw {
            "version" => {
                return Err(perr(
                    line,
                    format!("`[{written}]` repeats the keyword of line {version_line}"),
                ));
            }
            "number of ports" => {
                once(h.ports.map(|p| p.1))?;
                let n = count(written, arg).map_err(|m| perr(line, m))?;
                if n > 2 {
                    return Err(perr(
                        line,
                        format!(
                            "`[{written}] {n}`: files of more than 2 ports are not supported \
                             (1 or 2)"
                        ),
                    ));
                }
                if let Some(e) = expected_ports.filter(|e| *e != n) {
                    return Err(perr(
                        line,
                        format!(
                            "`[{written}] {n}`, but the extension .s{e}p names {e} port{}",
                            if e == 1 { "" } else { "s" }
                        ),
                    ));
                }
                if n == 1 && matches!(opts.parameter, Parameter::H | Parameter::G) {
                    return Err(perr(
                        line,
                        format!(
                            "`[{written}] 1`: {} parameters are defined for 2 ports only",
                            opts.parameter.letter()
                        ),
                    ));
                }
                h.ports = Some((n, line));
                section = Section::Header;
            }
            "two port data order" => {
                header_only(section)?;
                once(h.order_12_21.map(|o| o.1))?;
                if ports != Some(2) {
                    return Err(perr(
                        line,
                        format!("`[{written}]` applies to 2-port files only"),
                    ));
                }
                let order = match arg {
                    "12_21" => true,
                    "21_12" => false,
                    _ => {
                        return Err(perr(
                            line,
                            format!("`[{written}]` needs 12_21 or 21_12, got `{}`", shorten(arg)),
                        ));
                    }
                };
                h.order_12_21 = Some((order, line));
            }
            "number of frequencies" => {
                header_only(section)?;
                once(h.frequencies.map(|f| f.1))?;
                h.frequencies = Some((count(written, arg).map_err(|m| perr(line, m))?, line));
            }
            "number of noise frequencies" => {
                header_only(section)?;
                once(h.noise_frequencies.map(|f| f.1))?;
                if ports != Some(2) {
                    return Err(perr(
                        line,
                        format!("`[{written}]`: noise parameters are defined for 2 ports only"),
                    ));
                }
                h.noise_frequencies = Some((count(written, arg).map_err(|m| perr(line, m))?, line));
            }
            "reference" => {
                header_only(section)?;
                once(h.reference)?;
                h.reference = Some(line);
                reference_line = line;
                let n = ports.unwrap_or(1);
                for field in fields(arg) {
                    references.push(
                        reference_value(field, n, references.len()).map_err(|m| perr(line, m))?,
                    );
                }
                if references.len() < n {
                    section = Section::Reference;
                }
            }
            "matrix format" => {
                header_only(section)?;
                once(h.matrix.map(|m| m.1))?;
                let format = match arg.to_ascii_lowercase().as_str() {
                    "full" => MatrixFormat::Full,
                    "lower" => MatrixFormat::Lower,
                    "upper" => MatrixFormat::Upper,
                    _ => {
                        return Err(perr(
                            line,
                            format!(
                                "`[{written}]` needs Full, Lower or Upper, got `{}`",
                                shorten(arg)
                            ),
                        ));
                    }
                };
                h.matrix = Some((format, line));
            }
            "mixed mode order" => {
                return Err(perr(
                    line,
                    format!(
                        "`[{written}]`: mixed-mode network data are not supported (only \
                         single-ended 1- and 2-port data)"
                    ),
                ));
            }
            "begin information" => {
                header_only(section)?;
                once(h.information)?;
                h.information = Some(line);
                section = Section::Information;
            }
            "end information" => {
                if section != Section::Information {
                    return Err(perr(
                        line,
                        format!("`[{written}]` without `[Begin Information]`"),
                    ));
                }
                section = Section::Header;
            }
            "network data" => {
                header_only(section)?;
                let Some(n) = ports else {
                    return Err(perr(
                        line,
                        "`[Network Data]` without `[Number of Ports]` before it".into(),
                    ));
                };
                if h.frequencies.is_none() {
                    return Err(perr(
                        line,
                        "`[Network Data]` without `[Number of Frequencies]` before it".into(),
                    ));
                }
                if n == 2 && h.order_12_21.is_none() {
                    return Err(perr(
                        line,
                        "`[Network Data]` of 2 ports without `[Two-Port Data Order]` \
                         (12_21 or 21_12) before it"
                            .into(),
                    ));
                }
                h.network = Some(line);
                let pairs = match h.matrix.map_or(MatrixFormat::Full, |m| m.0) {
                    MatrixFormat::Full => n * n,
                    _ => n * (n + 1) / 2,
                };
                width = 1 + 2 * pairs;
                section = Section::Network;
            }
            "noise data" => {
                if section != Section::Network {
                    return Err(perr(
                        line,
                        format!("`[{written}]` must follow the rows of `[Network Data]`"),
                    ));
                }
                if h.noise_frequencies.is_none() {
                    return Err(perr(
                        line,
                        format!(
                            "`[{written}]` without `[Number of Noise Frequencies]` before \
                             `[Network Data]`"
                        ),
                    ));
                }
                h.noise = Some(line);
                section = Section::Noise;
            }
            "end" => {
                if section != Section::Network && section != Section::Noise {
                    return Err(perr(line, format!("`[{written}]` before `[Network Data]`")));
                }
                if let Some((_, at)) = h.noise_frequencies
                    && h.noise.is_none()
                {
                    return Err(perr(
                        line,
                        format!(
                            "`[{written}]` without the `[Noise Data]` that \
                             `[Number of Noise Frequencies]` (line {at}) announces"
                        ),
                    ));
                }
                section = Section::End;
            }
            _ => {
                return Err(perr(
                    line,
                    format!("unknown Touchstone 2.0 keyword `[{}]`", shorten(written)),
                ));
            }
        }
    }
    let at = last_line;
    match section {
        Section::End => {}
        Section::Network | Section::Noise => {
            if section == Section::Network {
                if !row.is_empty() {
                    return Err(perr(
                        row_line,
                        short_row(&row, width, h.ports.map_or(1, |p| p.0)),
                    ));
                }
                check_frequency_count(&h, freq_hz.len(), at).map_err(|m| perr(at, m))?;
            }
            return Err(perr(
                at,
                "the file ends without `[End]` after its data".into(),
            ));
        }
        Section::Version => {
            return Err(perr(
                version_line,
                "no option line (`# ...`) after `[Version] 2.0`".into(),
            ));
        }
        Section::Options => {
            return Err(perr(
                at,
                "no `[Number of Ports]` after the option line".into(),
            ));
        }
        Section::Reference => {
            return Err(perr(
                reference_line,
                format!(
                    "`[Reference]` gives {} of the {} reference impedances",
                    references.len(),
                    h.ports.map_or(1, |p| p.0)
                ),
            ));
        }
        Section::Header | Section::Information => {
            return Err(perr(
                at,
                "no `[Network Data]`: the file holds no data".into(),
            ));
        }
    }
    let Some((ports, _)) = h.ports else {
        return Err(perr(0, "no `[Number of Ports]`".into()));
    };
    if references.is_empty() {
        references = vec![opts.reference; ports];
    }
    Ok(Touchstone {
        ports,
        parameter: opts.parameter,
        format: opts.format,
        reference: opts.reference,
        version: TouchstoneVersion::V2,
        references,
        freq_hz,
        values,
    })
}

/// The rows read against `[Number of Frequencies]`, at the end of the network data.
fn check_frequency_count(h: &Header, rows: usize, line: usize) -> std::result::Result<(), String> {
    let (declared, at) = h.frequencies.unwrap_or((0, 0));
    if rows == declared {
        return Ok(());
    }
    Err(format!(
        "`[Network Data]` (line {}) holds {rows} frequenc{} up to line {line}, but \
         `[Number of Frequencies]` (line {at}) says {declared}",
        h.network.unwrap_or(0),
        if rows == 1 { "y" } else { "ies" }
    ))
}

/// One reference impedance of `[Reference]`: positive and finite, at most `ports` of them
/// (`index` given before).
fn reference_value(field: &str, ports: usize, index: usize) -> std::result::Result<f64, String> {
    if index >= ports {
        return Err(format!(
            "`[Reference]`: `{}` is one value more than the {ports} port{} need",
            shorten(field),
            if ports == 1 { "" } else { "s" }
        ));
    }
    let r = number(field).map_err(|m| format!("`[Reference]`: {m}"))?;
    if r > 0.0 {
        Ok(r)
    } else {
        Err(format!(
            "`[Reference]`: reference impedance {field} of port {} must be positive",
            index + 1
        ))
    }
}

/// A frequency must be non-negative and above the previous one.
fn check_frequency(f: f64, previous: Option<f64>, field: &str) -> std::result::Result<(), String> {
    if f < 0.0 {
        return Err(format!("negative frequency `{field}`"));
    }
    if !f.is_finite() {
        return Err(format!("frequency `{field}` is out of range in Hz"));
    }
    if let Some(p) = previous
        && f <= p
    {
        return Err(format!(
            "frequency {f} Hz is not above the previous one, {p} Hz: frequencies must \
             increase strictly"
        ));
    }
    Ok(())
}

/// The settings of the option line.
#[derive(Debug, Clone, Copy)]
struct Options {
    /// Hz per frequency unit.
    unit: f64,
    parameter: Parameter,
    format: NumberFormat,
    reference: f64,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            unit: 1e9,
            parameter: Parameter::S,
            format: NumberFormat::MagnitudeAngle,
            reference: 50.0,
        }
    }
}

impl Options {
    /// Parses the fields after `#`.
    fn parse(rest: &str) -> std::result::Result<Self, String> {
        let mut o = Self::default();
        let mut seen = [false; 4];
        let mut once = |slot: usize, field: &str| {
            if std::mem::replace(&mut seen[slot], true) {
                Err(format!(
                    "option line: `{field}` repeats a setting given before"
                ))
            } else {
                Ok(())
            }
        };
        let mut fields = rest.split_whitespace();
        while let Some(field) = fields.next() {
            match field.to_ascii_uppercase().as_str() {
                u @ ("HZ" | "KHZ" | "MHZ" | "GHZ") => {
                    once(0, field)?;
                    o.unit = match u {
                        "HZ" => 1.0,
                        "KHZ" => 1e3,
                        "MHZ" => 1e6,
                        _ => 1e9,
                    };
                }
                p @ ("S" | "Y" | "Z" | "H" | "G") => {
                    once(1, field)?;
                    o.parameter = match p {
                        "S" => Parameter::S,
                        "Y" => Parameter::Y,
                        "Z" => Parameter::Z,
                        "H" => Parameter::H,
                        _ => Parameter::G,
                    };
                }
                f @ ("RI" | "MA" | "DB") => {
                    once(2, field)?;
                    o.format = match f {
                        "RI" => NumberFormat::RealImaginary,
                        "MA" => NumberFormat::MagnitudeAngle,
                        _ => NumberFormat::DecibelAngle,
                    };
                }
                "R" => {
                    once(3, field)?;
                    let value = fields.next().ok_or_else(|| {
                        "option line: `R` needs the reference resistance after it".to_string()
                    })?;
                    let r: f64 = value.parse().map_err(|_| {
                        format!("option line: reference resistance `{value}` is not a number")
                    })?;
                    if !(r.is_finite() && r > 0.0) {
                        return Err(format!(
                            "option line: reference resistance {value} must be positive and \
                             finite"
                        ));
                    }
                    o.reference = r;
                }
                _ => {
                    return Err(format!(
                        "option line: unknown field `{field}` (expected a unit Hz/kHz/MHz/GHz, \
                         a parameter S/Y/Z/H/G, a format RI/MA/DB or R <ohms>)"
                    ));
                }
            }
        }
        Ok(o)
    }

    /// The `ports × ports` matrix (row-major) of the pairs of one row, in physical units.
    fn matrix(&self, pairs: &[f64], ports: usize) -> Vec<Complex<f64>> {
        let mut m = vec![Complex::new(0.0, 0.0); ports * ports];
        for (k, p) in pairs.chunks_exact(2).enumerate() {
            // version 1 writes the 2-port matrix column by column: X11 X21 X12 X22
            let (i, j) = if ports == 2 { (k % 2, k / 2) } else { (0, 0) };
            m[i * ports + j] = self.value(p) * self.scale(i, j);
        }
        m
    }

    /// The `ports × ports` matrix (row-major) of the pairs of one version 2 row: not
    /// normalised; `12_21` for the natural order of a full 2-port matrix, else that of
    /// version 1; a triangle mirrored for `Lower` and `Upper`.
    fn matrix_v2(
        &self,
        pairs: &[f64],
        ports: usize,
        format: MatrixFormat,
        order_12_21: bool,
    ) -> Vec<Complex<f64>> {
        let cells: Vec<(usize, usize)> = match (ports, format) {
            (1, _) => vec![(0, 0)],
            (_, MatrixFormat::Full) if order_12_21 => vec![(0, 0), (0, 1), (1, 0), (1, 1)],
            (_, MatrixFormat::Full) => vec![(0, 0), (1, 0), (0, 1), (1, 1)],
            (_, MatrixFormat::Lower) => vec![(0, 0), (1, 0), (1, 1)],
            (_, MatrixFormat::Upper) => vec![(0, 0), (0, 1), (1, 1)],
        };
        let mut m = vec![Complex::new(0.0, 0.0); ports * ports];
        for (p, (i, j)) in pairs.chunks_exact(2).zip(cells) {
            let x = self.value(p);
            m[i * ports + j] = x;
            if format != MatrixFormat::Full {
                m[j * ports + i] = x;
            }
        }
        m
    }

    /// The complex value of one pair.
    fn value(&self, p: &[f64]) -> Complex<f64> {
        match self.format {
            NumberFormat::RealImaginary => Complex::new(p[0], p[1]),
            NumberFormat::MagnitudeAngle => Complex::from_polar(p[0], p[1].to_radians()),
            NumberFormat::DecibelAngle => {
                Complex::from_polar(10f64.powf(p[0] / 20.0), p[1].to_radians())
            }
        }
    }

    /// The factor from the normalised value of entry `(i, j)` (0-based) to the physical one.
    fn scale(&self, i: usize, j: usize) -> f64 {
        let r = self.reference;
        match (self.parameter, i == j, i) {
            (Parameter::S, _, _) => 1.0,
            (Parameter::Z, _, _) => r,
            (Parameter::Y, _, _) => 1.0 / r,
            (Parameter::H, true, 0) | (Parameter::G, true, 1) => r,
            (Parameter::H, true, _) | (Parameter::G, true, _) => 1.0 / r,
            (Parameter::H | Parameter::G, false, _) => 1.0,
        }
    }
}

/// The first 40 characters of `s`.
fn shorten(s: &str) -> String {
    if s.chars().count() > 40 {
        format!("{}…", s.chars().take(40).collect::<String>())
    } else {
        s.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str, ports: usize) -> Result<Touchstone> {
        parse_touchstone(text.as_bytes(), ports, "t")
    }

    fn line_of(e: FdidError) -> usize {
        match e {
            FdidError::Parse { line, .. } => line,
            e => panic!("not a parse error: {e}"),
        }
    }

    #[test]
    fn formats_convert_to_the_same_complex_value() {
        // 0.5 e^{i 30°}: RI, MA and DB rows of the same value
        let x = Complex::from_polar(0.5, 30f64.to_radians());
        let db = 20.0 * 0.5f64.log10();
        let ri = format!("# Hz S RI\n1 {} {}\n", x.re, x.im);
        let ma = "# hz s ma\n1 0.5 30\n".to_string();
        let dbs = format!("# Hz S DB R 50\n1 {db} 30\n");
        for text in [ri, ma, dbs] {
            let t = parse(&text, 1).unwrap();
            assert_eq!(t.freq_hz, vec![1.0]);
            assert!(
                (t.values[0][0] - x).norm() < 1e-15,
                "{text}: {}",
                t.values[0][0]
            );
        }
    }

    #[test]
    fn two_port_column_order_and_units() {
        let text = "! comment\n# MHz S RI R 75\n 1.5 11 0 21 0 12 0 22 0 ! S11 S21 S12 S22\n\
                    2.0 1 1 2 2\n 3 3 4 4\n";
        let t = parse(text, 2).unwrap();
        assert_eq!(t.freq_hz, vec![1.5e6, 2.0e6]);
        assert_eq!(t.reference, 75.0);
        let m = &t.values[0];
        // row-major X11 X12 X21 X22
        assert_eq!(
            m.iter().map(|c| c.re).collect::<Vec<_>>(),
            vec![11.0, 12.0, 21.0, 22.0]
        );
        // a row continued over two lines
        assert_eq!(t.values[1][2], Complex::new(2.0, 2.0));
        let s21 = t.frequency_data::<f64>((2, 1)).unwrap();
        assert_eq!(s21.y()[0], Complex::new(21.0, 0.0));
        assert!((s21.omega()[1] - std::f64::consts::TAU * 2e6).abs() < 1e-6);
        assert!(t.frequency_data::<f64>((3, 1)).is_err());
    }

    #[test]
    fn defaults_are_ghz_s_ma_50_ohm() {
        let t = parse("#\n1 1 90\n", 1).unwrap();
        assert_eq!(t.freq_hz, vec![1e9]);
        assert_eq!(
            (t.parameter, t.format, t.reference),
            (Parameter::S, NumberFormat::MagnitudeAngle, 50.0)
        );
        assert!((t.values[0][0] - Complex::new(0.0, 1.0)).norm() < 1e-15);
    }

    #[test]
    fn impedance_is_denormalised() {
        let t = parse("# Hz Z RI R 50\n1 2 -1\n", 1).unwrap();
        assert_eq!(t.values[0][0], Complex::new(100.0, -50.0));
        let t = parse("# Hz Y RI R 50\n1 2 -1\n", 1).unwrap();
        assert_eq!(t.values[0][0], Complex::new(0.04, -0.02));
    }

    #[test]
    fn noise_parameters_of_a_two_port_are_skipped() {
        let text = "# GHz S MA\n1 1 0 2 0 3 0 4 0\n2 1 0 2 0 3 0 4 0\n1 0.5 0.1 10 0.3\n";
        let t = parse(text, 2).unwrap();
        assert_eq!(t.freq_hz.len(), 2);
    }

    #[test]
    fn malformed_files_name_the_line() {
        let cases: [(&str, usize, usize); 9] = [
            ("# Hz S RI\n1 0 0\n2 x 0\n", 1, 3),
            ("# Hz S RI\n2 0 0\n1 0 0\n", 1, 3),
            ("# Hz S RI\n-1 0 0\n", 1, 2),
            ("! c\n# Hz Q RI\n1 0 0\n", 1, 2),
            ("# Hz S RI R\n1 0 0\n", 1, 1),
            ("# Hz S RI R -5\n1 0 0\n", 1, 1),
            ("# Hz Hz S\n1 0 0\n", 1, 1),
            ("[Version] 2.0\n# Hz S RI\n", 2, 2),
            ("# Hz S RI\n1 0 0 0 0 0 0 0 0\n2 1 1 1\n", 2, 3),
        ];
        // an option line after the data
        assert_eq!(line_of(parse("1 0 0\n# Hz S RI\n", 1).unwrap_err()), 2);
        // a second option line is ignored
        let t = parse("# Hz S RI\n1 0 0\n# GHz S MA\n2 0 0\n", 1).unwrap();
        assert_eq!(t.freq_hz, vec![1.0, 2.0]);
        for (text, ports, line) in cases {
            let e = parse(text, ports).unwrap_err();
            let msg = e.to_string();
            assert_eq!(line_of(e), line, "{text:?}: {msg}");
        }
        assert_eq!(
            line_of(parse("! only a comment\n# Hz S RI\n", 1).unwrap_err()),
            0
        );
        assert!(
            parse("# Hz S RI\n1 nan 0\n", 1)
                .unwrap_err()
                .to_string()
                .contains("not finite")
        );
        assert!(parse("# Hz S RI\n1 0 0\n", 3).is_err());
        let v2 = parse("[Version] 2.0\n", 2).unwrap_err().to_string();
        assert!(v2.contains("option line") && v2.contains("line 1"), "{v2}");
        // a keyword in a version 1 file
        let v1 = parse("# Hz S RI\n[Number of Ports] 1\n1 0 0\n", 1).unwrap_err();
        assert!(v1.to_string().contains("[Number of Ports]"), "{v1}");
        assert_eq!(line_of(v1), 2);
    }
}
