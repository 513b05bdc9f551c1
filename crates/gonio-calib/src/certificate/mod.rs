//! One calibration certificate for every method: the encoder's angle error at every calibrated
//! angle with its full uncertainty statement, built in one place.
//!
//! A [`Certificate`] holds, whatever the method:
//! - every calibrated angle ([`AnglePoint`]): α, u, the estimator's random part u_random, U, k,
//!   ν_eff and the coverage probability p; U is attached here and nowhere else
//!   ([`Certificate::from_shift_angle`], [`Certificate::from_selfcal`],
//!   [`Certificate::from_joint`]);
//! - the compensation table (correction = −α, to add to the encoder's reading);
//! - the harmonic spectrum of α with the orders each method cannot see ([`Spectrum`]);
//! - the GUM budget of the angle with the largest U ([`Certificate::budget`]);
//! - the method's own section: the polygon's pitch deviations, setup errors, the harmonic check
//!   and every reading's residual (shift-angle method, [`ShiftAngleSection`]), the heads,
//!   the harmonic table and the head offsets (self-calibration, [`SelfcalSection`]), or both
//!   instruments' results with the split of every u between them, the full covariance of α and
//!   the per-order split of the information (joint calibration, [`JointSection`]);
//! - optionally the administrative data of ISO/IEC 17025 §7.8 ([`CertificateMeta`]).
//!
//! The JSON form carries the format tag [`CERTIFICATE_FORMAT`] and keeps every field name the
//! `shift-angle` and `selfcal` commands wrote before certificates existed: the angles are
//! `encoder_errors` for the shift-angle method and `errors` (each point with `position_deg` as
//! well) for self-calibration, `encoder_errors` for a joint calibration (whose own results are
//! under the key `joint`); the invisible orders are written both as
//! `undetectable_harmonics` and `undetectable_orders`. A new method adds a [`Procedure`], a
//! builder function in [`build`](self) and, if it needs one, an optional section.
//!
//! ```
//! use gonio_calib::certificate::{Certificate, Instrument, Procedure};
//! use gonio_calib::shift_angle::{calibrate, Options, Reading, ReadingSet};
//! // A 3-face polygon at one shift, two repeats that differ by ±0.01″ (residual dof 3).
//! let mut readings = Vec::new();
//! for j in 1..=3usize {
//!     for i in 1..=3usize {
//!         for (r, e) in [(1u32, 0.01), (2, -0.01)] {
//!             readings.push(Reading { repeat: r, ..Reading::new(0.0, j, i, 0.1 * i as f64 + e) });
//!         }
//!     }
//! }
//! let set = ReadingSet::new(3, readings).unwrap();
//! let cal = calibrate(&set, &Options::default()).unwrap();
//! let cert = Certificate::from_shift_angle(&cal, &set, false, 1, &Instrument::default()).unwrap();
//! assert_eq!(cert.procedure, Procedure::ShiftAngle);
//! let p = &cert.points[0];
//! assert_eq!(p.p, Some(0.95));
//! assert!((p.expanded_arcsec.unwrap() - p.k.unwrap() * p.u_arcsec).abs() < 1e-15);
//! assert_eq!(cert.compensation[0].correction_arcsec, -p.value_arcsec);
//! ```

mod build;
mod error;
mod meta;
mod validate;
mod wire;

pub use build::{Instrument, MAX_SPECTRUM_ORDER};
pub use error::CertificateError;
pub use meta::{
    Authorisation, CalibrationDates, CertificateMeta, Date, Environment, Item, MethodMeta, Party,
    ReferenceStandard,
};
pub use validate::check_text;

use crate::joint::{
    BlindOrders, Consistency, HeadAngles, Interpolation, JointAlpha, JointHarmonic, SigmaUsed,
};
use crate::selfcal::{HarmonicRow, NoiseModel};
use crate::shift_angle::{HarmonicCheck, SetupError};
use gonio_uncertainty::BudgetResult;
use gonio_uncertainty::budget::{
    deserialize_dof, deserialize_opt_dof, serialize_dof, serialize_opt_dof,
};
use serde::{Deserialize, Serialize};

/// The certificate's `format` value.
pub const CERTIFICATE_FORMAT: &str = "gonio.certificate/1";

