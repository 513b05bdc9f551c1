//! The certificate of the shift-angle method (Hsieh et al., 2022): `gonio shift-angle --json`
//! and `gonio.shift_angle` in Python, from one code path: the readings read and checked, the
//! estimator run, the instrument terms and the metadata added, the result checked finite.
//!
//! Errors are one line naming the input (`readings.csv:3:2: column 'start_face': …`) or the
//! flag (`--coverage 1.5: …`), as the command line prints them.
//!
//! ```
//! use gonio_io::formats::{csv::CsvTable, source::Table};
//! use gonio_io::input::Inputs;
//! use gonio_io::results::shift_angle::{Request, evaluate};
//! let mut csv = String::from("shift_deg,start_face,step,reading_arcsec\n");
//! for s in 1..=4 {
//!     for k in 1..=4 {
//!         csv.push_str(&format!("0,{s},{k},{}\n", 0.1 * ((s * k) % 3) as f64));
//!     }
//! }
//! let table = CsvTable::parse("r.csv", &csv).unwrap();
//! let cert = evaluate(&Inputs::new(), Request::new(Table::Given(table))).unwrap();
//! assert_eq!(cert.points.len(), 4);
//! ```

use crate::formats::source::{Document, Table};
use crate::formats::{instrument, meta, readings};
use crate::input::Inputs;
use anyhow::{Result, anyhow};
use gonio_calib::certificate::Certificate;
use gonio_calib::shift_angle::{Method, Options, calibrate};

/// What a shift-angle calibration reads and how it runs (the flags of `gonio shift-angle`).
#[derive(Debug)]
pub struct Request {
    /// The readings (`shift_deg,start_face,step,reading_arcsec[,repeat]`).
    pub readings: Table,
    /// Polygon faces N (`--faces`; default: the largest face or step number).
    pub faces: Option<usize>,
    /// The estimator (`--method`).
    pub method: Method,
    /// σ of one reading, arcsec, if known (`--sigma`).
    pub sigma_arcsec: Option<f64>,
    /// Harmonic order of the setup-error check (`--check-order`, Hsieh et al., 2022, §3.1: 2).
    pub check_order: u32,
    /// Instrument terms (`--instrument`).
    pub instrument: Option<Document>,
    /// Coverage probability of U (`--coverage`; default: the instrument file's, else 0.95).
    pub coverage: Option<f64>,
    /// ISO/IEC 17025 metadata (`--meta`).
    pub meta: Option<Document>,
}

impl Request {
    /// The readings with every option at the command line's default.
    pub fn new(readings: Table) -> Request {
        Request {
            readings,
            faces: None,
            method: Method::default(),
            sigma_arcsec: None,
            check_order: 2,
            instrument: None,
            coverage: None,
            meta: None,
        }
    }
}

/// The certificate (`gonio.certificate/1`), checked finite.
///
/// # Errors
/// An input that cannot be read or is malformed, readings the estimator cannot solve (naming
/// the readings), a result that is not finite (naming the field and the readings).
pub fn evaluate(inputs: &Inputs, r: Request) -> Result<Certificate> {
    let instrument = instrument::from_document(inputs, r.instrument.as_ref(), r.coverage)?;
    let meta = r
        .meta
        .as_ref()
        .map(|m| m.parse(inputs, meta::parse))
        .transpose()?;
    let name = r.readings.name();
    let set = match r.readings {
        Table::File(p) => readings::read(inputs, &p, r.faces)?,
        Table::Given(t) => readings::from_table(&t, r.faces)?,
    };
    let opts = Options {
        method: r.method,
        sigma_arcsec: r.sigma_arcsec,
        ..Options::default()
    };
    let cal = calibrate(&set, &opts).map_err(|e| anyhow!("{name}: {e}"))?;
    let cert = Certificate::from_shift_angle(
        &cal,
        &set,
        r.sigma_arcsec.is_some(),
        r.check_order,
        &instrument,
    )?;
    super::finish(cert, meta, &name)
}
