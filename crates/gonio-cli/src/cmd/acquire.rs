//! `gonio acquire shift-angle` and `gonio acquire axis`: read an ELCOMAT-type autocollimator
//! over its serial line while the operator turns the polygon through the measuring plan, or
//! moves a rotary axis through its ISO 230-2 test cycle.
//!
//! Glue only: the driver, the plans, the checks and the journal are `gonio_lab`'s. This module
//! talks to the operator: a full-screen view when standard input is a terminal
//! ([`crate::cmd::acquire::screen`]), else the line protocol (`NEXT …` / `READ …`).

mod screen;

use anyhow::{Result, anyhow, bail};
use gonio_cli::flag;
use gonio_cli::output::Outputs;
use gonio_cli::{note, say};
use gonio_core::bound::{Num, duration_s};
use gonio_io::input;
use gonio_lab::acquire::{
    self, AcquireError, Acquisition, Attempt, Check, CheckKind, Requested, Settings,
};
use gonio_lab::axis::AxisPlan;
use gonio_lab::instrument;
use gonio_lab::instrument::{Autocollimator, Transport};
use gonio_lab::journal::{self, Outcome};
use gonio_lab::log::Mode;
use gonio_lab::plan::Plan;
use gonio_lab::sequence::Sequence;
use std::io::{BufRead, IsTerminal};
use std::path::PathBuf;

/// What to acquire.
#[derive(Debug, clap::Subcommand)]
pub enum Acquire {
    /// A shift-angle measurement: polygon readings of an autocollimator at every position of
    /// a measuring plan → the readings CSV of `gonio shift-angle`.
    ShiftAngle(Args),
    /// A rotary axis to ISO 230-2: the autocollimator reads the polygon on the axis at every
    /// approach of the standard's test cycle → the readings CSV of `gonio axis`.
    #[command(after_help = AXIS_HELP)]
    Axis(Args),
}

const AXIS_HELP: &str = "\
The plan (TOML, see docs/iso230-2.md) names the polygon's faces, the targets (every face by
default, and 360°), the runs (5), the directions and the overrun. The cycle is the standard's:
run 1 turns to the first target less the overrun, approaches every target upwards, turns beyond
the last by the overrun, approaches every target downwards; then run 2 … Each approach is read
as `gonio acquire shift-angle` reads a position: --samples answers averaged, the spread checked,
a flagged answer never a reading, every reading synced to OUT.journal (--resume continues),
every run checked against run 1 (drift) and 360° against 0° (closure). The CSV
(target_deg,direction,run,face,reading_arcsec) is written when the cycle is complete; `gonio axis
--polygon CERT.json` evaluates it.

In a terminal: the full-screen view (Enter or r: read, e: read the last again, s: skip, p: pause,
q: quit). Otherwise gonio prints
  NEXT target_deg=T direction=D run=J face=F from_deg=A
(move the axis to T coming from A: the approach in the direction D) and waits for a line: empty =
read, `redo`, `skip`, `quit`; after a reading
  READ target_deg=T direction=D run=J face=F from_deg=A x_arcsec=X spread_arcsec=S

Examples:
  gonio simulate autocollimator --pty --faces 12 --axis --seed 1 &     # prints the port
  gonio acquire axis --plan axis.toml --port /dev/pts/4 --out readings.csv
  gonio axis readings.csv --polygon cal.json --json axis.json";

/// Arguments of `gonio acquire shift-angle`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Talks to an ELCOMAT-type autocollimator on a serial port: sends `a` (absolute) or `r` (relative)
and CR LF, reads `4 003 X Y` or `2 103 X Y` ended by CR (arcseconds). Each position of the plan
is the mean of --samples answers; a set whose X spreads more than --max-spread-arcsec is read
again (--rereads times, then the operator decides); an answer with another status code is
never a reading. Every accepted reading is synced to OUT.journal before the next position is
asked for; --resume continues there after a quit, a crash or a pulled cable. The CSV (the input
of `gonio shift-angle`, with a repeat column when the plan repeats) is written when the plan is
complete; --log keeps what the instrument sent, readable by `gonio import elcomat`.

In a terminal: a full-screen view (Enter or r: read, e: read the last position again, s: skip,
p: pause, q: quit). Otherwise, lines: gonio prints
  NEXT shift_deg=S start_face=F step=I repeat=R
and waits for a line: empty = read, `redo` = read the last position again, `skip`, `quit`
(saves and exits 0); after a reading it prints
  READ shift_deg=S start_face=F step=I repeat=R x_arcsec=X spread_arcsec=D
