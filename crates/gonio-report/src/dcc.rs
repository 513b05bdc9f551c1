//! The Digital Calibration Certificate (DCC v3.1.2 of PTB, namespace `https://ptb.de/dcc`, with
//! D-SI 2.1.0 quantities, namespace `https://ptb.de/si`) of a calibration certificate.
//!
//! - `administrativeData` from the certificate's ISO/IEC 17025 metadata: software, core data
//!   (certificate number, dates, languages, country), the item, the laboratory, the authorising
//!   person, the customer, and the statements (traceability, deviations, uncertainty, invisible
//!   harmonics).
//! - `measurementResults`: the method (with its paper), the reference standards, the
//!   environmental conditions, and one result per quantity: every calibrated angle as a `dcc:list`
//!   of the angle θ (`si:real`, unit `\degree`) and the encoder error α (`si:real`, unit
//!   `\arcsecond`, with `si:expandedUnc`: U, k and p); for the shift-angle method also the
//!   polygon's pitch deviations β per face.
//!
//! Units are D-SI's: angles of the table in `\degree`, encoder errors and uncertainties in
//! `\arcsecond` (the D-SI form of the arcsecond, 1″ = π/648 000 rad), temperature in
//! `\degreecelsius`, humidity in `\percent`. The output validates against
//! `schemas/dcc/dcc-3.1.2.xsd` (a test runs `xmllint --schema`).

use crate::ReportError;
use gonio_calib::certificate::{Certificate, CertificateMeta, Procedure};
use quick_xml::Writer;
use quick_xml::events::{BytesDecl, BytesEnd, BytesStart, BytesText, Event};
use std::io;

/// The DCC schema version written.
pub const DCC_VERSION: &str = "3.1.2";

struct X {
    w: Writer<Vec<u8>>,
    lang: String,
}

impl X {
    fn open(&mut self, name: &str) -> io::Result<()> {
        self.w.write_event(Event::Start(BytesStart::new(name)))
    }

    fn open_with(&mut self, name: &str, attrs: &[(&str, &str)]) -> io::Result<()> {
        let mut s = BytesStart::new(name);
        for a in attrs {
            s.push_attribute(*a);
        }
        self.w.write_event(Event::Start(s))
    }

    fn close(&mut self, name: &str) -> io::Result<()> {
        self.w.write_event(Event::End(BytesEnd::new(name)))
    }

    fn leaf(&mut self, name: &str, text: &str) -> io::Result<()> {
        self.w
            .create_element(name)
            .write_text_content(BytesText::new(text))?;
        Ok(())
    }

    /// A `dcc:textType` element: one `dcc:content` in the certificate's language.
    fn text(&mut self, name: &str, text: &str) -> io::Result<()> {
        self.open(name)?;
        let lang = self.lang.clone();
        self.w
            .create_element("dcc:content")
            .with_attribute(("lang", lang.as_str()))
            .write_text_content(BytesText::new(text))?;
        self.close(name)
    }

    /// An `si:real` with an optional expanded uncertainty (U, k, p).
    fn real(
        &mut self,
        label: Option<&str>,
        value: &str,
        unit: &str,
        unc: Option<(f64, f64, f64)>,
    ) -> io::Result<()> {
        self.open("si:real")?;
        if let Some(l) = label {
            self.leaf("si:label", l)?;
        }
        self.leaf("si:value", value)?;
        self.leaf("si:unit", unit)?;
        if let Some((u, k, p)) = unc {
            self.open("si:expandedUnc")?;
            self.leaf("si:uncertainty", &num(u, 6)?)?;
            self.leaf("si:coverageFactor", &format!("{k:.3}"))?;
            self.leaf("si:coverageProbability", &format!("{p:.4}"))?;
            self.close("si:expandedUnc")?;
        }
        self.close("si:real")
    }

    fn quantity(
        &mut self,
        name: &str,
        label: Option<&str>,
        value: &str,
        unit: &str,
        unc: Option<(f64, f64, f64)>,
    ) -> io::Result<()> {
        self.open("dcc:quantity")?;
        self.text("dcc:name", name)?;
        self.real(label, value, unit, unc)?;
        self.close("dcc:quantity")
    }

