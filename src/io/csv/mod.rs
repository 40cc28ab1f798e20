//! The CSV file contract of the `fdid` command.

mod channels;
mod checks;
mod header;
mod records;
mod rows;

pub use self::channels::{
    ChannelSelection, Column, MultiChannelSelection, parse_channels, parse_multichannel,
    read_channels, read_multichannel,
};

pub use self::checks::uniform_sample_time;
use self::checks::{check_frequencies, check_time_grid};
use self::header::{Kind, Layout};
use self::records::Lines;
use super::Measurement;
use crate::data::{FrequencyData, FrfMatrix, NoiseVariances, TimeData};
use crate::error::{FdidError, Result};
use crate::io::lines::echo;
use crate::scalar::{Complex, Real};
use std::io::Read;
use std::path::Path;
use std::sync::Arc;

/// Reads a data file; see [`parse_csv`] for the format. Errors name the file.
///
/// # Errors
/// [`FdidError::Io`] when the file cannot be opened or read, otherwise as [`parse_csv`].
pub fn read_csv<T: Real>(path: &Path) -> Result<Measurement<T>> {
    let file =
        std::fs::File::open(path).map_err(|e| FdidError::Io(format!("{}: {e}", path.display())))?;
    let bytes = file.metadata().ok().map(|m| m.len());
    parse_sized(file, &path.display().to_string(), bytes)
}

/// True when the header of the CSV file at `path` names the columns of a frequency response
/// matrix (`re_IJ`, `im_IJ`); false for any other header or a file that cannot be read
/// (whose error [`read_csv`] reports).
pub fn is_frf_matrix_csv(path: &Path) -> bool {
    let Ok(file) = std::fs::File::open(path) else {
        return false;
    };
    let mut lines = Lines::new(file);
    match read_header(&mut lines, &path.display().to_string()) {
        Ok((_, names)) => Kind::of_header(&names).is_ok_and(|k| k == Kind::Matrix),
        Err(_) => false,
    }
}

/// Parses a data file from `reader`; `name` is used in error messages.
///
/// # Format
///
/// UTF-8 text (a leading byte-order mark is ignored), one row per line (`\n`, `\r\n` or a
/// lone `\r`; a line may hold at most [`MAX_LINE_BYTES`](crate::io::MAX_LINE_BYTES)),
/// fields separated by commas; spaces around a field and one pair of double quotes
/// wrapping it are removed (quoted fields cannot contain commas or line breaks). Blank
/// lines and lines whose first non-blank character is `#` are ignored anywhere. The first
/// other line is the header: it names the columns (case-insensitive, any order). Three
/// layouts exist:
///
/// | layout | required columns | optional columns |
/// | --- | --- | --- |
/// | frequency response | `f`, `re`, `im` | `var` |
/// | frequency response matrix | `f`, `re_IJ`, `im_IJ` per entry | `var_IJ` per entry |
/// | spectra | `f`, `u_re`, `u_im`, `y_re`, `y_im` | `var_u`, `var_y` |
/// | time record | `t`, `u`, `y` | — |
///
/// - `f` is in Hz and is converted to `ω = 2πf` rad/s. Frequencies must be non-negative
///   and strictly increasing. Frequency data carry no sample time.
/// - FRF rows give `G = re + i·im`, stored as `Y = G`, `U = 1`. `var` is the FRF noise
///   variance `E|N_G|²` (stored as `var_y`, with `var_u = 0`, `cov_yu = 0`).
/// - A frequency response matrix holds the ny × nu FRF G_IJ (output I, input J, 1-based)
///   in `re_IJ`, `im_IJ`, with one digit each (`re_21`), or `re_I_J` for indices beyond 9;
///   ny and nu are the largest indices, and every entry needs both columns. `var_IJ` is the
///   variance E|N|² of entry IJ, for every entry or none. The conventional order is column
///   by column, `f,re_11,im_11,re_21,im_21,…,re_12,…`, but any order is read. The result
///   is [`Measurement::Matrix`].
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
///   non-uniform time column (a skipped row is named where it occurs), invalid UTF-8, a
///   line longer than [`MAX_LINE_BYTES`](crate::io::MAX_LINE_BYTES), and for a negative,
///   repeated or decreasing frequency (in Hz);
/// - [`FdidError::TooShort`] when there are no data rows (or one row of a time record);
/// - [`FdidError::Io`] when reading fails.
pub fn parse_csv<T: Real, R: Read>(reader: R, name: &str) -> Result<Measurement<T>> {
    parse_sized(reader, name, None)
}

