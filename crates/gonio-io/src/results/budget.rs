//! The result of evaluating a GUM budget file (`gonio budget --json`, `gonio.budget` in Python):
//! the reported budget's fields at the top level, every budget evaluated, and optionally the
//! JCGM 101 Monte Carlo run with its validation of the GUM result.
//!
//! Errors are `anyhow` errors naming the file (`NAME:LINE:COL: message` when they concern a place
//! in it).
//!
//! ```
//! use gonio_io::results::budget::{Request, evaluate};
//! let toml = b"[[budget]]\nname = \"y\"\n[[budget.contribution]]\nname = \"a\"\nu = 0.1\n";
//! let e = evaluate(toml, "b.toml", &Request::default(), |_| {}).unwrap();
//! assert_eq!(e.selected, "y");
//! assert!(gonio_io::json::to_bytes(&e.output()).is_ok());
//! ```

use anyhow::{Result, anyhow, bail};
use gonio_uncertainty::montecarlo::{McConfig, McResult, McTrials, Validation, validate};
use gonio_uncertainty::{BudgetFile, BudgetResult, UncertaintyError, short};
use serde::Serialize;

/// Default upper limit of the adaptive Monte Carlo procedure, in trials.
pub const ADAPTIVE_MAX_TRIALS: usize = 10_000_000;

/// The Monte Carlo run asked for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct McRequest {
    /// Seed (same seed, same result).
    pub seed: u64,
    /// Trials; `None`: adaptive (JCGM 101 §7.9), up to [`ADAPTIVE_MAX_TRIALS`].
    pub trials: Option<usize>,
    /// Significant digits of u regarded as meaningful (tolerance and validation).
    pub ndig: u32,
}

impl Default for McRequest {
    /// Seed 1, adaptive, 2 significant digits (the command's defaults).
    fn default() -> McRequest {
        McRequest {
            seed: 1,
            trials: None,
            ndig: 2,
        }
    }
}

/// What to evaluate.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Request {
    /// Coverage probability p, 0 < p < 1 (default: the file's `coverage`, else 0.95).
    pub coverage: Option<f64>,
    /// The budget to report (default: the last one in the file).
    pub name: Option<String>,
    /// Also propagate the distributions by Monte Carlo.
    pub monte_carlo: Option<McRequest>,
}

/// How a Monte Carlo run is going, for a progress bar.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Progress {
    /// The run starts: at most `total` trials (adaptive: stops earlier when stable) of a model
    /// with `inputs` inputs.
    Start {
        /// Upper limit of the trials.
        total: usize,
        /// Adaptive (`total` is a limit) or fixed.
        adaptive: bool,
        /// Inputs of the model.
        inputs: usize,
    },
    /// Trials done so far.
    Trials(usize),
    /// The run ended.
    Done,
}

/// The Monte Carlo part of the JSON output.
#[derive(Debug, Serialize)]
pub struct McJson {
    /// The run.
    #[serde(flatten)]
    pub result: McResult,
    /// The GUM result checked against it.
    pub validation: Validation,
    /// `GUM` when validated, else `Monte Carlo`.
    pub reported: &'static str,
}

/// The JSON output: the reported budget's fields at the top level, then every budget evaluated.
#[derive(Debug, Serialize)]
pub struct Output<'a> {
    /// The file's name as given.
    pub file: &'a str,
    /// The reported budget's name.
    pub budget: &'a str,
    /// The reported budget.
    #[serde(flatten)]
    pub result: &'a BudgetResult,
    /// Every budget of the file, evaluated.
    pub budgets: &'a [BudgetResult],
    /// The Monte Carlo run, when asked for.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub monte_carlo: Option<&'a McJson>,
}

/// A budget file evaluated.
#[derive(Debug)]
pub struct Evaluation {
    /// The file's name as given.
    pub file: String,
    /// The reported budget's name.
    pub selected: String,
    /// Every budget, evaluated, in the file's order.
    pub all: Vec<BudgetResult>,
    /// The budgets the reported one depends on (itself included): those a table shows.
    pub shown: Vec<String>,
    /// The Monte Carlo run.
    pub monte_carlo: Option<McJson>,
    /// The adaptive run's trial limit when the model's size lowered it below
    /// [`ADAPTIVE_MAX_TRIALS`].
    pub capped: Option<usize>,
}

impl Evaluation {
    /// The reported budget.
    pub fn result(&self) -> &BudgetResult {
        // `evaluate` checked that it is there.
        self.all
            .iter()
            .find(|r| r.name == self.selected)
            .unwrap_or(&self.all[0])
    }

    /// The JSON output.
    pub fn output(&self) -> Output<'_> {
        Output {
            file: &self.file,
            budget: &self.selected,
            result: self.result(),
            budgets: &self.all,
            monte_carlo: self.monte_carlo.as_ref(),
        }
    }
}

