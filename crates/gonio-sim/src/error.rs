//! Errors of the simulators.

use thiserror::Error;

/// An error from a simulator or a model file.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum SimError {
    /// A model file is not valid JSON of the expected shape.
    #[error("line {line}, column {column}: {message}")]
    ModelFormat {
        /// 1-based line of the problem.
        line: usize,
        /// 1-based column of the problem.
        column: usize,
        /// What was wrong and what was expected.
        message: String,
    },
    /// A parameter is out of its valid range.
    #[error("{name} = {found}: expected {expected}")]
    Parameter {
        /// The parameter's name (as in the model file or CLI flag).
        name: String,
        /// The value given.
        found: String,
        /// What is allowed.
        expected: String,
    },
}

impl SimError {
    /// Shorthand for [`SimError::Parameter`] (a number found is written the short way:
    /// `1e300`, not three hundred digits).
    pub fn parameter(name: &str, found: impl ToString, expected: &str) -> Self {
        SimError::Parameter {
            name: name.to_string(),
            found: gonio_core::bound::tidy(&found.to_string()),
            expected: expected.to_string(),
        }
    }
}
