//! Contributions: how each row of a budget gets its standard uncertainty u, its degrees of
//! freedom ν and its sensitivity coefficient c (JCGM 100 §4).

use crate::UncertaintyError;

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

    /// Another budget's combined uncertainty and truncated ν_eff, resolved by [`BudgetSet`](super::BudgetSet).
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
