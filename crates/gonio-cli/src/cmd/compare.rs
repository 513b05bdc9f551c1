//! `gonio compare`: two calibrations of one encoder compared at their common angles (En).

use crate::io;
use anyhow::{Result, anyhow};
use gonio_calib::compare::{Comparison, Curve, CurvePoint, compare};
use serde::Deserialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Arguments of `gonio compare`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Either file may be a shift-angle result (`encoder_errors` [{angle_deg, value_arcsec, u_arcsec,
U_arcsec?}], `undetectable_harmonics`) or a self-calibration result (`errors` [{position_deg,
value_arcsec, u_arcsec, U_arcsec?}], `undetectable_orders`), or a simulator's truth.json.
Angles are matched to 1e-6° modulo 360°. En = |a − b| / √(U_a² + U_b²) with each point's
U_arcsec, or k = 2·u_arcsec where a file gives none (the output says which).

Examples:
  gonio compare sa/result.json sc/result.json
  gonio compare sa/result.json sc/result.json --json cmp.json
  gonio compare sc/result.json sc/truth.json")]
pub struct Args {
    /// First calibration result (JSON).
    pub a: PathBuf,
    /// Second calibration result (JSON).
    pub b: PathBuf,
    /// Write the comparison as JSON here (`-` for standard output).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Print every common angle, not only the summary.
    #[arg(long)]
    pub all: bool,
}

#[derive(Debug, Deserialize)]
struct ShiftPoint {
    angle_deg: f64,
    value_arcsec: f64,
    u_arcsec: f64,
    #[serde(rename = "U_arcsec", default)]
    big_u: Option<f64>,
}

#[derive(Debug, Deserialize)]
struct SelfPoint {
    position_deg: f64,
    value_arcsec: f64,
    u_arcsec: f64,
    #[serde(rename = "U_arcsec", default)]
    big_u: Option<f64>,
}

#[derive(Debug, Deserialize)]
struct AnyResult {
    #[serde(default)]
    method: Option<serde_json::Value>,
    #[serde(default)]
    encoder_errors: Option<Vec<ShiftPoint>>,
    #[serde(default)]
    errors: Option<Vec<SelfPoint>>,
    #[serde(default)]
    undetectable_harmonics: Option<Vec<u32>>,
    #[serde(default)]
    undetectable_orders: Option<Vec<u32>>,
}

/// Reads either result shape into a [`Curve`].
pub fn load_curve(path: &Path) -> Result<Curve> {
    let text = io::read_text(path)?;
    let r: AnyResult = serde_json::from_str(&text).map_err(|e| {
        anyhow!(
            "{}:{}:{}: {e} (expected a shift-angle or selfcal result JSON)",
            path.display(),
            e.line(),
            e.column()
        )
    })?;
    let method = match &r.method {
        Some(serde_json::Value::String(s)) => s.clone(),
        Some(v) => v.to_string(),
        None => "?".into(),
    };
    let label = format!("{} ({method})", path.display());
    let undetectable_orders = r
        .undetectable_harmonics
        .or(r.undetectable_orders)
        .unwrap_or_default();
    let points: Vec<CurvePoint> = match (r.encoder_errors, r.errors) {
        (Some(v), _) => v
            .into_iter()
            .map(|p| CurvePoint {
                angle_deg: p.angle_deg,
                value_arcsec: p.value_arcsec,
                u_arcsec: p.u_arcsec,
                expanded_arcsec: p.big_u,
            })
            .collect(),
        (None, Some(v)) => v
            .into_iter()
            .map(|p| CurvePoint {
                angle_deg: p.position_deg,
                value_arcsec: p.value_arcsec,
                u_arcsec: p.u_arcsec,
                expanded_arcsec: p.big_u,
            })
            .collect(),
        (None, None) => {
            return Err(anyhow!(
                "{}:1:1: expected an `encoder_errors` (shift-angle) or `errors` (selfcal) list",
                path.display()
            ));
        }
    };
    Ok(Curve {
        label,
        points,
        undetectable_orders,
    })
}

/// Runs `gonio compare`.
pub fn run(args: Args) -> Result<()> {
    let a = load_curve(&args.a)?;
    let b = load_curve(&args.b)?;
    let c = compare(&a, &b)?;
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
    emit(&out);
}

/// Writes the summary to standard output, ignoring a closed pipe (`gonio … | head`).
fn emit(text: &str) {
    use std::io::Write;
    let _ = std::io::stdout().lock().write_all(text.as_bytes());
}
