//! The CSV file contract of the `fdid` command.

use super::Measurement;
use crate::data::{FrequencyData, NoiseVariances, TimeData};
use crate::error::{FdidError, Result};
use crate::scalar::{Complex, Real};
use std::io::Read;
use std::path::Path;

/// Relative tolerance on the time grid: every `t_i` must lie within `1e-3·Ts` of
/// `t_0 + i·Ts`.
const TIME_GRID_TOLERANCE: f64 = 1e-3;

/// Reads a data file; see [`parse_csv`] for the format. Errors name the file.
///
/// # Errors
/// [`FdidError::Io`] when the file cannot be opened or read, otherwise as [`parse_csv`].
pub fn read_csv<T: Real>(path: &Path) -> Result<Measurement<T>> {
    let file =
        std::fs::File::open(path).map_err(|e| FdidError::Io(format!("{}: {e}", path.display())))?;
    parse_csv(file, &path.display().to_string())
}

/// Parses a data file from `reader`; `name` is used in error messages.
///
/// # Format
///
/// UTF-8 text (a leading byte-order mark is ignored), one row per line (`\n` or `\r\n`),
/// fields separated by commas; spaces around a field and one pair of double quotes
/// wrapping it are removed (quoted fields cannot contain commas or line breaks). Blank
/// lines and lines whose first non-blank character is `#` are ignored anywhere. The first
/// other line is the header: it names the columns (case-insensitive, any order). Three
/// layouts exist:
///
/// | layout | required columns | optional columns |
/// | --- | --- | --- |
/// | frequency response | `f`, `re`, `im` | `var` |
/// | spectra | `f`, `u_re`, `u_im`, `y_re`, `y_im` | `var_u`, `var_y` |
/// | time record | `t`, `u`, `y` | — |
///
/// - `f` is in Hz and is converted to `ω = 2πf` rad/s. Frequencies must be non-negative
///   and strictly increasing. Frequency data carry no sample time.
/// - FRF rows give `G = re + i·im`, stored as `Y = G`, `U = 1`. `var` is the FRF noise
///   variance `E|N_G|²` (stored as `var_y`, with `var_u = 0`, `cov_yu = 0`).
/// - Spectra rows give `U = u_re + i·u_im` and `Y = y_re + i·y_im`; `var_u = E|N_U|²`,
///   `var_y = E|N_Y|²` (a missing one of the two is zero; `cov_yu = 0`).
/// - Time rows give samples `u(t)`, `y(t)` at times `t` (s) that must increase strictly
///   and be uniform: `Ts = (t_{N−1} − t_0)/(N − 1)` and every `t_i` within `10⁻³·Ts` of
///   `t_0 + i·Ts`. At least two rows are needed.
///
/// # Errors
/// - [`FdidError::Parse`] (with the 1-based line number, or line 0 for the file as a
///   whole) for: no header, an unrecognized header, a missing, unknown, empty or duplicate
///   column name, a row with the wrong number of fields, a field that is not a number,
///   NaN or infinite, a value out of range of `T`, a negative variance, a decreasing or
///   non-uniform time column, invalid UTF-8;
/// - [`FdidError::TooShort`] when there are no data rows (or one row of a time record);
/// - [`FdidError::NegativeFrequency`], [`FdidError::Unsorted`],
///   [`FdidError::DuplicateFrequency`] for bad frequencies (the index is the 0-based data
///   row, the values are in Hz);
/// - [`FdidError::Io`] when reading fails.
pub fn parse_csv<T: Real, R: Read>(reader: R, name: &str) -> Result<Measurement<T>> {
    let perr = |line: usize, message: String| FdidError::Parse {
        path: name.to_string(),
        line,
        message,
    };
    let mut lines = Lines::new(reader);

    // Header.
    let (header_line, names) = match lines.next_record().map_err(|e| e.into_error(name))? {
        None => return Err(perr(0, "no header line (empty file)".into())),
        Some((line, fields)) => (
            line,
            fields
                .iter()
                .map(|f| f.to_lowercase())
                .collect::<Vec<String>>(),
        ),
    };
    let layout = Layout::from_header(&names).map_err(|m| perr(header_line, m))?;

    // Data rows: one f64 per column, plus the line number of each row.
    let ncols = names.len();
    let mut columns: Vec<Vec<f64>> = vec![Vec::new(); ncols];
    let mut lines_of_rows: Vec<usize> = Vec::new();
    while let Some((line, fields)) = lines.next_record().map_err(|e| e.into_error(name))? {
        if fields.len() != ncols {
            return Err(perr(
                line,
                format!(
                    "expected {ncols} fields ({}), found {}: `{}`",
                    names.join(","),
                    fields.len(),
                    shorten(&fields.join(","))
                ),
            ));
        }
        for (j, text) in fields.iter().enumerate() {
            let col = &names[j];
            let v: f64 = text.parse().map_err(|_| {
                perr(
                    line,
                    format!("column `{col}`: `{}` is not a number", shorten(text)),
                )
            })?;
            if !v.is_finite() {
                return Err(perr(
                    line,
                    format!("column `{col}`: value `{text}` is not finite"),
                ));
            }
            if !num_traits::Float::is_finite(T::lit(v)) {
                return Err(perr(
                    line,
                    format!(
                        "column `{col}`: value `{text}` is out of range for {}",
                        std::any::type_name::<T>()
                    ),
                ));
            }
            columns[j].push(v);
        }
        lines_of_rows.push(line);
    }
    let lines = lines_of_rows;

    let col = |c: &str| layout.index(c).map(|j| columns[j].as_slice());
    let to_t = |v: &[f64]| v.iter().map(|x| T::lit(*x)).collect::<Vec<T>>();
    match layout.kind {
        Kind::Time => {
            let (t, u, y) = (
                col("t").unwrap_or_default(),
                col("u").unwrap_or_default(),
                col("y").unwrap_or_default(),
            );
            if t.len() < 2 {
                return Err(FdidError::TooShort {
                    what: "data rows of a time record",
                    needed: 2,
                    got: t.len(),
                });
            }
            let ts = check_time_grid(t, &lines).map_err(|(line, m)| perr(line, m))?;
            let ts_t = T::lit(ts);
            if !(num_traits::Float::is_finite(ts_t) && ts_t > T::zero()) {
                return Err(perr(
                    0,
                    format!(
                        "sample time Ts = {ts} s is not representable in {}",
                        std::any::type_name::<T>()
                    ),
                ));
            }
            Ok(Measurement::Time(TimeData::new(to_t(u), to_t(y), ts_t)?))
        }
        Kind::Frf | Kind::Spectra => {
            let f = col("f").unwrap_or_default();
            if f.is_empty() {
                return Err(FdidError::TooShort {
                    what: "data rows",
                    needed: 1,
                    got: 0,
                });
            }
            check_frequencies(f)?;
            let mut omega = Vec::with_capacity(f.len());
            for (i, fi) in f.iter().enumerate() {
                let w = T::lit(std::f64::consts::TAU * fi);
                if !num_traits::Float::is_finite(w) {
                    return Err(perr(
                        lines[i],
                        format!(
                            "column `f`: 2π·{fi} Hz is out of range for {}",
                            std::any::type_name::<T>()
                        ),
                    ));
                }
                omega.push(w);
            }
            let cplx = |re: &[f64], im: &[f64]| -> Vec<Complex<T>> {
                re.iter()
                    .zip(im)
                    .map(|(r, i)| Complex::new(T::lit(*r), T::lit(*i)))
                    .collect()
            };
            for var in ["var", "var_u", "var_y"] {
                if let Some(v) = col(var)
                    && let Some(i) = v.iter().position(|x| *x < 0.0)
                {
                    return Err(perr(
                        lines[i],
                        format!("column `{var}`: negative variance {}", v[i]),
                    ));
                }
            }
            let data = if layout.kind == Kind::Frf {
                let g = cplx(col("re").unwrap_or_default(), col("im").unwrap_or_default());
                let d = FrequencyData::from_frf(omega, g, None)?;
                match col("var") {
                    Some(v) => d.with_noise(NoiseVariances::output_only(to_t(v)))?,
                    None => d,
                }
            } else {
                let u = cplx(
                    col("u_re").unwrap_or_default(),
                    col("u_im").unwrap_or_default(),
                );
                let y = cplx(
                    col("y_re").unwrap_or_default(),
                    col("y_im").unwrap_or_default(),
                );
                let n = omega.len();
                let d = FrequencyData::new(omega, y, u, None)?;
                let (vu, vy) = (col("var_u"), col("var_y"));
                if vu.is_none() && vy.is_none() {
                    d
                } else {
                    let zeros = vec![T::zero(); n];
                    d.with_noise(NoiseVariances {
                        var_y: vy.map(to_t).unwrap_or_else(|| zeros.clone()),
                        var_u: vu.map(to_t).unwrap_or(zeros),
                        cov_yu: vec![Complex::new(T::zero(), T::zero()); n],
                    })?
                }
            };
            Ok(Measurement::Frequency(data))
        }
    }
}

