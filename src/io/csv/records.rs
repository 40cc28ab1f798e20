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

    /// The next line that is neither blank nor a comment, as (line number, trimmed
    /// fields); a field wrapped in double quotes loses them. `None` at the end.
    pub(super) fn next_record(
        &mut self,
    ) -> std::result::Result<Option<(usize, Vec<String>)>, LineError> {
        while let Some((line, text)) = self.lines.next_line()? {
            let text = text.trim();
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
            return Ok(Some((line, fields)));
        }
        Ok(None)
    }
}
