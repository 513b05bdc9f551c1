//! The checks a certificate passes when it is read: every value one of gonio's calibrations
//! can give, and metadata that any text format (JSON, XML, HTML) can carry.
//!
//! A hand-edited certificate with a negative U, a coverage probability of 1.2, no angles, an
//! angle of 1e300° or the same angle twice, or metadata holding a control character (SOH, ESC,
//! FF: not allowed in XML 1.0) or a temperature of NaN is refused with [`CertificateError::Invalid`]
//! naming the field (`encoder_errors[3].U_arcsec`, `meta.customer.name`), before anything is
//! computed or written from it.

use super::{Certificate, CertificateError, CertificateMeta};

fn invalid(field: impl Into<String>, what: impl Into<String>) -> CertificateError {
    CertificateError::Invalid {
        field: field.into(),
        what: what.into(),
    }
}

/// A text character that XML 1.0 cannot carry or that is a control character other than tab,
/// line feed and carriage return.
pub(crate) fn bad_char(c: char) -> bool {
    (c.is_control() && !matches!(c, '\t' | '\n' | '\r')) || matches!(c, '\u{FFFE}' | '\u{FFFF}')
}

/// Checks one text: no control character (other than tab, newline, carriage return).
///
/// # Errors
/// [`CertificateError::Invalid`] naming `field`, the character and its position.
pub fn check_text(field: &str, s: &str) -> Result<(), CertificateError> {
    match s.chars().enumerate().find(|&(_, c)| bad_char(c)) {
        Some((i, c)) => Err(invalid(
            field,
            format!(
                "control character U+{:04X} at character {}: not allowed in certificate text",
                c as u32,
                i + 1
            ),
        )),
        None => Ok(()),
    }
}

fn walk_texts(v: &serde_json::Value, path: &str) -> Result<(), CertificateError> {
    use serde_json::Value;
    match v {
        Value::String(s) => check_text(path, s),
        Value::Array(a) => a
            .iter()
            .enumerate()
            .try_for_each(|(i, x)| walk_texts(x, &format!("{path}[{i}]"))),
        Value::Object(m) => m.iter().try_for_each(|(k, x)| {
            check_text(&format!("{path} (a key)"), k)?;
            walk_texts(
                x,
                &if path.is_empty() {
                    k.to_string()
                } else {
                    format!("{path}.{k}")
                },
            )
        }),
        _ => Ok(()),
    }
}

/// A standard uncertainty: NaN (`null`, unknown) or a finite number ≥ 0.
fn standard_u(field: &str, u: f64) -> Result<(), CertificateError> {
    if u.is_infinite() || u < 0.0 {
        return Err(invalid(field, format!("{u}: expected a finite number ≥ 0")));
    }
    Ok(())
}

/// An expanded uncertainty U (≥ 0) and its coverage factor k (> 0), where given; `f` makes a
/// field's name.
fn expanded_and_k(
    f: &dyn Fn(&str) -> String,
    expanded: Option<f64>,
    k: Option<f64>,
) -> Result<(), CertificateError> {
    finite_in(
        &f("U_arcsec"),
        expanded,
        0.0,
        f64::MAX,
        "a finite number ≥ 0",
    )?;
    finite_in(
        &f("k"),
        k,
        f64::MIN_POSITIVE,
        f64::MAX,
        "a finite number > 0",
    )
}

fn finite_in(
    field: &str,
    v: Option<f64>,
    lo: f64,
    hi: f64,
    what: &str,
) -> Result<(), CertificateError> {
    match v {
        Some(x) if !(x.is_finite() && x >= lo && x <= hi) => {
            Err(invalid(field, format!("{x}: expected {what}")))
        }
        _ => Ok(()),
    }
}

impl CertificateMeta {
    /// Checks the metadata: no control characters in any text, environmental values finite and
    /// physical (temperature above −273.15 °C, humidity 0–100 %, tolerances ≥ 0).
    ///
    /// # Errors
    /// [`CertificateError::Invalid`] naming the field by its dotted name (`customer.name`).
    ///
    /// ```
    /// use gonio_calib::certificate::{CertificateMeta, Environment};
    /// let mut m = CertificateMeta { title: Some("Calibration\u{1} certificate".into()), ..Default::default() };
    /// assert!(m.validate().unwrap_err().to_string().starts_with("title: control character U+0001"));
    /// m.title = None;
    /// m.environment = Some(Environment { temperature_c: Some(f64::NAN), ..Default::default() });
    /// assert!(m.validate().unwrap_err().to_string().starts_with("environment.temperature_c: NaN"));
    /// ```
    pub fn validate(&self) -> Result<(), CertificateError> {
        if let Some(e) = &self.environment {
            finite_in(
                "environment.temperature_c",
                e.temperature_c,
                -273.15,
                1e4,
                "a temperature in °C, finite and above −273.15",
            )?;
            finite_in(
                "environment.temperature_tolerance_c",
                e.temperature_tolerance_c,
                0.0,
                1e4,
                "a finite number ≥ 0",
            )?;
            finite_in(
                "environment.humidity_percent",
                e.humidity_percent,
                0.0,
                100.0,
                "a relative humidity from 0 to 100 %",
            )?;
            finite_in(
                "environment.humidity_tolerance_percent",
                e.humidity_tolerance_percent,
                0.0,
                100.0,
                "a finite number from 0 to 100",
            )?;
        }
        // Every text, by its path (the metadata holds no number other than the environment's).
        let v = serde_json::to_value(self).map_err(|e| invalid("meta", e.to_string()))?;
        walk_texts(&v, "")
    }
}

