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

/// Bytes read at a time after the header (the most), into one buffer kept for the whole
/// file: the parsed values of a piece stay in cache.
const PIECE_BYTES: usize = 4 << 20;

/// The smallest piece of a file of known length ([`piece_bytes`]): four parts.
const SMALLEST_PIECE_BYTES: usize = 4 * PART_BYTES;

/// The largest file of known length read in pieces of [`SMALLEST_PIECE_BYTES`]
/// ([`piece_bytes`]): 2 MiB.
const SMALL_FILE_BYTES: usize = 8 * SMALLEST_PIECE_BYTES;

/// The largest file of known length whose parts are parsed one after the other on the
/// calling thread ([`read_rows`]).
const SERIAL_FILE_BYTES: usize = 8 * PART_BYTES;

/// Bytes per part of a piece parsed on one thread: enough work (about 0.1 ms) to outweigh
/// handing it to a thread.
const PART_BYTES: usize = 64 << 10;

/// The data rows after the header: one number per column, finite in `f64` and in `T`.
///
/// The rest of the file is read in pieces of at most [`PIECE_BYTES`] cut after a line
/// break (a line stays whole, and a line beyond [`MAX_LINE_BYTES`] is refused as line by
/// line); each piece is split at line breaks into parts of about [`PART_BYTES`] that are
/// parsed at once on the thread pool (one after the other for a small file:
/// [`parallel_parts`]), and the first bad line of the file is reported.
///
/// `file_bytes`, the length of the whole file when known, sizes the pieces
/// ([`piece_bytes`]) and the columns, once, from the lines of the first piece
/// (`make_room`).
pub(super) fn read_rows<T: Real, R: Read>(
    lines: Lines<R>,
    layout: Layout,
    name: &str,
    file_bytes: Option<u64>,
) -> Result<Table> {
    let piece = file_bytes.map_or(PIECE_BYTES, piece_bytes);
    let parallel = parallel_parts(file_bytes);
    read_rows_in::<T, R>(
        lines,
        layout,
        name,
        file_bytes,
        (piece, PART_BYTES, parallel),
    )
}

/// Whether the parts of a file of `file_bytes` bytes (unknown: `None`) are parsed on the
/// thread pool: not for a file of at most [`SERIAL_FILE_BYTES`] (512 KiB), parsed on the
/// calling thread. In a fresh process the pool's start costs more than its second thread
/// saves on such a file (a first reading of 1 650 rows, 120 kB: 0.79 ms on one thread
/// against 1.14 ms on the pool; of 3 000 rows 1.36 against 1.72 ms; of 10 000 rows,
/// 730 kB, the two are even).
fn parallel_parts(file_bytes: Option<u64>) -> bool {
    file_bytes.is_none_or(|b| b > SERIAL_FILE_BYTES as u64)
}

/// The pieces of a file of `file_bytes` bytes: [`SMALLEST_PIECE_BYTES`] for a file of
/// at most [`SMALL_FILE_BYTES`] (2 MiB), [`PIECE_BYTES`] beyond. A process reads its file once,
/// and each page of the buffer it touches first is a page fault (3–4 µs on a virtual
/// machine): a small file is read through a small buffer (10 000 rows read in a fresh
/// process: 4.0 against 4.5 ms). A large file keeps the two threads busy with large
/// pieces: each piece ends in a join, and an idle thread is slow to wake (100 000 rows
/// read again in one process: 16 ms with pieces of 4 MiB, 22 ms with pieces of 1 MiB).
fn piece_bytes(file_bytes: u64) -> usize {
    if file_bytes <= SMALL_FILE_BYTES as u64 {
        SMALLEST_PIECE_BYTES
    } else {
        PIECE_BYTES
    }
}

