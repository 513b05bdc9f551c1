//! Certificate files (`gonio.certificate/1` JSON, written by `shift-angle --json` and
//! `selfcal --json`).

use super::json_error;
use anyhow::Result;
use gonio_calib::certificate::Certificate;
use std::path::Path;

/// Reads a certificate; errors name the file, line and column.
pub fn load(path: &Path) -> Result<Certificate> {
    let text = crate::io::read_text(path)?;
    parse(path, &text)
}

/// Parses certificate JSON; `path` names it in errors.
pub fn parse(path: &Path, text: &str) -> Result<Certificate> {
    serde_json::from_str(text).map_err(|e| {
        json_error(
            path,
            &e,
            "expected a gonio.certificate/1 JSON from `gonio shift-angle --json` or `gonio selfcal --json`",
        )
    })
}
