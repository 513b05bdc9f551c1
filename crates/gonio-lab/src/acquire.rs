//! The acquisition: a measuring plan (any [`Sequence`]: the shift-angle plan, an axis's test
//! cycle) walked position by position, each position read from the autocollimator as the mean
//! of K samples, checked, and journalled before the next.
//!
//! For every planned position [`Acquisition::measure`] asks the instrument for K samples
//! ([`Settings::samples`]). An answer that is no reading (another status code: the instrument
//! flagged it; garbage; a reading of the other kind) is never a sample: it is kept in the
//! journal as rejected and the sample is asked for again, up to [`Settings::rejects`] times in a
//! row, then the operator decides ([`Attempt::Faulty`]). When the K samples spread (largest −
//! smallest X) more than [`Settings::max_spread_arcsec`] the set is read again, up to
//! [`Settings::rereads`] times, then the operator decides ([`Attempt::SpreadOver`]). An accepted
//! reading is the mean of its samples, written with one decimal more than the instrument sent
//! (K > 1; with K = 1 as sent). [`Acquisition::commit`] appends it to the journal and syncs
//! before the caller asks for the next position.
//!
//! Checks as the readings come in ([`Acquisition::checks`]), against the earlier position the
//! plan names ([`Sequence::partners`]): the closure of a run (its closure reading against its
//! step 1) and the drift between repeats (a repeat against repeat 1 of the same shift, start
//! face and step), each with the limit 3·√2·σ/√K from the autocollimator's σ per sample
//! ([`Settings::sigma_arcsec`]), which a plan may widen ([`Sequence::check_limit_arcsec`]).
//!
//! ```
//! use gonio_lab::acquire::{Acquisition, Settings};
//! use gonio_lab::plan::Plan;
//! let plan = Plan::parse_text("p", "faces = 3\nshifts_deg = [0]\nstart_faces = [1]\n").unwrap();
//! let dir = tempfile::tempdir().unwrap();
//! let j = dir.path().join("r.csv.journal");
//! let mut a = Acquisition::start(plan, Settings::default(), &j, false).unwrap();
//! assert_eq!(a.next(), Some(0));
//! a.skip(0, vec![]).unwrap();
//! assert_eq!((a.next(), a.missing()), (Some(1), 1));
//! ```

use crate::instrument::{Autocollimator, InstrumentError, Transport};
use crate::journal::{self, ExchangeKind, Header, Journal, JournalError, Outcome, Record};
use crate::log::{Mode, Reply};
use crate::plan::{ModeRule, Plan, PlannedReading};
use crate::readings::Row;
pub use crate::sequence::CheckKind;
use crate::sequence::Sequence;
use gonio_core::bound::{Bound, Num, OutOfBound};
use std::path::Path;

/// How positions are read and checked.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// Absolute (`a`) or relative (`r`) readings.
    pub mode: Mode,
    /// Samples averaged per position (K ≥ 1).
    pub samples: usize,
    /// Largest spread of one position's samples, arcsec.
    pub max_spread_arcsec: f64,
    /// Sets read again when the spread is over the limit, before the operator is asked.
    pub rereads: u32,
    /// Answers in a row that are no reading before the operator is asked.
    pub rejects: u32,
    /// The autocollimator's standard deviation of one sample, arcsec (the checks' limits).
    pub sigma_arcsec: f64,
}

/// What the operator asks of an acquisition, before it is checked against the plan
/// ([`Settings::for_plan`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Requested {
    /// The readings' mode, or `None` for the one the plan's rule gives.
    pub mode: Option<Mode>,
    /// Samples averaged per position.
    pub samples: usize,
    /// Largest spread of one position's samples, arcsec, or `None` for 5σ.
    pub max_spread_arcsec: Option<f64>,
    /// Sets read again when the spread is over the limit.
    pub rereads: u32,
    /// The autocollimator's standard deviation of one sample, arcsec.
    pub sigma_arcsec: f64,
}

