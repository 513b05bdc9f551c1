//! `gonio eccentricity`: the eccentricity of a grating from one turn's `(θ, c)` samples.

use anyhow::Result;
use gonio_cli::flag;
use gonio_cli::output::Outputs;
use gonio_cli::say;
use gonio_io::formats::csv::CsvTable;
use gonio_io::formats::{recipe, samples};
use gonio_io::results::eccentricity::{Settings, evaluate};
use gonio_station::Recipe;
use gonio_station::fit::FitMethod;
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

Every fit is judged by the station's quality gate (residual RMS, coverage and largest gap,
frames used, outliers, u(e) against the acceptance threshold, agreement of the two half-turns;
limits derived from the detector's accuracy, see docs/quality-gates.md). A turn that fails it
is reported as not trusted, with the reasons (exit code 0: the fit itself succeeded).

Example:
  gonio eccentricity turn.csv --um-per-px 0.75 --json ecc.json
  gonio eccentricity turn.csv --frames-taken 200 --threshold-um 5
  gonio eccentricity turn.csv --recipe examples/recipes/r25-fine.toml
  gonio eccentricity turn.csv --method paper")]
pub struct Args {
    /// Samples (CSV with `theta_deg,c_px`; `-` for standard input).
    pub samples: PathBuf,
    /// Fit method.
    #[arg(long, value_enum, default_value = "least-squares")]
    pub method: Method,
    /// Pixel scale on the grating, µm per px [default: the recipe's, else 0.75].
    #[arg(long, value_parser = flag::real(gonio_station::recipe::UM_PER_PX))]
    pub um_per_px: Option<f64>,
    /// Frames the turn had, valid or not [default: the rows of the file].
    #[arg(long, value_parser = flag::whole::<usize>(gonio_station::recipe::FRAMES_PER_TURN))]
    pub frames_taken: Option<usize>,
    /// Acceptance threshold of e, µm, against which u(e) is judged [default: the recipe's, else
    /// 5].
    #[arg(long, value_parser = flag::real(gonio_station::recipe::THRESHOLD_UM))]
    pub threshold_um: Option<f64>,
    /// Recipe (TOML) whose fit settings and quality limits to use.
    #[arg(long)]
    pub recipe: Option<PathBuf>,
    /// Write the result as JSON here (`-` for standard output).
    #[arg(long)]
    pub json: Option<PathBuf>,
}

/// Runs `gonio eccentricity`.
pub fn run(a: Args) -> Result<()> {
    let mut outputs = Outputs::new();
    let json = outputs.optional("--json", a.json.as_deref())?;
    let recipe = match &a.recipe {
        Some(p) => recipe::load(outputs.inputs(), p)?,
        None => Recipe::default(),
    };
    let settings = Settings::new(recipe, a.um_per_px, a.threshold_um)?;
    let read = samples::from_table(CsvTable::read(outputs.inputs(), &a.samples)?)?;
    let method = match a.method {
        Method::LeastSquares => FitMethod::LeastSquares,
        Method::Paper => FitMethod::Paper,
    };
    let out = evaluate(&read, &settings, method, a.frames_taken)?;
    let to_stdout = outputs.to_stdout(json);
    if !to_stdout {
        let u = out
            .u_e_um
            .map_or(String::new(), |u| format!(" ± {u:.3} µm (1σ)"));
        say!(
            "e = {:.3} µm{u} ({:.3} px) at θ_max = {:.3}°, c₀ = {:.2} px",
            out.e_um,
            out.e_px,
            out.theta_max_deg,
            out.c0_px
        )?;
        say!(
            "method {}, {} frames used over {:.1}°, {} outliers, residual RMS {:.3} px",
            out.method,
            out.frames_used,
            out.arc_deg,
            out.outliers,
            out.residual_rms_px
        )?;
        if out.quality_ok {
            say!("quality: trusted (every check of the quality gate passed)")?;
        } else {
            say!(
                "quality: NOT TRUSTED, do not push on this turn: {}",
                out.quality_reasons.join("; ")
            )?;
        }
    }
    if let Some(j) = json {
        outputs.json(j, &out)?;
    }
    outputs.commit()
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
            um_per_px: Some(0.75),
            frames_taken: None,
            threshold_um: None,
            recipe: None,
            json: Some(d.path().join("o.json")),
        })
    }

    fn err(text: &str) -> String {
        gonio_io::input::one_line(&run_on(text, Method::LeastSquares).unwrap_err())
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
                um_per_px: Some(0.75),
                frames_taken: None,
                threshold_um: None,
                recipe: None,
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
                "quality_ok",
                "quality_reasons",
            ] {
                assert!(v.get(k).is_some(), "{k}");
            }
            assert!((v["e_um"].as_f64().unwrap() - 7.5).abs() < 1e-5);
            assert_eq!(v["quality_ok"], serde_json::json!(true));
            assert_eq!(v["quality_reasons"], serde_json::json!([]));
        }
    }

    #[test]
    fn an_untrusted_turn_says_why() {
        // 200 frames taken, 120 valid, on a line 30 px off on every third of them: those 40 are
        // cut as outliers, 80 of the 200 used.
        let mut s = String::from("theta_deg,c_px\n");
        for i in 0..120 {
            let t = 3.0 * i as f64;
            let line = if i % 3 == 0 { 30.0 } else { 0.0 };
            s.push_str(&format!(
                "{t},{}\n",
                700.0 + 10.0 * (t - 40.0f64).to_radians().cos() + line
            ));
        }
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("s.csv");
        std::fs::write(&p, &s).unwrap();
        let o = d.path().join("o.json");
        run(Args {
            samples: p,
            method: Method::LeastSquares,
            um_per_px: None,
            frames_taken: Some(200),
            threshold_um: None,
            recipe: None,
            json: Some(o.clone()),
        })
        .unwrap();
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&o).unwrap()).unwrap();
        assert_eq!(v["quality_ok"], serde_json::json!(false));
        let reasons: Vec<String> = v["quality_reasons"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r.as_str().unwrap().to_string())
            .collect();
        assert!(
            reasons
                .iter()
                .any(|r| r.starts_with("frames_used 40.0 % < 75.0 %")),
            "{reasons:?}"
        );
        assert!(
            reasons
                .iter()
                .any(|r| r.starts_with("residual_rms ") || r.starts_with("outliers ")),
            "{reasons:?}"
        );
    }
}
