//! The text of a Touchstone file: reading it, comments, keyword lines, the fields of a
//! data line and the numbers in them.

use crate::io::lines::echo;

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
        .map_err(|_| format!("`{}` is not a number", echo(field)))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("value `{}` is not finite", echo(field)))
    }
}