    fn location(&mut self, address: &str, country: Option<&str>) -> io::Result<()> {
        self.open("dcc:location")?;
        if let Some(c) = country.filter(|c| valid_country(c)) {
            self.leaf("dcc:countryCode", c)?;
        }
        self.open("dcc:further")?;
        let lang = self.lang.clone();
        self.w
            .create_element("dcc:content")
            .with_attribute(("lang", lang.as_str()))
            .write_text_content(BytesText::new(address))?;
        self.close("dcc:further")?;
        self.close("dcc:location")
    }
}

/// A decimal number with `d` decimals (the D-SI decimal pattern); a number that is not finite
/// is an error, never a made-up value.
fn num(v: f64, d: usize) -> io::Result<String> {
    if !v.is_finite() {
        return Err(io::Error::other(format!(
            "{v} is not a number a DCC can state"
        )));
    }
    let s = format!("{v:.d$}");
    Ok(
        if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
            s[1..].to_string()
        } else {
            s
        },
    )
}

/// An expanded uncertainty as the D-SI states one: U ≥ 0, k ≥ 1 (`si:kValueType`) and p in
/// (0, 1), all finite; `what` names the quantity in the error.
fn expanded(what: &str, u: f64, k: f64, p: f64) -> io::Result<(f64, f64, f64)> {
    if !(u.is_finite() && u >= 0.0) {
        return Err(io::Error::other(format!(
            "{what}: U = {u}: expected a finite number ≥ 0"
        )));
    }
    if !(k.is_finite() && k >= 1.0) {
        return Err(io::Error::other(format!(
            "{what}: coverage factor k = {k}: a DCC states k ≥ 1 (a coverage probability of about 0.69 or more)"
        )));
    }
    if !(p > 0.0 && p < 1.0) {
        return Err(io::Error::other(format!(
            "{what}: coverage probability p = {p}: expected a value strictly between 0 and 1"
        )));
    }
    Ok((u, k, p))
}

/// The first character XML 1.0 cannot carry (or a control character other than tab, newline
/// and carriage return), with its byte offset.
fn bad_xml_char(s: &str) -> Option<(usize, char)> {
    s.char_indices().find(|&(_, c)| {
        (c.is_control() && !matches!(c, '\t' | '\n' | '\r')) || matches!(c, '\u{FFFE}' | '\u{FFFF}')
    })
}

fn valid_country(c: &str) -> bool {
    c.len() == 2 && c.chars().all(|x| x.is_ascii_uppercase())
}

fn valid_lang(c: &str) -> bool {
    c.len() == 2 && c.chars().all(|x| x.is_ascii_lowercase())
}

fn xml_err(e: io::Error) -> ReportError {
    ReportError::Xml {
        message: e.to_string(),
    }
}

