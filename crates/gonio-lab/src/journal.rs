//! The acquisition journal: every accepted (or skipped) position appended as one line and
//! synced to disk before the next position is asked for, so that a quit, a crash or a pulled
//! cable loses nothing and `--resume` continues after the last line.
//!
//! The journal is text, one record a line, fields separated by tabs (shown as spaces here):
//!
//! ```text
//! gonio-acquire-journal 1  plan=5c0f…  readings=48  mode=absolute
//! R  0  +1.2350  -0.1000  0.002  s:4 003 +1.234 -0.100  s:4 003 +1.236 -0.101  s:4 003 +1.235 -0.099
//! K  1  x:4 013 +9.000 +0.000
//! ```
//!
//! `R INDEX X Y SPREAD EXCHANGES…` is a reading of planned position INDEX (0-based, in measuring
//! order): the mean X and Y in arcseconds as written (the plan's `x_sign` not applied), the
//! spread of its samples; `K INDEX EXCHANGES…` a skipped position. The exchanges are what the
//! instrument sent while the position was measured: `s:` a sample of the reading, `d:` a sample
//! of a set read again (spread over the limit), `x:` an answer that is no reading (another
//! status code, garbage), bytes outside printable ASCII as `\xNN`. A later record of the same
//! position (a re-read) replaces the earlier. A last line without its line end (a crash while
//! writing) was never acknowledged and is dropped on resume.
//!
//! ```
//! use gonio_lab::journal::{Header, Journal, Record, Outcome};
//! let dir = tempfile::tempdir().unwrap();
//! let path = dir.path().join("r.csv.journal");
//! let header = Header { plan: 7, readings: 3, mode: gonio_lab::log::Mode::Absolute };
//! let mut j = Journal::create(&path, &header).unwrap();
//! j.append(&Record { index: 0, outcome: Outcome::Skipped, exchanges: vec![] }).unwrap();
//! drop(j);
//! let (_, records) = Journal::resume(&path, &header).unwrap();
//! assert_eq!(records[0].outcome, Outcome::Skipped);
//! ```

use crate::log::Mode;
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

const MAGIC: &str = "gonio-acquire-journal 1";

/// A plan's fingerprint as it is built ([`Header::plan`]): FNV-1a, 64 bits, stable across builds
/// and platforms.
///
/// ```
/// let mut f = gonio_lab::journal::Fingerprint::new();
/// f.eat(b"a");
/// assert_eq!(f.finish(), 0xaf63_dc4c_8601_ec8c);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Fingerprint(u64);

impl Default for Fingerprint {
    fn default() -> Self {
        Fingerprint(0xcbf2_9ce4_8422_2325)
    }
}

impl Fingerprint {
    /// An empty fingerprint.
    pub fn new() -> Fingerprint {
        Fingerprint::default()
    }

    /// Adds bytes.
    pub fn eat(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    /// The fingerprint.
    pub fn finish(self) -> u64 {
        self.0
    }
}

/// What the journal is for: a journal is resumed only for the same plan and mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Header {
    /// [`crate::plan::Plan::fingerprint`].
    pub plan: u64,
    /// Planned readings.
    pub readings: usize,
    /// Absolute or relative readings.
    pub mode: Mode,
}

impl Header {
    fn line(&self) -> String {
        format!(
            "{MAGIC}\tplan={:016x}\treadings={}\tmode={}",
            self.plan,
            self.readings,
            self.mode.name()
        )
    }
}

/// What one exchange was to the measurement.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExchangeKind {
    /// A sample of the accepted reading.
    Sample,
    /// A sample of a set read again (spread over the limit).
    Discarded,
    /// An answer that is no reading (another status code, garbage).
    Rejected,
}

impl ExchangeKind {
    fn tag(self) -> &'static str {
        match self {
            ExchangeKind::Sample => "s:",
            ExchangeKind::Discarded => "d:",
            ExchangeKind::Rejected => "x:",
        }
    }
}

