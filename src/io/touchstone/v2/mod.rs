//! Version 2.0: keywords in brackets around the option line and the data rows.

mod keywords;

use super::matrix::MatrixFormat;
use super::options::Options;
use super::rows::{check_frequency, short_row};
use super::text::{content, fields, keyword, number};
use super::{Touchstone, TouchstoneVersion, parse_error};
use crate::error::{FdidError, Result};
use crate::io::lines::echo;
use crate::scalar::Complex;

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

/// Version 2.0 (see [`parse_touchstone`](super::parse_touchstone)); `[Version]` is on line
/// `version_line` with the argument `version`.
pub(super) fn parse_v2(
    text: &str,
    expected_ports: Option<usize>,
    name: &str,
    version_line: usize,
    version: &str,
) -> Result<Touchstone> {
    if version.parse::<f64>() != Ok(2.0) {
        return Err(parse_error(
            name,
            version_line,
            format!(
                "`[Version] {}`: only Touchstone version 2.0 (or version 1, without \
                 `[Version]`) is read",
                echo(version)
            ),
        ));
    }
    let mut reader = Reader::new(name, expected_ports, version_line);
    for (i, raw) in text.lines().enumerate().skip(version_line) {
        let content = content(raw);
        if content.is_empty() {
            continue;
        }
        reader.line(i + 1, content)?;
    }
    reader.finish()
}

/// The state of a version 2 file as it is read line by line.
struct Reader<'a> {
    /// The file name of error messages.
    name: &'a str,
    /// The number of ports the extension names, if any.
    expected_ports: Option<usize>,
    /// The line of `[Version]`.
    version_line: usize,
    section: Section,
    h: Header,
    opts: Options,
    /// The reference impedances of `[Reference]`, on line `reference_line`.
    references: Vec<f64>,
    reference_line: usize,
    /// Numbers per row of `[Network Data]`: the frequency and the pairs of the matrix.
    width: usize,
    /// The numbers of the row being read, from line `row_line`.
    row: Vec<f64>,
    row_line: usize,
    freq_hz: Vec<f64>,
    values: Vec<Vec<Complex<f64>>>,
    /// The last line with content.
    last_line: usize,
}

impl<'a> Reader<'a> {
    fn new(name: &'a str, expected_ports: Option<usize>, version_line: usize) -> Self {
        Self {
            name,
            expected_ports,
            version_line,
            section: Section::Version,
            h: Header::default(),
            opts: Options::default(),
            references: Vec::new(),
            reference_line: 0,
            width: 0,
            row: Vec::new(),
            row_line: 0,
            freq_hz: Vec::new(),
            values: Vec::new(),
            last_line: version_line,
        }
    }

    /// A [`FdidError::Parse`] of this file at `line`.
    fn error(&self, line: usize, message: String) -> FdidError {
        parse_error(self.name, line, message)
    }

    /// The number of ports of `[Number of Ports]`, once given.
    fn ports(&self) -> Option<usize> {
        self.h.ports.map(|p| p.0)
    }

    /// One line with content (its comment removed) at `line`.
    fn line(&mut self, line: usize, content: &str) -> Result<()> {
        self.last_line = line;
        if self.section == Section::End {
            return Err(self.error(
                line,
                format!(
                    "`{}` after `[End]`: only comments may follow it",
                    echo(content)
                ),
            ));
        }
        if self.section == Section::Information
            && keyword(content).is_none_or(|(kw, _, _)| kw != "end information")
        {
            // the information block is skipped
            return Ok(());
        }
        if let Some(rest) = content.strip_prefix('#') {
            return self.option_line(line, rest);
        }
        match keyword(content) {
            Some((kw, written, arg)) => self.keyword(line, &kw, written, arg),
            None => self.data(line, content),
        }
    }

    /// The option line: exactly one, right after `[Version]`.
    fn option_line(&mut self, line: usize, rest: &str) -> Result<()> {
        if self.section != Section::Version {
            return Err(self.error(
                line,
                "a second option line: a Touchstone 2.0 file has one, right after \
                 `[Version]`"
                    .into(),
            ));
        }
        self.opts = Options::parse(rest).map_err(|m| self.error(line, m))?;
        self.section = Section::Options;
        Ok(())
    }

