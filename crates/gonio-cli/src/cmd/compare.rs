//! `gonio compare`: two calibration certificates of one encoder compared at their common angles
//! (differences and En).

use crate::formats;
use crate::io;
use anyhow::{Result, anyhow};
use gonio_calib::compare::{Comparison, Curve, CurvePoint, compare};
use serde::Deserialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Arguments of `gonio compare`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Each file is a certificate (gonio.certificate/1 JSON from `gonio shift-angle --json` or `gonio
selfcal --json`); the second may also be a simulator's truth.json (`gonio simulate selfcal`), a
reference without uncertainty. Angles are matched to 1e-6° modulo 360°.
En = |a − b| / √(U_a² + U_b²) with each angle's U, or k = 2·u where a certificate has no U (the
output says which). `gonio report cmp.json` plots the comparison.

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

/// A simulator's truth file (`gonio-selfcal-truth`): the true error at every position.
#[derive(Debug, Deserialize)]
struct Truth {
    errors: Vec<TruthPoint>,
}

#[derive(Debug, Deserialize)]
struct TruthPoint {
    position_deg: f64,
    value_arcsec: f64,
}

/// The format tag of a JSON file, if it has one.
#[derive(Debug, Deserialize)]
struct Tagged {
    #[serde(default)]
    format: Option<String>,
}

/// Reads a certificate (or a simulator's truth) into a [`Curve`].
pub fn load_curve(path: &Path) -> Result<Curve> {
    let text = io::read_text(path)?;
    let tag: Tagged = serde_json::from_str(&text)
        .map_err(|e| formats::json_error(path, &e, "expected a gonio certificate JSON"))?;
    if tag.format.as_deref() == Some("gonio-selfcal-truth") {
        let t: Truth = serde_json::from_str(&text)
            .map_err(|e| formats::json_error(path, &e, "expected a simulator's truth.json"))?;
        return Ok(Curve {
            label: format!("{} (truth)", path.display()),
            points: t
                .errors
                .into_iter()
                .map(|p| CurvePoint {
                    angle_deg: p.position_deg,
                    value_arcsec: p.value_arcsec,
                    u_arcsec: 0.0,
                    expanded_arcsec: None,
                })
                .collect(),
            undetectable_orders: Vec::new(),
        });
    }
    let cert = formats::certificate::parse(path, &text)?;
    let mut curve = Curve::from(&cert);
    curve.label = format!("{} ({})", path.display(), cert.method);
    Ok(curve)
}

/// Runs `gonio compare`.
pub fn run(args: Args) -> Result<()> {
    let a = load_curve(&args.a)?;
    let b = load_curve(&args.b)?;
    let c = compare(&a, &b).map_err(|e| anyhow!("{e}"))?;
    if let Some(p) = &args.json {
        io::write_json(p, &c)?;
    }
    if args.json.as_deref() != Some(Path::new("-")) {
        print_summary(&c, args.all);
    }
    Ok(())
}

fn print_summary(c: &Comparison, all: bool) {
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
    let _ = writeln!(
        out,
        "largest En = {:.3} at {}° ({})",
        c.max_en,
        c.max_en_angle_deg,
        if c.all_en_pass {
            "every En ≤ 1"
        } else {
            "some En > 1"
        }
    );
    let _ = writeln!(
        out,
        "U from: A {}; B {}",
        c.uncertainty_source.a, c.uncertainty_source.b
    );
    let _ = writeln!(out, "{}", c.note);
    io::emit(&out);
}
