//! The lines of a text data file, read with bounded memory: line breaks `\n`, `\r\n` or a
//! lone `\r`, 1-based line numbers, a byte-order mark ignored, and no line longer than
//! [`MAX_LINE_BYTES`].

use crate::error::FdidError;
use std::io::{BufRead, Read};

/// The longest line a data file may hold, in bytes (1 MiB): a longer one is refused with
/// its line number instead of being read into memory without bound (a file without line
/// breaks, a binary file).
pub const MAX_LINE_BYTES: usize = 1 << 20;

/// Reads the lines of a text file one at a time.
pub(crate) struct LineReader<R: Read> {
    reader: std::io::BufReader<R>,
    /// The line read last, validated as UTF-8 (its bytes are reused for the next one).
    text: String,
    line: usize,
    /// The last line ended with `\r`: a `\n` right after it belongs to that break.
    after_cr: bool,
    /// A byte-order mark at the start of line 1 is dropped (the start of a file).
    bom: bool,
    /// The byte that starts a comment: the bytes after it on a line that is not UTF-8 are
    /// read as Latin-1 (a comment is not data, and vendors' files carry such bytes).
    comment: Option<u8>,
}

/// A failure of [`LineReader::next_line`], turned into an error once the file name is
/// known ([`LineError::into_error`]).
#[derive(Debug)]
pub(crate) enum LineError {
    /// Reading failed.
    Io(std::io::Error),
    /// The line (1-based) is not valid UTF-8.
    Utf8(usize),
    /// The line (1-based) is longer than [`MAX_LINE_BYTES`].
    TooLong(usize),
}

impl LineError {
    /// The error of file `name`.
    pub(crate) fn into_error(self, name: &str) -> FdidError {
        let parse = |line, message: String| FdidError::Parse {
            path: name.to_string(),
            line,
            message,
        };
        match self {
            Self::Io(e) => FdidError::Io(format!("{name}: {e}")),
            Self::Utf8(line) => parse(line, "the line is not valid UTF-8 text".into()),
            Self::TooLong(line) => parse(
                line,
                format!(
                    "the line is longer than {MAX_LINE_BYTES} bytes (1 MiB): a data file has \
                     one row per line (is this a binary file, or one without line breaks?)"
                ),
            ),
        }
    }
}

impl<R: Read> LineReader<R> {
    /// A reader at the start of `reader`.
    pub(crate) fn new(reader: R) -> Self {
        Self {
            reader: std::io::BufReader::new(reader),
            text: String::new(),
            line: 0,
            after_cr: false,
            bom: true,
            comment: None,
        }
    }

    /// A reader at the start of `reader` whose comments start with `marker`: a line that
    /// is not UTF-8 is read when its bytes before the first `marker` are, the comment then
    /// as Latin-1 (each byte the character of that code).
    pub(crate) fn with_comments(reader: R, marker: u8) -> Self {
        Self {
            comment: Some(marker),
            ..Self::new(reader)
        }
    }

    /// A reader of text that continues a file after its line `line` (a byte-order mark is
    /// then data, and the first line read is numbered `line + 1`).
    pub(crate) fn continuing(reader: R, line: usize) -> Self {
        Self {
            line,
            bom: false,
            ..Self::new(reader)
        }
    }

    /// The bytes not read yet, with the number of the line read last: for a reader that
    /// goes on in larger pieces. A `\n` that completes a `\r\n` after the last line is
    /// skipped when it is already buffered and otherwise reported (the flag is true).
    pub(crate) fn into_rest(mut self) -> (usize, bool, std::io::BufReader<R>) {
        let next = self.reader.buffer().first().copied();
        if self.after_cr && next == Some(b'\n') {
            self.reader.consume(1);
        }
        (self.line, self.after_cr && next.is_none(), self.reader)
    }

    /// The next line without its line break, with its 1-based number; `None` at the end.
    pub(crate) fn next_line(&mut self) -> Result<Option<(usize, &str)>, LineError> {
        if !self.advance()? {
            return Ok(None);
        }
        Ok(Some((self.line, self.current())))
    }

