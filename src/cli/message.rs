//! The text of an `error:` line.

/// Joins the lines of a message so it always prints as one line, escapes control
/// characters and keeps at most 1000 characters (values from files are already cut to 200
/// where they are quoted; this bounds the rest).
pub fn one_line(s: &str) -> String {
    const MAX: usize = 1000;
    let joined = s
        .split(['\n', '\r'])
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join(" ");
    fdid::io::printable(&joined, MAX)
}
