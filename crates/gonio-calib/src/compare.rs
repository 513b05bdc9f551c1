//! Comparison of two calibrations of one encoder: differences and En numbers at common angles.
//!
//! Both inputs are "encoder error with zero mean over the circle" curves (a shift-angle result is
//! closed per shift, a self-calibration over the whole circle); they are compared as they are.
//! At every common angle (matched to [`ANGLE_TOL_DEG`], modulo 360°):
//!
//! ```text
//! d = x_A − x_B,      En = |d| / √(U_A² + U_B²)      (|En| ≤ 1 passes)
//! ```
//!
//! U is each point's expanded uncertainty when given, else 2·u (k = 2); the result says which.
//! Where both U are 0 (two results without uncertainty, or a self-calibration of identical
//! turns against a truth) En is undefined (`null`): it is not counted as passing, and the
//! comparison passes only when every common angle has an En ≤ 1.
//! Harmonics that either method cannot see are invisible to the comparison too: they are listed.
//!
//! ```
//! use gonio_calib::compare::{compare, Curve, CurvePoint};
//! let p = |angle_deg, value_arcsec| CurvePoint { angle_deg, value_arcsec, u_arcsec: 0.05, expanded_arcsec: None };
//! let a = Curve { label: "a".into(), points: vec![p(0.0, 0.1), p(15.0, -0.1)], undetectable_orders: vec![24] };
//! let b = Curve { label: "b".into(), points: vec![p(375.0, -0.2), p(7.0, 0.0)], undetectable_orders: vec![84] };
//! let c = compare(&a, &b).unwrap();
//! assert_eq!(c.points.len(), 1); // 15° ≡ 375°
//! assert!((c.points[0].difference_arcsec - 0.1).abs() < 1e-12);
//! assert!((c.max_en.unwrap() - 0.1 / 0.02f64.sqrt()).abs() < 1e-12); // U = 2·u = 0.1″ each
//! assert!(c.all_en_pass && c.en_undefined == 0);
//! ```

use crate::certificate::Certificate;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use thiserror::Error;

/// Angles closer than this (degrees, modulo 360°) are the same angle.
pub const ANGLE_TOL_DEG: f64 = 1e-6;

/// The comparison file's `format` value.
pub const COMPARE_FORMAT: &str = "gonio-compare-result";

/// An error from [`compare`].
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum CompareError {
    /// The two curves share no angle.
    #[error("no common angles (within {tol_deg}°) between {a} ({na} points) and {b} ({nb} points)")]
    NoCommonAngles {
        /// First curve's label.
        a: String,
        /// Second curve's label.
        b: String,
        /// Points in the first.
        na: usize,
        /// Points in the second.
        nb: usize,
        /// Matching tolerance.
        tol_deg: f64,
    },
    /// A value or uncertainty is not finite or an uncertainty is negative.
    #[error("{curve}, point {index} (angle {angle_deg}°): {what}")]
    BadPoint {
        /// Curve label.
        curve: String,
        /// 0-based index of the point.
        index: usize,
        /// Its angle.
        angle_deg: f64,
        /// What is wrong.
        what: String,
    },
}

/// One calibrated point.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CurvePoint {
    /// Angle, degrees (any real; compared modulo 360°).
    pub angle_deg: f64,
    /// Error value, arcsec.
    pub value_arcsec: f64,
    /// Standard uncertainty, arcsec.
    pub u_arcsec: f64,
    /// Expanded uncertainty, arcsec, if the result states one.
    pub expanded_arcsec: Option<f64>,
}

/// A calibration result reduced to what the comparison needs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Curve {
    /// The method or file name, for messages and output.
    pub label: String,
    /// The points.
    pub points: Vec<CurvePoint>,
    /// Harmonic orders the method cannot see.
    pub undetectable_orders: Vec<u32>,
}

impl From<&Certificate> for Curve {
    /// The calibrated angles of a certificate with their expanded uncertainties.
    fn from(c: &Certificate) -> Self {
        Curve {
            label: c.method_title(),
            points: c
                .points
                .iter()
                .map(|p| CurvePoint {
                    angle_deg: p.angle_deg,
                    value_arcsec: p.value_arcsec,
                    u_arcsec: p.u_arcsec,
                    expanded_arcsec: p.expanded_arcsec,
                })
                .collect(),
            undetectable_orders: c.undetectable_orders.clone(),
        }
    }
}