/// The calibration procedure a certificate comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
#[non_exhaustive]
pub enum Procedure {
    /// Cross-calibration with a polygon and an autocollimator at shifted start angles.
    ShiftAngle,
    /// Self-calibration with several read heads on the encoder's own scale.
    SelfCalibration,
    /// Both of the above on one encoder, in one least-squares estimate.
    Joint,
}

impl Procedure {
    /// The name in files (`shift-angle`, `self-calibration`).
    pub fn name(self) -> &'static str {
        match self {
            Procedure::ShiftAngle => "shift-angle",
            Procedure::SelfCalibration => "self-calibration",
            Procedure::Joint => "joint",
        }
    }

    /// The name a user knows, with the paper it comes from.
    pub fn title(self) -> &'static str {
        match self {
            Procedure::ShiftAngle => "shift-angle method (Hsieh et al., 2022)",
            Procedure::SelfCalibration => {
                "multi-head self-calibration (Hsieh et al., 2022, after the SelfA encoder)"
            }
            Procedure::Joint => {
                "joint calibration: the shift-angle method and multi-head self-calibration (Hsieh et al., 2022) in one least squares"
            }
        }
    }

    /// The JSON key of the per-angle list (the name each command wrote before certificates).
    pub(crate) fn points_key(self) -> &'static str {
        match self {
            Procedure::SelfCalibration => "errors",
            Procedure::ShiftAngle | Procedure::Joint => "encoder_errors",
        }
    }
}

/// The encoder's error at one calibrated angle, with its uncertainty statement.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AnglePoint {
    /// Angle θ, degrees in [0, 360).
    pub angle_deg: f64,
    /// The encoder's angle error α(θ), arcsec (zero mean over the circle, or over each shift's
    /// N angles for the shift-angle method).
    pub value_arcsec: f64,
    /// Combined standard uncertainty u_c, arcsec (the random part and the instrument terms);
    /// NaN (JSON null) when the random part is unknown.
    #[serde(with = "nan_as_null")]
    pub u_arcsec: f64,
    /// The estimator's random part of u, arcsec.
    #[serde(with = "nan_as_null")]
    pub u_random_arcsec: f64,
    /// Expanded uncertainty U = k·u_c, arcsec (absent when u is unknown).
    #[serde(rename = "U_arcsec")]
    pub expanded_arcsec: Option<f64>,
    /// Coverage factor k = t_p(ν_eff).
    pub k: Option<f64>,
    /// Welch–Satterthwaite ν_eff, truncated (JSON: a number or `"inf"`).
    #[serde(
        serialize_with = "serialize_opt_dof",
        deserialize_with = "deserialize_opt_dof",
        default
    )]
    pub nu_eff: Option<f64>,
    /// Coverage probability p of U.
    #[serde(default)]
    pub p: Option<f64>,
    /// Shift angle the point was measured at, degrees (shift-angle method).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shift_deg: Option<f64>,
    /// Rotation step (1-based) within its shift (shift-angle method).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub step: Option<usize>,
}

/// One row of the compensation table.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CompensationRow {
    /// Angle, degrees.
    pub angle_deg: f64,
    /// Correction to add to the encoder's reading, arcsec (−α).
    pub correction_arcsec: f64,
}

/// Residual statistics of the estimator, the same fields for every method.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Residuals {
    /// RMS residual, arcsec.
    pub rms_arcsec: f64,
    /// Largest |residual|, arcsec.
    pub max_abs_arcsec: f64,
    /// Residual degrees of freedom (JSON: a number or `"inf"`).
    #[serde(serialize_with = "serialize_dof", deserialize_with = "deserialize_dof")]
    pub dof: f64,
    /// Readings (or head differences) compared with the model.
    pub count: Option<usize>,
    /// σ̂ of one reading from the residuals, arcsec (absent without residual dof).
    pub sigma_hat_arcsec: Option<f64>,
    /// The same σ̂ under the name `gonio selfcal` wrote.
    pub sigma_arcsec: Option<f64>,
    /// χ² check of the residuals against a stated σ (shift-angle method with `--sigma`).
    pub chi2: Option<crate::shift_angle::Chi2Check>,
}

