//! File formats the commands read, each with errors that name the file, line and column. Every
//! parser takes text (or bytes) and a name, so that it can be tested and fuzzed without files
//! (`fuzz/`); the `load`/`read` functions add the file reading.

pub mod angles;
pub mod axis;
pub mod certificate;
pub mod compensation;
pub mod csv;
pub mod curve;
pub mod encoder;
pub mod frames;
pub mod heads;
pub mod instrument;
pub mod meta;
pub mod readings;
pub mod recipe;
pub mod replay;
pub mod report;
pub mod samples;
pub mod source;

use anyhow::{Result, anyhow};
use std::path::Path;

pub use gonio_core::text::line_col;

/// A TOML error as `NAME:LINE:COL: message` (the one TOML location helper).
pub fn toml_error(name: &str, text: &str, e: &toml::de::Error) -> anyhow::Error {
    let (l, c) = e.span().map_or((1, 1), |s| line_col(text, s.start));
    anyhow!(
        "{name}:{l}:{c}: {}",
        crate::input::cap(&e.message().trim_end().replace('\n', " "))
    )
}

/// Parses TOML text into `T`; errors read `NAME:LINE:COL: what was wrong`.
///
/// # Errors
/// Syntax, unknown keys and wrong types, located.
pub fn parse_toml<T: serde::de::DeserializeOwned>(name: &str, text: &str) -> Result<T> {
    toml::from_str(text).map_err(|e| toml_error(name, text, &e))
}

/// Reads a TOML file (or `-`) into `T`; errors name the file, line and column.
///
/// # Errors
/// As [`crate::input::Inputs::read_text`] and [`parse_toml`].
pub fn read_toml<T: serde::de::DeserializeOwned>(
    inputs: &crate::input::Inputs,
    path: &Path,
) -> Result<T> {
    let text = inputs.read_text(path)?;
    parse_toml(&path.display().to_string(), &text)
}

/// An error a library located in a file (`line`, `column` 1-based; 0 when unknown, shown as 1)
/// as `NAME:LINE:COL: message`, the message capped.
pub fn located(name: &str, line: usize, column: usize, message: &str) -> anyhow::Error {
    anyhow!(
        "{name}:{}:{}: {}",
        line.max(1),
        column.max(1),
        crate::input::cap(message)
    )
}

/// A JSON error as `NAME:LINE:COL: message (what was expected)`.
pub fn json_error(name: &str, e: &serde_json::Error, expected: &str) -> anyhow::Error {
    if e.line() == 0 {
        // A value checked after it was read (a certificate's U < 0): the message names the
        // field; there is no line to give.
        return anyhow!("{name}: {}", crate::input::cap(&e.to_string()));
    }
    anyhow!(
        "{name}:{}:{}: {} ({expected})",
        e.line().max(1),
        e.column().max(1),
        crate::input::cap(strip_position(&e.to_string()))
    )
}

/// serde_json appends " at line L column C" to its messages: the prefix already says where.
fn strip_position(msg: &str) -> &str {
    match msg.rfind(" at line ") {
        Some(i) => &msg[..i],
        None => msg,
    }
}

/// 1-based line and column of a dotted key (`fit.huber_k`) in a TOML text, if the text sets it.
pub use gonio_station::recipe::key_position;
