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
use crate::limits::{MAX_BUDGETS, MAX_FILE_BYTES, MAX_MESSAGE_CHARS, MAX_OBSERVATIONS, MAX_ROWS};
use crate::{UncertaintyError, check_coverage, short};
use serde::Deserialize;
use std::collections::HashSet;
use std::ops::Range;
use toml::Spanned;

/// An error in a budget (or instrument) file, at a 1-based line and column. Display:
/// `LINE:COLUMN: message`; the caller prefixes the file name. The message is one line of at most
/// [`MAX_MESSAGE_CHARS`] characters, whatever the input.
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

impl BudgetFileError {
    /// An error at `line`:`column`; line breaks in the message become spaces and a message
    /// longer than [`MAX_MESSAGE_CHARS`] characters is cut (with `…`).
    pub fn new(line: usize, column: usize, message: impl Into<String>) -> BudgetFileError {
        let message = message.into();
        let mut m: String = message
            .chars()
            .take(MAX_MESSAGE_CHARS)
            .map(|c| if c.is_control() { ' ' } else { c })
            .collect();
        if message.chars().nth(MAX_MESSAGE_CHARS).is_some() {
            m.pop();
            m.push('…');
        }
        BudgetFileError {
            line,
            column,
            message: m,
        }
    }
}

pub(crate) use gonio_core::text::line_col;

/// Line and column of many byte offsets in one pass over the text (linear, whatever the number
/// of offsets or the length of the lines).
fn line_cols(text: &str, offsets: &[usize]) -> Vec<(usize, usize)> {
    let mut order: Vec<usize> = (0..offsets.len()).collect();
    order.sort_unstable_by_key(|&k| offsets[k]);
    let mut out = vec![(1, 1); offsets.len()];
    let (mut line, mut col) = (1usize, 1usize);
    let mut chars = text.char_indices().peekable();
    for k in order {
        let target = offsets[k].min(text.len());
        while let Some(&(i, c)) = chars.peek() {
            if i >= target {
                break;
            }
            if c == '\n' {
                line += 1;
                col = 1;
            } else {
                col += 1;
            }
            chars.next();
        }
        out[k] = (line, col);
    }
    out
}

pub(crate) fn err_at(
    text: &str,
    span: &Range<usize>,
    message: impl Into<String>,
) -> BudgetFileError {
    let (line, column) = line_col(text, span.start);
    BudgetFileError::new(line, column, message)
}

pub(crate) fn toml_error(text: &str, e: toml::de::Error) -> BudgetFileError {
    let (line, column) = e.span().map_or((1, 1), |s| line_col(text, s.start));
    BudgetFileError::new(line, column, e.message().trim().replace('\n', " "))
}

