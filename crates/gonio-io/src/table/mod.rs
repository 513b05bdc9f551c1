//! Results as text tables, written into a `String` the caller prints: numbers with a given
//! number of decimals or significant digits, an undefined number as an en dash (never `NaN`),
//! degrees of freedom (`inf`), names cut to a table's width; the GUM budget as a text,
//! Markdown or CSV table ([`budget`]).
//!
//! ```
//! use gonio_io::table::{fixed, sig, dof_text};
//! assert_eq!(fixed(2.345, 1), "2.3");
//! assert_eq!(fixed(None, 1), "–");
//! assert_eq!(sig(0.0123456, 3), "0.0123");
//! assert_eq!(dof_text(f64::INFINITY), "inf");
//! ```

pub mod budget;
pub mod mount;

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
