//! GUM uncertainty budgets: contributions, combined standard uncertainty, Welch–Satterthwaite,
//! coverage factor, expanded uncertainty and shares (JCGM 100:2008 §5, §6, Annex G).
//!
//! For inputs x_i with standard uncertainties u_i, sensitivity coefficients c_i, degrees of freedom
//! ν_i and correlation coefficients r_ij,
//!
//! ```text
//! u_c² = Σ (c_i u_i)² + 2 Σ_{i<j} c_i c_j u_i u_j r_ij
//! ν_eff = u_c⁴ / Σ (c_i u_i)⁴ / ν_i        (Welch–Satterthwaite, G.2b)
//! k = t_{(1+p)/2}(⌊ν_eff⌋)                 (G.4.1: ν_eff truncated to the next lower integer)
//! U = k · u_c
//! ```
//!
//! Infinite degrees of freedom are `f64::INFINITY`. The share of a row is (c_i u_i)² / u_c²; with
//! correlations the shares do not add up to 1 (the cross terms are not attributed to any row), and
//! Welch–Satterthwaite is then only an approximation (it assumes independent inputs).
//!
//! ```
//! use gonio_uncertainty::{Budget, Contribution};
//! let mut b = Budget::new("length");
//! b.push(Contribution::rectangular("resolution", 0.5));
//! b.push(Contribution::normal("certificate", 0.2, 2.0));
//! let r = b.evaluate(0.95).unwrap();
//! assert!((r.u_c - (0.25f64 / 3.0 + 0.01).sqrt()).abs() < 1e-15);
//! assert!(r.nu_eff.is_infinite() && (r.k - 1.959964).abs() < 1e-6);
//! ```

use crate::montecarlo::{InputDistribution, McConfig, McResult, monte_carlo};
use crate::student::coverage_factor;
use crate::{UncertaintyError, check_coverage};
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::collections::HashMap;

/// How a contribution's standard uncertainty was obtained (also selects its Monte Carlo
/// distribution, JCGM 101 §6.4).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Source {
    /// u given directly. Monte Carlo: normal if ν is infinite or comes from a relative uncertainty,
    /// otherwise a scaled-and-shifted t with ν degrees of freedom (a Type A value).
    Direct,
    /// Type A from n repeated observations: u = s/√n, ν = n − 1. Monte Carlo: scaled-and-shifted t.
    TypeA {
        /// Number of observations.
        n: usize,
    },
    /// Rectangular with half-width a: u = a/√3.
    Rectangular {
        /// Half-width a.
        half_width: f64,
    },
    /// Resolution with full step d (rectangular of half-width d/2): u = d/(2√3).
    Resolution {
        /// Full step d.
        step: f64,
    },
    /// Symmetric triangular with half-width a: u = a/√6.
    Triangular {
        /// Half-width a.
        half_width: f64,
    },
    /// U-shaped (arcsine) with half-width a: u = a/√2.
    Arcsine {
        /// Half-width a.
        half_width: f64,
    },
    /// Normal from a certificate's expanded uncertainty U and coverage factor k: u = U/k.
    Normal {
        /// Expanded uncertainty U.
        expanded: f64,
        /// Coverage factor k.
        k: f64,
    },
    /// Another budget's combined standard uncertainty and (truncated) ν_eff.
    Budget {
        /// The referenced budget's name.
        name: String,
    },
}

impl Source {
    /// A short description for tables, e.g. `rectangular a=0.05`.
    pub fn describe(&self) -> String {
        match self {
            Source::Direct => "given".into(),
            Source::TypeA { n } => format!("type A n={n}"),
            Source::Rectangular { half_width } => format!("rectangular a={half_width}"),
            Source::Resolution { step } => format!("resolution d={step}"),
            Source::Triangular { half_width } => format!("triangular a={half_width}"),
            Source::Arcsine { half_width } => format!("arcsine a={half_width}"),
            Source::Normal { expanded, k } => format!("normal U={expanded} k={k}"),
            Source::Budget { name } => format!("budget '{name}'"),
        }
    }
}