See docs/measuring-plan.md.

Examples:
  gonio simulate autocollimator --pty --faces 12 --seed 1 &      # prints the port, e.g. /dev/pts/4
  gonio acquire shift-angle --plan plan.toml --port /dev/pts/4 --out readings.csv --log raw.log
  gonio acquire shift-angle --plan plan.toml --port /dev/ttyUSB0 --out readings.csv --resume
  gonio shift-angle readings.csv --json cal.json")]
pub struct Args {
    /// The measuring plan (TOML, see docs/measuring-plan.md; an axis's: docs/iso230-2.md).
    #[arg(long)]
    pub plan: PathBuf,
    /// The autocollimator's serial port (`/dev/ttyUSB0`, `/dev/ttyS0`, a pseudo-terminal).
    #[arg(long)]
    pub port: String,
    /// The readings CSV to write when the plan is complete; the journal is OUT.journal.
    #[arg(long)]
    pub out: PathBuf,
    /// Baud rate of the serial line (50 to 4000000).
    #[arg(long, default_value_t = 9600, value_parser = flag::whole::<u32>(instrument::BAUD))]
    pub baud: u32,
    /// Readings to ask for: `absolute` (`a`, answered `4 003 …`) or `relative` (`r`, `2 103
    /// …`). Default: the plan's mode, absolute when it allows either.
    #[arg(long, value_enum, hide_possible_values = true)]
    pub mode: Option<Mode>,
    /// Answers averaged per position (1 to 1000).
    #[arg(long, default_value_t = 3, value_parser = flag::whole::<usize>(acquire::SAMPLES))]
    pub samples: usize,
    /// Largest spread (largest − smallest X) of one position's samples, arcsec. Default: 5σ.
    #[arg(long, value_parser = flag::real(acquire::MAX_SPREAD_ARCSEC))]
    pub max_spread_arcsec: Option<f64>,
    /// The autocollimator's standard deviation of one answer, arcsec: the default spread
    /// limit and the limits of the closure and drift checks (3·√2·σ/√samples).
    #[arg(long, default_value_t = 0.05, value_parser = flag::real(acquire::SIGMA_ARCSEC))]
    pub sigma_arcsec: f64,
    /// Sets read again when their spread is over the limit, before the operator is asked.
    #[arg(long, default_value_t = 3, value_parser = flag::whole::<u32>(acquire::REREADS))]
    pub rereads: u32,
    /// Seconds to wait for one answer before the instrument counts as silent (0.05 to 60).
    #[arg(long, default_value_t = 2.0, value_parser = flag::real(acquire::ANSWER_TIMEOUT_S))]
    pub timeout_s: f64,
    /// Also write what the instrument sent (samples and rejected answers as `#` lines, each
    /// reading as the mean line `gonio import elcomat` reads) when the plan is complete.
    #[arg(long)]
    pub log: Option<PathBuf>,
    /// Continue the acquisition in OUT.journal after its last reading.
    #[arg(long)]
    pub resume: bool,
}

/// Runs `gonio acquire …`.
pub fn run(a: Acquire) -> Result<()> {
    match a {
        Acquire::ShiftAngle(args) => {
            let inputs = input::Inputs::new();
            let plan = Plan::parse(&args.plan, &inputs.read_text(&args.plan)?)?;
            acquire(args, plan, inputs)
        }
        Acquire::Axis(args) => {
            let inputs = input::Inputs::new();
            let plan = AxisPlan::parse(&args.plan, &inputs.read_text(&args.plan)?)?;
            acquire(args, plan, inputs)
        }
    }
}

/// How the operator ended the session.
pub(crate) enum End {
    /// The plan is complete.
    Complete,
    /// The operator quit.
    Quit,
}

/// The acquisition's settings: the flags checked against the plan.
fn settings(args: &Args, plan: &impl Sequence) -> Result<Settings> {
    let asked = Requested {
        mode: args.mode,
        samples: args.samples,
        max_spread_arcsec: args.max_spread_arcsec,
        rereads: args.rereads,
        sigma_arcsec: args.sigma_arcsec,
    };
    Ok(Settings::for_plan(
        &asked,
        plan,
        &args.plan.display().to_string(),
    )?)
}

