//! Expanded uncertainty of calibration results: the estimator's random part combined with an
//! instrument file's terms (`--instrument`), shared by `shift-angle` and `selfcal`.

use anyhow::{Result, anyhow};
use gonio_uncertainty::budget::{Combined, serialize_dof};
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
            random_dof,
            instrument_terms: self
                .file
                .contributions
                .iter()
                .map(|c| TermJson {
                    name: c.name.clone(),
                    u: c.u,
                    c: c.sensitivity,
                    nu: c.nu,
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

/// Serialises an optional ν like [`serialize_dof`] (null when absent).
pub fn serialize_opt_dof<S: serde::Serializer>(nu: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
    match nu {
        Some(v) => serialize_dof(v, s),
        None => s.serialize_none(),
    }
}

/// ν for a table: a whole number, two decimals, or `inf`.
pub fn dof_text(nu: f64) -> String {
    if nu.is_infinite() {
        "inf".into()
    } else if nu.fract() == 0.0 {
        format!("{nu:.0}")
    } else {
        format!("{nu:.2}")
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
    /// Degrees of freedom (a number, or "inf").
    #[serde(serialize_with = "serialize_dof")]
    pub nu: f64,
}

/// How the expanded uncertainties of a result were formed.
#[derive(Debug, Clone, Serialize)]
pub struct UncertaintySummary {
    /// Coverage probability p.
    pub coverage: f64,
    /// The `--instrument` file, if any.
    pub instrument_file: Option<String>,
    /// Degrees of freedom of the random part ("inf" with a stated σ).
    #[serde(serialize_with = "serialize_dof")]
    pub random_dof: f64,
    /// Instrument terms combined with the random part.
    pub instrument_terms: Vec<TermJson>,
}