    /// A line that is not a keyword: reference impedances, network or noise data.
    fn data(&mut self, line: usize, content: &str) -> Result<()> {
        match self.section {
            Section::Reference => self.references(line, content),
            Section::Network => self.network_row(line, content),
            Section::Noise => Ok(()),
            Section::Version => Err(self.error(
                line,
                format!(
                    "`{}`: the option line (`# ...`) must follow `[Version] 2.0`",
                    echo(content)
                ),
            )),
            _ => Err(self.error(
                line,
                format!(
                    "`{}` before `[Network Data]`: data rows come after that keyword",
                    echo(content)
                ),
            )),
        }
    }

    /// Reference impedances of `[Reference]` on `line`: more are to come while fewer than
    /// the ports have one.
    fn references(&mut self, line: usize, values: &str) -> Result<()> {
        let n = self.ports().unwrap_or(1);
        for field in fields(values) {
            let r = reference_value(field, n, self.references.len())
                .map_err(|m| self.error(line, m))?;
            self.references.push(r);
        }
        self.section = if self.references.len() < n {
            Section::Reference
        } else {
            Section::Header
        };
        Ok(())
    }

    /// Numbers of the rows of `[Network Data]`; a row may continue on the next lines.
    fn network_row(&mut self, line: usize, content: &str) -> Result<()> {
        let ports = self.ports().unwrap_or(1);
        for field in fields(content) {
            let v = number(field).map_err(|m| self.error(line, m))?;
            if self.row.is_empty() {
                self.row_line = line;
                self.check_row_start(line, v, field)?;
            }
            self.row.push(v);
            if self.row.len() == self.width {
                self.freq_hz.push(self.row[0] * self.opts.unit);
                self.values.push(self.opts.matrix_v2(
                    &self.row[1..],
                    ports,
                    self.h.matrix.map_or(MatrixFormat::Full, |m| m.0),
                    self.h.order_12_21.is_some_and(|o| o.0),
                ));
                self.row.clear();
            }
        }
        Ok(())
    }

    /// A row that starts with `v` (written `field`) on `line`: one of the declared
    /// frequencies, above the previous one.
    fn check_row_start(&self, line: usize, v: f64, field: &str) -> Result<()> {
        let declared = self.h.frequencies.map_or(0, |f| f.0);
        if self.freq_hz.len() == declared {
            return Err(self.error(
                line,
                format!(
                    "more than the {declared} frequencies of `[Number of Frequencies]` \
                     (line {}): a row starts with `{}` after the last one",
                    self.h.frequencies.map_or(0, |f| f.1),
                    echo(field)
                ),
            ));
        }
        check_frequency(v * self.opts.unit, self.freq_hz.last().copied(), field)
            .map_err(|m| self.error(line, m))
    }

    /// The end of the network data at `line`: the last row complete, the declared number
    /// of frequencies.
    fn close_network(&self, line: usize) -> Result<()> {
        if !self.row.is_empty() {
            return Err(self.error(
                self.row_line,
                short_row(&self.row, self.width, self.ports().unwrap_or(1)),
            ));
        }
        check_frequency_count(&self.h, self.freq_hz.len(), line).map_err(|m| self.error(line, m))
    }

    /// The end of the file: after `[End]`, else the error of the section it stops in.
    fn check_end(&self) -> Result<()> {
        let at = self.last_line;
        let message = match self.section {
            Section::End => return Ok(()),
            Section::Network | Section::Noise => {
                if self.section == Section::Network {
                    self.close_network(at)?;
                }
                "the file ends without `[End]` after its data".into()
            }
            Section::Version => {
                return Err(self.error(
                    self.version_line,
                    "no option line (`# ...`) after `[Version] 2.0`".into(),
                ));
            }
            Section::Options => "no `[Number of Ports]` after the option line".into(),
            Section::Reference => {
                return Err(self.error(
                    self.reference_line,
                    format!(
                        "`[Reference]` gives {} of the {} reference impedances",
                        self.references.len(),
                        self.ports().unwrap_or(1)
                    ),
                ));
            }
            Section::Header | Section::Information => {
                "no `[Network Data]`: the file holds no data".into()
            }
        };
        Err(self.error(at, message))
    }

    /// The file read: ended by `[End]`.
    fn finish(self) -> Result<Touchstone> {
        self.check_end()?;
        let Some((ports, _)) = self.h.ports else {
            return Err(self.error(0, "no `[Number of Ports]`".into()));
        };
        let mut references = self.references;
        if references.is_empty() {
            references = vec![self.opts.reference; ports];
        }
        Ok(Touchstone {
            ports,
            parameter: self.opts.parameter,
            format: self.opts.format,
            reference: self.opts.reference,
            version: TouchstoneVersion::V2,
            references,
            freq_hz: self.freq_hz,
            values: self.values,
        })
    }
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
            echo(field),
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
