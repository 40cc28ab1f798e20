//! The text of a Touchstone file: reading it, comments, keyword lines, the fields of a
//! data line and the numbers in them.

use super::parse_error;
use crate::error::{FdidError, Result};
use std::io::Read;

/// The text of `reader` (UTF-8, without a byte-order mark).
pub(super) fn read_text<R: Read>(mut reader: R, name: &str) -> Result<String> {
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
pub(super) fn content(raw: &str) -> &str {
    raw.split('!').next().unwrap_or("").trim()
}

/// A keyword line `[Name] argument`: the name, lower case with single spaces for the
/// spaces and dashes between words, as written, and the argument.
pub(super) fn keyword(content: &str) -> Option<(String, &str, &str)> {
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

/// The fields of a data line: separated by spaces, tabs or commas.
pub(super) fn fields(content: &str) -> impl Iterator<Item = &str> {
    content
        .split(|c: char| c.is_whitespace() || c == ',')
        .filter(|f| !f.is_empty())
}

/// A finite number.
pub(super) fn number(field: &str) -> std::result::Result<f64, String> {
    let v: f64 = field
        .parse()
        .map_err(|_| format!("`{}` is not a number", shorten(field)))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("value `{field}` is not finite"))
    }
}

/// The first 40 characters of `s`.
pub(super) fn shorten(s: &str) -> String {
    if s.chars().count() > 40 {
        format!("{}…", s.chars().take(40).collect::<String>())
    } else {
        s.to_string()
    }
}