    /// The text of the line [`Self::next_line`] or [`Self::advance`] read last (empty
    /// before the first).
    pub(crate) fn current(&self) -> &str {
        let text = self.text.as_str();
        if self.line == 1 && self.bom {
            text.strip_prefix('\u{feff}').unwrap_or(text)
        } else {
            text
        }
    }

    /// Reads the next line into the buffer ([`Self::current`]) and checks that it is
    /// UTF-8; false at the end.
    pub(crate) fn advance(&mut self) -> Result<bool, LineError> {
        let mut buf = std::mem::take(&mut self.text).into_bytes();
        buf.clear();
        let mut found = false;
        loop {
            let chunk = self.reader.fill_buf().map_err(LineError::Io)?;
            if chunk.is_empty() {
                break;
            }
            let skip = usize::from(std::mem::take(&mut self.after_cr) && chunk[0] == b'\n');
            let rest = &chunk[skip..];
            let end = memchr::memchr2(b'\n', b'\r', rest);
            let take = end.unwrap_or(rest.len());
            if buf.len() + take > MAX_LINE_BYTES {
                return Err(LineError::TooLong(self.line + 1));
            }
            buf.extend_from_slice(&rest[..take]);
            found |= take > 0 || end.is_some();
            match end {
                Some(p) => {
                    self.after_cr = rest[p] == b'\r';
                    self.reader.consume(skip + p + 1);
                    break;
                }
                None => {
                    let n = chunk.len();
                    self.reader.consume(n);
                }
            }
        }
        if !found {
            return Ok(false);
        }
        self.line += 1;
        self.text = match String::from_utf8(buf) {
            Ok(text) => text,
            Err(e) => {
                let bytes = e.into_bytes();
                latin1_comment(&bytes, self.comment).ok_or(LineError::Utf8(self.line))?
            }
        };
        Ok(true)
    }

    /// The number of the line read last (1-based; 0 before the first).
    pub(crate) fn line(&self) -> usize {
        self.line
    }
}

/// `bytes` (not UTF-8) as text when those before the first `marker` are UTF-8: the
/// comment from the marker on read as Latin-1; `None` otherwise.
fn latin1_comment(bytes: &[u8], marker: Option<u8>) -> Option<String> {
    let at = memchr::memchr(marker?, bytes)?;
    let mut text = std::str::from_utf8(&bytes[..at]).ok()?.to_string();
    text.extend(bytes[at..].iter().map(|&b| char::from(b)));
    Some(text)
}

/// The whole text of `reader` with every line break as `\n` (so that `str::lines`
/// numbers the lines as the file does), without a byte-order mark; errors name `name`.
pub(crate) fn read_text<R: Read>(reader: R, name: &str) -> crate::error::Result<String> {
    read_lines(LineReader::new(reader), name)
}

/// [`read_text`] of a file whose comments start with `marker`, read as Latin-1 where
/// they are not UTF-8 ([`LineReader::with_comments`]).
pub(crate) fn read_text_with_comments<R: Read>(
    reader: R,
    name: &str,
    marker: u8,
) -> crate::error::Result<String> {
    read_lines(LineReader::with_comments(reader, marker), name)
}

/// The text of the lines of `lines`, each ended by `\n`.
fn read_lines<R: Read>(mut lines: LineReader<R>, name: &str) -> crate::error::Result<String> {
    let mut text = String::new();
    while let Some((_, line)) = lines.next_line().map_err(|e| e.into_error(name))? {
        text.push_str(line);
        text.push('\n');
    }
    Ok(text)
}

/// A value from a file as echoed in a message: [`printable`] with at most 200
/// characters, so that an error stays one readable line.
pub(crate) fn echo(value: &str) -> String {
    printable(value, 200)
}

