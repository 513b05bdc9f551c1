//! Monte Carlo view of a budget: every row's input distribution (JCGM 101 §6.4) and the budget
//! flattened into a linear model y = Σ c_i x_i over its leaf inputs.

use super::{Budget, BudgetSet, Contribution, Source};
use crate::UncertaintyError;
use crate::montecarlo::{InputDistribution, McConfig, McResult, monte_carlo};

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
/// sensitivity (the product of the coefficients along the nesting), and the correlations between
/// leaves. The measurement function is y = Σ coefficient_i · x_i.
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
    /// As [`monte_carlo`].
    pub fn monte_carlo(&self, cfg: &McConfig) -> Result<McResult, UncertaintyError> {
        let c = &self.coefficients;
        monte_carlo(
            &self.inputs,
            &self.correlations,
            |x: &[f64]| x.iter().zip(c).map(|(x, c)| x * c).sum(),
            cfg,
        )
    }
}

impl BudgetSet {
    /// Flattens a budget (`None`: the last) and its nested budgets into a [`LinearModel`].
    ///
    /// # Errors
    /// Reference errors as [`check_references`](Self::check_references); invalid rows;
    /// [`UncertaintyError::MonteCarlo`] when a correlation involves a nested budget (its inputs,
    /// not the budget, are what Monte Carlo draws).
    pub fn linear_model(&self, name: Option<&str>) -> Result<LinearModel, UncertaintyError> {
        self.check_references()?;
        let b = self.select(name)?;
        let mut m = LinearModel {
            names: Vec::new(),
            inputs: Vec::new(),
            coefficients: Vec::new(),
            correlations: Vec::new(),
        };
        self.flatten(b, 1.0, &mut m)?;
        Ok(m)
    }

    fn flatten(&self, b: &Budget, coef: f64, m: &mut LinearModel) -> Result<(), UncertaintyError> {
        let cors = b.correlation_indices()?;
        let mut leaf_index = vec![usize::MAX; b.contributions.len()];
        for (i, c) in b.contributions.iter().enumerate() {
            c.validate()?;
            match (&c.source, c.distribution()) {
                (Source::Budget { name }, _) => {
                    let sub = self.select(Some(name))?;
                    self.flatten(sub, coef * c.sensitivity, m)?;
                }
                (_, Some(d)) => {
                    leaf_index[i] = m.inputs.len();
                    m.names.push(format!("{}/{}", b.name, c.name));
                    m.inputs.push(d);
                    m.coefficients.push(coef * c.sensitivity);
                }
                (_, None) => {}
            }
        }
        for (i, j, r) in cors {
            if leaf_index[i] == usize::MAX || leaf_index[j] == usize::MAX {
                return Err(UncertaintyError::MonteCarlo {
                    what: format!(
                        "budget '{}': the correlation between '{}' and '{}' involves a nested budget; correlate its inputs instead",
                        b.name, b.contributions[i].name, b.contributions[j].name
                    ),
                });
            }
            m.correlations.push((leaf_index[i], leaf_index[j], r));
        }
        Ok(())
    }
}
