//! The result document of `gonio axis` (JSON, format tag [`AXIS_FORMAT`]): the ISO 230-2
//! parameters by the standard's letters, every target's statistics, how the deviations were
//! formed, the uncertainty beside the parameters, the notes where the test departs from the
//! standard, and the compensation table.

use super::compensation::{AxisCompensation, compensation};
use super::data::Direction;
use super::parameters::{Approach, Evaluation, Parameters, STANDARD_RUNS};
use super::polygon::Polygon;
use super::uncertainty::{PARAMETER_K, parameter_uncertainty, reference_budget};
use super::{AxisError, STANDARD, STANDARD_TITLE};
use crate::certificate::{Instrument, Software};
use gonio_uncertainty::BudgetResult;
use gonio_uncertainty::budget::{deserialize_dof, serialize_dof};
use serde::{Deserialize, Serialize};

/// The sign convention of the compensation table, as the document states it.
pub const COMPENSATION_NOTE: &str = "correction = −x̄ (arcsec): added to the commanded position it cancels the measured deviation x̄ = position reached − target; correction_mean_arcsec = −(x̄↑ + x̄↓)/2 for a controller with one value per target";

/// The `format` of the document.
pub const AXIS_FORMAT: &str = "gonio.axis/1";

/// One target's statistics, arcsec.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AxisTarget {
    /// Target P_i, degrees.
    pub target_deg: f64,
    /// x̄↑.
    pub mean_up_arcsec: Option<f64>,
    /// x̄↓.
    pub mean_down_arcsec: Option<f64>,
    /// s↑ (n − 1).
    pub s_up_arcsec: Option<f64>,
    /// s↓ (n − 1).
    pub s_down_arcsec: Option<f64>,
    /// B_i = x̄↑ − x̄↓.
    #[serde(rename = "B_arcsec")]
    pub b_arcsec: Option<f64>,
    /// R_i = max(2s↑ + 2s↓ + |B_i|, R_i↑, R_i↓).
    #[serde(rename = "R_arcsec")]
    pub r_arcsec: Option<f64>,
    /// Approaches in the positive direction.
    pub n_up: usize,
    /// Approaches in the negative direction.
    pub n_down: usize,
    /// x̄_i = (x̄↑ + x̄↓)/2.
    pub mean_arcsec: Option<f64>,
    /// R_i↑ = 4s↑.
    #[serde(rename = "R_up_arcsec")]
    pub r_up_arcsec: Option<f64>,
    /// R_i↓ = 4s↓.
    #[serde(rename = "R_down_arcsec")]
    pub r_down_arcsec: Option<f64>,
    /// Every positive approach's x_ij, in run order.
    pub deviations_up_arcsec: Vec<f64>,
    /// Every negative approach's x_ij, in run order.
    pub deviations_down_arcsec: Vec<f64>,
    /// The polygon face at the autocollimator (readings corrected by a polygon).
    pub face: Option<usize>,
    /// That face's term taken off the readings.
    pub polygon_term_arcsec: Option<f64>,
    /// The reference's standard uncertainty of one deviation here.
    pub u_reference_arcsec: Option<f64>,
}

/// The polygon whose calibration corrected the readings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PolygonSection {
    /// The certificate it came from.
    pub certificate: String,
    /// Faces N.
    pub faces: usize,
    /// Pitch 360°/N, degrees.
    pub pitch_deg: f64,
    /// What gonio did with it, beyond the standard.
    pub note: String,
}

/// The reference's uncertainty of one deviation: the budget of the target where it is largest.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReferenceSection {
    /// The largest u over the targets, arcsec.
    pub u_arcsec: f64,
    /// Its expanded uncertainty, arcsec.
    #[serde(rename = "U_arcsec")]
    pub expanded_arcsec: f64,
    /// Coverage factor.
    pub k: f64,
    /// Welch–Satterthwaite ν_eff (a number or `"inf"`).
    #[serde(serialize_with = "serialize_dof", deserialize_with = "deserialize_dof")]
    pub nu_eff: f64,
    /// Coverage probability.
    pub p: f64,
    /// The target of that budget, degrees.
    pub target_deg: f64,
    /// The instrument file of the terms, if any.
    pub instrument_file: Option<String>,
    /// The polygon's certificate, if any.
    pub polygon_certificate: Option<String>,
    /// The budget, rows with their shares.
    pub budget: BudgetResult,
}

