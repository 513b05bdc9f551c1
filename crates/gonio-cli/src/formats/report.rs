//! Inputs of `gonio report`: certificates, comparisons and mounting batches, told apart by their
//! `format` tag (a mounting batch from `gonio mount --json` has none: it is known by its `parts`
//! and `summary`).

use super::json_error;
use anyhow::{Result, anyhow};
use gonio_calib::certificate::{CERTIFICATE_FORMAT, Certificate};
use gonio_calib::compare::{COMPARE_FORMAT, Comparison};
use gonio_report::batch::BatchView;
use serde::Deserialize;
use std::path::Path;

/// One input of a report.
#[derive(Debug)]
pub enum ReportInput {
    /// A calibration certificate.
    Certificate(Box<Certificate>),
    /// A comparison of two certificates (`gonio compare --json`).
    Comparison(Box<Comparison>),
    /// A mounting batch (`gonio mount --json`).
    Batch(Box<BatchView>),
}

#[derive(Deserialize)]
struct Shape {
    #[serde(default)]
    format: Option<String>,
    #[serde(default)]
    parts: Option<serde::de::IgnoredAny>,
    #[serde(default)]
    summary: Option<serde::de::IgnoredAny>,
}

/// Reads one input; errors name the file, line and column.
pub fn load(path: &Path) -> Result<ReportInput> {
    let text = crate::io::read_text(path)?;
    let expected = "expected a certificate (gonio shift-angle/selfcal --json), a comparison (gonio compare --json) or a mounting batch (gonio mount --json)";
    let shape: Shape = serde_json::from_str(&text).map_err(|e| json_error(path, &e, expected))?;
    match shape.format.as_deref() {
        Some(CERTIFICATE_FORMAT) => Ok(ReportInput::Certificate(Box::new(
            super::certificate::parse(path, &text)?,
        ))),
        Some(COMPARE_FORMAT) => Ok(ReportInput::Comparison(Box::new(
            serde_json::from_str(&text).map_err(|e| json_error(path, &e, "a comparison"))?,
        ))),
        None if shape.parts.is_some() && shape.summary.is_some() => {
            Ok(ReportInput::Batch(Box::new(
                serde_json::from_str(&text)
                    .map_err(|e| json_error(path, &e, "a mounting batch"))?,
            )))
        }
        Some(other) => Err(anyhow!(
            "{}:1:1: format {other:?}: {expected}",
            path.display()
        )),
        None => Err(anyhow!("{}:1:1: no format tag: {expected}", path.display())),
    }
}