impl Settings {
    /// The settings of an acquisition through `plan` (named `plan_name` in errors): the mode
    /// asked for, which must agree with the plan's rule, or the rule's (absolute unless the
    /// plan says relative); the spread limit 5σ unless one is given; 3 rejects. The bounds are
    /// checked when the acquisition starts ([`Acquisition::start`]).
    ///
    /// # Errors
    /// [`AcquireError::ModeConflict`]: a mode the plan's rule refuses.
    pub fn for_plan(
        asked: &Requested,
        plan: &impl Sequence,
        plan_name: &str,
    ) -> Result<Settings, AcquireError> {
        let rule = plan.mode();
        let mode = match (asked.mode, rule) {
            (None, ModeRule::Relative) => Mode::Relative,
            (None, _) => Mode::Absolute,
            (Some(m @ Mode::Absolute), ModeRule::Relative)
            | (Some(m @ Mode::Relative), ModeRule::Absolute) => {
                return Err(AcquireError::ModeConflict {
                    given: m,
                    plan: plan_name.to_string(),
                    plan_mode: if rule == ModeRule::Relative {
                        "relative"
                    } else {
                        "absolute"
                    },
                });
            }
            (Some(m), _) => m,
        };
        Ok(Settings {
            mode,
            samples: asked.samples,
            max_spread_arcsec: asked.max_spread_arcsec.unwrap_or(5.0 * asked.sigma_arcsec),
            rereads: asked.rereads,
            rejects: 3,
            sigma_arcsec: asked.sigma_arcsec,
        })
    }
}

impl Default for Settings {
    /// Absolute, 3 samples, σ = 0.05″, spread limit 5σ, 3 re-reads, 3 rejects.
    fn default() -> Self {
        Settings {
            mode: Mode::Absolute,
            samples: 3,
            max_spread_arcsec: 0.25,
            rereads: 3,
            rejects: 3,
            sigma_arcsec: 0.05,
        }
    }
}

/// Samples averaged per position ([`Settings::samples`]).
pub const SAMPLES: Bound = Bound::new(1.0, 1000.0, "");
/// The instrument's σ of one sample ([`Settings::sigma_arcsec`]): an autocollimator's is a few
/// hundredths of an arcsecond.
pub const SIGMA_ARCSEC: Bound = Bound::new(0.0, 100.0, "″").lo_excluded();
/// The spread limit of one position's samples ([`Settings::max_spread_arcsec`]): an
/// autocollimator's whole range is a few thousand arcseconds.
pub const MAX_SPREAD_ARCSEC: Bound = Bound::new(0.0, 10_000.0, "″");
/// Re-reads before the operator is asked ([`Settings::rereads`]) and rejected answers in a row
/// ([`Settings::rejects`]).
pub const REREADS: Bound = Bound::new(0.0, 100.0, "");
/// The wait for one answer (the driver's `timeout`): long enough for 50 baud, short enough that
/// a silent instrument is noticed.
pub const ANSWER_TIMEOUT_S: Bound = Bound::new(0.05, 60.0, "s");

impl Settings {
    /// Checks every setting against its bound ([`SAMPLES`], [`SIGMA_ARCSEC`],
    /// [`MAX_SPREAD_ARCSEC`], [`REREADS`]).
    ///
    /// # Errors
    /// [`AcquireError::Setting`] naming the first setting out of its bound.
    pub fn validate(&self) -> Result<(), AcquireError> {
        let bad = |name: &'static str, e: OutOfBound| AcquireError::Setting { name, error: e };
        SAMPLES
            .check_int(self.samples as u64)
            .map_err(|e| bad("samples", e))?;
        SIGMA_ARCSEC
            .check(self.sigma_arcsec)
            .map_err(|e| bad("sigma_arcsec", e))?;
        MAX_SPREAD_ARCSEC
            .check(self.max_spread_arcsec)
            .map_err(|e| bad("max_spread_arcsec", e))?;
        REREADS
            .check_int(self.rereads)
            .map_err(|e| bad("rereads", e))?;
        REREADS
            .check_int(self.rejects)
            .map_err(|e| bad("rejects", e))?;
        Ok(())
    }