/// One common angle.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ComparePoint {
    /// The angle (first curve's), degrees in [0, 360).
    pub angle_deg: f64,
    /// First curve's value, arcsec.
    pub a_arcsec: f64,
    /// Second curve's value, arcsec.
    pub b_arcsec: f64,
    /// a − b, arcsec.
    pub difference_arcsec: f64,
    /// First curve's expanded uncertainty used, arcsec.
    #[serde(rename = "U_a_arcsec")]
    pub expanded_a_arcsec: f64,
    /// Second curve's expanded uncertainty used, arcsec.
    #[serde(rename = "U_b_arcsec")]
    pub expanded_b_arcsec: f64,
    /// |a − b| / √(U_a² + U_b²); absent when both U are 0.
    pub en: Option<f64>,
}

/// Where each curve's expanded uncertainty came from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UncertaintySource {
    /// First curve.
    pub a: String,
    /// Second curve.
    pub b: String,
}

/// The undetectable harmonics of each curve.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Undetectable {
    /// First curve.
    pub a: Vec<u32>,
    /// Second curve.
    pub b: Vec<u32>,
}

/// The comparison.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Comparison {
    /// Always [`COMPARE_FORMAT`].
    pub format: String,
    /// First curve's label.
    pub method_a: String,
    /// Second curve's label.
    pub method_b: String,
    /// Every common angle, sorted by angle.
    pub points: Vec<ComparePoint>,
    /// The largest |difference|, arcsec.
    pub max_abs_difference_arcsec: f64,
    /// Where it occurs, degrees.
    pub max_abs_difference_angle_deg: f64,
    /// Mean difference over the common angles, arcsec.
    pub mean_difference_arcsec: f64,
    /// RMS difference over the common angles, arcsec.
    pub rms_difference_arcsec: f64,
    /// The largest En (`None`, JSON `null`: no En is defined, every common angle has U_a = U_b
    /// = 0).
    pub max_en: Option<f64>,
    /// Where it occurs, degrees (`None`: no En is defined).
    pub max_en_angle_deg: Option<f64>,
    /// Whether every common angle has an En and every En is ≤ 1 (an undefined En does not
    /// pass).
    pub all_en_pass: bool,
    /// Common angles whose En is undefined (U_a = U_b = 0).
    #[serde(default)]
    pub en_undefined: usize,
    /// How U was obtained for each curve.
    pub uncertainty_source: UncertaintySource,
    /// Harmonics each method cannot see (the comparison is blind to their union).
    pub undetectable_harmonics: Undetectable,
    /// A one-line statement of the blind spots and the U convention.
    pub note: String,
}

fn source_of(c: &Curve) -> String {
    let n_u = c
        .points
        .iter()
        .filter(|p| p.expanded_arcsec.is_some())
        .count();
    if n_u == c.points.len() {
        "U_arcsec".into()
    } else if n_u == 0 {
        "k=2·u_arcsec (no U_arcsec in the input)".into()
    } else {
        "mixed: U_arcsec where given, else k=2·u_arcsec".into()
    }
}

fn check(c: &Curve) -> Result<(), CompareError> {
    for (i, p) in c.points.iter().enumerate() {
        let bad = |what: &str| {
            Err(CompareError::BadPoint {
                curve: c.label.clone(),
                index: i,
                angle_deg: p.angle_deg,
                what: what.into(),
            })
        };
        if !p.angle_deg.is_finite() || !p.value_arcsec.is_finite() {
            return bad("angle and value must be finite");
        }
        if !(p.u_arcsec >= 0.0 && p.u_arcsec.is_finite()) {
            return bad("u_arcsec must be finite and ≥ 0");
        }
        if let Some(x) = p.expanded_arcsec
            && !(x >= 0.0 && x.is_finite())
        {
            return bad("U_arcsec must be finite and ≥ 0");
        }
    }
    Ok(())
}

const KEY_SCALE: f64 = 1e6;
const KEY_TURN: i64 = 360_000_000;

fn key(angle_deg: f64) -> i64 {
    ((angle_deg.rem_euclid(360.0) * KEY_SCALE).round() as i64).rem_euclid(KEY_TURN)
}