/// [`read_rows`] with pieces and parts of the given sizes in bytes, the parts parsed in
/// parallel or one after the other.
fn read_rows_in<T: Real, R: Read>(
    lines: Lines<R>,
    layout: Layout,
    name: &str,
    file_bytes: Option<u64>,
    (piece_bytes, part_bytes, parallel): (usize, usize, bool),
) -> Result<Table> {
    let ncols = layout.names.len();
    let (mut line, mut skip_lf, mut reader) = lines.into_rest();
    let mut columns: Vec<Vec<f64>> = vec![Vec::new(); ncols];
    let mut lines_of_rows: Vec<usize> = Vec::new();
    let mut piece: Vec<u8> = Vec::with_capacity(piece_bytes);
    let mut eof = false;
    // bytes of the pieces read so far
    let mut read = 0u64;
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
        let rows_at_most = parts.last().map_or(line, |p| p.2) - line;
        read += cut as u64;
        let more = file_bytes.map_or(0, |total| {
            expected_lines(rows_at_most, cut, total.saturating_sub(read))
        });
        for column in &mut columns {
            make_room(column, rows_at_most, more);
        }
        make_room(&mut lines_of_rows, rows_at_most, more);
        let part = |p: usize| {
            let (range, first) = (&parts[p].0, parts[p].1);
            parse_part::<T>(&piece[range.clone()], first, &layout.names, name)
        };
        let parsed: Vec<_> = if parallel {
            crate::linalg::parallel::map_indices(parts.len(), part)
        } else {
            (0..parts.len()).map(part).collect()
        };
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

/// The lines expected in `rest` more bytes of a file whose last `bytes` held `lines`,
/// with a margin of 1/16 (the rows of a data file are about as long as one another).
fn expected_lines(lines: usize, bytes: usize, rest: u64) -> usize {
    let per_byte = lines as f64 / bytes.max(1) as f64;
    let expected = per_byte * rest as f64 * (17.0 / 16.0);
    // a float beyond usize saturates: the reservation below then fails and is skipped
    expected as usize
}

/// Room in `v` for `now` more values, with `then` more expected after them: when `now`
/// do not fit, one reservation of both (so that a file of known length fills its columns
/// without moving them), or of `now` alone as the vector's usual growth when that fails.
fn make_room<X>(v: &mut Vec<X>, now: usize, then: usize) {
    if v.capacity() - v.len() < now
        && (then == 0 || v.try_reserve_exact(now.saturating_add(then)).is_err())
    {
        v.reserve(now);
    }
}

/// Appends bytes of `reader` to `out` until it holds `limit` bytes (`limit` more when it
/// already holds as many: a line longer than a piece), so that a buffer of `limit` bytes
/// is reused from piece to piece; true at the end of the input.
fn fill<R: Read>(reader: &mut R, out: &mut Vec<u8>, limit: usize) -> std::io::Result<bool> {
    let want = if out.len() < limit {
        limit
    } else {
        out.len() + limit
    };
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
        let (mut number, mut start, mut fine) = (line, 0, true);
        while start < bytes.len() {
            number += 1;
            // the plain reading ends the line where its last number does; the general
            // one takes the line up to its break
            let (end, next) = match plain_row::<T>(bytes, start, ncols, &mut values) {
                Some((plain, end, next)) => {
                    if plain == Plain::Row {
                        rows.push(number);
                    }
                    (end, next)
                }
                None => {
                    let (end, next) = line_end(bytes, start);
                    let trimmed = text[start..end].trim();
                    if !(trimmed.is_empty() || trimmed.starts_with('#')) {
                        if parse_row::<T>(trimmed, names, &mut values).is_err() {
                            fine = false;
                            break;
                        }
                        rows.push(number);
                    }
                    (end, next)
                }
            };
            if end - start > MAX_LINE_BYTES {
                fine = false;
                break;
            }
            start = next;
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

/// The end of the line that starts at `start` (its break, or the end of `bytes`) and the
/// start of the next: after `\n`, `\r\n` or a lone `\r`, as the line reader splits.
fn line_end(bytes: &[u8], start: usize) -> (usize, usize) {
    match memchr::memchr2(b'\n', b'\r', &bytes[start..]) {
        Some(i) => (start + i, after_break(bytes, start + i)),
        None => (bytes.len(), bytes.len()),
    }
}

/// The start of the next line after the break at `at` (a `\r\n` is one break).
fn after_break(bytes: &[u8], at: usize) -> usize {
    if bytes[at] == b'\r' && bytes.get(at + 1) == Some(&b'\n') {
        at + 2
    } else {
        at + 1
    }
}

/// What [`plain_row`] made of a line.
#[derive(Debug, PartialEq)]
enum Plain {
    /// A row: its values were appended.
    Row,
    /// A blank or comment line.
    Skipped,
}

/// The common case of a line, read at the byte level: the line that starts at `start` of
/// `bytes` holds ASCII blanks around unquoted fields that are finite numbers, as many as
/// the columns. Appends the row's values to `out` and returns [`Plain::Row`], or returns
/// [`Plain::Skipped`] for a blank or comment line, with the end of the line (its break)
/// and the start of the next; `None` (with `out` unchanged) for anything else (quotes,
/// other than ASCII blanks, a wrong count, a bad value), which [`parse_row`] then reads
/// with the same result or names the fault.
///
/// One pass over the bytes: each number is parsed where it starts and ends where its
/// parse stops, after which only blanks and a comma (a line break or the end after the
/// last field) may follow. The blanks are those of [`str::trim`] among ASCII bytes, and
/// the grammar and correctly rounded value of a number those of `str::parse::<f64>`, so
/// that a row read here gives the values [`parse_row`] would (a difference test holds
/// the two to it).
fn plain_row<T: Real>(
    bytes: &[u8],
    start: usize,
    ncols: usize,
    out: &mut Vec<f64>,
) -> Option<(Plain, usize, usize)> {
    let first = start + leading_blanks(&bytes[start..]);
    if matches!(bytes.get(first), None | Some(b'\n' | b'\r' | b'#')) {
        let (end, next) = line_end(bytes, first);
        return Some((Plain::Skipped, end, next));
    }
    let before = out.len();
    let end = plain_fields::<T>(bytes, first, ncols, out);
    if end.is_none() {
        out.truncate(before);
    }
    end.map(|end| {
        let next = if end == bytes.len() {
            end
        } else {
            after_break(bytes, end)
        };
        (Plain::Row, end, next)
    })
}

/// The values of the `ncols` plain fields from `at` appended to `out`, and the end of
/// their line (its break or the end of `bytes`); `None` (with some perhaps appended) when
/// a field is not plain or the count is wrong.
fn plain_fields<T: Real>(
    bytes: &[u8],
    mut at: usize,
    ncols: usize,
    out: &mut Vec<f64>,
) -> Option<usize> {
    for j in 0..ncols {
        at += leading_blanks(&bytes[at..]);
        let (v, used): (f64, usize) = fast_float2::parse_partial(&bytes[at..]).ok()?;
        at += used;
        at += leading_blanks(&bytes[at..]);
        let next = bytes.get(at).copied();
        if j + 1 == ncols {
            if !matches!(next, None | Some(b'\n' | b'\r')) {
                return None;
            }
        } else if next == Some(b',') {
            at += 1;
        } else {
            return None;
        }
        if !(v.is_finite() && num_traits::Float::is_finite(T::lit(v))) {
            return None;
        }
        out.push(v);
    }
    Some(at)
}

/// The number of blank bytes ([`is_blank`]) that `bytes` starts with.
fn leading_blanks(bytes: &[u8]) -> usize {
    bytes.iter().take_while(|&&b| is_blank(b)).count()
}

/// The ASCII bytes [`char::is_whitespace`] holds blank, but for the line breaks.
fn is_blank(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | 0x0b | 0x0c)
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
        parallel: bool,
    ) -> std::result::Result<(Vec<Vec<f64>>, Vec<usize>), String> {
        let mut lines = Lines::new(text);
        let (_, names) = lines.next_record().unwrap().unwrap();
        let layout = Layout::from_header(&names).unwrap();
        read_rows_in::<f64, _>(lines, layout, "t", None, (piece, part, parallel))
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
                // on the pool and on the calling thread alike
                for parallel in [true, false] {
                    assert_eq!(
                        in_pieces(&text, piece, part, parallel),
                        Ok(want.clone()),
                        "{rows} {piece} {part} {parallel}"
                    );
                }
            }
            // without the last line break
            let mut cut = text.clone();
            while matches!(cut.last(), Some(b'\n' | b'\r')) {
                cut.pop();
            }
            let want = line_by_line(&cut).unwrap();
            assert_eq!(in_pieces(&cut, 64, 16, true), Ok(want));
        }
    }

    #[test]
    fn the_file_length_sizes_the_buffers_and_not_the_values() {
        let text = file(400, None);
        let want = line_by_line(&text).unwrap();
        let n = text.len() as u64;
        // right, too small, too large and absurd lengths: the rows are the same
        for hint in [Some(n), Some(0), Some(n / 10), Some(n * 10), Some(u64::MAX)] {
            for (piece, part) in [(64, 16), (1000, 300), (4 << 20, 64 << 10)] {
                let mut lines = Lines::new(&text[..]);
                let (_, names) = lines.next_record().unwrap().unwrap();
                let layout = Layout::from_header(&names).unwrap();
                let got = read_rows_in::<f64, _>(lines, layout, "t", hint, (piece, part, true))
                    .map(|t| (t.columns, t.lines))
                    .map_err(|e| e.to_string());
                assert_eq!(got, Ok(want.clone()), "{hint:?} {piece} {part}");
            }
        }
    }

    #[test]
    fn small_files_are_read_through_a_small_buffer() {
        assert_eq!(piece_bytes(0), SMALLEST_PIECE_BYTES);
        assert_eq!(piece_bytes(730_000), SMALLEST_PIECE_BYTES);
        assert_eq!(piece_bytes(2 << 20), SMALLEST_PIECE_BYTES);
        assert_eq!(piece_bytes((2 << 20) + 1), PIECE_BYTES);
        assert_eq!(piece_bytes(u64::MAX), PIECE_BYTES);
    }

    #[test]
    fn small_files_are_parsed_on_the_calling_thread() {
        assert!(parallel_parts(None));
        assert!(!parallel_parts(Some(0)));
        assert!(!parallel_parts(Some(512 << 10)));
        assert!(parallel_parts(Some((512 << 10) + 1)));
    }

    #[test]
    fn the_piece_buffer_is_filled_to_its_size_and_reused() {
        let data = vec![b'1'; 1000];
        let mut reader = &data[..];
        let mut piece = Vec::with_capacity(64);
        piece.extend_from_slice(b"rest");
        // topped up to 64 bytes, not 64 more
        assert!(!fill(&mut reader, &mut piece, 64).unwrap());
        assert_eq!((piece.len(), piece.capacity()), (64, 64));
        // a piece as long as the limit (a long line) gets the limit more
        assert!(!fill(&mut reader, &mut piece, 64).unwrap());
        assert_eq!(piece.len(), 128);
        piece.drain(..120);
        let capacity = piece.capacity();
        assert!(!fill(&mut reader, &mut piece, 64).unwrap());
        assert_eq!((piece.len(), piece.capacity()), (64, capacity));
        // the end of the input
        let mut short = &b"ab"[..];
        let mut v = Vec::new();
        assert!(fill(&mut short, &mut v, 64).unwrap());
        assert_eq!(v, b"ab");
    }

    #[test]
    fn room_is_made_once_for_the_expected_values() {
        let mut v: Vec<f64> = Vec::new();
        make_room(&mut v, 10, 90);
        assert_eq!(v.capacity(), 100);
        v.extend(std::iter::repeat_n(0.0, 95));
        // enough room for 5 more: nothing moves
        make_room(&mut v, 5, 1000);
        assert_eq!(v.capacity(), 100);
        // an expectation beyond memory: the usual growth instead of an abort
        make_room(&mut v, 10, usize::MAX / 2);
        assert!(v.capacity() >= 105 && v.capacity() < 1 << 20);
        // 3 lines in 100 bytes, 1000 bytes to come: 30 lines and a sixteenth
        assert_eq!(expected_lines(3, 100, 1000), 31);
        assert_eq!(expected_lines(3, 0, 0), 0);
    }

    /// A line of fields drawn from numbers in every notation and from near misses (signs
    /// alone, exponents without digits, quotes, non-ASCII blanks, values beyond `f32`
    /// and `f64`, comments), with commas, blanks and ends of each kind.
    fn drawn_line(picks: &[(u8, u8, f64)]) -> String {
        const ODD: [&str; 26] = [
            "",
            "+",
            "-",
            ".",
            "e5",
            "1e",
            "1e+",
            "1.5.2",
            "--1",
            "0x1f",
            "1_0",
            "inf",
            "-Infinity",
            "NaN",
            "1e39",
            "-3.5e38",
            "1e400",
            "1e-400",
            "\"2.5\"",
            "\" 7 \"",
            "\u{a0}4\u{a0}",
            "#",
            "# 1,2,3",
            "٣",
            "\"3",
            "4\"",
        ];
        const SEP: [&str; 7] = [",", ", ", " ,", "\t,\t", ",,", " ", ",\u{2003}"];
        let mut line = String::new();
        for (k, &(token, sep, x)) in picks.iter().enumerate() {
            if k > 0 {
                line.push_str(SEP[usize::from(sep) % SEP.len()]);
            }
            let x = if x.is_finite() { x } else { 0.25 };
            let field = match token % 8 {
                0 => format!("{x}"),
                1 => format!("{x:e}"),
                2 => format!("{x:.17e}"),
                3 => format!("{:+}", x / 3.0),
                4 => format!("{}", x.trunc()),
                5 => format!(" {x:E} "),
                6 => format!("{}", x * 1e-300),
                _ => ODD[usize::from(token / 8) % ODD.len()].to_string(),
            };
            line.push_str(&field);
        }
        line
    }

    /// The plain reading of `line` (followed by the break `brk` and a further line)
    /// against [`parse_row`]'s: a row it reads holds the same values, bit for bit; a line
    /// it skips is blank or a comment; a line it leaves adds nothing; the line it reads
    /// ends before the break and the next starts after it.
    fn plain_agrees<T: Real>(line: &str, brk: &str, names: &[String]) -> bool {
        let text = format!("{line}{brk}1,2");
        let (mut plain, mut general) = (vec![-1.0], vec![-1.0]);
        let trimmed = line.trim();
        let ends = |end: usize, next: usize| end == line.len() && next == line.len() + brk.len();
        match plain_row::<T>(text.as_bytes(), 0, names.len(), &mut plain) {
            Some((Plain::Row, end, next)) => {
                ends(end, next)
                    && parse_row::<T>(trimmed, names, &mut general).is_ok()
                    && plain.len() == general.len()
                    && plain
                        .iter()
                        .zip(&general)
                        .all(|(a, b)| a.to_bits() == b.to_bits())
            }
            Some((Plain::Skipped, end, next)) => {
                ends(end, next)
                    && plain.len() == 1
                    && (trimmed.is_empty() || trimmed.starts_with('#'))
            }
            None => plain.len() == 1,
        }
    }

    #[test]
    fn the_plain_reading_of_a_row_is_the_general_one() {
        fn prop(picks: Vec<(u8, u8, f64)>, lead: u8) -> bool {
            let line = format!(
                "{}{}",
                [" ", "", "\t", "# "][usize::from(lead % 4)],
                drawn_line(&picks)
            );
            let brk = ["\n", "\r\n", "\r"][usize::from(lead / 4) % 3];
            (1..=4).all(|n| {
                let names: Vec<String> = (0..n).map(|j| format!("c{j}")).collect();
                plain_agrees::<f64>(&line, brk, &names) && plain_agrees::<f32>(&line, brk, &names)
            })
        }
        quickcheck::QuickCheck::new()
            .tests(3000)
            .rng(quickcheck::Gen::from_size_and_seed(6, 0x5eed))
            .quickcheck(prop as fn(Vec<(u8, u8, f64)>, u8) -> bool);
    }

    #[test]
    fn ordinary_rows_take_the_plain_reading() {
        let names: Vec<String> = ["f", "re", "im"].map(String::from).to_vec();
        let plain = |line: &str, out: &mut Vec<f64>| {
            plain_row::<f64>(line.as_bytes(), 0, 3, out).map(|(p, end, _)| (p, end))
        };
        for line in [
            "0.015915494309189534,6.0640006786585401,-0.081865599487377524",
            " 1.37e-2 , 9.99812e-1\t,-1.369e-2 ",
            "1,2,3",
            "+.5,5.,-0E+0",
        ] {
            let mut out = vec![];
            assert_eq!(
                plain(line, &mut out),
                Some((Plain::Row, line.len())),
                "{line}"
            );
            let mut general = vec![];
            parse_row::<f64>(line.trim(), &names, &mut general).unwrap();
            assert_eq!(out, general, "{line}");
        }
        for line in ["", "  \t", "# f,re,im", "  #"] {
            assert_eq!(plain(line, &mut vec![]), Some((Plain::Skipped, line.len())));
        }
        // left to the general reading, which names the fault or reads the quotes
        for line in ["1,2", "1,2,3,4", "1,x,3", "1,\"2\",3"] {
            let mut out = vec![];
            assert_eq!((plain(line, &mut out), out.len()), (None, 0), "{line}");
        }
        let mut out = vec![];
        assert_eq!(plain_row::<f32>(b"1,2,1e39", 0, 3, &mut out), None);
        assert!(out.is_empty());
    }

    #[test]
    fn the_first_bad_line_is_reported() {
        let mut text = file(300, Some(211));
        // a second fault later: not valid UTF-8
        text.extend_from_slice(b"1,2,\xff\n");
        let want = line_by_line(&text).unwrap_err();
        assert!(want.contains("x211"), "{want}");
        for (piece, part) in [(4 << 20, 64 << 10), (64, 16), (500, 3)] {
            for parallel in [true, false] {
                assert_eq!(in_pieces(&text, piece, part, parallel), Err(want.clone()));
            }
        }
        // alone, the UTF-8 fault and a line beyond the cap are named with their lines
        let mut text = file(40, None);
        text.extend_from_slice(b"1,2,\xff\n");
        assert_eq!(
            in_pieces(&text, 64, 16, true),
            Err(line_by_line(&text).unwrap_err())
        );
        let mut text = file(40, None);
        text.extend(std::iter::repeat_n(b'7', MAX_LINE_BYTES + 1));
        let want = line_by_line(&text).unwrap_err();
        assert!(want.contains("longer than"), "{want}");
        assert_eq!(in_pieces(&text, 1 << 16, 1 << 10, true), Err(want));
    }
}