    /// The limit of a closure or drift: 3·√2·σ/√K, arcsec.
    pub fn check_limit_arcsec(&self) -> f64 {
        3.0 * std::f64::consts::SQRT_2 * self.sigma_arcsec / (self.samples.max(1) as f64).sqrt()
    }
}

/// Trouble while acquiring.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum AcquireError {
    /// The instrument or its port.
    #[error(transparent)]
    Instrument(#[from] InstrumentError),
    /// The journal.
    #[error(transparent)]
    Journal(#[from] JournalError),
    /// A setting out of its bound.
    #[error("{name} = {}: {error}", Num(error.value))]
    Setting {
        /// The setting ([`Settings`]' field).
        name: &'static str,
        /// The bound it broke.
        error: OutOfBound,
    },
    /// The mode asked for is not the one the plan says (the flag `--mode`).
    #[error("--mode {given}: the plan {plan} says mode = \"{plan_mode}\"")]
    ModeConflict {
        /// The mode asked for.
        given: Mode,
        /// The plan's name.
        plan: String,
        /// The plan's mode (`absolute` or `relative`).
        plan_mode: &'static str,
    },
    /// A position that is not in the plan.
    #[error("position {index} is not in the plan's {planned} readings")]
    NoSuchPosition {
        /// The position asked for.
        index: usize,
        /// Planned readings.
        planned: usize,
    },
}

/// The result of measuring one position.
#[derive(Debug, Clone, PartialEq)]
pub enum Attempt {
    /// Read: the record to [`Acquisition::commit`].
    Accepted(Record),
    /// Every set of samples spread more than the limit; `record` is the last set's mean, to
    /// commit if the operator accepts it.
    SpreadOver {
        /// The last set's spread, arcsec.
        spread_arcsec: f64,
        /// The last set as a record.
        record: Record,
    },
    /// The instrument answered with no reading too many times in a row.
    Faulty {
        /// The last answer and what was wrong with it.
        reason: String,
        /// What it sent.
        exchanges: Vec<(ExchangeKind, Vec<u8>)>,
    },
}

/// A check of a reading against an earlier one (`P` the plan's position).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Check<P = PlannedReading> {
    /// Closure or drift.
    pub kind: CheckKind,
    /// This reading minus the earlier, arcsec.
    pub value_arcsec: f64,
    /// The limit, arcsec (3·√2·σ/√K, or the plan's).
    pub limit_arcsec: f64,
    /// The reading checked.
    pub reading: P,
}

impl<P> Check<P> {
    /// Whether the difference is within the limit.
    pub fn ok(&self) -> bool {
        self.value_arcsec.abs() <= self.limit_arcsec
    }
}

/// A plan being acquired (a shift-angle plan by default).
#[derive(Debug)]
pub struct Acquisition<S: Sequence = Plan> {
    plan: S,
    planned: Vec<S::Position>,
    /// Per position: the earlier position it is checked against.
    partners: Vec<Option<(CheckKind, usize)>>,
    settings: Settings,
    journal: Journal,
    /// Every record in the order committed (re-reads included).
    history: Vec<Record>,
    /// Per position: its latest record in `history`.
    current: Vec<Option<usize>>,
    next: usize,
    last: Option<usize>,
}

/// Decimals of a number as written (`+1.2350` → 4).
fn decimals_of(s: &str) -> usize {
    s.split_once('.').map_or(0, |(_, d)| d.len())
}

