//! Budgets and sets of budgets that refer to each other by name: evaluation of every budget,
//! nested references resolved first.

use super::{Contribution, Source, Term, combine, deserialize_dof, serialize_dof};
use crate::{UncertaintyError, check_coverage};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

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

/// One evaluated row of a budget table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Row {
    /// Contribution name.
    pub name: String,
    /// How u was obtained (e.g. `rectangular a=0.05`).
    pub source: String,
    /// Input estimate x_i.
    pub value: f64,
    /// Standard uncertainty u(x_i).
    pub u: f64,
    /// Sensitivity coefficient c_i.
    pub c: f64,
    /// |c_i|·u(x_i), the contribution to u_c in the result's unit.
    pub cu: f64,
    /// Degrees of freedom ν_i (integer, number or `"inf"` in JSON).
    #[serde(serialize_with = "serialize_dof", deserialize_with = "deserialize_dof")]
    pub nu: f64,
    /// Share of u_c²: (c_i u_i)² / u_c² (0…1).
    pub share: f64,
}

/// An evaluated budget: the rows and the combination.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BudgetResult {
    /// Budget name.
    pub name: String,
    /// Unit of u_c and U, if the budget states one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unit: Option<String>,
    /// Estimate y = Σ c_i x_i.
    pub value: f64,
    /// Combined standard uncertainty u_c.
    pub u_c: f64,
    /// ν_eff truncated (integer, or `"inf"`).
    #[serde(serialize_with = "serialize_dof", deserialize_with = "deserialize_dof")]
    pub nu_eff: f64,
    /// ν_eff before truncation.
    #[serde(serialize_with = "serialize_dof", deserialize_with = "deserialize_dof")]
    pub nu_eff_raw: f64,
    /// Coverage probability p.
    pub coverage: f64,
    /// Coverage factor k.
    pub k: f64,
    /// Expanded uncertainty U = k·u_c.
    #[serde(rename = "U")]
    pub expanded: f64,
    /// The evaluated rows, in input order.
    pub contributions: Vec<Row>,
    /// Correlations used, as (a, b, r).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub correlations: Vec<(String, String, f64)>,
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

    /// Evaluates a budget without nested references at coverage p.
    ///
    /// # Errors
    /// Any invalid row or correlation, p outside (0, 1), or a nested reference
    /// ([`UncertaintyError::MissingBudget`]; use [`BudgetSet`] for nested budgets).
    pub fn evaluate(&self, coverage: f64) -> Result<BudgetResult, UncertaintyError> {
        BudgetSet {
            coverage,
            budgets: vec![self.clone()],
        }
        .evaluate(Some(&self.name), None)
    }

    /// Indices of the correlations `(i, j, r)`, validated.
    pub(crate) fn correlation_indices(&self) -> Result<Vec<(usize, usize, f64)>, UncertaintyError> {
        let index = |n: &str| self.contributions.iter().position(|c| c.name == n);
        let mut out = Vec::with_capacity(self.correlations.len());
        for cor in &self.correlations {
            let bad = |what: String| UncertaintyError::BadCorrelation {
                budget: self.name.clone(),
                a: cor.a.clone(),
                b: cor.b.clone(),
                what,
            };
            let i = index(&cor.a).ok_or_else(|| bad(format!("no contribution '{}'", cor.a)))?;
            let j = index(&cor.b).ok_or_else(|| bad(format!("no contribution '{}'", cor.b)))?;
            if i == j {
                return Err(bad("a contribution cannot be correlated with itself".into()));
            }
            if cor.r.is_nan() || cor.r.abs() > 1.0 {
                return Err(bad(format!("r must be within [-1, 1], found {}", cor.r)));
            }
            if out
                .iter()
                .any(|&(p, q, _)| (p, q) == (i, j) || (p, q) == (j, i))
            {
                return Err(bad("given twice".into()));
            }
            out.push((i, j, cor.r));
        }
        if !out.is_empty() {
            let n = self.contributions.len();
            let mut m = vec![0.0; n * n];
            for i in 0..n {
                m[i * n + i] = 1.0;
            }
            for &(i, j, r) in &out {
                m[i * n + j] = r;
                m[j * n + i] = r;
            }
            if crate::montecarlo::cholesky(&mut m, n).is_none() {
                return Err(UncertaintyError::NotPositiveDefinite {
                    context: format!("budget '{}'", self.name),
                });
            }
        }
        Ok(out)
    }
}

/// Several budgets that may refer to each other by name (the last one is the result by default),
/// with a default coverage probability.
#[derive(Debug, Clone, PartialEq)]
pub struct BudgetSet {
    /// Coverage probability p used unless overridden (0 < p < 1).
    pub coverage: f64,
    /// The budgets in file order.
    pub budgets: Vec<Budget>,
}

impl BudgetSet {
    /// Finds a budget by name, or the last one.
    ///
    /// # Errors
    /// [`UncertaintyError::NoSuchBudget`].
    pub fn select(&self, name: Option<&str>) -> Result<&Budget, UncertaintyError> {
        match name {
            Some(n) => self.budgets.iter().find(|b| b.name == n),
            None => self.budgets.last(),
        }
        .ok_or_else(|| UncertaintyError::NoSuchBudget {
            name: name.unwrap_or("").to_string(),
        })
    }

