//! Station recipes (TOML): the settings of one grating type, range-checked by
//! `gonio_station::Recipe::from_toml` with the key and its line.

use anyhow::{Result, anyhow};
use gonio_station::{Recipe, StationError};
use std::path::Path;

/// Reads a recipe file; errors name the file, line and column.
///
/// # Errors
/// As [`parse`], and the file cannot be read.
pub fn load(inputs: &crate::input::Inputs, path: &Path) -> Result<Recipe> {
    inputs.load(path, parse)
}

/// Parses recipe text; `name` names it in errors. A value out of range that the file does not
/// set (a default that no longer fits another value) is named as such, never at line 0.
///
/// # Errors
/// Syntax, unknown keys, wrong types, values out of range.
pub fn parse(name: &str, text: &str) -> Result<Recipe> {
    Recipe::from_toml(text).map_err(|e| match e {
        StationError::Recipe {
            line,
            column,
            message,
        } => super::located(name, line, column, &message),
        StationError::RecipeValue {
            key,
            value,
            expected,
            line,
            column,
        } if line > 0 => anyhow!("{name}:{line}:{column}: {key} = {value}: expected {expected}"),
        StationError::RecipeValue {
            key,
            value,
            expected,
            ..
        } => anyhow!(
            "{name}: {key} = {value} (the default: the file does not set it): expected {expected}"
        ),
        other => anyhow!("{name}: {other}"),
    })
}