impl<S: Sequence> Acquisition<S> {
    /// Starts acquiring `plan` with a new journal at `journal_path`, or continues the journal
    /// there (`resume`; a new one when there is none).
    ///
    /// # Errors
    /// [`AcquireError::Setting`] for a setting out of its bound; [`JournalError`]: a journal is
    /// there without `resume`, or is for another plan or mode.
    pub fn start(
        plan: S,
        settings: Settings,
        journal_path: &Path,
        resume: bool,
    ) -> Result<Acquisition<S>, AcquireError> {
        settings.validate()?;
        let planned = plan.positions();
        let header = Header {
            plan: plan.fingerprint(),
            readings: planned.len(),
            mode: settings.mode,
        };
        let (journal, records) = if resume && journal_path.exists() {
            Journal::resume(journal_path, &header)?
        } else {
            (Journal::create(journal_path, &header)?, Vec::new())
        };
        let partners = plan.partners(&planned);
        let mut a = Acquisition {
            current: vec![None; planned.len()],
            partners,
            plan,
            planned,
            settings,
            journal,
            history: Vec::new(),
            next: 0,
            last: None,
        };
        for r in records {
            a.note(r);
        }
        Ok(a)
    }

    fn note(&mut self, r: Record) {
        let i = r.index;
        self.current[i] = Some(self.history.len());
        self.history.push(r);
        self.last = Some(i);
        self.next = self.next.max(i + 1);
    }

    /// The plan.
    pub fn plan(&self) -> &S {
        &self.plan
    }

    /// The settings.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// Every planned reading, in measuring order.
    pub fn planned(&self) -> &[S::Position] {
        &self.planned
    }

    /// The journal's path.
    pub fn journal_path(&self) -> &Path {
        self.journal.path()
    }

    /// The next position to measure, `None` when the plan is complete.
    pub fn next(&self) -> Option<usize> {
        (self.next < self.planned.len()).then_some(self.next)
    }

    /// The position measured (or skipped) last, to read again.
    pub fn last(&self) -> Option<usize> {
        self.last
    }

    /// Positions done (read or skipped).
    pub fn done(&self) -> usize {
        self.current.iter().filter(|c| c.is_some()).count()
    }

    /// Positions skipped (missing in the readings).
    pub fn missing(&self) -> usize {
        self.current
            .iter()
            .flatten()
            .filter(|&&h| self.history[h].outcome == Outcome::Skipped)
            .count()
    }

    /// The latest record of a position.
    pub fn record(&self, index: usize) -> Option<&Record> {
        self.current
            .get(index)
            .copied()
            .flatten()
            .map(|h| &self.history[h])
    }

    /// The reading of a position as it goes into the CSV (x_sign applied), arcsec.
    pub fn value(&self, index: usize) -> Option<f64> {
        match &self.record(index)?.outcome {
            Outcome::Read { x, .. } => x.parse::<f64>().ok().map(|v| self.plan.x_sign() * v),
            Outcome::Skipped => None,
        }
    }

