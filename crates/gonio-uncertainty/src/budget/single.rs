//! One budget: a named list of contributions (rows) and the correlation coefficients between
//! them, checked to form a valid correlation matrix ([`crate::limits`] bound their number and
//! envelope). Evaluated through [`BudgetSet`](super::BudgetSet) ([`Budget::evaluate`]).

use super::Contribution;
use crate::envelope::Envelope;
use crate::limits::{MAX_CORRELATION_ENVELOPE, MAX_CORRELATIONS};
use crate::{UncertaintyError, short};
use std::collections::{HashMap, HashSet};

/// A correlation coefficient r between two contributions of the same budget, by name.
#[derive(Debug, Clone, PartialEq)]
pub struct Correlation {
    /// First contribution's name.
    pub a: String,
    /// Second contribution's name.
    pub b: String,
    /// Correlation coefficient, −1 ≤ r ≤ 1.
    pub r: f64,
}

/// A named list of contributions and their correlations.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Budget {
    /// Name (used by nested references and `--budget`).
    pub name: String,
    /// Unit of the result, e.g. `arcsec` or `nm` (free text; shown in tables and JSON).
    pub unit: Option<String>,
    /// The rows.
    pub contributions: Vec<Contribution>,
    /// Correlations between rows (by name).
    pub correlations: Vec<Correlation>,
}

impl Budget {
    /// An empty budget.
    pub fn new(name: &str) -> Budget {
        Budget {
            name: name.to_string(),
            ..Budget::default()
        }
    }

    /// Adds a row.
    pub fn push(&mut self, c: Contribution) -> &mut Budget {
        self.contributions.push(c);
        self
    }

    /// Adds a correlation coefficient between two rows (by name).
    pub fn correlate(&mut self, a: &str, b: &str, r: f64) -> &mut Budget {
        self.correlations.push(Correlation {
            a: a.to_string(),
            b: b.to_string(),
            r,
        });
        self
    }

    /// Indices of the correlations `(i, j, r)`, validated: both names exist, i ≠ j, |r| ≤ 1, no
    /// pair twice, and together they form a valid (positive semi-definite) correlation matrix.
    pub(crate) fn correlation_indices(&self) -> Result<Vec<(usize, usize, f64)>, UncertaintyError> {
        self.resolve_correlations().map_err(|(_, e)| e)
    }

    /// As [`correlation_indices`](Self::correlation_indices), with the position in
    /// `correlations` of the one that is wrong (`None`: the matrix as a whole, or their number).
    pub(crate) fn resolve_correlations(
        &self,
    ) -> Result<Vec<(usize, usize, f64)>, LocatedCorrelationError> {
        if self.correlations.is_empty() {
            return Ok(Vec::new());
        }
        if self.correlations.len() > MAX_CORRELATIONS {
            return Err((
                None,
                UncertaintyError::TooLarge {
                    budget: Some(self.name.clone()),
                    what: format!("budget '{}': correlations", short(&self.name)),
                    found: self.correlations.len() as u64,
                    limit: MAX_CORRELATIONS as u64,
                    hint: String::new(),
                },
            ));
        }
        let mut index: HashMap<&str, usize> = HashMap::with_capacity(self.contributions.len());
        for (i, c) in self.contributions.iter().enumerate() {
            index.entry(c.name.as_str()).or_insert(i);
        }
        let mut seen = HashSet::with_capacity(self.correlations.len());
        let mut out = Vec::with_capacity(self.correlations.len());
        for (k, cor) in self.correlations.iter().enumerate() {
            let bad = |what: String| {
                (
                    Some(k),
                    UncertaintyError::BadCorrelation {
                        budget: self.name.clone(),
                        a: cor.a.clone(),
                        b: cor.b.clone(),
                        what,
                    },
                )
            };
            let i = *index
                .get(cor.a.as_str())
                .ok_or_else(|| bad(format!("no contribution '{}'", short(&cor.a))))?;
            let j = *index
                .get(cor.b.as_str())
                .ok_or_else(|| bad(format!("no contribution '{}'", short(&cor.b))))?;
            if i == j {
                return Err(bad("a contribution cannot be correlated with itself".into()));
            }
            if cor.r.is_nan() || cor.r.abs() > 1.0 {
                return Err(bad(format!("r must be within [-1, 1], found {}", cor.r)));
            }
            if !seen.insert((i.min(j), i.max(j))) {
                return Err(bad("given twice".into()));
            }
            out.push((i, j, cor.r));
        }
        let mut m = Envelope::correlation(self.contributions.len(), &out, MAX_CORRELATION_ENVELOPE)
            .map_err(|entries| {
                (
                    None,
                    UncertaintyError::TooLarge {
                        budget: Some(self.name.clone()),
                        what: format!(
                            "budget '{}': the correlation matrix's envelope (for each correlated row, the entries from its first correlated row to itself)",
                            short(&self.name)
                        ),
                        found: entries as u64,
                        limit: MAX_CORRELATION_ENVELOPE as u64,
                        hint: "; list correlated rows next to each other".into(),
                    },
                )
            })?;
        if m.cholesky().is_none() {
            return Err((
                None,
                UncertaintyError::NotPositiveDefinite {
                    context: format!("budget '{}'", short(&self.name)),
                },
            ));
        }
        Ok(out)
    }
}

/// A correlation error with the position of the wrong correlation (`None`: all of them).
pub(crate) type LocatedCorrelationError = (Option<usize>, UncertaintyError);
