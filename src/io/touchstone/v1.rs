//! Version 1: an option line and data rows, without keywords.

use super::options::Options;
use super::rows::{check_frequency, short_row};
use super::text::{content, fields, keyword, number};
use super::{Touchstone, TouchstoneVersion, parse_error};
use crate::error::{FdidError, Result};
use crate::scalar::Complex;

/// Version 1 (see [`parse_touchstone`](super::parse_touchstone)).
pub(super) fn parse_v1(text: &str, ports: usize, name: &str) -> Result<Touchstone> {
    let mut reader = Reader::new(name, ports);
    for (i, raw) in text.lines().enumerate() {
        let content = content(raw);
        if content.is_empty() || reader.noise_section {
            continue;
        }
        reader.line(i + 1, content)?;
    }
    reader.finish()
}

/// The state of a version 1 file as it is read line by line.
struct Reader<'a> {
    /// The file name of error messages.
    name: &'a str,
    ports: usize,
    /// The option line, or the defaults once data came without one.
    options: Option<Options>,
    /// Whether the file gave an option line.
    options_given: bool,
    /// Numbers per row: the frequency and the pairs of the matrix.
    width: usize,
    /// The numbers of the row being read, from line `row_line`.
    row: Vec<f64>,
    row_line: usize,
    freq_hz: Vec<f64>,
    values: Vec<Vec<Complex<f64>>>,
    /// Whether the noise parameters of a 2-port started (they are not read).
    noise_section: bool,
    /// The line of the first data row.
    data_line: Option<usize>,
    /// Whether every data line so far held exactly 3 numbers (a 1-port row).
    only_one_port_rows: bool,
}

impl<'a> Reader<'a> {
    fn new(name: &'a str, ports: usize) -> Self {
        let width = 1 + 2 * ports * ports;
        Self {
            name,
            ports,
            options: None,
            options_given: false,
            width,
            row: Vec::with_capacity(width),
            row_line: 0,
            freq_hz: Vec::new(),
            values: Vec::new(),
            noise_section: false,
            data_line: None,
            only_one_port_rows: true,
        }
    }

    /// A [`FdidError::Parse`] of this file at `line`.
    fn error(&self, line: usize, message: String) -> FdidError {
        parse_error(self.name, line, message)
    }

    /// One line with content (its comment removed) at `line`.
    fn line(&mut self, line: usize, content: &str) -> Result<()> {
        if let Some((_, written, _)) = keyword(content) {
            return Err(self.error(
                line,
                format!(
                    "`[{written}]` is a Touchstone 2 keyword, but the file does not start \
                     with `[Version] 2.0`: a version 2 file needs that line first, a \
                     version 1 file has no keywords"
                ),
            ));
        }
        match content.strip_prefix('#') {
            Some(rest) => self.option_line(line, rest),
            None => self.data(line, content),
        }
    }

    /// The option line: the first one before the data counts, later ones are ignored.
    fn option_line(&mut self, line: usize, rest: &str) -> Result<()> {
        if let Some(first) = self.data_line {
            if self.options_given {
                // later option lines are ignored
                return Ok(());
            }
            return Err(self.error(
                line,
                format!(
                    "the option line comes after the data of line {first}: it must \
                     precede them (the data above would have been read with the \
                     defaults GHz, S, MA)"
                ),
            ));
        }
        if self.options.is_none() {
            self.options = Some(Options::parse(rest).map_err(|m| self.error(line, m))?);
            self.options_given = true;
        }
        Ok(())
    }

    /// A data line: numbers of the current row, which may continue on the next lines.
    fn data(&mut self, line: usize, content: &str) -> Result<()> {
        self.data_line.get_or_insert(line);
        let opts = *self.options.get_or_insert_with(Options::default);
        let count = fields(content).count();
        if self.ports == 1 && count != self.width {
            return Err(self.error(
                line,
                format!(
                    "the line holds {count} numbers, but a 1-port row holds 3 (the frequency \
                     and one complex value) on one line{}",
                    match count {
                        9 => ": it looks like a 2-port row (is the file a .s2p?)",
                        _ => "",
                    }
                ),
            ));
        }
        if count != 3 {
            self.only_one_port_rows = false;
        }
        for field in fields(content) {
            let v = number(field).map_err(|m| self.error(line, m))?;
            if self.row.is_empty() {
                self.row_line = line;
                let f = v * opts.unit;
                if self.ports == 2 && self.freq_hz.last().is_some_and(|last| f <= *last) {
                    // the noise parameters of a 2-port follow the network data
                    self.noise_section = true;
                    return Ok(());
                }
                check_frequency(f, self.freq_hz.last().copied(), field)
                    .map_err(|m| self.error(line, m))?;
            }
            self.row.push(v);
            if self.row.len() == self.width {
                self.freq_hz.push(self.row[0] * opts.unit);
                self.values.push(opts.matrix(&self.row[1..], self.ports));
                self.row.clear();
            }
        }
        Ok(())
    }

    /// The file read: its rows complete, at least one of them.
    fn finish(self) -> Result<Touchstone> {
        if self.ports > 1
            && self.only_one_port_rows
            && let Some(first) = self.data_line
        {
            return Err(self.error(
                first,
                format!(
                    "every data line holds 3 numbers (the frequency and one complex value, \
                     a 1-port row), but a {p}-port row holds {w}: the file looks like a \
                     1-port file named .s{p}p (rename it .s1p)",
                    p = self.ports,
                    w = self.width
                ),
            ));
        }
        if !self.row.is_empty() {
            return Err(self.error(self.row_line, short_row(&self.row, self.width, self.ports)));
        }
        if self.freq_hz.is_empty() {
            return Err(self.error(0, "no data rows".into()));
        }
        let opts = self.options.unwrap_or_default();
        Ok(Touchstone {
            ports: self.ports,
            parameter: opts.parameter,
            format: opts.format,
            reference: opts.reference,
            version: TouchstoneVersion::V1,
            references: vec![opts.reference; self.ports],
            freq_hz: self.freq_hz,
            values: self.values,
        })
    }
}
