//! The administrative data of a calibration certificate (ISO/IEC 17025:2017 §7.8.2.1 and
//! §7.8.4.1): who calibrated what, for whom, when, how, under which conditions, traceable to
//! which standards, and who authorises it.
//!
//! Every field is optional here so that a calculation never stops for want of paperwork;
//! [`CertificateMeta::missing_fields`] names the required ones that are missing, and a
//! certificate with any missing is a draft. Dates are ISO 8601 (`YYYY-MM-DD`).

use super::Procedure;
use serde::{Deserialize, Serialize};

/// A laboratory or a customer.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Party {
    /// Name.
    pub name: Option<String>,
    /// Postal address (free text, lines separated by newlines).
    pub address: Option<String>,
    /// ISO 3166-1 alpha-2 country code, e.g. `DE`.
    pub country: Option<String>,
    /// E-mail address.
    pub email: Option<String>,
    /// Phone number.
    pub phone: Option<String>,
    /// Accreditation (laboratory), e.g. `DAkkS D-K-12345-01-00`.
    pub accreditation: Option<String>,
}

/// The item calibrated.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Item {
    /// Description, e.g. `rotary encoder, 36 000 lines, 12 read heads`.
    pub description: Option<String>,
    /// Manufacturer.
    pub manufacturer: Option<String>,
    /// Model or type.
    pub model: Option<String>,
    /// Unambiguous identification (serial number).
    pub identification: Option<String>,
    /// Condition on receipt.
    pub condition: Option<String>,
}

/// A calendar date, ISO 8601 `YYYY-MM-DD`. Reads a string, or a TOML date (any one-entry map
/// holding the date as a string, which is how TOML dates reach serde).
///
/// ```
/// use gonio_calib::certificate::Date;
/// assert_eq!(Date::parse("2025-03-10").unwrap().as_str(), "2025-03-10");
/// assert!(Date::parse("2025-02-30").is_err());
/// assert!(Date::parse("10.03.2025").is_err());
/// ```
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(transparent)]
pub struct Date(String);

impl Date {
    /// Validates `YYYY-MM-DD` (a real day of the Gregorian calendar).
    ///
    /// # Errors
    /// A message saying what was expected.
    pub fn parse(s: &str) -> Result<Date, String> {
        let bad = || format!("{s:?}: expected a date YYYY-MM-DD, e.g. 2025-03-10");
        let b = s.as_bytes();
        if b.len() != 10 || b[4] != b'-' || b[7] != b'-' {
            return Err(bad());
        }
        let num = |r: std::ops::Range<usize>| s.get(r).and_then(|t| t.parse::<u32>().ok());
        let (y, m, d) = match (num(0..4), num(5..7), num(8..10)) {
            (Some(y), Some(m), Some(d)) => (y, m, d),
            _ => return Err(bad()),
        };
        let leap = (y % 4 == 0 && y % 100 != 0) || y % 400 == 0;
        let days = match m {
            1 | 3 | 5 | 7 | 8 | 10 | 12 => 31,
            4 | 6 | 9 | 11 => 30,
            2 if leap => 29,
            2 => 28,
            _ => return Err(bad()),
        };
        if d == 0 || d > days || y == 0 {
            return Err(bad());
        }
        Ok(Date(s.to_string()))
    }

    /// The date as `YYYY-MM-DD`.
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl std::fmt::Display for Date {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl<'de> Deserialize<'de> for Date {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = Date;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("a date YYYY-MM-DD")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Date, E> {
                Date::parse(v).map_err(E::custom)
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, mut m: A) -> Result<Date, A::Error> {
                let Some((_, v)) = m.next_entry::<String, String>()? else {
                    return Err(serde::de::Error::custom("expected a date YYYY-MM-DD"));
                };
                Date::parse(&v).map_err(serde::de::Error::custom)
            }
        }
        d.deserialize_any(V)
    }
}

/// Dates.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibrationDates {
    /// Receipt of the item.
    pub receipt: Option<Date>,
    /// Calibration (its first day).
    pub calibration: Option<Date>,
    /// Last day of the calibration, if it took more than one.
    pub calibration_end: Option<Date>,
    /// Issue of the certificate.
    pub issue: Option<Date>,
}

/// The method as the laboratory documents it.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MethodMeta {
    /// The laboratory's procedure document, e.g. `LP-ANG-07 rev. 3`.
    pub procedure: Option<String>,
    /// A description; the report names the computed method itself.
    pub description: Option<String>,
}

/// Environmental conditions during the calibration.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Environment {
    /// Air temperature, °C.
    pub temperature_c: Option<f64>,
    /// Its variation or uncertainty (±), °C.
    pub temperature_tolerance_c: Option<f64>,
    /// Relative humidity, %.
    pub humidity_percent: Option<f64>,
    /// Its variation or uncertainty (±), %.
    pub humidity_tolerance_percent: Option<f64>,
}