/// The three file layouts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Frf,
    Spectra,
    Time,
}

impl Kind {
    fn label(self) -> &'static str {
        match self {
            Kind::Frf => "frequency-response",
            Kind::Spectra => "spectra",
            Kind::Time => "time-record",
        }
    }

    fn required(self) -> &'static [&'static str] {
        match self {
            Kind::Frf => &["f", "re", "im"],
            Kind::Spectra => &["f", "u_re", "u_im", "y_re", "y_im"],
            Kind::Time => &["t", "u", "y"],
        }
    }

    fn optional(self) -> &'static [&'static str] {
        match self {
            Kind::Frf => &["var"],
            Kind::Spectra => &["var_u", "var_y"],
            Kind::Time => &[],
        }
    }

    fn allowed(self) -> String {
        let mut all: Vec<&str> = self.required().to_vec();
        all.extend(self.optional().iter().copied());
        all.join(", ")
    }
}

/// The layout of a file: its kind and the column names in file order.
struct Layout {
    kind: Kind,
    names: Vec<String>,
}

impl Layout {
    fn from_header(names: &[String]) -> std::result::Result<Self, String> {
        let has = |c: &str| names.iter().any(|n| n == c);
        let any = |cs: &[&str]| cs.iter().any(|c| has(c));
        let kind = if any(&["re", "im"]) {
            Kind::Frf
        } else if any(&["u_re", "u_im", "y_re", "y_im"]) {
            Kind::Spectra
        } else if any(&["t", "u", "y"]) {
            Kind::Time
        } else if has("var") {
            Kind::Frf
        } else if any(&["var_u", "var_y"]) {
            Kind::Spectra
        } else if has("f") {
            return Err(format!(
                "header `{}`: missing columns: frequency data need `re`, `im` (FRF) or \
                 `u_re`, `u_im`, `y_re`, `y_im` (spectra)",
                names.join(",")
            ));
        } else {
            return Err(format!(
                "unrecognized header `{}`: expected columns f,re,im (FRF), \
                 f,u_re,u_im,y_re,y_im (spectra) or t,u,y (time record)",
                names.join(",")
            ));
        };
        for (j, n) in names.iter().enumerate() {
            if n.is_empty() {
                return Err(format!("empty column name in header (column {})", j + 1));
            }
            if !kind.required().contains(&n.as_str()) && !kind.optional().contains(&n.as_str()) {
                return Err(format!(
                    "unknown column `{n}` in {} data (allowed: {})",
                    kind.label(),
                    kind.allowed()
                ));
            }
            if names[..j].contains(n) {
                return Err(format!("duplicate column `{n}`"));
            }
        }
        if let Some(m) = kind.required().iter().find(|c| !has(c)) {
            return Err(format!(
                "missing column `{m}` ({} data need {})",
                kind.label(),
                kind.required().join(", ")
            ));
        }
        Ok(Self {
            kind,
            names: names.to_vec(),
        })
    }

