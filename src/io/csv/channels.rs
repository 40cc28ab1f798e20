//! Raw multi-channel tables: one input and one output column picked from a file with
//! several channels (a benchmark's CSV with a header, or a whitespace-separated DaISy
//! `.dat` file without one).

use super::checks::check_time_grid;
use super::parse_error;
use crate::data::{MimoSpectra, TimeData};
use crate::error::{FdidError, Result};
use crate::io::lines::{echo, read_text};
use crate::scalar::Real;
use std::io::Read;
use std::path::Path;

/// One column of a table: by its header name (matched exactly, else ignoring case) or by
/// its 1-based position.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Column {
    /// The column whose header name is this.
    Name(String),
    /// The column at this 1-based position.
    Index(usize),
}

impl Column {
    /// A column from the user's text: a whole number is a 1-based index, anything else a
    /// name (`"3"` is column 3, `"Force"` the column named `Force`).
    pub fn parse(text: &str) -> Self {
        match text.trim().parse::<usize>() {
            Ok(i) => Self::Index(i),
            Err(_) => Self::Name(text.trim().to_string()),
        }
    }
}

impl std::fmt::Display for Column {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Name(n) => write!(f, "`{}`", echo(n)),
            Self::Index(i) => write!(f, "column {i}"),
        }
    }
}

/// Which columns of a table make the time record, and its sample time.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelSelection {
    /// The input column `u`.
    pub input: Column,
    /// The output column `y`.
    pub output: Column,
    /// The sample time (s); required when the table has no `t` column, else it must agree
    /// with the `t` column.
    pub ts: Option<f64>,
}

/// Relative tolerance of a given sample time against that of a `t` column.
const TS_AGREEMENT: f64 = 1e-6;

/// Reads the table `path` and returns the time record of the columns `selection` picks;
/// see [`parse_channels`].
///
/// # Errors
/// [`FdidError::Io`] when the file cannot be opened or read, otherwise as
/// [`parse_channels`].
pub fn read_channels<T: Real>(path: &Path, selection: &ChannelSelection) -> Result<TimeData<T>> {
    let file =
        std::fs::File::open(path).map_err(|e| FdidError::Io(format!("{}: {e}", path.display())))?;
    parse_channels(file, &path.display().to_string(), selection)
}

/// Parses a table of several channels from `reader` (`name` is used in messages) and
/// returns the time record `u = input column`, `y = output column`.
///
/// # Format
///
/// UTF-8 text, one row per line; blank lines and lines starting with `#` are ignored. The
/// fields of a row are separated by commas when the first row holds a comma, else by
/// spaces or tabs. The first row is a header when one of its fields is not a number: it
/// names the columns (a pair of double quotes around a name is removed; a trailing empty
/// name, from a trailing comma, is dropped). A file without a header (a DaISy `.dat` file)
/// is read by 1-based column indices only. Every data row has as many fields as the header
/// (or the first row), or one more that is empty (a trailing comma).
///
/// Only the selected columns and a `t` column are read as numbers; the other columns may
/// hold anything, empty cells included (a constant column such as `Fs` written only in
/// the first row). A column named `t` (any case), when the header has one, gives the sample
/// time as in [`parse_csv`](super::parse_csv): uniform, `Ts = (t_{N−1} − t_0)/(N − 1)`;
/// then `selection.ts`, if given, must agree within `10⁻⁶` relative. Without a `t` column
/// `selection.ts` is the sample time.
///
/// # Errors
/// [`FdidError::Parse`] naming the line (line 0 for the file as a whole) for: an empty
/// file, an unknown column name (the message lists the available names), a column index
/// of 0 or beyond the number of columns, a name used on a file without a header, a row
/// with the wrong number of fields, an empty, non-numeric or non-finite cell of a selected
/// column, a missing sample time (no `t` column and no `ts`), a sample time that is not
/// positive and finite or that contradicts the `t` column, invalid UTF-8;
/// [`FdidError::TooShort`] for fewer than 2 rows; as [`TimeData::new`] otherwise.
pub fn parse_channels<T: Real, R: Read>(
    reader: R,
    name: &str,
    selection: &ChannelSelection,
) -> Result<TimeData<T>> {
    let (mut u, mut y, ts) = parse_columns::<T, R>(
        reader,
        name,
        std::slice::from_ref(&selection.input),
        std::slice::from_ref(&selection.output),
        selection.ts,
    )?;
    let (Some(u), Some(y)) = (u.pop(), y.pop()) else {
        unreachable!("one column of each was asked for")
    };
    TimeData::new(u, y, T::lit(ts))
}