/// The text of a budget or instrument file from its bytes: at most [`MAX_FILE_BYTES`], UTF-8, a
/// leading byte-order mark skipped (line and column then count from after it).
///
/// # Errors
/// A file too large (at 1:1), a UTF-16 file (1:1), or invalid UTF-8 at the line and column of the
/// first bad byte.
///
/// ```
/// use gonio_uncertainty::decode_text;
/// assert_eq!(decode_text(b"\xEF\xBB\xBFcoverage = 0.95\n").unwrap(), "coverage = 0.95\n");
/// let e = decode_text(b"[[budget]]\nname = \"temp\xE9rature\"\n").unwrap_err();
/// assert_eq!((e.line, e.column), (2, 13));
/// assert!(e.message.starts_with("invalid UTF-8 (byte 0xE9)"));
/// ```
pub fn decode_text(bytes: &[u8]) -> Result<&str, BudgetFileError> {
    if bytes.len() > MAX_FILE_BYTES {
        return Err(BudgetFileError::new(
            1,
            1,
            format!(
                "the file is {} bytes, more than the limit of {MAX_FILE_BYTES} bytes (16 MiB) for a budget or instrument file",
                bytes.len()
            ),
        ));
    }
    gonio_core::text::decode_utf8(bytes)
        .map_err(|e| BudgetFileError::new(e.line, e.column, e.message))
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
    let sname = short(&name);
    let at =
        |s: Range<usize>, m: String| Err(err_at(text, &s, format!("contribution '{sname}': {m}")));
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
                        "contribution '{sname}': {field} is not used with {}",
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
            format!(
                "unknown distribution \"{}\": expected {DISTRIBUTIONS}",
                short(d)
            ),
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
        if obs.get_ref().len() > MAX_OBSERVATIONS {
            return at(
                obs.span(),
                format!(
                    "{} observations, more than the limit of {MAX_OBSERVATIONS}; give std_dev and n instead",
                    obs.get_ref().len()
                ),
            );
        }
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
                    format!("contribution '{sname}': distribution \"{d}\" needs {field}"),
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
                let (big_u, k) = (need("expanded", &c.expanded)?, need("k", &c.k)?);
                if big_u.is_finite() && k.is_finite() && k > 0.0 && !(big_u / k).is_finite() {
                    let ks = c.k.as_ref().map_or(ds.clone(), |x| x.span());
                    return at(
                        ks,
                        format!(
                            "u = expanded/k = {big_u:e}/{k:e} is not finite: the numbers overflow the floating-point range (about 1.8e308)"
                        ),
                    );
                }
                Contribution::normal(&name, big_u, k)
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
                    format!(
                        "degrees of freedom must be > 0 (or \"inf\"), found {}",
                        gonio_core::bound::Num(v)
                    ),
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
                    format!(
                        "relative_uncertainty must be ≥ 0 (0.10 means 10 %), found {}",
                        gonio_core::bound::Num(v)
                    ),
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
    s.strip_prefix(&format!("contribution '{}': ", short(name)))
        .map_or(s.clone(), str::to_string)
}

/// Parses a budget file into a [`BudgetSet`], checking everything that can be checked without
/// evaluating: fields, distributions, u ≥ 0, ν > 0, 0 < coverage < 1, unique names, nested
/// references (missing or cyclic), correlations, and the size limits of [`crate::limits`].
///
/// # Errors
/// [`BudgetFileError`] at the offending line and column, with what was expected.
pub fn parse_budget_file(text: &str) -> Result<BudgetSet, BudgetFileError> {
    BudgetFile::parse(text).map(|f| f.set)
}

/// As [`parse_budget_file`], from the file's bytes ([`decode_text`]: UTF-8, a byte-order mark
/// skipped).
///
/// # Errors
/// As [`decode_text`] and [`parse_budget_file`].
pub fn parse_budget_bytes(bytes: &[u8]) -> Result<BudgetSet, BudgetFileError> {
    BudgetFile::parse_bytes(bytes).map(|f| f.set)
}

/// A parsed budget file: the [`BudgetSet`] and where each budget, row and correlation is written,
/// so that errors found later (when evaluating, or in Monte Carlo) name the line and column too.
///
/// ```
/// use gonio_uncertainty::BudgetFile;
/// let text = "[[budget]]\nname = \"b\"\n[[budget.contribution]]\nname = \"a\"\nu = 1e308\n\
///             [[budget.contribution]]\nname = \"c\"\nu = 1e308\n";
/// let f = BudgetFile::parse(text).unwrap();
/// // Each row is fine; U = k·u_c overflows when they are combined.
/// let e = f.set.evaluate(None, None).unwrap_err();
/// assert_eq!(f.locate(&e), Some((2, 8)));
/// assert!(e.to_string().starts_with("budget 'b': U = k·u_c = 1.9600 × 1.414"));
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct BudgetFile {
    /// The budgets.
    pub set: BudgetSet,
    /// Line and column of each budget's name.
    budget_at: Vec<(usize, usize)>,
    /// Of each row: its `from` when it has one, else its name (or its table).
    row_at: Vec<Vec<(usize, usize)>>,
    /// Of each correlation.
    correlation_at: Vec<Vec<(usize, usize)>>,
}

impl BudgetFile {
    /// Parses a budget file (see [`parse_budget_file`]).
    ///
    /// # Errors
    /// [`BudgetFileError`] at the offending line and column, with what was expected.
    pub fn parse(text: &str) -> Result<BudgetFile, BudgetFileError> {
        if text.len() > MAX_FILE_BYTES {
            return Err(BudgetFileError::new(
                1,
                1,
                format!(
                    "the file is {} bytes, more than the limit of {MAX_FILE_BYTES} bytes (16 MiB)",
                    text.len()
                ),
            ));
        }
        parse(text)
    }