/// Writes the DCC of `cert` with its metadata.
///
/// A certificate whose required metadata is missing ([`Certificate::missing_meta`]) is refused
/// with [`ReportError::MissingMeta`] unless `draft` is set; a draft fills each missing text with
/// `not given (DRAFT)`, each missing date with 0001-01-01, and says DRAFT in its statements.
///
/// Every number is finite and every text is XML 1.0 text, or nothing is written: a value a DCC
/// cannot state (NaN, an expanded uncertainty with k < 1, U < 0, p outside (0, 1)) or a text
/// with a control character is a [`ReportError::Xml`] naming it (certificates read from files
/// are checked before, [`Certificate::validate`]).
///
/// # Errors
/// [`ReportError::MissingMeta`], or [`ReportError::Xml`] for a value or text a DCC cannot carry.
///
/// ```
/// # use gonio_calib::certificate::{Certificate, Instrument};
/// # use gonio_calib::shift_angle::{calibrate, Options, Reading, ReadingSet};
/// # let mut r = Vec::new();
/// # for j in 1..=3usize { for i in 1..=3usize { for (k, e) in [(1u32, 0.01), (2, -0.01)] {
/// #     r.push(Reading { repeat: k, ..Reading::new(0.0, j, i, 0.1 * i as f64 + e) }); } } }
/// # let set = ReadingSet::new(3, r).unwrap();
/// # let cal = calibrate(&set, &Options::default()).unwrap();
/// let cert = Certificate::from_shift_angle(&cal, &set, false, 1, &Instrument::default()).unwrap();
/// assert!(gonio_report::dcc::write(&cert, false).is_err()); // no metadata: not issued
/// let xml = gonio_report::dcc::write(&cert, true).unwrap();
/// assert!(xml.contains("<si:unit>\\arcsecond</si:unit>") && xml.contains("DRAFT"));
/// ```
pub fn write(cert: &Certificate, draft: bool) -> Result<String, ReportError> {
    let missing = cert.missing_meta();
    if !missing.is_empty() && !draft {
        return Err(ReportError::MissingMeta { missing });
    }
    let meta = cert.meta.clone().unwrap_or_default();
    let lang = meta
        .language
        .clone()
        .filter(|l| valid_lang(l))
        .unwrap_or_else(|| "en".into());
    let mut x = X {
        w: Writer::new_with_indent(Vec::new(), b' ', 2),
        lang,
    };
    body(&mut x, cert, &meta, &missing).map_err(xml_err)?;
    let xml = String::from_utf8(x.w.into_inner()).map_err(|e| ReportError::Xml {
        message: e.to_string(),
    })?;
    if let Some((at, c)) = bad_xml_char(&xml) {
        let line = xml[..at].lines().count();
        let context: String = xml[..at]
            .rsplit('<')
            .next()
            .unwrap_or_default()
            .chars()
            .take(40)
            .collect();
        return Err(ReportError::Xml {
            message: format!(
                "control character U+{:04X} in the text of <{context}… (line {line}): not allowed in XML 1.0",
                c as u32
            ),
        });
    }
    Ok(xml)
}

const GIVEN: &str = "not given (DRAFT)";

