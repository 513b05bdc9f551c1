//! `gonio shift-angle`: calibrate an encoder from polygon + autocollimator readings.

use crate::io::{self, CsvTable};
use crate::uncertainty::{Instrument, UncertaintySummary, serialize_opt_dof};
use anyhow::{Context, Result, anyhow};
use gonio_calib::shift_angle::{
    Calibration, HarmonicCheck, Method, Options, Reading, ReadingSet, ShiftAngleError, calibrate,
    harmonic_check,
};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// The readings file's header.
pub const HEADER: &str = "shift_deg,start_face,step,reading_arcsec[,repeat]";

/// Arguments of `gonio shift-angle`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Input: a CSV with header shift_deg,start_face,step,reading_arcsec (optional column repeat), one
reading a row; faces and steps 1-based as in seed 000; `#` comment lines allowed; `-` reads stdin.

Examples:
  gonio simulate shift-angle --shifts 0:1:14 --seed 1 --out lab
  gonio shift-angle lab/readings.csv --json cal.json --compensation comp.csv
  gonio shift-angle lab/readings.csv --method paper --sigma 0.05")]
pub struct Args {
    /// Readings CSV (`-` for standard input).
    pub readings: PathBuf,
    /// Estimator: `least-squares` (all readings jointly; default) or `paper` (seed 000's algorithm).
    #[arg(long, default_value = "least-squares")]
    pub method: String,
    /// Standard deviation of one reading, arcsec, if known: scales the uncertainties and is
    /// checked against the residuals (χ²). Default: estimated from the residuals.
    #[arg(long)]
    pub sigma: Option<f64>,
    /// Polygon faces N. Default: the largest face or step number in the file.
    #[arg(long)]
    pub faces: Option<usize>,
    /// Harmonic order of the setup-error check (seed 000 §3.1 uses 2).
    #[arg(long, default_value_t = 2)]
    pub check_order: u32,
    /// Write the result as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Instrument terms (TOML: autocollimator resolution, certificate, linearity, encoder
    /// resolution, setup residual …) combined with the estimator's random part into the expanded
    /// uncertainty U of every angle. See examples/instrument-shift-angle.toml.
    #[arg(long)]
    pub instrument: Option<PathBuf>,
    /// Coverage probability of U (default: the instrument file's, else 0.95).
    #[arg(long)]
    pub coverage: Option<f64>,
    /// Write the compensation table `angle_deg,correction_arcsec` (correction = −α, to add to
    /// the encoder's reading).
    #[arg(long)]
    pub compensation: Option<PathBuf>,
}

/// A pitch deviation in the JSON result.
#[derive(Debug, Clone, Serialize)]
pub struct PitchJson {
    /// Face (1-based).
    pub face: usize,
    /// β, arcsec.
    pub value_arcsec: f64,
    /// Standard uncertainty, arcsec.
    pub u_arcsec: f64,
}

/// A setup error in the JSON result.
#[derive(Debug, Clone, Serialize)]
pub struct SetupJson {
    /// Shift, degrees.
    pub shift_deg: f64,
    /// Start face (1-based).
    pub start_face: usize,
    /// U, arcsec.
    pub value_arcsec: f64,
    /// Standard uncertainty, arcsec.
    pub u_arcsec: f64,
}

/// An encoder error in the JSON result.
#[derive(Debug, Clone, Serialize)]
pub struct AlphaJson {
    /// Table angle, degrees in [0, 360).
    pub angle_deg: f64,
    /// α, arcsec.
    pub value_arcsec: f64,
    /// Combined standard uncertainty u_c, arcsec (the random part and any instrument terms).
    pub u_arcsec: f64,
    /// The estimator's random part of u, arcsec.
    pub u_random_arcsec: f64,
    /// Expanded uncertainty U = k·u_c, arcsec (null when σ is unknown).
    #[serde(rename = "U_arcsec")]
    pub expanded_arcsec: Option<f64>,
    /// Coverage factor.
    pub k: Option<f64>,
    /// Welch–Satterthwaite effective degrees of freedom (truncated), or "inf".
    #[serde(serialize_with = "serialize_opt_dof")]
    pub nu_eff: Option<f64>,
    /// Shift the angle was measured at, degrees.
    pub shift_deg: f64,
    /// Step (1-based).
    pub step: usize,
}

