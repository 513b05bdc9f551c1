//! Tables for the terminal, written into a `String` the caller prints: numbers with a given
//! number of significant digits, degrees of freedom, and GUM budget tables.

use gonio_uncertainty::BudgetResult;
use std::fmt::Write as _;

/// Longest row or budget name shown whole in a table; longer names are cut with `…` (the CSV and
/// JSON outputs keep every name whole).
pub const NAME_WIDTH: usize = 48;

/// A name as shown in a table: at most [`NAME_WIDTH`] characters, longer ones cut with `…`.
pub fn display_name(name: &str) -> String {
    if name.chars().count() <= NAME_WIDTH {
        name.to_string()
    } else {
        let mut s: String = name.chars().take(NAME_WIDTH - 1).collect();
        s.push('…');
        s
    }
}

/// ν for a table: a whole number, two decimals, or `inf`.
pub fn dof_text(nu: f64) -> String {
    if nu.is_infinite() {
        "inf".into()
    } else if nu.fract() == 0.0 {
        format!("{nu:.0}")
    } else {
        format!("{nu:.2}")
    }
}

/// What a table shows for a quantity that is not defined (`null` in JSON): an en dash.
pub const UNDEFINED: &str = "–";

/// A number with `decimals` decimals, or [`UNDEFINED`] when it is not defined (`None`, NaN):
/// `fixed(2.345, 1)` is `2.3`, `fixed(None, 1)` is `–`.
pub fn fixed(x: impl Into<Option<f64>>, decimals: usize) -> String {
    match x.into() {
        Some(v) if !v.is_nan() => format!("{v:.decimals$}"),
        _ => UNDEFINED.into(),
    }
}

/// A number with `sig` significant digits (plain notation for 1e-5 ≤ |x| < 1e6); NaN (not
/// defined) as [`UNDEFINED`].
pub fn sig(x: f64, digits: usize) -> String {
    if x == 0.0 {
        return "0".into();
    }
    if x.is_nan() {
        return UNDEFINED.into();
    }
    if !x.is_finite() {
        return format!("{x}");
    }
    let mag = x.abs().log10().floor() as i32;
    if (-5..6).contains(&mag) {
        let decimals = (digits as i32 - 1 - mag).max(0) as usize;
        format!("{x:.decimals$}")
    } else {
        format!("{x:.prec$e}", prec = digits - 1)
    }
}

/// The budget's unit with a leading space (empty without one).
pub fn unit(r: &BudgetResult) -> String {
    r.unit.as_deref().map_or(String::new(), |u| format!(" {u}"))
}

/// u_c, ν_eff, k, U and p on one line.
pub fn summary_line(r: &BudgetResult) -> String {
    format!(
        "u_c = {}{u}   nu_eff = {} (raw {:.2})   k = {:.3}   U = {}{u}   (p = {} %)",
        sig(r.u_c, 4),
        dof_text(r.nu_eff),
        r.nu_eff_raw,
        r.k,
        sig(r.expanded, 4),
        gonio_core::bound::Num(r.coverage * 100.0),
        u = unit(r),
    )
}

/// The budget as a text table (rows with shares, then the summary line); names longer than
/// [`NAME_WIDTH`] are cut.
pub fn text_table(out: &mut String, r: &BudgetResult) {
    let names: Vec<String> = r
        .contributions
        .iter()
        .map(|c| display_name(&c.name))
        .collect();
    let w = names
        .iter()
        .map(|n| n.chars().count())
        .max()
        .unwrap_or(12)
        .max(12);
    let _ = writeln!(
        out,
        "Budget \"{}\"{}",
        display_name(&r.name),
        unit(r).replace(' ', " in ")
    );
    let _ = writeln!(
        out,
        "  {:<w$}  {:>11}  {:>10}  {:>11}  {:>6}  {:>7}",
        "contribution", "u", "c", "|c·u|", "ν", "share"
    );
    for (c, name) in r.contributions.iter().zip(&names) {
        let _ = writeln!(
            out,
            "  {:<w$}  {:>11}  {:>10}  {:>11}  {:>6}  {:>6.1}%",
            name,
            sig(c.u, 4),
            sig(c.c, 4),
            sig(c.cu, 4),
            dof_text(c.nu),
            c.share * 100.0
        );
    }
    for (a, b, rho) in &r.correlations {
        let _ = writeln!(
            out,
            "  correlation r({}, {}) = {rho}",
            display_name(a),
            display_name(b)
        );
    }
    let _ = writeln!(out, "  {}\n", summary_line(r));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn undefined_is_a_dash_never_nan() {
        assert_eq!(fixed(2.345, 1), "2.3");
        assert_eq!(fixed(Some(-0.5), 2), "-0.50");
        assert_eq!(fixed(None, 1), UNDEFINED);
        assert_eq!(fixed(f64::NAN, 2), UNDEFINED);
        assert_eq!(sig(f64::NAN, 3), UNDEFINED);
        assert_eq!(sig(1.23456, 3), "1.23");
    }
}
