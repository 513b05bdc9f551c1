//! Rotary axes to ISO 230-2:2014 (accuracy and repeatability of positioning of numerically
//! controlled axes): the same polygon and autocollimator that calibrate an encoder test a rotary
//! table or a machine's rotary axis.
//!
//! n runs approach each of m targets from each direction; x_ij is the position reached less
//! the target (arcseconds). Per target the means x̄↑, x̄↓ and sample standard deviations s↑, s↓
//! (n − 1) give the reversal value B_i = x̄↑ − x̄↓ and the repeatabilities R_i↑ = 4s↑,
//! R_i = max(2s↑ + 2s↓ + |B_i|, R_i↑, R_i↓); over the axis:
//!
//! | parameter | definition |
//! |---|---|
//! | B, B̄ | max \|B_i\|, mean of B_i |
//! | R↑, R↓, R | max of R_i↑, R_i↓, R_i |
//! | E↑ (E↓) | max x̄↑ − min x̄↑ |
//! | E | max over both directions of x̄ − min over both of x̄ |
//! | M | max x̄_i − min x̄_i, x̄_i = (x̄_i↑ + x̄_i↓)/2 |
//! | A↑ (A↓) | max(x̄↑ + 2s↑) − min(x̄↑ − 2s↑) |
//! | A | max over both of (x̄ + 2s) − min over both of (x̄ − 2s) |
//!
//! - [`evaluate`] ([`parameters`](self::Parameters)): readings → every target's statistics
//!   and the parameters; a unidirectional test leaves the bidirectional ones `None`.
//! - [`Polygon`]: autocollimator readings corrected by the polygon's calibration.
//! - [`AxisResult`]: the document of `gonio axis`, with the uncertainty beside the parameters
//!   (the reference's GUM budget and its propagation) and the compensation table.
//!
//! Errors are [`AxisError`]s naming the reading (its index) or the target. See
//! `docs/iso230-2.md`.
//!
//! ```
//! use gonio_calib::axis::{AxisInput, AxisReading, Direction, analyse};
//! use gonio_calib::certificate::Instrument;
//! let mut r = Vec::new();
//! for (k, t) in [0.0, 120.0, 240.0].into_iter().enumerate() {
//!     for run in 1..=5u32 {
//!         let x = k as f64 + 0.1 * f64::from(run);
//!         r.push(AxisReading { target_deg: t, direction: Direction::Up, run, deviation_arcsec: x + 1.0 });
//!         r.push(AxisReading { target_deg: t, direction: Direction::Down, run, deviation_arcsec: x });
//!     }
//! }
//! let doc = analyse(&AxisInput::Deviations(r), &Instrument::default()).unwrap();
//! assert_eq!(doc.standard, "ISO 230-2:2014");
//! assert!((doc.parameters.b.unwrap() - 1.0).abs() < 1e-12);
//! assert!((doc.parameters.m.unwrap() - 2.0).abs() < 1e-12);
//! ```

mod compensation;
mod data;
mod error;
mod parameters;
mod polygon;
mod result;
mod uncertainty;

pub use compensation::{AxisCompensation, compensation};
pub use data::{
    AxisReading, Direction, MAX_DEVIATION_ARCSEC, MAX_RUNS, MAX_TARGET_DEG, MAX_TARGETS, TargetKey,
};
pub use error::AxisError;
pub use parameters::{
    Approach, Cell, Evaluation, Parameters, STANDARD_RUNS, TargetStats, evaluate, runs_text,
};
pub use polygon::{FaceReading, MAX_PITCH_DEVIATION_ARCSEC, Polygon};
pub use result::{
    AXIS_FORMAT, AxisResult, AxisTarget, AxisUncertainty, COMPENSATION_NOTE, PolygonSection,
    ReferenceSection,
};
pub use uncertainty::{PARAMETER_K, ReferenceBudget, parameter_uncertainty, reference_budget};

use crate::certificate::Instrument;
use std::collections::HashMap;

/// The standard and its edition.
pub const STANDARD: &str = "ISO 230-2:2014";

/// The standard's title.
pub const STANDARD_TITLE: &str = "Test code for machine tools — Part 2: Determination of accuracy and repeatability of positioning of numerically controlled axes";

/// What `gonio axis` evaluates.
#[derive(Debug, Clone, PartialEq)]
pub enum AxisInput {
    /// Deviations x_ij as measured (a reference that reads them directly).
    Deviations(Vec<AxisReading>),
    /// An autocollimator's readings of a polygon on the axis, and the polygon's calibration.
    Readings {
        /// The readings.
        rows: Vec<FaceReading>,
        /// The polygon.
        polygon: Polygon,
    },
}

/// Evaluates a test into the document of `gonio axis`, the reference's terms from `instrument`.
///
/// # Errors
/// [`AxisError`]s of the polygon's correction ([`Polygon::correct`]), of [`evaluate`] and of the
/// reference's budget; reading indices are the input's.
pub fn analyse(input: &AxisInput, instrument: &Instrument) -> Result<AxisResult, AxisError> {
    match input {
        AxisInput::Deviations(r) => AxisResult::new(&evaluate(r)?, &[], None, instrument),
        AxisInput::Readings { rows, polygon } => {
            let corrected = polygon.correct(rows)?;
            let readings: Vec<AxisReading> = corrected.iter().map(|(r, _)| *r).collect();
            let eval = evaluate(&readings)?;
            let mut face_of: HashMap<TargetKey, usize> = HashMap::new();
            for (r, f) in &corrected {
                face_of.entry(TargetKey::of(r.target_deg)).or_insert(*f);
            }
            let faces: Vec<Option<usize>> = eval
                .targets
                .iter()
                .map(|t| face_of.get(&TargetKey::of(t.target_deg)).copied())
                .collect();
            AxisResult::new(&eval, &faces, Some(polygon), instrument)
        }
    }
}
