//! `gonio selfcal`: self-calibration of an encoder from several read heads (EDA, SelfA, Fourier).

use crate::db;
use anyhow::Result;
use gonio_calib::certificate::Certificate;
use gonio_calib::selfcal::{Method, NoiseModel};
use gonio_cli::flag;
use gonio_cli::output::Outputs;
use gonio_io::formats::heads;
use gonio_io::formats::source::{Document, Table};
use gonio_io::results::selfcal::{Request, evaluate};
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of `gonio selfcal`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Input (one rotation position a row, NS rows equally spaced over one turn, header required; at
most 256 MiB):
  position_deg,head_2,…,head_M      head h minus head 1, arcsec (default)
  position_deg,head_1,…,head_M      raw head readings, degrees (--raw)
  an optional `turn` column (1, 2, …) holds repeated turns; u then comes from their spread.
Heads: `selfa12` (the 12 heads of the SelfA encoder in Hsieh et al., 2022: 3, 4 and 7 equal
divisions), `eda:N` (N equally spaced), or a TOML/JSON file:
  angles_deg = [0, 90, 180, 270]   (optional: sets = [[1, 3], [1, 2, 3, 4]])
--json writes a gonio.certificate/1 (see docs/certificate.md).

Examples:
  gonio simulate selfcal --heads selfa12 --positions 36000 --seed 1 --out sc
  gonio selfcal sc/readings.csv --heads selfa12 --json sc/result.json
  gonio selfcal sc/readings.csv --heads selfa12 --instrument examples/instrument-selfcal.toml \
        --coverage 0.99 --meta examples/certificate-meta.toml --json sc/result.json
  gonio selfcal sc/readings.csv --heads selfa12 --method eda --reference 1,7
  gonio selfcal raw.csv --raw --heads heads.toml --max-order 100")]
pub struct Args {
    /// Readings CSV (`-` for standard input).
    pub readings: PathBuf,
    /// Head arrangement: `selfa12`, `eda:N`, or a TOML/JSON heads file.
    #[arg(long)]
    pub heads: String,
    /// Estimator: `fourier` (least squares, any heads) or `eda` (equal-division averaging;
    /// the SelfA combination when the heads have several sets).
    #[arg(long, value_enum, default_value_t, hide_possible_values = true)]
    pub method: Method,
    /// The CSV holds raw head readings in degrees (`head_1..head_M`).
    #[arg(long)]
    pub raw: bool,
    /// Noise model for the uncertainty: `readings` (independent noise per head reading, so
    /// head 1's noise is common to every difference) or `differences`.
    #[arg(long, value_enum, default_value_t, hide_possible_values = true)]
    pub noise_model: NoiseModel,
    /// Heads (1-based) whose averaged reading is calibrated, e.g. `1,7` as in SelfA.
    #[arg(long, default_value = "1")]
    pub reference: String,
    /// Largest harmonic order in the harmonic table and the undetectable list.
    #[arg(long, default_value_t = 360, value_parser = flag::whole::<u32>(flag::MAX_ORDER))]
    pub max_order: u32,
    /// Instrument terms (TOML, e.g. examples/instrument-selfcal.toml: encoder resolution …)
    /// combined with the estimator's random part into u, ν_eff, k and U of every position.
    #[arg(long)]
    pub instrument: Option<PathBuf>,
    /// Coverage probability of U (default: the instrument file's, else 0.95).
    #[arg(long, value_parser = flag::real(gonio_uncertainty::COVERAGE))]
    pub coverage: Option<f64>,
    // `--json` and `--db`, shared with the other calibration commands.
    #[command(flatten)]
    pub to: db::CertificateTargets,
    /// Certificate metadata (TOML, ISO/IEC 17025 §7.8), carried in the certificate. See
    /// examples/certificate-meta.toml.
    #[arg(long)]
    pub meta: Option<PathBuf>,
}

/// Runs `gonio selfcal`.
pub fn run(args: Args) -> Result<()> {
    let mut out = Outputs::new();
    if let Some(loc) = &args.to.db {
        db::reserve(out.inputs(), loc);
    }
    let json = out.optional("--json", args.to.json.as_deref())?;
    let (heads, _) = heads::load(out.inputs(), &args.heads)?;
    let request = Request {
        readings: Table::File(args.readings.clone()),
        heads,
        method: args.method,
        raw: args.raw,
        noise_model: args.noise_model,
        reference: args.reference.clone(),
        max_order: args.max_order,
        instrument: args.instrument.clone().map(Document::File),
        coverage: args.coverage,
        meta: args.meta.clone().map(Document::File),
    };
    let cert = evaluate(out.inputs(), request)?;
    let to_stdout = out.to_stdout(json);
    if let Some(j) = json {
        out.json(j, &cert)?;
    }
    if let Some(loc) = &args.to.db {
        db::store_certificate(loc, &cert, &args.readings.display().to_string())?;
    }
    if !to_stdout {
        print_summary(&cert)?;
    }
    out.commit()
}

fn print_summary(c: &Certificate) -> Result<()> {
    let mut out = String::new();
    let Some(r) = &c.selfcal else {
        return Ok(());
    };
    let e0 = &c.points[0];
    let (lo, hi) = c
        .points
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), e| {
            (a.min(e.value_arcsec), b.max(e.value_arcsec))
        });
    let _ = writeln!(out, "{}", c.method_title());
    let _ = writeln!(
        out,
        "{}: {} heads, {} positions × {} turn(s); reference head(s) {:?}",
        c.method,
        r.heads_deg.len(),
        r.positions,
        r.turns,
        r.reference_heads
    );
    let opt = |v: Option<f64>, d: usize| v.map_or("–".to_string(), |x| format!("{x:.d$}"));
    let _ = writeln!(
        out,
        "a(θ): {lo:+.4}″ … {hi:+.4}″; u = {:.4}″, U = {}″ (k = {}, ν = {}, p = {}, from {})",
        e0.u_arcsec,
        opt(e0.expanded_arcsec, 4),
        opt(e0.k, 3),
        e0.nu_eff.map_or("–".into(), crate::table::dof_text),
        c.uncertainty.coverage,
        c.uncertainty.source
    );
    let _ = writeln!(
        out,
        "residuals: rms {:.4}″, max {:.4}″, σ̂ {}″ per {} ({:.0} dof)",
        c.residuals.rms_arcsec,
        c.residuals.max_abs_arcsec,
        crate::table::fixed(c.residuals.sigma_arcsec, 4),
        c.noise_unit().unwrap_or("reading"),
        c.residuals.dof
    );
    let und = &c.undetectable_orders;
    let _ = writeln!(
        out,
        "undetectable harmonics up to order {}: {}",
        r.max_order,
        if und.is_empty() {
            "none".to_string()
        } else if und.len() > 12 {
            format!("{:?}… ({} orders)", &und[..12], und.len())
        } else {
            format!("{und:?}")
        }
    );
    let mut top: Vec<_> = r.harmonics.iter().filter(|h| h.detectable).collect();
    top.sort_by(|a, b| b.amplitude_arcsec.total_cmp(&a.amplitude_arcsec));
    let _ = writeln!(out, "largest harmonics (A·sin(kθ + φ)):");
    for h in top.iter().take(6) {
        let _ = writeln!(
            out,
            "  k = {:>4}: A = {:.4}″ ± {:.4}″, φ = {:+.4} rad",
            h.order, h.amplitude_arcsec, h.u_coefficient_arcsec, h.phase_rad
        );
    }
    gonio_cli::term::out(&out)
}
