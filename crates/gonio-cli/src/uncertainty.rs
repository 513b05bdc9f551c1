//! Expanded uncertainty of calibration results: the estimator's random part combined with an
//! instrument file's terms (`--instrument`), shared by `shift-angle` and `selfcal`.

use anyhow::{Result, anyhow};
use gonio_uncertainty::budget::Combined;
use gonio_uncertainty::instrument::InstrumentFile;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// The instrument terms in force (an empty set when no file was given).
#[derive(Debug, Clone)]
pub struct Instrument {
    /// The file, when one was given.
    pub path: Option<PathBuf>,
    /// Its terms and coverage.
    pub file: InstrumentFile,
}

impl Instrument {
    /// Loads `--instrument` (or none), with `--coverage` overriding the file's.
    pub fn load(path: Option<&Path>, coverage: Option<f64>) -> Result<Instrument> {
        let mut file = match path {
            Some(p) => {
                let text = crate::io::read_text(p)?;
                InstrumentFile::parse(&text).map_err(|e| anyhow!("{}:{e}", p.display()))?
            }
            None => InstrumentFile::default(),
        };
        if let Some(c) = coverage {
            if !(c > 0.0 && c < 1.0) {
                return Err(anyhow!(
                    "--coverage {c}: expected a probability in (0, 1), e.g. 0.95"
                ));
            }
            file.coverage = c;
        }
        Ok(Instrument {
            path: path.map(Path::to_path_buf),
            file,
        })
    }

    /// Combines a random part u (ν degrees of freedom, ∞ allowed) with the instrument terms;
    /// `None` when u is unknown (NaN: no residual degrees of freedom and no stated σ).
    pub fn combine(&self, u_random: f64, nu_random: f64) -> Result<Option<Combined>> {
        if !u_random.is_finite() || nu_random.is_nan() || nu_random <= 0.0 {
            return Ok(None);
        }
        Ok(Some(self.file.combine(u_random, nu_random)?))
    }

    /// A summary of the terms for the JSON result.
    pub fn summary(&self, random_dof: f64) -> UncertaintySummary {
        UncertaintySummary {
            coverage: self.file.coverage,
            instrument_file: self.path.as_ref().map(|p| p.display().to_string()),
            random_dof: dof_value(random_dof),
            instrument_terms: self
                .file
                .contributions
                .iter()
                .map(|c| TermJson {
                    name: c.name.clone(),
                    u: c.u,
                    c: c.sensitivity,
                    nu: dof_value(c.nu),
                })
                .collect(),
        }
    }

    /// Prints the budget of one result (random part first) as a table.
    pub fn print_budget(&self, title: &str, u_random: f64, nu_random: f64, combined: &Combined) {
        let unit = &self.file.unit;
        println!("  uncertainty budget, {title}");
        println!(
            "    {:<30} {:>10} {:>8} {:>10} {:>8} {:>7}",
            "contribution",
            format!("u/{unit}"),
            "c",
            "|c·u|",
            "ν",
            "share"
        );
        let total = combined.u_c * combined.u_c;
        let row = |name: &str, u: f64, c: f64, nu: f64| {
            let cu = (c * u).abs();
            println!(
                "    {:<30} {:>10.5} {:>8.3} {:>10.5} {:>8} {:>6.1}%",
                name,
                u,
                c,
                cu,
                dof_text(nu),
                100.0 * cu * cu / total
            );
        };
        row("random part (estimator)", u_random, 1.0, nu_random);
        for c in &self.file.contributions {
            row(&c.name, c.u, c.sensitivity, c.nu);
        }
        println!(
            "    u_c = {:.5} {unit}, ν_eff = {} (raw {:.2}), p = {}, k = {:.3}, U = {:.4} {unit}",
            combined.u_c,
            dof_text(combined.nu_eff),
            combined.nu_eff_raw,
            combined.coverage,
            combined.k,
            combined.expanded
        );
    }
}

/// Degrees of freedom for JSON: a number, or the string "inf".
#[derive(Debug, Clone, Serialize)]
#[serde(untagged)]
pub enum DofJson {
    /// A whole number.
    Whole(i64),
    /// Finite, fractional.
    Finite(f64),
    /// Infinite.
    Text(String),
}

/// ν as JSON.
pub fn dof_value(nu: f64) -> DofJson {
    if nu.is_infinite() {
        DofJson::Text("inf".into())
    } else if nu.fract() == 0.0 && nu.abs() < 9.0e15 {
        DofJson::Whole(nu as i64)
    } else {
        DofJson::Finite(nu)
    }
}

fn dof_text(nu: f64) -> String {
    if nu.is_infinite() {
        "∞".into()
    } else if nu.fract() == 0.0 {
        format!("{nu:.0}")
    } else {
        format!("{nu:.1}")
    }
}

/// One instrument term in the JSON result.
#[derive(Debug, Clone, Serialize)]
pub struct TermJson {
    /// Name.
    pub name: String,
    /// Standard uncertainty.
    pub u: f64,
    /// Sensitivity coefficient.
    pub c: f64,
    /// Degrees of freedom.
    pub nu: DofJson,
}

/// How the expanded uncertainties of a result were formed.
#[derive(Debug, Clone, Serialize)]
pub struct UncertaintySummary {
    /// Coverage probability p.
    pub coverage: f64,
    /// The `--instrument` file, if any.
    pub instrument_file: Option<String>,
    /// Degrees of freedom of the random part ("inf" with a stated σ).
    pub random_dof: DofJson,
    /// Instrument terms combined with the random part.
    pub instrument_terms: Vec<TermJson>,
}
