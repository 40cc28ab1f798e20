//! The data rows of a CSV file, read in pieces of a few MiB whose parts are parsed in
//! parallel (the `rayon` feature; in turn without), with the line numbers, messages and
//! first error of a reading line by line.

use super::header::Layout;
use super::records::{Lines, fields};
use super::{Table, field_value, parse_error};
use crate::error::Result;
use crate::io::MAX_LINE_BYTES;
use crate::io::lines::{LineError, echo};
use crate::scalar::Real;
use std::io::Read;

/// Bytes read at a time after the header: the parsed values of a piece stay in cache.
const PIECE_BYTES: usize = 4 << 20;

/// Bytes per part of a piece parsed on one thread: enough work (about 0.1 ms) to outweigh
/// handing it to a thread.
const PART_BYTES: usize = 64 << 10;

/// The data rows after the header: one number per column, finite in `f64` and in `T`.
///
/// The rest of the file is read in pieces of [`PIECE_BYTES`] cut after a line break (a
/// line stays whole, and a line beyond [`MAX_LINE_BYTES`] is refused as line by line);
/// each piece is split at line breaks into parts of about [`PART_BYTES`] that are parsed
/// at once, and the first bad line of the file is reported.
pub(super) fn read_rows<T: Real, R: Read>(
    lines: Lines<R>,
    layout: Layout,
    name: &str,
) -> Result<Table> {
    read_rows_in::<T, R>(lines, layout, name, PIECE_BYTES, PART_BYTES)
}

/// [`read_rows`] with pieces of `piece_bytes` and parts of `part_bytes`.
fn read_rows_in<T: Real, R: Read>(
    lines: Lines<R>,
    layout: Layout,
    name: &str,
    piece_bytes: usize,
    part_bytes: usize,
) -> Result<Table> {
    let ncols = layout.names.len();
    let (mut line, mut skip_lf, mut reader) = lines.into_rest();
    let mut columns: Vec<Vec<f64>> = vec![Vec::new(); ncols];
    let mut lines_of_rows: Vec<usize> = Vec::new();
    let mut piece: Vec<u8> = Vec::new();
    let mut eof = false;
    while !eof {
        let before = piece.len();
        eof = fill(&mut reader, &mut piece, piece_bytes)
            .map_err(|e| LineError::Io(e).into_error(name))?;
        if std::mem::take(&mut skip_lf) && piece.get(before) == Some(&b'\n') {
            piece.remove(before);
        }
        let cut = if eof {
            piece.len()
        } else {
            match last_break(&piece) {
                Some(cut) => cut,
                // no line break in a piece longer than a line may be: let the line
                // reader name the line that is too long
                None if piece.len() > MAX_LINE_BYTES => piece.len(),
                None => continue,
            }
        };
        let parts = split_parts(&piece[..cut], line, part_bytes);
        let parsed = crate::linalg::parallel::map_indices(parts.len(), |p| {
            let (range, first) = (&parts[p].0, parts[p].1);
            parse_part::<T>(&piece[range.clone()], first, &layout.names, name)
        });
        for part in parsed {
            let (values, rows) = part?;
            for (j, column) in columns.iter_mut().enumerate() {
                column.extend(values.iter().skip(j).step_by(ncols));
            }
            lines_of_rows.extend(rows);
        }
        line = parts.last().map_or(line, |p| p.2);
        piece.drain(..cut);
    }
    Ok(Table {
        layout,
        columns,
        lines: lines_of_rows,
    })
}

/// Appends up to `limit` bytes of `reader` to `out`; true at the end of the input.
fn fill<R: Read>(reader: &mut R, out: &mut Vec<u8>, limit: usize) -> std::io::Result<bool> {
    let want = out.len() + limit;
    while out.len() < want {
        let n = reader
            .by_ref()
            .take((want - out.len()) as u64)
            .read_to_end(out)?;
        if n == 0 {
            return Ok(true);
        }
    }
    Ok(false)
}

/// The end of the last complete line of `bytes` (just after its break): after a `\n`,
/// or after a `\r` that is not the last byte (so that it is not the first half of a
/// `\r\n` split by the read).
fn last_break(bytes: &[u8]) -> Option<usize> {
    let n = bytes.len();
    if n > 0 && bytes[n - 1] == b'\n' {
        return Some(n);
    }
    memchr::memrchr2(b'\n', b'\r', &bytes[..n.saturating_sub(1)]).map(|i| i + 1)
}

