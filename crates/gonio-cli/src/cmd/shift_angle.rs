//! `gonio shift-angle`: calibrate an encoder from polygon + autocollimator readings.

use crate::db;
use crate::formats;
use crate::io::{self, CsvTable};
use anyhow::{Context, Result, anyhow};
use gonio_calib::certificate::Certificate;
use gonio_calib::shift_angle::{Method, Options, Reading, ReadingSet, ShiftAngleError, calibrate};
use std::path::{Path, PathBuf};

/// The readings file's header.
pub const HEADER: &str = "shift_deg,start_face,step,reading_arcsec[,repeat]";

/// Arguments of `gonio shift-angle`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Input: a CSV with header shift_deg,start_face,step,reading_arcsec (optional column repeat), one
reading a row; faces and steps 1-based as in Hsieh et al. (2022); `#` comment lines allowed; `-`
reads stdin. --json writes a gonio.certificate/1 (see docs/certificate.md); `gonio report` turns it
into an HTML report and `gonio certificate --dcc` into a Digital Calibration Certificate.

Examples:
  gonio simulate shift-angle --shifts 0:1:14 --seed 1 --out lab
  gonio shift-angle lab/readings.csv --json cal.json --compensation comp.csv
  gonio shift-angle lab/readings.csv --instrument examples/instrument-shift-angle.toml \
        --meta examples/certificate-meta.toml --json cal.json
  gonio shift-angle lab/readings.csv --method paper --sigma 0.05")]
pub struct Args {
    /// Readings CSV (`-` for standard input).
    pub readings: PathBuf,
    /// Estimator: `least-squares` (all readings jointly; default) or `paper` (the algorithm of
    /// Hsieh et al., 2022).
    #[arg(long, default_value = "least-squares")]
    pub method: String,
    /// Standard deviation of one reading, arcsec, if known: scales the uncertainties and is
    /// checked against the residuals (χ²). Default: estimated from the residuals.
    #[arg(long)]
    pub sigma: Option<f64>,
    /// Polygon faces N. Default: the largest face or step number in the file.
    #[arg(long)]
    pub faces: Option<usize>,
    /// Harmonic order of the setup-error check (Hsieh et al., 2022, §3.1 uses 2).
    #[arg(long, default_value_t = 2)]
    pub check_order: u32,
    /// Write the certificate (gonio.certificate/1 JSON) here (`-` for standard output).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Store the certificate whole in this results store (a SQLite file, created if missing, or
    /// a postgres:// URL), indexed by item, method, date, largest |α| and largest U; the
    /// dashboard (`gonio serve`) lists it.
    #[arg(long, value_name = "PATH|postgres://…")]
    pub db: Option<String>,
    /// Certificate metadata (TOML, ISO/IEC 17025 §7.8: laboratory, customer, item, dates …),
    /// carried in the certificate. See examples/certificate-meta.toml.
    #[arg(long)]
    pub meta: Option<PathBuf>,
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
    let instrument = formats::instrument::load(args.instrument.as_deref(), args.coverage)?;
    let meta = args.meta.as_deref().map(formats::meta::load).transpose()?;
    let set = read_readings(&args.readings, args.faces)?;
    let opts = Options {
        method,
        sigma_arcsec: args.sigma,
        ..Options::default()
    };
    let cal = calibrate(&set, &opts).map_err(|e| anyhow!("{}: {e}", args.readings.display()))?;
    let mut cert = Certificate::from_shift_angle(
        &cal,
        &set,
        args.sigma.is_some(),
        args.check_order,
        &instrument,
    )?;
    if let Some(m) = meta {
        cert = cert.with_meta(m);
    }
    let to_stdout = args.json.as_deref() == Some(Path::new("-"));
    if !to_stdout {
        print_summary(&cert);
    }
    if let Some(p) = &args.json {
        io::write_json(p, &cert).context("writing the certificate")?;
        if !to_stdout {
            eprintln!("wrote {}", p.display());
        }
    }
    if let Some(loc) = &args.db {
        db::store_certificate(loc, &cert, &args.readings.display().to_string())?;
    }
    if let Some(p) = &args.compensation {
        let rows: Vec<Vec<String>> = cert
            .compensation
            .iter()
            .map(|c| {
                vec![
                    format!("{}", c.angle_deg),
                    format!("{:.6}", c.correction_arcsec),
                ]
            })
            .collect();
        io::write_csv(p, &["angle_deg", "correction_arcsec"], &rows)?;
        eprintln!("wrote {}", p.display());
    }
    Ok(())
}

