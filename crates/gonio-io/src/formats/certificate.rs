//! Certificate files (`gonio.certificate/1` JSON, written by `shift-angle --json`,
//! `selfcal --json` and `joint --json`).

use super::json_error;
use anyhow::Result;
use gonio_calib::certificate::Certificate;
use std::path::Path;

/// Reads a certificate; errors name the file, line and column.
///
/// # Errors
/// As [`parse`], and the file cannot be read.
pub fn load(inputs: &crate::input::Inputs, path: &Path) -> Result<Certificate> {
    inputs.load(path, parse)
}

/// Parses certificate JSON; `name` names it in errors.
///
/// # Errors
/// Not a certificate (located).
pub fn parse(name: &str, text: &str) -> Result<Certificate> {
    serde_json::from_str(text).map_err(|e| {
        json_error(
            name,
            &e,
            "expected a gonio.certificate/1 JSON from `gonio shift-angle --json` or `gonio selfcal --json`",
        )
    })
}
