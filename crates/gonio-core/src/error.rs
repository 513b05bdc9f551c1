//! The error kinds shared by gonio's numerical code.

use thiserror::Error;

/// An error from a core numerical routine.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum CoreError {
    /// Too few data points for the number of unknowns.
    #[error("too few points: {found} given, at least {expected} needed")]
    TooFewPoints {
        /// Points needed.
        expected: usize,
        /// Points given.
        found: usize,
    },
    /// The normal matrix is singular: some unknowns are not determined by the data.
    #[error("the fit is singular: {what} not determined by the data")]
    Singular {
        /// Which unknowns are not determined.
        what: String,
    },
    /// An input value is not finite.
    #[error("value {index} is not finite ({value})")]
    NotFinite {
        /// Position of the value.
        index: usize,
        /// The value.
        value: f64,
    },
    /// An argument is out of its valid range.
    #[error("{name} = {value} is out of range: expected {expected}")]
    OutOfRange {
        /// The argument's name.
        name: &'static str,
        /// The value given.
        value: f64,
        /// What was expected.
        expected: &'static str,
    },
}