    /// Parses a budget file from its bytes ([`decode_text`], then [`parse`](Self::parse)).
    ///
    /// # Errors
    /// As [`decode_text`] and [`parse`](Self::parse).
    pub fn parse_bytes(bytes: &[u8]) -> Result<BudgetFile, BudgetFileError> {
        parse(decode_text(bytes)?)
    }

    /// The line and column an evaluation or Monte Carlo error refers to: the row (its `from`, or
    /// its name) for an error about one row, the correlation for a correlation, the budget's name
    /// for an error about a whole budget; `None` when the error is not about the file (e.g. the
    /// number of Monte Carlo trials asked for).
    pub fn locate(&self, e: &UncertaintyError) -> Option<(usize, usize)> {
        let budget = |name: &str| self.set.budgets.iter().position(|b| b.name == name);
        let row = |b: usize, name: &str| {
            let r = self.set.budgets[b]
                .contributions
                .iter()
                .position(|c| c.name == name)?;
            self.row_at.get(b)?.get(r).copied()
        };
        let correlation = |b: usize, x: &str, y: &str| {
            let k = self.set.budgets[b]
                .correlations
                .iter()
                .position(|c| (c.a == x && c.b == y) || (c.a == y && c.b == x))?;
            self.correlation_at.get(b)?.get(k).copied()
        };
        match e {
            UncertaintyError::MissingBudget {
                budget: b,
                contribution,
                ..
            } => row(budget(b)?, contribution),
            UncertaintyError::CyclicBudget { budgets, .. } => {
                let b = budget(budgets.first()?)?;
                let next = budgets.get(1)?;
                let r = self.set.budgets[b]
                    .contributions
                    .iter()
                    .position(|c| matches!(&c.source, Source::Budget { name } if name == next))?;
                self.row_at.get(b)?.get(r).copied()
            }
            UncertaintyError::BadCorrelation {
                budget: b, a, b: y, ..
            }
            | UncertaintyError::CorrelatedNestedBudget { budget: b, a, b: y } => {
                let i = budget(b)?;
                correlation(i, a, y).or_else(|| self.budget_at.get(i).copied())
            }
            UncertaintyError::NonFinite {
                budget: b,
                contribution,
                ..
            } => {
                let i = budget(b)?;
                contribution
                    .as_deref()
                    .and_then(|c| row(i, c))
                    .or_else(|| self.budget_at.get(i).copied())
            }
            UncertaintyError::TooLarge {
                budget: Some(b), ..
            } => self.budget_at.get(budget(b)?).copied(),
            _ => None,
        }
    }
}