/// One row of a budget: an input quantity with its standard uncertainty, sensitivity coefficient
/// and degrees of freedom.
#[derive(Debug, Clone, PartialEq)]
pub struct Contribution {
    /// Name shown in tables and used by correlations.
    pub name: String,
    /// Estimate x_i of the input (default 0); the budget's estimate is y = Σ c_i x_i.
    pub value: f64,
    /// Standard uncertainty u(x_i), in the input's unit (for a nested budget, filled on evaluation).
    pub u: f64,
    /// Degrees of freedom ν_i (`f64::INFINITY` for exactly known).
    pub nu: f64,
    /// Relative uncertainty R of u, when ν was derived from it (ν = 1/(2R²)).
    pub relative_uncertainty: Option<f64>,
    /// Sensitivity coefficient c_i = ∂y/∂x_i (default 1).
    pub sensitivity: f64,
    /// Where u came from.
    pub source: Source,
}

impl Contribution {
    fn with_source(name: &str, u: f64, source: Source) -> Contribution {
        Contribution {
            name: name.to_string(),
            value: 0.0,
            u,
            nu: f64::INFINITY,
            relative_uncertainty: None,
            sensitivity: 1.0,
            source,
        }
    }

    /// A standard uncertainty given directly (ν = ∞ unless [`with_dof`](Self::with_dof)).
    pub fn direct(name: &str, u: f64) -> Contribution {
        Self::with_source(name, u, Source::Direct)
    }

    /// Type A from repeated observations: value = mean, u = s/√n, ν = n − 1.
    ///
    /// # Errors
    /// [`UncertaintyError::BadParameter`] for fewer than 2 observations or a non-finite one.
    ///
    /// ```
    /// use gonio_uncertainty::Contribution;
    /// let c = Contribution::type_a("repeatability", &[1.0, 2.0, 3.0]).unwrap();
    /// assert_eq!((c.value, c.nu), (2.0, 2.0));
    /// assert!((c.u - 1.0 / 3f64.sqrt()).abs() < 1e-15);
    /// ```
    pub fn type_a(name: &str, observations: &[f64]) -> Result<Contribution, UncertaintyError> {
        let n = observations.len();
        if n < 2 || observations.iter().any(|x| !x.is_finite()) {
            return Err(UncertaintyError::BadParameter {
                name: name.to_string(),
                what: format!(
                    "Type A needs at least 2 finite observations, found {n}{}",
                    if observations.iter().any(|x| !x.is_finite()) {
                        " (some not finite)"
                    } else {
                        ""
                    }
                ),
            });
        }
        let mean = observations.iter().sum::<f64>() / n as f64;
        let ss: f64 = observations.iter().map(|x| (x - mean).powi(2)).sum();
        let s = (ss / (n - 1) as f64).sqrt();
        let mut c = Self::with_source(name, s / (n as f64).sqrt(), Source::TypeA { n });
        c.value = mean;
        c.nu = (n - 1) as f64;
        Ok(c)
    }

    /// Type A from a sample standard deviation s of n observations: u = s/√n, ν = n − 1.
    pub fn type_a_from_std(name: &str, s: f64, n: usize) -> Contribution {
        let mut c = Self::with_source(name, s / (n as f64).sqrt(), Source::TypeA { n });
        c.nu = n as f64 - 1.0;
        c
    }

    /// Rectangular distribution of half-width a: u = a/√3.
    pub fn rectangular(name: &str, half_width: f64) -> Contribution {
        Self::with_source(
            name,
            half_width / 3f64.sqrt(),
            Source::Rectangular { half_width },
        )
    }

    /// Resolution (full step d, rectangular of half-width d/2): u = d/(2√3).
    pub fn resolution(name: &str, step: f64) -> Contribution {
        Self::with_source(
            name,
            step / (2.0 * 3f64.sqrt()),
            Source::Resolution { step },
        )
    }

    /// Symmetric triangular distribution of half-width a: u = a/√6.
    pub fn triangular(name: &str, half_width: f64) -> Contribution {
        Self::with_source(
            name,
            half_width / 6f64.sqrt(),
            Source::Triangular { half_width },
        )
    }

    /// U-shaped (arcsine) distribution of half-width a: u = a/√2.
    pub fn arcsine(name: &str, half_width: f64) -> Contribution {
        Self::with_source(
            name,
            half_width / 2f64.sqrt(),
            Source::Arcsine { half_width },
        )
    }

    /// Normal, from an expanded uncertainty U with coverage factor k: u = U/k.
    pub fn normal(name: &str, expanded: f64, k: f64) -> Contribution {
        Self::with_source(name, expanded / k, Source::Normal { expanded, k })
    }