    /// Reads position `index` from the instrument (see the module's documentation).
    ///
    /// # Errors
    /// [`AcquireError::Instrument`]: a silent instrument or a lost port.
    pub fn measure<T: Transport>(
        &self,
        instrument: &mut Autocollimator<T>,
        index: usize,
    ) -> Result<Attempt, AcquireError> {
        if index >= self.planned.len() {
            return Err(AcquireError::NoSuchPosition {
                index,
                planned: self.planned.len(),
            });
        }
        let s = &self.settings;
        let k = s.samples.max(1);
        let mut exchanges: Vec<(ExchangeKind, Vec<u8>)> = Vec::new();
        let mut attempt = 0;
        loop {
            let mut set: Vec<(f64, f64, usize, usize)> = Vec::with_capacity(k);
            let first_in_set = exchanges.len();
            let mut rejects = 0;
            while set.len() < k {
                let e = instrument.read(s.mode)?;
                let fault = match e.reply {
                    Reply::Reading {
                        mode,
                        x_arcsec,
                        y_arcsec,
                        x_decimals,
                        y_decimals,
                    } if mode == s.mode => {
                        set.push((x_arcsec, y_arcsec, x_decimals, y_decimals));
                        exchanges.push((ExchangeKind::Sample, e.raw));
                        continue;
                    }
                    Reply::Reading { mode, .. } => {
                        format!("a {} reading, asked for {}", mode.name(), s.mode.name())
                    }
                    Reply::Flagged { code } => {
                        format!("status `{code}`: the instrument flagged the reading")
                    }
                    Reply::Garbage { message } => format!("not an answer ({message})"),
                };
                let shown = journal::escape(&e.raw);
                exchanges.push((ExchangeKind::Rejected, e.raw));
                rejects += 1;
                if rejects > s.rejects {
                    // The samples of this set so far are not a reading either.
                    for ex in &mut exchanges[first_in_set..] {
                        if ex.0 == ExchangeKind::Sample {
                            ex.0 = ExchangeKind::Discarded;
                        }
                    }
                    return Ok(Attempt::Faulty {
                        reason: format!("{shown:?}: {fault}"),
                        exchanges,
                    });
                }
            }
            let (lo, hi) = set
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                    (lo.min(v.0), hi.max(v.0))
                });
            let spread = hi - lo;
            let xd = set.iter().map(|v| v.2).max().unwrap_or(0);
            let yd = set.iter().map(|v| v.3).max().unwrap_or(0);
            let extra = usize::from(k > 1);
            let n = set.len() as f64;
            let mx = set.iter().map(|v| v.0).sum::<f64>() / n;
            let my = set.iter().map(|v| v.1).sum::<f64>() / n;
            let record = Record {
                index,
                outcome: Outcome::Read {
                    x: format!("{mx:+.p$}", p = xd + extra),
                    y: format!("{my:+.p$}", p = yd + extra),
                    spread: format!("{spread:.xd$}"),
                },
                exchanges: exchanges.clone(),
            };
            // Rounding the spread to the instrument's decimals: compare with a hair of slack.
            if spread <= s.max_spread_arcsec * (1.0 + 1e-9) {
                return Ok(Attempt::Accepted(record));
            }
            attempt += 1;
            if attempt > s.rereads {
                return Ok(Attempt::SpreadOver {
                    spread_arcsec: spread,
                    record,
                });
            }
            for ex in &mut exchanges[first_in_set..] {
                if ex.0 == ExchangeKind::Sample {
                    ex.0 = ExchangeKind::Discarded;
                }
            }
        }
    }

    /// Journals a record (synced to disk) and moves on: the position is done.
    ///
    /// # Errors
    /// [`AcquireError::Journal`]; [`AcquireError::NoSuchPosition`].
    pub fn commit(&mut self, record: Record) -> Result<(), AcquireError> {
        if record.index >= self.planned.len() {
            return Err(AcquireError::NoSuchPosition {
                index: record.index,
                planned: self.planned.len(),
            });
        }
        self.journal.append(&record)?;
        self.note(record);
        Ok(())
    }

    /// Journals position `index` as skipped (missing in the readings), with what the
    /// instrument sent while it was tried.
    ///
    /// # Errors
    /// As [`Acquisition::commit`].
    pub fn skip(
        &mut self,
        index: usize,
        exchanges: Vec<(ExchangeKind, Vec<u8>)>,
    ) -> Result<(), AcquireError> {
        let exchanges = exchanges
            .into_iter()
            .map(|(k, raw)| {
                let k = if k == ExchangeKind::Sample {
                    ExchangeKind::Discarded
                } else {
                    k
                };
                (k, raw)
            })
            .collect();
        self.commit(Record {
            index,
            outcome: Outcome::Skipped,
            exchanges,
        })
    }

    /// The checks of position `index` against the earlier reading the plan names: its run's
    /// closure, or its drift from the first repeat.
    pub fn checks(&self, index: usize) -> Vec<Check<S::Position>> {
        let Some(p) = self.planned.get(index) else {
            return Vec::new();
        };
        let Some(v) = self.value(index) else {
            return Vec::new();
        };
        self.partners[index]
            .and_then(|(kind, i)| {
                self.value(i).map(|w| Check {
                    kind,
                    value_arcsec: v - w,
                    limit_arcsec: self
                        .plan
                        .check_limit_arcsec(self.settings.check_limit_arcsec()),
                    reading: *p,
                })
            })
            .into_iter()
            .collect()
    }

    /// The readings so far, in measuring order (skipped positions left out).
    pub fn rows(&self) -> Vec<Row<S::Position>> {
        (0..self.planned.len())
            .filter_map(|i| match &self.record(i)?.outcome {
                Outcome::Read { x, .. } => Some(Row {
                    planned: self.planned[i],
                    value_arcsec: self.plan.x_sign() * x.parse::<f64>().ok()?,
                    decimals: decimals_of(x),
                }),
                Outcome::Skipped => None,
            })
            .collect()
    }

    /// The raw log (`--log`): what the instrument sent, in order, as `#` comment lines (`#>` a
    /// sample, `#-` a sample of a set read again, `#!` an answer that is no reading), and after
    /// each position's samples its reading, the mean, as the instrument writes a reading (the
    /// line `gonio import elcomat` reads). A record a re-read replaced keeps its lines as
    /// comments. Lines end with CR LF.
    pub fn raw_log(&self, header: &str) -> String {
        let (t, st) = self.settings.mode.codes();
        let mut s = String::new();
        for line in header.lines() {
            s.push_str("# ");
            s.push_str(line);
            s.push_str("\r\n");
        }
        for (h, r) in self.history.iter().enumerate() {
            let p = &self.planned[r.index];
            let latest = self.current[r.index] == Some(h);
            s.push_str(&format!(
                "# {}{}\r\n",
                self.plan.describe(p),
                match (&r.outcome, latest) {
                    (Outcome::Skipped, _) => ": skipped",
                    (_, false) => ": replaced by a later re-read",
                    _ => "",
                }
            ));
            for (k, raw) in &r.exchanges {
                let tag = match k {
                    ExchangeKind::Sample => "#> ",
                    ExchangeKind::Discarded => "#- ",
                    ExchangeKind::Rejected => "#! ",
                };
                s.push_str(tag);
                s.push_str(&journal::escape(raw));
                s.push_str("\r\n");
            }
            if let Outcome::Read { x, y, .. } = &r.outcome {
                let prefix = if latest { "" } else { "#~ " };
                s.push_str(&format!("{prefix}{t} {st} {x} {y}\r\n"));
            }
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::VecDeque;
    use std::io::{Read, Write};
    use std::time::Duration;

    #[test]
    fn settings_out_of_their_bounds_are_refused_naming_the_bound() {
        for (settings, want) in [
            (
                Settings {
                    sigma_arcsec: 1e300,
                    ..Settings::default()
                },
                "sigma_arcsec = 1e300: at most 100″",
            ),
            (
                Settings {
                    samples: 0,
                    ..Settings::default()
                },
                "samples = 0: at least 1",
            ),
            (
                Settings {
                    max_spread_arcsec: f64::NAN,
                    ..Settings::default()
                },
                "max_spread_arcsec = NaN: not a finite number",
            ),
            (
                Settings {
                    rereads: u32::MAX,
                    ..Settings::default()
                },
                "rereads = 4294967295: at most 100",
            ),
        ] {
            let e = settings.validate().unwrap_err().to_string();
            assert!(e.starts_with(want), "{e}");
        }
        assert!(Settings::default().validate().is_ok());
    }

    /// An instrument that answers each request with the next scripted line (none: silent).
    struct Scripted {
        answers: VecDeque<&'static str>,
        out: Vec<u8>,
    }

    impl Read for Scripted {
        fn read(&mut self, b: &mut [u8]) -> std::io::Result<usize> {
            if self.out.is_empty() {
                return Err(std::io::ErrorKind::TimedOut.into());
            }
            let n = b.len().min(self.out.len());
            b[..n].copy_from_slice(&self.out[..n]);
            self.out.drain(..n);
            Ok(n)
        }
    }

    impl Write for Scripted {
        fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
            assert!(b == b"a\r\n", "{b:?}");
            if let Some(a) = self.answers.pop_front() {
                self.out.extend_from_slice(a.as_bytes());
                self.out.push(b'\r');
            }
            Ok(b.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    impl Transport for Scripted {}

    fn bench(answers: &[&'static str]) -> Autocollimator<Scripted> {
        let s = Scripted {
            answers: answers.iter().copied().collect(),
            out: Vec::new(),
        };
        Autocollimator::new(s, "scripted", Duration::from_millis(50))
    }

    #[test]
    fn flagged_answers_are_never_samples_and_a_wide_set_is_read_again() {
        let plan = Plan::parse_text(
            "p",
            "faces = 3\nshifts_deg = [0]\nstart_faces = [1]\nrepeats = 2\nclosure = true\n",
        )
        .unwrap();
        let dir = tempfile::tempdir().unwrap();
        let j = dir.path().join("j");
        let mut a = Acquisition::start(plan, Settings::default(), &j, false).unwrap();
        let mut inst = bench(&[
            "4 003 +1.000 +0.1",
            "4 013 +9.000 +0.0",
            "4 003 +1.002 +0.1",
            "4 003 +1.004 +0.4",
            // Spread 0.6″: read again.
            "4 003 +2.000 0",
            "4 003 +2.600 0",
            "4 003 +2.300 0",
            "4 003 +2.010 0",
            "4 003 +2.020 0",
            "4 003 +2.030 0",
        ]);
        let Attempt::Accepted(r) = a.measure(&mut inst, 0).unwrap() else {
            panic!("accepted")
        };
        assert_eq!(
            r.outcome,
            Outcome::Read {
                x: "+1.0020".into(),
                y: "+0.20".into(),
                spread: "0.004".into()
            }
        );
        assert_eq!(r.exchanges[1].0, ExchangeKind::Rejected);
        a.commit(r).unwrap();
        let Attempt::Accepted(r) = a.measure(&mut inst, 1).unwrap() else {
            panic!("accepted")
        };
        assert_eq!(
            r.exchanges.iter().map(|e| e.0).collect::<Vec<_>>(),
            [[ExchangeKind::Discarded; 3], [ExchangeKind::Sample; 3]].concat()
        );
        assert!(matches!(&r.outcome, Outcome::Read { x, .. } if x == "+2.0200"));
        a.commit(r).unwrap();
        // Silence is an error naming the port; nothing journalled is lost.
        let e = a.measure(&mut inst, 2).unwrap_err().to_string();
        assert!(
            e.starts_with("port scripted: the autocollimator did not answer"),
            "{e}"
        );
        drop(a);
        let plan = Plan::parse_text(
            "p",
            "faces = 3\nshifts_deg = [0]\nstart_faces = [1]\nrepeats = 2\nclosure = true\n",
        )
        .unwrap();
        let a = Acquisition::start(plan, Settings::default(), &j, true).unwrap();
        assert_eq!((a.next(), a.done()), (Some(2), 2));
        // Repeat 2 of step 1 (position 1) drifted 1.018″ from repeat 1: over 3·√2·0.05/√3.
        let c = a.checks(1);
        assert_eq!(c.len(), 1);
        assert_eq!(c[0].kind, CheckKind::Drift);
        assert!((c[0].value_arcsec - 1.018).abs() < 1e-9 && !c[0].ok());
        // Four flagged answers in a row: the operator decides.
        let mut inst = bench(&["4 013 1 1", "4 013 1 1", "2 103 1 1", "garbage"]);
        assert!(matches!(
            a.measure(&mut inst, 2).unwrap(),
            Attempt::Faulty { ref reason, .. } if reason.contains("garbage")
        ));
    }
}