/// The χ² check in the JSON result.
#[derive(Debug, Clone, Serialize)]
pub struct Chi2Json {
    /// Stated σ, arcsec.
    pub sigma_arcsec: f64,
    /// χ².
    pub chi2: f64,
    /// P(χ² ≥ observed).
    pub p_upper: f64,
    /// Inside the central 95 %.
    pub consistent: bool,
}

/// Residual statistics in the JSON result.
#[derive(Debug, Clone, Serialize)]
pub struct ResidualsJson {
    /// RMS residual, arcsec.
    pub rms_arcsec: f64,
    /// Largest |residual|, arcsec.
    pub max_abs_arcsec: f64,
    /// Degrees of freedom.
    pub dof: usize,
    /// Readings compared.
    pub count: usize,
    /// σ̂, arcsec.
    pub sigma_hat_arcsec: Option<f64>,
    /// χ² check against --sigma.
    pub chi2: Option<Chi2Json>,
}

/// The harmonic check of one shift in the JSON result.
#[derive(Debug, Clone, Serialize)]
pub struct CheckShiftJson {
    /// Shift, degrees.
    pub shift_deg: f64,
    /// Start face of the run checked.
    pub start_face: usize,
    /// U from the harmonic fit, arcsec.
    pub u_fit_arcsec: f64,
    /// U from the closure (Eq. 7), arcsec.
    pub u_closure_arcsec: f64,
    /// Difference, arcsec.
    pub difference_arcsec: f64,
}

/// The harmonic check in the JSON result.
#[derive(Debug, Clone, Serialize)]
pub struct CheckJson {
    /// Harmonic order.
    pub order: u32,
    /// A, arcsec.
    pub amplitude_arcsec: f64,
    /// u(A), arcsec.
    pub u_amplitude_arcsec: f64,
    /// B, rad.
    pub phase_rad: f64,
    /// u(B), rad.
    pub u_phase_rad: f64,
    /// Per shift.
    pub shifts: Vec<CheckShiftJson>,
}

/// The result file of `gonio shift-angle`.
#[derive(Debug, Clone, Serialize)]
pub struct ShiftAngleReport {
    /// `least-squares` or `paper`.
    pub method: String,
    /// Polygon faces.
    pub faces: usize,
    /// Readings used.
    pub readings: usize,
    /// Shifts, degrees.
    pub shifts_deg: Vec<f64>,
    /// The σ of one reading behind the uncertainties, arcsec.
    pub sigma_arcsec: Option<f64>,
    /// `stated` (--sigma) or `residuals`.
    pub sigma_source: String,
    /// β per face.
    pub pitch_deviations: Vec<PitchJson>,
    /// U per run.
    pub setup_errors: Vec<SetupJson>,
    /// α at every sampled angle, sorted by angle over all shifts.
    pub encoder_errors: Vec<AlphaJson>,
    /// Residual statistics.
    pub residuals: ResidualsJson,
    /// Harmonic orders no polygon run can see (multiples of N).
    pub undetectable_harmonics: Vec<u32>,
    /// How the expanded uncertainties were formed.
    pub uncertainty: UncertaintySummary,
    /// Seed 000 §3.1 check, when it could be computed.
    pub harmonic_check: Option<CheckJson>,
    /// Identical duplicate readings kept once.
    pub duplicates_ignored: usize,
}

fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

