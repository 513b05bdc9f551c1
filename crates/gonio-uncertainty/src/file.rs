//! The TOML budget-file format (documented with examples in `docs/budget-format.md`), parsed with
//! errors that name the line and column.
//!
//! ```toml
//! coverage = 0.95                 # optional; default 0.95
//! [[budget]]                      # several budgets; the last one is the result by default
//! name = "measured value"
//! unit = "arcsec"                 # optional, shown in tables
//! [[budget.contribution]]
//! name = "repeatability"
//! u = 0.0531                      # or observations = [..], std_dev = s + n = N,
//! dof = 5                         #   distribution = "rectangular" | "triangular" | "arcsine"
//! sensitivity = 1.0               #     + half_width, "resolution" + step, "normal" + expanded + k,
//! [[budget]]                      #   or from = "budget name"
//! name = "shift-angle"
//! [[budget.contribution]]
//! name = "measured value"
//! from = "measured value"
//! ```
//!
//! ```
//! use gonio_uncertainty::parse_budget_file;
//! let set = parse_budget_file("[[budget]]\nname = \"b\"\n[[budget.contribution]]\nname = \"r\"\nu = -1\n");
//! assert_eq!(set.unwrap_err().to_string(), "5:5: contribution 'r': u must be a finite number ≥ 0, found -1");
//! ```

use crate::budget::{Budget, BudgetSet, Contribution, Correlation, Source};
use crate::{UncertaintyError, check_coverage};
use serde::Deserialize;
use std::ops::Range;
use toml::Spanned;

/// An error in a budget (or instrument) file, at a 1-based line and column. Display:
/// `LINE:COLUMN: message`; the caller prefixes the file name.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{line}:{column}: {message}")]
pub struct BudgetFileError {
    /// 1-based line.
    pub line: usize,
    /// 1-based column (characters).
    pub column: usize,
    /// What is wrong and what was expected.
    pub message: String,
}

/// 1-based line and column of a byte offset.
pub(crate) fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let mut o = offset;
    while !text.is_char_boundary(o) {
        o -= 1;
    }
    let before = &text[..o];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

pub(crate) fn err_at(
    text: &str,
    span: &Range<usize>,
    message: impl Into<String>,
) -> BudgetFileError {
    let (line, column) = line_col(text, span.start);
    BudgetFileError {
        line,
        column,
        message: message.into(),
    }
}

pub(crate) fn toml_error(text: &str, e: toml::de::Error) -> BudgetFileError {
    let (line, column) = e.span().map_or((1, 1), |s| line_col(text, s.start));
    BudgetFileError {
        line,
        column,
        message: e.message().trim().replace('\n', " "),
    }
}

/// Degrees of freedom as written: a number or `"inf"`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct DofValue(pub f64);

impl<'de> Deserialize<'de> for DofValue {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl serde::de::Visitor<'_> for V {
            type Value = DofValue;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a number or \"inf\"")
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<DofValue, E> {
                Ok(DofValue(v as f64))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<DofValue, E> {
                Ok(DofValue(v as f64))
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<DofValue, E> {
                Ok(DofValue(v))
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<DofValue, E> {
                match v.trim().to_ascii_lowercase().as_str() {
                    "inf" | "infinity" | "∞" => Ok(DofValue(f64::INFINITY)),
                    _ => Err(E::custom(format!(
                        "expected a number or \"inf\", found \"{v}\""
                    ))),
                }
            }
        }
        d.deserialize_any(V)
    }
}

