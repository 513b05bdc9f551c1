//! `gonio budget`: evaluate a GUM uncertainty budget file (TOML), optionally with Monte Carlo.

use crate::table::{display_name, dof_text, sig, summary_line, text_table, unit};
use anyhow::{Result, anyhow, bail};
use gonio_cli::flag;
use gonio_cli::output::Outputs;
use gonio_io::results::budget::{self, McJson, Progress};
use gonio_uncertainty::limits::MAX_FILE_BYTES;
use gonio_uncertainty::montecarlo;
use gonio_uncertainty::{BudgetResult, short};
use std::collections::HashSet;
use std::fmt::Write as _;
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
            "csv" => csv_table(&mut out, r),
            "markdown" | "md" => markdown_table(&mut out, r),
            _ => text_table(&mut out, r),
        }
    }
    if let Some(m) = &e.monte_carlo {
        mc_summary(&mut out, m, e.capped, result, format.as_str());
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

fn markdown_table(out: &mut String, r: &BudgetResult) {
    let _ = writeln!(
        out,
        "### {}{}\n",
        display_name(&r.name),
        unit(r).replace(' ', " in ")
    );
    let _ = writeln!(out, "| contribution | u | c | \\|c·u\\| | ν | share |");
    let _ = writeln!(out, "|---|---:|---:|---:|---:|---:|");
    for c in &r.contributions {
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {:.1} % |",
            display_name(&c.name).replace('|', "\\|"),
            sig(c.u, 4),
            sig(c.c, 4),
            sig(c.cu, 4),
            dof_text(c.nu),
            c.share * 100.0
        );
    }
    let _ = writeln!(out, "\n{}\n", summary_line(r));
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn csv_table(out: &mut String, r: &BudgetResult) {
    if out.is_empty() {
        out.push_str("budget,name,u,c,cu,nu,share\n");
    }
    for c in &r.contributions {
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{}",
            csv_field(&r.name),
            csv_field(&c.name),
            c.u,
            c.c,
            c.cu,
            dof_text(c.nu),
            c.share
        );
    }
    let _ = writeln!(
        out,
        "# {}: u_c={} nu_eff={} nu_eff_raw={} coverage={} k={} U={}",
        r.name,
        r.u_c,
        dof_text(r.nu_eff),
        r.nu_eff_raw,
        r.coverage,
        r.k,
        r.expanded
    );
}

/// The Monte Carlo summary; `capped`: the adaptive run's trial limit when the model's size lowered
/// it below the default 10⁷.
fn mc_summary(
    out: &mut String,
    m: &McJson,
    capped: Option<usize>,
    gum: &BudgetResult,
    format: &str,
) {
    let r = &m.result;
    let v = &m.validation;
    let p = if format == "csv" { "# " } else { "" };
    let u = unit(gum);
    let _ = writeln!(
        out,
        "{p}Monte Carlo (JCGM 101): {} trials in {} batches ({}), seed {}, tolerance δ = {}{u}",
        r.trials,
        r.batches,
        if r.batches > 1 || r.converged {
            if r.converged {
                "adaptive, converged".to_string()
            } else {
                match capped {
                    Some(limit) => format!(
                        "adaptive, NOT converged at the trial limit of {limit} (for this many inputs)"
                    ),
                    None => "adaptive, NOT converged at the trial limit".to_string(),
                }
            }
        } else {
            "fixed".to_string()
        },
        r.seed,
        sig(r.tolerance, 1),
    );
    let _ = writeln!(
        out,
        "{p}  y = {}{u}   u(y) = {}{u}   {} % interval: symmetric [{}, {}]   shortest [{}, {}]",
        sig(r.estimate, 4),
        sig(r.std_uncertainty, 4),
        r.coverage * 100.0,
        sig(r.symmetric.low, 4),
        sig(r.symmetric.high, 4),
        sig(r.shortest.low, 4),
        sig(r.shortest.high, 4),
    );
    let _ = writeln!(
        out,
        "{p}  GUM [{}, {}]: d_low = {}, d_high = {} {} δ = {} → {}; reported: {}",
        sig(v.gum.low, 4),
        sig(v.gum.high, 4),
        sig(v.d_low, 2),
        sig(v.d_high, 2),
        if v.passed { "≤" } else { "vs" },
        sig(v.tolerance, 1),
        if v.passed {
            "GUM validated"
        } else {
            "GUM not validated"
        },
        m.reported
    );
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