impl ShiftAngleReport {
    /// Builds the report of a calibration.
    ///
    /// # Errors
    /// An instrument term that cannot be combined (invalid u or ν).
    pub fn new(
        cal: &Calibration,
        set: &ReadingSet,
        check: Option<&HarmonicCheck>,
        sigma_stated: bool,
        instrument: &Instrument,
    ) -> Result<Self> {
        let random_dof = random_dof(cal, sigma_stated);
        let mut encoder_errors = Vec::with_capacity(set.len());
        for m in cal.merged() {
            let c = instrument.combine(m.u_arcsec, random_dof)?;
            encoder_errors.push(AlphaJson {
                angle_deg: m.angle_deg,
                value_arcsec: m.value_arcsec,
                u_arcsec: c.as_ref().map_or(m.u_arcsec, |c| c.u_c),
                u_random_arcsec: m.u_arcsec,
                expanded_arcsec: c.as_ref().map(|c| c.expanded),
                k: c.as_ref().map(|c| c.k),
                nu_eff: c.as_ref().map(|c| c.nu_eff),
                shift_deg: m.shift_deg,
                step: m.step,
            });
        }
        Ok(ShiftAngleReport {
            method: cal.method.name().to_string(),
            faces: cal.faces,
            readings: set.len(),
            shifts_deg: set.shifts_deg().to_vec(),
            sigma_arcsec: finite(cal.sigma_used_arcsec),
            sigma_source: if sigma_stated { "stated" } else { "residuals" }.into(),
            pitch_deviations: cal
                .beta_arcsec
                .iter()
                .zip(&cal.u_beta_arcsec)
                .enumerate()
                .map(|(k, (&v, &u))| PitchJson {
                    face: k + 1,
                    value_arcsec: v,
                    u_arcsec: u,
                })
                .collect(),
            setup_errors: cal
                .setup
                .iter()
                .map(|u| SetupJson {
                    shift_deg: u.shift_deg,
                    start_face: u.start_face,
                    value_arcsec: u.value_arcsec,
                    u_arcsec: u.u_arcsec,
                })
                .collect(),
            encoder_errors,
            residuals: ResidualsJson {
                rms_arcsec: cal.residuals.rms_arcsec,
                max_abs_arcsec: cal.residuals.max_abs_arcsec,
                dof: cal.residuals.dof,
                count: cal.residuals.count,
                sigma_hat_arcsec: finite(cal.residuals.sigma_hat_arcsec),
                chi2: cal.residuals.chi2.map(|c| Chi2Json {
                    sigma_arcsec: c.sigma_arcsec,
                    chi2: c.chi2,
                    p_upper: c.p_upper,
                    consistent: c.consistent,
                }),
            },
            undetectable_harmonics: cal.undetectable_harmonics.clone(),
            harmonic_check: check.map(|c| CheckJson {
                order: c.order,
                amplitude_arcsec: c.amplitude_arcsec,
                u_amplitude_arcsec: c.u_amplitude_arcsec,
                phase_rad: c.phase_rad,
                u_phase_rad: c.u_phase_rad,
                shifts: c
                    .shifts
                    .iter()
                    .map(|s| CheckShiftJson {
                        shift_deg: s.shift_deg,
                        start_face: s.start_face,
                        u_fit_arcsec: s.u_fit_arcsec,
                        u_closure_arcsec: s.u_closure_arcsec,
                        difference_arcsec: s.difference_arcsec,
                    })
                    .collect(),
            }),
            duplicates_ignored: cal.duplicates_ignored,
            uncertainty: instrument.summary(random_dof),
        })
    }
}

/// Degrees of freedom of the random part: ∞ with a stated σ, else the residual dof.
fn random_dof(cal: &Calibration, sigma_stated: bool) -> f64 {
    if sigma_stated {
        f64::INFINITY
    } else {
        cal.residuals.dof as f64
    }
}

/// Parses `least-squares` or `paper`.
pub fn parse_method(s: &str) -> Result<Method> {
    match s {
        "least-squares" | "ls" => Ok(Method::LeastSquares),
        "paper" => Ok(Method::Paper),
        _ => Err(anyhow!("--method {s:?}: expected least-squares or paper")),
    }
}