/// Checks a coverage probability asked for: 0 < p < 1.
///
/// # Errors
/// Outside (0, 1), or not a number.
pub fn check_coverage(coverage: Option<f64>) -> Result<()> {
    if let Some(p) = coverage
        && let Err(e) = gonio_uncertainty::COVERAGE.check(p)
    {
        bail!(
            "--coverage {}: a probability {e} (e.g. 0.95)",
            gonio_core::bound::Num(p)
        );
    }
    Ok(())
}

/// Checks a Monte Carlo request's digits and trials against their bounds
/// ([`gonio_uncertainty::montecarlo::NDIG`], [`gonio_uncertainty::montecarlo::TRIALS`]).
///
/// # Errors
/// The first one out of its bound, named as the command's flag.
pub fn check_monte_carlo(mc: &McRequest) -> Result<()> {
    use gonio_uncertainty::montecarlo::{NDIG, TRIALS};
    if let Err(e) = NDIG.check_int(mc.ndig) {
        bail!("--ndig {}: {e}", mc.ndig);
    }
    if let Some(n) = mc.trials
        && let Err(e) = TRIALS.check_int(n as u64)
    {
        bail!("--trials {n}: {e}");
    }
    Ok(())
}

/// Parses and evaluates a budget file (`bytes`, named `file` in errors).
///
/// # Errors
/// A coverage outside (0, 1), a file that does not parse, an unknown budget name, a budget that
/// cannot be evaluated, a Monte Carlo run that fails or overflows; located where they concern
/// the file.
pub fn evaluate(
    bytes: &[u8],
    file: &str,
    req: &Request,
    mut progress: impl FnMut(Progress),
) -> Result<Evaluation> {
    check_coverage(req.coverage)?;
    if let Some(mc) = &req.monte_carlo {
        check_monte_carlo(mc)?;
    }
    let parsed = BudgetFile::parse_bytes(bytes).map_err(|e| anyhow!("{file}:{e}"))?;
    // An error found after parsing, at its line and column when it concerns the file.
    let located = |e: UncertaintyError| match parsed.locate(&e) {
        Some((line, col)) => anyhow!("{file}:{line}:{col}: {e}"),
        None => anyhow!("{file}: {e}"),
    };
    let set = &parsed.set;
    let selected = set
        .select(req.name.as_deref())
        .map_err(|_| {
            const LISTED: usize = 10;
            let mut names: Vec<String> = set
                .budgets
                .iter()
                .take(LISTED)
                .map(|b| short(&b.name))
                .collect();
            if set.budgets.len() > LISTED {
                names.push(format!("… ({} budgets)", set.budgets.len()));
            }
            anyhow!(
                "--budget: no budget named '{}' in {file}; the file has: {}",
                short(req.name.as_deref().unwrap_or("")),
                names.join(", ")
            )
        })?
        .name
        .clone();
    let all = set.evaluate_all(req.coverage).map_err(located)?;
    let shown: Vec<String> = set
        .dependencies(Some(&selected))
        .map_err(located)?
        .into_iter()
        .map(str::to_string)
        .collect();
    let result = all
        .iter()
        .find(|r| r.name == selected)
        .ok_or_else(|| anyhow!("{file}: budget '{}' was not evaluated", short(&selected)))?;

    let (monte_carlo, capped) = match &req.monte_carlo {
        Some(mc) => {
            let model = set.linear_model(Some(&selected)).map_err(located)?;
            let limit = model.max_trials().map_err(located)?;
            let (trials, total) = match mc.trials {
                Some(n) => (McTrials::Fixed(n), n),
                None => {
                    let max = ADAPTIVE_MAX_TRIALS.min(limit);
                    (McTrials::Adaptive { max_trials: max }, max)
                }
            };
            let cfg = McConfig {
                coverage: result.coverage,
                seed: mc.seed,
                ndig: mc.ndig,
                trials,
            };
            progress(Progress::Start {
                total,
                adaptive: mc.trials.is_none(),
                inputs: model.inputs.len(),
            });
            let r = model
                .monte_carlo_with_progress(&cfg, |t| progress(Progress::Trials(t)))
                .map_err(located);
            progress(Progress::Done);
            let r = r?;
            let v = validate(result.value, result.u_c, result.expanded, &r, mc.ndig);
            if !(v.d_low.is_finite() && v.d_high.is_finite()) {
                bail!(
                    "{file}: the GUM–Monte Carlo comparison overflows (y ± U = {:e} ± {:e})",
                    result.value,
                    result.expanded
                );
            }
            (
                Some(McJson {
                    result: r,
                    validation: v,
                    reported: if v.passed { "GUM" } else { "Monte Carlo" },
                }),
                (mc.trials.is_none() && limit < ADAPTIVE_MAX_TRIALS).then_some(limit),
            )
        }
        None => (None, None),
    };
    Ok(Evaluation {
        file: file.to_string(),
        selected,
        all,
        shown,
        monte_carlo,
        capped,
    })
}