fn acquire<S: Sequence>(args: Args, plan: S, inputs: input::Inputs) -> Result<()> {
    if args.out.as_os_str() == "-" {
        bail!("--out -: the readings need a file (the journal is kept beside it)");
    }
    let settings = settings(&args, &plan)?;
    // Claim the outputs first: a CSV that cannot be written is refused before the bench starts.
    let mut out = Outputs::with_inputs(inputs);
    let csv_out = out.file("--out", &args.out)?;
    let log_out = out.optional("--log", args.log.as_deref())?;
    let journal_path = journal::path_for(&args.out);
    let timeout = duration_s(args.timeout_s, &acquire::ANSWER_TIMEOUT_S)
        .map_err(|e| anyhow!("--timeout-s {}: {e}", Num(args.timeout_s)))?;
    let resuming = args.resume && journal_path.exists();
    // A new journal only once the port is open: a missing port leaves nothing behind.
    let (mut acq, mut port) = if resuming {
        let acq = Acquisition::start(plan, settings, &journal_path, true)?;
        let port = match acq.next() {
            Some(_) => Some(Autocollimator::open(&args.port, args.baud, timeout)?),
            None => None,
        };
        (acq, port)
    } else {
        if !args.resume {
            // Said before the port is touched.
            journal::ensure_new(&journal_path)?;
        }
        let port = Autocollimator::open(&args.port, args.baud, timeout)?;
        (
            Acquisition::start(plan, settings, &journal_path, args.resume)?,
            Some(port),
        )
    };
    if resuming {
        note!(
            "resuming {}: {} of {} positions done",
            journal_path.display(),
            acq.done(),
            acq.planned().len()
        );
    }
    let end = match port.as_mut() {
        None => End::Complete,
        Some(port) => {
            let ended = if std::io::stdin().is_terminal() {
                screen::run(&mut acq, port, &args)
            } else {
                lines(&mut acq, port)
            };
            ended.map_err(|e| lost(e, &acq))?
        }
    };
    match end {
        End::Quit => {
            note!(
                "quit with {} of {} positions done; they are in {} (continue with --resume)",
                acq.done(),
                acq.planned().len(),
                acq.journal_path().display()
            );
            Ok(())
        }
        End::Complete => finish(out, csv_out, log_out, &acq, &args),
    }
}

/// An error during the acquisition, with where the readings so far are.
fn lost<S: Sequence>(e: anyhow::Error, acq: &Acquisition<S>) -> anyhow::Error {
    match e.downcast_ref::<AcquireError>() {
        Some(AcquireError::Instrument(_)) => anyhow!(
            "{e}; the {} positions done are in {} (continue with --resume)",
            acq.done(),
            acq.journal_path().display()
        ),
        _ => e,
    }
}

fn finish<S: Sequence>(
    mut out: Outputs,
    csv_out: gonio_cli::output::OutId,
    log_out: Option<gonio_cli::output::OutId>,
    acq: &Acquisition<S>,
    args: &Args,
) -> Result<()> {
    let rows = acq.rows();
    let plan = acq.plan();
    let comment = format!(
        "# gonio acquire {} --plan {} ({} readings, {} missing)",
        plan.command(),
        args.plan.display(),
        rows.len(),
        acq.missing()
    );
    let csv = plan.csv(&comment, &rows);
    out.write(csv_out, csv.as_bytes())?;
    if let Some(id) = log_out {
        let header = format!(
            "gonio acquire {} --plan {} --port {}: what the autocollimator sent\n\
             `#>` a sample, `#-` a sample of a set read again, `#!` an answer that is no reading;\n\
             each position's reading (the mean of its samples) is the line without `#`",
            plan.command(),
            args.plan.display(),
            args.port
        );
        out.write(id, acq.raw_log(&header).as_bytes())?;
    }
    out.commit()?;
    note!(
        "wrote {} readings ({} missing) to {}{}",
        rows.len(),
        acq.missing(),
        args.out.display(),
        args.log.as_ref().map_or(String::new(), |l| format!(
            " and the instrument's log to {}",
            l.display()
        ))
    );
    Ok(())
}

/// The READ line of a journalled position.
pub(crate) fn read_line<S: Sequence>(acq: &Acquisition<S>, index: usize) -> Option<String> {
    let r = acq.record(index)?;
    let Outcome::Read { x, spread, .. } = &r.outcome else {
        return None;
    };
    let d = x.split_once('.').map_or(0, |(_, d)| d.len());
    let v = acq.value(index)?;
    Some(format!(
        "READ {} x_arcsec={v:.d$} spread_arcsec={spread}",
        acq.plan().fields(&acq.planned()[index])
    ))
}