    /// Another budget's combined uncertainty and truncated ν_eff, resolved by [`BudgetSet`].
    pub fn from_budget(name: &str, budget: &str) -> Contribution {
        Self::with_source(
            name,
            f64::NAN,
            Source::Budget {
                name: budget.to_string(),
            },
        )
    }

    /// Sets the degrees of freedom (`f64::INFINITY` for none).
    pub fn with_dof(mut self, nu: f64) -> Contribution {
        self.nu = nu;
        self.relative_uncertainty = None;
        self
    }

    /// Sets ν from the relative uncertainty R of u: ν = 1/(2R²) (JCGM 100 G.4.2; R = 0.10 → 50).
    /// R = 0 gives ν = ∞.
    pub fn with_relative_uncertainty(mut self, r: f64) -> Contribution {
        self.nu = if r == 0.0 {
            f64::INFINITY
        } else {
            // 1/(2·0.1²) is 49.999…: snap to the whole number the formula means.
            let nu = 1.0 / (2.0 * r * r);
            if (nu - nu.round()).abs() < 1e-9 * nu {
                nu.round()
            } else {
                nu
            }
        };
        self.relative_uncertainty = Some(r);
        self
    }

    /// Sets the sensitivity coefficient c.
    pub fn with_sensitivity(mut self, c: f64) -> Contribution {
        self.sensitivity = c;
        self
    }

    /// Sets the input estimate x.
    pub fn with_value(mut self, x: f64) -> Contribution {
        self.value = x;
        self
    }

    /// Checks the numbers: u ≥ 0 and finite (except a not yet resolved nested budget), bounds ≥ 0,
    /// k > 0, ν > 0, R ≥ 0, finite c and x.
    ///
    /// # Errors
    /// [`UncertaintyError::BadUncertainty`], [`UncertaintyError::BadDof`] or
    /// [`UncertaintyError::BadParameter`] naming the contribution.
    pub fn validate(&self) -> Result<(), UncertaintyError> {
        let bad_u = |what: &str, value: f64| {
            Err(UncertaintyError::BadUncertainty {
                name: self.name.clone(),
                what: what.to_string(),
                value,
            })
        };
        let param = |what: String| {
            Err(UncertaintyError::BadParameter {
                name: self.name.clone(),
                what,
            })
        };
        match &self.source {
            Source::Rectangular { half_width }
            | Source::Triangular { half_width }
            | Source::Arcsine { half_width }
                if !(half_width.is_finite() && *half_width >= 0.0) =>
            {
                return bad_u("half_width", *half_width);
            }
            Source::Resolution { step } if !(step.is_finite() && *step >= 0.0) => {
                return bad_u("step", *step);
            }
            Source::Normal { expanded, k } => {
                if !(expanded.is_finite() && *expanded >= 0.0) {
                    return bad_u("expanded", *expanded);
                }
                if !(k.is_finite() && *k > 0.0) {
                    return param(format!("coverage factor k must be > 0, found {k}"));
                }
            }
            Source::TypeA { n } if *n < 2 => {
                return param(format!("Type A needs n ≥ 2 observations, found {n}"));
            }
            _ => {}
        }
        let resolved = !matches!(self.source, Source::Budget { .. }) || !self.u.is_nan();
        if resolved && !(self.u.is_finite() && self.u >= 0.0) {
            return bad_u("u", self.u);
        }
        if let Some(r) = self.relative_uncertainty
            && !(r.is_finite() && r >= 0.0)
        {
            return param(format!("relative_uncertainty must be ≥ 0, found {r}"));
        }
        if self.nu.is_nan() || self.nu <= 0.0 {
            return Err(UncertaintyError::BadDof {
                name: self.name.clone(),
                nu: self.nu,
            });
        }
        if !self.sensitivity.is_finite() {
            return param(format!(
                "sensitivity must be finite, found {}",
                self.sensitivity
            ));
        }
        if !self.value.is_finite() {
            return param(format!("value must be finite, found {}", self.value));
        }
        Ok(())
    }
}

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

/// The terms of a GUM combination: |c|·u, its ν, and the raw c and u for tables.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Term {
    /// Standard uncertainty u_i.
    pub u: f64,
    /// Sensitivity coefficient c_i.
    pub c: f64,
    /// Degrees of freedom ν_i (`f64::INFINITY` allowed).
    pub nu: f64,
}