/// The parts of `bytes` (whole lines, which continue a file after line `line`): each
/// part's range, the line before its first and the last line it holds, cut after a line
/// break near every `part_bytes`.
#[allow(clippy::type_complexity)]
fn split_parts(
    bytes: &[u8],
    line: usize,
    part_bytes: usize,
) -> Vec<(std::ops::Range<usize>, usize, usize)> {
    let mut parts = Vec::new();
    let (mut start, mut line) = (0, line);
    while start < bytes.len() {
        let target = start + part_bytes;
        let end = if target >= bytes.len() {
            bytes.len()
        } else {
            last_break(&bytes[..target])
                .filter(|e| *e > start)
                .unwrap_or_else(|| {
                    // a line longer than a part: up to its break (or the end)
                    memchr::memchr2(b'\n', b'\r', &bytes[target..])
                        .map_or(bytes.len(), |i| (target + i + 1).min(bytes.len()))
                })
        };
        // a `\r\n` cut between its bytes belongs to the part before
        let end = if end < bytes.len() && bytes[end - 1] == b'\r' && bytes[end] == b'\n' {
            end + 1
        } else {
            end
        };
        let last = line
            + breaks(&bytes[start..end])
            + usize::from(end == bytes.len() && !ends_with_break(&bytes[start..end]));
        parts.push((start..end, line, last));
        (start, line) = (end, last);
    }
    parts
}

/// Line breaks in `bytes`: each `\n`, and each `\r` not followed by `\n`.
fn breaks(bytes: &[u8]) -> usize {
    memchr::memchr2_iter(b'\n', b'\r', bytes)
        .filter(|&i| !(bytes[i] == b'\r' && bytes.get(i + 1) == Some(&b'\n')))
        .count()
}

fn ends_with_break(bytes: &[u8]) -> bool {
    matches!(bytes.last(), Some(b'\n' | b'\r'))
}

/// The values of the rows of one part (whole lines after line `line` of the file), row
/// after row, and each row's line; the error of its first bad line.
///
/// A part that is valid UTF-8 throughout is split into lines in place; any fault sends
/// the part to the line reader, whose error is the one a reading line by line gives.
fn parse_part<T: Real>(
    bytes: &[u8],
    line: usize,
    names: &[String],
    name: &str,
) -> Result<(Vec<f64>, Vec<usize>)> {
    let ncols = names.len();
    let mut values = Vec::with_capacity(bytes.len() / 16);
    let mut rows = Vec::with_capacity(bytes.len() / (16 * ncols.max(1)));
    if let Ok(text) = std::str::from_utf8(bytes) {
        let mut number = line;
        let mut fine = true;
        for raw in text_lines(text) {
            number += 1;
            let trimmed = raw.trim();
            if raw.len() > MAX_LINE_BYTES {
                fine = false;
                break;
            }
            if trimmed.is_empty() || trimmed.starts_with('#') {
                continue;
            }
            if parse_row::<T>(trimmed, names, &mut values).is_err() {
                fine = false;
                break;
            }
            rows.push(number);
        }
        if fine {
            return Ok((values, rows));
        }
        values.clear();
        rows.clear();
    }
    let mut lines = Lines::continuing(bytes, line);
    while let Some((line, text)) = lines.next_text().map_err(|e| e.into_error(name))? {
        parse_row::<T>(text, names, &mut values).map_err(|m| parse_error(name, line, m))?;
        rows.push(line);
    }
    Ok((values, rows))
}

/// The lines of `text` without their breaks (`\n`, `\r\n` or a lone `\r`), as the line
/// reader splits them: no empty line after a final break.
fn text_lines(text: &str) -> impl Iterator<Item = &str> {
    let bytes = text.as_bytes();
    let mut start = 0;
    std::iter::from_fn(move || {
        if start >= bytes.len() {
            return None;
        }
        let (end, next) = match memchr::memchr2(b'\n', b'\r', &bytes[start..]) {
            Some(i) => {
                let at = start + i;
                let crlf = bytes[at] == b'\r' && bytes.get(at + 1) == Some(&b'\n');
                (at, at + 1 + usize::from(crlf))
            }
            None => (bytes.len(), bytes.len()),
        };
        let line = &text[start..end];
        start = next;
        Some(line)
    })
}