/// The uncertainty beside the parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AxisUncertainty {
    /// What this is, and that the standard does not ask for it in this form.
    pub note: String,
    /// Coverage factor of the parameters' U.
    pub k: f64,
    /// The expanded uncertainty U of every parameter, by its name (`null` where the parameter
    /// is), arcsec.
    pub parameters: Parameters,
    /// The reference's budget of one deviation (`null` without any reference term).
    pub reference: Option<ReferenceSection>,
    /// Why there is no reference budget, when there is none.
    pub reference_note: Option<String>,
}

/// The result of `gonio axis`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AxisResult {
    /// Always [`AXIS_FORMAT`].
    pub format: String,
    /// The standard and its edition, `ISO 230-2:2014`.
    pub standard: String,
    /// The standard's title.
    pub standard_title: String,
    /// `rotary`.
    pub axis: String,
    /// The unit of every deviation and parameter, `arcsec`.
    pub unit: String,
    /// `bidirectional`, or `unidirectional (positive)` / `unidirectional (negative)`.
    pub test: String,
    /// Runs n in each direction.
    pub runs: usize,
    /// The parameters (`A_arcsec`, `A_up_arcsec`, …).
    #[serde(flatten)]
    pub parameters: Parameters,
    /// Why the bidirectional parameters are `null`, in a unidirectional test.
    pub bidirectional_note: Option<String>,
    /// Every target, ascending.
    pub targets: Vec<AxisTarget>,
    /// How the deviations x_ij were formed.
    pub deviations: String,
    /// The polygon that corrected the readings.
    pub polygon: Option<PolygonSection>,
    /// The uncertainty beside the parameters.
    pub uncertainty: AxisUncertainty,
    /// Where the test departs from the standard's.
    pub notes: Vec<String>,
    /// The controller's compensation table.
    pub compensation: Vec<AxisCompensation>,
    /// The sign convention of the compensation table.
    #[serde(default)]
    pub compensation_note: String,
    /// The program.
    pub software: Software,
}

impl AxisResult {
    /// `5 runs in each direction`, or `5 runs, negative direction only` in a unidirectional test.
    pub fn runs_summary(&self) -> String {
        match self.test.strip_prefix("unidirectional (") {
            Some(rest) => format!(
                "{} runs, {} direction only",
                self.runs,
                rest.trim_end_matches(')')
            ),
            None => format!("{} runs in each direction", self.runs),
        }
    }