/// Which columns of a table are the inputs and outputs of a multi-channel record, and its
/// sample time (as [`ChannelSelection`]).
#[derive(Debug, Clone, PartialEq)]
pub struct MultiChannelSelection {
    /// The input columns, in order.
    pub inputs: Vec<Column>,
    /// The output columns, in order.
    pub outputs: Vec<Column>,
    /// The sample time (s), as [`ChannelSelection::ts`].
    pub ts: Option<f64>,
    /// The periods P the record holds (`None`: one non-periodic record): the spectra are
    /// averaged over the periods kept ([`MimoSpectra::from_periods`]).
    pub periods: Option<usize>,
    /// The leading periods dropped before averaging (transients); needs `periods`.
    pub skip_periods: usize,
}

/// Reads the table `path` and returns the spectra (DFT) of the input and output columns
/// `selection` picks; see [`parse_multichannel`].
///
/// # Errors
/// [`FdidError::Io`] when the file cannot be opened or read, otherwise as
/// [`parse_multichannel`].
pub fn read_multichannel<T: Real>(
    path: &Path,
    selection: &MultiChannelSelection,
) -> Result<MimoSpectra<T>> {
    let file =
        std::fs::File::open(path).map_err(|e| FdidError::Io(format!("{}: {e}", path.display())))?;
    parse_multichannel(file, &path.display().to_string(), selection)
}

/// Parses a table of channels as [`parse_channels`] does, with several input and output
/// columns, and returns their DFT spectra: [`MimoSpectra::from_time`] (lines k = 0, …,
/// ⌊N/2⌋ of the whole record) or, with `periods` P and `skip_periods` K, the average over
/// the last P − K of the P periods ([`MimoSpectra::from_periods`], with the noise
/// covariances between periods).
///
/// # Errors
/// As [`parse_channels`] for each column; no input or no output column; `skip_periods`
/// without `periods` or leaving no period, P not dividing the record
/// ([`FdidError::InvalidArgument`]); [`MimoSpectra::from_time`]'s and
/// [`MimoSpectra::from_periods`]'s errors.
pub fn parse_multichannel<T: Real, R: Read>(
    reader: R,
    name: &str,
    selection: &MultiChannelSelection,
) -> Result<MimoSpectra<T>> {
    let (u, y, ts) = parse_columns::<T, R>(
        reader,
        name,
        &selection.inputs,
        &selection.outputs,
        selection.ts,
    )?;
    let Some(p) = selection.periods else {
        if selection.skip_periods > 0 {
            return Err(FdidError::InvalidArgument {
                name: "skip_periods",
                value: selection.skip_periods.to_string(),
                reason: "skipping periods needs the number of periods".into(),
            });
        }
        return MimoSpectra::from_time(u, y, T::lit(ts));
    };
    let n = u.first().map_or(0, Vec::len);
    let k = selection.skip_periods;
    if p == 0 || !n.is_multiple_of(p) || k >= p {
        return Err(FdidError::InvalidArgument {
            name: "periods",
            value: p.to_string(),
            reason: if k >= p && p > 0 {
                format!("skipping {k} of {p} periods leaves none")
            } else {
                format!("the record of {n} samples is not a whole number of {p} periods")
            },
        });
    }
    let drop = k * (n / p);
    let steady = |x: Vec<Vec<T>>| x.into_iter().map(|c| c[drop..].to_vec()).collect();
    MimoSpectra::from_periods(steady(u), steady(y), T::lit(ts), p - k)
}

/// The selected input and output columns of a table (in `T`) and its sample time.
type Columns<T> = (Vec<Vec<T>>, Vec<Vec<T>>, f64);

/// Reads the `inputs` and `outputs` columns of the table in `reader` and its sample time.
fn parse_columns<T: Real, R: Read>(
    reader: R,
    name: &str,
    inputs: &[Column],
    outputs: &[Column],
    ts: Option<f64>,
) -> Result<Columns<T>> {
    if inputs.is_empty() || outputs.is_empty() {
        return Err(parse_error(
            name,
            0,
            "select at least one input and one output column".into(),
        ));
    }
    let text = read_text(reader, name)?;
    let table = Table::parse(&text, name)?;
    let read = |columns: &[Column], flag: &str| -> Result<Vec<Vec<T>>> {
        columns
            .iter()
            .map(|c| {
                let j = table.index(c, flag, name)?;
                let x = table.numbers::<T>(j, name)?;
                Ok(x.iter().map(|v| T::lit(*v)).collect())
            })
            .collect()
    };
    let u = read(inputs, "--input")?;
    let y = read(outputs, "--output")?;
    if u[0].len() < 2 {
        return Err(FdidError::TooShort {
            what: "data rows of a time record",
            needed: 2,
            got: u[0].len(),
        });
    }
    let ts = table.sample_time(ts, name)?;
    Ok((u, y, ts))
}

