//! The serial output of an ELCOMAT-type electronic autocollimator (Möller-Wedel ELCOMAT 3000,
//! vario, HR): one reading a line, `TYPE STATUS X Y`, angles in arcseconds.
//!
//! ```text
//! 4 003 +12.345 -0.210      absolute reading (type 4, status 003)
//! 2 103 -0.512 +0.004       relative reading (type 2, status 103)
//! ```
//!
//! X is the polygon's angle (the one the shift-angle method uses), Y the tilt across it. What
//! the instrument sends varies with model, firmware and the program that logged it, so the
//! reader accepts: lines ended by CR (the instrument's own terminator), CR LF or LF; fields
//! separated by any run of spaces or tabs (or commas, semicolons); an explicit `+`, leading zeros,
//! a sign detached from its digits (`+  12.345`, fixed-width output), no decimal point; blank
//! lines and `#` comment lines (a logger's header). Any other line is an error naming the file,
//! line and column, including a status code other than 003 (absolute) or 103 (relative): the
//! instrument flags a reading it could not take properly with another code, and such a reading
//! must not enter a calibration silently.
//!
//! [`parse`] reads a whole log ([`LogError`] names every bad line); [`parse_reply`] reads one
//! answer of the instrument (the driver's view: a reading, a flagged reading, or garbage);
//! [`write()`] writes readings as the instrument sends them.
//!
//! ```
//! use gonio_lab::log::{self, Mode, Reply};
//! let r = log::parse("log", "4 003 +12.345 -0.210\r4 003 -0.500 +0.004\r").unwrap();
//! assert_eq!((r[0].x_arcsec, r[0].x_decimals, r[1].line), (12.345, 3, 2));
//! assert!(matches!(log::parse_reply("4 013 +1.000 +0.000"), Reply::Flagged { .. }));
//! assert_eq!(log::write(&[(1.25, -0.5)], Mode::Absolute, 3), "4 003 +1.250 -0.500\r");
//! ```

use std::fmt::Write as _;

/// A log with lines that are not readings: each bad line (up to ten) located.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub struct LogError {
    /// The log's name (its path) as given.
    pub name: String,
    /// The first bad lines (at most ten), in order.
    pub lines: Vec<LineError>,
    /// How many lines are bad in all.
    pub bad: usize,
}

/// One bad line of a log.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub struct LineError {
    /// Line, 1-based.
    pub line: usize,
    /// Column (in characters), 1-based.
    pub column: usize,
    /// What is wrong.
    pub message: String,
}

impl std::fmt::Display for LogError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let shown: Vec<String> = self
            .lines
            .iter()
            .map(|l| format!("{}:{}:{}: {}", self.name, l.line, l.column, l.message))
            .collect();
        let more = if self.bad > self.lines.len() {
            format!("; … {} more", self.bad - self.lines.len())
        } else {
            String::new()
        };
        write!(
            f,
            "{}{more} ({} line(s) are not autocollimator readings `4 003 X Y` or `2 103 X Y`)",
            shown.join("; "),
            self.bad
        )
    }
}

/// What one answer line of the instrument is.
#[derive(Debug, Clone, PartialEq)]
pub enum Reply {
    /// A reading: `4 003 X Y` or `2 103 X Y`.
    Reading {
        /// Absolute or relative.
        mode: Mode,
        /// X, arcsec.
        x_arcsec: f64,
        /// Y, arcsec.
        y_arcsec: f64,
        /// Decimals X was sent with.
        x_decimals: usize,
        /// Decimals Y was sent with.
        y_decimals: usize,
    },
    /// Four fields with numeric codes other than `4 003` / `2 103`: the instrument flagged the
    /// reading (it could not take it properly).
    Flagged {
        /// The type and status codes as sent (`4 013`).
        code: String,
    },
    /// Not an answer of the protocol (line noise, a half line, another device).
    Garbage {
        /// What is wrong.
        message: String,
    },
}

/// Reads one answer line (without its CR).
pub fn parse_reply(line: &str) -> Reply {
    match parse_line(line) {
        Ok((mode, x, y, x_decimals, y_decimals)) => Reply::Reading {
            mode,
            x_arcsec: x,
            y_arcsec: y,
            x_decimals,
            y_decimals,
        },
        Err(LineFault {
            flagged: Some(code),
            ..
        }) => Reply::Flagged { code },
        Err(f) => Reply::Garbage { message: f.message },
    }
}

/// Absolute or relative readings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// `4 003 X Y`: angles from the instrument's own zero.
    Absolute,
    /// `2 103 X Y`: angles from a zero the operator set.
    Relative,
}

gonio_core::choices!(Mode {
    Absolute => "absolute",
    Relative => "relative",
});

