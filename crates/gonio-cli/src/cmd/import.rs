//! `gonio import …`: instrument logs into gonio's readings files.

use anyhow::{Result, anyhow, bail};
use gonio_cli::formats::elcomat::{self, Mode};
use gonio_cli::formats::plan::{ModeRule, Plan};
use gonio_cli::input;
use gonio_cli::output::Outputs;
use std::fmt::Write as _;
use std::path::PathBuf;

/// The largest log read (a reading is about 25 bytes: ten million readings).
const LOG_LIMIT_BYTES: usize = 256 << 20;

/// What to import.
#[derive(Debug, clap::Subcommand)]
pub enum Import {
    /// An ELCOMAT-type autocollimator log (serial output, `4 003 X Y` / `2 103 X Y`) and its
    /// measuring plan → a shift-angle readings CSV.
    Elcomat(ElcomatArgs),
}

/// Arguments of `gonio import elcomat`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
The log holds one reading a line as the autocollimator sends it: `4 003 X Y` (absolute) or
`2 103 X Y` (relative), arcseconds; X is the polygon's angle. Lines may end in CR, CR LF or LF;
blank lines and `#` comments are skipped; any other line stops the import with its file:line:column.
The plan (TOML, see docs/measuring-plan.md) says which reading each line is: faces, shifts,
start faces, steps, repeats and the order they were measured in.

Output: shift_deg,start_face,step,reading_arcsec (a repeat column when any reading is repeated),
the file `gonio shift-angle` and `gonio joint` read.

Examples:
  gonio simulate shift-angle --shifts 0:1:14 --seed 1 --out lab --elcomat-log lab/elcomat.log
  gonio import elcomat lab/elcomat.log --plan lab/plan.toml --out readings.csv")]
pub struct ElcomatArgs {
    /// The log (`-` for standard input).
    pub log: PathBuf,
    /// The measuring plan (TOML).
    #[arg(long)]
    pub plan: PathBuf,
    /// The readings CSV to write (`-` for standard output).
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs `gonio import …`.
pub fn run(i: Import) -> Result<()> {
    match i {
        Import::Elcomat(a) => elcomat(a),
    }
}

fn elcomat(args: ElcomatArgs) -> Result<()> {
    let mut out = Outputs::new();
    let csv_out = out.file("--out", &args.out)?;
    let plan_text = input::read_text(&args.plan)?;
    let plan = Plan::parse(&args.plan, &plan_text)?;
    let name = args.log.display().to_string();
    // Bytes that are not UTF-8 (line noise on a serial link) become U+FFFD, so that the
    // parser names the line they are on.
    let bytes = input::read_bytes(&args.log, LOG_LIMIT_BYTES)?;
    let log = elcomat::parse(&name, &String::from_utf8_lossy(&bytes))?;
    let planned = plan.readings();
    // One kind of reading, the one the plan allows.
    if let Some(first) = log.first() {
        let wanted = match plan.mode {
            ModeRule::Absolute => Some(Mode::Absolute),
            ModeRule::Relative => Some(Mode::Relative),
            ModeRule::Any => None,
        };
        let expected = wanted.unwrap_or(first.mode);
        if let Some(r) = log.iter().find(|r| r.mode != expected) {
            bail!(
                "{name}:{}:1: a {} reading, expected {} readings only ({})",
                r.line,
                r.mode.name(),
                expected.name(),
                match wanted {
                    Some(_) => format!("the plan says mode = \"{}\"", expected.name()),
                    None => format!("line {} is {}", first.line, first.mode.name()),
                }
            );
        }
    }
    let where_in_plan = |k: usize| {
        let p = planned[k];
        format!(
            "shift {}°, start face {}, step {}{}",
            p.shift_deg,
            p.start_face,
            if p.closure {
                format!("{} (closure)", plan.faces + 1)
            } else {
                p.step.to_string()
            },
            if p.repeat > 1 && !p.closure {
                format!(", repeat {}", p.repeat)
            } else {
                String::new()
            }
        )
    };
    if log.len() > planned.len() {
        let extra = &log[planned.len()];
        bail!(
            "{name}:{}:1: reading {} is beyond the plan's {} readings (the plan ends with {})",
            extra.line,
            planned.len() + 1,
            planned.len(),
            where_in_plan(planned.len() - 1)
        );
    }
    if log.len() < planned.len() {
        let last = log.last().map_or("no readings".to_string(), |r| {
            format!(
                "its last reading (line {}) is {}",
                r.line,
                where_in_plan(log.len() - 1)
            )
        });
        return Err(anyhow!(
            "{name}: {} readings, the plan {} expects {}: {last}; the next planned reading is {}",
            log.len(),
            args.plan.display(),
            planned.len(),
            where_in_plan(log.len())
        ));
    }
    let with_repeat = planned.iter().any(|p| p.repeat > 1);
    let mut csv = String::with_capacity(planned.len() * 24);
    let _ = writeln!(
        csv,
        "# gonio import elcomat {} --plan {} ({} readings)",
        name,
        args.plan.display(),
        log.len()
    );
    csv.push_str(if with_repeat {
        "shift_deg,start_face,step,repeat,reading_arcsec\n"
    } else {
        "shift_deg,start_face,step,reading_arcsec\n"
    });
    for (p, r) in planned.iter().zip(&log) {
        let v = plan.x_sign * r.x_arcsec;
        let d = r.x_decimals;
        if with_repeat {
            let _ = writeln!(
                csv,
                "{},{},{},{},{v:.d$}",
                p.shift_deg, p.start_face, p.step, p.repeat
            );
        } else {
            let _ = writeln!(csv, "{},{},{},{v:.d$}", p.shift_deg, p.start_face, p.step);
        }
    }
    out.write(csv_out, csv.as_bytes())?;
    out.commit()?;
    if args.out.as_os_str() != "-" {
        gonio_cli::note!(
            "wrote {} readings ({} faces, {} shifts, {} log) to {}",
            log.len(),
            plan.faces,
            plan.shifts.len(),
            log.first().map_or("empty", |r| r.mode.name()),
            args.out.display()
        );
    }
    Ok(())
}
