//! The records of a CSV file: its lines that are neither blank nor comments, split into
//! fields.

use crate::error::FdidError;
use std::io::Read;

/// A line-by-line reader of comma-separated fields that skips blank and comment lines
/// and counts lines exactly (1-based).
pub(super) struct Lines<R: Read> {
    reader: std::io::BufReader<R>,
    buf: Vec<u8>,
    line: usize,
}

/// A failure of [`Lines::next_record`], turned into an error once the file name is known.
pub(super) enum LineError {
    Io(std::io::Error),
    Utf8(usize),
}

impl LineError {
    pub(super) fn into_error(self, name: &str) -> FdidError {
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
    pub(super) fn new(reader: R) -> Self {
        Self {
            reader: std::io::BufReader::new(reader),
            buf: Vec::new(),
            line: 0,
        }
    }

    /// The next line that is neither blank nor a comment, as (line number, trimmed
    /// fields); a field wrapped in double quotes loses them. `None` at the end.
    pub(super) fn next_record(
        &mut self,
    ) -> std::result::Result<Option<(usize, Vec<String>)>, LineError> {
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
