//! Sets of budgets that refer to each other by name: evaluation of every budget (and of one
//! budget alone), nested references resolved first; the evaluated rows and results.
//!
//! Everything here is linear in the size of the set: names are looked up through hash maps, the
//! reference graph is walked without recursion (no stack overflow on a chain of 10,000 nested
//! budgets), each budget is evaluated once however often it is referred to (a "diamond" of 60
//! levels, each referring twice to the next, is 61 evaluations, not 2⁶⁰), and correlations are
//! checked through the envelope of their matrix ([`crate::limits`]).

use super::combine::finish;
use super::graph::{References, postorder};
use super::shared::shared_u_c;
use super::{Budget, Source, Term, combine, deserialize_dof, serialize_dof};
use crate::limits::{MAX_BUDGETS, MAX_ROWS};
use crate::{UncertaintyError, check_coverage, short};
use serde::{Deserialize, Serialize};
use std::collections::{HashMap, HashSet};

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
        self.position(name).map(|i| &self.budgets[i])
    }

    /// Index of a budget by name, or of the last one.
    pub(crate) fn position(&self, name: Option<&str>) -> Result<usize, UncertaintyError> {
        match name {
            Some(n) => self.budgets.iter().position(|b| b.name == n),
            None => self.budgets.len().checked_sub(1),
        }
        .ok_or_else(|| UncertaintyError::NoSuchBudget {
            name: name.unwrap_or("").to_string(),
        })
    }

    /// Checks sizes ([`crate::limits`]: budgets, rows per budget), names (unique budgets, unique
    /// rows per budget) and references (no missing budget, no cycle).
    ///
    /// # Errors
    /// [`UncertaintyError::TooLarge`], [`UncertaintyError::DuplicateName`],
    /// [`UncertaintyError::MissingBudget`], [`UncertaintyError::CyclicBudget`].
    pub fn check_references(&self) -> Result<(), UncertaintyError> {
        self.references().map(|_| ())
    }

    /// As [`check_references`](Self::check_references), returning the resolved references.
    pub(crate) fn references(&self) -> Result<References, UncertaintyError> {
        if self.budgets.len() > MAX_BUDGETS {
            return Err(UncertaintyError::TooLarge {
                budget: None,
                what: "budgets".into(),
                found: self.budgets.len() as u64,
                limit: MAX_BUDGETS as u64,
                hint: String::new(),
            });
        }
        let mut index: HashMap<&str, usize> = HashMap::with_capacity(self.budgets.len());
        for (i, b) in self.budgets.iter().enumerate() {
            if index.insert(b.name.as_str(), i).is_some() {
                return Err(UncertaintyError::DuplicateName {
                    name: b.name.clone(),
                    place: "among budgets".into(),
                });
            }
        }
        let mut refs = Vec::with_capacity(self.budgets.len());
        for b in &self.budgets {
            if b.contributions.len() > MAX_ROWS {
                return Err(UncertaintyError::TooLarge {
                    budget: Some(b.name.clone()),
                    what: format!("budget '{}': rows", short(&b.name)),
                    found: b.contributions.len() as u64,
                    limit: MAX_ROWS as u64,
                    hint: String::new(),
                });
            }
            let mut rows = HashSet::with_capacity(b.contributions.len());
            let mut r = Vec::with_capacity(b.contributions.len());
            for c in &b.contributions {
                if !rows.insert(c.name.as_str()) {
                    return Err(UncertaintyError::DuplicateName {
                        name: c.name.clone(),
                        place: format!("in budget '{}'", short(&b.name)),
                    });
                }
                r.push(match &c.source {
                    Source::Budget { name } => {
                        Some(*index.get(name.as_str()).ok_or_else(|| {
                            UncertaintyError::MissingBudget {
                                budget: b.name.clone(),
                                contribution: c.name.clone(),
                                missing: name.clone(),
                            }
                        })?)
                    }
                    _ => None,
                });
            }
            refs.push(r);
        }
        // Cycle detection: depth-first from each budget in file order, rows in order, without
        // recursion. State 1: on the current path; 2: done.
        let mut state = vec![0u8; self.budgets.len()];
        let mut path: Vec<(usize, usize)> = Vec::new();
        for root in 0..self.budgets.len() {
            if state[root] != 0 {
                continue;
            }
            state[root] = 1;
            path.push((root, 0));
            while let Some(top) = path.last_mut() {
                let (b, row) = *top;
                if row == refs[b].len() {
                    state[b] = 2;
                    path.pop();
                    continue;
                }
                top.1 += 1;
                let Some(sub) = refs[b][row] else { continue };
                match state[sub] {
                    0 => {
                        state[sub] = 1;
                        path.push((sub, 0));
                    }
                    1 => {
                        let start = path.iter().position(|&(x, _)| x == sub).unwrap_or(0);
                        let mut budgets: Vec<String> = path[start..]
                            .iter()
                            .map(|&(x, _)| self.budgets[x].name.clone())
                            .collect();
                        budgets.push(self.budgets[sub].name.clone());
                        return Err(UncertaintyError::CyclicBudget {
                            cycle: cycle_text(&budgets),
                            budgets,
                        });
                    }
                    _ => {}
                }
            }
        }
        Ok(refs)
    }

    /// Evaluates every budget in file order (nested references resolved first, each budget once)
    /// at coverage p (`None`: the set's coverage).
    ///
    /// # Errors
    /// As [`check_references`](Self::check_references), plus any invalid row, correlation or
    /// coverage, and [`UncertaintyError::NonFinite`] when a result overflows.
    pub fn evaluate_all(
        &self,
        coverage: Option<f64>,
    ) -> Result<Vec<BudgetResult>, UncertaintyError> {
        let refs = self.references()?;
        let p = check_coverage(coverage.unwrap_or(self.coverage))?;
        let order = postorder(&refs, 0..self.budgets.len());
        let exact = shared_u_c(&self.budgets, &refs, &order)?;
        let mut results: Vec<Option<BudgetResult>> = vec![None; self.budgets.len()];
        for i in order {
            results[i] = Some(self.eval_one(i, &refs[i], exact[i], p, &results)?);
        }
        Ok(results.into_iter().flatten().collect())
    }

    /// Evaluates one budget (`None`: the last) at coverage p (`None`: the set's coverage), and the
    /// budgets it refers to, each once.
    ///
    /// # Errors
    /// As [`evaluate_all`](Self::evaluate_all), plus [`UncertaintyError::NoSuchBudget`].
    pub fn evaluate(
        &self,
        name: Option<&str>,
        coverage: Option<f64>,
    ) -> Result<BudgetResult, UncertaintyError> {
        let refs = self.references()?;
        let p = check_coverage(coverage.unwrap_or(self.coverage))?;
        let root = self.position(name)?;
        let order = postorder(&refs, std::iter::once(root));
        let exact = shared_u_c(&self.budgets, &refs, &order)?;
        let mut results: Vec<Option<BudgetResult>> = vec![None; self.budgets.len()];
        for i in order {
            results[i] = Some(self.eval_one(i, &refs[i], exact[i], p, &results)?);
        }
        results[root]
            .take()
            .ok_or_else(|| UncertaintyError::NoSuchBudget {
                name: self.budgets[root].name.clone(),
            })
    }

    /// The budget `name` (`None`: the last) and every budget it refers to, directly or through
    /// others, each once, breadth first (the budget itself first). References to missing budgets
    /// are skipped.
    ///
    /// # Errors
    /// [`UncertaintyError::NoSuchBudget`].
    pub fn dependencies(&self, name: Option<&str>) -> Result<Vec<&str>, UncertaintyError> {
        let root = self.position(name)?;
        let index: HashMap<&str, usize> = self
            .budgets
            .iter()
            .enumerate()
            .map(|(i, b)| (b.name.as_str(), i))
            .collect();
        let mut seen = vec![false; self.budgets.len()];
        seen[root] = true;
        let mut out = vec![root];
        let mut k = 0;
        while k < out.len() {
            for c in &self.budgets[out[k]].contributions {
                if let Source::Budget { name } = &c.source
                    && let Some(&i) = index.get(name.as_str())
                    && !seen[i]
                {
                    seen[i] = true;
                    out.push(i);
                }
            }
            k += 1;
        }
        Ok(out
            .into_iter()
            .map(|i| self.budgets[i].name.as_str())
            .collect())
    }

    /// Evaluates budget `i` whose references are already in `results`; `exact_u_c`: its combined
    /// standard uncertainty from the leaves when two of its rows share a nested budget.
    fn eval_one(
        &self,
        i: usize,
        refs: &[Option<usize>],
        exact_u_c: Option<f64>,
        p: f64,
        results: &[Option<BudgetResult>],
    ) -> Result<BudgetResult, UncertaintyError> {
        let b = &self.budgets[i];
        let overflow = |row: Option<&str>, quantity: String| UncertaintyError::NonFinite {
            budget: b.name.clone(),
            contribution: row.map(str::to_string),
            quantity,
        };
        let mut rows = Vec::with_capacity(b.contributions.len());
        let mut terms = Vec::with_capacity(b.contributions.len());
        for (c, sub) in b.contributions.iter().zip(refs) {
            c.validate()?;
            let (u, nu, value) = match sub.map(|s| results[s].as_ref()) {
                Some(Some(r)) => (r.u_c, r.nu_eff, r.value),
                Some(None) => {
                    return Err(UncertaintyError::MissingBudget {
                        budget: b.name.clone(),
                        contribution: c.name.clone(),
                        missing: match &c.source {
                            Source::Budget { name } => name.clone(),
                            _ => String::new(),
                        },
                    });
                }
                None => (c.u, c.nu, c.value),
            };
            let cu = (c.sensitivity * u).abs();
            if !cu.is_finite() {
                return Err(overflow(
                    Some(&c.name),
                    format!("|c·u| = |{:e} × {:e}|", c.sensitivity, u),
                ));
            }
            if !(c.sensitivity * value).is_finite() {
                return Err(overflow(
                    Some(&c.name),
                    format!("c·x = {:e} × {:e}", c.sensitivity, value),
                ));
            }
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
                cu,
                nu,
                share: 0.0,
            });
        }
        let cors = b.correlation_indices()?;
        let comb = match exact_u_c {
            Some(u_c) => finish(&terms, u_c, p),
            None => combine(&terms, &cors, p),
        }
        .map_err(|e| match e {
            UncertaintyError::NotPositiveDefinite { .. } => UncertaintyError::NotPositiveDefinite {
                context: format!("budget '{}'", short(&b.name)),
            },
            UncertaintyError::NonFinite { quantity, .. } => overflow(None, quantity),
            e => e,
        })?;
        for r in &mut rows {
            r.share = if comb.u_c > 0.0 {
                (r.cu / comb.u_c).powi(2)
            } else {
                0.0
            };
        }
        let value: f64 = rows.iter().map(|r| r.c * r.value).sum();
        if !value.is_finite() {
            // Name the row at which the running sum leaves the floating-point range.
            let mut y = 0.0;
            let at = rows
                .iter()
                .find(|r| {
                    y += r.c * r.value;
                    !y.is_finite()
                })
                .map(|r| r.name.as_str());
            return Err(overflow(
                at,
                "the estimate y = Σ c·x (summed up to this row)".into(),
            ));
        }
        Ok(BudgetResult {
            name: b.name.clone(),
            unit: b.unit.clone(),
            value,
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
        })
    }
}

/// `a -> b -> a` with shortened names; long cycles show their first budgets and the count.
fn cycle_text(budgets: &[String]) -> String {
    const SHOWN: usize = 6;
    if budgets.len() <= SHOWN + 2 {
        return budgets
            .iter()
            .map(|b| short(b))
            .collect::<Vec<_>>()
            .join(" -> ");
    }
    let head: Vec<String> = budgets[..SHOWN].iter().map(|b| short(b)).collect();
    format!(
        "{} -> … ({} more) -> {}",
        head.join(" -> "),
        budgets.len() - 1 - SHOWN,
        short(&budgets[0])
    )
}