/// A position's outcome.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Outcome {
    /// Read: mean X and Y, arcsec, as written (decimals kept), and the samples' spread.
    Read {
        /// Mean X, arcsec (the plan's `x_sign` not applied), e.g. `+1.2350`.
        x: String,
        /// Mean Y, arcsec.
        y: String,
        /// Spread (largest − smallest X) of the samples, arcsec.
        spread: String,
    },
    /// Skipped by the operator: missing in the readings.
    Skipped,
}

/// One journal line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Record {
    /// Planned position (0-based, measuring order).
    pub index: usize,
    /// Read or skipped.
    pub outcome: Outcome,
    /// What the instrument sent meanwhile.
    pub exchanges: Vec<(ExchangeKind, Vec<u8>)>,
}

/// Journal trouble, naming the journal.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum JournalError {
    /// Reading, writing or syncing failed.
    #[error("{path}: {reason}")]
    Io {
        /// The journal.
        path: PathBuf,
        /// What the system said.
        reason: String,
    },
    /// A journal is there and `--resume` was not asked for.
    #[error(
        "{path}: a journal of an earlier acquisition is there: continue it with --resume, or move it away to start again"
    )]
    Exists {
        /// The journal.
        path: PathBuf,
    },
    /// The journal is for another plan or mode.
    #[error("{path}: the journal is for {what}")]
    Mismatch {
        /// The journal.
        path: PathBuf,
        /// What differs.
        what: String,
    },
    /// A line is not a journal record.
    #[error("{path}:{line}:1: {message}")]
    Corrupt {
        /// The journal.
        path: PathBuf,
        /// Line, 1-based.
        line: usize,
        /// What is wrong.
        message: String,
    },
}

/// Escapes bytes as the journal and the raw log keep them: printable ASCII as is, others (and
/// `\`) as `\xNN`.
pub fn escape(bytes: &[u8]) -> String {
    let mut s = String::with_capacity(bytes.len());
    for &b in bytes {
        if (0x20..0x7f).contains(&b) && b != b'\\' {
            s.push(b as char);
        } else {
            s.push_str(&format!("\\x{b:02x}"));
        }
    }
    s
}

/// Reverses [`escape`]; `None` for a malformed escape.
pub fn unescape(s: &str) -> Option<Vec<u8>> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'\\' {
            let hex = s.get(i + 2..i + 4)?;
            if b.get(i + 1) != Some(&b'x') {
                return None;
            }
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 4;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    Some(out)
}

impl Record {
    fn line(&self) -> String {
        let mut s = match &self.outcome {
            Outcome::Read { x, y, spread } => format!("R\t{}\t{x}\t{y}\t{spread}", self.index),
            Outcome::Skipped => format!("K\t{}", self.index),
        };
        for (k, raw) in &self.exchanges {
            s.push('\t');
            s.push_str(k.tag());
            s.push_str(&escape(raw));
        }
        s.push('\n');
        s
    }

    fn parse(line: &str, readings: usize) -> Result<Record, String> {
        let f: Vec<&str> = line.split('\t').collect();
        let index = |s: &str| -> Result<usize, String> {
            s.parse::<usize>()
                .ok()
                .filter(|&i| i < readings)
                .ok_or_else(|| format!("position {s:?}: expected 0 to {}", readings - 1))
        };
        let number = |s: &str| -> Result<String, String> {
            s.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .map(|_| s.to_string())
                .ok_or_else(|| format!("{s:?}: expected a number of arcseconds"))
        };
        let (index, outcome, rest) = match f.as_slice() {
            ["R", i, x, y, spread, rest @ ..] => (
                index(i)?,
                Outcome::Read {
                    x: number(x)?,
                    y: number(y)?,
                    spread: number(spread)?,
                },
                rest,
            ),
            ["K", i, rest @ ..] => (index(i)?, Outcome::Skipped, rest),
            _ => {
                return Err("expected a record `R POSITION X Y SPREAD …` or `K POSITION …`".into());
            }
        };
        let exchanges = rest
            .iter()
            .map(|e| {
                let kind = match e.get(..2) {
                    Some("s:") => ExchangeKind::Sample,
                    Some("d:") => ExchangeKind::Discarded,
                    Some("x:") => ExchangeKind::Rejected,
                    _ => return Err(format!("{e:?}: expected an exchange `s:…`, `d:…` or `x:…`")),
                };
                unescape(&e[2..])
                    .map(|raw| (kind, raw))
                    .ok_or_else(|| format!("{e:?}: a malformed \\x escape"))
            })
            .collect::<Result<_, _>>()?;
        Ok(Record {
            index,
            outcome,
            exchanges,
        })
    }
}