    fn index(&self, column: &str) -> Option<usize> {
        self.names.iter().position(|n| n == column)
    }
}

/// A line-by-line reader of comma-separated fields that skips blank and comment lines
/// and counts lines exactly (1-based).
struct Lines<R: Read> {
    reader: std::io::BufReader<R>,
    buf: Vec<u8>,
    line: usize,
}

/// A failure of [`Lines::next_record`], turned into an error once the file name is known.
enum LineError {
    Io(std::io::Error),
    Utf8(usize),
}

impl LineError {
    fn into_error(self, name: &str) -> FdidError {
        match self {
            LineError::Io(e) => FdidError::Io(format!("{name}: {e}")),
            LineError::Utf8(line) => FdidError::Parse {
                path: name.to_string(),
                line,
                message: "the line is not valid UTF-8 text".into(),
            },
        }
    }
}

impl<R: Read> Lines<R> {
    fn new(reader: R) -> Self {
        Self {
            reader: std::io::BufReader::new(reader),
            buf: Vec::new(),
            line: 0,
        }
    }

    /// The next line that is neither blank nor a comment, as (line number, trimmed
    /// fields); a field wrapped in double quotes loses them. `None` at the end.
    fn next_record(&mut self) -> std::result::Result<Option<(usize, Vec<String>)>, LineError> {
        use std::io::BufRead;
        loop {
            self.buf.clear();
            let n = self
                .reader
                .read_until(b'\n', &mut self.buf)
                .map_err(LineError::Io)?;
            if n == 0 {
                return Ok(None);
            }
            self.line += 1;
            let text = std::str::from_utf8(&self.buf).map_err(|_| LineError::Utf8(self.line))?;
            let text = if self.line == 1 {
                text.trim_start_matches('\u{feff}')
            } else {
                text
            }
            .trim();
            if text.is_empty() || text.starts_with('#') {
                continue;
            }
            let fields = text
                .split(',')
                .map(|f| {
                    let f = f.trim();
                    f.strip_prefix('"')
                        .and_then(|g| g.strip_suffix('"'))
                        .map_or(f, str::trim)
                        .to_string()
                })
                .collect();
            return Ok(Some((self.line, fields)));
        }
    }
}