    /// Checks names (unique budgets, unique rows per budget) and references (no missing budget, no
    /// cycle).
    ///
    /// # Errors
    /// [`UncertaintyError::DuplicateName`], [`UncertaintyError::MissingBudget`],
    /// [`UncertaintyError::CyclicBudget`].
    pub fn check_references(&self) -> Result<(), UncertaintyError> {
        let mut seen = HashMap::new();
        for (i, b) in self.budgets.iter().enumerate() {
            if seen.insert(b.name.as_str(), i).is_some() {
                return Err(UncertaintyError::DuplicateName {
                    name: b.name.clone(),
                    place: "among budgets".into(),
                });
            }
            let mut rows = HashMap::new();
            for c in &b.contributions {
                if rows.insert(c.name.as_str(), ()).is_some() {
                    return Err(UncertaintyError::DuplicateName {
                        name: c.name.clone(),
                        place: format!("in budget '{}'", b.name),
                    });
                }
                if let Source::Budget { name } = &c.source
                    && !seen.contains_key(name.as_str())
                    && !self.budgets.iter().any(|x| &x.name == name)
                {
                    return Err(UncertaintyError::MissingBudget {
                        budget: b.name.clone(),
                        contribution: c.name.clone(),
                        missing: name.clone(),
                    });
                }
            }
        }
        // Cycle detection by depth-first search.
        fn visit<'a>(
            set: &'a BudgetSet,
            name: &'a str,
            state: &mut HashMap<&'a str, u8>,
            stack: &mut Vec<&'a str>,
        ) -> Result<(), UncertaintyError> {
            match state.get(name) {
                Some(2) => return Ok(()),
                Some(1) => {
                    let start = stack.iter().position(|s| *s == name).unwrap_or(0);
                    let mut cycle: Vec<&str> = stack[start..].to_vec();
                    cycle.push(name);
                    return Err(UncertaintyError::CyclicBudget {
                        cycle: cycle.join(" -> "),
                    });
                }
                _ => {}
            }
            state.insert(name, 1);
            stack.push(name);
            if let Some(b) = set.budgets.iter().find(|b| b.name == name) {
                for c in &b.contributions {
                    if let Source::Budget { name: sub } = &c.source {
                        visit(set, sub, state, stack)?;
                    }
                }
            }
            stack.pop();
            state.insert(name, 2);
            Ok(())
        }
        let mut state = HashMap::new();
        for b in &self.budgets {
            visit(self, &b.name, &mut state, &mut Vec::new())?;
        }
        Ok(())
    }

    /// Evaluates every budget in file order (nested references resolved first) at coverage p
    /// (`None`: the set's coverage).
    ///
    /// # Errors
    /// As [`check_references`](Self::check_references), plus any invalid row, correlation or
    /// coverage.
    pub fn evaluate_all(
        &self,
        coverage: Option<f64>,
    ) -> Result<Vec<BudgetResult>, UncertaintyError> {
        self.check_references()?;
        let p = check_coverage(coverage.unwrap_or(self.coverage))?;
        let mut memo: HashMap<String, BudgetResult> = HashMap::new();
        let mut out = Vec::with_capacity(self.budgets.len());
        for b in &self.budgets {
            out.push(self.eval_one(b, p, &mut memo)?);
        }
        Ok(out)
    }

    /// Evaluates one budget (`None`: the last) at coverage p (`None`: the set's coverage).
    ///
    /// # Errors
    /// As [`evaluate_all`](Self::evaluate_all), plus [`UncertaintyError::NoSuchBudget`].
    pub fn evaluate(
        &self,
        name: Option<&str>,
        coverage: Option<f64>,
    ) -> Result<BudgetResult, UncertaintyError> {
        self.check_references()?;
        let p = check_coverage(coverage.unwrap_or(self.coverage))?;
        let b = self.select(name)?;
        self.eval_one(b, p, &mut HashMap::new())
    }

    fn eval_one(
        &self,
        b: &Budget,
        p: f64,
        memo: &mut HashMap<String, BudgetResult>,
    ) -> Result<BudgetResult, UncertaintyError> {
        if let Some(r) = memo.get(&b.name) {
            return Ok(r.clone());
        }
        let mut rows = Vec::with_capacity(b.contributions.len());
        let mut terms = Vec::with_capacity(b.contributions.len());
        for c in &b.contributions {
            c.validate()?;
            let (u, nu, value) = match &c.source {
                Source::Budget { name } => {
                    let sub = self.select(Some(name))?;
                    let r = self.eval_one(sub, p, memo)?;
                    (r.u_c, r.nu_eff, r.value)
                }
                _ => (c.u, c.nu, c.value),
            };
            terms.push(Term {
                u,
                c: c.sensitivity,
                nu,
            });
            rows.push(Row {
                name: c.name.clone(),
                source: c.source.describe(),
                value,
                u,
                c: c.sensitivity,
                cu: (c.sensitivity * u).abs(),
                nu,
                share: 0.0,
            });
        }
        let cors = b.correlation_indices()?;
        let comb = combine(&terms, &cors, p).map_err(|e| match e {
            UncertaintyError::NotPositiveDefinite { .. } => UncertaintyError::NotPositiveDefinite {
                context: format!("budget '{}'", b.name),
            },
            e => e,
        })?;
        for r in &mut rows {
            r.share = if comb.u_c > 0.0 {
                (r.cu / comb.u_c).powi(2)
            } else {
                0.0
            };
        }
        let result = BudgetResult {
            name: b.name.clone(),
            unit: b.unit.clone(),
            value: rows.iter().map(|r| r.c * r.value).sum(),
            u_c: comb.u_c,
            nu_eff: comb.nu_eff,
            nu_eff_raw: comb.nu_eff_raw,
            coverage: p,
            k: comb.k,
            expanded: comb.expanded,
            contributions: rows,
            correlations: cors
                .iter()
                .map(|&(i, j, r)| {
                    (
                        b.contributions[i].name.clone(),
                        b.contributions[j].name.clone(),
                        r,
                    )
                })
                .collect(),
        };
        memo.insert(b.name.clone(), result.clone());
        Ok(result)
    }
}
