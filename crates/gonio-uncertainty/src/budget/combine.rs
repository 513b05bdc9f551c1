//! Combining terms: u_c, Welch–Satterthwaite ν_eff, k and U (JCGM 100 §5, §6, Annex G); the GUM
//! for a caller's measurement function; the normalised error En.

use crate::student::coverage_factor;
use crate::{UncertaintyError, check_coverage};
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::Contribution;

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
/// The correlation sum runs over the listed pairs only (a sparse combination): the work is
/// linear in the number of terms plus the number of correlations.
///
/// # Errors
/// [`UncertaintyError::BadCoverage`] for p outside (0, 1);
/// [`UncertaintyError::NotPositiveDefinite`] when correlations make u_c² negative;
/// [`UncertaintyError::BadParameter`] for a correlation index out of range;
/// [`UncertaintyError::NonFinite`] when c·u, u_c, k or U overflows (it names the quantity).
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
    let overflow = |quantity: String| UncertaintyError::NonFinite {
        budget: String::new(),
        contribution: None,
        quantity,
    };
    for (i, t) in terms.iter().enumerate() {
        if !(t.c * t.u).is_finite() {
            return Err(overflow(format!(
                "|c·u| of term {i} = |{:e} × {:e}|",
                t.c, t.u
            )));
        }
    }
    if let Some(&(i, j, _)) = correlations
        .iter()
        .find(|&&(i, j, _)| i >= terms.len() || j >= terms.len())
    {
        return Err(UncertaintyError::BadParameter {
            name: "combination".into(),
            what: format!(
                "correlation ({i}, {j}) refers to a term beyond the {} given",
                terms.len()
            ),
        });
    }
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
    if !u_c.is_finite() {
        return Err(overflow(format!(
            "u_c = √Σ(c·u)² = {s:e} × {}",
            var.max(0.0).sqrt()
        )));
    }
    finish(terms, u_c, coverage)
}

/// ν_eff (Welch–Satterthwaite over the terms), k and U for a combined standard uncertainty u_c
/// computed by the caller.
pub(crate) fn finish(
    terms: &[Term],
    u_c: f64,
    coverage: f64,
) -> Result<Combined, UncertaintyError> {
    let overflow = |quantity: String| UncertaintyError::NonFinite {
        budget: String::new(),
        contribution: None,
        quantity,
    };
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
    if !k.is_finite() {
        return Err(overflow(format!(
            "the coverage factor k = t_p(ν_eff) for p = {coverage} and ν_eff = {nu_eff:e}"
        )));
    }
    if !(k * u_c).is_finite() {
        return Err(overflow(format!("U = k·u_c = {k:.4} × {u_c:e}")));
    }
    Ok(Combined {
        u_c,
        nu_eff,
        nu_eff_raw,
        coverage,
        k,
        expanded: k * u_c,
    })
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
