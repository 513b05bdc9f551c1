//! Functions for text that comes from files: UTF-8 decoding with the line and column of a bad
//! byte, line and column of a byte offset, input text quoted short in messages, and one line of
//! a stream read with a bound on its length ([`read_line_bounded`]).
//!
//! Every parser of gonio (budgets, instruments, recipes, optics, readings, logs) decodes its
//! bytes here, so that every text input refuses UTF-16 and Latin-1 alike, with a located message,
//! and skips a leading UTF-8 byte-order mark.

use thiserror::Error;

/// A text file that is not UTF-8, located at its first bad byte.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[non_exhaustive]
#[error("{line}:{column}: {message}")]
pub struct TextError {
    /// 1-based line (after a byte-order mark, if any).
    pub line: usize,
    /// 1-based column, in characters.
    pub column: usize,
    /// What was wrong and what was expected.
    pub message: String,
}

/// The UTF-8 text of `bytes`, a leading byte-order mark skipped (lines and columns then count
/// from after it).
///
/// # Errors
/// A UTF-16 file (it starts with a UTF-16 byte-order mark; at 1:1) or invalid UTF-8 at the line
/// and column of the first bad byte.
///
/// ```
/// use gonio_core::text::decode_utf8;
/// assert_eq!(decode_utf8(b"\xEF\xBB\xBF# comment\na,b\n").unwrap(), "# comment\na,b\n");
/// let e = decode_utf8(b"a,b\n1,temp\xE9rature\n").unwrap_err();
/// assert_eq!((e.line, e.column), (2, 7));
/// assert!(e.message.starts_with("invalid UTF-8 (byte 0xE9)"));
/// ```
pub fn decode_utf8(bytes: &[u8]) -> Result<&str, TextError> {
    if bytes.starts_with(&[0xFF, 0xFE]) || bytes.starts_with(&[0xFE, 0xFF]) {
        return Err(TextError {
            line: 1,
            column: 1,
            message: "the file is UTF-16 (it starts with a UTF-16 byte-order mark): expected UTF-8 text; save it as UTF-8".into(),
        });
    }
    let body = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    std::str::from_utf8(body).map_err(|e| {
        let good = e.valid_up_to();
        let prefix = std::str::from_utf8(&body[..good]).unwrap_or_default();
        let (line, column) = line_col(prefix, good);
        TextError {
            line,
            column,
            message: format!(
                "invalid UTF-8 (byte 0x{:02X}): expected UTF-8 text; save the file as UTF-8 (it may be Latin-1 or Windows-1252)",
                body[good]
            ),
        }
    })
}

/// 1-based line and column (in characters) of a byte offset in `text` (an offset inside a
/// character counts as that character; past the end, as the end).
///
/// ```
/// use gonio_core::text::line_col;
/// let t = "a = 1\nbé = x\n";
/// assert_eq!(line_col(t, 0), (1, 1));
/// assert_eq!(line_col(t, t.find('x').unwrap()), (2, 6));
/// ```
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let mut o = offset.min(text.len());
    while !text.is_char_boundary(o) {
        o -= 1;
    }
    let before = &text[..o];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

/// The longest input text (in characters) quoted whole in an error message; longer text is cut.
pub const MAX_QUOTED_CHARS: usize = 60;

/// Input text as quoted in messages: at most [`MAX_QUOTED_CHARS`] characters, longer text cut
/// with `…` and its length, and control characters (line breaks…) shown as `\u{..}` escapes, so
/// that a message stays one short line.
///
/// ```
/// use gonio_core::text::short;
/// assert_eq!(short("autocollimator"), "autocollimator");
/// let long = "x".repeat(65_536);
/// assert_eq!(short(&long), format!("{}… (65536 characters)", "x".repeat(40)));
/// assert_eq!(short("a\nb"), "a\\u{a}b");
/// ```
pub fn short(text: &str) -> String {
    let escape = |c: char, out: &mut String| {
        if c.is_control() {
            out.push_str(&c.escape_unicode().to_string());
        } else {
            out.push(c);
        }
    };
    let mut out = String::new();
    let n = text.chars().count();
    if n <= MAX_QUOTED_CHARS {
        text.chars().for_each(|c| escape(c, &mut out));
    } else {
        text.chars().take(40).for_each(|c| escape(c, &mut out));
        out.push_str(&format!("… ({n} characters)"));
    }
    out
}

/// A line of a stream that goes on beyond its bound, or a failed read.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum LineError {
    /// The stream could not be read.
    #[error("{0}")]
    Io(#[from] std::io::Error),
    /// More than `max_bytes` bytes came without a line end.
    #[error("a line longer than {max_bytes} bytes")]
    TooLong {
        /// The bound.
        max_bytes: usize,
    },
}

/// Reads one line of at most `max_bytes` bytes (its `\n` and a `\r` before it not counted,
/// nor returned) into `line`, which is cleared first; `false` at the end of the stream with
/// nothing read. Never holds more than `max_bytes` + the reader's buffer in memory, however long
/// the line (an endless line on a pipe is refused, not collected).
///
/// # Errors
/// [`LineError::TooLong`] as soon as the line passes `max_bytes`; [`LineError::Io`].
///
/// ```
/// use gonio_core::text::{read_line_bounded, LineError};
/// let mut input = &b"skip\r\nquit\n"[..];
/// let mut line = Vec::new();
/// assert!(read_line_bounded(&mut input, 16, &mut line).unwrap());
/// assert_eq!(line, b"skip");
/// assert!(read_line_bounded(&mut input, 16, &mut line).unwrap());
/// assert_eq!(line, b"quit");
/// assert!(!read_line_bounded(&mut input, 16, &mut line).unwrap());
/// let mut endless = std::io::repeat(b'x');
/// let mut reader = std::io::BufReader::new(&mut endless);
/// let e = read_line_bounded(&mut reader, 4096, &mut line).unwrap_err();
/// assert!(matches!(e, LineError::TooLong { max_bytes: 4096 }));
/// ```
pub fn read_line_bounded(
    r: &mut impl std::io::BufRead,
    max_bytes: usize,
    line: &mut Vec<u8>,
) -> Result<bool, LineError> {
    line.clear();
    let mut any = false;
    loop {
        let buf = match r.fill_buf() {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e.into()),
        };
        if buf.is_empty() {
            break;
        }
        any = true;
        let (take, end) = match buf.iter().position(|&b| b == b'\n') {
            Some(i) => (i, true),
            None => (buf.len(), false),
        };
        // A `\r` just before the `\n` may still come: allow one byte over until the end.
        if line.len() + take > max_bytes + 1 {
            return Err(LineError::TooLong { max_bytes });
        }
        line.extend_from_slice(&buf[..take]);
        r.consume(take + usize::from(end));
        if end {
            break;
        }
    }
    if line.last() == Some(&b'\r') {
        line.pop();
    }
    if line.len() > max_bytes {
        return Err(LineError::TooLong { max_bytes });
    }
    Ok(any)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utf16_and_latin1_are_located() {
        assert_eq!(decode_utf8(b"\xFF\xFEa\0").unwrap_err().line, 1);
        let e = decode_utf8(b"\xEF\xBB\xBFa\nb\nc\xFC\n").unwrap_err();
        assert_eq!((e.line, e.column), (3, 2));
        assert!(e.to_string().starts_with("3:2: invalid UTF-8 (byte 0xFC)"));
    }

    #[test]
    fn offsets_inside_a_character_and_past_the_end() {
        let t = "é\nx";
        assert_eq!(line_col(t, 1), (1, 1));
        assert_eq!(line_col(t, 99), (2, 2));
    }
}