impl Mode {
    /// The request that asks the instrument for this kind of reading: `a` or `r`, then CR LF.
    pub fn request(self) -> &'static [u8] {
        match self {
            Mode::Absolute => b"a\r\n",
            Mode::Relative => b"r\r\n",
        }
    }

    /// The type and status codes of a good reading: (`4`, `003`) or (`2`, `103`).
    pub fn codes(self) -> (&'static str, &'static str) {
        match self {
            Mode::Absolute => ("4", "003"),
            Mode::Relative => ("2", "103"),
        }
    }
}

/// One reading of the log.
#[derive(Debug, Clone, PartialEq)]
pub struct LogReading {
    /// Line in the file (1-based; a CR, LF or CR LF ends a line).
    pub line: usize,
    /// Absolute or relative.
    pub mode: Mode,
    /// X, arcsec.
    pub x_arcsec: f64,
    /// Y, arcsec.
    pub y_arcsec: f64,
    /// Decimals X was written with (to write it back at the instrument's resolution).
    pub x_decimals: usize,
}

/// Splits text into lines ended by CR LF, CR or LF, with their 1-based numbers.
fn lines(text: &str) -> Vec<(usize, &str)> {
    let mut out = Vec::new();
    let bytes = text.as_bytes();
    let (mut start, mut i, mut n) = (0usize, 0usize, 1usize);
    while i < bytes.len() {
        match bytes[i] {
            b'\r' | b'\n' => {
                out.push((n, &text[start..i]));
                if bytes[i] == b'\r' && bytes.get(i + 1) == Some(&b'\n') {
                    i += 1;
                }
                n += 1;
                start = i + 1;
            }
            _ => {}
        }
        i += 1;
    }
    if start < bytes.len() {
        out.push((n, &text[start..]));
    }
    out
}

/// The fields of a line with their 1-based columns (in characters); a lone sign joins the next
/// field.
fn fields(line: &str) -> Vec<(usize, String)> {
    let mut raw: Vec<(usize, String)> = Vec::new();
    let mut cur: Option<(usize, String)> = None;
    for (col, ch) in line.chars().enumerate() {
        if ch.is_whitespace() || ch == ',' || ch == ';' {
            if let Some(f) = cur.take() {
                raw.push(f);
            }
        } else {
            cur.get_or_insert_with(|| (col + 1, String::new()))
                .1
                .push(ch);
        }
    }
    raw.extend(cur);
    let mut out: Vec<(usize, String)> = Vec::with_capacity(raw.len());
    let mut pending: Option<(usize, String)> = None;
    for (col, f) in raw {
        match pending.take() {
            Some((c, sign)) => out.push((c, sign + &f)),
            None if f == "+" || f == "-" || f == "−" => pending = Some((col, f)),
            None => out.push((col, f)),
        }
    }
    out.extend(pending);
    out
}

/// Parses an angle field: optional sign, digits, optional decimals; returns the value and the
/// number of decimals.
fn angle(field: &str) -> Option<(f64, usize)> {
    let f = field.replace('−', "-");
    let body = f.trim_start_matches(['+', '-']);
    if body.is_empty()
        || f.len() - body.len() > 1
        || !body.chars().all(|c| c.is_ascii_digit() || c == '.')
        || body.matches('.').count() > 1
        || !body.chars().any(|c| c.is_ascii_digit())
    {
        return None;
    }
    let v: f64 = f.parse().ok()?;
    let decimals = body.split_once('.').map_or(0, |(_, d)| d.len());
    v.is_finite().then_some((v, decimals))
}

/// Reads a log; every line that is not a reading, blank or a `#` comment is an error, and all of
/// them (up to ten) are named in one message.
///
/// # Errors
/// [`LogError`] when any line is not a reading.
pub fn parse(name: &str, text: &str) -> Result<Vec<LogReading>, LogError> {
    let mut readings = Vec::new();
    let mut errors: Vec<LineError> = Vec::new();
    let mut bad = 0usize;
    for (n, line) in lines(text) {
        let trimmed = line.trim();
        if trimmed.is_empty() || trimmed.starts_with('#') {
            continue;
        }
        match parse_line(line) {
            Ok((mode, x, y, x_decimals, _)) => readings.push(LogReading {
                line: n,
                mode,
                x_arcsec: x,
                y_arcsec: y,
                x_decimals,
            }),
            Err(f) => {
                bad += 1;
                if errors.len() < 10 {
                    errors.push(LineError {
                        line: n,
                        column: f.column,
                        message: f.message,
                    });
                }
            }
        }
    }
    if bad > 0 {
        return Err(LogError {
            name: name.to_string(),
            lines: errors,
            bad,
        });
    }
    Ok(readings)
}

/// What is wrong with a line: where, what, and the codes when the instrument flagged it.
struct LineFault {
    column: usize,
    message: String,
    flagged: Option<String>,
}

impl From<(usize, String)> for LineFault {
    fn from((column, message): (usize, String)) -> LineFault {
        LineFault {
            column,
            message,
            flagged: None,
        }
    }
}

