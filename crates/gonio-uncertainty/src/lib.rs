//! GUM uncertainty budgets (JCGM 100:2008) and Monte Carlo propagation (JCGM 101:2008) for gonio.
//!
//! - [`budget`]: contributions (Type A from observations; Type B from rectangular, resolution,
//!   triangular, arcsine and normal-with-k bounds; given directly; nested budgets), sensitivity
//!   coefficients, correlations, combined standard uncertainty, Welch–Satterthwaite ν_eff (raw and
//!   truncated), coverage factor, expanded uncertainty, shares, and the normalised error [`en`].
//! - [`mod@file`]: the TOML budget-file format, with errors that name the line.
//! - [`student`]: the Student-t distribution and the coverage factor k_p(ν).
//! - [`montecarlo`]: adaptive, seeded Monte Carlo for any measurement function, coverage intervals
//!   (probabilistically symmetric and shortest), and the GUM-vs-Monte-Carlo validation.
//! - [`instrument`]: instrument terms (autocollimator, encoder, setup, heads) combined with the
//!   random part of a calibration result into an expanded uncertainty per angle.
//!
//! ```
//! use gonio_uncertainty::{Budget, Contribution};
//! // Hsieh et al. (2022)'s self-calibration budget: repeatability 0.01″/√6 (ν = 5) and the encoder
//! // resolution row as printed (0.0101″, ν = 50).
//! let mut b = Budget::new("self-calibration");
//! b.push(Contribution::direct("repeatability", 0.01 / 6f64.sqrt()).with_dof(5.0));
//! b.push(Contribution::direct("encoder resolution", 0.0101).with_dof(50.0));
//! let r = b.evaluate(0.95).unwrap();
//! assert_eq!(r.nu_eff, 53.0);
//! assert!((r.k - 2.006).abs() < 5e-4 && (r.expanded - 0.022).abs() < 5e-4);
//! ```
#![deny(missing_docs)]

pub mod budget;
mod envelope;
pub mod file;
pub mod instrument;
pub mod limits;
pub mod montecarlo;
pub mod student;

pub use budget::{
    Budget, BudgetResult, BudgetSet, Combined, Contribution, Correlation, LinearModel, Row, Source,
    Term, combine, en, gum_for_model,
};
pub use file::{BudgetFile, BudgetFileError, decode_text, parse_budget_bytes, parse_budget_file};
use gonio_core::bound::Num;
pub use instrument::{InstrumentFile, combine_with_instrument};
pub use montecarlo::{
    InputDistribution, Interval, McConfig, McResult, McTrials, Validation, monte_carlo,
    monte_carlo_with_progress, validate,
};