impl Certificate {
    /// Checks a certificate read from a file: at least one angle; every angle finite, in
    /// [0°, 360°) and given once; every α finite; u, U ≥ 0 and finite (u may be unknown, `null`);
    /// k finite and > 0; ν_eff > 0; p and the summary's coverage strictly between 0 and 1; the
    /// compensation table finite; the metadata as [`CertificateMeta::validate`].
    ///
    /// Field names are the JSON's (`encoder_errors[3].U_arcsec`, `errors[0].p`, `meta.title`).
    ///
    /// # Errors
    /// [`CertificateError::Invalid`] naming the first field that fails.
    pub fn validate(&self) -> Result<(), CertificateError> {
        let key = self.procedure.points_key();
        if self.points.is_empty() {
            return Err(invalid(key, "no calibrated angle: expected at least one"));
        }
        let cov = self.uncertainty.coverage;
        if !(cov > 0.0 && cov < 1.0) {
            return Err(invalid(
                "uncertainty.coverage",
                format!("{cov}: expected a probability strictly between 0 and 1"),
            ));
        }
        let mut seen: Vec<(i64, usize)> = Vec::with_capacity(self.points.len());
        for (i, p) in self.points.iter().enumerate() {
            let f = |name: &str| format!("{key}[{i}].{name}");
            let a = p.angle_deg;
            if !(a.is_finite() && (0.0..360.0).contains(&a)) {
                return Err(invalid(
                    f("angle_deg"),
                    format!("{a}: expected an angle from 0 to 360° (360 excluded)"),
                ));
            }
            if !p.value_arcsec.is_finite() {
                return Err(invalid(f("value_arcsec"), "not a finite number"));
            }
            standard_u(&f("u_arcsec"), p.u_arcsec)?;
            standard_u(&f("u_random_arcsec"), p.u_random_arcsec)?;
            expanded_and_k(&f, p.expanded_arcsec, p.k)?;
            finite_in(
                &f("p"),
                p.p,
                f64::MIN_POSITIVE,
                1.0 - f64::EPSILON / 2.0,
                "a probability strictly between 0 and 1",
            )?;
            if let Some(nu) = p.nu_eff
                && (nu.is_nan() || nu <= 0.0)
            {
                return Err(invalid(
                    f("nu_eff"),
                    format!("{nu}: expected degrees of freedom > 0 (or \"inf\")"),
                ));
            }
            // Angles matched to 1e-6°, as `gonio compare` matches them.
            let k = ((a * 1e6).round() as i64).rem_euclid(360_000_000);
            if let Some(&(_, first)) = seen.iter().find(|(kk, _)| *kk == k) {
                return Err(invalid(
                    f("angle_deg"),
                    format!(
                        "{a}° is also {key}[{first}]: every calibrated angle must be given once"
                    ),
                ));
            }
            seen.push((k, i));
        }
        for (i, c) in self.compensation.iter().enumerate() {
            if !(c.angle_deg.is_finite() && (0.0..360.0).contains(&c.angle_deg)) {
                return Err(invalid(
                    format!("compensation[{i}].angle_deg"),
                    format!("{}: expected an angle from 0 to 360°", c.angle_deg),
                ));
            }
            if !c.correction_arcsec.is_finite() {
                return Err(invalid(
                    format!("compensation[{i}].correction_arcsec"),
                    "not a finite number",
                ));
            }
        }
        let pitch_key = if self.joint.is_some() {
            "joint.pitch_deviations"
        } else {
            "pitch_deviations"
        };
        for (i, b) in self
            .pitch_deviations()
            .unwrap_or_default()
            .iter()
            .enumerate()
        {
            let f = |name: &str| format!("{pitch_key}[{i}].{name}");
            if !b.value_arcsec.is_finite() {
                return Err(invalid(f("value_arcsec"), "not a finite number"));
            }
            standard_u(&f("u_arcsec"), b.u_arcsec)?;
            expanded_and_k(&f, b.expanded_arcsec, b.k)?;
        }
        let r = &self.residuals;
        for (name, v) in [
            ("residuals.rms_arcsec", r.rms_arcsec),
            ("residuals.max_abs_arcsec", r.max_abs_arcsec),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(invalid(name, format!("{v}: expected a finite number ≥ 0")));
            }
        }
        if let Some(m) = &self.meta {
            m.validate().map_err(|e| match e {
                CertificateError::Invalid { field, what } => invalid(format!("meta.{field}"), what),
                e => e,
            })?;
        }
        check_text("method", &self.method)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_characters_are_found_with_their_place() {
        assert!(check_text("x", "tab\there\nand\r").is_ok());
        assert!(check_text("x", "Grüße, 測定 ±0.1″").is_ok());
        for c in ['\u{1}', '\u{1b}', '\u{c}', '\u{7f}', '\u{85}', '\u{FFFF}'] {
            let e = check_text("customer.name", &format!("ab{c}")).unwrap_err();
            assert!(
                e.to_string().starts_with(&format!(
                    "customer.name: control character U+{:04X} at character 3",
                    c as u32
                )),
                "{e}"
            );
        }
    }
}
