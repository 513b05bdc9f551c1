//! The errors of the station: bad fit input, recipes, and device failures.

use crate::hal::DeviceErrorKind;
use thiserror::Error;

/// An error from the eccentricity fit, a recipe, or the mounting controller.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum StationError {
    /// Too few samples for the fit.
    #[error("too few samples: {found} given, at least {expected} needed")]
    TooFewSamples {
        /// Samples needed.
        expected: usize,
        /// Samples given.
        found: usize,
    },
    /// A value is NaN or infinite.
    #[error("sample {index}: {what} is not finite ({value})")]
    NotFinite {
        /// 0-based index of the sample.
        index: usize,
        /// Which value (`theta_deg`, `c_px`, `t_s`).
        what: &'static str,
        /// The value.
        value: f64,
    },
    /// Angles must increase strictly within a turn.
    #[error("sample {index}: angle {found_deg}° does not increase (previous {previous_deg}°)")]
    NotIncreasing {
        /// 0-based index of the offending sample.
        index: usize,
        /// The previous sample's angle.
        previous_deg: f64,
        /// This sample's angle.
        found_deg: f64,
    },
    /// The samples do not determine the fit (e.g. all at one angle).
    #[error("the fit is singular: {what}")]
    Singular {
        /// What is not determined.
        what: String,
    },
    /// A parameter is out of its valid range.
    #[error("{name} = {value}: expected {expected}")]
    OutOfRange {
        /// The parameter's name.
        name: &'static str,
        /// The value given.
        value: f64,
        /// What is allowed.
        expected: &'static str,
    },
    /// A time is outside the servo's angle log.
    #[error("time {t_s} s is outside the servo angle log ({first_s} s to {last_s} s)")]
    OutsideAngleLog {
        /// The time asked for.
        t_s: f64,
        /// First logged time.
        first_s: f64,
        /// Last logged time.
        last_s: f64,
    },
    /// A recipe file is not valid.
    #[error("line {line}, column {column}: {message}")]
    Recipe {
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What was wrong and what was expected.
        message: String,
    },
    /// A recipe value is outside its allowed range (or inconsistent with another value).
    #[error("{}", setting_message(*line, *column, key, value, expected))]
    RecipeValue {
        /// The key, with its section (`fit.huber_k`, `push.max_push_um`).
        key: String,
        /// The value given, as written.
        value: String,
        /// What is allowed.
        expected: String,
        /// 1-based line of the key in the recipe file (0 when not read from a file).
        line: usize,
        /// 1-based column of the key (0 when not read from a file).
        column: usize,
    },
    /// A device reported an error; the part is aborted.
    #[error("{device}: {kind:?} error: {message}")]
    Device {
        /// Which device (`servo`, `camera`, `focus drive`, `push rod`, `clock`).
        device: &'static str,
        /// The error's kind.
        kind: DeviceErrorKind,
        /// The device's message.
        message: String,
    },
}

fn setting_message(line: usize, column: usize, key: &str, value: &str, expected: &str) -> String {
    if line > 0 {
        format!("line {line}, column {column}: {key} = {value}: expected {expected}")
    } else {
        format!("{key} = {value}: expected {expected}")
    }
}