/// Reads and validates a readings file; errors name the file, line and column.
pub fn read_readings(path: &Path, faces: Option<usize>) -> Result<ReadingSet> {
    let table = CsvTable::read(path)?;
    let c_shift = table.require("shift_deg", HEADER)?;
    let c_face = table.require("start_face", HEADER)?;
    let c_step = table.require("step", HEADER)?;
    let c_value = table.require("reading_arcsec", HEADER)?;
    let c_repeat = table.column("repeat");
    let mut readings = Vec::with_capacity(table.rows.len());
    let mut lines = Vec::with_capacity(table.rows.len());
    let mut max_index = 0i64;
    for (line, f) in &table.rows {
        let shift = table.f64_at(*line, f, c_shift)?;
        let face = table.int_at(*line, f, c_face)?;
        let step = table.int_at(*line, f, c_step)?;
        for (c, v) in [(c_face, face), (c_step, step)] {
            if v < 1 {
                return Err(table.error_at(
                    *line,
                    c,
                    format!("{v} is out of range: expected 1 or more"),
                ));
            }
            if let Some(n) = faces {
                if v > n as i64 {
                    return Err(table.error_at(
                        *line,
                        c,
                        format!("{v} is out of range: expected 1..={n} (--faces {n})"),
                    ));
                }
            }
        }
        max_index = max_index.max(face).max(step);
        let repeat = match c_repeat {
            Some(c) => {
                let r = table.int_at(*line, f, c)?;
                if !(1..=i64::from(u32::MAX)).contains(&r) {
                    return Err(table.error_at(
                        *line,
                        c,
                        format!("{r} is out of range: expected 1 or more"),
                    ));
                }
                r as u32
            }
            None => 1,
        };
        readings.push(Reading {
            shift_deg: shift,
            start_face: face as usize,
            step: step as usize,
            repeat,
            value_arcsec: table.f64_at(*line, f, c_value)?,
        });
        lines.push(*line);
    }
    if readings.is_empty() {
        return Err(anyhow!(
            "{}:{}: no readings after the header",
            table.name,
            table.header_line
        ));
    }
    let n = faces.unwrap_or(max_index as usize);
    ReadingSet::new(n, readings).map_err(|e| match e {
        ShiftAngleError::ConflictingDuplicate {
            index,
            first,
            first_value,
            value,
            ..
        } => anyhow!(
            "{}:{}: conflicting duplicate: reading {value} for the same shift, start_face, step and repeat as line {} ({first_value}); add a repeat column to keep both",
            table.name,
            lines[index],
            lines[first]
        ),
        ShiftAngleError::TooFewFaces { faces } => anyhow!(
            "{}: {faces} faces: expected a polygon with at least 3 faces (largest face/step number in the file, or --faces)",
            table.name
        ),
        e => anyhow!("{}: {e}", table.name),
    })
}

/// Runs `gonio shift-angle`.
pub fn run(args: Args) -> Result<()> {
    let method = parse_method(&args.method)?;
    let instrument = Instrument::load(args.instrument.as_deref(), args.coverage)?;
    let set = read_readings(&args.readings, args.faces)?;
    let opts = Options {
        method,
        sigma_arcsec: args.sigma,
        ..Options::default()
    };
    let cal = calibrate(&set, &opts).map_err(|e| anyhow!("{}: {e}", args.readings.display()))?;
    let check = harmonic_check(&cal, args.check_order).ok();
    let report = ShiftAngleReport::new(
        &cal,
        &set,
        check.as_ref(),
        args.sigma.is_some(),
        &instrument,
    )?;
    print_summary(&report);
    // The budget of the angle with the largest U.
    if let Some(worst) = cal
        .merged()
        .into_iter()
        .max_by(|a, b| a.u_arcsec.total_cmp(&b.u_arcsec))
    {
        let nu = random_dof(&cal, args.sigma.is_some());
        if let Some(c) = instrument.combine(worst.u_arcsec, nu)? {
            instrument.print_budget(
                &format!("α at {}° (the largest U)", worst.angle_deg),
                worst.u_arcsec,
                nu,
                &c,
            );
        }
    }
    if let Some(p) = &args.json {
        io::write_json(p, &report).context("writing the JSON result")?;
        eprintln!("wrote {}", p.display());
    }
    if let Some(p) = &args.compensation {
        let rows: Vec<Vec<String>> = report
            .encoder_errors
            .iter()
            .map(|a| {
                vec![
                    format!("{}", a.angle_deg),
                    format!("{:.6}", -a.value_arcsec),
                ]
            })
            .collect();
        io::write_csv(p, &["angle_deg", "correction_arcsec"], &rows)?;
        eprintln!("wrote {}", p.display());
    }
    Ok(())
}