fn parse(text: &str) -> Result<BudgetFile, BudgetFileError> {
    let raw: RawFile = toml::from_str(text).map_err(|e| toml_error(text, e))?;
    let coverage = match &raw.coverage {
        Some(c) => {
            check_coverage(*c.get_ref()).map_err(|e| err_at(text, &c.span(), e.to_string()))?
        }
        None => 0.95,
    };
    if raw.budget.is_empty() {
        return Err(BudgetFileError::new(
            1,
            1,
            "no budget: expected at least one [[budget]] table with [[budget.contribution]] rows",
        ));
    }
    if raw.budget.len() > MAX_BUDGETS {
        return Err(err_at(
            text,
            &raw.budget[MAX_BUDGETS].span(),
            format!(
                "{} budgets, more than the limit of {MAX_BUDGETS}",
                raw.budget.len()
            ),
        ));
    }
    let mut budgets = Vec::with_capacity(raw.budget.len());
    let mut names: HashSet<String> = HashSet::with_capacity(raw.budget.len());
    // Byte offsets of each budget's name, each row's `from` (or name, or table), each correlation.
    let mut budget_span = Vec::with_capacity(raw.budget.len());
    let mut row_spans: Vec<Vec<usize>> = Vec::with_capacity(raw.budget.len());
    let mut cor_spans: Vec<Vec<usize>> = Vec::with_capacity(raw.budget.len());
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
        if !names.insert(bname.clone()) {
            return Err(err_at(
                text,
                &name.span(),
                format!("duplicate budget name '{}'", short(&bname)),
            ));
        }
        let sname = short(&bname);
        if b.contribution.is_empty() {
            return Err(err_at(
                text,
                &rb.span(),
                format!("budget '{sname}' has no rows: expected [[budget.contribution]] tables"),
            ));
        }
        if b.contribution.len() > MAX_ROWS {
            return Err(err_at(
                text,
                &b.contribution[MAX_ROWS].span(),
                format!(
                    "budget '{sname}' has {} rows, more than the limit of {MAX_ROWS}",
                    b.contribution.len()
                ),
            ));
        }
        let mut budget = Budget::new(&bname);
        budget.unit = b.unit.clone();
        let mut rows: HashSet<String> = HashSet::with_capacity(b.contribution.len());
        let mut spans = Vec::with_capacity(b.contribution.len());
        for rc in &b.contribution {
            let c = build_contribution(text, rc, None)?;
            let r = rc.get_ref();
            if !rows.insert(c.name.clone()) {
                let s = r.name.as_ref().map_or(rc.span(), |n| n.span());
                return Err(err_at(
                    text,
                    &s,
                    format!(
                        "duplicate contribution name '{}' in budget '{sname}'",
                        short(&c.name)
                    ),
                ));
            }
            spans.push(
                r.from
                    .as_ref()
                    .map(|f| f.span())
                    .or_else(|| r.name.as_ref().map(|n| n.span()))
                    .unwrap_or(rc.span())
                    .start,
            );
            budget.contributions.push(c);
        }
        for rcor in &b.correlation {
            let cor = rcor.get_ref();
            let pair = cor.between.get_ref();
            if pair.len() != 2 {
                return Err(err_at(
                    text,
                    &cor.between.span(),
                    format!(
                        "between must name exactly 2 contributions, found {}",
                        pair.len()
                    ),
                ));
            }
            budget.correlations.push(Correlation {
                a: pair[0].clone(),
                b: pair[1].clone(),
                r: *cor.r.get_ref(),
            });
        }
        // Names, |r| ≤ 1, pairs given twice, then the matrix as a whole (at the first
        // correlation), in one pass: linear in the rows and correlations.
        if let Err((k, e)) = budget.resolve_correlations() {
            let s = match k.and_then(|k| b.correlation.get(k)) {
                Some(c) if matches!(&e, UncertaintyError::BadCorrelation { what, .. } if what.starts_with("r ")) => {
                    c.get_ref().r.span()
                }
                Some(c) => c.get_ref().between.span(),
                None => b.correlation.first().map_or(rb.span(), |c| c.span()),
            };
            return Err(err_at(text, &s, e.to_string()));
        }
        budget_span.push(name.span().start);
        row_spans.push(spans);
        cor_spans.push(b.correlation.iter().map(|c| c.span().start).collect());
        budgets.push(budget);
    }
    let set = BudgetSet { coverage, budgets };
    // Every offset to a line and column, in one pass over the text.
    let mut offsets = budget_span.clone();
    offsets.extend(row_spans.iter().flatten());
    offsets.extend(cor_spans.iter().flatten());
    let mut at = line_cols(text, &offsets).into_iter();
    let budget_at: Vec<(usize, usize)> = at.by_ref().take(budget_span.len()).collect();
    let row_at: Vec<Vec<(usize, usize)>> = row_spans
        .iter()
        .map(|v| at.by_ref().take(v.len()).collect())
        .collect();
    let correlation_at: Vec<Vec<(usize, usize)>> = cor_spans
        .iter()
        .map(|v| at.by_ref().take(v.len()).collect())
        .collect();
    let file = BudgetFile {
        set,
        budget_at,
        row_at,
        correlation_at,
    };
    // References: the `from` of the offending contribution.
    if let Err(e) = file.set.check_references() {
        let (line, column) = file.locate(&e).unwrap_or((1, 1));
        return Err(BudgetFileError::new(line, column, e.to_string()));
    }
    Ok(file)
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
