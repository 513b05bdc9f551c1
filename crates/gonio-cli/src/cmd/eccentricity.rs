//! `gonio eccentricity`: the eccentricity of a grating from one turn's `(θ, c)` samples.

use crate::io::{CsvTable, write_json};
use anyhow::{Result, anyhow};
use gonio_station::StationError;
use gonio_station::fit::{FitMethod, FitOptions, Sample, fit, validate};
use serde::Serialize;
use std::path::PathBuf;

/// The fit method on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Method {
    /// Robust least-squares sinusoid with ridge-regularised roundness harmonics 2–4 (default).
    LeastSquares,
    /// The extreme points through cubic splines of Yu et al., 2024.
    Paper,
}

/// Arguments of `gonio eccentricity`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Input: CSV with a header and columns theta_deg,c_px (servo angle at mid-exposure, ring column),
one row per frame, angles increasing within the turn; partial turns and dropped frames are fine.

Example:
  gonio eccentricity turn.csv --um-per-px 0.75 --json ecc.json
  gonio eccentricity turn.csv --method paper")]
pub struct Args {
    /// Samples (CSV with `theta_deg,c_px`; `-` for standard input).
    pub samples: PathBuf,
    /// Fit method.
    #[arg(long, value_enum, default_value = "least-squares")]
    pub method: Method,
    /// Pixel scale on the grating, µm per px.
    #[arg(long, default_value_t = 0.75)]
    pub um_per_px: f64,
    /// Write the result as JSON here (`-` for standard output).
    #[arg(long)]
    pub json: Option<PathBuf>,
}

#[derive(Debug, Serialize)]
struct Output {
    method: &'static str,
    e_px: f64,
    e_um: f64,
    u_e_um: Option<f64>,
    theta_max_deg: f64,
    u_theta_max_deg: Option<f64>,
    c0_px: f64,
    residual_rms_px: f64,
    sigma_px: f64,
    frames_used: usize,
    outliers: usize,
    outlier_lines: Vec<u64>,
    arc_deg: f64,
    um_per_px: f64,
}

/// Runs `gonio eccentricity`.
pub fn run(a: Args) -> Result<()> {
    if !(a.um_per_px.is_finite() && a.um_per_px > 0.0) {
        return Err(anyhow!(
            "--um-per-px {}: expected a finite number > 0",
            a.um_per_px
        ));
    }
    let t = CsvTable::read(&a.samples)?;
    let expected = "theta_deg,c_px";
    let ct = t.require("theta_deg", expected)?;
    let cc = t.require("c_px", expected)?;
    let mut samples = Vec::with_capacity(t.rows.len());
    for (line, f) in &t.rows {
        samples.push(Sample {
            theta_deg: t.f64_at(*line, f, ct)?,
            c_px: t.f64_at(*line, f, cc)?,
        });
    }
    let line_of = |i: usize| t.rows.get(i).map_or(t.header_line, |r| r.0);
    if let Err(e) = validate(&samples) {
        return Err(match e {
            StationError::NotIncreasing { index, .. } => t.error_at(
                line_of(index),
                ct,
                format!("{e}: angles must increase within a turn"),
            ),
            StationError::NotFinite { index, what, .. } => {
                t.error_at(line_of(index), if what == "c_px" { cc } else { ct }, e)
            }
            StationError::TooFewSamples { .. } => {
                let last = t.rows.last().map_or(t.header_line, |r| r.0);
                anyhow!("{}:{}: {e}", t.name, last)
            }
            other => anyhow!("{}: {other}", t.name),
        });
    }
    let method = match a.method {
        Method::LeastSquares => FitMethod::LeastSquares,
        Method::Paper => FitMethod::Paper,
    };
    let f =
        fit(&samples, &FitOptions::with_method(method)).map_err(|e| anyhow!("{}: {e}", t.name))?;
    let um = a.um_per_px;
    let finite = |v: f64| v.is_finite().then_some(v);
    let out = Output {
        method: method.name(),
        e_px: f.e_px,
        e_um: f.e_px * um,
        u_e_um: finite(f.u_e_px * um),
        theta_max_deg: f.theta_max_deg,
        u_theta_max_deg: finite(f.u_theta_max_deg),
        c0_px: f.c0_px,
        residual_rms_px: f.residual_rms_px,
        sigma_px: f.sigma_px,
        frames_used: f.frames_used,
        outliers: f.outliers.len(),
        outlier_lines: f.outliers.iter().map(|&i| line_of(i)).collect(),
        arc_deg: f.arc_deg,
        um_per_px: um,
    };
    let to_stdout = a.json.as_deref().is_some_and(|p| p.as_os_str() == "-");
    if !to_stdout {
        let u = out
            .u_e_um
            .map_or(String::new(), |u| format!(" ± {u:.3} µm (1σ)"));
        println!(
            "e = {:.3} µm{u} ({:.3} px) at θ_max = {:.3}°, c₀ = {:.2} px",
            out.e_um, out.e_px, out.theta_max_deg, out.c0_px
        );
        println!(
            "method {}, {} frames used over {:.1}°, {} outliers, residual RMS {:.3} px",
            out.method, out.frames_used, out.arc_deg, out.outliers, out.residual_rms_px
        );
    }
    if let Some(p) = &a.json {
        write_json(p, &out)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run_on(text: &str, method: Method) -> Result<()> {
        let d = tempfile::tempdir()?;
        let p = d.path().join("s.csv");
        std::fs::write(&p, text)?;
        run(Args {
            samples: p,
            method,
            um_per_px: 0.75,
            json: Some(d.path().join("o.json")),
        })
    }

    fn err(text: &str) -> String {
        crate::io::one_line(&run_on(text, Method::LeastSquares).unwrap_err())
    }

    #[test]
    fn bad_input_names_file_and_line() {
        assert!(err("theta_deg,c_px\n0,1\n1,2\n").contains("s.csv:3: too few samples"));
        let e = err("theta_deg,c_px\n0,1\n1,NaN\n2,3\n");
        assert!(e.contains("s.csv:3:2: column 'c_px'"), "{e}");
        let e = err("theta_deg,c_px\n0,1\n2,2\n1,3\n3,4\n");
        assert!(
            e.contains("s.csv:4:1: column 'theta_deg'") && e.contains("increase"),
            "{e}"
        );
        let e = err("theta,c\n0,1\n");
        assert!(e.contains("missing column 'theta_deg'"), "{e}");
    }

    #[test]
    fn writes_the_contract_fields() {
        let mut s = String::from("theta_deg,c_px\n");
        for i in 0..200 {
            let t = 1.8 * i as f64;
            s.push_str(&format!(
                "{t},{}\n",
                700.0 + 10.0 * (t - 40.0f64).to_radians().cos()
            ));
        }
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("s.csv");
        std::fs::write(&p, &s).unwrap();
        let o = d.path().join("o.json");
        for m in [Method::LeastSquares, Method::Paper] {
            run(Args {
                samples: p.clone(),
                method: m,
                um_per_px: 0.75,
                json: Some(o.clone()),
            })
            .unwrap();
            let v: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(&o).unwrap()).unwrap();
            for k in [
                "e_px",
                "e_um",
                "theta_max_deg",
                "c0_px",
                "residual_rms_px",
                "frames_used",
                "outliers",
                "method",
            ] {
                assert!(v.get(k).is_some(), "{k}");
            }
            assert!((v["e_um"].as_f64().unwrap() - 7.5).abs() < 1e-5);
        }
    }
}