/// The rows of a table split into fields, with the header names if any.
struct Table<'a> {
    /// The header names (quotes removed), `None` for a file without a header.
    names: Option<Vec<String>>,
    /// The line number of the header, 0 without one.
    header_line: usize,
    /// The number of columns.
    width: usize,
    /// Each data row: its line number and its fields.
    rows: Vec<(usize, Vec<&'a str>)>,
}

impl<'a> Table<'a> {
    /// Splits `text` into the header (if any) and the data rows.
    fn parse(text: &'a str, name: &str) -> Result<Self> {
        let mut records = text
            .lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l.trim()))
            .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'))
            .peekable();
        let Some(&(first_line, first)) = records.peek() else {
            return Err(parse_error(name, 0, "no data (empty file)".into()));
        };
        let comma = first.contains(',');
        let split = move |l: &'a str| -> Vec<&'a str> {
            if comma {
                l.split(',').map(str::trim).collect()
            } else {
                l.split_whitespace().collect()
            }
        };
        let mut fields = split(first);
        let header = fields
            .iter()
            .any(|f| !f.is_empty() && f.parse::<f64>().is_err());
        let (names, header_line) = if header {
            records.next();
            if fields.len() > 1 && fields.last().is_some_and(|f| f.is_empty()) {
                fields.pop();
            }
            let names: Vec<String> = fields.iter().map(|f| unquote(f).to_string()).collect();
            (Some(names), first_line)
        } else {
            if fields.len() > 1 && fields.last().is_some_and(|f| f.is_empty()) {
                fields.pop();
            }
            (None, 0)
        };
        let width = fields.len();
        let mut rows = Vec::new();
        for (line, l) in records {
            let mut f = split(l);
            if f.len() == width + 1 && f.last().is_some_and(|v| v.is_empty()) {
                f.pop();
            }
            if f.len() != width {
                return Err(parse_error(
                    name,
                    line,
                    format!(
                        "expected {width} fields (as the {}), found {}: `{}`",
                        if header { "header" } else { "first row" },
                        f.len(),
                        echo(l)
                    ),
                ));
            }
            rows.push((line, f));
        }
        Ok(Self {
            names,
            header_line,
            width,
            rows,
        })
    }

    /// The 0-based position of `column`, the value of the flag `flag`.
    fn index(&self, column: &Column, flag: &str, name: &str) -> Result<usize> {
        match column {
            Column::Index(i) if (1..=self.width).contains(i) => Ok(i - 1),
            Column::Index(i) => Err(parse_error(
                name,
                self.header_line,
                format!(
                    "{flag} {i}: the file has {} columns (indices 1..{}){}",
                    self.width,
                    self.width,
                    self.available()
                ),
            )),
            Column::Name(n) => {
                let Some(names) = &self.names else {
                    return Err(parse_error(
                        name,
                        0,
                        format!(
                            "{flag} {n}: the file has no header line, select its columns by \
                             1-based index (1..{})",
                            self.width
                        ),
                    ));
                };
                names
                    .iter()
                    .position(|c| c == n)
                    .or_else(|| names.iter().position(|c| c.eq_ignore_ascii_case(n)))
                    .ok_or_else(|| {
                        parse_error(
                            name,
                            self.header_line,
                            format!("{flag} {n}: no such column{}", self.available()),
                        )
                    })
            }
        }
    }

    /// The available column names for a message (`": the columns are …"`), empty without
    /// a header.
    fn available(&self) -> String {
        match &self.names {
            Some(names) => format!(
                "; the columns are {}",
                names
                    .iter()
                    .enumerate()
                    .map(|(j, n)| format!("{} `{}`", j + 1, echo(n)))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            None => String::new(),
        }
    }

    /// The label of column `j` in messages.
    fn label(&self, j: usize) -> String {
        match &self.names {
            Some(names) => format!("column `{}`", echo(&names[j])),
            None => format!("column {}", j + 1),
        }
    }

    /// Column `j` as finite numbers, finite in `T`.
    fn numbers<T: Real>(&self, j: usize, name: &str) -> Result<Vec<f64>> {
        let col = self.label(j);
        self.rows
            .iter()
            .map(|(line, f)| {
                let text = unquote(f[j]);
                if text.is_empty() {
                    return Err(parse_error(name, *line, format!("{col}: empty cell")));
                }
                let v: f64 = text.parse().map_err(|_| {
                    parse_error(
                        name,
                        *line,
                        format!("{col}: `{}` is not a number", echo(text)),
                    )
                })?;
                if !v.is_finite() || !num_traits::Float::is_finite(T::lit(v)) {
                    return Err(parse_error(
                        name,
                        *line,
                        format!(
                            "{col}: value `{}` is not finite in {}",
                            echo(text),
                            std::any::type_name::<T>()
                        ),
                    ));
                }
                Ok(v)
            })
            .collect()
    }

    /// The sample time: from the `t` column (checked against `given`), else `given`.
    fn sample_time(&self, given: Option<f64>, name: &str) -> Result<f64> {
        if let Some(ts) = given
            && !(ts.is_finite() && ts > 0.0)
        {
            return Err(parse_error(
                name,
                0,
                format!("sample time {ts} s: must be positive and finite"),
            ));
        }
        let t_col = self
            .names
            .as_ref()
            .and_then(|n| n.iter().position(|c| c.eq_ignore_ascii_case("t")));
        let Some(j) = t_col else {
            return given.ok_or_else(|| {
                parse_error(
                    name,
                    0,
                    "no `t` column: give the sample time in seconds (--ts S)".into(),
                )
            });
        };
        let t = self.numbers::<f64>(j, name)?;
        let lines: Vec<usize> = self.rows.iter().map(|(l, _)| *l).collect();
        let ts = check_time_grid(&t, &lines).map_err(|(line, m)| parse_error(name, line, m))?;
        if let Some(g) = given
            && (g - ts).abs() > TS_AGREEMENT * ts
        {
            return Err(parse_error(
                name,
                0,
                format!("sample time {g} s contradicts the `t` column, which gives Ts = {ts} s"),
            ));
        }
        Ok(ts)
    }
}

