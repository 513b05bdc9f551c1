//! Encoder error model files (JSON, from `gonio simulate encoder`).

use anyhow::{Result, anyhow};
use gonio_sim::{EncoderModel, SimError};
use std::path::Path;

/// Loads an encoder model file, with the file name in errors.
///
/// # Errors
/// As [`parse`], and the file cannot be read.
pub fn load(inputs: &crate::input::Inputs, path: &Path) -> Result<EncoderModel> {
    inputs.load(path, parse)
}

/// Parses an encoder model; `name` names it in errors.
///
/// # Errors
/// Not a model (located), or values out of range (too many lines or harmonics, non-finite
/// amplitudes).
pub fn parse(name: &str, text: &str) -> Result<EncoderModel> {
    EncoderModel::from_json(text).map_err(|e| match e {
        SimError::ModelFormat {
            line,
            column,
            message,
        } => super::located(name, line, column, &message),
        other => anyhow!("{name}: {other}"),
    })
}
