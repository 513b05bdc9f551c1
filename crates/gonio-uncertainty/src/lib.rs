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
//! // Seed 000's self-calibration budget: repeatability 0.01″/√6 (ν = 5) and the encoder resolution
//! // row as printed (0.0101″, ν = 50).
//! let mut b = Budget::new("self-calibration");
//! b.push(Contribution::direct("repeatability", 0.01 / 6f64.sqrt()).with_dof(5.0));
//! b.push(Contribution::direct("encoder resolution", 0.0101).with_dof(50.0));
//! let r = b.evaluate(0.95).unwrap();
//! assert_eq!(r.nu_eff, 53.0);
//! assert!((r.k - 2.006).abs() < 5e-4 && (r.expanded - 0.022).abs() < 5e-4);
//! ```
#![deny(missing_docs)]

pub mod budget;
pub mod file;
pub mod instrument;
pub mod montecarlo;
pub mod student;

pub use budget::{
    Budget, BudgetResult, BudgetSet, Combined, Contribution, Correlation, LinearModel, Row, Source,
    Term, combine, en, gum_for_model,
};
pub use file::{BudgetFileError, parse_budget_file};
pub use instrument::{InstrumentFile, combine_with_instrument};
pub use montecarlo::{
    InputDistribution, Interval, McConfig, McResult, McTrials, Validation, monte_carlo, validate,
};

/// Errors of budget evaluation and Monte Carlo.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum UncertaintyError {
    /// A standard uncertainty (or a bound it was derived from) is negative or not finite.
    #[error("contribution '{name}': {what} must be a finite number ≥ 0, found {value}")]
    BadUncertainty {
        /// Contribution name.
        name: String,
        /// Which quantity (`u`, `half_width`, `step`, `expanded`…).
        what: String,
        /// The value found.
        value: f64,
    },
    /// Degrees of freedom ≤ 0 or NaN.
    #[error("contribution '{name}': degrees of freedom must be > 0 (or infinite), found {nu}")]
    BadDof {
        /// Contribution name.
        name: String,
        /// The value found.
        nu: f64,
    },
    /// A parameter other than u or ν is out of range (k ≤ 0, relative uncertainty ≤ 0, a
    /// non-finite sensitivity, fewer than 2 observations…).
    #[error("contribution '{name}': {what}")]
    BadParameter {
        /// Contribution name.
        name: String,
        /// What was expected and found.
        what: String,
    },
    /// Coverage probability outside (0, 1).
    #[error("coverage probability must be strictly between 0 and 1, found {coverage}")]
    BadCoverage {
        /// The value found.
        coverage: f64,
    },
    /// A nested budget refers to a budget that does not exist.
    #[error(
        "budget '{budget}': contribution '{contribution}' refers to missing budget '{missing}'"
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
        /// The cycle, `a -> b -> a`.
        cycle: String,
    },
    /// Two budgets, or two contributions of one budget, share a name.
    #[error("duplicate name '{name}' {place}")]
    DuplicateName {
        /// The repeated name.
        name: String,
        /// Where (`among budgets` or `in budget 'x'`).
        place: String,
    },
    /// No budget to evaluate.
    #[error("no budget named '{name}'")]
    NoSuchBudget {
        /// The name asked for (empty: the file has no budget at all).
        name: String,
    },
    /// A correlation names an unknown contribution, pairs one with itself, or has |r| > 1.
    #[error("budget '{budget}': correlation between '{a}' and '{b}': {what}")]
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
    /// A Monte Carlo set-up error (no inputs, bad trial count, correlation not representable…).
    #[error("Monte Carlo: {what}")]
    MonteCarlo {
        /// What is wrong.
        what: String,
    },
}

/// Checks a coverage probability: 0 < p < 1.
pub fn check_coverage(coverage: f64) -> Result<f64, UncertaintyError> {
    if coverage > 0.0 && coverage < 1.0 {
        Ok(coverage)
    } else {
        Err(UncertaintyError::BadCoverage { coverage })
    }
}