/// One reading line: (mode, X, Y, decimals of X, decimals of Y) or what is wrong.
fn parse_line(line: &str) -> Result<(Mode, f64, f64, usize, usize), LineFault> {
    let f = fields(line);
    if f.len() < 4 {
        return Err(LineFault::from((
            f.last().map_or(1, |l| l.0),
            format!(
                "expected 4 fields `TYPE STATUS X Y` (e.g. `4 003 +12.345 -0.210`), found {}: {:?}",
                f.len(),
                line.trim()
            ),
        )));
    }
    if f.len() > 4 {
        return Err(LineFault::from((
            f[4].0,
            format!(
                "expected 4 fields `TYPE STATUS X Y`, found {}: {:?}",
                f.len(),
                line.trim()
            ),
        )));
    }
    let mode = match (f[0].1.as_str(), f[1].1.as_str()) {
        ("4", "003") => Mode::Absolute,
        ("2", "103") => Mode::Relative,
        (t, s)
            if t.chars().all(|c| c.is_ascii_digit()) && s.chars().all(|c| c.is_ascii_digit()) =>
        {
            return Err(LineFault {
                column: f[0].0,
                message: format!(
                    "status `{t} {s}`: expected `4 003` (absolute) or `2 103` (relative); another code means the instrument flagged the reading"
                ),
                flagged: Some(format!("{t} {s}")),
            });
        }
        _ => {
            return Err(LineFault::from((
                f[0].0,
                format!(
                    "expected the codes `4 003` or `2 103` first, found {:?}",
                    line.trim()
                ),
            )));
        }
    };
    let x = angle(&f[2].1).ok_or_else(|| {
        LineFault::from((
            f[2].0,
            format!("X: expected an angle in arcseconds, found {:?}", f[2].1),
        ))
    })?;
    let y = angle(&f[3].1).ok_or_else(|| {
        LineFault::from((
            f[3].0,
            format!("Y: expected an angle in arcseconds, found {:?}", f[3].1),
        ))
    })?;
    Ok((mode, x.0, y.0, x.1, y.1))
}

/// Writes readings as the instrument sends them: `4 003 +X.XXX +Y.YYY` (or `2 103 …`), each line
/// ended by CR, with `decimals` decimals.
pub fn write(readings: &[(f64, f64)], mode: Mode, decimals: usize) -> String {
    let (t, s) = mode.codes();
    let mut out = String::with_capacity(readings.len() * 24);
    for &(x, y) in readings {
        let _ = write!(out, "{t} {s} {x:+.decimals$} {y:+.decimals$}\r");
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn realistic_variations_parse() {
        let text = "# logged 2026-11-23\r\n4 003 +12.345 -0.210\r\n4 003 -0012.3 +0.0\r\n\n4\t003   +  7.5  -   1\r\r4 003 3,0\n2 103 −0.500 0.004";
        let r = parse("log", text).unwrap();
        assert_eq!(r.len(), 5);
        assert_eq!((r[0].line, r[0].x_arcsec, r[0].x_decimals), (2, 12.345, 3));
        assert_eq!((r[1].x_arcsec, r[1].x_decimals), (-12.3, 1));
        assert_eq!((r[2].line, r[2].x_arcsec, r[2].y_arcsec), (5, 7.5, -1.0));
        // CR CR leaves an empty line 6; a comma separates fields like a space.
        assert_eq!((r[3].line, r[3].x_arcsec, r[3].y_arcsec), (7, 3.0, 0.0));
        assert_eq!((r[4].mode, r[4].x_arcsec), (Mode::Relative, -0.5));
    }

    #[test]
    fn bad_lines_are_named_with_line_and_column() {
        let e = parse(
            "log",
            "4 003 1.0 2.0\r4 013 1.0 2.0\r4 003 1.x 2.0\rhello\r4 003 1 2 3\r",
        )
        .unwrap_err()
        .to_string();
        assert!(e.starts_with("log:2:1: status `4 013`"), "{e}");
        assert!(e.contains("log:3:7: X: expected an angle"), "{e}");
        assert!(e.contains("log:4:1: expected 4 fields"), "{e}");
        assert!(e.contains("log:5:11: expected 4 fields"), "{e}");
        assert!(e.contains("(4 line(s)"), "{e}");
        let e = parse("log", "4 003 nan 1\r").unwrap_err().to_string();
        assert!(e.starts_with("log:1:7: X"), "{e}");
        let e = parse("log", "4 003 ++1 1\r").unwrap_err().to_string();
        assert!(e.starts_with("log:1:7: X"), "{e}");
    }

    #[test]
    fn written_log_reads_back() {
        let w = write(&[(1.25, -0.5), (-0.001, 0.0)], Mode::Absolute, 3);
        assert_eq!(w, "4 003 +1.250 -0.500\r4 003 -0.001 +0.000\r");
        let r = parse("log", &w).unwrap();
        assert_eq!(r[1].x_arcsec, -0.001);
        assert_eq!(r[1].line, 2);
    }
}