/// Errors of budget evaluation and Monte Carlo.
///
/// Names and other echoed input are shortened in the messages (see [`short`]), so that an error
/// stays one short line whatever the input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum UncertaintyError {
    /// A standard uncertainty (or a bound it was derived from) is negative or not finite.
    #[error(
        "contribution '{}': {what} must be a finite number ≥ 0, found {}",
        short(.name),
        Num(*.value)
    )]
    BadUncertainty {
        /// Contribution name.
        name: String,
        /// Which quantity (`u`, `half_width`, `step`, `expanded`…).
        what: String,
        /// The value found.
        value: f64,
    },
    /// Degrees of freedom ≤ 0 or NaN.
    #[error(
        "contribution '{}': degrees of freedom must be > 0 (or infinite), found {}",
        short(.name),
        Num(*.nu)
    )]
    BadDof {
        /// Contribution name.
        name: String,
        /// The value found.
        nu: f64,
    },
    /// A parameter other than u or ν is out of range (k ≤ 0, relative uncertainty ≤ 0, a
    /// non-finite sensitivity, fewer than 2 observations…).
    #[error("contribution '{}': {what}", short(.name))]
    BadParameter {
        /// Contribution name.
        name: String,
        /// What was expected and found.
        what: String,
    },
    /// Coverage probability outside (0, 1).
    #[error(
        "coverage probability must be strictly between 0 and 1, found {}",
        Num(*.coverage)
    )]
    BadCoverage {
        /// The value found.
        coverage: f64,
    },
    /// A nested budget refers to a budget that does not exist.
    #[error(
        "budget '{}': contribution '{}' refers to missing budget '{}'",
        short(.budget),
        short(.contribution),
        short(.missing)
    )]
    MissingBudget {
        /// The budget holding the reference.
        budget: String,
        /// The contribution holding the reference.
        contribution: String,
        /// The name that was not found.
        missing: String,
    },
    /// Nested budgets refer to each other in a cycle.
    #[error("budgets refer to themselves in a cycle: {cycle}")]
    CyclicBudget {
        /// The cycle for display, `a -> b -> a` (names shortened, at most a few shown).
        cycle: String,
        /// The budgets of the cycle in order, full names, the first repeated at the end.
        budgets: Vec<String>,
    },
    /// Two budgets, or two contributions of one budget, share a name.
    #[error("duplicate name '{}' {place}", short(.name))]
    DuplicateName {
        /// The repeated name.
        name: String,
        /// Where (`among budgets` or `in budget 'x'`).
        place: String,
    },
    /// No budget to evaluate.
    #[error("no budget named '{}'", short(.name))]
    NoSuchBudget {
        /// The name asked for (empty: the file has no budget at all).
        name: String,
    },
    /// A correlation names an unknown contribution, pairs one with itself, or has |r| > 1.
    #[error(
        "budget '{}': correlation between '{}' and '{}': {what}",
        short(.budget),
        short(.a),
        short(.b)
    )]
    BadCorrelation {
        /// Budget name.
        budget: String,
        /// First contribution.
        a: String,
        /// Second contribution.
        b: String,
        /// What is wrong.
        what: String,
    },
    /// The correlation coefficients do not form a valid (positive semi-definite) matrix.
    #[error(
        "{context}: the correlation coefficients are not a valid correlation matrix (not positive semi-definite)"
    )]
    NotPositiveDefinite {
        /// Budget or model name.
        context: String,
    },
    /// Monte Carlo draws the inputs of a nested budget, so a correlation with the nested budget's
    /// row itself cannot be represented.
    #[error(
        "budget '{}': the correlation between '{}' and '{}' involves a nested budget; Monte Carlo draws its inputs, so correlate those instead",
        short(.budget),
        short(.a),
        short(.b)
    )]
    CorrelatedNestedBudget {
        /// Budget name.
        budget: String,
        /// First contribution.
        a: String,
        /// Second contribution.
        b: String,
    },
    /// A result or an intermediate quantity is not finite: the numbers overflow the range of
    /// floating point (about ±1.8e308), e.g. U = k·u_c with u_c = 1.4e308.
    #[error(
        "{}{quantity} is not finite: the numbers overflow the floating-point range (about 1.8e308)",
        place(.budget, .contribution)
    )]
    NonFinite {
        /// The budget (empty when not known, e.g. a bare [`budget::combine`]).
        budget: String,
        /// The contribution, when one row is the cause.
        contribution: Option<String>,
        /// What overflowed, with its operands, e.g. `U = k·u_c = 1.96 × 1.41e308`.
        quantity: String,
    },
    /// A size that comes from the input is above its stated limit (see [`limits`]).
    #[error("{what}: {found} is more than the limit of {limit}{hint}")]
    TooLarge {
        /// The budget concerned, if one (to locate the error in its file).
        budget: Option<String>,
        /// What was counted, e.g. `budget 'x': rows`.
        what: String,
        /// The size found.
        found: u64,
        /// The limit.
        limit: u64,
        /// What to do instead (starts with `; ` when not empty).
        hint: String,
    },
    /// A Monte Carlo set-up error (no inputs, bad trial count, correlation not representable…).
    #[error("Monte Carlo: {what}")]
    MonteCarlo {
        /// What is wrong.
        what: String,
    },
}

pub use gonio_core::text::{MAX_QUOTED_CHARS, short};

fn place(budget: &str, contribution: &Option<String>) -> String {
    match (budget.is_empty(), contribution) {
        (true, None) => String::new(),
        (true, Some(c)) => format!("contribution '{}': ", short(c)),
        (false, None) => format!("budget '{}': ", short(budget)),
        (false, Some(c)) => format!("budget '{}', contribution '{}': ", short(budget), short(c)),
    }
}

/// A coverage probability p: 0 < p < 1 (the flags' and files' bound).
pub const COVERAGE: gonio_core::bound::Bound = gonio_core::bound::Bound::new(0.0, 1.0, "")
    .lo_excluded()
    .hi_excluded();

/// Checks a coverage probability: 0 < p < 1 ([`COVERAGE`]).
pub fn check_coverage(coverage: f64) -> Result<f64, UncertaintyError> {
    if COVERAGE.contains(coverage) {
        Ok(coverage)
    } else {
        Err(UncertaintyError::BadCoverage { coverage })
    }
}
