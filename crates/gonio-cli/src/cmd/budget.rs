//! `gonio budget`: evaluate a GUM uncertainty budget file (TOML), optionally with Monte Carlo.

use anyhow::{Result, anyhow, bail};
use gonio_cli::flag;
use gonio_cli::output::Outputs;
use gonio_io::results::budget::{self, Progress};
use gonio_io::table::budget as table;
use gonio_uncertainty::limits::MAX_FILE_BYTES;
use gonio_uncertainty::montecarlo;
use gonio_uncertainty::short;
use std::collections::HashSet;
use std::io::IsTerminal;
use std::path::PathBuf;

/// Arguments of `gonio budget`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
The budget file format, with examples, is in docs/budget-format.md.

Examples:
  gonio budget examples/budgets/hsieh2022-shift-angle.toml
  gonio budget examples/budgets/jcgm100-h1.toml --coverage 0.99 --json h1.json
  gonio budget examples/budgets/hsieh2022-shift-angle.toml --monte-carlo --seed 7
  gonio budget examples/budgets/hsieh2022-shift-angle.toml --budget 'measured value' --format markdown")]
pub struct Args {
    /// Budget file (TOML; `-` for standard input).
    pub budget: PathBuf,
    /// Coverage probability p, 0 < p < 1 (default: the file's `coverage`, else 0.95).
    #[arg(long, value_parser = flag::real(gonio_uncertainty::COVERAGE))]
    pub coverage: Option<f64>,
    /// Budget to report (default: the last one in the file).
    #[arg(long = "budget", value_name = "NAME")]
    pub name: Option<String>,
    /// Also propagate the distributions by Monte Carlo (JCGM 101) and validate the GUM result.
    #[arg(long)]
    pub monte_carlo: bool,
    /// Monte Carlo seed (same seed, same result).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Monte Carlo trials (default: adaptive, JCGM 101 §7.9, up to 10⁷; at most 10⁸).
    #[arg(long, value_parser = flag::whole::<usize>(montecarlo::TRIALS))]
    pub trials: Option<usize>,
    /// Significant digits of u regarded as meaningful (Monte Carlo tolerance and validation),
    /// 1 to 6.
    #[arg(long, default_value_t = 2, value_parser = flag::whole::<u32>(montecarlo::NDIG))]
    pub ndig: u32,
    /// Table format on standard output: text, markdown or csv.
    #[arg(long, default_value = "text")]
    pub format: String,
    /// Write the result as JSON.
    #[arg(long, value_name = "OUT.json")]
    pub json: Option<PathBuf>,
}

/// Runs `gonio budget`.
pub fn run(args: Args) -> Result<()> {
    let file = args.budget.display().to_string();
    let format = args.format.to_ascii_lowercase();
    if !matches!(format.as_str(), "text" | "markdown" | "md" | "csv") {
        bail!(
            "--format: expected text, markdown or csv, found '{}'",
            short(&args.format)
        );
    }
    budget::check_coverage(args.coverage)?;
    let mut outputs = Outputs::new();
    let json = outputs.optional("--json", args.json.as_deref())?;
    let bytes = outputs.inputs().read_bytes(&args.budget, MAX_FILE_BYTES)?;
    let req = budget::Request {
        coverage: args.coverage,
        name: args.name.clone(),
        monte_carlo: args.monte_carlo.then_some(budget::McRequest {
            seed: args.seed,
            trials: args.trials,
            ndig: args.ndig,
        }),
    };
    let mut bar = None;
    let e = budget::evaluate(&bytes, &file, &req, |p| match p {
        Progress::Start {
            total,
            adaptive,
            inputs,
        } => bar = Some(progress_bar(total, adaptive, inputs)),
        Progress::Trials(t) => {
            if let Some(b) = &bar {
                b.set_position(t as u64);
            }
        }
        Progress::Done => {
            if let Some(b) = bar.take() {
                b.finish_and_clear();
            }
        }
    })?;
    drop(bytes);
    let result = e.result();
    let shown: HashSet<&str> = e.shown.iter().map(String::as_str).collect();

    let mut out = String::new();
    for r in e.all.iter().filter(|r| shown.contains(r.name.as_str())) {
        match format.as_str() {
            "csv" => table::csv(&mut out, r),
            "markdown" | "md" => table::markdown(&mut out, r),
            _ => table::text(&mut out, r),
        }
    }
    if let Some(m) = &e.monte_carlo {
        table::monte_carlo(&mut out, m, e.capped, result, format == "csv");
    }

    // Checked before anything is printed: a result that is not finite is an error, not a null.
    let bytes = gonio_io::json::to_bytes(&e.output())
        .map_err(|err| anyhow!("{file}: nothing was written: {err}"))?;
    gonio_cli::term::out(&out)?;
    if let Some(j) = json {
        outputs.write(j, &bytes)?;
    }
    outputs.commit()
}

