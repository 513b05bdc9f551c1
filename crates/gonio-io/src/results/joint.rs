//! The certificate of the joint calibration (the polygon and the read heads in one least
//! squares): `gonio joint --json` and `gonio.joint` in Python, from one code path: the options
//! checked, both readings read (each at most [`crate::input::MAX_TEXT_BYTES`]), the estimator
//! run, its errors told as the input they concern, the instrument terms and the metadata
//! added, the result checked finite.
//!
//! Errors are one line naming the input (`poly.csv: …`, `heads.csv:12: …`, `poly.csv and
//! heads.csv: …` for an angle off the heads' grid) or the flag, as the command line prints
//! them.

use crate::formats::heads::{locate, read_turns};
use crate::formats::source::{Document, Table};
use crate::formats::{instrument, meta, readings};
use crate::input::Inputs;
use anyhow::{Result, anyhow};
use gonio_calib::certificate::Certificate;
use gonio_calib::joint::{HeadAngles, Interpolation, JointError, JointOptions, calibrate};
use gonio_calib::selfcal::{Heads, NoiseModel};

/// What a joint calibration reads and how it runs (the flags of `gonio joint`).
#[derive(Debug)]
pub struct Request {
    /// The polygon readings (`shift_deg,start_face,step,reading_arcsec[,repeat]`).
    pub readings: Table,
    /// The head readings (`position_deg,head_2,…,head_M[,turn]`).
    pub heads_readings: Table,
    /// Polygon faces N (`--faces`).
    pub faces: usize,
    /// The head arrangement (`--heads`, loaded with [`crate::formats::heads::load`]).
    pub heads: Heads,
    /// The head readings are raw readings in degrees (`--raw`).
    pub raw: bool,
    /// σ of one polygon reading, arcsec (`--sigma-polygon`; default: its residuals).
    pub sigma_polygon_arcsec: Option<f64>,
    /// σ of one head reading or difference, arcsec (`--sigma-heads`; default: its residuals).
    pub sigma_heads_arcsec: Option<f64>,
    /// The heads' noise model (`--noise-model`).
    pub noise_model: NoiseModel,
    /// The head angles of the heads' model (`--head-angles`).
    pub head_angles: HeadAngles,
    /// The scale error between rotation positions (`--interpolation`).
    pub interpolation: Interpolation,
    /// Largest order of the harmonic table and the blind lists (`--max-order`).
    pub max_order: u32,
    /// Highest heads-blind order the polygon is asked to resolve (`--blind-max-order`).
    pub blind_max_order: Option<u32>,
    /// Instrument terms (`--instrument`).
    pub instrument: Option<Document>,
    /// Coverage probability of U (`--coverage`; default: the instrument file's, else 0.95).
    pub coverage: Option<f64>,
    /// ISO/IEC 17025 metadata (`--meta`).
    pub meta: Option<Document>,
}

impl Request {
    /// The two readings, the faces and the heads with every option at the command line's
    /// default.
    pub fn new(readings: Table, heads_readings: Table, faces: usize, heads: Heads) -> Request {
        let d = JointOptions::default();
        Request {
            readings,
            heads_readings,
            faces,
            heads,
            raw: false,
            sigma_polygon_arcsec: None,
            sigma_heads_arcsec: None,
            noise_model: d.noise_model,
            head_angles: d.head_angles,
            interpolation: d.interpolation,
            max_order: d.max_order,
            blind_max_order: None,
            instrument: None,
            coverage: None,
            meta: None,
        }
    }
}

/// Checks the options that need no input: the faces and the largest orders.
///
/// # Errors
/// `--faces` out of range; `--max-order` or `--blind-max-order` above
/// `gonio_calib::selfcal::MAX_ORDER`.
pub fn check(faces: usize, max_order: u32, blind_max_order: Option<u32>) -> Result<()> {
    readings::check_faces(faces)?;
    super::selfcal::check_max_order("--max-order", max_order)?;
    if let Some(k) = blind_max_order {
        super::selfcal::check_max_order("--blind-max-order", k)?;
    }
    Ok(())
}

/// The certificate (`gonio.certificate/1`), checked finite.
///
/// # Errors
/// As [`check`]; an input that cannot be read or is malformed; data the estimator refuses,
/// told as the input it concerns; a result that is not finite.
pub fn evaluate(inputs: &Inputs, r: Request) -> Result<Certificate> {
    check(r.faces, r.max_order, r.blind_max_order)?;
    let instrument = instrument::from_document(inputs, r.instrument.as_ref(), r.coverage)?;
    let meta = r
        .meta
        .as_ref()
        .map(|m| m.parse(inputs, meta::parse))
        .transpose()?;
    let opts = JointOptions {
        sigma_polygon_arcsec: r.sigma_polygon_arcsec,
        sigma_heads_arcsec: r.sigma_heads_arcsec,
        noise_model: r.noise_model,
        head_angles: r.head_angles,
        interpolation: r.interpolation,
        max_order: r.max_order,
        blind_max_order: r.blind_max_order,
        coverage: instrument.terms.coverage,
    };
    let (poly_name, heads_name) = (r.readings.name(), r.heads_readings.name());
    let set = match r.readings {
        Table::File(p) => readings::read(inputs, &p, Some(r.faces))?,
        Table::Given(t) => readings::from_table(&t, Some(r.faces))?,
    };
    let table = r.heads_readings.read(inputs)?;
    let rt = read_turns(&table, &r.heads, r.raw)?;
    let cal = calibrate(&set, &r.heads, &rt.turns, &opts).map_err(|e| match e {
        JointError::Heads(h) => locate(h, &table, &rt.lines),
        JointError::Polygon(p) => anyhow!("{poly_name}: {p}"),
        e @ JointError::OffGrid { .. } => anyhow!("{poly_name} and {heads_name}: {e}"),
        e => anyhow!("{e}"),
    })?;
    let cert = Certificate::from_joint(&cal, &instrument)?;
    super::finish(cert, meta, &poly_name)
}