/// Prints the human-readable summary of a shift-angle certificate.
pub fn print_summary(c: &Certificate) {
    use std::fmt::Write as _;
    let Some(sa) = &c.shift_angle else { return };
    let mut out = String::new();
    let shifts = if sa.shifts_deg.len() > 6 {
        format!(
            "{}° … {}° ({} shifts)",
            sa.shifts_deg[0],
            sa.shifts_deg[sa.shifts_deg.len() - 1],
            sa.shifts_deg.len()
        )
    } else {
        sa.shifts_deg
            .iter()
            .map(|s| format!("{s}°"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let _ = writeln!(out, "{}", c.method_title());
    let _ = writeln!(out, "  polygon faces      {}", sa.faces);
    let _ = writeln!(out, "  shifts             {shifts}");
    let _ = writeln!(out, "  readings           {}", sa.readings);
    match sa.sigma_arcsec {
        Some(s) => {
            let _ = writeln!(out, "  σ per reading      {s:.4}″ ({})", sa.sigma_source);
        }
        None => {
            let _ = writeln!(
                out,
                "  σ per reading      unknown (no residual degrees of freedom; give --sigma)"
            );
        }
    }
    let r = &c.residuals;
    let _ = writeln!(
        out,
        "  residuals          RMS {:.4}″, max {:.4}″, dof {}",
        r.rms_arcsec,
        r.max_abs_arcsec,
        crate::table::dof_text(r.dof)
    );
    if let Some(x) = &r.chi2 {
        let _ = writeln!(
            out,
            "  χ² check           χ² = {:.1}, P(χ² ≥ this) = {:.3}: {}",
            x.chi2,
            x.p_upper,
            if x.consistent {
                "consistent with the stated σ"
            } else {
                "NOT consistent with the stated σ"
            }
        );
    }
    let umax = c.points.iter().map(|e| e.u_arcsec).fold(0.0, f64::max);
    let _ = writeln!(
        out,
        "  encoder error α    {} angles, largest |α| {:.3}″ (peak-to-peak {:.3}″), largest u {:.4}″{}",
        c.points.len(),
        c.max_abs_error_arcsec(),
        c.peak_to_peak_arcsec(),
        umax,
        c.max_expanded_arcsec().map_or(String::new(), |u| format!(
            ", largest U {u:.4}″ (p = {})",
            c.uncertainty.coverage
        ))
    );
    let _ = writeln!(out, "  pitch deviations β (face: value ± u, arcsec)");
    for chunk in sa.pitch_deviations.chunks(4) {
        let line: Vec<String> = chunk
            .iter()
            .map(|p| format!("{:>3}: {:+.4} ± {:.4}", p.face, p.value_arcsec, p.u_arcsec))
            .collect();
        let _ = writeln!(out, "    {}", line.join("   "));
    }
    if c.points.len() <= 48 {
        let _ = writeln!(out, "  encoder errors (angle: α ± u, arcsec)");
        for chunk in c.points.chunks(4) {
            let line: Vec<String> = chunk
                .iter()
                .map(|a| {
                    format!(
                        "{:>7.2}°: {:+.4} ± {:.4}",
                        a.angle_deg, a.value_arcsec, a.u_arcsec
                    )
                })
                .collect();
            let _ = writeln!(out, "    {}", line.join("   "));
        }
    } else {
        let _ = writeln!(out, "  (the full α table is in --json and --compensation)");
    }
    if let Some(h) = &sa.harmonic_check {
        let _ = writeln!(
            out,
            "  harmonic check     A·sin({}θ + B): A = {:.4}″ ± {:.4}″, B = {:.4} ± {:.4} rad",
            h.order, h.amplitude_arcsec, h.u_amplitude_arcsec, h.phase_rad, h.u_phase_rad
        );
        for s in h.shifts.iter().take(6) {
            let _ = writeln!(
                out,
                "    S = {:>6}°: U fit {:+.4}″, U closure {:+.4}″, difference {:+.1e}″",
                s.shift_deg, s.u_fit_arcsec, s.u_closure_arcsec, s.difference_arcsec
            );
        }
        if h.shifts.len() > 6 {
            let _ = writeln!(out, "    … {} more shifts in --json", h.shifts.len() - 6);
        }
    }
    let _ = writeln!(
        out,
        "  undetectable       harmonics {:?} (multiples of N: a polygon cannot see them)",
        c.undetectable_orders
    );
    if sa.duplicates_ignored > 0 {
        let _ = writeln!(
            out,
            "  note               {} identical duplicate readings kept once",
            sa.duplicates_ignored
        );
    }
    if let Some(b) = &c.budget {
        let _ = writeln!(out, "  uncertainty budget of the angle with the largest U:");
        let mut t = String::new();
        crate::table::text_table(&mut t, b);
        for l in t.lines() {
            let _ = writeln!(out, "    {l}");
        }
    }
    crate::io::emit(&out);
}
