//! Touchstone (version 1) network-parameter files: `.s1p` and `.s2p`.

use crate::data::FrequencyData;
use crate::error::{FdidError, Result};
use crate::{Complex, Real};
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

/// Reads a Touchstone file; the number of ports comes from the extension (`.s1p`, `.s2p`,
/// case-insensitive). See [`parse_touchstone`] for the format. Errors name the file.
///
/// # Errors
/// [`FdidError::Io`] when the file cannot be opened or read; [`FdidError::Parse`] for an
/// extension other than `.s1p`/`.s2p`; otherwise as [`parse_touchstone`].
pub fn read_touchstone(path: &Path) -> Result<Touchstone> {
    let name = path.display().to_string();
    let ports = touchstone_ports(path).ok_or_else(|| FdidError::Parse {
        path: name.clone(),
        line: 0,
        message: "a Touchstone file needs the extension .s1p (1 port) or .s2p (2 ports)".into(),
    })?;
    let file = std::fs::File::open(path).map_err(|e| FdidError::Io(format!("{name}: {e}")))?;
    parse_touchstone(file, ports, &name)
}

/// The number of ports a `.s1p`/`.s2p` extension names (case-insensitive), `None` for any
/// other file name.
pub fn touchstone_ports(path: &Path) -> Option<usize> {
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    match ext.as_str() {
        "s1p" => Some(1),
        "s2p" => Some(2),
        _ => None,
    }
}

/// Parses a version-1 Touchstone file of `ports` ports (1 or 2) from `reader`; `name` is
/// used in error messages.
///
/// # Format
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
/// Version 2 files (keywords in brackets such as `[Version]`) are rejected with an error
/// that names the keyword.
///
/// # Errors
/// [`FdidError::Parse`] with the 1-based line number (0 for the file as a whole) for: a
/// Touchstone 2 keyword, an unknown or repeated option field, an option line after the
/// data, a missing or bad reference resistance, a field that is not a number or is not
/// finite, a negative or non-increasing frequency, a row cut short at the end of the file,
/// no data rows, invalid UTF-8, a port count other than 1 or 2; [`FdidError::Io`] when
/// reading fails.
pub fn parse_touchstone<R: Read>(mut reader: R, ports: usize, name: &str) -> Result<Touchstone> {
    let perr = |line: usize, message: String| FdidError::Parse {
        path: name.to_string(),
        line,
        message,
    };
    if !(1..=2).contains(&ports) {
        return Err(perr(
            0,
            format!("{ports}-port files are not supported (only .s1p and .s2p)"),
        ));
    }
    let mut bytes = Vec::new();
    reader
        .read_to_end(&mut bytes)
        .map_err(|e| FdidError::Io(format!("{name}: {e}")))?;
    let text = String::from_utf8(bytes).map_err(|e| {
        let line = 1 + e.as_bytes()[..e.utf8_error().valid_up_to()]
            .iter()
            .filter(|b| **b == b'\n')
            .count();
        perr(line, "invalid UTF-8".into())
    })?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);

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
        let content = raw.split('!').next().unwrap_or("").trim();
        if content.is_empty() || noise_section {
            continue;
        }
        if content.starts_with('[') {
            let keyword = content.split(']').next().unwrap_or(content);
            return Err(perr(
                line,
                format!(
                    "`{keyword}]` is a Touchstone 2 keyword: only version 1 files are read \
                     (write the data as a version 1 .s{ports}p file)"
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
        for field in content
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|f| !f.is_empty())
        {
            let v: f64 = field
                .parse()
                .map_err(|_| perr(line, format!("`{}` is not a number", shorten(field))))?;
            if !v.is_finite() {
                return Err(perr(line, format!("value `{field}` is not finite")));
            }
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
        return Err(perr(
            row_line,
            format!(
                "the row of frequency {} ends after {} of its {width} numbers (f and {} \
                 pairs for {ports} port{})",
                row[0],
                row.len(),
                ports * ports,
                if ports == 1 { "" } else { "s" }
            ),
        ));
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
        freq_hz,
        values,
    })
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
            let x = match self.format {
                NumberFormat::RealImaginary => Complex::new(p[0], p[1]),
                NumberFormat::MagnitudeAngle => Complex::from_polar(p[0], p[1].to_radians()),
                NumberFormat::DecibelAngle => {
                    Complex::from_polar(10f64.powf(p[0] / 20.0), p[1].to_radians())
                }
            };
            m[i * ports + j] = x * self.scale(i, j);
        }
        m
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
            ("[Version] 2.0\n# Hz S RI\n", 2, 1),
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
        assert!(v2.contains("[Version]") && v2.contains("version 1"), "{v2}");
    }
}
