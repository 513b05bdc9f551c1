//! The JSON form of a certificate: the per-angle list under the key each command wrote before
//! certificates existed, the method sections flattened to the top level.

use super::{
    AnglePoint, CERTIFICATE_FORMAT, Certificate, CertificateMeta, CompensationRow, JointSection,
    Procedure, Residuals, SelfcalSection, ShiftAngleSection, Software, Spectrum,
    UncertaintySummary,
};
use gonio_uncertainty::BudgetResult;
use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// A self-calibration point: also under `position_deg`, the name `gonio selfcal` wrote.
#[derive(Serialize)]
struct PositionPoint<'a> {
    position_deg: f64,
    #[serde(flatten)]
    point: &'a AnglePoint,
}

#[derive(Serialize)]
struct Out<'a> {
    format: &'a str,
    procedure: Procedure,
    procedure_title: &'static str,
    method: &'a str,
    #[serde(skip_serializing_if = "Option::is_none")]
    encoder_errors: Option<&'a [AnglePoint]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    errors: Option<Vec<PositionPoint<'a>>>,
    residuals: &'a Residuals,
    uncertainty: &'a UncertaintySummary,
    budget: &'a Option<BudgetResult>,
    undetectable_harmonics: &'a [u32],
    undetectable_orders: &'a [u32],
    spectrum: &'a Spectrum,
    compensation: &'a [CompensationRow],
    #[serde(flatten)]
    shift_angle: &'a Option<ShiftAngleSection>,
    #[serde(flatten)]
    selfcal: &'a Option<SelfcalSection>,
    #[serde(skip_serializing_if = "Option::is_none")]
    joint: &'a Option<JointSection>,
    software: &'a Software,
    #[serde(skip_serializing_if = "Option::is_none")]
    meta: &'a Option<CertificateMeta>,
}

impl Serialize for Certificate {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let by_position = self.procedure.points_key() == "errors";
        Out {
            format: &self.format,
            procedure: self.procedure,
            procedure_title: self.procedure.title(),
            method: &self.method,
            encoder_errors: (!by_position).then_some(self.points.as_slice()),
            errors: by_position.then(|| {
                self.points
                    .iter()
                    .map(|p| PositionPoint {
                        position_deg: p.angle_deg,
                        point: p,
                    })
                    .collect()
            }),
            residuals: &self.residuals,
            uncertainty: &self.uncertainty,
            budget: &self.budget,
            undetectable_harmonics: &self.undetectable_orders,
            undetectable_orders: &self.undetectable_orders,
            spectrum: &self.spectrum,
            compensation: &self.compensation,
            shift_angle: &self.shift_angle,
            selfcal: &self.selfcal,
            joint: &self.joint,
            software: &self.software,
            meta: &self.meta,
        }
        .serialize(s)
    }
}

#[derive(Deserialize)]
struct In {
    format: String,
    procedure: Procedure,
    method: String,
    #[serde(default)]
    encoder_errors: Option<Vec<AnglePoint>>,
    #[serde(default)]
    errors: Option<Vec<AnglePoint>>,
    residuals: Residuals,
    uncertainty: UncertaintySummary,
    #[serde(default)]
    budget: Option<BudgetResult>,
    #[serde(default)]
    undetectable_harmonics: Option<Vec<u32>>,
    #[serde(default)]
    undetectable_orders: Option<Vec<u32>>,
    #[serde(default)]
    spectrum: Spectrum,
    #[serde(default)]
    compensation: Vec<CompensationRow>,
    #[serde(flatten)]
    shift_angle: Option<ShiftAngleSection>,
    #[serde(flatten)]
    selfcal: Option<SelfcalSection>,
    #[serde(default)]
    joint: Option<JointSection>,
    #[serde(default)]
    software: Software,
    #[serde(default)]
    meta: Option<CertificateMeta>,
}

impl<'de> Deserialize<'de> for Certificate {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let w = In::deserialize(d)?;
        if w.format != CERTIFICATE_FORMAT {
            return Err(D::Error::custom(format!(
                "format {:?}: expected \"{CERTIFICATE_FORMAT}\"",
                w.format
            )));
        }
        let key = w.procedure.points_key();
        let points = match key {
            "errors" => w.errors,
            _ => w.encoder_errors,
        }
        .ok_or_else(|| D::Error::custom(format!("missing field `{key}`")))?;
        let section = |name: &str, fields: &str| {
            D::Error::custom(format!(
                "a {name} certificate needs the fields {fields}, with valid values"
            ))
        };
        match w.procedure {
            Procedure::ShiftAngle if w.shift_angle.is_none() => {
                return Err(section(
                    "shift-angle",
                    "faces, readings, shifts_deg, sigma_arcsec, sigma_source, pitch_deviations, setup_errors, harmonic_check, duplicates_ignored",
                ));
            }
            Procedure::SelfCalibration if w.selfcal.is_none() => {
                return Err(section(
                    "self-calibration",
                    "heads_deg, reference_heads, positions, turns, noise_model, harmonics, max_order, head_offsets_arcsec",
                ));
            }
            Procedure::Joint if w.joint.is_none() => {
                return Err(section("joint", "joint (the joint calibration's section)"));
            }
            _ => {}
        }
        let cert = Certificate {
            format: w.format,
            procedure: w.procedure,
            method: w.method,
            points,
            residuals: w.residuals,
            uncertainty: w.uncertainty,
            budget: w.budget,
            undetectable_orders: w
                .undetectable_orders
                .or(w.undetectable_harmonics)
                .unwrap_or_default(),
            spectrum: w.spectrum,
            compensation: w.compensation,
            shift_angle: if w.procedure == Procedure::ShiftAngle {
                w.shift_angle
            } else {
                None
            },
            selfcal: if w.procedure == Procedure::SelfCalibration {
                w.selfcal
            } else {
                None
            },
            joint: if w.procedure == Procedure::Joint {
                w.joint
            } else {
                None
            },
            software: w.software,
            meta: w.meta,
        };
        // Validated as it is read: a hand-edited certificate with a value no calibration gives
        // is refused here, with the place in the file.
        cert.validate()
            .map_err(|e| D::Error::custom(e.to_string()))?;
        Ok(cert)
    }
}