/// Prints the human-readable summary.
pub fn print_summary(r: &ShiftAngleReport) {
    let shifts = if r.shifts_deg.len() > 6 {
        format!(
            "{}° … {}° ({} shifts)",
            r.shifts_deg[0],
            r.shifts_deg[r.shifts_deg.len() - 1],
            r.shifts_deg.len()
        )
    } else {
        r.shifts_deg
            .iter()
            .map(|s| format!("{s}°"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    println!("shift-angle calibration ({} method)", r.method);
    println!("  polygon faces      {}", r.faces);
    println!("  shifts             {shifts}");
    println!("  readings           {}", r.readings);
    match r.sigma_arcsec {
        Some(s) => println!("  σ per reading      {s:.4}″ ({})", r.sigma_source),
        None => {
            println!("  σ per reading      unknown (no residual degrees of freedom; give --sigma)")
        }
    }
    println!(
        "  residuals          RMS {:.4}″, max {:.4}″, dof {}",
        r.residuals.rms_arcsec, r.residuals.max_abs_arcsec, r.residuals.dof
    );
    if let Some(c) = &r.residuals.chi2 {
        println!(
            "  χ² check           χ² = {:.1}, P(χ² ≥ this) = {:.3}: {}",
            c.chi2,
            c.p_upper,
            if c.consistent {
                "consistent with the stated σ"
            } else {
                "NOT consistent with the stated σ"
            }
        );
    }
    let (lo, hi) = r
        .encoder_errors
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), e| {
            (a.min(e.value_arcsec), b.max(e.value_arcsec))
        });
    let umax = r
        .encoder_errors
        .iter()
        .map(|e| e.u_arcsec)
        .fold(0.0, f64::max);
    println!(
        "  encoder error α    {} angles, {:.3}″ … {:.3}″ (peak-to-peak {:.3}″), largest u {:.4}″",
        r.encoder_errors.len(),
        lo,
        hi,
        hi - lo,
        umax
    );
    println!("  pitch deviations β (face: value ± u, arcsec)");
    for chunk in r.pitch_deviations.chunks(4) {
        let line: Vec<String> = chunk
            .iter()
            .map(|p| format!("{:>3}: {:+.4} ± {:.4}", p.face, p.value_arcsec, p.u_arcsec))
            .collect();
        println!("    {}", line.join("   "));
    }
    if r.encoder_errors.len() <= 48 {
        println!("  encoder errors (angle: α ± u, arcsec)");
        for chunk in r.encoder_errors.chunks(4) {
            let line: Vec<String> = chunk
                .iter()
                .map(|a| {
                    format!(
                        "{:>7.2}°: {:+.4} ± {:.4}",
                        a.angle_deg, a.value_arcsec, a.u_arcsec
                    )
                })
                .collect();
            println!("    {}", line.join("   "));
        }
    } else {
        println!("  (the full α table is in --json and --compensation)");
    }
    if let Some(c) = &r.harmonic_check {
        println!(
            "  harmonic check     A·sin({}θ + B): A = {:.4}″ ± {:.4}″, B = {:.4} ± {:.4} rad",
            c.order, c.amplitude_arcsec, c.u_amplitude_arcsec, c.phase_rad, c.u_phase_rad
        );
        for s in c.shifts.iter().take(6) {
            println!(
                "    S = {:>6}°: U fit {:+.4}″, U closure {:+.4}″, difference {:+.1e}″",
                s.shift_deg, s.u_fit_arcsec, s.u_closure_arcsec, s.difference_arcsec
            );
        }
        if c.shifts.len() > 6 {
            println!("    … {} more shifts in --json", c.shifts.len() - 6);
        }
    }
    println!(
        "  undetectable       harmonics {:?} (multiples of N: a polygon cannot see them)",
        r.undetectable_harmonics
    );
    if r.duplicates_ignored > 0 {
        println!(
            "  note               {} identical duplicate readings kept once",
            r.duplicates_ignored
        );
    }
}