/// One instrument term of the budget, as stated.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InstrumentTerm {
    /// Name.
    pub name: String,
    /// Standard uncertainty, arcsec.
    pub u: f64,
    /// Sensitivity coefficient.
    pub c: f64,
    /// Degrees of freedom (JSON: a number or `"inf"`).
    #[serde(serialize_with = "serialize_dof", deserialize_with = "deserialize_dof")]
    pub nu: f64,
}

/// How the uncertainties were formed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UncertaintySummary {
    /// Where the random part comes from (e.g. `residuals`, `repeated turns`).
    pub source: String,
    /// Coverage probability p of every U.
    pub coverage: f64,
    /// Degrees of freedom of the random part (JSON: a number or `"inf"` for a stated σ).
    #[serde(serialize_with = "serialize_dof", deserialize_with = "deserialize_dof")]
    pub random_dof: f64,
    /// The instrument file the terms came from, if any.
    pub instrument_file: Option<String>,
    /// The instrument terms combined with the random part.
    pub instrument_terms: Vec<InstrumentTerm>,
    /// Self-calibration: u from the residuals, arcsec.
    pub u_residuals_arcsec: Option<f64>,
    /// Self-calibration: u from the turn-to-turn spread, arcsec (two or more turns).
    pub u_turns_arcsec: Option<f64>,
}

/// One line of the harmonic spectrum of α: `amplitude·sin(order·θ + phase)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SpectrumLine {
    /// Order (cycles per turn).
    pub order: u32,
    /// Amplitude, arcsec (0 for an order the method cannot see).
    pub amplitude_arcsec: f64,
    /// Standard uncertainty of the amplitude, arcsec (NaN/null when unknown).
    #[serde(with = "nan_as_null")]
    pub u_amplitude_arcsec: f64,
    /// Phase, radians.
    pub phase_rad: f64,
    /// Whether the method can see this order.
    pub visible: bool,
}

/// The orders one instrument or method cannot see.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InvisibleOrders {
    /// What cannot see them, e.g. `24-face polygon` or `12 read heads (SelfA)`.
    pub by: String,
    /// The orders, ascending (up to the spectrum's largest order).
    pub orders: Vec<u32>,
}

/// The harmonic amplitude spectrum of α and the blind orders of each method behind it.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Spectrum {
    /// Orders 1… in ascending order, up to the grid's Nyquist order and at most 360 (one a
    /// degree).
    pub lines: Vec<SpectrumLine>,
    /// Per method (one for shift-angle or self-calibration; several for a joint calibration).
    pub invisible: Vec<InvisibleOrders>,
}

/// The polygon's pitch deviation of one face.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PitchDeviation {
    /// Face (1-based).
    pub face: usize,
    /// β, arcsec.
    pub value_arcsec: f64,
    /// Standard uncertainty (the estimator's random part), arcsec.
    #[serde(with = "nan_as_null")]
    pub u_arcsec: f64,
    /// Expanded uncertainty k·u at the certificate's p (random part only), arcsec.
    #[serde(rename = "U_arcsec", default)]
    pub expanded_arcsec: Option<f64>,
    /// Coverage factor.
    #[serde(default)]
    pub k: Option<f64>,
}

/// What only the shift-angle method has.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShiftAngleSection {
    /// Polygon faces N.
    pub faces: usize,
    /// Readings used.
    pub readings: usize,
    /// Shift angles, degrees.
    pub shifts_deg: Vec<f64>,
    /// The σ of one reading behind the uncertainties, arcsec.
    pub sigma_arcsec: Option<f64>,
    /// `stated` (`--sigma`) or `residuals`.
    pub sigma_source: String,
    /// β per face.
    pub pitch_deviations: Vec<PitchDeviation>,
    /// Setup error U per run.
    pub setup_errors: Vec<SetupError>,
    /// The harmonic check of the setup error (Hsieh et al., 2022, §3.1), when it could be fitted.
    pub harmonic_check: Option<HarmonicCheck>,
    /// Identical duplicate readings kept once.
    pub duplicates_ignored: usize,
    /// Every compared reading's residual (reading − model), arcsec, in reading order.
    #[serde(default)]
    pub reading_residuals_arcsec: Vec<f64>,
}

