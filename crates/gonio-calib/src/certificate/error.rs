//! Errors of certificate building.

use thiserror::Error;

/// An error from building a [`super::Certificate`].
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum CertificateError {
    /// The calibration has no calibrated angle.
    #[error("the calibration has no calibrated angle")]
    Empty,
    /// The instrument terms cannot be combined with the random part (an invalid u, ν or p).
    #[error("instrument terms: {source}")]
    Uncertainty {
        /// The budget error.
        #[source]
        source: gonio_uncertainty::UncertaintyError,
    },
    /// A certificate (or its metadata) read from a file holds a value no calibration gives, or
    /// text that a certificate cannot carry.
    #[error("{field}: {what}")]
    Invalid {
        /// The field, by its JSON name (`encoder_errors[3].U_arcsec`, `meta.customer.name`).
        field: String,
        /// What is wrong and what was expected.
        what: String,
    },
    /// A coverage probability outside (0, 1).
    #[error(
        "coverage probability {coverage}: expected a value strictly between 0 and 1, e.g. 0.95"
    )]
    BadCoverage {
        /// The value given.
        coverage: f64,
    },
}

impl From<gonio_uncertainty::UncertaintyError> for CertificateError {
    fn from(source: gonio_uncertainty::UncertaintyError) -> Self {
        CertificateError::Uncertainty { source }
    }
}