/// An open journal, appended to.
#[derive(Debug)]
pub struct Journal {
    file: File,
    path: PathBuf,
}

/// The journal beside an output: `OUT.journal`.
pub fn path_for(out: &Path) -> PathBuf {
    let mut s = out.as_os_str().to_owned();
    s.push(".journal");
    PathBuf::from(s)
}

fn io(path: &Path, e: &std::io::Error) -> JournalError {
    JournalError::Io {
        path: path.to_path_buf(),
        reason: e.to_string(),
    }
}

/// Refuses a journal that is there (an earlier acquisition not to be overwritten).
///
/// # Errors
/// [`JournalError::Exists`].
pub fn ensure_new(path: &Path) -> Result<(), JournalError> {
    if path.exists() {
        return Err(JournalError::Exists {
            path: path.to_path_buf(),
        });
    }
    Ok(())
}

/// Syncs the directory holding `path`, so that a new file's name survives a crash.
fn sync_dir(path: &Path) -> std::io::Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    File::open(dir)?.sync_all()
}

impl Journal {
    /// Starts a new journal at `path`.
    ///
    /// # Errors
    /// [`JournalError::Exists`] when one is there; [`JournalError::Io`].
    pub fn create(path: &Path, header: &Header) -> Result<Journal, JournalError> {
        let mut file = OpenOptions::new()
            .append(true)
            .create_new(true)
            .open(path)
            .map_err(|e| {
                if e.kind() == std::io::ErrorKind::AlreadyExists {
                    JournalError::Exists {
                        path: path.to_path_buf(),
                    }
                } else {
                    io(path, &e)
                }
            })?;
        file.write_all(format!("{}\n", header.line()).as_bytes())
            .and_then(|()| file.sync_all())
            .and_then(|()| sync_dir(path))
            .map_err(|e| io(path, &e))?;
        Ok(Journal {
            file,
            path: path.to_path_buf(),
        })
    }