/// What only self-calibration has.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SelfcalSection {
    /// Head angles, degrees.
    pub heads_deg: Vec<f64>,
    /// 1-based heads whose averaged reading is calibrated.
    pub reference_heads: Vec<usize>,
    /// Rotation positions per turn.
    pub positions: usize,
    /// Turns.
    pub turns: usize,
    /// The noise model of the uncertainty.
    pub noise_model: NoiseModel,
    /// The harmonic table with noise gains.
    pub harmonics: Vec<HarmonicRow>,
    /// The largest order considered.
    pub max_order: u32,
    /// Mounting offsets c_h of heads 2..M, arcsec.
    pub head_offsets_arcsec: Vec<f64>,
}

/// What only the joint calibration has: both instruments' results, the split of every random
/// part between them, the full covariance of α at the polygon angles, and the harmonic table with
/// each instrument's share per order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JointSection {
    /// Polygon faces N.
    pub faces: usize,
    /// Polygon readings used.
    pub readings: usize,
    /// Shift angles, degrees.
    pub shifts_deg: Vec<f64>,
    /// β per face.
    pub pitch_deviations: Vec<PitchDeviation>,
    /// Setup error U per run (the run's whole setup error: α has zero mean over the circle).
    pub setup_errors: Vec<SetupError>,
    /// Head angles, degrees (nominal).
    pub heads_deg: Vec<f64>,
    /// Rotation positions per turn of the heads (the encoder grid).
    pub positions: usize,
    /// The heads' noise model.
    pub noise_model: NoiseModel,
    /// The head angles the heads' model used.
    pub head_angles: HeadAngles,
    /// How the heads' model placed the error between positions.
    pub interpolation: Interpolation,
    /// Mounting offsets c_h of heads 2..M, arcsec.
    pub head_offsets_arcsec: Vec<f64>,
    /// σ of one polygon reading.
    pub sigma_polygon: SigmaUsed,
    /// σ of one head reading (or difference).
    pub sigma_heads: SigmaUsed,
    /// RMS of the head-difference residuals against the joint estimate, arcsec.
    pub residuals_heads_rms_arcsec: f64,
    /// The random part at every angle (same order as the points): its split between the
    /// instruments and each instrument's own u.
    pub random_part: Vec<JointAlpha>,
    /// Full covariance of α (random part) at the points' angles, arcsec².
    pub covariance_alpha_arcsec2: Vec<Vec<f64>>,
    /// Harmonics 1..=max order with the per-order split of the information.
    pub harmonics: Vec<JointHarmonic>,
    /// Blind orders of each method and of the joint estimate.
    pub blind_orders: BlindOrders,
    /// The χ² agreement of the two instruments.
    pub consistency: Option<Consistency>,
}

/// The program that computed the certificate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Software {
    /// `gonio`.
    pub name: String,
    /// Its version.
    pub version: String,
}

impl Default for Software {
    fn default() -> Self {
        Software {
            name: "gonio".into(),
            version: env!("CARGO_PKG_VERSION").into(),
        }
    }
}

/// A calibration certificate (see the [module docs](self)).
#[derive(Debug, Clone, PartialEq)]
pub struct Certificate {
    /// Always [`CERTIFICATE_FORMAT`].
    pub format: String,
    /// The procedure.
    pub procedure: Procedure,
    /// The estimator (`least-squares`, `paper`, `selfcal-fourier`, `selfcal-eda`,
    /// `selfcal-selfa`).
    pub method: String,
    /// Every calibrated angle, sorted by angle.
    pub points: Vec<AnglePoint>,
    /// Residual statistics.
    pub residuals: Residuals,
    /// How the uncertainties were formed.
    pub uncertainty: UncertaintySummary,
    /// The GUM budget of the angle with the largest U (rows with shares).
    pub budget: Option<BudgetResult>,
    /// Harmonic orders of α the method cannot see.
    pub undetectable_orders: Vec<u32>,
    /// The harmonic spectrum of α.
    pub spectrum: Spectrum,
    /// Correction = −α at every calibrated angle.
    pub compensation: Vec<CompensationRow>,
    /// The shift-angle method's own results.
    pub shift_angle: Option<ShiftAngleSection>,
    /// Self-calibration's own results.
    pub selfcal: Option<SelfcalSection>,
    /// The joint calibration's own results.
    pub joint: Option<JointSection>,
    /// The program that computed it.
    pub software: Software,
    /// Administrative data (ISO/IEC 17025 §7.8), if given.
    pub meta: Option<CertificateMeta>,
}