/// Text for messages, cut to at most 200 characters.
fn shorten(s: &str) -> String {
    if s.chars().count() > 200 {
        let mut t: String = s.chars().take(200).collect();
        t.push('…');
        t
    } else {
        s.to_string()
    }
}

/// Frequencies (Hz) must be non-negative and strictly increasing.
fn check_frequencies(f: &[f64]) -> Result<()> {
    for (i, &fi) in f.iter().enumerate() {
        if fi < 0.0 {
            return Err(FdidError::NegativeFrequency {
                index: i,
                value: fi,
            });
        }
        if i > 0 {
            let prev = f[i - 1];
            if fi == prev {
                return Err(FdidError::DuplicateFrequency {
                    index: i,
                    value: fi,
                });
            }
            if fi < prev {
                return Err(FdidError::Unsorted {
                    index: i,
                    value: fi,
                    previous: prev,
                });
            }
        }
    }
    Ok(())
}

/// Checks that the times increase strictly and lie on a uniform grid; returns
/// `Ts = (t_{N−1} − t_0)/(N − 1)`. Errors carry the line number.
fn check_time_grid(t: &[f64], lines: &[usize]) -> std::result::Result<f64, (usize, String)> {
    let line = |i: usize| lines.get(i).copied().unwrap_or(0);
    for i in 1..t.len() {
        if t[i] <= t[i - 1] {
            return Err((
                line(i),
                format!(
                    "column `t`: time {} does not increase (previous row has t = {})",
                    t[i],
                    t[i - 1]
                ),
            ));
        }
    }
    let n = t.len();
    let t0 = t[0];
    let ts = (t[n - 1] - t0) / (n - 1) as f64;
    if !(ts.is_finite() && ts > 0.0) {
        return Err((
            0,
            format!("column `t`: sample time Ts = {ts} is not usable"),
        ));
    }
    for (i, &ti) in t.iter().enumerate() {
        let grid = t0 + i as f64 * ts;
        let dev = (ti - grid).abs();
        let tol = TIME_GRID_TOLERANCE * ts + 8.0 * f64::EPSILON * ti.abs().max(t0.abs());
        if dev > tol {
            return Err((
                line(i),
                format!(
                    "column `t`: non-uniform sampling: t = {ti} is {dev:.3e} s from the \
                     uniform grid t_0 + {i}·Ts = {grid} (Ts = {ts} s, tolerance {:.0e}·Ts)",
                    TIME_GRID_TOLERANCE
                ),
            ));
        }
    }
    Ok(ts)
}