/// `text` without one pair of surrounding double quotes, trimmed.
fn unquote(text: &str) -> &str {
    let t = text.trim();
    t.strip_prefix('"')
        .and_then(|s| s.strip_suffix('"'))
        .map_or(t, str::trim)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sel(i: &str, o: &str, ts: Option<f64>) -> ChannelSelection {
        ChannelSelection {
            input: Column::parse(i),
            output: Column::parse(o),
            ts,
        }
    }

    #[test]
    fn benchmark_header_trailing_field_and_constant_column() {
        let text = "\"Force\",\"Voltage\",\"Acc1\",\"Fs\",\n1,9,2,400,\n3,9,4,,\n5,9,6,,\n\n";
        let r = parse_channels::<f64, _>(text.as_bytes(), "f", &sel("Force", "acc1", Some(0.5)))
            .unwrap();
        assert_eq!(r.u(), &[1.0, 3.0, 5.0]);
        assert_eq!(r.y(), &[2.0, 4.0, 6.0]);
        assert_eq!(r.ts(), 0.5);
        let e = parse_channels::<f64, _>(text.as_bytes(), "f", &sel("Force", "Fs", Some(0.5)))
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 3") && e.contains("empty cell"), "{e}");
        let e = parse_channels::<f64, _>(text.as_bytes(), "f", &sel("Force", "Acc9", Some(0.5)))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("`Voltage`") && e.contains("--output Acc9"),
            "{e}"
        );
        let e = parse_channels::<f64, _>(text.as_bytes(), "f", &sel("Force", "Acc1", None))
            .unwrap_err()
            .to_string();
        assert!(e.contains("--ts"), "{e}");
    }

    #[test]
    fn whitespace_without_header_and_t_column() {
        let text = "  1.0\t 2.0\n  3.0\t 4.0\n 5e0 6e0\n";
        let r = parse_channels::<f64, _>(text.as_bytes(), "d", &sel("2", "1", Some(1.0))).unwrap();
        assert_eq!(r.u(), &[2.0, 4.0, 6.0]);
        let e = parse_channels::<f64, _>(text.as_bytes(), "d", &sel("3", "1", Some(1.0)))
            .unwrap_err()
            .to_string();
        assert!(e.contains("--input 3") && e.contains("1..2"), "{e}");
        let e = parse_channels::<f64, _>(text.as_bytes(), "d", &sel("u", "1", Some(1.0)))
            .unwrap_err()
            .to_string();
        assert!(e.contains("no header"), "{e}");
        let text = "t,u1,y1\n0,1,2\n0.5,3,x\n1.0,5,6\n";
        let e = parse_channels::<f64, _>(text.as_bytes(), "c", &sel("u1", "y1", None))
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 3") && e.contains("`x`"), "{e}");
        let text = "t,u1,y1\n0,1,2\n0.5,3,4\n1.0,5,6\n";
        let r = parse_channels::<f64, _>(text.as_bytes(), "c", &sel("u1", "y1", None)).unwrap();
        assert_eq!(r.ts(), 0.5);
        assert!(
            parse_channels::<f64, _>(text.as_bytes(), "c", &sel("u1", "y1", Some(0.4))).is_err()
        );
    }
}