/// The result of combining terms: u_c, ν_eff (raw and truncated), k and U at coverage p.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Combined {
    /// Combined standard uncertainty u_c.
    pub u_c: f64,
    /// Welch–Satterthwaite ν_eff, truncated to the next lower integer (kept fractional below 1;
    /// `f64::INFINITY` when every ν is infinite); k is computed from this value.
    #[serde(serialize_with = "serialize_dof", deserialize_with = "deserialize_dof")]
    pub nu_eff: f64,
    /// Welch–Satterthwaite ν_eff before truncation.
    #[serde(serialize_with = "serialize_dof", deserialize_with = "deserialize_dof")]
    pub nu_eff_raw: f64,
    /// Coverage probability p.
    pub coverage: f64,
    /// Coverage factor k = t_{(1+p)/2}(ν_eff).
    pub k: f64,
    /// Expanded uncertainty U = k·u_c.
    #[serde(rename = "U")]
    pub expanded: f64,
}

/// Serialises degrees of freedom: a whole number as an integer, infinity as the string `"inf"`.
pub fn serialize_dof<S: Serializer>(nu: &f64, s: S) -> Result<S::Ok, S::Error> {
    if nu.is_infinite() {
        s.serialize_str("inf")
    } else if nu.fract() == 0.0 && nu.abs() < 9.0e15 {
        s.serialize_i64(*nu as i64)
    } else {
        s.serialize_f64(*nu)
    }
}

/// Reads degrees of freedom written by [`serialize_dof`]: a number, or the string `"inf"`.
///
/// # Errors
/// Anything else (another string, a boolean, null…).
pub fn deserialize_dof<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Dof {
        Number(f64),
        Text(String),
    }
    match Dof::deserialize(d)? {
        Dof::Number(v) => Ok(v),
        Dof::Text(t) if t == "inf" => Ok(f64::INFINITY),
        Dof::Text(t) => Err(serde::de::Error::custom(format!(
            "degrees of freedom: expected a number or \"inf\", found {t:?}"
        ))),
    }
}

/// Serialises an optional ν like [`serialize_dof`] (null when absent).
pub fn serialize_opt_dof<S: Serializer>(nu: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
    match nu {
        Some(v) => serialize_dof(v, s),
        None => s.serialize_none(),
    }
}

/// Reads an optional ν written by [`serialize_opt_dof`] (null or absent: `None`).
///
/// # Errors
/// As [`deserialize_dof`].
pub fn deserialize_opt_dof<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    #[derive(Deserialize)]
    struct Wrap(#[serde(deserialize_with = "deserialize_dof")] f64);
    Ok(Option::<Wrap>::deserialize(d)?.map(|w| w.0))
}

/// Truncates ν_eff to the next lower integer (JCGM 100 G.4.1); values below 1 are kept as they are
/// (truncating them to 0 would make k infinite).
pub fn truncate_dof(nu: f64) -> f64 {
    if nu.is_infinite() || nu < 1.0 {
        nu
    } else {
        nu.floor()
    }
}

