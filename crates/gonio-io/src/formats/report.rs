//! Inputs of `gonio report`: certificates, comparisons, rotary axes tested to ISO 230-2 and
//! mounting batches, told apart by their `format` tag (a mounting batch from `gonio mount --json` has none: it is known by its `parts`
//! and `summary`).

use super::json_error;
use anyhow::{Result, anyhow};
use gonio_calib::axis::{AXIS_FORMAT, AxisResult};
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
    /// A rotary axis tested to ISO 230-2 (`gonio axis --json`).
    Axis(Box<AxisResult>),
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
///
/// # Errors
/// As [`parse`], and the file cannot be read.
pub fn load(inputs: &crate::input::Inputs, path: &Path) -> Result<ReportInput> {
    inputs.load(path, parse)
}

/// Parses one input; `name` names it in errors.
///
/// # Errors
/// Not JSON, or none of the three kinds (located).
pub fn parse(name: &str, text: &str) -> Result<ReportInput> {
    let path = name;
    let expected = "expected a certificate (gonio shift-angle/selfcal --json), a comparison (gonio compare --json), an axis (gonio axis --json) or a mounting batch (gonio mount --json)";
    let shape: Shape = serde_json::from_str(text).map_err(|e| json_error(path, &e, expected))?;
    match shape.format.as_deref() {
        Some(CERTIFICATE_FORMAT) => Ok(ReportInput::Certificate(Box::new(
            super::certificate::parse(path, text)?,
        ))),
        Some(COMPARE_FORMAT) => Ok(ReportInput::Comparison(Box::new(
            serde_json::from_str(text).map_err(|e| json_error(path, &e, "a comparison"))?,
        ))),
        Some(AXIS_FORMAT) => Ok(ReportInput::Axis(Box::new(
            serde_json::from_str(text)
                .map_err(|e| json_error(path, &e, "an axis evaluated by gonio axis --json"))?,
        ))),
        None if shape.parts.is_some() && shape.summary.is_some() => {
            Ok(ReportInput::Batch(Box::new(
                serde_json::from_str(text).map_err(|e| json_error(path, &e, "a mounting batch"))?,
            )))
        }
        Some(other) => Err(anyhow!(
            "{path}:1:1: format {:?}: {expected}",
            gonio_core::text::short(other)
        )),
        None => Err(anyhow!("{path}:1:1: no format tag: {expected}")),
    }
}

/// Builds one report from its inputs (named as given), in order; `meta` replaces every
/// certificate's metadata.
///
/// # Errors
/// No input, or an input the report cannot draw.
pub fn build(
    inputs: Vec<(String, ReportInput)>,
    meta: Option<&gonio_calib::certificate::CertificateMeta>,
    title: Option<&str>,
) -> Result<gonio_report::html::Report> {
    use anyhow::Context;
    let default_title = match inputs.first() {
        Some((_, ReportInput::Certificate(c))) => c
            .meta
            .as_ref()
            .and_then(|m| m.title.clone())
            .unwrap_or_else(|| "Calibration certificate".into()),
        Some((_, ReportInput::Comparison(_))) => "Comparison of calibrations".into(),
        Some((_, ReportInput::Batch(_))) => "Mounting batch".into(),
        Some((_, ReportInput::Axis(_))) => "Rotary axis to ISO 230-2".into(),
        None => anyhow::bail!("no input files"),
    };
    let mut report = gonio_report::html::Report::new(title.unwrap_or(&default_title));
    for (name, input) in inputs {
        match input {
            ReportInput::Certificate(c) => {
                let c = match meta {
                    Some(m) => c.with_meta(m.clone()),
                    None => *c,
                };
                report.add_certificate(&c, &name)
            }
            ReportInput::Comparison(c) => report.add_comparison(&c, &name),
            ReportInput::Batch(b) => report.add_batch(&b, &name),
            ReportInput::Axis(a) => report.add_axis(&a, &name),
        }
        .with_context(|| format!("{name}: drawing the report"))?;
    }
    Ok(report)
}