/// A progress bar on standard error for a Monte Carlo run of `total` trials (the upper limit of
/// an adaptive run), drawn only when standard error is a terminal.
fn progress_bar(total: usize, adaptive: bool, inputs: usize) -> indicatif::ProgressBar {
    if !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(total as u64);
    let what = if adaptive {
        "trials (adaptive: stops when stable, at most {len})"
    } else {
        "/{len} trials"
    };
    bar.set_style(
        indicatif::ProgressStyle::with_template(&format!(
            "Monte Carlo, {inputs} inputs: {{bar:30}} {{pos}} {what} {{elapsed}}"
        ))
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    bar
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn example(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../examples/budgets")
            .join(name)
    }

    fn args(budget: PathBuf, json: Option<PathBuf>) -> Args {
        Args {
            budget,
            coverage: None,
            name: None,
            monte_carlo: false,
            seed: 1,
            trials: None,
            ndig: 2,
            format: "text".into(),
            json,
        }
    }

    #[test]
    fn hsieh2022_table3_json_has_the_contract_fields() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("t3.json");
        run(args(
            example("hsieh2022-shift-angle.toml"),
            Some(out.clone()),
        ))
        .unwrap();
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
        // Seed Table 3: u_c 0.069″, ν_eff 13, k 2.16, U 0.15″.
        assert!((v["u_c"].as_f64().unwrap() - 0.069).abs() < 5e-4);
        assert_eq!(v["nu_eff"], 13);
        assert!((v["nu_eff_raw"].as_f64().unwrap() - 13.13).abs() < 5e-3);
        assert_eq!(v["coverage"], 0.95);
        assert!((v["k"].as_f64().unwrap() - 2.160).abs() < 5e-4);
        assert!((v["U"].as_f64().unwrap() - 0.15).abs() < 5e-3);
        let rows = v["contributions"].as_array().unwrap();
        assert_eq!(rows.len(), 3);
        for key in ["name", "u", "c", "cu", "nu", "share"] {
            assert!(rows[0].get(key).is_some(), "missing {key}");
        }
        assert_eq!(rows[0]["nu"], 12);
    }

    #[test]
    fn monte_carlo_json_and_infinite_dof() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("h1.json");
        let mut a = args(example("jcgm100-h1.toml"), Some(out.clone()));
        a.monte_carlo = true;
        a.name = Some("theta".into());
        run(a).unwrap();
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
        assert_eq!(v["nu_eff"], "inf");
        assert_eq!(v["nu_eff_raw"], "inf");
        let mc = &v["monte_carlo"];
        assert!(mc["trials"].as_u64().unwrap() >= 20_000);
        assert!(mc["validation"]["passed"].is_boolean());
    }

    #[test]
    fn bad_files_name_file_and_line() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("bad.toml");
        std::fs::write(
            &p,
            "[[budget]]\nname = \"b\"\n[[budget.contribution]]\nname = \"r\"\nu = 1\ndof = -2\n",
        )
        .unwrap();
        let e = gonio_io::input::one_line(&run(args(p.clone(), None)).unwrap_err());
        assert_eq!(
            e,
            format!(
                "{}:6:7: contribution 'r': degrees of freedom must be > 0 (or \"inf\"), found -2",
                p.display()
            )
        );
        let mut a = args(example("hsieh2022-selfcal.toml"), None);
        a.coverage = Some(0.0);
        assert!(run(a).unwrap_err().to_string().starts_with("--coverage"));
    }
}