fn body(x: &mut X, cert: &Certificate, m: &CertificateMeta, missing: &[String]) -> io::Result<()> {
    let g = |s: &Option<String>| {
        s.clone()
            .filter(|t| !t.trim().is_empty())
            .unwrap_or_else(|| GIVEN.into())
    };
    x.w.write_event(Event::Decl(BytesDecl::new("1.0", Some("UTF-8"), None)))?;
    x.open_with(
        "dcc:digitalCalibrationCertificate",
        &[
            ("xmlns:dcc", "https://ptb.de/dcc"),
            ("xmlns:si", "https://ptb.de/si"),
            ("schemaVersion", DCC_VERSION),
        ],
    )?;
    x.open("dcc:administrativeData")?;
    // Software.
    x.open("dcc:dccSoftware")?;
    x.open("dcc:software")?;
    x.text("dcc:name", &cert.software.name)?;
    x.leaf("dcc:release", &cert.software.version)?;
    x.leaf("dcc:type", "application")?;
    x.close("dcc:software")?;
    x.close("dcc:dccSoftware")?;
    // Core data.
    let lab = m.laboratory.clone().unwrap_or_default();
    let customer = m.customer.clone().unwrap_or_default();
    let dates = m.dates.clone().unwrap_or_default();
    let date = |d: &Option<gonio_calib::certificate::Date>| {
        d.as_ref()
            .map_or("0001-01-01".to_string(), |d| d.as_str().to_string())
    };
    x.open("dcc:coreData")?;
    let country = lab
        .country
        .clone()
        .filter(|c| valid_country(c))
        .unwrap_or_else(|| "ZZ".into());
    x.leaf("dcc:countryCodeISO3166_1", &country)?;
    let lang = x.lang.clone();
    x.leaf("dcc:usedLangCodeISO639_1", &lang)?;
    x.leaf("dcc:mandatoryLangCodeISO639_1", &lang)?;
    let number = g(&m.certificate_number);
    x.leaf(
        "dcc:uniqueIdentifier",
        &if missing.is_empty() {
            number
        } else {
            format!("DRAFT {number}")
        },
    )?;
    if let Some(r) = &dates.receipt {
        x.leaf("dcc:receiptDate", r.as_str())?;
    }
    x.leaf("dcc:beginPerformanceDate", &date(&dates.calibration))?;
    x.leaf(
        "dcc:endPerformanceDate",
        &date(
            dates
                .calibration_end
                .as_ref()
                .map_or(&dates.calibration, |_| &dates.calibration_end),
        ),
    )?;
    x.leaf(
        "dcc:performanceLocation",
        if m.location.is_some() {
            "other"
        } else {
            "laboratory"
        },
    )?;
    x.close("dcc:coreData")?;
    // The item.
    let item = m.item.clone().unwrap_or_default();
    x.open("dcc:items")?;
    x.open("dcc:item")?;
    x.text("dcc:name", &g(&item.description))?;
    if let Some(c) = &item.condition {
        x.open("dcc:description")?;
        x.text("dcc:name", "condition on receipt")?;
        x.w.create_element("dcc:content")
            .with_attribute(("lang", lang.as_str()))
            .write_text_content(BytesText::new(c))?;
        x.close("dcc:description")?;
    }
    x.open("dcc:manufacturer")?;
    x.text("dcc:name", &g(&item.manufacturer))?;
    x.close("dcc:manufacturer")?;
    if let Some(model) = &item.model {
        x.leaf("dcc:model", model)?;
    }
    x.open("dcc:identifications")?;
    x.open("dcc:identification")?;
    x.leaf("dcc:issuer", "manufacturer")?;
    x.leaf("dcc:value", &g(&item.identification))?;
    x.text("dcc:name", "serial number")?;
    x.close("dcc:identification")?;
    x.close("dcc:identifications")?;
    x.close("dcc:item")?;
    x.close("dcc:items")?;
    // Laboratory.
    x.open("dcc:calibrationLaboratory")?;
    if let Some(a) = &lab.accreditation {
        x.leaf("dcc:calibrationLaboratoryCode", a)?;
    }
    contact(x, &lab, &g)?;
    x.close("dcc:calibrationLaboratory")?;
    // Authorising person.
    let auth = m.authorisation.clone().unwrap_or_default();
    x.open("dcc:respPersons")?;
    x.open("dcc:respPerson")?;
    x.open("dcc:person")?;
    x.text("dcc:name", &g(&auth.name))?;
    x.close("dcc:person")?;
    x.leaf("dcc:role", &g(&auth.function))?;
    x.leaf("dcc:mainSigner", "true")?;
    x.close("dcc:respPerson")?;
    x.close("dcc:respPersons")?;
    // Customer.
    x.open("dcc:customer")?;
    contact_body(x, &customer, &g)?;
    x.close("dcc:customer")?;
    // Statements.
    x.open("dcc:statements")?;
    let statement = |x: &mut X, name: &str, text: &str, traceable: bool| -> io::Result<()> {
        x.open("dcc:statement")?;
        if traceable {
            x.leaf("dcc:traceable", "true")?;
        }
        x.open("dcc:declaration")?;
        x.text("dcc:name", name)?;
        let lang = x.lang.clone();
        x.w.create_element("dcc:content")
            .with_attribute(("lang", lang.as_str()))
            .write_text_content(BytesText::new(text))?;
        x.close("dcc:declaration")?;
        x.close("dcc:statement")
    };
    if !missing.is_empty() {
        statement(
            x,
            "DRAFT",
            &format!(
                "DRAFT, not a valid calibration certificate: required fields missing: {}",
                missing.join(", ")
            ),
            false,
        )?;
    }
    statement(x, "traceability", &g(&m.traceability), true)?;
    statement(x, "deviations from the method", &g(&m.deviations), false)?;
    statement(
        x,
        "measurement uncertainty",
        &format!(
            "The expanded uncertainty U is the combined standard uncertainty multiplied by the coverage factor k = t_p(ν_eff) of Student's distribution, for a coverage probability of about {} % (JCGM 100:2008). Encoder errors and uncertainties are in arcseconds.",
            cert.uncertainty.coverage * 100.0
        ),
        false,
    )?;
    for inv in cert
        .spectrum
        .invisible
        .iter()
        .filter(|i| !i.orders.is_empty())
    {
        let k: Vec<String> = inv.orders.iter().map(|k| k.to_string()).collect();
        statement(
            x,
            "harmonics the method cannot see",
            &format!(
                "The {} cannot see harmonics of the encoder error of order {}: they are absent from the result.",
                inv.by,
                k.join(", ")
            ),
            false,
        )?;
    }
    statement(
        x,
        "scope",
        "The results relate only to the item calibrated.",
        false,
    )?;
    x.close("dcc:statements")?;
    x.close("dcc:administrativeData")?;

    // Measurement results.
    x.open("dcc:measurementResults")?;
    x.open("dcc:measurementResult")?;
    x.text("dcc:name", "Angle error of the rotary encoder")?;
    x.open("dcc:usedMethods")?;
    x.open("dcc:usedMethod")?;
    x.text("dcc:name", &cert.method_title())?;
    if let Some(p) = m.method.as_ref().and_then(|mm| mm.procedure.as_ref()) {
        x.open("dcc:description")?;
        x.w.create_element("dcc:content")
            .with_attribute(("lang", lang.as_str()))
            .write_text_content(BytesText::new(&format!("laboratory procedure: {p}")))?;
        x.close("dcc:description")?;
    }
    x.leaf("dcc:norm", "JCGM 100:2008 (GUM)")?;
    x.leaf(
        "dcc:reference",
        match cert.procedure {
            Procedure::ShiftAngle | Procedure::SelfCalibration | Procedure::Joint => {
                "Hsieh, Watanabe, Hsu, Calibration of Rotary Encoders Using a Shift-Angle Method, Appl. Sci. 2022, 12(10), 5008"
            }
            _ => "gonio",
        },
    )?;
    x.close("dcc:usedMethod")?;
    x.close("dcc:usedMethods")?;
    if !m.reference_standards.is_empty() {
        x.open("dcc:measuringEquipments")?;
        for s in &m.reference_standards {
            x.open("dcc:measuringEquipment")?;
            x.text("dcc:name", &format!("{}: {}", s.role, g(&s.description)))?;
            if let Some(mf) = &s.manufacturer {
                x.open("dcc:manufacturer")?;
                x.text("dcc:name", mf)?;
                x.close("dcc:manufacturer")?;
            }
            x.open("dcc:identifications")?;
            x.open("dcc:identification")?;
            x.leaf("dcc:issuer", "manufacturer")?;
            x.leaf("dcc:value", &g(&s.identification))?;
            x.text("dcc:name", "serial number")?;
            x.close("dcc:identification")?;
            x.open("dcc:identification")?;
            x.leaf("dcc:issuer", "other")?;
            x.leaf("dcc:value", &g(&s.certificate))?;
            x.text(
                "dcc:name",
                &format!(
                    "calibration certificate{}{}",
                    s.issued_by
                        .as_deref()
                        .map_or(String::new(), |i| format!(" issued by {i}")),
                    s.calibrated
                        .as_ref()
                        .map_or(String::new(), |d| format!(" on {d}"))
                ),
            )?;
            x.close("dcc:identification")?;
            x.close("dcc:identifications")?;
            x.close("dcc:measuringEquipment")?;
        }
        x.close("dcc:measuringEquipments")?;
    }
    if let Some(env) = &m.environment {
        let conds = [
            (
                "air temperature",
                env.temperature_c,
                env.temperature_tolerance_c,
                "\\degreecelsius",
            ),
            (
                "relative humidity",
                env.humidity_percent,
                env.humidity_tolerance_percent,
                "\\percent",
            ),
        ];
        if conds.iter().any(|c| c.1.is_some()) {
            x.open("dcc:influenceConditions")?;
            for (name, v, tol, unit) in conds {
                let Some(v) = v else { continue };
                x.open("dcc:influenceCondition")?;
                x.text("dcc:name", name)?;
                x.open("dcc:data")?;
                x.open("dcc:quantity")?;
                x.real(
                    None,
                    &num(v, 2).map_err(|e| io::Error::other(format!("{name}: {e}")))?,
                    unit,
                    None,
                )?;
                x.close("dcc:quantity")?;
                if let Some(t) = tol {
                    x.open("dcc:quantity")?;
                    x.text("dcc:name", "variation (±)")?;
                    x.real(
                        None,
                        &num(t, 2)
                            .map_err(|e| io::Error::other(format!("{name} variation: {e}")))?,
                        unit,
                        None,
                    )?;
                    x.close("dcc:quantity")?;
                }
                x.close("dcc:data")?;
                x.close("dcc:influenceCondition")?;
            }
            x.close("dcc:influenceConditions")?;
        }
    }
    x.open("dcc:results")?;
    x.open("dcc:result")?;
    x.text("dcc:name", "Encoder angle error α(θ)")?;
    x.open("dcc:description")?;
    x.w.create_element("dcc:content")
        .with_attribute(("lang", lang.as_str()))
        .write_text_content(BytesText::new(
            "At every calibrated angle θ: the encoder's angle error α (its reading minus the true angle, zero mean over the circle); the correction to apply is −α.",
        ))?;
    x.close("dcc:description")?;
    x.open("dcc:data")?;
    x.open("dcc:list")?;
    for (i, p) in cert.points.iter().enumerate() {
        let what = format!("angle {i} ({}°)", p.angle_deg);
        let at = |e: io::Error| io::Error::other(format!("{what}: {e}"));
        x.open("dcc:list")?;
        x.quantity(
            "angle θ",
            None,
            &num(p.angle_deg, 6).map_err(at)?,
            "\\degree",
            None,
        )?;
        let unc = match (p.expanded_arcsec, p.k, p.p) {
            (Some(u), Some(k), Some(pp)) => Some(expanded(&what, u, k, pp)?),
            _ => None,
        };
        x.quantity(
            "encoder error α",
            None,
            &num(p.value_arcsec, 6).map_err(at)?,
            "\\arcsecond",
            unc,
        )?;
        x.close("dcc:list")?;
    }
    x.close("dcc:list")?;
    x.close("dcc:data")?;
    x.close("dcc:result")?;
    if let Some(pitch) = cert.pitch_deviations() {
        x.open("dcc:result")?;
        x.text("dcc:name", "Pitch deviations β of the polygon")?;
        x.open("dcc:data")?;
        x.open("dcc:list")?;
        for b in pitch {
            let what = format!("β of face {}", b.face);
            let unc = match (b.expanded_arcsec, b.k) {
                (Some(u), Some(k)) => Some(expanded(&what, u, k, cert.uncertainty.coverage)?),
                _ => None,
            };
            x.quantity(
                &what,
                Some(&format!("face {}", b.face)),
                &num(b.value_arcsec, 6).map_err(|e| io::Error::other(format!("{what}: {e}")))?,
                "\\arcsecond",
                unc,
            )?;
        }
        x.close("dcc:list")?;
        x.close("dcc:data")?;
        x.close("dcc:result")?;
    }
    x.close("dcc:results")?;
    x.close("dcc:measurementResult")?;
    x.close("dcc:measurementResults")?;
    x.close("dcc:digitalCalibrationCertificate")?;
    Ok(())
}

fn contact(
    x: &mut X,
    p: &gonio_calib::certificate::Party,
    g: &dyn Fn(&Option<String>) -> String,
) -> io::Result<()> {
    x.open("dcc:contact")?;
    contact_body(x, p, g)?;
    x.close("dcc:contact")
}

fn contact_body(
    x: &mut X,
    p: &gonio_calib::certificate::Party,
    g: &dyn Fn(&Option<String>) -> String,
) -> io::Result<()> {
    x.text("dcc:name", &g(&p.name))?;
    x.leaf("dcc:eMail", p.email.as_deref().unwrap_or(""))?;
    if let Some(ph) = &p.phone {
        x.leaf("dcc:phone", ph)?;
    }
    x.location(&g(&p.address), p.country.as_deref())
}