/// Appends the values of one row's fields to `out`: one pass for the values of the first
/// fields (the first bad one remembered) and the count; a wrong count is reported before
/// a bad value.
fn parse_row<T: Real>(
    text: &str,
    names: &[String],
    out: &mut Vec<f64>,
) -> std::result::Result<(), String> {
    let ncols = names.len();
    let mut bad: Option<String> = None;
    let mut count = 0;
    for (j, field) in fields(text).enumerate() {
        count += 1;
        if j < ncols && bad.is_none() {
            match field_value::<T>(&names[j], field) {
                Ok(v) => out.push(v),
                Err(m) => bad = Some(m),
            }
        }
    }
    if count != ncols {
        let found: Vec<&str> = fields(text).collect();
        return Err(format!(
            "expected {ncols} fields ({}), found {count}: `{}`",
            names.join(","),
            echo(&found.join(","))
        ));
    }
    bad.map_or(Ok(()), Err)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Header and rows of `text` read line by line (the reference), as a table or the
    /// error's line and message.
    fn line_by_line(text: &[u8]) -> std::result::Result<(Vec<Vec<f64>>, Vec<usize>), String> {
        let mut lines = Lines::new(text);
        let (_, names) = lines.next_record().unwrap().unwrap();
        let mut values = vec![];
        let mut rows = vec![];
        loop {
            match lines.next_text() {
                Ok(Some((line, t))) => {
                    parse_row::<f64>(t, &names, &mut values)
                        .map_err(|m| parse_error("t", line, m).to_string())?;
                    rows.push(line);
                }
                Ok(None) => break,
                Err(e) => return Err(e.into_error("t").to_string()),
            }
        }
        let n = names.len();
        let columns = (0..n)
            .map(|j| values.iter().skip(j).step_by(n).copied().collect())
            .collect();
        Ok((columns, rows))
    }

    fn in_pieces(
        text: &[u8],
        piece: usize,
        part: usize,
    ) -> std::result::Result<(Vec<Vec<f64>>, Vec<usize>), String> {
        let mut lines = Lines::new(text);
        let (_, names) = lines.next_record().unwrap().unwrap();
        let layout = Layout::from_header(&names).unwrap();
        read_rows_in::<f64, _>(lines, layout, "t", piece, part)
            .map(|t| (t.columns, t.lines))
            .map_err(|e| e.to_string())
    }

    /// A file of `rows` rows with every kind of line break, comments and blank lines.
    fn file(rows: usize, bad_at: Option<usize>) -> Vec<u8> {
        let breaks: [&[u8]; 3] = [b"\n", b"\r\n", b"\r"];
        let mut out = b"f,re,im\r\n".to_vec();
        for k in 0..rows {
            let f = (k + 1) as f64 * 0.25;
            let row = if Some(k) == bad_at {
                format!("{f},x{k},1")
            } else {
                format!(" {f}, {:.17e} ,\"{}\"", (k as f64).sin(), k as f64 * -1e-3)
            };
            out.extend_from_slice(row.as_bytes());
            out.extend_from_slice(breaks[k % 3]);
            if k % 17 == 0 {
                out.extend_from_slice(b"# a comment\n\r\n");
            }
        }
        out
    }

    #[test]
    fn pieces_and_parts_read_as_line_by_line() {
        for rows in [0, 1, 2, 50, 400] {
            let text = file(rows, None);
            let want = line_by_line(&text).unwrap();
            for (piece, part) in [(4 << 20, 64 << 10), (64, 16), (97, 1), (1000, 300), (7, 7)] {
                assert_eq!(
                    in_pieces(&text, piece, part),
                    Ok(want.clone()),
                    "{rows} {piece} {part}"
                );
            }
            // without the last line break
            let mut cut = text.clone();
            while matches!(cut.last(), Some(b'\n' | b'\r')) {
                cut.pop();
            }
            let want = line_by_line(&cut).unwrap();
            assert_eq!(in_pieces(&cut, 64, 16), Ok(want));
        }
    }

    #[test]
    fn the_first_bad_line_is_reported() {
        let mut text = file(300, Some(211));
        // a second fault later: not valid UTF-8
        text.extend_from_slice(b"1,2,\xff\n");
        let want = line_by_line(&text).unwrap_err();
        assert!(want.contains("x211"), "{want}");
        for (piece, part) in [(4 << 20, 64 << 10), (64, 16), (500, 3)] {
            assert_eq!(in_pieces(&text, piece, part), Err(want.clone()));
        }
        // alone, the UTF-8 fault and a line beyond the cap are named with their lines
        let mut text = file(40, None);
        text.extend_from_slice(b"1,2,\xff\n");
        assert_eq!(
            in_pieces(&text, 64, 16),
            Err(line_by_line(&text).unwrap_err())
        );
        let mut text = file(40, None);
        text.extend(std::iter::repeat_n(b'7', MAX_LINE_BYTES + 1));
        let want = line_by_line(&text).unwrap_err();
        assert!(want.contains("longer than"), "{want}");
        assert_eq!(in_pieces(&text, 1 << 16, 1 << 10), Err(want));
    }
}