    /// The document of an evaluated test. `faces`: each target's polygon face (the
    /// evaluation's order) when `polygon` corrected the readings; `instrument`: the reference
    /// instrument's terms.
    ///
    /// # Errors
    /// [`AxisError::Uncertainty`]: the reference's budget cannot be evaluated.
    pub fn new(
        eval: &Evaluation,
        faces: &[Option<usize>],
        polygon: Option<&Polygon>,
        instrument: &Instrument,
    ) -> Result<AxisResult, AxisError> {
        let reference = reference_budget(eval, faces, instrument, polygon)?;
        let u_ref_owned = reference.as_ref().map(|r| r.u_arcsec.clone());
        let u_ref = u_ref_owned.as_deref();
        let targets = eval
            .targets
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let face = faces.get(i).copied().flatten();
                let term = polygon.zip(face).map(|(p, f)| p.term(f).0);
                let of = |d: Direction| t.cell(d);
                AxisTarget {
                    target_deg: t.target_deg,
                    mean_up_arcsec: of(Direction::Up).map(|c| c.mean_arcsec),
                    mean_down_arcsec: of(Direction::Down).map(|c| c.mean_arcsec),
                    s_up_arcsec: of(Direction::Up).map(|c| c.s_arcsec),
                    s_down_arcsec: of(Direction::Down).map(|c| c.s_arcsec),
                    b_arcsec: t.reversal_arcsec(),
                    r_arcsec: t.repeatability_arcsec(),
                    n_up: of(Direction::Up).map_or(0, |c| c.n()),
                    n_down: of(Direction::Down).map_or(0, |c| c.n()),
                    mean_arcsec: t.mean_arcsec(),
                    r_up_arcsec: of(Direction::Up).map(|c| c.repeatability_arcsec()),
                    r_down_arcsec: of(Direction::Down).map(|c| c.repeatability_arcsec()),
                    deviations_up_arcsec: of(Direction::Up)
                        .map_or(Vec::new(), |c| c.deviations_arcsec.clone()),
                    deviations_down_arcsec: of(Direction::Down)
                        .map_or(Vec::new(), |c| c.deviations_arcsec.clone()),
                    face,
                    polygon_term_arcsec: term,
                    u_reference_arcsec: u_ref.map(|u| u[i]),
                }
            })
            .collect();
        let (test, bidirectional_note) = match eval.approach {
            Approach::Bidirectional => ("bidirectional".to_string(), None),
            Approach::Unidirectional(d) => (
                format!("unidirectional ({})", d.word()),
                Some(format!(
                    "only {} approaches: a unidirectional test (ISO 230-2 allows it); the bidirectional parameters A, B, B_mean, E, M, R and the {} direction's are undefined (null)",
                    d.word(),
                    match d {
                        Direction::Up => Direction::Down.word(),
                        Direction::Down => Direction::Up.word(),
                    }
                )),
            ),
        };
        let mut notes = Vec::new();
        if eval.n() < STANDARD_RUNS {
            notes.push(format!(
                "{} runs in each direction: ISO 230-2's standard test cycle has {STANDARD_RUNS}",
                eval.n()
            ));
        }
        let deviations = match polygon {
            Some(p) => format!(
                "the autocollimator's readings less the term of the polygon face at each target, from the polygon's calibration {} (gonio beyond ISO 230-2)",
                p.source
            ),
            None => "as given (deviation_arcsec: position reached − target)".to_string(),
        };
        let reference_note = reference.is_none().then(|| {
            "no reference terms: give the reference instrument's terms (--instrument) or the polygon's calibration (--polygon) for the uncertainty of the deviations; the parameters' U below is the measured scatter alone".to_string()
        });
        let reference = reference.map(|r| ReferenceSection {
            u_arcsec: r.budget.u_c,
            expanded_arcsec: r.budget.expanded,
            k: r.budget.k,
            nu_eff: r.budget.nu_eff,
            p: r.budget.coverage,
            target_deg: r.target_deg,
            instrument_file: (!instrument.terms.contributions.is_empty())
                .then(|| instrument.source.clone())
                .flatten(),
            polygon_certificate: polygon.map(|p| p.source.clone()),
            budget: r.budget,
        });
        Ok(AxisResult {
            format: AXIS_FORMAT.into(),
            standard: STANDARD.into(),
            standard_title: STANDARD_TITLE.into(),
            axis: "rotary".into(),
            unit: "arcsec".into(),
            test,
            runs: eval.n(),
            parameters: eval.parameters,
            bidirectional_note,
            targets,
            deviations,
            polygon: polygon.map(|p| PolygonSection {
                certificate: p.source.clone(),
                faces: p.faces(),
                pitch_deg: p.pitch_deg(),
                note: "gonio beyond ISO 230-2: the readings are corrected by the polygon's calibrated pitch deviations, and the calibration's uncertainty enters the reference's budget".into(),
            }),
            uncertainty: AxisUncertainty {
                note: format!(
                    "gonio beyond ISO 230-2: the expanded uncertainty U (k = {PARAMETER_K}) of every parameter, a first-order propagation of the reference's budget of one deviation and of the measured scatter (s²/n of a mean, s²/(2(n − 1)) of a standard deviation), the approaches that decide each parameter held fixed"
                ),
                k: PARAMETER_K,
                parameters: parameter_uncertainty(eval, u_ref),
                reference,
                reference_note,
            },
            notes,
            compensation: compensation(eval),
            compensation_note: COMPENSATION_NOTE.into(),
            software: Software::default(),
        })
    }
}
