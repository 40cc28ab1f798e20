//! The records of a CSV file: its lines that are neither blank nor comments, split into
//! fields.

use crate::io::lines::{LineError, LineReader};
use std::io::Read;

/// A reader of comma-separated fields that skips blank and comment lines and counts lines
/// exactly (1-based), on [`LineReader`] (bounded line length, any line break).
pub(super) struct Lines<R: Read> {
    lines: LineReader<R>,
}

impl<R: Read> Lines<R> {
    pub(super) fn new(reader: R) -> Self {
        Self {
            lines: LineReader::new(reader),
        }
    }

    /// Records of text that continues a file after its line `line`.
    pub(super) fn continuing(reader: R, line: usize) -> Self {
        Self {
            lines: LineReader::continuing(reader, line),
        }
    }

    /// The bytes not read yet (see [`LineReader::into_rest`]).
    pub(super) fn into_rest(self) -> (usize, bool, std::io::BufReader<R>) {
        self.lines.into_rest()
    }

    /// The next line that is neither blank nor a comment, as (line number, trimmed
    /// fields); a field wrapped in double quotes loses them. `None` at the end.
    pub(super) fn next_record(
        &mut self,
    ) -> std::result::Result<Option<(usize, Vec<String>)>, LineError> {
        Ok(self
            .next_text()?
            .map(|(line, text)| (line, fields(text).map(str::to_string).collect())))
    }

    /// The next line that is neither blank nor a comment, as (line number, trimmed text),
    /// for [`fields`] to split without allocating; `None` at the end.
    pub(super) fn next_text(&mut self) -> std::result::Result<Option<(usize, &str)>, LineError> {
        loop {
            if !self.lines.advance()? {
                return Ok(None);
            }
            let text = self.lines.current().trim();
            if !(text.is_empty() || text.starts_with('#')) {
                break;
            }
        }
        Ok(Some((self.lines.line(), self.lines.current().trim())))
    }
}

/// The trimmed fields of a record's text; a field wrapped in double quotes loses them.
pub(super) fn fields(text: &str) -> impl Iterator<Item = &str> {
    text.split(',').map(|f| {
        let f = f.trim();
        f.strip_prefix('"')
            .and_then(|g| g.strip_suffix('"'))
            .map_or(f, str::trim)
    })
}
