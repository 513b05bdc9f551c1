//! A curve to compare (`gonio compare`): a certificate, or a simulator's truth.json.

use super::json_error;
use anyhow::Result;
use gonio_calib::compare::{Curve, CurvePoint};
use serde::Deserialize;
use std::path::Path;

/// A simulator's truth file (`gonio-selfcal-truth`): the true error at every position.
#[derive(Debug, Deserialize)]
struct Truth {
    errors: Vec<TruthPoint>,
}

#[derive(Debug, Deserialize)]
struct TruthPoint {
    position_deg: f64,
    value_arcsec: f64,
}

/// The format tag of a JSON file, if it has one.
#[derive(Debug, Deserialize)]
struct Tagged {
    #[serde(default)]
    format: Option<String>,
}

/// Reads a certificate (or a simulator's truth) into a [`Curve`].
///
/// # Errors
/// As [`parse`], and the file cannot be read.
pub fn load(inputs: &crate::input::Inputs, path: &Path) -> Result<Curve> {
    inputs.load(path, parse)
}

/// Parses a certificate or a truth file; `name` names it in errors and in the curve's label.
///
/// # Errors
/// Not JSON, or neither kind of file (located).
pub fn parse(name: &str, text: &str) -> Result<Curve> {
    let tag: Tagged = serde_json::from_str(text)
        .map_err(|e| json_error(name, &e, "expected a gonio certificate JSON"))?;
    if tag.format.as_deref() == Some("gonio-selfcal-truth") {
        let t: Truth = serde_json::from_str(text)
            .map_err(|e| json_error(name, &e, "expected a simulator's truth.json"))?;
        return Ok(Curve {
            label: format!("{name} (truth)"),
            points: t
                .errors
                .into_iter()
                .map(|p| CurvePoint {
                    angle_deg: p.position_deg,
                    value_arcsec: p.value_arcsec,
                    u_arcsec: 0.0,
                    expanded_arcsec: None,
                })
                .collect(),
            undetectable_orders: Vec::new(),
        });
    }
    let cert = super::certificate::parse(name, text)?;
    let mut curve = Curve::from(&cert);
    curve.label = format!("{name} ({})", cert.method);
    Ok(curve)
}