/// The fields a results database indexes, read off a certificate.
#[derive(Debug, Clone, PartialEq)]
pub struct IndexFields<'a> {
    /// The item's identification (serial number), if the metadata gives it.
    pub item: Option<&'a str>,
    /// The procedure.
    pub procedure: Procedure,
    /// The estimator.
    pub method: &'a str,
    /// Date of calibration (ISO 8601), if the metadata gives it.
    pub calibration_date: Option<&'a str>,
    /// Largest |α|, arcsec.
    pub max_abs_error_arcsec: f64,
    /// Largest U, arcsec (absent when no angle has one).
    pub max_expanded_arcsec: Option<f64>,
}

impl Certificate {
    /// Largest |α| over the calibrated angles, arcsec (0 without points).
    pub fn max_abs_error_arcsec(&self) -> f64 {
        self.points
            .iter()
            .map(|p| p.value_arcsec.abs())
            .fold(0.0, f64::max)
    }

    /// Largest U over the calibrated angles, arcsec.
    pub fn max_expanded_arcsec(&self) -> Option<f64> {
        self.points
            .iter()
            .filter_map(|p| p.expanded_arcsec)
            .reduce(f64::max)
    }

    /// Peak-to-peak α, arcsec.
    pub fn peak_to_peak_arcsec(&self) -> f64 {
        let (lo, hi) = self
            .points
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.value_arcsec), b.max(p.value_arcsec))
            });
        if lo.is_finite() { hi - lo } else { 0.0 }
    }

    /// The fields a results database indexes.
    pub fn index_fields(&self) -> IndexFields<'_> {
        let meta = self.meta.as_ref();
        IndexFields {
            item: meta
                .and_then(|m| m.item.as_ref())
                .and_then(|i| i.identification.as_deref()),
            procedure: self.procedure,
            method: &self.method,
            calibration_date: meta
                .and_then(|m| m.dates.as_ref())
                .and_then(|d| d.calibration.as_ref())
                .map(Date::as_str),
            max_abs_error_arcsec: self.max_abs_error_arcsec(),
            max_expanded_arcsec: self.max_expanded_arcsec(),
        }
    }

    /// The required metadata fields that are missing, by name (`customer.name`, …); every field
    /// when there is no metadata. A certificate with any missing is a draft.
    pub fn missing_meta(&self) -> Vec<String> {
        match &self.meta {
            Some(m) => m.missing_fields(self.procedure),
            None => CertificateMeta::default().missing_fields(self.procedure),
        }
    }

    /// The polygon's pitch deviations, for a procedure that has a polygon (shift-angle, joint).
    pub fn pitch_deviations(&self) -> Option<&[PitchDeviation]> {
        match (&self.shift_angle, &self.joint) {
            (Some(s), _) => Some(&s.pitch_deviations),
            (None, Some(j)) => Some(&j.pitch_deviations),
            (None, None) => None,
        }
    }

    /// Attaches (or replaces) the administrative data.
    pub fn with_meta(mut self, meta: CertificateMeta) -> Self {
        self.meta = Some(meta);
        self
    }

    /// A one-line name of the method for people, e.g.
    /// `shift-angle method (Hsieh et al., 2022), least squares`.
    pub fn method_title(&self) -> String {
        let estimator = match self.method.as_str() {
            "least-squares" => "least squares over all readings",
            "paper" => "the paper's algorithm",
            "selfcal-fourier" => "Fourier least squares",
            "selfcal-eda" => "equal-division averaging",
            "selfcal-selfa" => "equal-division averaging on SelfA's 3-, 4- and 7-head sets",
            "joint-least-squares" => "both instruments' readings, each weighted by its own σ",
            other => other,
        };
        format!("{}, {estimator}", self.procedure.title())
    }
}

/// Serde helpers: an `f64` that may be NaN, written as `null` and read back as NaN.
pub(crate) mod nan_as_null {
    use serde::{Deserialize, Deserializer, Serializer};

    /// Writes NaN and infinities as null.
    pub fn serialize<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
        if v.is_finite() {
            s.serialize_f64(*v)
        } else {
            s.serialize_none()
        }
    }

    /// Reads null as NaN.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
    }
}