/// [`parse_csv`] of a file of `bytes` bytes when known (its columns are then sized once).
fn parse_sized<T: Real, R: Read>(
    reader: R,
    name: &str,
    bytes: Option<u64>,
) -> Result<Measurement<T>> {
    let mut lines = Lines::new(reader);
    let (header_line, names) = read_header(&mut lines, name)?;
    let layout = Layout::from_header(&names).map_err(|m| parse_error(name, header_line, m))?;
    let table = rows::read_rows::<T, R>(lines, layout, name, bytes)?;
    match table.layout.kind {
        Kind::Time => table.time_record(name),
        Kind::Frf | Kind::Spectra => table.frequency_data(name),
        Kind::Matrix => table.frf_matrix(name),
    }
}

/// A [`FdidError::Parse`] of the file `name` at `line`.
fn parse_error(name: &str, line: usize, message: String) -> FdidError {
    FdidError::Parse {
        path: name.to_string(),
        line,
        message,
    }
}

/// The header: the first record, its line and its column names in lower case.
fn read_header<R: Read>(lines: &mut Lines<R>, name: &str) -> Result<(usize, Vec<String>)> {
    match lines.next_record().map_err(|e| e.into_error(name))? {
        None => Err(parse_error(name, 0, "no header line (empty file)".into())),
        Some((line, fields)) => Ok((
            line,
            fields
                .iter()
                .map(|f| f.to_lowercase())
                .collect::<Vec<String>>(),
        )),
    }
}

/// The columns of a file as numbers, with the line of each row.
struct Table {
    layout: Layout,
    /// One `f64` per row in each column, in the order of the header.
    columns: Vec<Vec<f64>>,
    /// The line number of each row.
    lines: Vec<usize>,
}

/// The number of the field `text` of column `col`: finite, and finite in `T`.
fn field_value<T: Real>(col: &str, text: &str) -> std::result::Result<f64, String> {
    let v: f64 = text
        .parse()
        .map_err(|_| format!("column `{col}`: `{}` is not a number", echo(text)))?;
    if !v.is_finite() {
        return Err(format!(
            "column `{col}`: value `{}` is not finite",
            echo(text)
        ));
    }
    if !num_traits::Float::is_finite(T::lit(v)) {
        return Err(format!(
            "column `{col}`: value `{}` is out of range for {}",
            echo(text),
            std::any::type_name::<T>()
        ));
    }
    Ok(v)
}

/// The values of a column in `T`.
fn to_real<T: Real>(v: &[f64]) -> Vec<T> {
    v.iter().map(|x| T::lit(*x)).collect()
}

/// The complex values `re + i·im` of two columns in `T`.
fn complex<T: Real>(re: &[f64], im: &[f64]) -> Vec<Complex<T>> {
    re.iter()
        .zip(im)
        .map(|(r, i)| Complex::new(T::lit(*r), T::lit(*i)))
        .collect()
}

impl Table {
    /// The column named `c`, if the file has it.
    fn col(&self, c: &str) -> Option<&[f64]> {
        self.layout.index(c).map(|j| self.columns[j].as_slice())
    }

    /// The column named `c`, empty if the file does not have it.
    fn required(&self, c: &str) -> &[f64] {
        self.col(c).unwrap_or_default()
    }

    /// A time record: at least two rows on a uniform time grid.
    fn time_record<T: Real>(&self, name: &str) -> Result<Measurement<T>> {
        let (t, u, y) = (self.required("t"), self.required("u"), self.required("y"));
        if t.len() < 2 {
            return Err(FdidError::TooShort {
                what: "data rows of a time record",
                needed: 2,
                got: t.len(),
            });
        }
        let ts = check_time_grid(t, &self.lines).map_err(|(line, m)| parse_error(name, line, m))?;
        let ts_t = T::lit(ts);
        if !(num_traits::Float::is_finite(ts_t) && ts_t > T::zero()) {
            return Err(parse_error(
                name,
                0,
                format!(
                    "sample time Ts = {ts} s is not representable in {}",
                    std::any::type_name::<T>()
                ),
            ));
        }
        Ok(Measurement::Time(TimeData::new(
            to_real(u),
            to_real(y),
            ts_t,
        )?))
    }

