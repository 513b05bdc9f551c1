//! `gonio shift-angle`: calibrate an encoder from polygon + autocollimator readings.

use crate::db;
use anyhow::Result;
use gonio_calib::certificate::Certificate;
use gonio_calib::shift_angle::Method;
use gonio_cli::flag;
use gonio_cli::output::Outputs;
use gonio_core::bound::Bound;
use gonio_io::formats::source::{Document, Table};
use gonio_io::results::shift_angle::{Request, evaluate};
use std::path::PathBuf;

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
    #[arg(long, value_enum, default_value_t, hide_possible_values = true)]
    pub method: Method,
    /// Standard deviation of one reading, arcsec, if known: scales the uncertainties and is
    /// checked against the residuals (χ²). Default: estimated from the residuals.
    #[arg(long, value_parser = flag::real(flag::SIGMA_ARCSEC))]
    pub sigma: Option<f64>,
    /// Polygon faces N. Default: the largest face or step number in the file.
    #[arg(long, value_parser = flag::whole::<usize>(flag::FACES))]
    pub faces: Option<usize>,
    /// Harmonic order of the setup-error check (Hsieh et al., 2022, §3.1 uses 2), 1 to 1000.
    #[arg(long, default_value_t = 2, value_parser = flag::whole::<u32>(CHECK_ORDER))]
    pub check_order: u32,
    // `--json` and `--db`, shared with the other calibration commands.
    #[command(flatten)]
    pub to: db::CertificateTargets,
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
    #[arg(long, value_parser = flag::real(gonio_uncertainty::COVERAGE))]
    pub coverage: Option<f64>,
    /// Write the compensation table `angle_deg,correction_arcsec` (correction = −α, to add to
    /// the encoder's reading).
    #[arg(long)]
    pub compensation: Option<PathBuf>,
}

/// `--check-order`: any order a polygon can have faces for.
const CHECK_ORDER: Bound = Bound::new(1.0, gonio_calib::shift_angle::MAX_FACES as f64, "");

/// Runs `gonio shift-angle`.
pub fn run(args: Args) -> Result<()> {
    let mut out = Outputs::new();
    if let Some(loc) = &args.to.db {
        db::reserve(out.inputs(), loc);
    }
    let json = out.optional("--json", args.to.json.as_deref())?;
    let comp = out.optional("--compensation", args.compensation.as_deref())?;
    let request = Request {
        readings: Table::File(args.readings.clone()),
        faces: args.faces,
        method: args.method,
        sigma_arcsec: args.sigma,
        check_order: args.check_order,
        instrument: args.instrument.clone().map(Document::File),
        coverage: args.coverage,
        meta: args.meta.clone().map(Document::File),
    };
    let cert = evaluate(out.inputs(), request)?;
    let to_stdout = out.to_stdout(json);
    out.certificate(json, comp, &cert)?;
    if !to_stdout {
        print_summary(&cert)?;
    }
    out.commit()?;
    for p in [&args.to.json, &args.compensation].into_iter().flatten() {
        if p.as_os_str() != "-" {
            gonio_cli::note!("wrote {}", p.display());
        }
    }
    if let Some(loc) = &args.to.db {
        db::store_certificate(loc, &cert, &args.readings.display().to_string())?;
    }
    Ok(())
}

/// Prints the human-readable summary of a shift-angle certificate.
pub fn print_summary(c: &Certificate) -> Result<()> {
    use std::fmt::Write as _;
    let Some(sa) = &c.shift_angle else {
        return Ok(());
    };
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
            gonio_core::bound::Num(c.uncertainty.coverage)
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
            "  harmonic check     A·sin({}θ + B): A = {:.4}″ ± {}″, B = {:.4} ± {} rad",
            h.order,
            h.amplitude_arcsec,
            crate::table::fixed(h.u_amplitude_arcsec, 4),
            h.phase_rad,
            crate::table::fixed(h.u_phase_rad, 4)
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
        crate::table::budget::text(&mut t, b);
        for l in t.lines() {
            let _ = writeln!(out, "    {l}");
        }
    }
    gonio_cli::term::out(&out)
}
