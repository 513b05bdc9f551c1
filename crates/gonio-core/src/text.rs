//! Functions for text that comes from files: UTF-8 decoding with the line and column of a bad
//! byte, line and column of a byte offset, and input text quoted short in messages.
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