    /// A frequency response matrix: entry (i, j) from `re_ij`, `im_ij` (and `var_ij`).
    fn frf_matrix<T: Real>(&self, name: &str) -> Result<Measurement<T>> {
        let omega: Vec<T> = self.frequencies::<T, _>(name)?;
        let (ny, nu, with_var) = self.layout.matrix.unwrap_or((1, 1, false));
        let column = |part: &str, i: usize, j: usize| -> &[f64] {
            let index = self
                .layout
                .names
                .iter()
                .position(|n| header::matrix_column(n) == Some((part, i + 1, j + 1)));
            index.map_or(&[][..], |k| self.columns[k].as_slice())
        };
        let mut entries = Vec::with_capacity(ny * nu);
        let mut variances = Vec::with_capacity(ny * nu);
        for j in 0..nu {
            for i in 0..ny {
                entries.push(complex(column("re", i, j), column("im", i, j)));
                if with_var {
                    let v = column("var", i, j);
                    if let Some(k) = v.iter().position(|x| *x < 0.0) {
                        return Err(parse_error(
                            name,
                            self.lines[k],
                            format!(
                                "column `var_{}{}`: negative variance {}",
                                i + 1,
                                j + 1,
                                v[k]
                            ),
                        ));
                    }
                    variances.push(to_real(v));
                }
            }
        }
        let mut m = FrfMatrix::from_entries(omega, ny, nu, entries, None)?;
        if with_var {
            m = m.with_variances(variances)?;
        }
        Ok(Measurement::Matrix(m))
    }

    /// Frequency data: an FRF or spectra, with their variances if given.
    fn frequency_data<T: Real>(&self, name: &str) -> Result<Measurement<T>> {
        let omega: Arc<[T]> = self.frequencies::<T, _>(name)?;
        self.check_variances(name)?;
        let data = if self.layout.kind == Kind::Frf {
            self.frf(omega)?
        } else {
            self.spectra(omega)?
        };
        Ok(Measurement::Frequency(data))
    }

    /// The angular frequencies of the `f` column: at least one row, non-negative and
    /// strictly increasing.
    fn frequencies<T: Real, C: FromIterator<T>>(&self, name: &str) -> Result<C> {
        let f = self.required("f");
        if f.is_empty() {
            return Err(FdidError::TooShort {
                what: "data rows",
                needed: 1,
                got: 0,
            });
        }
        check_frequencies(f, &self.lines).map_err(|(line, m)| parse_error(name, line, m))?;
        self.omega::<T, C>(f, name)
    }

    /// `ω = 2πf` in `T` of the frequencies `f` (Hz), collected straight into the buffer
    /// the data keep (`Arc<[T]>` for frequency data) once every one is known finite.
    fn omega<T: Real, C: FromIterator<T>>(&self, f: &[f64], name: &str) -> Result<C> {
        let w = |fi: &f64| T::lit(std::f64::consts::TAU * fi);
        if let Some(i) = f.iter().position(|fi| !num_traits::Float::is_finite(w(fi))) {
            return Err(parse_error(
                name,
                self.lines[i],
                format!(
                    "column `f`: 2π·{} Hz is out of range for {}",
                    f[i],
                    std::any::type_name::<T>()
                ),
            ));
        }
        Ok(f.iter().map(w).collect())
    }

    /// Every variance given is non-negative.
    fn check_variances(&self, name: &str) -> Result<()> {
        for var in ["var", "var_u", "var_y"] {
            if let Some(v) = self.col(var)
                && let Some(i) = v.iter().position(|x| *x < 0.0)
            {
                return Err(parse_error(
                    name,
                    self.lines[i],
                    format!("column `{var}`: negative variance {}", v[i]),
                ));
            }
        }
        Ok(())
    }

    /// FRF rows `G = re + i·im` as `Y = G`, `U = 1`, with `var` as the output variance.
    fn frf<T: Real>(&self, omega: Arc<[T]>) -> Result<FrequencyData<T>> {
        let g = complex(self.required("re"), self.required("im"));
        let d = FrequencyData::from_frf_shared(omega, g, None)?;
        match self.col("var") {
            Some(v) => d.with_noise(NoiseVariances::output_only(to_real(v))),
            None => Ok(d),
        }
    }

    /// Spectra rows `U`, `Y` with `var_u`, `var_y` (a missing one of the two is zero).
    fn spectra<T: Real>(&self, omega: Arc<[T]>) -> Result<FrequencyData<T>> {
        let u = complex(self.required("u_re"), self.required("u_im"));
        let y = complex(self.required("y_re"), self.required("y_im"));
        let n = omega.len();
        let d = FrequencyData::new_shared(omega, y, u, None)?;
        let (vu, vy) = (self.col("var_u"), self.col("var_y"));
        if vu.is_none() && vy.is_none() {
            return Ok(d);
        }
        let zeros = vec![T::zero(); n];
        d.with_noise(NoiseVariances {
            var_y: vy.map(to_real).unwrap_or_else(|| zeros.clone()),
            var_u: vu.map(to_real).unwrap_or(zeros),
            cov_yu: vec![Complex::new(T::zero(), T::zero()); n],
        })
    }
}
