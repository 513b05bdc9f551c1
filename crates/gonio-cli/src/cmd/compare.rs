//! `gonio compare`: two calibration certificates of one encoder compared at their common angles
//! (differences and En).

use anyhow::Result;
use gonio_calib::compare::Comparison;
use gonio_cli::output::Outputs;
use gonio_io::formats::source::Document;
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of `gonio compare`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Each file is a certificate (gonio.certificate/1 JSON from `gonio shift-angle --json` or `gonio
selfcal --json`); the second may also be a simulator's truth.json (`gonio simulate selfcal`), a
reference without uncertainty. Angles are matched to 1e-6° modulo 360°.
En = |a − b| / √(U_a² + U_b²) with each angle's U, or k = 2·u where a certificate has no U (the
output says which). Where both U are 0, En is undefined (null in --json, `–` in the table) and the
comparison does not pass (all_en_pass false, en_undefined counts them). `gonio report cmp.json`
plots the comparison.

Examples:
  gonio compare sa/cal.json sc/cal.json
  gonio compare sa/cal.json sc/cal.json --json cmp.json
  gonio compare sc/cal.json sc/truth.json")]
pub struct Args {
    /// First certificate (JSON).
    pub a: PathBuf,
    /// Second certificate (JSON), or a simulator's truth.json.
    pub b: PathBuf,
    /// Write the comparison as JSON here (`-` for standard output).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Print every common angle, not only the summary.
    #[arg(long)]
    pub all: bool,
}

/// Runs `gonio compare`.
pub fn run(args: Args) -> Result<()> {
    let mut out = Outputs::new();
    let json = out.optional("--json", args.json.as_deref())?;
    let (a, b) = (
        Document::File(args.a.clone()),
        Document::File(args.b.clone()),
    );
    let c = gonio_io::results::compare::evaluate(out.inputs(), &a, &b)?;
    let to_stdout = out.to_stdout(json);
    if let Some(j) = json {
        out.json(j, &c)?;
    }
    if !to_stdout {
        print_summary(&c, args.all)?;
    }
    out.commit()
}

fn print_summary(c: &Comparison, all: bool) -> Result<()> {
    let mut out = String::new();
    let _ = writeln!(out, "A = {}\nB = {}", c.method_a, c.method_b);
    if all {
        let _ = writeln!(out, "  angle_deg   A_arcsec   B_arcsec  A−B_arcsec     En");
        for p in &c.points {
            let _ = writeln!(
                out,
                "{:>11.6} {:>+10.4} {:>+10.4} {:>+11.4} {:>6}",
                p.angle_deg,
                p.a_arcsec,
                p.b_arcsec,
                p.difference_arcsec,
                p.en.map_or("–".into(), |e| format!("{e:.3}"))
            );
        }
    }
    let _ = writeln!(
        out,
        "{} common angles: largest |A − B| = {:.4}″ at {}°, mean {:+.4}″, rms {:.4}″",
        c.points.len(),
        c.max_abs_difference_arcsec,
        c.max_abs_difference_angle_deg,
        c.mean_difference_arcsec,
        c.rms_difference_arcsec
    );
    let n = c.points.len();
    let verdict = if c.all_en_pass {
        "every En ≤ 1".to_string()
    } else if c.en_undefined > 0 {
        format!(
            "NOT PASSED: En undefined at {} of {n} angles, where both U are 0",
            c.en_undefined
        )
    } else {
        "some En > 1".to_string()
    };
    match (c.max_en, c.max_en_angle_deg) {
        (Some(e), Some(at)) => {
            let _ = writeln!(out, "largest En = {e:.3} at {at}° ({verdict})");
        }
        _ => {
            let _ = writeln!(out, "En undefined at every angle ({verdict})");
        }
    }
    let _ = writeln!(
        out,
        "U from: A {}; B {}",
        c.uncertainty_source.a, c.uncertainty_source.b
    );
    let _ = writeln!(out, "{}", c.note);
    gonio_cli::term::out(&out)
}