/// A check as a line: `CHECK kind=closure … diff_arcsec=… limit_arcsec=… ok=true`.
pub(crate) fn check_line<S: Sequence>(plan: &S, c: &Check<S::Position>) -> String {
    format!(
        "CHECK kind={} {} diff_arcsec={:+.4} limit_arcsec={:.4} ok={}",
        match c.kind {
            CheckKind::Closure => "closure",
            CheckKind::Drift => "drift",
        },
        plan.fields(&c.reading),
        c.value_arcsec,
        c.limit_arcsec,
        c.ok()
    )
}

/// The longest operator line read (the longest answer, `accept`, is 6 bytes).
const MAX_OPERATOR_LINE_BYTES: usize = 4096;

/// Reads one operator line; `None` at the end of input.
///
/// # Errors
/// Standard input cannot be read, or a line goes on beyond [`MAX_OPERATOR_LINE_BYTES`].
fn operator_line(stdin: &mut impl BufRead) -> Result<Option<String>> {
    let mut line = Vec::new();
    let more = gonio_core::text::read_line_bounded(stdin, MAX_OPERATOR_LINE_BYTES, &mut line)
        .map_err(|e| {
            anyhow!(
                "standard input: {e}: expected an empty line (read), redo, skip, accept or quit"
            )
        })?;
    Ok(more.then(|| String::from_utf8_lossy(&line).trim().to_string()))
}

/// The line protocol (standard input not a terminal).
fn lines<S: Sequence, T: Transport>(
    acq: &mut Acquisition<S>,
    port: &mut Autocollimator<T>,
) -> Result<End> {
    let stdin = std::io::stdin();
    let mut stdin = stdin.lock();
    while let Some(i) = acq.next() {
        say!("NEXT {}", acq.plan().fields(&acq.planned()[i]))?;
        let Some(cmd) = operator_line(&mut stdin)? else {
            note!("end of standard input: quitting");
            return Ok(End::Quit);
        };
        let target = match cmd.as_str() {
            "" => i,
            "redo" => match acq.last() {
                Some(l) => l,
                None => {
                    note!("redo: nothing read yet");
                    continue;
                }
            },
            "skip" => {
                acq.skip(i, Vec::new())?;
                say!("SKIPPED {}", acq.plan().fields(&acq.planned()[i]))?;
                continue;
            }
            "quit" => return Ok(End::Quit),
            other => {
                note!(
                    "{:?}: expected an empty line (read), redo, skip or quit",
                    gonio_core::text::short(other)
                );
                continue;
            }
        };
        if let Some(End::Quit) = measure_lines(acq, port, target, &mut stdin)? {
            return Ok(End::Quit);
        }
    }
    Ok(End::Complete)
}

/// Measures one position in the line protocol, asking the operator when the checks fail.
fn measure_lines<S: Sequence, T: Transport>(
    acq: &mut Acquisition<S>,
    port: &mut Autocollimator<T>,
    index: usize,
    stdin: &mut impl BufRead,
) -> Result<Option<End>> {
    loop {
        let attempt = acq.measure(port, index)?;
        let (ask, record, exchanges) = match attempt {
            Attempt::Accepted(record) => {
                acq.commit(record)?;
                say!("{}", read_line(acq, index).unwrap_or_default())?;
                for c in acq.checks(index) {
                    say!("{}", check_line(acq.plan(), &c))?;
                }
                return Ok(None);
            }
            Attempt::SpreadOver {
                spread_arcsec,
                record,
            } => (
                format!(
                    "ASK spread_arcsec={spread_arcsec} max_spread_arcsec={}: an empty line reads again, or accept, skip, quit",
                    acq.settings().max_spread_arcsec
                ),
                Some(record.clone()),
                record.exchanges,
            ),
            Attempt::Faulty { reason, exchanges } => (
                format!(
                    "ASK fault={:?}: an empty line reads again, or skip, quit",
                    gonio_core::text::short(&reason)
                ),
                None,
                exchanges,
            ),
        };
        say!("{ask}")?;
        let Some(answer) = operator_line(stdin)? else {
            note!("end of standard input: quitting");
            return Ok(Some(End::Quit));
        };
        match answer.as_str() {
            "accept" if record.is_some() => {
                let record = record.expect("checked");
                acq.commit(record)?;
                say!("{}", read_line(acq, index).unwrap_or_default())?;
                return Ok(None);
            }
            "skip" => {
                acq.skip(index, exchanges)?;
                say!("SKIPPED {}", acq.plan().fields(&acq.planned()[index]))?;
                return Ok(None);
            }
            "quit" => return Ok(Some(End::Quit)),
            _ => {}
        }
    }
}
