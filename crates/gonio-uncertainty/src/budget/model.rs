//! Monte Carlo view of a budget: every row's input distribution (JCGM 101 §6.4) and the budget
//! flattened into a linear model y = Σ c_i x_i over its leaf inputs.
//!
//! A budget referred to by several rows (directly or through other budgets) is one quantity: its
//! inputs appear once in the model, drawn once per trial, with a coefficient summed over every
//! path of references (each path contributing the product of its sensitivity coefficients). The
//! flattening therefore visits each budget once: a diamond of 60 levels, each referring twice to
//! the next, gives one leaf, not 2⁶⁰ copies.

use super::graph::postorder;
use super::{BudgetSet, Contribution, Source};
use crate::UncertaintyError;
use crate::montecarlo::{InputDistribution, McConfig, McResult, max_trials, monte_carlo_linear};

impl Contribution {
    /// The Monte Carlo distribution of this input (JCGM 101 §6.4): Type A and a directly given u
    /// with stated finite ν → scaled-and-shifted t; normal certificates, u with ν = ∞ or ν from a
    /// relative uncertainty → normal; rectangular, resolution, triangular, arcsine → their shape.
    /// `None` for a nested budget (its inputs are drawn instead).
    pub fn distribution(&self) -> Option<InputDistribution> {
        let mean = self.value;
        Some(match &self.source {
            Source::Direct if self.nu.is_finite() && self.relative_uncertainty.is_none() => {
                InputDistribution::StudentT {
                    mean,
                    scale: self.u,
                    nu: self.nu,
                }
            }
            Source::Direct => InputDistribution::Normal { mean, sd: self.u },
            Source::TypeA { .. } => InputDistribution::StudentT {
                mean,
                scale: self.u,
                nu: self.nu,
            },
            Source::Rectangular { half_width } => InputDistribution::Rectangular {
                mean,
                half_width: *half_width,
            },
            Source::Resolution { step } => InputDistribution::Rectangular {
                mean,
                half_width: step / 2.0,
            },
            Source::Triangular { half_width } => InputDistribution::Triangular {
                mean,
                half_width: *half_width,
            },
            Source::Arcsine { half_width } => InputDistribution::Arcsine {
                mean,
                half_width: *half_width,
            },
            Source::Normal { .. } => InputDistribution::Normal { mean, sd: self.u },
            Source::Budget { .. } => return None,
        })
    }
}

/// A budget flattened for Monte Carlo: every leaf input with its distribution and its overall
/// sensitivity (summed over every path of nested references, each path the product of its
/// coefficients), and the correlations between leaves. The measurement function is
/// y = Σ coefficient_i · x_i.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearModel {
    /// Leaf names, `budget/contribution`.
    pub names: Vec<String>,
    /// Leaf distributions.
    pub inputs: Vec<InputDistribution>,
    /// Overall sensitivity coefficient of each leaf.
    pub coefficients: Vec<f64>,
    /// Correlations between leaves (indices into `inputs`).
    pub correlations: Vec<(usize, usize, f64)>,
}

impl LinearModel {
    /// Runs Monte Carlo on y = Σ c_i x_i.
    ///
    /// # Errors
    /// As [`crate::monte_carlo`].
    pub fn monte_carlo(&self, cfg: &McConfig) -> Result<McResult, UncertaintyError> {
        self.monte_carlo_with_progress(cfg, |_| {})
    }

    /// As [`monte_carlo`](Self::monte_carlo), calling `progress(trials_so_far)` as the trials are
    /// drawn (at least once per batch).
    ///
    /// # Errors
    /// As [`crate::monte_carlo`].
    pub fn monte_carlo_with_progress<P: FnMut(usize)>(
        &self,
        cfg: &McConfig,
        progress: P,
    ) -> Result<McResult, UncertaintyError> {
        // The model is evaluated a chunk of trials at a time, column by column: the same sums as
        // `x.iter().zip(c).map(|(x, c)| x * c).sum()` per trial, bit for bit.
        monte_carlo_linear(
            &self.inputs,
            &self.correlations,
            &self.coefficients,
            cfg,
            progress,
        )
    }

    /// The most trials a run of this model may use ([`crate::montecarlo::max_trials`]): fewer
    /// than [`crate::montecarlo::MAX_TRIALS`] for large models, so that trials × inputs stays
    /// within [`crate::limits::MAX_MC_DRAWS`].
    ///
    /// # Errors
    /// As [`crate::montecarlo::max_trials`].
    pub fn max_trials(&self) -> Result<usize, UncertaintyError> {
        max_trials(&self.inputs, &self.correlations)
    }
}