fn circ_dist(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(360.0);
    d.min(360.0 - d)
}

/// Compares two calibrations at their common angles.
///
/// # Errors
/// [`CompareError::BadPoint`] for a non-finite value or a negative uncertainty,
/// [`CompareError::NoCommonAngles`] when no angle matches.
pub fn compare(a: &Curve, b: &Curve) -> Result<Comparison, CompareError> {
    check(a)?;
    check(b)?;
    let mut index: HashMap<i64, usize> = HashMap::with_capacity(b.points.len());
    for (j, p) in b.points.iter().enumerate() {
        index.entry(key(p.angle_deg)).or_insert(j);
    }
    let ua = |p: &CurvePoint| p.expanded_arcsec.unwrap_or(2.0 * p.u_arcsec);
    let mut points = Vec::new();
    for p in &a.points {
        let k = key(p.angle_deg);
        let found = [
            k,
            (k + 1).rem_euclid(KEY_TURN),
            (k - 1).rem_euclid(KEY_TURN),
        ]
        .iter()
        .filter_map(|kk| index.get(kk))
        .copied()
        .find(|&j| circ_dist(b.points[j].angle_deg, p.angle_deg) <= ANGLE_TOL_DEG);
        if let Some(j) = found {
            let q = &b.points[j];
            let d = p.value_arcsec - q.value_arcsec;
            let (xa, xb) = (ua(p), ua(q));
            let den = xa.hypot(xb);
            points.push(ComparePoint {
                angle_deg: p.angle_deg.rem_euclid(360.0),
                a_arcsec: p.value_arcsec,
                b_arcsec: q.value_arcsec,
                difference_arcsec: d,
                expanded_a_arcsec: xa,
                expanded_b_arcsec: xb,
                en: (den > 0.0)
                    .then(|| gonio_uncertainty::en(p.value_arcsec, xa, q.value_arcsec, xb)),
            });
        }
    }
    if points.is_empty() {
        return Err(CompareError::NoCommonAngles {
            a: a.label.clone(),
            b: b.label.clone(),
            na: a.points.len(),
            nb: b.points.len(),
            tol_deg: ANGLE_TOL_DEG,
        });
    }
    points.sort_by(|x, y| x.angle_deg.total_cmp(&y.angle_deg));
    let n = points.len() as f64;
    let (mut maxd, mut maxd_at) = (0.0f64, points[0].angle_deg);
    let mut max_en: Option<(f64, f64)> = None;
    for p in &points {
        if p.difference_arcsec.abs() > maxd {
            maxd = p.difference_arcsec.abs();
            maxd_at = p.angle_deg;
        }
        if let Some(e) = p.en
            && max_en.is_none_or(|(m, _)| e > m)
        {
            max_en = Some((e, p.angle_deg));
        }
    }
    let en_undefined = points.iter().filter(|p| p.en.is_none()).count();
    let mean = points.iter().map(|p| p.difference_arcsec).sum::<f64>() / n;
    let rms = (points
        .iter()
        .map(|p| p.difference_arcsec.powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    let fmt_orders = |v: &[u32]| -> String {
        if v.is_empty() {
            "none listed".into()
        } else if v.len() > 6 {
            format!("{:?}…", &v[..6])
        } else {
            format!("{v:?}")
        }
    };
    let note = format!(
        "the comparison cannot see harmonics {} ({}) or {} ({}); En uses U_arcsec when given, else k = 2·u; where both U are 0 En is undefined and does not pass",
        fmt_orders(&a.undetectable_orders),
        a.label,
        fmt_orders(&b.undetectable_orders),
        b.label
    );
    Ok(Comparison {
        format: COMPARE_FORMAT.to_string(),
        method_a: a.label.clone(),
        method_b: b.label.clone(),
        points,
        max_abs_difference_arcsec: maxd,
        max_abs_difference_angle_deg: maxd_at,
        mean_difference_arcsec: mean,
        rms_difference_arcsec: rms,
        max_en: max_en.map(|m| m.0),
        max_en_angle_deg: max_en.map(|m| m.1),
        all_en_pass: en_undefined == 0 && max_en.is_some_and(|m| m.0 <= 1.0),
        en_undefined,
        uncertainty_source: UncertaintySource {
            a: source_of(a),
            b: source_of(b),
        },
        undetectable_harmonics: Undetectable {
            a: a.undetectable_orders.clone(),
            b: b.undetectable_orders.clone(),
        },
        note,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pt(angle_deg: f64, value_arcsec: f64, u: f64, big_u: Option<f64>) -> CurvePoint {
        CurvePoint {
            angle_deg,
            value_arcsec,
            u_arcsec: u,
            expanded_arcsec: big_u,
        }
    }

    #[test]
    fn matches_modulo_360_and_within_tolerance() {
        let a = Curve {
            label: "a".into(),
            points: vec![
                pt(0.0, 0.3, 0.01, Some(0.15)),
                pt(1.0, 0.0, 0.01, Some(0.15)),
                pt(2.0, 0.0, 0.01, Some(0.15)),
            ],
            undetectable_orders: vec![24, 48],
        };
        let b = Curve {
            label: "b".into(),
            points: vec![
                pt(359.999_999_9, 0.1, 0.01, None),
                pt(1.000_000_5, 0.05, 0.01, None),
                pt(2.00001, 0.0, 0.01, None),
            ],
            undetectable_orders: vec![84],
        };
        let c = compare(&a, &b).unwrap();
        assert_eq!(c.points.len(), 2);
        assert!((c.points[0].difference_arcsec - 0.2).abs() < 1e-12);
        let en0 = 0.2 / (0.15f64.powi(2) + 0.02f64.powi(2)).sqrt();
        assert!((c.max_en.unwrap() - en0).abs() < 1e-12);
        assert_eq!(c.max_en_angle_deg, Some(0.0));
        assert!(c.uncertainty_source.b.starts_with("k=2"));
        assert_eq!(c.uncertainty_source.a, "U_arcsec");
        assert_eq!(c.undetectable_harmonics.b, vec![84]);
        assert!(c.note.contains("[84]"));
    }

    #[test]
    fn no_common_angles_and_bad_values() {
        let a = Curve {
            label: "a".into(),
            points: vec![pt(0.0, 0.0, 0.0, None)],
            undetectable_orders: vec![],
        };
        let mut b = a.clone();
        b.points[0].angle_deg = 0.5;
        assert!(matches!(
            compare(&a, &b),
            Err(CompareError::NoCommonAngles { .. })
        ));
        b.points[0] = pt(0.0, f64::NAN, 0.0, None);
        assert!(matches!(
            compare(&a, &b),
            Err(CompareError::BadPoint { .. })
        ));
        // Both uncertainties zero: En undefined, not infinite.
        let c = compare(&a, &a).unwrap();
        assert_eq!(c.points[0].en, None);
    }

    #[test]
    fn an_undefined_en_never_passes() {
        // Two results without uncertainty that differ by 0.13″: no En, no pass.
        let a = Curve {
            label: "a".into(),
            points: vec![pt(0.0, 0.13, 0.0, Some(0.0)), pt(90.0, 0.0, 0.0, Some(0.0))],
            undetectable_orders: vec![],
        };
        let mut b = a.clone();
        b.points[0].value_arcsec = 0.0;
        let c = compare(&a, &b).unwrap();
        assert_eq!(c.max_en, None);
        assert_eq!(c.max_en_angle_deg, None);
        assert_eq!(c.en_undefined, 2);
        assert!(!c.all_en_pass);
        // One angle with an uncertainty: its En is defined, the other still is not.
        b.points[1].expanded_arcsec = Some(0.1);
        let c = compare(&a, &b).unwrap();
        assert_eq!(c.max_en, Some(0.0));
        assert_eq!(c.en_undefined, 1);
        assert!(!c.all_en_pass);
        // Every En defined and ≤ 1: passes; one above 1: does not.
        b.points[0].expanded_arcsec = Some(0.2);
        let c = compare(&a, &b).unwrap();
        assert!(c.all_en_pass, "{c:?}");
        b.points[0].expanded_arcsec = Some(0.1);
        let c = compare(&a, &b).unwrap();
        assert!(!c.all_en_pass);
        assert!((c.max_en.unwrap() - 1.3).abs() < 1e-12);
    }
}