/// `text` cut to at most `max` characters (then `…`) with its control characters escaped
/// (`\u{0}`, `\t`, `\n`): safe to print on one line of a terminal.
///
/// ```
/// assert_eq!(fdid::io::printable("a\u{0}b", 10), "a\\u{0}b");
/// assert_eq!(fdid::io::printable("abcdef", 3), "abc…");
/// ```
pub fn printable(text: &str, max: usize) -> String {
    let mut out = String::new();
    for (i, c) in text.chars().enumerate() {
        if i == max {
            out.push('…');
            break;
        }
        if c.is_control() {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn all(bytes: &[u8]) -> Vec<(usize, String)> {
        let mut r = LineReader::new(bytes);
        let mut v = vec![];
        while let Some((n, l)) = r.next_line().unwrap() {
            v.push((n, l.to_string()));
        }
        v
    }

    #[test]
    fn every_line_break_counts_once() {
        let want: Vec<(usize, String)> = vec![(1, "a".into()), (2, "".into()), (3, "b".into())];
        assert_eq!(all(b"a\n\nb\n"), want);
        assert_eq!(all(b"a\r\n\r\nb"), want);
        assert_eq!(all(b"a\r\rb\r"), want);
        assert_eq!(all(b"\xef\xbb\xbfa\n\nb"), want);
        assert!(all(b"").is_empty());
    }

    #[test]
    fn a_crlf_split_across_reads_is_one_break() {
        // a reader that returns one byte per read
        struct Slow<'a>(&'a [u8]);
        impl Read for Slow<'_> {
            fn read(&mut self, out: &mut [u8]) -> std::io::Result<usize> {
                match self.0.split_first() {
                    Some((b, rest)) if !out.is_empty() => {
                        out[0] = *b;
                        self.0 = rest;
                        Ok(1)
                    }
                    _ => Ok(0),
                }
            }
        }
        let mut r = LineReader::new(Slow(b"x\r\ny\r\n\r\nz"));
        let mut v = vec![];
        while let Some((n, l)) = r.next_line().unwrap() {
            v.push((n, l.to_string()));
        }
        assert_eq!(
            v,
            vec![
                (1, "x".into()),
                (2, "y".into()),
                (3, "".into()),
                (4, "z".into())
            ]
        );
    }

    #[test]
    fn a_line_beyond_the_cap_is_refused_with_its_number() {
        let mut bytes = b"f,re,im\n1,2,3\n".to_vec();
        bytes.extend(std::iter::repeat_n(b'7', MAX_LINE_BYTES + 1));
        let mut r = LineReader::new(&bytes[..]);
        assert!(r.next_line().unwrap().is_some());
        assert!(r.next_line().unwrap().is_some());
        assert!(matches!(r.next_line(), Err(LineError::TooLong(3))));
        // exactly at the cap is fine
        let ok = vec![b'7'; MAX_LINE_BYTES];
        assert_eq!(
            LineReader::new(&ok[..])
                .next_line()
                .unwrap()
                .unwrap()
                .1
                .len(),
            MAX_LINE_BYTES
        );
    }

    #[test]
    fn latin1_bytes_of_a_comment_are_read_and_of_data_refused() {
        // 0xB0 (the degree sign in Latin-1) is not UTF-8 on its own
        let bytes = b"! 25\xB0C, S-parameters\n1e6 0.5 0\n2e6 0.5 0 ! \xE9t\xE9\n".to_vec();
        let text = read_text_with_comments(&bytes[..], "zx.s1p", b'!').unwrap();
        assert_eq!(
            text,
            "! 25\u{b0}C, S-parameters\n1e6 0.5 0\n2e6 0.5 0 ! \u{e9}t\u{e9}\n"
        );
        // without the comment marker, or before it, the line is refused with its number
        let err = read_text(&bytes[..], "zx.s1p").unwrap_err().to_string();
        assert!(err.contains("line 1") && err.contains("UTF-8"), "{err}");
        let data = b"! ok\n1e6 0.\xB05 0\n".to_vec();
        let err = read_text_with_comments(&data[..], "zx.s1p", b'!')
            .unwrap_err()
            .to_string();
        assert!(err.contains("line 2") && err.contains("UTF-8"), "{err}");
    }

    #[test]
    fn echoes_are_short_and_printable() {
        assert_eq!(echo("1.5e3"), "1.5e3");
        assert_eq!(echo("a\u{0}b\tc\u{1b}"), "a\\u{0}b\\tc\\u{1b}");
        let long = "9".repeat(100_000);
        let e = echo(&long);
        assert_eq!(e.chars().count(), 201);
        assert!(e.ends_with('…'));
    }
}