/// A reference standard used (the polygon, the autocollimator, …) with its own certificate.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReferenceStandard {
    /// Its role: `polygon`, `autocollimator`, or another word.
    pub role: String,
    /// Description, e.g. `24-face optical polygon`.
    pub description: Option<String>,
    /// Manufacturer.
    pub manufacturer: Option<String>,
    /// Identification (serial number).
    pub identification: Option<String>,
    /// Number of its calibration certificate.
    pub certificate: Option<String>,
    /// Who issued that certificate.
    pub issued_by: Option<String>,
    /// Date of that calibration.
    pub calibrated: Option<Date>,
}

/// The person who authorises the certificate.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Authorisation {
    /// Name.
    pub name: Option<String>,
    /// Function, e.g. `head of the angle laboratory`.
    pub function: Option<String>,
}

/// The administrative data of a certificate (see the module docs).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CertificateMeta {
    /// Title, e.g. `Calibration certificate`.
    pub title: Option<String>,
    /// Unique certificate number.
    pub certificate_number: Option<String>,
    /// ISO 639-1 language of the certificate (default `en`).
    pub language: Option<String>,
    /// The calibration laboratory.
    pub laboratory: Option<Party>,
    /// Where the calibration was performed, when not at the laboratory's address.
    pub location: Option<String>,
    /// The customer.
    pub customer: Option<Party>,
    /// The item calibrated.
    pub item: Option<Item>,
    /// Dates.
    pub dates: Option<CalibrationDates>,
    /// The method.
    pub method: Option<MethodMeta>,
    /// Environmental conditions.
    pub environment: Option<Environment>,
    /// How the results are metrologically traceable.
    pub traceability: Option<String>,
    /// Reference standards used.
    #[serde(default)]
    pub reference_standards: Vec<ReferenceStandard>,
    /// Additions to, deviations from or exclusions from the method (`none` if there are none).
    pub deviations: Option<String>,
    /// Who authorises the certificate.
    pub authorisation: Option<Authorisation>,
    /// Further remarks printed on the certificate.
    pub remarks: Option<String>,
}

fn blank(s: &Option<String>) -> bool {
    s.as_deref().is_none_or(|t| t.trim().is_empty())
}

impl CertificateMeta {
    /// The reference standards a procedure needs, by role.
    pub fn required_standards(procedure: Procedure) -> &'static [&'static str] {
        match procedure {
            Procedure::ShiftAngle | Procedure::Joint => &["polygon", "autocollimator"],
            _ => &[],
        }
    }

    /// The reference standard with a role, if listed.
    pub fn standard(&self, role: &str) -> Option<&ReferenceStandard> {
        self.reference_standards
            .iter()
            .find(|s| s.role.eq_ignore_ascii_case(role))
    }

    /// The required fields that are missing or blank, by dotted name, in the order of
    /// ISO/IEC 17025 §7.8.2.1 and §7.8.4.1.
    ///
    /// ```
    /// use gonio_calib::certificate::{CertificateMeta, Procedure};
    /// let m = CertificateMeta { title: Some("Calibration certificate".into()), ..Default::default() };
    /// let missing = m.missing_fields(Procedure::ShiftAngle);
    /// assert!(!missing.contains(&"title".to_string()));
    /// assert!(missing.contains(&"customer.name".to_string()));
    /// assert!(missing.contains(&"reference_standards.polygon".to_string()));
    /// ```
    pub fn missing_fields(&self, procedure: Procedure) -> Vec<String> {
        let mut out: Vec<String> = Vec::new();
        let mut need = |ok: bool, name: &str| {
            if !ok {
                out.push(name.to_string());
            }
        };
        need(!blank(&self.title), "title");
        need(!blank(&self.certificate_number), "certificate_number");
        let lab = self.laboratory.clone().unwrap_or_default();
        need(!blank(&lab.name), "laboratory.name");
        need(!blank(&lab.address), "laboratory.address");
        let customer = self.customer.clone().unwrap_or_default();
        need(!blank(&customer.name), "customer.name");
        need(!blank(&customer.address), "customer.address");
        let item = self.item.clone().unwrap_or_default();
        need(!blank(&item.description), "item.description");
        need(!blank(&item.identification), "item.identification");
        need(!blank(&item.condition), "item.condition");
        let dates = self.dates.clone().unwrap_or_default();
        need(dates.receipt.is_some(), "dates.receipt");
        need(dates.calibration.is_some(), "dates.calibration");
        need(dates.issue.is_some(), "dates.issue");
        let method = self.method.clone().unwrap_or_default();
        need(!blank(&method.procedure), "method.procedure");
        let env = self.environment.clone().unwrap_or_default();
        need(env.temperature_c.is_some(), "environment.temperature_c");
        need(
            env.humidity_percent.is_some(),
            "environment.humidity_percent",
        );
        need(!blank(&self.traceability), "traceability");
        for role in Self::required_standards(procedure) {
            match self.standard(role) {
                None => need(false, &format!("reference_standards.{role}")),
                Some(s) => {
                    need(
                        !blank(&s.identification),
                        &format!("reference_standards.{role}.identification"),
                    );
                    need(
                        !blank(&s.certificate),
                        &format!("reference_standards.{role}.certificate"),
                    );
                }
            }
        }
        need(!blank(&self.deviations), "deviations");
        let auth = self.authorisation.clone().unwrap_or_default();
        need(!blank(&auth.name), "authorisation.name");
        need(!blank(&auth.function), "authorisation.function");
        out
    }
}
