//! `gonio import …`: instrument logs into gonio's readings files.

//!
//! Glue only: the log's format, the plan and the pairing of the two are `gonio_lab`'s.

use anyhow::{Result, bail};
use gonio_cli::output::Outputs;
use gonio_lab::plan::Plan;
use gonio_lab::{import, log, readings};
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
    /// The measuring plan (TOML; `-` for standard input, when the log is a file).
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
    // Standard input is read once: said before either is read, not as the second's parse error.
    if args.log.as_os_str() == "-" && args.plan.as_os_str() == "-" {
        bail!(
            "LOG - and --plan -: both are standard input, which can be read only once; give the plan as a file"
        );
    }
    let mut out = Outputs::new();
    let csv_out = out.file("--out", &args.out)?;
    let plan_text = out.inputs().read_text(&args.plan)?;
    let plan = Plan::parse(&args.plan, &plan_text)?;
    let name = args.log.display().to_string();
    // Bytes that are not UTF-8 (line noise on a serial link) become U+FFFD, so that the
    // parser names the line they are on.
    let bytes = out.inputs().read_bytes(&args.log, LOG_LIMIT_BYTES)?;
    let log = log::parse(&name, &String::from_utf8_lossy(&bytes))?;
    let plan_name = args.plan.display().to_string();
    let rows = import::assign(&plan, &plan_name, &name, &log)?;
    let comment = format!(
        "# gonio import elcomat {name} --plan {plan_name} ({} readings)",
        log.len()
    );
    let csv = readings::csv(&comment, plan.has_repeats(), &rows);
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
