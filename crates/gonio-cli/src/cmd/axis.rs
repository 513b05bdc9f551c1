//! `gonio axis`: a rotary axis's accuracy and repeatability of positioning to ISO 230-2.

use anyhow::Result;
use gonio_calib::axis::AxisResult;
use gonio_cli::output::Outputs;
use gonio_io::formats::{self, axis};
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of `gonio axis`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Input: a CSV with header target_deg,direction,run,deviation_arcsec, one approach a row:
direction + or - (approached in the positive or negative sense), run 1…n, deviation the position
reached minus the target (arcsec); `#` comment lines allowed; `-` reads stdin. An autocollimator's
readings of a polygon (reading_arcsec instead of deviation_arcsec, as `gonio acquire axis` writes
them, with an optional face column) need --polygon: each reading less its face's term from the
polygon's calibration.

Writes the ISO 230-2:2014 parameters A, A_up, A_down, B, B_mean, E, E_up, E_down, M, R, R_up,
R_down (arcsec) and every target's x̄, s, B_i, R_i; a test with one direction only is the
standard's unidirectional test (the bidirectional parameters are null). Beside them, beyond the
standard: the reference's GUM budget of one deviation (--instrument, --polygon) and every
parameter's expanded uncertainty U (k = 2). See docs/iso230-2.md.

Examples:
  gonio simulate axis --seed 1 --out ax
  gonio axis ax/readings.csv --json axis.json --compensation comp.csv
  gonio acquire axis --plan axis.toml --port /dev/ttyUSB0 --out readings.csv
  gonio axis readings.csv --polygon cal.json --instrument examples/instrument-axis.toml --json axis.json
  gonio report axis.json --out axis.html")]
pub struct Args {
    /// Readings CSV (`-` for standard input).
    pub readings: PathBuf,
    /// Write the result here (JSON, `gonio.axis/1`; `-` for standard output).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the controller's compensation table here (CSV:
    /// target_deg,correction_up_arcsec,correction_down_arcsec,correction_mean_arcsec; the
    /// correction to add to the commanded position).
    #[arg(long)]
    pub compensation: Option<PathBuf>,
    /// The polygon's calibration (a certificate of `gonio shift-angle --json` or `gonio joint
    /// --json`): corrects the readings of a reading_arcsec column; its uncertainty enters the
    /// reference's budget.
    #[arg(long)]
    pub polygon: Option<PathBuf>,
    /// The reference instrument's terms (TOML: autocollimator resolution, certificate, linearity,
    /// set-up …) for the budget of one deviation. See examples/instrument-axis.toml.
    #[arg(long)]
    pub instrument: Option<PathBuf>,
    /// Coverage probability of the reference's U (default: the instrument file's, else 0.95).
    #[arg(long, value_parser = gonio_cli::flag::real(gonio_uncertainty::COVERAGE))]
    pub coverage: Option<f64>,
}

/// Runs `gonio axis`.
pub fn run(args: Args) -> Result<()> {
    let mut out = Outputs::new();
    let json = out.optional("--json", args.json.as_deref())?;
    let comp = out.optional("--compensation", args.compensation.as_deref())?;
    let instrument =
        formats::instrument::load(out.inputs(), args.instrument.as_deref(), args.coverage)?;
    let doc = axis::evaluate(
        out.inputs(),
        &args.readings,
        args.polygon.as_deref(),
        &instrument,
    )?;
    gonio_io::json::finite_result(&doc, &args.readings, "the evaluation")?;
    let to_stdout = out.to_stdout(json);
    if let Some(j) = json {
        out.json(j, &doc)?;
    }
    if let Some(c) = comp {
        out.write(
            c,
            formats::compensation::axis_csv(&doc.compensation).as_bytes(),
        )?;
    }
    // The files first: an output refused at the commit (an input named as an output) leaves
    // no summary behind its error.
    out.commit()?;
    if !to_stdout {
        gonio_cli::term::out(&summary(&doc))?;
    }
    for p in [&args.json, &args.compensation].into_iter().flatten() {
        if p.as_os_str() != "-" {
            gonio_cli::note!("wrote {}", p.display());
        }
    }
    Ok(())
}

/// The parameters and the notes, for the terminal.
fn summary(doc: &AxisResult) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{}, rotary axis: {} test, {} targets ({}° … {}°), {}",
        doc.standard,
        doc.test,
        doc.targets.len(),
        doc.targets.first().map_or(0.0, |t| t.target_deg),
        doc.targets.last().map_or(0.0, |t| t.target_deg),
        doc.runs_summary()
    );
    let _ = writeln!(
        s,
        "  parameter        value/″   U/″ (k = {})",
        doc.uncertainty.k
    );
    let u = doc.uncertainty.parameters.named();
    for ((name, v), (_, uu)) in doc.parameters.named().into_iter().zip(u) {
        let _ = writeln!(
            s,
            "  {name:<14} {:>9}  {:>8}",
            crate::table::fixed(v, 3),
            crate::table::fixed(uu, 3)
        );
    }
    match &doc.uncertainty.reference {
        Some(r) => {
            let _ = writeln!(
                s,
                "  the reference's budget of one deviation, at {}° where it is largest:",
                r.target_deg
            );
            let mut t = String::new();
            crate::table::budget::text(&mut t, &r.budget);
            for l in t.lines() {
                let _ = writeln!(s, "    {l}");
            }
        }
        None => {
            let _ = writeln!(
                s,
                "  reference        no terms given (--instrument, --polygon): U above is the scatter alone"
            );
        }
    }
    for n in doc.notes.iter().chain(&doc.bidirectional_note) {
        let _ = writeln!(s, "  note: {n}");
    }
    s
}
