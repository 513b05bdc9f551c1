//! Two calibrations of one encoder compared at their common angles (differences, En):
//! `gonio compare --json` and `gonio.compare` in Python, from one code path. Each side is a
//! certificate (a file, or the text of one: a Python dict) or a simulator's `truth.json`.
//!
//! Errors are one line naming the file (`a.json:3:7: …`), or saying why the two cannot be
//! compared (no common angle).
//!
//! ```
//! use gonio_io::formats::source::Document;
//! use gonio_io::input::Inputs;
//! let truth = r#"{"format": "gonio-selfcal-truth", "errors": [
//!     {"position_deg": 0, "value_arcsec": 0.5}, {"position_deg": 90, "value_arcsec": -0.5}]}"#;
//! let doc = |n: &str| Document::Given { name: n.into(), text: truth.into() };
//! let c = gonio_io::results::compare::evaluate(&Inputs::new(), &doc("<a>"), &doc("<b>")).unwrap();
//! assert_eq!(c.points.len(), 2);
//! assert_eq!(c.max_abs_difference_arcsec, 0.0);
//! ```

use crate::formats::curve;
use crate::formats::source::Document;
use crate::input::Inputs;
use anyhow::{Result, anyhow};
use gonio_calib::compare::{Comparison, compare};

/// The comparison of `a` and `b`.
///
/// # Errors
/// A side that cannot be read or is neither a certificate nor a truth file (located); two
/// curves without a common angle.
pub fn evaluate(inputs: &Inputs, a: &Document, b: &Document) -> Result<Comparison> {
    let a = a.parse(inputs, curve::parse)?;
    let b = b.parse(inputs, curve::parse)?;
    compare(&a, &b).map_err(|e| anyhow!("{e}"))
}