/// One contribution as written (shared with instrument files).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawContribution {
    pub name: Option<Spanned<String>>,
    pub u: Option<Spanned<f64>>,
    pub observations: Option<Spanned<Vec<f64>>>,
    pub std_dev: Option<Spanned<f64>>,
    pub n: Option<Spanned<i64>>,
    pub distribution: Option<Spanned<String>>,
    pub half_width: Option<Spanned<f64>>,
    pub step: Option<Spanned<f64>>,
    pub expanded: Option<Spanned<f64>>,
    pub k: Option<Spanned<f64>>,
    pub dof: Option<Spanned<DofValue>>,
    pub relative_uncertainty: Option<Spanned<f64>>,
    pub sensitivity: Option<Spanned<f64>>,
    pub value: Option<Spanned<f64>>,
    pub from: Option<Spanned<String>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCorrelation {
    between: Spanned<Vec<String>>,
    r: Spanned<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBudget {
    name: Option<Spanned<String>>,
    unit: Option<String>,
    #[serde(default)]
    contribution: Vec<Spanned<RawContribution>>,
    #[serde(default)]
    correlation: Vec<Spanned<RawCorrelation>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFile {
    coverage: Option<Spanned<f64>>,
    #[serde(default)]
    budget: Vec<Spanned<RawBudget>>,
}

const DISTRIBUTIONS: &str = "rectangular, triangular, arcsine, resolution or normal";

/// Builds a contribution from its table; `default_name` is used when the table has no `name`
/// (instrument sections), otherwise a name is required.
pub(crate) fn build_contribution(
    text: &str,
    raw: &Spanned<RawContribution>,
    default_name: Option<&str>,
) -> Result<Contribution, BudgetFileError> {
    let span = raw.span();
    let c = raw.get_ref();
    let name = match (&c.name, default_name) {
        (Some(n), _) => n.get_ref().trim().to_string(),
        (None, Some(d)) => d.to_string(),
        (None, None) => {
            return Err(err_at(
                text,
                &span,
                "contribution without a name: expected name = \"...\"",
            ));
        }
    };
    if name.is_empty() {
        let s = c.name.as_ref().map_or(span.clone(), |n| n.span());
        return Err(err_at(text, &s, "empty contribution name"));
    }
    let at =
        |s: Range<usize>, m: String| Err(err_at(text, &s, format!("contribution '{name}': {m}")));
    // Exactly one way to give u.
    let kinds: Vec<(&str, Range<usize>)> = [
        ("u", c.u.as_ref().map(|x| x.span())),
        ("observations", c.observations.as_ref().map(|x| x.span())),
        ("std_dev", c.std_dev.as_ref().map(|x| x.span())),
        ("distribution", c.distribution.as_ref().map(|x| x.span())),
        ("from", c.from.as_ref().map(|x| x.span())),
    ]
    .into_iter()
    .filter_map(|(k, s)| s.map(|s| (k, s)))
    .collect();
    if kinds.is_empty() {
        return at(
            span,
            "expected one of u, observations, std_dev (with n), distribution or from".into(),
        );
    }
    if kinds.len() > 1 {
        return at(
            kinds[1].1.clone(),
            format!(
                "give only one of u, observations, std_dev, distribution, from; found {} and {}",
                kinds[0].0, kinds[1].0
            ),
        );
    }
    // Fields that belong to one way only.
    let unused =
        |field: &str, s: Option<Range<usize>>, allowed: bool| -> Result<(), BudgetFileError> {
            match s {
                Some(s) if !allowed => Err(err_at(
                    text,
                    &s,
                    format!(
                        "contribution '{name}': {field} is not used with {}",
                        kinds[0].0
                    ),
                )),
                _ => Ok(()),
            }
        };
    let dist = c
        .distribution
        .as_ref()
        .map(|d| d.get_ref().trim().to_ascii_lowercase());
    let d = dist.as_deref().unwrap_or("");
    if let Some(ds) = &c.distribution
        && !matches!(
            d,
            "rectangular"
                | "uniform"
                | "triangular"
                | "arcsine"
                | "u-shaped"
                | "resolution"
                | "normal"
                | "gaussian"
        )
    {
        return at(
            ds.span(),
            format!("unknown distribution \"{d}\": expected {DISTRIBUTIONS}"),
        );
    }
    unused("n", c.n.as_ref().map(|x| x.span()), c.std_dev.is_some())?;
    unused(
        "half_width",
        c.half_width.as_ref().map(|x| x.span()),
        matches!(
            d,
            "rectangular" | "triangular" | "arcsine" | "uniform" | "u-shaped"
        ),
    )?;
    unused("step", c.step.as_ref().map(|x| x.span()), d == "resolution")?;
    unused(
        "expanded",
        c.expanded.as_ref().map(|x| x.span()),
        d == "normal",
    )?;
    unused("k", c.k.as_ref().map(|x| x.span()), d == "normal")?;
    let mut contrib = if let Some(u) = &c.u {
        Contribution::direct(&name, *u.get_ref())
    } else if let Some(obs) = &c.observations {
        Contribution::type_a(&name, obs.get_ref()).or_else(|e| at(obs.span(), strip(&e, &name)))?
    } else if let Some(s) = &c.std_dev {
        let Some(n) = &c.n else {
            return at(
                s.span(),
                "std_dev needs n = number of observations (u = s/√n, ν = n − 1)".into(),
            );
        };
        if *n.get_ref() < 2 {
            return at(n.span(), format!("n must be ≥ 2, found {}", n.get_ref()));
        }
        Contribution::type_a_from_std(&name, *s.get_ref(), *n.get_ref() as usize)
    } else if let Some(from) = &c.from {
        Contribution::from_budget(&name, from.get_ref().trim())
    } else {
        let ds = c.distribution.as_ref().map_or(span.clone(), |x| x.span());
        let need = |field: &str, v: &Option<Spanned<f64>>| -> Result<f64, BudgetFileError> {
            v.as_ref().map(|x| *x.get_ref()).ok_or_else(|| {
                err_at(
                    text,
                    &ds,
                    format!("contribution '{name}': distribution \"{d}\" needs {field}"),
                )
            })
        };
        match d {
            "rectangular" | "uniform" => {
                Contribution::rectangular(&name, need("half_width", &c.half_width)?)
            }
            "triangular" => Contribution::triangular(&name, need("half_width", &c.half_width)?),
            "arcsine" | "u-shaped" => {
                Contribution::arcsine(&name, need("half_width", &c.half_width)?)
            }
            "resolution" => Contribution::resolution(&name, need("step", &c.step)?),
            "normal" | "gaussian" => {
                Contribution::normal(&name, need("expanded", &c.expanded)?, need("k", &c.k)?)
            }
            other => {
                return at(
                    ds,
                    format!("unknown distribution \"{other}\": expected {DISTRIBUTIONS}"),
                );
            }
        }
    };
    // Degrees of freedom.
    match (&c.dof, &c.relative_uncertainty) {
        (Some(_), Some(r)) => {
            return at(
                r.span(),
                "give dof or relative_uncertainty, not both".into(),
            );
        }
        (Some(nu), None) => {
            if c.from.is_some() || c.observations.is_some() || c.std_dev.is_some() {
                return at(
                    nu.span(),
                    format!("dof is not used with {} (ν comes from it)", kinds[0].0),
                );
            }
            let v = nu.get_ref().0;
            if v.is_nan() || v <= 0.0 {
                return at(
                    nu.span(),
                    format!("degrees of freedom must be > 0 (or \"inf\"), found {v}"),
                );
            }
            contrib = contrib.with_dof(v);
        }
        (None, Some(r)) => {
            if c.from.is_some() || c.observations.is_some() || c.std_dev.is_some() {
                return at(
                    r.span(),
                    format!(
                        "relative_uncertainty is not used with {} (ν comes from it)",
                        kinds[0].0
                    ),
                );
            }
            let v = *r.get_ref();
            if !(v.is_finite() && v >= 0.0) {
                return at(
                    r.span(),
                    format!("relative_uncertainty must be ≥ 0 (0.10 means 10 %), found {v}"),
                );
            }
            contrib = contrib.with_relative_uncertainty(v);
        }
        (None, None) => {}
    }
    if let Some(s) = &c.sensitivity {
        contrib = contrib.with_sensitivity(*s.get_ref());
    }
    if let Some(v) = &c.value {
        if c.from.is_some() {
            return at(
                v.span(),
                "value is not used with from (the nested budget gives it)".into(),
            );
        }
        contrib = contrib.with_value(*v.get_ref());
    }
    if let Err(e) = contrib.validate() {
        let field_span = |f: &str| -> Option<Range<usize>> {
            match f {
                "u" => c.u.as_ref().map(|x| x.span()),
                "half_width" => c.half_width.as_ref().map(|x| x.span()),
                "step" => c.step.as_ref().map(|x| x.span()),
                "expanded" => c.expanded.as_ref().map(|x| x.span()),
                "k" => c.k.as_ref().map(|x| x.span()),
                "std_dev" => c.std_dev.as_ref().map(|x| x.span()),
                "sensitivity" => c.sensitivity.as_ref().map(|x| x.span()),
                "value" => c.value.as_ref().map(|x| x.span()),
                _ => None,
            }
        };
        let s = match &e {
            UncertaintyError::BadUncertainty { what, .. } => field_span(what)
                .or_else(|| field_span("std_dev"))
                .unwrap_or(span.clone()),
            UncertaintyError::BadParameter { what, .. } => ["k", "sensitivity", "value"]
                .into_iter()
                .find(|f| what.contains(f))
                .and_then(field_span)
                .unwrap_or(span.clone()),
            _ => span.clone(),
        };
        return Err(err_at(text, &s, e.to_string()));
    }
    Ok(contrib)
}

fn strip(e: &UncertaintyError, name: &str) -> String {
    let s = e.to_string();
    s.strip_prefix(&format!("contribution '{name}': "))
        .map_or(s.clone(), str::to_string)
}

/// Parses a budget file into a [`BudgetSet`], checking everything that can be checked without
/// evaluating: fields, distributions, u ≥ 0, ν > 0, 0 < coverage < 1, unique names, nested
/// references (missing or cyclic) and correlations.
///
/// # Errors
/// [`BudgetFileError`] at the offending line and column, with what was expected.
pub fn parse_budget_file(text: &str) -> Result<BudgetSet, BudgetFileError> {
    let raw: RawFile = toml::from_str(text).map_err(|e| toml_error(text, e))?;
    let coverage = match &raw.coverage {
        Some(c) => {
            check_coverage(*c.get_ref()).map_err(|e| err_at(text, &c.span(), e.to_string()))?
        }
        None => 0.95,
    };
    if raw.budget.is_empty() {
        return Err(BudgetFileError {
            line: 1,
            column: 1,
            message: "no budget: expected at least one [[budget]] table with [[budget.contribution]] rows".into(),
        });
    }
    let mut budgets = Vec::with_capacity(raw.budget.len());
    // Spans: budget name, each contribution's `from` (or table), each correlation.
    let mut name_spans = Vec::new();
    let mut from_spans: Vec<Vec<Range<usize>>> = Vec::new();
    for rb in &raw.budget {
        let b = rb.get_ref();
        let Some(name) = &b.name else {
            return Err(err_at(
                text,
                &rb.span(),
                "budget without a name: expected name = \"...\"",
            ));
        };
        let bname = name.get_ref().trim().to_string();
        if bname.is_empty() {
            return Err(err_at(text, &name.span(), "empty budget name"));
        }
        if budgets.iter().any(|x: &Budget| x.name == bname) {
            return Err(err_at(
                text,
                &name.span(),
                format!("duplicate budget name '{bname}'"),
            ));
        }
        if b.contribution.is_empty() {
            return Err(err_at(
                text,
                &rb.span(),
                format!("budget '{bname}' has no rows: expected [[budget.contribution]] tables"),
            ));
        }
        let mut budget = Budget::new(&bname);
        budget.unit = b.unit.clone();
        let mut froms = Vec::new();
        for rc in &b.contribution {
            let c = build_contribution(text, rc, None)?;
            if budget.contributions.iter().any(|x| x.name == c.name) {
                let s = rc.get_ref().name.as_ref().map_or(rc.span(), |n| n.span());
                return Err(err_at(
                    text,
                    &s,
                    format!(
                        "duplicate contribution name '{}' in budget '{bname}'",
                        c.name
                    ),
                ));
            }
            froms.push(rc.get_ref().from.as_ref().map_or(rc.span(), |f| f.span()));
            budget.contributions.push(c);
        }
        for rcor in &b.correlation {
            let cor = rcor.get_ref();
            let names = cor.between.get_ref();
            if names.len() != 2 {
                return Err(err_at(
                    text,
                    &cor.between.span(),
                    format!(
                        "between must name exactly 2 contributions, found {}",
                        names.len()
                    ),
                ));
            }
            budget.correlations.push(Correlation {
                a: names[0].clone(),
                b: names[1].clone(),
                r: *cor.r.get_ref(),
            });
            let single = Budget {
                correlations: vec![budget.correlations.last().cloned().unwrap_or_else(|| {
                    Correlation {
                        a: String::new(),
                        b: String::new(),
                        r: 0.0,
                    }
                })],
                ..budget.clone()
            };
            if let Err(e) = single.correlation_indices() {
                let s = if matches!(&e, UncertaintyError::BadCorrelation { what, .. } if what.starts_with("r "))
                {
                    cor.r.span()
                } else {
                    cor.between.span()
                };
                return Err(err_at(text, &s, e.to_string()));
            }
        }
        if let Err(e) = budget.correlation_indices() {
            let s = b.correlation.first().map_or(rb.span(), |c| c.span());
            return Err(err_at(text, &s, e.to_string()));
        }
        name_spans.push(name.span());
        from_spans.push(froms);
        budgets.push(budget);
    }
    let set = BudgetSet { coverage, budgets };
    // References: name the `from` line of the offending contribution.
    if let Err(e) = set.check_references() {
        let span = match &e {
            UncertaintyError::MissingBudget {
                budget,
                contribution,
                ..
            } => locate(&set, &from_spans, budget, contribution),
            UncertaintyError::CyclicBudget { cycle } => {
                let parts: Vec<&str> = cycle.split(" -> ").collect();
                // The reference from the cycle's first budget to the next.
                let (b0, b1) = (parts[0], parts.get(1).copied().unwrap_or(parts[0]));
                let bi = set.budgets.iter().position(|b| b.name == b0).unwrap_or(0);
                let ci = set.budgets[bi]
                    .contributions
                    .iter()
                    .position(|c| matches!(&c.source, Source::Budget { name } if name == b1))
                    .unwrap_or(0);
                from_spans.get(bi).and_then(|v| v.get(ci)).cloned()
            }
            _ => None,
        }
        .unwrap_or(0..0);
        return Err(err_at(text, &span, e.to_string()));
    }
    let _ = name_spans;
    Ok(set)
}

fn locate(
    set: &BudgetSet,
    spans: &[Vec<Range<usize>>],
    budget: &str,
    contribution: &str,
) -> Option<Range<usize>> {
    let bi = set.budgets.iter().position(|b| b.name == budget)?;
    let ci = set.budgets[bi]
        .contributions
        .iter()
        .position(|c| c.name == contribution)?;
    spans.get(bi)?.get(ci).cloned()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(text: &str) -> String {
        parse_budget_file(text).unwrap_err().to_string()
    }

    const HEAD: &str = "[[budget]]\nname = \"b\"\n[[budget.contribution]]\nname = \"r\"\n";

    #[test]
    fn every_way_to_give_u() {
        let text = r#"
coverage = 0.99
[[budget]]
name = "inner"
[[budget.contribution]]
name = "given"
u = 0.5
dof = 5
[[budget.contribution]]
name = "obs"
observations = [1.0, 2.0, 3.0]
[[budget.contribution]]
name = "s"
std_dev = 0.13
n = 6
[[budget.contribution]]
name = "rect"
distribution = "rectangular"
half_width = 0.07
relative_uncertainty = 0.10
[[budget.contribution]]
name = "res"
distribution = "resolution"
step = 0.04
dof = "inf"
[[budget.contribution]]
name = "tri"
distribution = "triangular"
half_width = 6
[[budget.contribution]]
name = "arc"
distribution = "arcsine"
half_width = 2
sensitivity = -2
[[budget.contribution]]
name = "cert"
distribution = "normal"
expanded = 0.01
k = 2
[[budget]]
name = "outer"
[[budget.contribution]]
name = "inner"
from = "inner"
"#;
        let set = parse_budget_file(text).unwrap();
        assert_eq!(set.coverage, 0.99);
        let c = &set.budgets[0].contributions;
        let us: Vec<f64> = c.iter().map(|c| c.u).collect();
        let expect = [
            0.5,
            1.0 / 3f64.sqrt(),
            0.13 / 6f64.sqrt(),
            0.07 / 3f64.sqrt(),
            0.04 / 12f64.sqrt(),
            6.0 / 6f64.sqrt(),
            2.0 / 2f64.sqrt(),
            0.005,
        ];
        for (u, e) in us.iter().zip(expect) {
            assert!((u - e).abs() < 1e-15, "{u} vs {e}");
        }
        let nus: Vec<f64> = c.iter().map(|c| c.nu).collect();
        assert_eq!(nus[..3], [5.0, 2.0, 5.0]);
        assert!(nus[3] == 50.0 && nus[4].is_infinite());
        assert_eq!(c[6].sensitivity, -2.0);
        let r = set.evaluate(None, None).unwrap();
        assert_eq!(r.name, "outer");
        assert_eq!(r.coverage, 0.99);
    }

    #[test]
    fn errors_name_line_and_column() {
        assert_eq!(
            err(&format!(
                "{HEAD}distribution = \"gaussianish\"\nhalf_width = 1\n"
            )),
            "5:16: contribution 'r': unknown distribution \"gaussianish\": expected rectangular, triangular, arcsine, resolution or normal"
        );
        assert!(
            err(&format!("{HEAD}u = 1\ndof = 0\n"))
                .starts_with("6:7: contribution 'r': degrees of freedom must be > 0")
        );
        assert!(err(&format!("{HEAD}u = 1\ndof = -3\n")).starts_with("6:7: "));
        assert!(err(&format!("{HEAD}u = 1\ndof = \"lots\"\n")).starts_with("6:7: "));
        assert!(err(&format!("{HEAD}u = -0.1\n")).starts_with("5:5: contribution 'r': u must be"));
        assert!(
            err(&format!("coverage = 1.5\n{HEAD}u = 1\n"))
                .starts_with("1:12: coverage probability must be strictly between 0 and 1")
        );
        assert!(err(&format!("coverage = 0\n{HEAD}u = 1\n")).starts_with("1:12: "));
        // Unknown key (a typo) is caught by the TOML layer with its position.
        assert!(
            err(&format!("{HEAD}u = 1\nsensitivty = 2\n"))
                .starts_with("6:1: unknown field `sensitivty`")
        );
        // Nested budget that refers to itself, or to a missing one: the `from` line.
        let selfref =
            "[[budget]]\nname = \"a\"\n[[budget.contribution]]\nname = \"x\"\nfrom = \"a\"\n";
        assert_eq!(
            err(selfref),
            "5:8: budgets refer to themselves in a cycle: a -> a"
        );
        let missing = "[[budget]]\nname = \"a\"\n[[budget.contribution]]\nname = \"x\"\nu = 1\n[[budget.contribution]]\nname = \"y\"\nfrom = \"nope\"\n";
        assert_eq!(
            err(missing),
            "8:8: budget 'a': contribution 'y' refers to missing budget 'nope'"
        );
        let cycle = "[[budget]]\nname = \"a\"\n[[budget.contribution]]\nname = \"x\"\nfrom = \"b\"\n[[budget]]\nname = \"b\"\n[[budget.contribution]]\nname = \"y\"\nfrom = \"a\"\n";
        assert_eq!(
            err(cycle),
            "5:8: budgets refer to themselves in a cycle: a -> b -> a"
        );
        // Missing pieces.
        assert!(
            err(&format!("{HEAD}distribution = \"normal\"\nexpanded = 1\n")).contains("needs k")
        );
        assert!(err(&format!("{HEAD}dof = 3\n")).contains("expected one of u"));
        assert!(
            err(&format!("{HEAD}u = 1\nstep = 2\n"))
                .starts_with("6:8: contribution 'r': step is not used with u")
        );
        assert!(err("[[budget]]\nname = \"b\"\n").starts_with("1:1: budget 'b' has no rows"));
        assert!(err("").starts_with("1:1: no budget"));
        assert!(err("[[budget]\n").starts_with("1:"));
        assert!(
            err(&format!(
                "{HEAD}u = 1\n[[budget.correlation]]\nbetween = [\"r\", \"q\"]\nr = 0.5\n"
            ))
            .starts_with("7:11: budget 'b': correlation between 'r' and 'q': no contribution 'q'")
        );
    }
}