impl BudgetSet {
    /// Flattens a budget (`None`: the last) and its nested budgets into a [`LinearModel`]. Leaves
    /// come in the order of the rows, a nested budget's leaves where it is first referred to.
    ///
    /// # Errors
    /// Reference errors as [`check_references`](Self::check_references); invalid rows or
    /// correlations; [`UncertaintyError::CorrelatedNestedBudget`] when a correlation involves a
    /// nested budget (its inputs, not the budget, are what Monte Carlo draws);
    /// [`UncertaintyError::NonFinite`] when the draws' sum could overflow (Σ|c|·|x| beyond the
    /// floating-point range, |x| bounded by the support, or 40 u for the normal and the t) or a
    /// summed coefficient does.
    pub fn linear_model(&self, name: Option<&str>) -> Result<LinearModel, UncertaintyError> {
        let refs = self.references()?;
        let root = self.position(name)?;
        // Coefficient of each budget: the sum over the rows referring to it of the referring
        // budget's coefficient times the row's sensitivity, parents before children (reverse
        // post-order). A budget referred to once gets exactly the product along its path.
        let order = postorder(&refs, std::iter::once(root));
        let mut coef: Vec<Option<f64>> = vec![None; self.budgets.len()];
        coef[root] = Some(1.0);
        for &b in order.iter().rev() {
            let Some(cb) = coef[b] else { continue };
            for (c, sub) in self.budgets[b].contributions.iter().zip(&refs[b]) {
                if let Some(s) = *sub {
                    let add = cb * c.sensitivity;
                    let total = coef[s].map_or(add, |x| x + add);
                    if !total.is_finite() {
                        return Err(UncertaintyError::NonFinite {
                            budget: self.budgets[b].name.clone(),
                            contribution: Some(c.name.clone()),
                            quantity: format!(
                                "the overall sensitivity coefficient of budget '{}'",
                                crate::short(&self.budgets[s].name)
                            ),
                        });
                    }
                    coef[s] = Some(total);
                }
            }
        }
        let mut m = LinearModel {
            names: Vec::new(),
            inputs: Vec::new(),
            coefficients: Vec::new(),
            correlations: Vec::new(),
        };
        // Depth-first walk from the root, rows in order, each budget entered once (at its first
        // reference): leaves in the order of the old recursive flattening for a tree of budgets.
        let mut entered = vec![false; self.budgets.len()];
        entered[root] = true;
        // (budget, next row, leaf index of each row so far)
        let mut path: Vec<(usize, usize, Vec<usize>)> = vec![(root, 0, Vec::new())];
        let mut bound = 0.0f64;
        while let Some(top) = path.last_mut() {
            let (bi, row) = (top.0, top.1);
            let b = &self.budgets[bi];
            if row == 0 {
                b.correlation_indices()?;
            }
            if row == b.contributions.len() {
                let leaves = std::mem::take(&mut top.2);
                path.pop();
                for (i, j, r) in b.correlation_indices()? {
                    if leaves[i] == usize::MAX || leaves[j] == usize::MAX {
                        return Err(UncertaintyError::CorrelatedNestedBudget {
                            budget: b.name.clone(),
                            a: b.contributions[i].name.clone(),
                            b: b.contributions[j].name.clone(),
                        });
                    }
                    m.correlations.push((leaves[i], leaves[j], r));
                }
                continue;
            }
            top.1 += 1;
            let c = &b.contributions[row];
            c.validate()?;
            match (refs[bi][row], c.distribution()) {
                (Some(s), _) => {
                    top.2.push(usize::MAX);
                    if !entered[s] {
                        entered[s] = true;
                        path.push((s, 0, Vec::new()));
                    }
                }
                (None, Some(d)) => {
                    top.2.push(m.inputs.len());
                    let k = coef[bi].unwrap_or(1.0) * c.sensitivity;
                    // A bound of |c·x| over the draws (the support of the bounded shapes, 40
                    // standard uncertainties for the normal and the t).
                    bound += k.abs() * d.reach();
                    if !bound.is_finite() {
                        return Err(UncertaintyError::NonFinite {
                            budget: b.name.clone(),
                            contribution: Some(c.name.clone()),
                            quantity: format!(
                                "the sum of the Monte Carlo draws of c·x up to this row (c = {k:e}, |x| up to {:e})",
                                d.reach()
                            ),
                        });
                    }
                    m.names.push(format!("{}/{}", b.name, c.name));
                    m.inputs.push(d);
                    m.coefficients.push(k);
                }
                (None, None) => top.2.push(usize::MAX),
            }
        }
        Ok(m)
    }
}
