//! `gonio selfcal`: self-calibration of an encoder from several read heads (EDA, SelfA, Fourier).

use crate::db;
use anyhow::{Context, Result, bail};
use gonio_calib::certificate::Certificate;
use gonio_calib::selfcal::{Method, NoiseModel, SelfcalOptions, calibrate};
use gonio_cli::flag;
use gonio_cli::output::Outputs;
use gonio_io::formats::csv::CsvTable;
use gonio_io::formats::heads::{self, locate, read_turns};
use gonio_io::formats::{self};
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of `gonio selfcal`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Input (one rotation position a row, NS rows equally spaced over one turn, header required; at
most 64 MiB):
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
    #[arg(long, default_value = "fourier")]
    pub method: String,
    /// The CSV holds raw head readings in degrees (`head_1..head_M`).
    #[arg(long)]
    pub raw: bool,
    /// Noise model for the uncertainty: `readings` (independent noise per head reading, so
    /// head 1's noise is common to every difference) or `differences`.
    #[arg(long, default_value = "readings")]
    pub noise_model: String,
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

/// Parses a list of 1-based head numbers (`1,7`) into 0-based indices.
fn parse_reference(s: &str, m: usize) -> Result<Vec<usize>> {
    s.split(',')
        .map(|p| {
            let h: usize = p
                .trim()
                .parse()
                .ok()
                .filter(|h| (1..=m).contains(h))
                .with_context(|| {
                    format!("--reference {s:?}: {p:?} is not a head number in 1..={m}")
                })?;
            Ok(h - 1)
        })
        .collect()
}

/// Largest readings file: 64 MiB (10 turns of 36,000 positions with 12 heads are ≈ 50 MB).
/// Reading, parsing and solving keep about 8 bytes of memory per byte of it (≈ 0.5 GB at the
/// limit); checked before anything is read.
const MAX_READINGS_BYTES: usize = 64 << 20;

/// Runs `gonio selfcal`.
pub fn run(args: Args) -> Result<()> {
    let mut out = Outputs::new();
    let json = out.optional("--json", args.to.json.as_deref())?;
    let (heads, _) = heads::load(&args.heads)?;
    let method = match args.method.as_str() {
        "fourier" => Method::Fourier,
        "eda" | "selfa" => Method::Eda,
        s => bail!("--method {s:?}: expected fourier or eda"),
    };
    let noise_model = match args.noise_model.as_str() {
        "readings" => NoiseModel::Readings,
        "differences" => NoiseModel::Differences,
        s => bail!("--noise-model {s:?}: expected readings or differences"),
    };
    let reference_heads = parse_reference(&args.reference, heads.len())?;
    let table = {
        let bytes = gonio_io::input::read_bytes(&args.readings, MAX_READINGS_BYTES)?;
        let name = args.readings.display().to_string();
        CsvTable::parse(&name, &gonio_io::input::decode(&name, &bytes)?)?
    };
    let rt = read_turns(&table, &heads, args.raw)?;
    let opts = SelfcalOptions {
        method,
        noise_model,
        reference_heads,
        max_order: args.max_order,
    };
    let instrument = formats::instrument::load(args.instrument.as_deref(), args.coverage)?;
    let meta = args.meta.as_deref().map(formats::meta::load).transpose()?;
    let r = calibrate(&heads, &rt.turns, &opts).map_err(|e| locate(e, &table, &rt.lines))?;
    let mut cert = Certificate::from_selfcal(&r, &instrument)?;
    if let Some(m) = meta {
        cert = cert.with_meta(m);
    }
    // Overflow (a reading of 1e308) is an error naming the input, before any output.
    gonio_io::json::finite_result(&cert, &args.readings, "the calibration")?;
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

#[cfg(test)]
mod tests {
    use super::*;

    fn run_csv(text: &str, heads: &str, raw: bool) -> Result<gonio_calib::selfcal::SelfcalResult> {
        let (heads, _) = heads::load(heads)?;
        let table = CsvTable::parse("r.csv", text)?;
        let rt = read_turns(&table, &heads, raw)?;
        calibrate(&heads, &rt.turns, &SelfcalOptions::default())
            .map_err(|e| locate(e, &table, &rt.lines))
    }

    fn csv(rows: usize, step: f64, f: impl Fn(usize) -> String) -> String {
        let mut s = String::from("position_deg,head_2,head_3\n");
        for i in 0..rows {
            s.push_str(&format!("{},{}\n", i as f64 * step, f(i)));
        }
        s
    }

    #[test]
    fn good_file_and_one_line_errors_with_file_and_line() {
        let ok = csv(36, 10.0, |i| format!("{},0.2", (i as f64).sin()));
        let r = run_csv(&ok, "eda:3", false).unwrap();
        assert_eq!(r.errors.len(), 36);
        // Position 7 (file line 9) off the 10° grid.
        let bad = csv(36, 10.0, |_| "0.1,0.2".into()).replace("\n70,", "\n71,");
        let e = gonio_io::input::one_line(&run_csv(&bad, "eda:3", false).unwrap_err());
        assert!(
            e.starts_with("r.csv:9: column 'position_deg': found 71°"),
            "{e}"
        );
        // Half a turn.
        let e = gonio_io::input::one_line(
            &run_csv(&csv(36, 5.0, |_| "0,0".into()), "eda:3", false).unwrap_err(),
        );
        assert!(e.starts_with("r.csv:3: column 'position_deg'"), "{e}");
        // NaN and ragged rows.
        let e = gonio_io::input::one_line(
            &run_csv(
                &csv(
                    36,
                    10.0,
                    |i| if i == 3 { "NaN,0".into() } else { "0,0".into() },
                ),
                "eda:3",
                false,
            )
            .unwrap_err(),
        );
        assert!(e.starts_with("r.csv:5:2: column 'head_2'"), "{e}");
        let e = gonio_io::input::one_line(
            &run_csv(
                &csv(36, 10.0, |i| if i == 2 { "0".into() } else { "0,0".into() }),
                "eda:3",
                false,
            )
            .unwrap_err(),
        );
        assert!(e.starts_with("r.csv:4: expected 3 fields"), "{e}");
        // Head count not matching the heads.
        let e = gonio_io::input::one_line(&run_csv(&ok, "eda:4", false).unwrap_err());
        assert!(e.starts_with("r.csv:1: 2 head columns for 4 heads"), "{e}");
        let e = gonio_io::input::one_line(&run_csv(&ok, "eda:3", true).unwrap_err());
        assert!(e.contains("expected head_1,head_2,head_3"), "{e}");
        // Too few rows.
        let e = gonio_io::input::one_line(
            &run_csv(&csv(4, 90.0, |_| "0,0".into()), "eda:3", false).unwrap_err(),
        );
        assert!(e.starts_with("r.csv:5: turn 1: expected at least 8"), "{e}");
    }

    #[test]
    fn turns_column_groups_rows() {
        let mut s = String::from("position_deg,head_2,turn\n");
        for t in [2, 1] {
            for i in 0..12 {
                s.push_str(&format!("{},{},{t}\n", i * 30, 0.01 * t as f64));
            }
        }
        let r = run_csv(&s, "eda:2", false).unwrap();
        assert_eq!(r.turns, 2);
        assert_eq!(r.uncertainty.source, "repeated turns");
        let s = s.replace(",1\n", ",0\n");
        let e = gonio_io::input::one_line(&run_csv(&s, "eda:2", false).unwrap_err());
        assert!(e.contains("turn number ≥ 1"), "{e}");
    }
}