/// Combines terms with optional correlations `(i, j, r_ij)` (indices into `terms`, i ≠ j) into
/// u_c, ν_eff, k and U at coverage p.
///
/// # Errors
/// [`UncertaintyError::BadCoverage`] for p outside (0, 1);
/// [`UncertaintyError::NotPositiveDefinite`] when correlations make u_c² negative.
///
/// ```
/// use gonio_uncertainty::{Term, combine};
/// let t = [Term { u: 3.0, c: 1.0, nu: 4.0 }, Term { u: 4.0, c: 1.0, nu: f64::INFINITY }];
/// let r = combine(&t, &[], 0.95).unwrap();
/// assert_eq!(r.u_c, 5.0);
/// assert!((r.nu_eff_raw - 625.0 / (81.0 / 4.0)).abs() < 1e-12); // 30.86…
/// assert_eq!(r.nu_eff, 30.0);
/// ```
pub fn combine(
    terms: &[Term],
    correlations: &[(usize, usize, f64)],
    coverage: f64,
) -> Result<Combined, UncertaintyError> {
    check_coverage(coverage)?;
    // Work in units of the largest |c·u| so that squares cannot overflow or underflow.
    let scale = terms
        .iter()
        .map(|t| (t.c * t.u).abs())
        .fold(0.0f64, f64::max);
    let s = if scale > 0.0 && scale.is_finite() {
        scale
    } else {
        1.0
    };
    let cu = |t: &Term| t.c * t.u / s;
    let mut var: f64 = terms.iter().map(|t| cu(t).powi(2)).sum();
    for &(i, j, r) in correlations {
        var += 2.0 * cu(&terms[i]) * cu(&terms[j]) * r;
    }
    if var < -1e-12 * terms.iter().map(|t| cu(t).powi(2)).sum::<f64>() {
        return Err(UncertaintyError::NotPositiveDefinite {
            context: "combination".into(),
        });
    }
    let u_c = s * var.max(0.0).sqrt();
    // ν_eff = u_c⁴ / Σ (c u)⁴/ν, with every term divided by u_c first so that no power overflows.
    let denom: f64 = if u_c > 0.0 {
        terms
            .iter()
            .filter(|t| t.nu.is_finite())
            .map(|t| (t.c * t.u / u_c).powi(4) / t.nu)
            .sum()
    } else {
        0.0
    };
    let nu_eff_raw = if denom > 0.0 {
        1.0 / denom
    } else {
        f64::INFINITY
    };
    let nu_eff = truncate_dof(nu_eff_raw);
    let k = coverage_factor(coverage, nu_eff);
    Ok(Combined {
        u_c,
        nu_eff,
        nu_eff_raw,
        coverage,
        k,
        expanded: k * u_c,
    })
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

/// The GUM (law of propagation of uncertainty, first order) for a measurement function supplied
/// by the caller: sensitivity coefficients c_i = ∂f/∂x_i by central differences at the estimates x
/// (step h_i = 10⁻⁴·u_i, or 10⁻⁸·max(|x_i|, 1) when u_i = 0), then [`combine`]. Returns
/// y = f(x), the coefficients, and the combination; pair it with [`crate::monte_carlo`] and
/// [`crate::validate`] for the JCGM 101 §8 comparison.
///
/// # Errors
/// [`UncertaintyError::BadParameter`] when the slices differ in length or f is not finite near x;
/// the errors of [`combine`].
///
/// ```
/// use gonio_uncertainty::budget::gum_for_model;
/// // y = x₁·x₂ at (2, 3) with u = (0.1, 0.2): c = (3, 2), u_c = √(0.09 + 0.16) = 0.5.
/// let (y, c, r) = gum_for_model(|x: &[f64]| x[0] * x[1], &[2.0, 3.0], &[0.1, 0.2],
///     &[f64::INFINITY; 2], 0.95).unwrap();
/// assert_eq!(y, 6.0);
/// assert!((c[0] - 3.0).abs() < 1e-9 && (c[1] - 2.0).abs() < 1e-9);
/// assert!((r.u_c - 0.5).abs() < 1e-9);
/// ```
pub fn gum_for_model<F: Fn(&[f64]) -> f64>(
    f: F,
    x: &[f64],
    u: &[f64],
    nu: &[f64],
    coverage: f64,
) -> Result<(f64, Vec<f64>, Combined), UncertaintyError> {
    if x.len() != u.len() || x.len() != nu.len() {
        return Err(UncertaintyError::BadParameter {
            name: "model".into(),
            what: format!(
                "x, u and nu must have the same length, found {}, {} and {}",
                x.len(),
                u.len(),
                nu.len()
            ),
        });
    }
    let y = f(x);
    let mut xs = x.to_vec();
    let mut c = Vec::with_capacity(x.len());
    let mut terms = Vec::with_capacity(x.len());
    for i in 0..x.len() {
        let h = if u[i] > 0.0 {
            1e-4 * u[i]
        } else {
            1e-8 * x[i].abs().max(1.0)
        };
        xs[i] = x[i] + h;
        let up = f(&xs);
        xs[i] = x[i] - h;
        let down = f(&xs);
        xs[i] = x[i];
        let ci = (up - down) / (2.0 * h);
        if !(ci.is_finite() && y.is_finite()) {
            return Err(UncertaintyError::BadParameter {
                name: format!("input {i}"),
                what: "the measurement function is not finite near the estimate".into(),
            });
        }
        let input = Contribution::direct(&format!("input {i}"), u[i]).with_dof(nu[i]);
        input.validate()?;
        c.push(ci);
        terms.push(Term {
            u: u[i],
            c: ci,
            nu: nu[i],
        });
    }
    let r = combine(&terms, &[], coverage)?;
    Ok((y, c, r))
}

/// The normalised error En = |x₁ − x₂| / √(U₁² + U₂²) for comparing two results with expanded
/// uncertainties U₁, U₂ (|En| ≤ 1 passes). Returns ∞ when both U are 0 and x₁ ≠ x₂, 0 when equal.
///
/// ```
/// use gonio_uncertainty::en;
/// assert!((en(0.10, 0.15, 0.0, 0.02) - 0.10 / (0.15f64.powi(2) + 0.02f64.powi(2)).sqrt()).abs() < 1e-15);
/// ```
pub fn en(x1: f64, expanded1: f64, x2: f64, expanded2: f64) -> f64 {
    let d = (x1 - x2).abs();
    let s = expanded1.hypot(expanded2);
    if d == 0.0 { 0.0 } else { d / s }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Seed 000 Table 3 as printed, from its listed contributions (the two-stage evaluation the
    /// paper describes: u(ε) from six rows, then ε, β and the polygon set-up).
    fn seed_table3() -> BudgetSet {
        let mut eps = Budget::new("measured value");
        eps.push(Contribution::type_a_from_std(
            "repeatability of angle error",
            0.13,
            6,
        ));
        eps.push(Contribution::resolution("autocollimator resolution", 0.001).with_dof(50.0));
        eps.push(Contribution::normal("autocollimator traceability", 0.01, 2.0).with_dof(50.0));
        // As printed: the row uses 0.07/√3 although the text states 0.05″.
        eps.push(Contribution::rectangular("autocollimator angle error", 0.07).with_dof(50.0));
        // As printed: 0.0101″ (0.04/(2√3) would be 0.0115″).
        eps.push(Contribution::direct("encoder resolution", 0.0101).with_dof(50.0));
        eps.push(Contribution::resolution("residual setup error", 0.0001).with_dof(50.0));
        let mut top = Budget::new("shift-angle");
        top.push(Contribution::from_budget(
            "measured value",
            "measured value",
        ));
        top.push(
            Contribution::type_a_from_std("pitch deviation repeatability", 0.12, 6)
                .with_sensitivity(0.0401),
        );
        top.push(Contribution::resolution("polygon setup", 0.05).with_dof(50.0));
        BudgetSet {
            coverage: 0.95,
            budgets: vec![eps, top],
        }
    }

    #[test]
    fn seed_table3_reproduced() {
        let set = seed_table3();
        let all = set.evaluate_all(None).unwrap();
        let eps = &all[0];
        // Paper: u(ε) = 0.0676″ (0.0677 from the listed rows), ν = 12.
        assert!((eps.u_c - 0.0677).abs() < 5e-5, "{}", eps.u_c);
        assert!((eps.nu_eff_raw - 12.77).abs() < 0.01);
        assert_eq!(eps.nu_eff, 12.0);
        let r = &all[1];
        // Paper: u_c = 0.07″ (0.069), ν_eff = 13, k = 2.16, U = 0.15″.
        assert!((r.u_c - 0.069).abs() < 5e-4, "{}", r.u_c);
        assert!((r.nu_eff_raw - 13.13).abs() < 0.005, "{}", r.nu_eff_raw);
        assert_eq!(r.nu_eff, 13.0);
        assert!((r.k - 2.160).abs() < 5e-4);
        assert!((r.expanded - 0.15).abs() < 5e-3);
        let shares: f64 = r.contributions.iter().map(|c| c.share).sum();
        assert!((shares - 1.0).abs() < 1e-12);
        // Table 3 row: |c·u| of β = 0.0401 × 0.0490 = 0.0020″.
        assert!((r.contributions[1].cu - 0.0020).abs() < 5e-5);
    }

    #[test]
    fn seed_table3_flat_gives_13_96() {
        let set = seed_table3();
        let mut flat = Budget::new("flat");
        flat.contributions = set.budgets[0].contributions.clone();
        flat.contributions
            .extend(set.budgets[1].contributions[1..].iter().cloned());
        let r = flat.evaluate(0.95).unwrap();
        assert!((r.nu_eff_raw - 13.96).abs() < 0.02, "{}", r.nu_eff_raw);
        assert_eq!(r.nu_eff, 13.0);
    }

    #[test]
    fn seed_self_calibration_budget() {
        let mut b = Budget::new("self-calibration");
        b.push(Contribution::type_a_from_std("repeatability", 0.01, 6));
        b.push(Contribution::direct("encoder resolution", 0.0101).with_relative_uncertainty(0.10));
        let r = b.evaluate(0.95).unwrap();
        // Paper: u = 0.01″ (0.0109), ν_eff = 53, k = 2.01 (2.006), U = 0.02″ (0.022).
        assert!((r.u_c - 0.0109).abs() < 5e-5);
        assert_eq!(r.nu_eff, 53.0);
        assert!((r.k - 2.006).abs() < 5e-4);
        assert!((r.expanded - 0.022).abs() < 5e-4);
    }

    /// JCGM 100:2008 Annex H.1 (end-gauge calibration), Table H.1, first-order terms. Inputs as
    /// stated in H.1.3 (u(l_s) = 25 nm, ν = 18; u(d̄) = 5.8 nm ν = 24, u(d₁) = 3.9 nm ν = 5,
    /// u(d₂) = 6.7 nm ν = 8; δα rectangular ±1×10⁻⁶ °C⁻¹, ν = 50 (R = 10 %); δθ rectangular
    /// ±0.050 °C, ν = 2 (R = 50 %); α_s rectangular ±2×10⁻⁶ °C⁻¹ and θ with zero first-order
    /// sensitivity), l_s = 50 mm, θ = −0.1 °C, α_s = 11.5×10⁻⁶ °C⁻¹.
    /// Published: u_c = 32 nm, ν_eff = 16, k₉₉ = 2.92, U₉₉ = 93 nm.
    #[test]
    fn jcgm_100_h1_end_gauge() {
        let l_s_nm = 50.0e6;
        let mut d = Budget::new("d");
        d.push(Contribution::direct("d mean", 5.8).with_dof(24.0));
        d.push(Contribution::direct("d1 random comparator", 3.9).with_dof(5.0));
        d.push(Contribution::direct("d2 systematic comparator", 6.7).with_dof(8.0));
        let mut l = Budget::new("l");
        l.push(Contribution::direct("l_s", 25.0).with_dof(18.0));
        l.push(Contribution::from_budget("d", "d"));
        l.push(Contribution::rectangular("alpha_s", 2e-6).with_sensitivity(0.0));
        l.push(Contribution::direct("theta", 0.41).with_sensitivity(0.0));
        l.push(
            Contribution::rectangular("delta alpha", 1e-6)
                .with_dof(50.0)
                .with_sensitivity(-l_s_nm * -0.1),
        );
        l.push(
            Contribution::rectangular("delta theta", 0.05)
                .with_dof(2.0)
                .with_sensitivity(-l_s_nm * 11.5e-6),
        );
        let set = BudgetSet {
            coverage: 0.99,
            budgets: vec![d, l],
        };
        let all = set.evaluate_all(None).unwrap();
        // H.1.3.2: u(d) = 9.7 nm, ν_eff(d) = 25.6 (25.4 from the rounded inputs).
        assert!((all[0].u_c - 9.7).abs() < 0.05);
        assert!((all[0].nu_eff_raw - 25.6).abs() < 0.3);
        let r = &all[1];
        // H.1.4: u_c² = 1002 nm², u_c = 32 nm.
        assert!((r.u_c.powi(2) - 1002.0).abs() < 1.0, "{}", r.u_c);
        assert_eq!(r.u_c.round(), 32.0);
        assert_eq!(r.nu_eff, 16.0);
        assert!((r.k - 2.92).abs() < 0.005);
        // H.1.6: U₉₉ = 2.92 × (32 nm) = 93 nm, from the rounded u_c; unrounded 2.921 × 31.66 nm
        // = 92.5 nm.
        assert_eq!((r.k * r.u_c.round()).round(), 93.0);
        assert!((r.expanded - 92.5).abs() < 0.05, "{}", r.expanded);
        // Table H.1 rows: c·u(δα) = 2.9 nm, c·u(δθ) = 16.6 nm.
        assert!((r.contributions[4].cu - 2.9).abs() < 0.05);
        assert!((r.contributions[5].cu - 16.6).abs() < 0.05);
    }

    #[test]
    fn correlations_enter_u_c() {
        let mut b = Budget::new("c");
        b.push(Contribution::direct("a", 3.0));
        b.push(Contribution::direct("b", 4.0).with_sensitivity(-1.0));
        b.correlate("a", "b", 1.0);
        // Fully correlated with opposite signs: u_c = |3 − 4| = 1.
        let r = b.evaluate(0.95).unwrap();
        assert!((r.u_c - 1.0).abs() < 1e-12);
        b.correlations[0].r = 1.5;
        assert!(matches!(
            b.evaluate(0.95),
            Err(UncertaintyError::BadCorrelation { .. })
        ));
        b.correlations[0].r = 0.5;
        b.correlations[0].b = "zz".into();
        assert!(matches!(
            b.evaluate(0.95),
            Err(UncertaintyError::BadCorrelation { .. })
        ));
    }

    #[test]
    fn bad_inputs_are_typed_errors() {
        let mut b = Budget::new("x");
        b.push(Contribution::direct("neg", -1.0));
        assert!(matches!(
            b.evaluate(0.95),
            Err(UncertaintyError::BadUncertainty { .. })
        ));
        let mut b = Budget::new("x");
        b.push(Contribution::direct("zero dof", 1.0).with_dof(0.0));
        assert!(matches!(
            b.evaluate(0.95),
            Err(UncertaintyError::BadDof { .. })
        ));
        let mut b = Budget::new("x");
        b.push(Contribution::direct("ok", 1.0));
        assert!(matches!(
            b.evaluate(1.0),
            Err(UncertaintyError::BadCoverage { .. })
        ));
        let mut a = Budget::new("a");
        a.push(Contribution::from_budget("b", "b"));
        let mut bb = Budget::new("b");
        bb.push(Contribution::from_budget("a", "a"));
        let set = BudgetSet {
            coverage: 0.95,
            budgets: vec![a.clone(), bb],
        };
        let e = set.evaluate(None, None).unwrap_err();
        assert_eq!(
            e.to_string(),
            "budgets refer to themselves in a cycle: a -> b -> a"
        );
        let set = BudgetSet {
            coverage: 0.95,
            budgets: vec![a],
        };
        assert!(matches!(
            set.evaluate(None, None),
            Err(UncertaintyError::MissingBudget { .. })
        ));
    }

    /// Monte Carlo of the seed's Table 3 as a linear model: the Type A rows (ν = 5) are drawn as
    /// scaled t₅, whose standard deviation is √(5/3) times u, so u(y) must exceed the GUM u_c by
    /// the amount that follows from the rows (computed here from the same rows, independently of
    /// the sampler).
    #[test]
    fn table3_monte_carlo_u_matches_t_inflated_variance() {
        let set = seed_table3();
        let model = set.linear_model(None).unwrap();
        assert_eq!(model.inputs.len(), 8);
        let mc = model.monte_carlo(&McConfig::default()).unwrap();
        assert!(mc.converged);
        let mut var = 0.0;
        for (d, c) in model.inputs.iter().zip(&model.coefficients) {
            let v = match *d {
                InputDistribution::StudentT { scale, nu, .. } => scale * scale * nu / (nu - 2.0),
                _ => d.std_uncertainty().powi(2),
            };
            var += c * c * v;
        }
        assert!(
            (mc.std_uncertainty - var.sqrt()).abs() < 2.0 * mc.tolerance,
            "{mc:?}"
        );
    }

    #[test]
    fn extreme_magnitudes_do_not_overflow() {
        let mut b = Budget::new("big");
        b.push(Contribution::direct("a", 1e200).with_dof(4.0));
        b.push(Contribution::direct("b", 1e200).with_dof(4.0));
        let r = b.evaluate(0.95).unwrap();
        // Two equal terms with ν = 4: ν_eff = 4·(2u²)²/(2u⁴) = 8.
        assert!((r.nu_eff_raw - 8.0).abs() < 1e-12 && r.k.is_finite());
    }

    #[test]
    fn en_number() {
        assert_eq!(en(1.0, 3.0, 5.0, 4.0), 0.8);
        assert_eq!(en(1.0, 0.0, 1.0, 0.0), 0.0);
        assert!(en(1.0, 0.0, 2.0, 0.0).is_infinite());
    }
}