    /// Opens the journal at `path` to continue it: its records in order. A last line without
    /// its line end is cut off.
    ///
    /// # Errors
    /// [`JournalError::Mismatch`] for another plan or mode, [`JournalError::Corrupt`],
    /// [`JournalError::Io`].
    pub fn resume(path: &Path, header: &Header) -> Result<(Journal, Vec<Record>), JournalError> {
        let bytes = std::fs::read(path).map_err(|e| io(path, &e))?;
        let complete = bytes.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
        let corrupt = |line: usize, message: String| JournalError::Corrupt {
            path: path.to_path_buf(),
            line,
            message,
        };
        let text = std::str::from_utf8(&bytes[..complete])
            .map_err(|_| corrupt(1, "not text: not a gonio acquisition journal".into()))?;
        let mut lines = text.lines();
        let first = lines.next().unwrap_or("");
        let mut h = first.split('\t');
        if h.next() != Some(MAGIC) {
            return Err(corrupt(
                1,
                format!("expected `{MAGIC}`: not a gonio acquisition journal"),
            ));
        }
        let mut fields = std::collections::HashMap::new();
        for kv in h {
            if let Some((k, v)) = kv.split_once('=') {
                fields.insert(k, v);
            }
        }
        let plan = format!("{:016x}", header.plan);
        if fields.get("plan") != Some(&plan.as_str()) {
            return Err(JournalError::Mismatch {
                path: path.to_path_buf(),
                what: format!(
                    "another measuring plan (fingerprint {}, this plan's {plan})",
                    fields.get("plan").unwrap_or(&"none")
                ),
            });
        }
        if fields.get("mode") != Some(&header.mode.name()) {
            return Err(JournalError::Mismatch {
                path: path.to_path_buf(),
                what: format!(
                    "{} readings, not {}",
                    fields.get("mode").unwrap_or(&"unknown"),
                    header.mode.name()
                ),
            });
        }
        let records = lines
            .enumerate()
            .map(|(k, l)| Record::parse(l, header.readings).map_err(|m| corrupt(k + 2, m)))
            .collect::<Result<Vec<_>, _>>()?;
        let file = OpenOptions::new()
            .write(true)
            .open(path)
            .map_err(|e| io(path, &e))?;
        if complete < bytes.len() {
            file.set_len(complete as u64)
                .and_then(|()| file.sync_all())
                .map_err(|e| io(path, &e))?;
        }
        drop(file);
        let file = OpenOptions::new()
            .append(true)
            .open(path)
            .map_err(|e| io(path, &e))?;
        Ok((
            Journal {
                file,
                path: path.to_path_buf(),
            },
            records,
        ))
    }

    /// Appends a record and syncs it to disk.
    ///
    /// # Errors
    /// [`JournalError::Io`].
    pub fn append(&mut self, record: &Record) -> Result<(), JournalError> {
        self.file
            .write_all(record.line().as_bytes())
            .and_then(|()| self.file.sync_data())
            .map_err(|e| io(&self.path, &e))
    }

    /// Where the journal is.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_round_trip_and_a_torn_line_is_dropped() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("j");
        let h = Header {
            plan: 0xabc,
            readings: 5,
            mode: Mode::Relative,
        };
        let r0 = Record {
            index: 0,
            outcome: Outcome::Read {
                x: "+1.2350".into(),
                y: "-0.1000".into(),
                spread: "0.002".into(),
            },
            exchanges: vec![
                (ExchangeKind::Sample, b"2 103 +1.234 -0.100".to_vec()),
                (ExchangeKind::Rejected, b"\xff\t\\ junk".to_vec()),
            ],
        };
        let mut j = Journal::create(&path, &h).unwrap();
        j.append(&r0).unwrap();
        drop(j);
        assert!(matches!(
            Journal::create(&path, &h),
            Err(JournalError::Exists { .. })
        ));
        // A crash half way through the second record.
        let mut f = OpenOptions::new().append(true).open(&path).unwrap();
        f.write_all(b"R\t1\t+0.5").unwrap();
        drop(f);
        let (mut j, recs) = Journal::resume(&path, &h).unwrap();
        assert_eq!(recs, vec![r0.clone()]);
        j.append(&Record {
            index: 1,
            outcome: Outcome::Skipped,
            exchanges: vec![],
        })
        .unwrap();
        drop(j);
        let (_, recs) = Journal::resume(&path, &h).unwrap();
        assert_eq!(recs.len(), 2);
        assert_eq!(recs[1].outcome, Outcome::Skipped);
        let other = Header { plan: 1, ..h };
        let e = Journal::resume(&path, &other).unwrap_err().to_string();
        assert!(e.contains("another measuring plan"), "{e}");
        std::fs::write(&path, format!("{}\nR\t9\t1\t1\t0\n", h.line())).unwrap();
        let e = Journal::resume(&path, &h).unwrap_err().to_string();
        assert!(e.ends_with(":2:1: position \"9\": expected 0 to 4"), "{e}");
    }
}
